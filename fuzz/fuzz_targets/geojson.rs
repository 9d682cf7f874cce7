//! Fuzzes the map loader on x.geojson content (then the grid, R-tree, topology
//! and defect checks on whatever loads).
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let mut bytes = b"{".to_vec();
    bytes.extend_from_slice(data);
    common::load_map("x.geojson", &bytes);
});
