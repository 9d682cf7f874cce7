//! Fuzzes the tag file reader (`simulate --tags`, `planner.existing_tags`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = waymark::sim::tags::parse_tags_csv(Path::new("tags.csv"), text);
    }
});
