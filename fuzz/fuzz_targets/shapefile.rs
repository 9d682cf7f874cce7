//! Fuzzes the shapefile loader: the input is split into a `.shp` and a
//! `.dbf` (the first two bytes give the `.shp`'s length), written to a
//! scratch folder and loaded as a map.
#![no_main]
use libfuzzer_sys::fuzz_target;
use waymark::network::{LoadOptions, Network};
mod common;

fuzz_target!(|data: &[u8]| {
    if data.len() < 2 {
        return;
    }
    let n = (u16::from_le_bytes([data[0], data[1]]) as usize).min(data.len() - 2);
    let (shp, dbf) = data[2..].split_at(n);
    let dir = common::scratch();
    let path = dir.join("roads.shp");
    std::fs::write(&path, shp).unwrap();
    std::fs::write(dir.join("roads.dbf"), dbf).unwrap();
    let _ = Network::load(&path, &LoadOptions::default());
});
