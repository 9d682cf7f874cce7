//! Bad values inside input files other than the scenario (tag files,
//! tracks, maps, `planner.destinations`) through the real binary: one
//! error line naming the file and the value, printed short (`1e300`, not
//! 301 digits), exit code 1, and no wrong diagnosis.

use crate::common;

use common::{fails_with, repo, run};
use std::path::Path;

/// The Helsinki map, as an argument.
fn helsinki() -> String {
    repo("maps/helsinki.osm.pbf").display().to_string()
}

#[test]
fn absurd_numbers_in_input_files_print_short() {
    // Each of these printed the refused value with all its digits (lat
    // 1e300: 301 of them), in a line of over 300 characters.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let check = |out: &std::process::Output, needles: &[&str]| {
        let e = fails_with(out, needles);
        assert!(e.len() < 300, "{e}");
    };
    // A tag file (simulate --tags).
    let demo = std::fs::read_to_string(repo("scenarios/demo.toml"))
        .unwrap()
        .replace("../maps/helsinki.osm.pbf", &helsinki());
    std::fs::write(d.join("demo.toml"), demo).unwrap();
    std::fs::write(
        d.join("tags.csv"),
        "tag_id,lat,lon,mounting\nA,1e300,24.94,road_surface\n",
    )
    .unwrap();
    check(
        &run(
            &["simulate", "demo.toml", "--tags", "tags.csv", "--out", "o"],
            d,
        ),
        &["tags.csv: line 2", "lat 1e300"],
    );
    std::fs::write(
        d.join("tags.csv"),
        "tag_id,lat,lon,mounting,height_m\nA,60.17,24.94,road_surface,-1e300\n",
    )
    .unwrap();
    check(
        &run(
            &["simulate", "demo.toml", "--tags", "tags.csv", "--out", "o"],
            d,
        ),
        &["tags.csv: line 2", "height_m -1e300"],
    );
    assert!(!d.join("o").exists());
    // Tracks: CSV, GeoJSON, GPX (the gpx crate's own message).
    std::fs::write(
        d.join("t.csv"),
        "t_s,lat,lon\n0,1e300,24.94\n1,60.17,24.94\n",
    )
    .unwrap();
    std::fs::write(
        d.join("t.geojson"),
        r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},
        "geometry":{"type":"LineString","coordinates":[[24.94,1e300],[24.941,60.171]]}}]}"#,
    )
    .unwrap();
    std::fs::write(
        d.join("t.gpx"),
        r#"<?xml version="1.0"?><gpx version="1.1" creator="x"><trk><trkseg>
        <trkpt lat="1e300" lon="24.94"><time>2020-01-01T00:00:00Z</time></trkpt>
        <trkpt lat="60.171" lon="24.941"><time>2020-01-01T00:00:01Z</time></trkpt>
        </trkseg></trk></gpx>"#,
    )
    .unwrap();
    for track in ["t.csv", "t.geojson", "t.gpx"] {
        check(
            &run(
                &[
                    "match",
                    "--map",
                    &helsinki(),
                    "--track",
                    track,
                    "--out",
                    "m.csv",
                ],
                d,
            ),
            &[track, "1e300"],
        );
    }
    assert!(!d.join("m.csv").exists());
    // Maps: GeoJSON and OSM XML.
    std::fs::write(
        d.join("map.geojson"),
        r#"{"type":"FeatureCollection","features":[{"type":"Feature",
        "properties":{"highway":"residential"},
        "geometry":{"type":"LineString","coordinates":[[24.9,60.1],[1e300,60.1]]}}]}"#,
    )
    .unwrap();
    let osm = std::fs::read_to_string(repo("tests/data/small.osm")).unwrap();
    let at = osm.find("lat=\"").unwrap() + 5;
    let end = at + osm[at..].find('"').unwrap();
    std::fs::write(
        d.join("map.osm"),
        format!("{}1e300{}", &osm[..at], &osm[end..]),
    )
    .unwrap();
    for map in ["map.geojson", "map.osm"] {
        check(
            &run(&["network", "inspect", map], d),
            &[map, "coordinate out of range", "1e300"],
        );
    }
}

/// A ladder of six two-way residential roads about 1 km across (south of
/// Helsinki), each named `name`, written to `dir/lad.geojson`.
fn ladder(dir: &Path, name: &str) {
    let mut roads = Vec::new();
    for k in 0..4 {
        let lon = 24.90 + 0.005 * f64::from(k);
        roads.push([[lon, 60.10], [lon, 60.11]]);
    }
    roads.push([[24.90, 60.10], [24.915, 60.10]]);
    roads.push([[24.90, 60.11], [24.915, 60.11]]);
    let features: Vec<String> = roads
        .iter()
        .enumerate()
        .map(|(i, r)| {
            format!(
                r#"{{"type":"Feature","id":{},"properties":{{"highway":"residential","name":{}}},
                "geometry":{{"type":"LineString","coordinates":[[{},{}],[{},{}]]}}}}"#,
                i + 1,
                serde_json::to_string(name).unwrap(),
                r[0][0],
                r[0][1],
                r[1][0],
                r[1][1]
            )
        })
        .collect();
    std::fs::write(
        dir.join("lad.geojson"),
        format!(
            r#"{{"type":"FeatureCollection","features":[{}]}}"#,
            features.join(",")
        ),
    )
    .unwrap();
}

/// [`ladder`] and a trips scenario planning it with the destinations
/// `dest.csv`, written to `dir/s.toml`.
fn ladder_trips(dir: &Path) {
    ladder(dir, "Ladder Road");
    std::fs::write(
        dir.join("s.toml"),
        "name = \"ladder\"\nrequirement_m = 20.0\n[map]\npath = \"lad.geojson\"\n\
         [navigator]\nmode = \"integrated\"\n[imu]\ngrade = \"industrial\"\nrate_hz = 100\n\
         [odometer]\nscale_factor_error = 0.005\nnoise_mps = 0.02\npulse_m = 0.02\n\
         [aiding]\nodometer = true\nbaro = true\nrfid = true\nmap_matching = true\n\
         [rfid]\nread_probability = 0.977\n\
         [planner]\ncoverage = \"network\"\ntraffic = \"trips\"\ndestinations = \"dest.csv\"\n\
         tolerate_missed_reads = 1\nmountings = [\"road_surface\", \"roadside\"]\n",
    )
    .unwrap();
}

#[test]
fn destinations_need_finite_weights_and_two_places() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ladder_trips(d);
    let plan = |dest: &str| {
        std::fs::write(d.join("dest.csv"), dest).unwrap();
        run(&["plan", "s.toml", "--runs", "0", "--out", "o", "-q"], d)
    };
    // Two weights of 1e308 added up to infinity: every trip then started at
    // one destination and the plan failed with "the destinations are not
    // connected by permitted roads".
    let e = fails_with(
        &plan("lat,lon,weight\n60.1,24.9,1e308\n60.11,24.915,1e308\n"),
        &[
            "dest.csv: line 2",
            "weight 1e308",
            "between 0 and 1000000000",
        ],
    );
    assert!(!e.contains("connected"), "{e}");
    // Two destinations at one place, and one of two with a weight of -0
    // (as good as 0): no trip to drive, not a map that is not connected.
    for dest in [
        "lat,lon\n60.1,24.9\n60.1,24.9\n",
        "lat,lon,weight\n60.1,24.9,-0\n60.11,24.915,1\n",
    ] {
        let e = fails_with(
            &plan(dest),
            &[
                "dest.csv: trips need at least two destinations",
                "different places",
            ],
        );
        assert!(!e.contains("connected"), "{e}");
    }
    // A coordinate: the file first, the number short.
    let e = fails_with(
        &plan("lat,lon\n1e300,24.9\n60.11,24.915\n"),
        &["dest.csv: line 2", "(1e300, 24.9)"],
    );
    assert!(e.len() < 300, "{e}");
    assert!(!d.join("o").exists());
    // The same file with ordinary weights plans.
    let out = plan("lat,lon,weight\n60.1,24.9,2\n60.11,24.915,1\n");
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(d.join("o/plan.json").exists());
}

#[test]
fn a_score_with_no_true_road_matched_is_zero_not_negative_zero() {
    // `Iterator::sum` of no f64 is -0.0: a truth road the track never
    // drove printed "precision_length -0.0000" (and -0.0 in the JSON).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("t.csv"),
        "t_s,lat,lon\n0,60.17,24.94\n1,60.171,24.941\n",
    )
    .unwrap();
    std::fs::write(d.join("truth.csv"), "road_id\n675858715\n").unwrap();
    let out = run(
        &[
            "match",
            "--map",
            &helsinki(),
            "--track",
            "t.csv",
            "--truth",
            "truth.csv",
            "--json",
        ],
        d,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let score = &v["score"];
    assert_eq!(score["correct_roads"], 0, "{score}");
    for k in ["precision_length", "recall_length"] {
        let x = score[k].as_f64().unwrap();
        assert!(x == 0.0 && x.is_sign_positive(), "{k} = {x}");
    }
    assert!(stderr.contains("precision_length 0.0000"), "{stderr}");
    assert!(!stderr.contains("-0.0"), "{stderr}");
}

#[test]
fn a_road_name_with_control_characters_keeps_the_error_on_one_line() {
    // A map's road name with a line break and an escape sequence, quoted
    // by an infeasible plan's error: two lines, and the terminal's colour
    // changed.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ladder(d, "Evil\nRoad\u{1b}[31mRed");
    std::fs::write(
        d.join("r.toml"),
        "name = \"ladder\"\nrequirement_m = 3.0\n[map]\npath = \"lad.geojson\"\n\
         [[route]]\nwaypoints = [[60.100, 24.915], [60.110, 24.900]]\nspeed_kmh = 40\n\
         [navigator]\nmode = \"integrated\"\n[imu]\ngrade = \"industrial\"\nrate_hz = 100\n\
         [aiding]\nrfid = true\n[planner]\nmin_spacing_m = 1e9\n",
    )
    .unwrap();
    let out = run(&["plan", "r.toml", "--runs", "0", "--out", "o", "-q"], d);
    let e = fails_with(&out, &["infeasible", "\"Evil Road [31mRed\""]);
    assert!(!e.contains('\u{1b}'), "{e:?}");
}

#[test]
fn absurd_track_times_are_refused_at_their_line() {
    // A time of 1e300 s (or of the year 9999) was taken as it was: the
    // matcher's gaps and speeds then came from a time no track holds.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let matched = |track: &str| {
        run(
            &[
                "match",
                "--map",
                &helsinki(),
                "--track",
                track,
                "--out",
                "m.csv",
            ],
            d,
        )
    };
    let gpx = |t: &str| {
        format!(
            r#"<?xml version="1.0"?><gpx version="1.1" creator="x"><trk><trkseg>
        <trkpt lat="60.17" lon="24.94"><time>2020-01-01T00:00:00Z</time></trkpt>
        <trkpt lat="60.171" lon="24.941"><time>{t}</time></trkpt>
        </trkseg></trk></gpx>"#
        )
    };
    let geojson = |times: &str, fourth: &str| {
        format!(
            r#"{{"type":"FeatureCollection","features":[{{"type":"Feature",
            "properties":{{{times}}},
            "geometry":{{"type":"LineString","coordinates":[[24.94,60.17,0,0],[24.941,60.171,0,{fourth}]]}}}}]}}"#
        )
    };
    for (name, text, needles) in [
        // CSV: read whole (interleaved tracks) and streamed.
        (
            "t.csv",
            "t_s,lat,lon\n0,60.17,24.94\n1e300,60.171,24.941\n".to_string(),
            vec!["t.csv:3", "t_s 1e300", "1e11"],
        ),
        (
            "t.csv",
            "t_s,lat,lon,track_id\n-1e300,60.17,24.94,a\n0,60.17,24.94,b\n1,60.171,24.941,a\n"
                .to_string(),
            vec!["t.csv:2", "t_s -1e300", "1e11"],
        ),
        (
            "t.csv",
            "t_s,lat,lon\n0,60.17,24.94\n300000000000,60.171,24.941\n".to_string(),
            vec!["t.csv:3", "t_s 300000000000", "1e11"],
        ),
        (
            "t.csv",
            "t_s,lat,lon\n-inf,60.17,24.94\n1,60.171,24.941\n".to_string(),
            vec!["t.csv:2", "t_s", "-inf"],
        ),
        (
            "t.gpx",
            gpx("9999-12-31T23:59:59Z"),
            vec!["t.gpx", "point 2", "1e11"],
        ),
        (
            "t.geojson",
            geojson("", "1e300"),
            vec!["t.geojson", "point 2", "1e300", "1e11"],
        ),
        (
            "t.geojson",
            geojson(r#""times":[0, 1e300]"#, "0"),
            vec!["t.geojson", "point 2", "1e300", "1e11"],
        ),
        (
            "t.geojson",
            geojson(r#""times":["0", "-1e300"]"#, "0"),
            vec!["t.geojson", "point 2", "-1e300", "1e11"],
        ),
    ] {
        std::fs::write(d.join(name), &text).unwrap();
        let e = fails_with(&matched(name), &needles);
        assert!(e.len() < 300, "{e}");
        assert!(!d.join("m.csv").exists(), "{text}");
    }
    // Times at the limit's scale, as ordinary Unix times, still match.
    for (name, text) in [
        (
            "t.csv",
            "t_s,lat,lon\n1700000000,60.17,24.94\n1700000001,60.171,24.941\n".to_string(),
        ),
        ("t.gpx", gpx("2020-01-01T00:01:00Z")),
        ("t.geojson", geojson("", "60")),
    ] {
        std::fs::write(d.join(name), &text).unwrap();
        let out = matched(name);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::remove_file(d.join("m.csv")).unwrap();
    }
}
