//! Fuzzes the track reader of `waymark match` (from a scratch file).
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let path = common::scratch().join("track.csv");
    std::fs::write(&path, data).unwrap();
    if let Ok(rows) = waymark::matching::track::read_track(&path) {
        let _ = waymark::matching::track::group_tracks(&rows);
    }
});
