//! Fuzzes the scenario parser and its one validation pass.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(scn) = waymark::Scenario::parse(Path::new("fuzz.toml"), text) {
            // What the planner derives from it must not panic either.
            let _ = waymark::PlannerSettings::from_scenario(&scn);
        }
    }
});
