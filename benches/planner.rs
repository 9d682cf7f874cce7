//! Tag planner benchmarks: network coverage planning (`coverage =
//! "network"`, no validation) on Monaco (../shared/data, skipped when absent)
//! and the bundled Gothenburg GeoJSON: map load, reach analysis, instance,
//! greedy/exact placement and the DP verification. Target: < 10 s each.
//!
//! Run: `cargo bench --bench planner` (10 samples each; Gothenburg takes a
//! few minutes in all).

use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;
use std::time::Duration;
use waymark::planner::network::plan_network;
use waymark::planner::PlannerSettings;
use waymark::sim::Scenario;

fn network_coverage(c: &mut Criterion) {
    let mut g = c.benchmark_group("plan_network");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, map) in [
        (
            "monaco-network-plan.toml",
            root.join("../shared/data/maps/monaco.osm.pbf"),
        ),
        (
            "gothenburg-network-plan.toml",
            root.join("maps/gothenburg-roads.geojson"),
        ),
    ] {
        if !map.exists() {
            eprintln!("skipping {name}: {} not found", map.display());
            continue;
        }
        let scn = Scenario::load(&root.join("scenarios").join(name)).expect("scenario");
        let settings = PlannerSettings::from_scenario(&scn).expect("settings");
        let p = plan_network(&scn, &settings, 1, false).expect("plan");
        eprintln!(
            "{name}: {} directed edges, {} candidates, R = {:.0} m, {} tags, lower bound {}, {}",
            p.directed_edges,
            p.candidates,
            p.reach_m,
            p.tag_count(),
            p.lower_bound,
            p.method
        );
        g.bench_function(name, |b| {
            b.iter(|| plan_network(&scn, &settings, 1, false).expect("plan"))
        });
    }
    g.finish();
}

criterion_group!(benches, network_coverage);
criterion_main!(benches);
