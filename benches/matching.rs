//! Map-matching throughput, single thread: dense 1 m tracks (30 m drift,
//! 2 m noise, seeded) on real maps (bundled Helsinki; Monaco from
//! ../shared/data/maps when present) and on a synthetic 200 × 200 street
//! grid with 100 m blocks. Each iteration matches the whole track with a
//! fresh matcher (cold network-distance cache included).
//!
//! Run: `cargo bench --bench matching`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};
use std::time::Duration;
use waymark::matching::{along_route, TrackModel};
use waymark::matching::{
    match_track, Fix, HmmMatcher, HmmParams, IncrementalMatcher, IncrementalParams,
};
use waymark::network::{model_from_polylines, LoadOptions, Network, TagSet};
use waymark::route::plan_route;

fn street_grid(k: usize) -> Network {
    let dlat = 100.0 / 111_320.0;
    let dlon = 100.0 / (111_320.0 * 60f64.to_radians().cos());
    let mut roads = Vec::with_capacity(2 * k);
    for i in 0..k {
        let row: Vec<[f64; 2]> = (0..k)
            .map(|j| [59.0 + i as f64 * dlat, 24.0 + j as f64 * dlon])
            .collect();
        let col: Vec<[f64; 2]> = (0..k)
            .map(|j| [59.0 + j as f64 * dlat, 24.0 + i as f64 * dlon])
            .collect();
        roads.push((TagSet::default().attributes(format!("row{i}")), vec![row]));
        roads.push((TagSet::default().attributes(format!("col{i}")), vec![col]));
    }
    Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap()
}

/// A dense track through `n` random junctions (seeded), at least `min_m` long.
fn dense_track(net: &Network, seed: u64, stops: usize, min_hop_m: f64) -> Vec<Fix> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut w = Vec::new();
    while w.len() < stops {
        let p = net.nodes[rng.random_range(0..net.nodes.len())].enu;
        if let Some(q) = w.last() {
            let q: &[f64; 2] = q;
            if (p[0] - q[0]).hypot(p[1] - q[1]) < min_hop_m {
                continue;
            }
        }
        w.push(p);
    }
    let ll: Vec<[f64; 2]> = w
        .iter()
        .map(|p| {
            let g = net.frame.to_geodetic([p[0], p[1], 0.0]);
            [g.lat_deg(), g.lon_deg()]
        })
        .collect();
    // Drop waypoints that cannot be joined (one-way dead ends) one at a time.
    let mut ll = ll;
    let route = loop {
        match plan_route(net, &ll) {
            Ok(r) => break r,
            Err(_) => {
                ll.pop();
                assert!(ll.len() >= 2);
            }
        }
    };
    along_route(
        net,
        &route,
        &TrackModel {
            spacing_m: 1.0,
            speed_mps: 10.0,
            drift_max_m: 30.0,
            noise_sigma_m: 2.0,
            heading_sigma_deg: None,
            seed,
        },
    )
    .fixes
}

fn shared(name: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/maps")
        .join(name);
    p.exists().then_some(p)
}

fn bench_track(c: &mut Criterion, group: &str, net: &Network, fixes: &[Fix]) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10).measurement_time(Duration::from_secs(6));
    g.throughput(Throughput::Elements(fixes.len() as u64));
    g.bench_function(BenchmarkId::new("incremental", fixes.len()), |b| {
        b.iter(|| {
            let mut m = IncrementalMatcher::new(net, IncrementalParams::default());
            match_track(&mut m, fixes).len()
        })
    });
    g.bench_function(BenchmarkId::new("hmm", fixes.len()), |b| {
        b.iter(|| {
            let mut m = HmmMatcher::new(net, HmmParams::default());
            match_track(&mut m, fixes).len()
        })
    });
    // `match --model independent`'s matcher (one emission per candidate, at
    // most 8 candidates, filtered confidence).
    let lean = HmmParams {
        model: waymark::matching::HmmModel::Independent,
        max_candidates: waymark::matching::options::INDEPENDENT_MAX_CANDIDATES,
        ..HmmParams::default()
    };
    g.bench_function(BenchmarkId::new("hmm_independent", fixes.len()), |b| {
        b.iter(|| {
            let mut m = HmmMatcher::new(net, lean);
            match_track(&mut m, fixes).len()
        })
    });
    g.finish();
}

fn real_maps(c: &mut Criterion) {
    let helsinki = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    let net = Network::load(&helsinki, &LoadOptions::default()).unwrap();
    let fixes = dense_track(&net, 1, 12, 800.0);
    bench_track(c, "match_helsinki_1m", &net, &fixes);
    if let Some(p) = shared("monaco.osm.pbf") {
        let net = Network::load(&p, &LoadOptions::default()).unwrap();
        let fixes = dense_track(&net, 2, 12, 800.0);
        bench_track(c, "match_monaco_1m", &net, &fixes);
    } else {
        eprintln!("skipping Monaco: not found in ../shared/data/maps");
    }
}

fn synthetic(c: &mut Criterion) {
    let net = street_grid(200);
    let fixes = dense_track(&net, 3, 8, 3000.0);
    bench_track(c, "match_grid200_1m", &net, &fixes);
}

criterion_group!(benches, real_maps, synthetic);
criterion_main!(benches);
