//! The map feed's cost (issue 12): one run of the 50 min MEMS Helsinki tour
//! (`scenarios/helsinki-tour-mems-map-matching.toml`, 100 Hz, the truth in
//! its lane) with map matching off, on a perfect map, and on the default
//! erroneous map (4.8 m, 200 m); one thread. The budget: the feed
//! adds at most 20 % to an integrated run.
//!
//! `cargo bench --bench map_feed`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::path::Path;
use waymark::sim::{simulate, Scenario, TruthSource};

fn variant(dir: &Path, name: &str, map_matching: bool, sigma: f64) -> Scenario {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenarios/helsinki-tour-mems-map-matching.toml"))
        .unwrap()
        .replace(
            "../maps/helsinki.osm.pbf",
            &root.join("maps/helsinki.osm.pbf").display().to_string(),
        )
        .replace(
            "map_matching = true",
            &format!("map_matching = {map_matching}"),
        )
        .replace(
            "geometry_error_m = 4.8",
            &format!("geometry_error_m = {sigma}"),
        );
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    Scenario::load(&p).unwrap()
}

fn map_feed(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("waymark-bench-map-feed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("map_feed");
    g.sample_size(10);
    for (name, mm, sigma) in [
        ("tour_50min_no_map_matching", false, 4.8),
        ("tour_50min_map_matching_perfect_map", true, 0.0),
        ("tour_50min_map_matching_4.8m_map_error", true, 4.8),
    ] {
        let scn = variant(&dir, name, mm, sigma);
        let truth = TruthSource::new(&scn).unwrap();
        g.bench_function(name, |b| {
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
    }
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, map_feed);
criterion_main!(benches);
