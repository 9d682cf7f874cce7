//! `waymark match --model independent` (Newson and Krumm's HMM: one emission
//! per candidate, filtered confidence) on the committed real traces
//! (tests/data/real/README.md), with the accuracy the default model reaches
//! there (tests/it/cli_match_real.rs), and its option checked.

use crate::common;

use common::real_data as data;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn waymark(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .output()
        .unwrap()
}

/// `waymark match --json --model MODEL` with a complete path: the JSON, the
/// path rows and the MATCHED.csv rows (its header first).
fn run(
    map: &str,
    track: &str,
    model: &str,
    extra: &[&str],
) -> (serde_json::Value, Vec<Vec<String>>, Vec<Vec<String>>) {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join("path.csv");
    let matched: PathBuf = dir.path().join("m.csv");
    let (m, t) = (data(map), data(track));
    let (p, o) = (path.display().to_string(), matched.display().to_string());
    let mut args = vec![
        "match", "--map", &m, "--track", &t, "--json", "--model", model, "--out", &o, "--path", &p,
    ];
    args.extend_from_slice(extra);
    let out = waymark(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = |f: &Path, skip: usize| -> Vec<Vec<String>> {
        std::fs::read_to_string(f)
            .unwrap()
            .lines()
            .skip(skip)
            .map(|l| l.split(',').map(str::to_owned).collect())
            .collect()
    };
    (json, rows(&path, 1), rows(&matched, 0))
}

fn roads_of(rows: &[Vec<String>], track: &str) -> String {
    let r: Vec<&str> = rows
        .iter()
        .filter(|r| r[0] == track)
        .map(|r| r[2].as_str())
        .collect();
    r.join(",")
}

#[test]
fn fmm_example_under_the_independent_model_is_fmms_committed_result() {
    for extra in [&[][..], &["--radius-m", "100"][..]] {
        let mut args = vec!["--truth".to_owned(), data("fmm-truth.csv")];
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (json, rows, _) = run(
            "fmm-network.geojson",
            "fmm-trips.geojson",
            "independent",
            &args,
        );
        assert_eq!(json["matched_share"], 1.0);
        assert_eq!(json["path_pieces"], 3);
        // FMM's cpath (mr.txt), edge by edge, in driving order.
        for (track, cpath) in [
            ("1", "2,5,13,14,23"),
            ("2", "25,4,3,5,17,19"),
            ("3", "8,11,13,18,20,24"),
        ] {
            assert_eq!(roads_of(&rows, track), cpath, "trip {track} {extra:?}");
        }
        // As the default model's: 1 to rounding (tests/it/cli_match_real.rs).
        let s = &json["score"];
        assert!(s["precision_length"].as_f64().unwrap() >= 0.999, "{s}");
        assert!(s["recall_length"].as_f64().unwrap() >= 0.999, "{s}");
    }
}

#[test]
fn graphhopper_traces_under_the_independent_model() {
    // Issue 70: GraphHopper's three expected streets, in order.
    let (json, rows, matched) = run(
        "issue-70.osm",
        "issue-70.gpx",
        "independent",
        &["--truth", &data("issue-70-truth.csv")],
    );
    assert_eq!(json["matched_share"], 1.0);
    assert_eq!(json["breaks"].as_array().unwrap().len(), 0);
    assert_eq!(roads_of(&rows, "1"), "263190269,115389243,190958702");
    let s = &json["score"];
    assert_eq!(s["precision_length"].as_f64().unwrap(), 1.0, "{s}");
    assert_eq!(s["recall_count"].as_f64().unwrap(), 1.0, "{s}");
    // The points' roads are the default model's, point by point; the
    // confidences are a filtered probability, in 0..=1.
    let (default_json, _, default) = run("issue-70.osm", "issue-70.gpx", "drift", &[]);
    // The JSON says which model ran.
    assert_eq!(json["model"], "independent");
    assert_eq!(default_json["model"], "drift");
    assert_eq!(matched.len(), 18, "a header and 17 points");
    assert_eq!(matched.len(), default.len());
    let col = |name: &str| matched[0].iter().position(|c| c == name).unwrap();
    let (road, conf) = (col("road_id"), col("confidence"));
    for (a, b) in matched.iter().zip(&default).skip(1) {
        assert_eq!(a[road], b[road]);
        let c: f64 = a[conf].parse().unwrap();
        assert!((0.0..=1.0).contains(&c), "{c}");
    }

    // Issue 13 (identical timestamps): the trace's length within 5 m, as the
    // default model's test; issue 127 (two identical points): length 0.
    let (json, _, _) = run("issue-13.osm", "issue-13.gpx", "independent", &[]);
    assert_eq!(json["matched_share"], 1.0);
    assert_eq!(json["path_pieces"], 1);
    let len = json["path_length_m"].as_f64().unwrap();
    assert!((len - 237.5).abs() <= 5.0, "{len}");
    let (json, rows, _) = run("issue-13.osm", "issue-127.gpx", "independent", &[]);
    assert_eq!(json["matched"], 2);
    assert_eq!(json["path_length_m"], 0.0);
    assert!(rows.is_empty());
}

#[test]
fn a_bad_model_is_a_usage_error_naming_the_option() {
    let (m, t) = (data("issue-70.osm"), data("issue-70.gpx"));
    for bad in ["magic", "", "Independent "] {
        let out = waymark(&["match", "--map", &m, "--track", &t, "--model", bad]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        let first = stderr.lines().next().unwrap_or_default();
        assert!(
            first.starts_with("error:") && first.contains("--model"),
            "{stderr}"
        );
        assert!(stderr.contains("drift, independent"), "{stderr}");
    }
}
