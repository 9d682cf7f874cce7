//! Road network benchmarks: load + index + topology on every real map in
//! ../shared/data/maps (skipped when absent), point queries on the grid and the
//! R-tree, synthetic street grids up to one million segments, and shortest
//! paths with and without landmarks.
//!
//! Run: `cargo bench --bench network`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::path::{Path, PathBuf};
use std::time::Duration;
use waymark::network::{model_from_polylines, LoadOptions, Network, TagSet};
use waymark::route::{shortest_path_with, Landmarks, SectionPoint, DEFAULT_LANDMARKS};

fn shared(name: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/maps")
        .join(name);
    p.exists().then_some(p)
}

fn real_maps(c: &mut Criterion) {
    let mut g = c.benchmark_group("load_index_topology");
    g.sample_size(20).measurement_time(Duration::from_secs(8));
    for name in [
        "monaco.osm.pbf",
        "liechtenstein.osm.pbf",
        "helsinki.osm.pbf",
        "gothenburg-roads.geojson",
        "stockholm/edges.shp",
    ] {
        let Some(path) = shared(name) else {
            eprintln!("skipping {name}: not found in ../shared/data/maps");
            continue;
        };
        g.bench_function(name, |b| {
            b.iter(|| Network::load(black_box(&path), &LoadOptions::default()).unwrap())
        });
    }
    g.finish();
}

/// Uniforms in [0, 1) from a fixed linear congruential sequence.
fn uniforms(mut state: u64) -> impl FnMut() -> f64 {
    move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Deterministic query points: near segment midpoints (real roads), jittered
/// by up to ±40 m, from a fixed linear congruential sequence.
fn query_points(net: &Network, n: usize) -> Vec<[f64; 2]> {
    let mut next = uniforms(0x2545_F491_4F6C_DD1D);
    (0..n)
        .map(|_| {
            let s = &net.segments[(next() * net.segments.len() as f64) as usize];
            let m = [(s.a[0] + s.b[0]) / 2.0, (s.a[1] + s.b[1]) / 2.0];
            [m[0] + 80.0 * (next() - 0.5), m[1] + 80.0 * (next() - 0.5)]
        })
        .collect()
}

fn point_queries(c: &mut Criterion) {
    let mut g = c.benchmark_group("point_query_r50");
    for name in ["monaco.osm.pbf", "gothenburg-roads.geojson"] {
        let Some(path) = shared(name) else { continue };
        let net = Network::load(&path, &LoadOptions::default()).unwrap();
        let pts = query_points(&net, 10_000);
        g.throughput(Throughput::Elements(pts.len() as u64));
        g.bench_function(BenchmarkId::new("grid", name), |b| {
            let mut out = Vec::with_capacity(64);
            b.iter(|| {
                let mut found = 0usize;
                for p in &pts {
                    out.clear();
                    net.grid.within_radius_into(*p, 50.0, &mut out);
                    found += out.len();
                }
                found
            })
        });
        g.bench_function(BenchmarkId::new("rtree", name), |b| {
            b.iter(|| {
                pts.iter()
                    .map(|p| net.rtree.within_radius(*p, 50.0).len())
                    .sum::<usize>()
            })
        });
    }
    g.finish();
}

/// A k×k street grid with 100 m blocks near 60° N: 2·k·(k−1) segments.
fn street_grid(k: usize) -> waymark::network::RoadNetwork {
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
    model_from_polylines(roads).unwrap()
}

fn synthetic(c: &mut Criterion) {
    let mut g = c.benchmark_group("synthetic_grid");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for k in [100usize, 224, 500, 708] {
        let segments = 2 * k * (k - 1);
        g.bench_function(BenchmarkId::new("build_model", segments), |b| {
            b.iter(|| street_grid(k))
        });
        let model = street_grid(k);
        g.bench_function(BenchmarkId::new("index_topology", segments), |b| {
            b.iter(|| Network::from_model(model.clone(), None).unwrap())
        });
        let net = Network::from_model(model, None).unwrap();
        let pts = query_points(&net, 10_000);
        g.bench_function(BenchmarkId::new("point_query_r50_x10000", segments), |b| {
            let mut out = Vec::with_capacity(64);
            b.iter(|| {
                let mut found = 0usize;
                for p in &pts {
                    out.clear();
                    net.grid.within_radius_into(*p, 50.0, &mut out);
                    found += out.len();
                }
                found
            })
        });
    }
    g.finish();
}

/// Deterministic pairs of points on sections of the largest strongly
/// connected part (every pair routable), from [`uniforms`].
fn route_pairs(net: &Network, n: usize) -> Vec<(SectionPoint, SectionPoint)> {
    let mut next = uniforms(0x9E37_79B9_7F4A_7C15);
    let main: Vec<usize> = (0..net.sections.len())
        .filter(|&i| {
            let s = &net.sections[i];
            let l = net.topology.largest_scc;
            net.topology.scc_of(s.start) == l && net.topology.scc_of(s.end) == l
        })
        .collect();
    let mut point = || {
        let i = main[(next() * main.len() as f64) as usize];
        SectionPoint {
            section: i as u32,
            offset_m: next() * net.sections[i].length_m,
        }
    };
    (0..n).map(|_| (point(), point())).collect()
}

/// Shortest paths between random points: A* on the straight line alone and
/// with landmarks (the trip sampler's), and the landmarks' build.
fn routing(c: &mut Criterion) {
    let maps: Vec<(&str, Network)> = [
        "monaco.osm.pbf",
        "gothenburg-roads.geojson",
        "liechtenstein.osm.pbf",
    ]
    .into_iter()
    .filter_map(|name| {
        Some((
            name,
            Network::load(&shared(name)?, &LoadOptions::default()).unwrap(),
        ))
    })
    .collect();
    let mut g = c.benchmark_group("shortest_path_x1000");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (name, net) in &maps {
        let pairs = route_pairs(net, 1000);
        let lm = Landmarks::build(net, DEFAULT_LANDMARKS);
        g.throughput(Throughput::Elements(pairs.len() as u64));
        for (how, guide) in [("line", None), ("landmarks", Some(&lm))] {
            g.bench_function(BenchmarkId::new(how, name), |b| {
                b.iter(|| {
                    pairs
                        .iter()
                        .filter_map(|&(a, z)| shortest_path_with(net, guide, a, z, None))
                        .map(|p| p.1)
                        .sum::<f64>()
                })
            });
        }
    }
    g.finish();
    let mut g = c.benchmark_group("landmarks_build");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (name, net) in &maps {
        g.bench_function(*name, |b| {
            b.iter(|| Landmarks::build(net, DEFAULT_LANDMARKS))
        });
    }
    g.finish();
}

criterion_group!(benches, real_maps, point_queries, synthetic, routing);
criterion_main!(benches);
