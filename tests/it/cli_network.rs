//! The real `waymark` binary on the bundled maps and on bad input, run in a
//! temporary folder.

use crate::common;

use common::{bin, repo, run};

use std::path::Path;
use std::process::Output;

fn inspect_json(map: &Path) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        &["network", "inspect", map.to_str().unwrap(), "--json"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

/// Asserts a clean failure: exit code 1, one line on stderr naming the file
/// and containing `needle`, no panic.
fn assert_clean_error(out: &Output, file: &str, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "one line expected: {stderr}"
    );
    assert!(stderr.starts_with("waymark: error: "), "{stderr}");
    assert!(stderr.contains(file), "file name missing: {stderr}");
    assert!(stderr.contains(needle), "expected '{needle}' in: {stderr}");
}

#[test]
fn inspect_helsinki_json_has_the_contract_fields() {
    let v = inspect_json(&repo("maps/helsinki.osm.pbf"));
    for key in [
        "roads",
        "sections",
        "segments",
        "nodes",
        "length_km",
        "tunnels",
        "oneway_share",
        "components",
        "grid",
        "defects",
        "skipped",
        "timings_ms",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    // DESIGN.md: about 1,000 drivable ways, some cut at the extract edge.
    let roads = v["roads"].as_u64().unwrap();
    assert!((900..=1100).contains(&roads), "roads {roads}");
    assert!(v["cut_ways"].as_u64().unwrap() > 0);
    assert!(v["tunnels"]["count"].as_u64().unwrap() > 0);
    assert!(v["tunnels"]["length_km"].as_f64().unwrap() > 0.0);
    assert!(v["components"]["weak"].as_u64().unwrap() >= 1);
    assert!(
        v["components"]["strong"].as_u64().unwrap() >= v["components"]["weak"].as_u64().unwrap()
    );
    let share = v["oneway_share"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&share));
    assert!(v["grid"]["n"].as_u64().unwrap().is_power_of_two());
    assert!(v["grid"]["occupied_cells"].as_u64().unwrap() > 0);
    assert!(v["defects"]["dead_end"].is_u64());
    assert!(v["timings_ms"]["load"].as_f64().unwrap() >= 0.0);
}

/// A map without one-way roads, tunnels or bridges reports its shares and
/// lengths as 0, not -0 (an empty f64 sum is -0.0, which JSON and the text
/// summary printed as "-0").
#[test]
fn inspect_reports_zero_not_negative_zero() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("two-way.geojson");
    std::fs::write(
        &map,
        r#"{"type": "FeatureCollection", "features": [{"type": "Feature", "id": "a", "properties": {"highway": "residential"},
           "geometry": {"type": "LineString", "coordinates": [[24, 60], [24.001, 60]]}}]}"#,
    )
    .unwrap();
    let v = inspect_json(&map);
    for (what, x) in [
        ("oneway_share", &v["oneway_share"]),
        ("tunnels", &v["tunnels"]["length_km"]),
        ("bridges", &v["bridges"]["length_km"]),
    ] {
        let x = x.as_f64().unwrap();
        assert!(x == 0.0 && x.is_sign_positive(), "{what}: {x}");
    }
    let out = run(&["network", "inspect", "two-way.geojson"], dir.path());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && !text.contains("-0"), "{text}");
}

#[test]
fn inspect_gothenburg_skips_and_counts_polygons() {
    let v = inspect_json(&repo("maps/gothenburg-roads.geojson"));
    assert_eq!(v["format"], "geojson");
    assert_eq!(v["features_read"], 20227);
    assert_eq!(v["skipped"]["geometry_polygon"], 107);
    assert!(v["roads"].as_u64().unwrap() > 9000);
    assert!(v["length_km"].as_f64().unwrap() > 500.0);
}

#[test]
fn inspect_text_and_defect_export() {
    let dir = tempfile::tempdir().unwrap();
    let small = repo("tests/data/small.osm");
    let out = run(
        &[
            "network",
            "inspect",
            small.to_str().unwrap(),
            "--defects",
            "defects.geojson",
        ],
        dir.path(),
    );
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("roads      12"), "{text}");
    assert!(text.contains("OpenStreetMap contributors"));
    let fc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("defects.geojson")).unwrap())
            .unwrap();
    assert_eq!(fc["type"], "FeatureCollection");
    // 2 + 1 + 1 + 2 + 9 + 6 defects planted in small.osm.
    assert_eq!(fc["features"].as_array().unwrap().len(), 21);
}

#[test]
fn demo_plans_validates_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    let out = bin().arg("demo").current_dir(dir.path()).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let demo = dir.path().join("waymark-demo");
    for f in [
        "tags.csv",
        "tags.geojson",
        "tags.kml",
        "tags.gpx",
        "plan.json",
        "report.html",
        "summary.json",
        "errors.csv",
    ] {
        assert!(demo.join(f).exists(), "missing {f}");
    }
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(demo.join("plan.json")).unwrap()).unwrap();
    assert_eq!(plan["requirement_m"], 20.0);
    assert!(plan["tag_count"].as_u64().unwrap() >= 1);
    assert!(
        plan["validation"]["fraction_within_requirement"]
            .as_f64()
            .unwrap()
            >= 0.99
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("report.html"));
}

#[test]
fn missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(&["network", "inspect", "nowhere.osm.pbf"], dir.path());
    assert_clean_error(&out, "nowhere.osm.pbf", "No such file");
}

#[test]
fn truncated_pbf() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(repo("maps/helsinki.osm.pbf")).unwrap();
    for cut in [10, 1000, bytes.len() / 2, bytes.len() - 7] {
        std::fs::write(dir.path().join("cut.osm.pbf"), &bytes[..cut]).unwrap();
        let out = run(&["network", "inspect", "cut.osm.pbf"], dir.path());
        assert_clean_error(&out, "cut.osm.pbf", "OSM PBF");
    }
}

#[test]
fn garbage_and_empty_files() {
    let dir = tempfile::tempdir().unwrap();
    let garbage: Vec<u8> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    std::fs::write(dir.path().join("noise.osm.pbf"), &garbage).unwrap();
    assert_clean_error(
        &run(&["network", "inspect", "noise.osm.pbf"], dir.path()),
        "noise.osm.pbf",
        "OSM PBF",
    );
    std::fs::write(dir.path().join("empty.geojson"), b"").unwrap();
    assert_clean_error(
        &run(&["network", "inspect", "empty.geojson"], dir.path()),
        "empty.geojson",
        "empty",
    );
    std::fs::write(dir.path().join("map.txt"), b"hello").unwrap();
    assert_clean_error(
        &run(&["network", "inspect", "map.txt"], dir.path()),
        "map.txt",
        "unrecognised map format",
    );
}

#[test]
fn invalid_geojson() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str, &str)] = &[
        (
            "broken.geojson",
            r#"{"type": "FeatureCollection", "features": [ "#,
            "invalid JSON",
        ),
        (
            "feature.geojson",
            r#"{"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[24,60],[24.1,60]]}}"#,
            "not a FeatureCollection",
        ),
        (
            "lat.geojson",
            r#"{"type": "FeatureCollection", "features": [{"type": "Feature", "id": "x", "properties": {"highway": "primary"},
               "geometry": {"type": "LineString", "coordinates": [[24, 95], [24.1, 60]]}}]}"#,
            "out of range",
        ),
        (
            "huge.geojson",
            r#"{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {},
               "geometry": {"type": "LineString", "coordinates": [[24, 1e999], [24.1, 60]]}}]}"#,
            "invalid JSON",
        ),
        (
            "foot.geojson",
            r#"{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {"highway": "footway"},
               "geometry": {"type": "LineString", "coordinates": [[24, 60], [24.1, 60]]}}]}"#,
            "empty after filtering",
        ),
    ];
    for (name, text, needle) in cases {
        std::fs::write(dir.path().join(name), text).unwrap();
        assert_clean_error(
            &run(&["network", "inspect", name], dir.path()),
            name,
            needle,
        );
    }
}

#[test]
fn invalid_osm_xml() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str, &str)] = &[
        (
            "nan.osm",
            r#"<osm><node id="1" lat="NaN" lon="24"/><node id="2" lat="60" lon="24"/>
               <way id="5"><nd ref="1"/><nd ref="2"/><tag k="highway" v="primary"/></way></osm>"#,
            "not a finite number",
        ),
        (
            "cut.osm",
            r#"<osm><node id="1" lat="60" lon="24"/><way id="5"><nd ref="1"/>"#,
            "ends inside a <way>",
        ),
        (
            "bad.osm",
            r#"<osm><node id="x" lat="60" lon="24"/></osm>"#,
            "not an integer",
        ),
        (
            "roads.osm",
            r#"<osm><node id="1" lat="60" lon="24"/></osm>"#,
            "empty after filtering",
        ),
    ];
    for (name, text, needle) in cases {
        std::fs::write(dir.path().join(name), text).unwrap();
        assert_clean_error(
            &run(&["network", "inspect", name], dir.path()),
            name,
            needle,
        );
    }
}

#[test]
fn bad_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let small = repo("tests/data/small.osm");
    let out = run(
        &[
            "network",
            "inspect",
            small.to_str().unwrap(),
            "--grid-n",
            "3",
        ],
        dir.path(),
    );
    // A bad option value is a bad command line (README, exit codes): 2.
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("power of two"));
    let out = run(
        &[
            "network",
            "inspect",
            small.to_str().unwrap(),
            "--defects",
            "no/such/dir/d.geojson",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(!dir.path().join("no").exists());
    // Unknown flags are clap's business: exit code 2.
    let out = run(&["network", "inspect", "--frobnicate"], dir.path());
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn defects_written_onto_the_map_are_refused() {
    // `--defects MAP` replaced the map with the defect points (exit 0); the
    // next inspect of it found no roads.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = std::fs::read_to_string(repo("tests/data/small.osm")).unwrap();
    std::fs::write(d.join("small.osm"), &text).unwrap();
    let out = run(
        &[
            "network",
            "inspect",
            "small.osm",
            "--defects",
            "./small.osm",
        ],
        d,
    );
    assert_clean_error(
        &out,
        "small.osm",
        "--defects is the same file as the input MAP",
    );
    assert_eq!(std::fs::read_to_string(d.join("small.osm")).unwrap(), text);
}
