//! `waymark match` as a user runs it: the real binary in a temporary folder,
//! on tracks driven along routes of the bundled Helsinki map, and on bad input.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use waymark::matching::{along_route, TrackModel};
use waymark::network::{LoadOptions, Network};
use waymark::route::plan_route;

fn map() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf")
}

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

fn match_args<'a>(track: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "match",
        "--map",
        MAP.get_or_init(|| map().display().to_string()),
        "--track",
        track,
    ];
    v.extend_from_slice(extra);
    v
}

static MAP: std::sync::OnceLock<String> = std::sync::OnceLock::new();

/// A clean failure: exit code 1, one line on stderr naming `file` and containing `needle`.
fn assert_clean_error(out: &Output, file: &str, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains(file), "{stderr}");
    assert!(stderr.contains(needle), "{stderr}");
}

/// TRACK.csv and TRUTH.csv text for a drive across Helsinki with drift (30 m)
/// and noise (2 m) at 5 m spacing.
fn drive(with_heading: bool) -> (String, String, usize) {
    let net = Network::load(&map(), &LoadOptions::default()).unwrap();
    let route = plan_route(&net, &[[60.1660, 24.9380], [60.1770, 24.9510]]).unwrap();
    let track = along_route(
        &net,
        &route,
        &TrackModel {
            spacing_m: 5.0,
            speed_mps: 10.0,
            drift_max_m: 30.0,
            noise_sigma_m: 2.0,
            heading_sigma_deg: with_heading.then_some(5.0),
            seed: 21,
        },
    );
    let mut csv = String::from("t_s,lat,lon");
    if with_heading {
        csv.push_str(",heading_deg");
    }
    csv.push('\n');
    for f in &track.fixes {
        let g = net.frame.to_geodetic([f.enu[0], f.enu[1], 0.0]);
        let _ = write!(csv, "{:.2},{:.8},{:.8}", f.t_s, g.lat_deg(), g.lon_deg());
        if let Some(h) = f.heading_rad {
            let _ = write!(csv, ",{:.1}", h.to_degrees());
        }
        csv.push('\n');
    }
    let mut truth = String::from("road_id,length_m\n");
    for (r, l) in &track.truth {
        let _ = writeln!(truth, "{r},{l:.2}");
    }
    (csv, truth, track.fixes.len())
}

fn number_after(text: &str, key: &str) -> f64 {
    let i = text.find(key).unwrap_or_else(|| panic!("{key} in {text}")) + key.len();
    text[i..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn matches_a_drive_and_scores_it_against_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, truth, n) = drive(false);
    std::fs::write(dir.path().join("track.csv"), csv).unwrap();
    std::fs::write(dir.path().join("truth.csv"), truth).unwrap();
    for method in ["hmm", "incremental"] {
        let out_name = format!("{method}.csv");
        let out = run(
            &match_args(
                "track.csv",
                &[
                    "--out",
                    &out_name,
                    "--method",
                    method,
                    "--truth",
                    "truth.csv",
                ],
            ),
            dir.path(),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{stderr}");
        eprintln!("{method}: {stderr}{stdout}");
        assert!(stderr.contains(&format!("{n} points")), "{stderr}");
        assert!(
            stderr.contains("matched") && stderr.contains("break"),
            "{stderr}"
        );
        let text = std::fs::read_to_string(dir.path().join(&out_name)).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "track_id,t_s,lat,lon,road_id,offset_m,distance_m,state,confidence"
        );
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        assert_eq!(rows.len(), n);
        assert!(rows.iter().all(|r| r.len() == 9));
        // Every point matched, within the drift plus noise of its road.
        assert!(rows.iter().all(|r| !r[4].is_empty()));
        let worst = rows
            .iter()
            .map(|r| r[6].parse::<f64>().unwrap())
            .fold(0.0, f64::max);
        assert!(worst < 50.0, "{worst}");
        let (p, r) = (
            number_after(&stdout, "precision_length"),
            number_after(&stdout, "recall_length"),
        );
        if method == "hmm" {
            assert!(p >= 0.95 && r >= 0.95, "{stdout}");
        } else {
            assert!(p >= 0.5 && r >= 0.5, "{stdout}");
        }
        // Nothing but the output was written.
        assert!(!std::fs::read_dir(dir.path()).unwrap().any(|e| e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .contains(".tmp")));
    }
}

#[test]
fn several_tracks_with_heading_keep_their_rows_and_order() {
    let dir = tempfile::tempdir().unwrap();
    let (a, _, n) = drive(true);
    // The same drive twice, rows interleaved, the second id quoted.
    let mut csv = String::from("track_id,t_s,lat,lon,heading_deg\n");
    for l in a.lines().skip(1) {
        for id in ["a", "\"b,1\""] {
            let _ = writeln!(csv, "{id},{l}");
        }
    }
    std::fs::write(dir.path().join("two.csv"), csv).unwrap();
    let out = run(&match_args("two.csv", &["--out", "m.csv"]), dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("2 track(s)"), "{stderr}");
    let text = std::fs::read_to_string(dir.path().join("m.csv")).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 2 * n);
    assert!(rows[0].starts_with("a,"));
    assert!(rows[1].starts_with("\"b,1\","));
    // The same drive matched the same way in both tracks.
    let road = |r: &str| r.rsplit(',').nth(4).unwrap().to_owned();
    let same = (0..n)
        .filter(|i| road(rows[2 * i]) == road(rows[2 * i + 1]))
        .count();
    assert_eq!(same, n);
}

#[test]
fn bad_input_gives_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, text: &str| std::fs::write(d.join(name), text).unwrap();
    write(
        "order.csv",
        "t_s,lat,lon\n0,60.17,24.94\n2,60.17,24.9401\n1,60.17,24.9402\n",
    );
    assert_clean_error(
        &run(&match_args("order.csv", &[]), d),
        "order.csv:4",
        "not in time order",
    );
    write("nan.csv", "t_s,lat,lon\n0,60.17,24.94\n1,NaN,24.9401\n");
    assert_clean_error(&run(&match_args("nan.csv", &[]), d), "nan.csv:3", "lat");
    write("cols.csv", "time,lat,lon\n0,60.17,24.94\n");
    assert_clean_error(
        &run(&match_args("cols.csv", &[]), d),
        "cols.csv:1",
        "missing column(s) t_s",
    );
    write("fields.csv", "t_s,lat,lon\n0,60.17\n");
    assert_clean_error(
        &run(&match_args("fields.csv", &[]), d),
        "fields.csv:2",
        "2 fields",
    );
    write("range.csv", "t_s,lat,lon\n0,95,24.94\n");
    assert_clean_error(
        &run(&match_args("range.csv", &[]), d),
        "range.csv:2",
        "out of range",
    );
    write("empty.csv", "");
    assert_clean_error(&run(&match_args("empty.csv", &[]), d), "empty.csv", "empty");
    write("header.csv", "t_s,lat,lon\n");
    assert_clean_error(
        &run(&match_args("header.csv", &[]), d),
        "header.csv",
        "no data rows",
    );
    assert_clean_error(
        &run(&match_args("missing.csv", &[]), d),
        "missing.csv",
        "No such file",
    );
    // Entirely off the map (Stockholm): an error, no output file.
    write("off.csv", "t_s,lat,lon\n0,59.33,18.06\n1,59.33,18.0601\n");
    let out = run(&match_args("off.csv", &["--out", "off-out.csv"]), d);
    assert_clean_error(&out, "off.csv", "no point lies within 100 m of a road");
    assert!(!d.join("off-out.csv").exists());
    // Truth naming a road not in the map.
    write(
        "ok.csv",
        "t_s,lat,lon\n0,60.1660,24.9380\n1,60.16601,24.93801\n",
    );
    write("truth.csv", "road_id\nnot-a-road\n");
    assert_clean_error(
        &run(&match_args("ok.csv", &["--truth", "truth.csv"]), d),
        "truth.csv:2",
        "not in the map",
    );
    // Output under a path that is a file (a missing folder is created since
    // issue 17: tests/it/cli_outputs.rs).
    let out = run(&match_args("ok.csv", &["--out", "ok.csv/m.csv"]), d);
    assert_clean_error(&out, "ok.csv", "not a folder");
    // Unknown method: clap's usage error.
    let out = run(&match_args("ok.csv", &["--method", "magic"]), d);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn partly_off_road_track_reports_the_unmatched_span() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, _, n) = drive(false);
    // Move rows 100..140 (200 m) 2 km south-east of the map's roads.
    let mut out_csv = String::new();
    for (i, l) in csv.lines().enumerate() {
        if (101..141).contains(&i) {
            let f: Vec<&str> = l.split(',').collect();
            let lat: f64 = f[1].parse::<f64>().unwrap() - 0.05;
            let lon: f64 = f[2].parse::<f64>().unwrap() + 0.2;
            let _ = writeln!(out_csv, "{},{lat:.8},{lon:.8}", f[0]);
        } else {
            let _ = writeln!(out_csv, "{l}");
        }
    }
    std::fs::write(dir.path().join("t.csv"), out_csv).unwrap();
    let out = run(&match_args("t.csv", &["--out", "m.csv"]), dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("unmatched span: lines 102-141"), "{stderr}");
    assert!(stderr.contains("break (off_road)"), "{stderr}");
    let text = std::fs::read_to_string(dir.path().join("m.csv")).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), n);
    for (i, r) in rows.iter().enumerate() {
        let unmatched = r.contains(",unmatched,");
        assert_eq!(unmatched, (100..140).contains(&i), "row {i}: {r}");
    }
}

#[test]
fn simulate_with_map_matching_reports_the_feed() {
    let dir = tempfile::tempdir().unwrap();
    let scn =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/helsinki-route-map-matching.toml");
    let out = run(
        &["simulate", scn.to_str().unwrap(), "--out", "sim"],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let fed = number_after(&stdout, "map matching (run 0): ");
    assert!(fed > 400.0, "{stdout}");
    assert!(dir.path().join("sim/summary.json").exists());
}

#[test]
fn a_truth_without_rows_or_with_an_absurd_length_is_refused() {
    // A header-only TRUTH.csv scored the path against nothing (every figure
    // 0/0, printed as -0.0000), and a length_m of 1e308 made the truth's
    // total infinite (recall by length 0, `truth_length_m` inf in the text
    // and null in --json), both with exit 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("ok.csv"),
        "t_s,lat,lon\n0,60.1660,24.9380\n1,60.16601,24.93801\n",
    )
    .unwrap();
    let write = |name: &str, text: &str| std::fs::write(d.join(name), text).unwrap();
    // A real road of the map: the one the track is on.
    let out = run(&match_args("ok.csv", &["--out", "m.csv"]), d);
    assert!(out.status.success());
    let matched = std::fs::read_to_string(d.join("m.csv")).unwrap();
    let road = matched.lines().nth(1).unwrap().split(',').nth(4).unwrap();
    write("header.csv", "road_id,length_m\n");
    let out = run(
        &match_args("ok.csv", &["--out", "m2.csv", "--truth", "header.csv"]),
        d,
    );
    assert_clean_error(&out, "header.csv:1", "no data rows");
    write(
        "huge.csv",
        &format!("road_id,length_m\n{road},1e308\n{road},1e308\n"),
    );
    let out = run(
        &match_args("ok.csv", &["--out", "m2.csv", "--truth", "huge.csv"]),
        d,
    );
    assert_clean_error(&out, "huge.csv:2", "length_m 1e308");
    assert!(!d.join("m2.csv").exists());
    // A plausible length is scored as before.
    write("fine.csv", &format!("road_id,length_m\n{road},2.5\n"));
    let out = run(
        &match_args("ok.csv", &["--out", "m2.csv", "--truth", "fine.csv"]),
        d,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_byte_that_is_not_utf8_is_reported_at_its_line() {
    // The error said line 0 ("track.csv:0: not UTF-8 text").
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("bad.csv"),
        b"t_s,lat,lon\n0,60.1660,24.9380\n1,60.16601\xff,24.93801\n",
    )
    .unwrap();
    let out = run(&match_args("bad.csv", &["--out", "m.csv"]), d);
    assert_clean_error(&out, "bad.csv:3:", "not UTF-8 text");
    std::fs::write(d.join("ok.csv"), "t_s,lat,lon\n0,60.1660,24.9380\n").unwrap();
    std::fs::write(d.join("truth.csv"), b"road_id\n\xfe\n").unwrap();
    let out = run(
        &match_args("ok.csv", &["--out", "m.csv", "--truth", "truth.csv"]),
        d,
    );
    assert_clean_error(&out, "truth.csv:2:", "not UTF-8 text");
}
