//! Navigation-core benchmarks: strapdown mechanization throughput (IMU samples
//! per second on one core), truth generation with inverse strapdown, and a
//! whole `simulate` of the 3.6 h / 300 km route at 100 Hz.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use waymark::nav::{ImuIncrement, Strapdown};
use waymark::sensors::{rng::stream, Imu, ImuModel};
use waymark::sim::{simulate, Scenario, TruthSource};
use waymark::trajectory::{ideal_imu, Extent, Motion, MotionPlan, Start};

fn plan() -> MotionPlan {
    let start = Start {
        lat: 30f64.to_radians(),
        lon: 117f64.to_radians(),
        h: 0.0,
        heading: 0.3,
        pitch: 0.0,
        roll: 0.0,
        speed_mps: 0.0,
    };
    let mut cmds = vec![Motion::ChangeSpeed {
        to_mps: 15.0,
        accel_mps2: 1.0,
        decelerate: false,
    }];
    for _ in 0..20 {
        cmds.push(Motion::Cruise {
            extent: Extent::Duration(40.0),
        });
        cmds.push(Motion::Turn {
            angle: 1.0,
            radius_m: 100.0,
        });
    }
    MotionPlan::new(start, &cmds, 0.01).unwrap()
}

fn mechanization(c: &mut Criterion) {
    let p = plan();
    let model = ImuModel {
        gyro_bias: [1e-7; 3],
        accel_bias: [1e-3; 3],
        gyro_arw: 1e-6,
        accel_vrw: 1e-4,
        ..Default::default()
    };
    let mut imu = Imu::new(&model, 0.01, stream(1, 0, 1));
    let truth: Vec<_> = ideal_imu(p.trajectory(), 0.01).collect();
    let incs: Vec<ImuIncrement> = truth.iter().skip(1).map(|s| imu.measure(&s.imu)).collect();
    let start = truth[0].avp.state;
    let mut g = c.benchmark_group("mechanization");
    g.throughput(Throughput::Elements(incs.len() as u64));
    g.bench_function("strapdown_step", |b| {
        b.iter(|| {
            let mut nav = Strapdown::new(start, 0.01);
            for inc in &incs {
                nav.step(inc);
            }
            black_box(nav.state)
        })
    });
    g.bench_function("truth_and_inverse_strapdown", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for s in ideal_imu(p.trajectory(), 0.01) {
                acc += s.imu.dv[1];
            }
            black_box(acc)
        })
    });
    g.finish();
}

fn simulate_300km(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/rfid-paper-sins-od.toml");
    let scn = Scenario::load(&path).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let samples = (truth.duration_s() / scn.dt) as u64;
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    g.throughput(Throughput::Elements(samples));
    g.bench_function("route_3.6h_300km_100Hz_dead_reckoning", |b| {
        b.iter(|| {
            black_box(
                simulate(&scn, &truth, 1, 1)
                    .unwrap()
                    .summary
                    .max_horizontal_error_m,
            )
        })
    });
    g.finish();
}

fn simulate_300km_filter(c: &mut Criterion) {
    // The full filter: 21 states, 100 Hz IMU, 10 Hz odometer + constraints,
    // 10 Hz baro, four tag fixes; one run on one thread.
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/rfid-paper-integrated-tags.toml");
    let scn = Scenario::load(&path).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let samples = (truth.duration_s() / scn.dt) as u64;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    g.throughput(Throughput::Elements(samples));
    g.bench_function("route_3.6h_300km_100Hz_integrated_filter", |b| {
        b.iter(|| {
            pool.install(|| {
                black_box(
                    simulate(&scn, &truth, 1, 1)
                        .unwrap()
                        .summary
                        .max_horizontal_error_m,
                )
            })
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    mechanization,
    simulate_300km,
    simulate_300km_filter
);
criterion_main!(benches);
