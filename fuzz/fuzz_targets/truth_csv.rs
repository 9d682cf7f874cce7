//! Fuzzes the truth reader of `waymark match --truth` (from a scratch file),
//! against the small test map.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;
use waymark::network::{LoadOptions, Network};
mod common;

static NET: OnceLock<Network> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let net = NET.get_or_init(|| {
        let map = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/small.osm");
        Network::load(&map, &LoadOptions::default()).expect("the small test map loads")
    });
    let path = common::scratch().join("truth.csv");
    std::fs::write(&path, data).unwrap();
    let _ = waymark::matching::evaluate::read_truth(&path, net);
});
