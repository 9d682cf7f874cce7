//! The simulation pipeline through the library API: perfect sensors give no
//! error whatever the navigator, rotation modulation is undone exactly for the
//! odometer, the baro loop holds the vertical channel, and an odometer failure
//! hands over to the inertial navigator without a jump.

use std::path::Path;
use waymark::sim::{simulate, Scenario, TruthSource};

const ROUTE: &str = r#"
[[route]]
start = { lat = 52.0, lon = 5.0, height_m = 10.0, heading_deg = 200.0 }
motion = [ { kind = "accelerate", to_kmh = 50, accel_mps2 = 1.5 },
           { kind = "turn", angle_deg = 90, radius_m = 50 },
           { kind = "climb", grade_percent = 6, distance_m = 200 },
           { kind = "cruise", duration_s = 60 },
           { kind = "turn", angle_deg = -135, radius_m = 30 },
           { kind = "cruise", distance_m = 2000 },
           { kind = "decelerate", to_kmh = 0, accel_mps2 = 2 },
           { kind = "stay", duration_s = 30 } ]
"#;

fn run(body: &str) -> waymark::sim::SimResult {
    let text = format!("name = \"t\"\n{ROUTE}\n{body}");
    let scn = Scenario::parse(Path::new("test.toml"), &text).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    simulate(&scn, &truth, 1, 1).unwrap()
}

fn max_h(r: &waymark::sim::SimResult) -> f64 {
    r.summary.max_horizontal_error_m
}

#[test]
fn perfect_sensors_give_no_error_in_every_mode() {
    // Truth and navigators are integrated alike; what is left is rounding and,
    // for the 3-D DR, the 10 Hz altimeter steps (heading held over 0.1 s in
    // turns): 1 cm for the inertial and odometer navigators, 10 cm for 3-D DR
    // (measured 3 cm).
    let free = run("[navigator]\nmode = \"free_inertial\"\nvertical_channel = \"free\"\n");
    assert!(max_h(&free) < 0.01, "free {}", max_h(&free));
    let dr = run("[navigator]\nmode = \"dead_reckoning\"\n");
    assert!(max_h(&dr) < 0.01, "dr {}", max_h(&dr));
    let dr3 =
        run("[navigator]\nmode = \"dead_reckoning_3d\"\n[baro]\nnoise_m = 0\nbias_drift_m = 0\n");
    eprintln!(
        "perfect sensors: free {:.2e} m, DR {:.2e} m, 3-D DR {:.3} m",
        max_h(&free),
        max_h(&dr),
        max_h(&dr3)
    );
    assert!(max_h(&dr3) < 0.1, "dr3d {}", max_h(&dr3));
}

#[test]
fn rotation_modulation_is_transparent_to_odometer_dead_reckoning() {
    // The navigator undoes the known IMU rotation to get the body attitude; a
    // mistake there would lay odometer distance along a spinning axis.
    let r = run(
        "[navigator]\nmode = \"dead_reckoning\"\n[imu]\nrotation_modulation = { rate_dps = 10 }\n",
    );
    assert!(max_h(&r) < 0.01, "{}", max_h(&r));
}

#[test]
fn baro_damping_holds_the_vertical_channel() {
    // A 100 µg vertical accelerometer bias: free, the vertical channel diverges
    // (time constant ≈ 570 s); baro-damped (noise 0.5 m, drift 1 m) it stays
    // within a few metres.
    let body = "[imu]\naccel_bias_ug = [0, 0, 100]\n";
    let free = run(&format!("[navigator]\nvertical_channel = \"free\"\n{body}"));
    let damped = run(&format!("[navigator]\nvertical_channel = \"baro\"\n{body}"));
    let up = |r: &waymark::sim::SimResult| {
        r.runs[0]
            .rows
            .iter()
            .map(|x| x.up_m.abs())
            .fold(0.0, f64::max)
    };
    eprintln!(
        "vertical: free {:.1} m, baro-damped {:.2} m",
        up(&free),
        up(&damped)
    );
    assert!(up(&free) > 20.0);
    assert!(up(&damped) < 5.0);
}

#[test]
fn odometer_failure_hands_over_without_a_jump() {
    let r = run("[navigator]\nmode = \"dead_reckoning\"\n[odometer]\nfailure = { from_s = 150 }\n");
    let rows = &r.runs[0].rows;
    // Perfect IMU: the inertial navigator continues from the dead-reckoned
    // state; within 20 s of the failure the error stays under 1 m.
    let after: Vec<_> = rows
        .iter()
        .filter(|x| x.t_s >= 150.0 && x.t_s <= 170.0)
        .collect();
    assert!(!after.is_empty());
    for x in after {
        assert!(x.horizontal_m < 1.0, "t {} error {}", x.t_s, x.horizontal_m);
    }
}

#[test]
fn every_bundled_scenario_loads() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let scn = Scenario::load(&p).unwrap_or_else(|e| panic!("{e}"));
            // Benchmark-only scenarios read maps from ../shared/data, which a
            // fresh clone does not have.
            if let waymark::scenario::RouteKind::Map { map, .. } = &scn.route {
                if !map.exists() && map.to_string_lossy().contains("shared/data") {
                    eprintln!("skipping {}: {} not found", p.display(), map.display());
                    continue;
                }
            }
            // Network plans from the map alone have no route to drive.
            if let waymark::scenario::RouteKind::Map { waypoints, .. } = &scn.route {
                if waypoints.is_empty() {
                    assert_eq!(scn.planner().coverage, waymark::scenario::Coverage::Network);
                    assert!(TruthSource::new(&scn).is_err());
                    continue;
                }
            }
            TruthSource::new(&scn).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 11, "{n} scenarios");
}
