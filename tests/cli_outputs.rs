//! Output paths and option values as a user hits them (issue 17, point 4):
//! every command checks its output path before working, `match --out`
//! creates its folder like `simulate --out`, and a bad option value exits 2.

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

fn scenario(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn runs_zero_is_a_bad_option_value_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        &[
            "simulate",
            &scenario("dr-straight-10km.toml"),
            "--runs",
            "0",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--runs"), "{stderr}");
    assert!(!dir.path().join("waymark-simulate").exists());
}

#[test]
fn an_output_folder_that_is_a_file_fails_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("taken"), "a file").unwrap();
    for args in [
        vec![
            "plan",
            &scenario("demo.toml"),
            "--out",
            "taken",
            "--runs",
            "0",
        ],
        vec![
            "simulate",
            &scenario("dr-straight-10km.toml"),
            "--out",
            "taken",
        ],
    ] {
        let out = run(&args, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("taken") && stderr.contains("not a folder"),
            "{stderr}"
        );
        // Before any work: the error is the only line, so no step's progress
        // note ("covariance analysis along the route", ...) came before it.
        assert_eq!(
            std::fs::read_to_string(dir.path().join("taken")).unwrap(),
            "a file"
        );
    }
}

#[test]
fn match_out_creates_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    // Three fixes on Mannerheimintie in central Helsinki.
    std::fs::write(
        dir.path().join("track.csv"),
        "t_s,lat,lon\n0,60.16987,24.93838\n1,60.17011,24.93819\n2,60.17036,24.93800\n",
    )
    .unwrap();
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    let out = run(
        &[
            "match",
            "--map",
            &map.display().to_string(),
            "--track",
            "track.csv",
            "--out",
            "a/b/matched.csv",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let text = std::fs::read_to_string(dir.path().join("a/b/matched.csv")).unwrap();
    assert_eq!(text.lines().count(), 4, "{text}");
}

/// Three fixes on Mannerheimintie in central Helsinki.
const TRACK: &str = "t_s,lat,lon\n0,60.16987,24.93838\n1,60.17011,24.93819\n2,60.17036,24.93800\n";

#[test]
fn match_refuses_an_output_that_is_an_input_or_another_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("track.csv"), TRACK).unwrap();
    std::fs::write(d.join("truth.csv"), "road_id\n").unwrap();
    let map = d.join("map.osm.pbf");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf"),
        &map,
    )
    .unwrap();
    let map_bytes = std::fs::read(&map).unwrap();
    let base = ["match", "--map", "map.osm.pbf", "--track", "track.csv"];
    for (extra, file, option) in [
        (vec!["--out", "track.csv"], "track.csv", "--track"),
        (vec!["--out", "./map.osm.pbf"], "map.osm.pbf", "--map"),
        (
            vec![
                "--out",
                "m.csv",
                "--truth",
                "truth.csv",
                "--path",
                "truth.csv",
            ],
            "truth.csv",
            "--truth",
        ),
        (
            vec!["--out", "m.csv", "--path-geojson", "track.csv"],
            "track.csv",
            "--track",
        ),
        (vec!["--out", "m.csv", "--path", "m.csv"], "m.csv", "--out"),
        (
            vec![
                "--out",
                "m.csv",
                "--path",
                "p.csv",
                "--path-geojson",
                "p.csv",
            ],
            "p.csv",
            "--path",
        ),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra.iter().copied()).collect();
        let out = run(&args, d);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains(file) && stderr.contains("the same file as the "),
            "{args:?}: {stderr}"
        );
        assert!(stderr.contains(option), "{args:?}: {stderr}");
        // The inputs are intact and no output was written.
        assert_eq!(std::fs::read_to_string(d.join("track.csv")).unwrap(), TRACK);
        assert_eq!(
            std::fs::read_to_string(d.join("truth.csv")).unwrap(),
            "road_id\n"
        );
        assert_eq!(std::fs::read(&map).unwrap(), map_bytes);
        assert!(!d.join("m.csv").exists() && !d.join("p.csv").exists());
    }
    // The default --out (matched.csv) is checked too.
    std::fs::write(d.join("matched.csv"), TRACK).unwrap();
    let out = run(
        &["match", "--map", "map.osm.pbf", "--track", "matched.csv"],
        d,
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(d.join("matched.csv")).unwrap(),
        TRACK
    );
}
