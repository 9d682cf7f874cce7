//! Small maps (a few kilobytes), loaded from bytes the way the fuzz targets
//! and `Network::load` do: model, grid, R-tree, topology and defect checks.
//! The constant cost of the pipeline, which dominates for small inputs, not
//! its throughput on real maps (that is `benches/network.rs`).
//!
//! Run: `cargo bench --bench small_maps`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::path::Path;
use waymark::network::{load_model, LoadOptions, Network};

fn data(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name),
    )
    .unwrap()
}

fn load(name: &str, bytes: &[u8]) -> usize {
    let model = load_model(Path::new(name), bytes, &LoadOptions::default()).unwrap();
    let net = Network::from_model(model, None).unwrap();
    net.defects(1.0).items.len()
}

/// Two short ways: one in Helsinki, one 1 000 km away (a small map whose
/// extent is large, as mutated fuzz inputs often are).
const WIDE_OSM: &str = r#"<osm version="0.6">
 <node id="1" lat="60.0" lon="24.0"/><node id="2" lat="60.0" lon="24.001"/>
 <node id="3" lat="51.0" lon="24.0"/><node id="4" lat="51.0" lon="24.001"/>
 <way id="1"><nd ref="1"/><nd ref="2"/><tag k="highway" v="residential"/></way>
 <way id="2"><nd ref="3"/><nd ref="4"/><tag k="highway" v="residential"/></way>
</osm>"#;

fn small_maps(c: &mut Criterion) {
    let mut g = c.benchmark_group("small_map_load_index_defects");
    let osm = data("small.osm");
    let geojson = data("small.geojson");
    g.bench_function("small.osm", |b| {
        b.iter(|| load("small.osm", black_box(&osm)))
    });
    g.bench_function("small.geojson", |b| {
        b.iter(|| load("small.geojson", black_box(&geojson)))
    });
    g.bench_function("two_ways_1000km_apart.osm", |b| {
        b.iter(|| load("wide.osm", black_box(WIDE_OSM.as_bytes())))
    });
    g.finish();
}

criterion_group!(benches, small_maps);
criterion_main!(benches);
