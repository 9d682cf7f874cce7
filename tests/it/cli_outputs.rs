//! Output paths and option values as a user hits them (issue 17, point 4):
//! every command checks its output path before working, `match --out`
//! creates its folder like `simulate --out`, and a bad option value exits 2.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

/// Exit 0, or the failure's stderr.
fn succeeded(out: &Output) {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
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

#[test]
fn a_network_plan_into_its_scenarios_folder_keeps_the_scenario() {
    // The scenario is the folder's own scenario.toml (the copy an earlier
    // run kept, edited and planned again into the same folder): clearing
    // the earlier outputs deleted it before it was copied, and the plan
    // failed with the user's scenario gone.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (scn, text) = area_scenario(d);
    for _ in 0..2 {
        let out = run(
            &["plan", "area/scenario.toml", "--out", "area", "--runs", "0"],
            d,
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{stderr}");
        assert_eq!(std::fs::read_to_string(&scn).unwrap(), text);
        assert!(d.join("area/plan.json").exists() && d.join("area/inputs.json").exists());
    }
}

#[test]
fn a_route_plan_over_an_area_plan_leaves_no_coverage_behind() {
    // The area plan's coverage.geojson stayed beside a route plan written
    // into the same folder, and `report` drew it on the route plan's page.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    area_scenario(d);
    let out = run(
        &["plan", "area/scenario.toml", "--out", "f", "--runs", "0"],
        d,
    );
    succeeded(&out);
    assert!(
        d.join("f/coverage.geojson").exists(),
        "the area plan writes it"
    );
    let out = run(
        &["plan", &scenario("demo.toml"), "--out", "f", "--runs", "0"],
        d,
    );
    succeeded(&out);
    assert!(
        !d.join("f/coverage.geojson").exists(),
        "left beside a route plan"
    );
    let out = run(&["report", "f"], d);
    succeeded(&out);
    let page = std::fs::read_to_string(d.join("f/report.html")).unwrap();
    assert!(
        !page.contains("class=\"coverage\""),
        "the route plan's page draws coverage"
    );
}

/// A small area plan's scenario at `area/scenario.toml` (any walk on
/// tests/data/small.osm) and its text.
fn area_scenario(d: &Path) -> (PathBuf, String) {
    std::fs::create_dir(d.join("area")).unwrap();
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
    let text = format!(
        "name = \"area\"\nrequirement_m = 20.0\n[map]\npath = \"{}\"\n\
         [navigator]\nmode = \"integrated\"\n\
         [imu]\nrate_hz = 100\ngyro_bias_dph = [10, 10, 10]\naccel_bias_ug = [1000, 1000, 1000]\n\
         gyro_arw_dprh = 0.3\naccel_vrw_ugprhz = 100\n\
         [odometer]\nscale_factor_error = 0.01\nnoise_mps = 0.02\npulse_m = 0.02\n\
         [aiding]\nodometer = true\nbaro = true\nrfid = true\n\
         [planner]\ncoverage = \"network\"\ntraffic = \"any_walk\"\ntolerate_missed_reads = 1\n",
        map.display()
    );
    let scn = d.join("area/scenario.toml");
    std::fs::write(&scn, &text).unwrap();
    (scn, text)
}

#[test]
fn an_input_among_the_files_a_command_replaces_is_refused() {
    // Planning again with the installed tags read from the earlier plan's
    // own folder (`existing_tags = "plan/tags.csv"`, `--out plan`) replaced
    // them with the new plan's tags.csv: 0 new tags, so the installed tags
    // were gone and the file held a header alone.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let demo = std::fs::read_to_string(scenario("demo.toml"))
        .unwrap()
        .replace("../maps/", &format!("{}/maps/", env!("CARGO_MANIFEST_DIR")));
    std::fs::write(d.join("demo.toml"), &demo).unwrap();
    succeeded(&run(
        &["plan", "demo.toml", "--out", "plan", "--runs", "0", "-q"],
        d,
    ));
    let installed = std::fs::read_to_string(d.join("plan/tags.csv")).unwrap();
    assert!(installed.lines().count() > 1, "{installed}");
    std::fs::write(
        d.join("again.toml"),
        demo.replace(
            "[planner]\n",
            "[planner]\nexisting_tags = \"plan/tags.csv\"\n",
        ),
    )
    .unwrap();
    let one_line = |out: &Output, needles: &[&str]| {
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        for n in needles {
            assert!(stderr.contains(n), "{n:?} not in {stderr}");
        }
    };
    one_line(
        &run(&["plan", "again.toml", "--out", "plan", "--runs", "0"], d),
        &[
            "plan/tags.csv: planner.existing_tags",
            "output folder's tags.csv",
            "choose another --out",
        ],
    );
    assert_eq!(
        std::fs::read_to_string(d.join("plan/tags.csv")).unwrap(),
        installed
    );
    // Into another folder it plans, keeping the installed tags.
    succeeded(&run(
        &["plan", "again.toml", "--out", "plan2", "--runs", "0", "-q"],
        d,
    ));
    // simulate --tags: a file the simulation writes in its folder.
    std::fs::create_dir(d.join("sim")).unwrap();
    std::fs::write(d.join("sim/errors.csv"), &installed).unwrap();
    one_line(
        &run(
            &[
                "simulate",
                "demo.toml",
                "--tags",
                "sim/errors.csv",
                "--out",
                "sim",
            ],
            d,
        ),
        &["sim/errors.csv: --tags", "output folder's errors.csv"],
    );
    assert_eq!(
        std::fs::read_to_string(d.join("sim/errors.csv")).unwrap(),
        installed
    );
}

#[test]
fn a_match_whose_later_output_fails_leaves_no_output() {
    // `--out m.csv --path P` where P could not be written (a folder's name,
    // a name too long for a file): m.csv was written and left behind, and a
    // missing folder on the way to P was created.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("track.csv"), TRACK).unwrap();
    // The same fixes as GPX: read whole, not streamed.
    std::fs::write(
        d.join("track.gpx"),
        "<?xml version=\"1.0\"?><gpx version=\"1.1\" creator=\"x\"><trk><trkseg>\
         <trkpt lat=\"60.16987\" lon=\"24.93838\"><time>2020-01-01T00:00:00Z</time></trkpt>\
         <trkpt lat=\"60.17011\" lon=\"24.93819\"><time>2020-01-01T00:00:01Z</time></trkpt>\
         <trkpt lat=\"60.17036\" lon=\"24.93800\"><time>2020-01-01T00:00:02Z</time></trkpt>\
         </trkseg></trk></gpx>",
    )
    .unwrap();
    let map = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("maps/helsinki.osm.pbf")
        .display()
        .to_string();
    // 256 bytes, one past the file systems' limit (a name of 250 is
    // written: its temporary name is cut short).
    let long = format!("{}.csv", "p".repeat(252));
    let listing = || {
        let mut names: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    let before = listing();
    for track in ["track.csv", "track.gpx"] {
        for option in ["--path", "--path-geojson"] {
            for (target, needle) in [
                ("sub/..", "sub/.."),
                ("p.csv/", "p.csv/"),
                ("new/p.csv/", "new/p.csv/"),
                (long.as_str(), "ppppp"),
            ] {
                let args = [
                    "match", "--map", &map, "--track", track, "--out", "m.csv", option, target,
                ];
                let out = run(&args, d);
                let stderr = String::from_utf8_lossy(&out.stderr);
                assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
                assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
                assert!(stderr.contains(needle), "{args:?}: {stderr}");
                assert_eq!(listing(), before, "{args:?}: {stderr}");
            }
        }
        // An earlier output of the same name is left as it was.
        std::fs::write(d.join("m.csv"), "old").unwrap();
        let out = run(
            &[
                "match",
                "--map",
                &map,
                "--track",
                track,
                "--out",
                "m.csv",
                "--path",
                "p.csv",
                "--path-geojson",
                &long,
            ],
            d,
        );
        assert_eq!(out.status.code(), Some(1));
        assert_eq!(std::fs::read_to_string(d.join("m.csv")).unwrap(), "old");
        assert!(!d.join("p.csv").exists());
        std::fs::remove_file(d.join("m.csv")).unwrap();
        // All three written when they can be.
        let out = run(
            &[
                "match",
                "--map",
                &map,
                "--track",
                track,
                "--out",
                "m.csv",
                "--path",
                "a/p.csv",
                "--path-geojson",
                "a/p.geojson",
            ],
            d,
        );
        succeeded(&out);
        for f in ["m.csv", "a/p.csv", "a/p.geojson"] {
            assert!(d.join(f).is_file(), "{f}");
        }
        std::fs::remove_dir_all(d.join("a")).unwrap();
        std::fs::remove_file(d.join("m.csv")).unwrap();
    }
}
