//! `waymark match` on real public traces with a peer's expected result
//! (tests/data/real/README.md): GraphHopper's map-matching test traces
//! (GPX, OpenStreetMap extracts) and FMM's example (its network, trips and
//! committed complete path, scaled to metres).

use crate::common;

use common::real_data as data;

use std::path::PathBuf;
use std::process::Command;

/// Runs `waymark match --json` with a complete path; the JSON and the path rows.
fn run(map: &str, track: &str, extra: &[&str]) -> (serde_json::Value, Vec<Vec<String>>) {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join("path.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args([
            "match",
            "--map",
            &data(map),
            "--track",
            &data(track),
            "--json",
        ])
        .args(["--out", &dir.path().join("m.csv").display().to_string()])
        .args(["--path", &path.display().to_string()])
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("track_id,seq,road_id,from_offset_m,to_offset_m,length_m")
    );
    let rows = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    (json, rows)
}

fn roads_of(rows: &[Vec<String>], track: &str) -> Vec<String> {
    rows.iter()
        .filter(|r| r[0] == track)
        .map(|r| r[2].clone())
        .collect()
}

#[test]
fn fmm_example_complete_paths_equal_fmms_committed_result() {
    let (json, rows) = run(
        "fmm-network.geojson",
        "fmm-trips.geojson",
        &["--truth", &data("fmm-truth.csv")],
    );
    assert_eq!(json["format"], "geojson");
    assert_eq!(json["matched_share"], 1.0);
    // FMM's cpath (mr.txt), edge by edge, in driving order.
    for (track, cpath) in [
        ("1", "2,5,13,14,23"),
        ("2", "25,4,3,5,17,19"),
        ("3", "8,11,13,18,20,24"),
    ] {
        assert_eq!(roads_of(&rows, track).join(","), cpath, "trip {track}");
    }
    assert_eq!(json["path_pieces"], 3);
    // By length: both paths start and end where the first and last points
    // project onto their edges; the truth's lengths are measured on FMM's
    // matched geometry (haversine, 0.3 % shorter than the map's frame
    // here), so precision and recall by length are 1 to rounding.
    let s = &json["score"];
    assert!(s["precision_length"].as_f64().unwrap() >= 0.999, "{s}");
    assert!(s["recall_length"].as_f64().unwrap() >= 0.999, "{s}");
}

#[test]
fn graphhopper_issue_70_follows_the_expected_streets() {
    let (json, rows) = run(
        "issue-70.osm",
        "issue-70.gpx",
        &["--truth", &data("issue-70-truth.csv")],
    );
    assert_eq!(json["format"], "gpx");
    assert_eq!(json["matched_share"], 1.0);
    assert_eq!(json["breaks"].as_array().unwrap().len(), 0);
    // GraphHopper's expected streets, in order: Милана Видака, Бранка
    // Радичевића, Здравка Челара (one OSM way each in this extract).
    assert_eq!(
        roads_of(&rows, "1"),
        ["263190269", "115389243", "190958702"]
    );
    let s = &json["score"];
    assert_eq!(s["precision_length"].as_f64().unwrap(), 1.0, "{s}");
    assert_eq!(s["recall_count"].as_f64().unwrap(), 1.0, "{s}");
}

#[test]
fn graphhopper_issue_13_identical_timestamps_match_the_trace_length() {
    // Every point has the same time: no speed bound, distance caps only.
    let (json, rows) = run("issue-13.osm", "issue-13.gpx", &[]);
    assert_eq!(json["matched_share"], 1.0);
    assert_eq!(json["path_pieces"], 1);
    assert!(!rows.is_empty());
    // GraphHopper asserts its match length equals the GPX trace's length
    // (237.5 m, the sum of the haversine distances between the points)
    // within 2.5 m; the matched path here follows the road's corners
    // where the trace cuts them: within 5 m (2 %).
    let len = json["path_length_m"].as_f64().unwrap();
    assert!((len - 237.5).abs() <= 5.0, "{len}");
}

#[test]
fn graphhopper_issue_127_two_identical_points() {
    let (json, rows) = run("issue-13.osm", "issue-127.gpx", &[]);
    assert_eq!(json["matched"], 2);
    assert_eq!(json["path_length_m"], 0.0);
    assert!(rows.is_empty());
}
