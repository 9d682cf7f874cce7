//! Absurd, huge and interrupted input as a user hits it (issue 17): every
//! case runs the real binary in a temporary folder and checks the exit
//! code, the one error line (naming the file, the field and the limit) and
//! what is left on disk.

use crate::common;

use common::{fails_with, succeeded_finite};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scenario(name: &str) -> String {
    root().join("scenarios").join(name).display().to_string()
}

/// The routed length (km) an error names: "... the route through its N
/// waypoints is X km ...".
fn routed_km(err: &str) -> f64 {
    err.split("waypoints is ")
        .nth(1)
        .and_then(|r| r.split(" km").next())
        .and_then(|k| k.parse().ok())
        .unwrap_or_else(|| panic!("the route's length in: {err}"))
}

/// A motion scenario with `extra` appended (sections after the route).
fn motion_scenario(dir: &Path, name: &str, motion: &str, extra: &str) -> String {
    let text = format!(
        "name = \"r\"\n[[route]]\nstart = {{ lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = 45.0 }}\n\
         motion = {motion}\n{extra}\n"
    );
    std::fs::write(dir.join(name), text).unwrap();
    name.to_string()
}

/// `simulate SCN --out o --json -q` in `dir`, which must succeed with
/// finite figures: its JSON.
fn simulate_json(dir: &Path, scn: &str) -> serde_json::Value {
    succeeded_finite(&run(&["simulate", scn, "--out", "o", "--json", "-q"], dir))
}

/// The demo scenario with its `[planner]` key `key` set to `value`, and its
/// map path made absolute.
fn demo_with(dir: &Path, key: &str, value: &str) -> String {
    let text = std::fs::read_to_string(root().join("scenarios/demo.toml")).unwrap();
    let map = root().join("maps/helsinki.osm.pbf");
    let mut text = text.replace("../maps/helsinki.osm.pbf", &map.display().to_string());
    text = text.replace("[planner]\n", &format!("[planner]\n{key} = {value}\n"));
    let lines: Vec<&str> = text.lines().collect();
    // The key must now appear once: drop the demo's own setting of it.
    let mut seen = false;
    let kept: Vec<&str> = lines
        .into_iter()
        .filter(|l| {
            if l.split('=').next().map(str::trim) == Some(key) {
                let first = !seen;
                seen = true;
                first
            } else {
                true
            }
        })
        .collect();
    std::fs::write(dir.join("demo.toml"), kept.join("\n")).unwrap();
    "demo.toml".into()
}

// --- 1. Limits before allocation ---------------------------------------------

#[test]
fn runs_beyond_the_limit_are_bad_option_values_for_simulate_and_plan() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        vec![
            "simulate",
            &scenario("dr-straight-10km.toml"),
            "--runs",
            "1000000000",
        ],
        vec!["plan", &scenario("demo.toml"), "--runs", "1000000000"],
    ] {
        let out = run(&args, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains("--runs") && stderr.contains("100000"),
            "{stderr}"
        );
        assert!(!stderr.contains("memory allocation"), "{stderr}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn planner_counts_beyond_their_limits_name_the_field_and_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    for (key, value, limit) in [
        ("validation_runs", "1000000000", "100000"),
        ("tolerate_missed_reads", "1000", "3"),
        ("refine_iterations", "100000", "100"),
    ] {
        let scn = demo_with(dir.path(), key, value);
        let out = run(&["plan", &scn, "--out", "p"], dir.path());
        let field = format!("planner.{key} = {value}");
        fails_with(&out, &["demo.toml", &field, "limit of", limit]);
        assert!(!dir.path().join("p").exists());
    }
}

#[test]
fn an_absurd_mounting_cost_is_refused_at_its_field() {
    // planner.cost.road_surface = 1e308 overflowed the plan's total cost to
    // inf, and the plan's check then blamed the covariance analysis and
    // [imu]. The limit is printed short (1e9), not as a 309-digit number.
    let dir = tempfile::tempdir().unwrap();
    let scn = demo_with(dir.path(), "cost", "{ road_surface = 1e308 }");
    let out = run(&["plan", &scn, "--out", "p"], dir.path());
    fails_with(
        &out,
        &[
            "demo.toml",
            "planner.cost.road_surface = 1e308",
            "limit of 1e9",
        ],
    );
    assert!(!dir.path().join("p").exists());
}

#[test]
fn a_plan_for_tags_that_are_never_read_is_refused() {
    // rfid.read_probability = 0 planned two tags that no run ever reads
    // and "validated" them as dead reckoning. Simulating such tags stays
    // allowed (what if every read fails?); planning them is refused.
    let dir = tempfile::tempdir().unwrap();
    let scn = demo_with(dir.path(), "tolerate_missed_reads", "1");
    let path = dir.path().join(&scn);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.contains("read_probability = 0.977"),
        "the demo changed"
    );
    std::fs::write(
        &path,
        text.replace("read_probability = 0.977", "read_probability = 0"),
    )
    .unwrap();
    let out = run(&["plan", &scn, "--out", "p"], dir.path());
    fails_with(
        &out,
        &["demo.toml", "road_surface tags are never read", "above 0"],
    );
    assert!(!dir.path().join("p").exists());
    let out = run(&["simulate", &scn, "--runs", "1", "--out", "s"], dir.path());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn rows_kept_in_memory_are_limited_before_the_runs_start() {
    // 23 days at a 10 ms output interval: 2e8 rows of one run, over the
    // 2e7-row limit (the motion commands' own limit is 30 days).
    let dir = tempfile::tempdir().unwrap();
    let scn = motion_scenario(
        dir.path(),
        "long.toml",
        "[ { kind = \"stay\", duration_s = 2000000 } ]",
        "output_interval_s = 0.01",
    );
    // `output_interval_s` must precede the tables: rewrite it at the top.
    let text = std::fs::read_to_string(dir.path().join(&scn)).unwrap();
    let text = format!(
        "output_interval_s = 0.01\n{}",
        text.replace("output_interval_s = 0.01\n", "")
    );
    std::fs::write(dir.path().join(&scn), text).unwrap();
    let out = run(&["simulate", &scn, "--out", "o"], dir.path());
    fails_with(
        &out,
        &["long.toml", "error rows", "20000000", "output_interval_s"],
    );
    assert!(!dir.path().join("o").exists());
    // Beyond 30 days of motion: refused by the motion compiler.
    let scn = motion_scenario(
        dir.path(),
        "longer.toml",
        "[ { kind = \"stay\", duration_s = 1e9 } ]",
        "",
    );
    let out = run(&["simulate", &scn, "--out", "o"], dir.path());
    fails_with(&out, &["longer.toml", "route[0]"]);
}

#[test]
fn a_route_plan_too_large_to_hold_is_refused_before_planning() {
    let dir = tempfile::tempdir().unwrap();
    let plan_scn = |name: &str, rate: &str, motion: &str, spacing: &str| {
        let text = format!(
            "name = \"p\"\nrequirement_m = 20\n[[route]]\n\
             start = {{ lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = 45.0 }}\n\
             motion = {motion}\n[navigator]\nmode = \"integrated\"\n[aiding]\nrfid = true\n\
             [imu]\nrate_hz = {rate}\n[planner]\ncandidate_spacing_m = {spacing}\n"
        );
        std::fs::write(dir.path().join(name), text).unwrap();
        name.to_string()
    };
    // 3000 s at 10 kHz: 3e7 truth samples, over the 1e7 limit.
    let scn = plan_scn(
        "samples.toml",
        "10000",
        "[ { kind = \"accelerate\", to_kmh = 36 }, { kind = \"cruise\", duration_s = 3000 } ]",
        "20",
    );
    let out = run(&["plan", &scn, "--out", "p"], dir.path());
    fails_with(&out, &["samples.toml", "truth samples", "10000000"]);
    // 300 km every metre: 3e5 candidate sites, over the 2e5 limit.
    let scn = plan_scn(
        "sites.toml",
        "100",
        "[ { kind = \"accelerate\", to_kmh = 100 }, { kind = \"cruise\", distance_m = 300000 } ]",
        "1",
    );
    let out = run(&["plan", &scn, "--out", "p"], dir.path());
    fails_with(
        &out,
        &[
            "sites.toml",
            "candidate sites",
            "200000",
            "candidate_spacing_m",
        ],
    );
    assert!(!dir.path().join("p").exists());
}

/// A network plan's candidate sites are counted on the loaded map, before
/// the planner enumerates them: the Gothenburg map (2,162 km of directed
/// road) cut every metre gives 2.2 M sites, over the 500,000 limit.
#[test]
fn a_network_plan_with_too_many_candidate_sites_is_refused_before_planning() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("scenarios/gothenburg-network-plan.toml"))
        .unwrap()
        .replace(
            "../maps/gothenburg-roads.geojson",
            &root()
                .join("maps/gothenburg-roads.geojson")
                .display()
                .to_string(),
        )
        .replace("candidate_spacing_m = 50", "candidate_spacing_m = 1");
    assert!(text.contains("candidate_spacing_m = 1\n"));
    std::fs::write(dir.path().join("g.toml"), text).unwrap();
    let out = run(&["plan", "g.toml", "--out", "p", "-q"], dir.path());
    let err = fails_with(
        &out,
        &[
            "g.toml",
            "candidate sites",
            "500000",
            "planner.candidate_spacing_m = 1",
        ],
    );
    // The count is the map's: about 2.2 million (1 m cuts of 2,162 km).
    let sites: f64 = err
        .split(" give ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{err}"));
    assert!((2.1e6..2.3e6).contains(&sites), "{err}");
    assert!(!dir.path().join("p").exists());
}

#[test]
fn an_imu_rate_beyond_the_limit_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let scn = motion_scenario(
        dir.path(),
        "rate.toml",
        "[ { kind = \"stay\", duration_s = 10 } ]",
        "[imu]\nrate_hz = 1e9",
    );
    let out = run(&["simulate", &scn], dir.path());
    fails_with(&out, &["rate.toml", "imu.rate_hz", "10000"]);
}

#[test]
fn files_beyond_their_size_limit_are_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    // Sparse files: their size costs no disk space.
    let sparse = |name: &str, head: &[u8], len: u64| {
        std::fs::write(dir.path().join(name), head).unwrap();
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(dir.path().join(name))
            .unwrap();
        f.set_len(len).unwrap();
    };
    sparse("big.toml", b"name = \"x\"\n", (16 << 20) + 1);
    let out = run(&["simulate", "big.toml"], dir.path());
    fails_with(&out, &["big.toml", "larger than the limit of 16 MiB"]);
    sparse("big.geojson", b"{", (1 << 30) + 1);
    let out = run(&["network", "inspect", "big.geojson"], dir.path());
    fails_with(&out, &["big.geojson", "larger than the limit of 1 GiB"]);
    sparse("tags.csv", b"tag_id,lat,lon,mounting\n", (256 << 20) + 1);
    let out = run(
        &[
            "simulate",
            &scenario("dr-straight-10km.toml"),
            "--tags",
            "tags.csv",
        ],
        dir.path(),
    );
    fails_with(&out, &["tags.csv", "larger than the limit of 256 MiB"]);
    // TRUTH.csv and planner.destinations were read whole without a limit
    // (`--truth /dev/zero` ran until memory ran out).
    let small = root().join("tests/data/small.osm").display().to_string();
    std::fs::write(
        dir.path().join("track.csv"),
        "t_s,lat,lon\n0,60.0,24.0005\n1,60.0,24.0015\n",
    )
    .unwrap();
    sparse("truth.csv", b"road_id\n", (512 << 20) + 1);
    let out = run(
        &[
            "match",
            "--map",
            &small,
            "--track",
            "track.csv",
            "--out",
            "m.csv",
            "--truth",
            "truth.csv",
        ],
        dir.path(),
    );
    fails_with(
        &out,
        &[
            "truth.csv",
            "the truth file is larger than the limit of 512 MiB",
        ],
    );
    assert!(!dir.path().join("m.csv").exists());
    sparse("dest.csv", b"lat,lon\n", (256 << 20) + 1);
    std::fs::write(
        dir.path().join("trips.toml"),
        format!(
            "name = \"t\"\nrequirement_m = 20.0\n[map]\npath = \"{small}\"\n\
             [navigator]\nmode = \"integrated\"\n[imu]\nrate_hz = 100\n\
             gyro_bias_dph = [10, 10, 10]\naccel_bias_ug = [1000, 1000, 1000]\n\
             [odometer]\nscale_factor_error = 0.01\n[aiding]\nodometer = true\nrfid = true\n\
             [planner]\ncoverage = \"network\"\ntraffic = \"trips\"\ndestinations = \"dest.csv\"\n"
        ),
    )
    .unwrap();
    let out = run(&["plan", "trips.toml", "--runs", "0", "-q"], dir.path());
    fails_with(
        &out,
        &[
            "dest.csv",
            "the destinations file is larger than the limit of 256 MiB",
        ],
    );
}

#[test]
fn an_endless_map_stops_at_its_first_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = std::time::Instant::now();
    let out = run(&["network", "inspect", "/dev/zero"], dir.path());
    fails_with(&out, &["/dev/zero", "unrecognised map format"]);
    // Not read to the limit (1 GiB): decided from the first 64 KiB.
    assert!(t0.elapsed().as_secs_f64() < 20.0);
}

// --- 2. No silent non-finite results -------------------------------------------

#[test]
fn an_empty_motion_list_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let scn = motion_scenario(dir.path(), "empty.toml", "[]", "");
    let out = run(&["simulate", &scn, "--out", "o"], dir.path());
    fails_with(&out, &["empty.toml", "route[0].motion is empty"]);
    assert!(!dir.path().join("o").exists());
}

#[test]
fn a_zero_length_map_route_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let map = root().join("maps/helsinki.osm.pbf");
    std::fs::write(
        dir.path().join("zero.toml"),
        format!(
            "name = \"z\"\n[map]\npath = \"{}\"\n[[route]]\n\
             waypoints = [[60.1660, 24.9380], [60.1660, 24.9380]]\n[navigator]\nmode = \"dead_reckoning\"\n",
            map.display()
        ),
    )
    .unwrap();
    let out = run(&["simulate", "zero.toml", "--out", "o"], dir.path());
    fails_with(&out, &["zero.toml", "route[0]", "shorter than 1 cm"]);
}

#[test]
fn fixed_length_arrays_of_a_scenario_refuse_extra_elements() {
    // The TOML reader dropped the elements beyond an array's length without
    // a word: a fourth accelerometer bias, a waypoint's third number (a
    // height?), a forbidden stretch [from, to, ...] were ignored.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let motion = "[ { kind = \"cruise\", duration_s = 10 } ]";
    for (name, extra, field, length) in [
        (
            "bias.toml",
            "[imu]\nrate_hz = 100\naccel_bias_ug = [0, 100, 0, 5]",
            "imu.accel_bias_ug",
            "invalid length 4, expected an array of length 3",
        ),
        (
            "bias2.toml",
            "[imu]\nrate_hz = 100\ngyro_bias_dph = [1]",
            "imu.gyro_bias_dph",
            "invalid length 1, expected an array of length 3",
        ),
        (
            "forbidden.toml",
            "[planner]\nforbidden_m = [[0, 100, 200]]",
            "planner.forbidden_m",
            "invalid length 3, expected an array of length 2",
        ),
        (
            "initial.toml",
            "[navigator]\nmode = \"free_inertial\"\ninitial_position_sigma_m = [1, 2, 3]",
            "navigator.initial_position_sigma_m",
            "invalid length 3, expected an array of length 2",
        ),
    ] {
        let scn = motion_scenario(d, name, motion, extra);
        let out = run(&["simulate", &scn, "--out", "o"], d);
        fails_with(&out, &[name, field, length]);
    }
    let map = root().join("maps/helsinki.osm.pbf");
    std::fs::write(
        d.join("waypoint.toml"),
        format!(
            "name = \"w\"\n[map]\npath = \"{}\"\n[[route]]\n\
             waypoints = [[60.1660, 24.9380], [60.1770, 24.9510, 30]]\n\
             [navigator]\nmode = \"dead_reckoning\"\n",
            map.display()
        ),
    )
    .unwrap();
    let out = run(&["simulate", "waypoint.toml", "--out", "o"], d);
    fails_with(
        &out,
        &[
            "waypoint.toml",
            "route[0].waypoints",
            "invalid length 3, expected an array of length 2",
        ],
    );
    assert!(!d.join("o").exists());
}

#[test]
fn absurd_imu_biases_are_refused_not_turned_into_nan() {
    let dir = tempfile::tempdir().unwrap();
    let scn = motion_scenario(
        dir.path(),
        "bias.toml",
        "[ { kind = \"accelerate\", to_kmh = 36 }, { kind = \"cruise\", duration_s = 100 } ]",
        "[imu]\ngyro_bias_dph = [1e300, 0, 0]",
    );
    let out = run(&["simulate", &scn, "--out", "o"], dir.path());
    fails_with(&out, &["bias.toml", "imu.gyro_bias_dph[0]", "3600000"]);
    assert!(!dir.path().join("o").exists());
    // Within the limit the run stays finite: no NaN in the summary.
    let scn = motion_scenario(
        dir.path(),
        "bias2.toml",
        "[ { kind = \"accelerate\", to_kmh = 36 }, { kind = \"cruise\", duration_s = 100 } ]",
        "[imu]\ngyro_bias_dph = [3.6e6, 3.6e6, 3.6e6]\naccel_bias_ug = [1e7, 1e7, 1e7]",
    );
    let v = simulate_json(dir.path(), &scn);
    for k in common::ERROR_FIGURES {
        let x = v[k].as_f64().unwrap_or(f64::NAN);
        assert!(x.is_finite() && x > 0.0, "{k} = {}", v[k]);
    }
    // serde_json writes NaN as null: the file's figures are numbers.
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("o/summary.json")).unwrap()).unwrap();
    for k in [
        "max_horizontal_error_m",
        "rms_horizontal_error_m",
        "distance_m",
    ] {
        assert!(summary[k].is_number(), "{k} = {}", summary[k]);
    }
    for x in summary["final_error_enu_m"].as_array().unwrap() {
        assert!(x.is_number(), "final_error_enu_m holds {x}");
    }
}

#[test]
fn an_absurd_odometer_noise_is_refused_not_turned_into_null() {
    // odometer.noise_mps = 1e308 on a dead-reckoning drive: every row stayed
    // finite (errors of 1e305 m), so the divergence check passed, but the
    // RMS overflowed and summary.json said "rms_horizontal_error_m": null,
    // exit 0.
    let dir = tempfile::tempdir().unwrap();
    let motion =
        "[ { kind = \"accelerate\", to_kmh = 36 }, { kind = \"cruise\", duration_s = 100 } ]";
    let dr = |noise: &str| {
        format!(
            "[navigator]\nmode = \"dead_reckoning\"\n\
             [odometer]\nscale_factor_error = 0.001\nnoise_mps = {noise}"
        )
    };
    let scn = motion_scenario(dir.path(), "odo.toml", motion, &dr("1e308"));
    let out = run(&["simulate", &scn, "--out", "o"], dir.path());
    fails_with(
        &out,
        &["odo.toml", "odometer.noise_mps", "between 0 and 10"],
    );
    assert!(!dir.path().join("o").exists());
    let diff = format!("{}\n[diff_odometer]\nnoise_mps = 1e308", dr("0.02"));
    let scn = motion_scenario(dir.path(), "diff.toml", motion, &diff);
    let out = run(&["simulate", &scn, "--out", "o"], dir.path());
    fails_with(&out, &["diff.toml", "diff_odometer.noise_mps"]);
    // At the limit the run's figures are numbers.
    let scn = motion_scenario(dir.path(), "odo10.toml", motion, &dr("10"));
    let v = simulate_json(dir.path(), &scn);
    for k in common::ERROR_FIGURES {
        assert!(v[k].as_f64().is_some_and(f64::is_finite), "{k} = {}", v[k]);
    }
}

// --- 4. Messages and exit codes --------------------------------------------------

/// A two-road polyline shapefile (`roads.shp`, `.shx`, `.dbf`).
fn write_shapefile(dir: &Path) -> PathBuf {
    use shapefile::dbase::{FieldName, FieldValue, Record, TableWriterBuilder};
    use shapefile::{Point, Polyline};
    let path = dir.join("roads.shp");
    let fields = TableWriterBuilder::new()
        .add_character_field(FieldName::try_from("highway").unwrap(), 40)
        .add_numeric_field(FieldName::try_from("lanes").unwrap(), 9, 0);
    let mut w = shapefile::Writer::from_path(&path, fields).unwrap();
    for (i, pts) in [
        vec![Point::new(18.0, 59.0), Point::new(18.001, 59.0)],
        vec![Point::new(18.001, 59.0), Point::new(18.002, 59.001)],
    ]
    .into_iter()
    .enumerate()
    {
        let mut r = Record::default();
        r.insert(
            "highway".into(),
            FieldValue::Character(Some("primary".into())),
        );
        r.insert("lanes".into(), FieldValue::Numeric(Some(i as f64 + 1.0)));
        w.write_shape_and_record(&Polyline::new(pts), &r).unwrap();
    }
    drop(w);
    path
}

#[test]
fn a_shapefile_names_its_failing_component_in_words() {
    let dir = tempfile::tempdir().unwrap();
    let shp = write_shapefile(dir.path());
    let inspect = |d: &Path| run(&["network", "inspect", "roads.shp"], d);
    assert_eq!(inspect(dir.path()).status.code(), Some(0));
    let dbf = dir.path().join("roads.dbf");
    let good_dbf = std::fs::read(&dbf).unwrap();
    // A damaged table header: the field descriptors end too early.
    std::fs::write(&dbf, &good_dbf[..40]).unwrap();
    let e = fails_with(
        &inspect(dir.path()),
        &["roads.dbf", "attribute table (.dbf)"],
    );
    assert!(
        !e.contains("kind:") && !e.contains('{'),
        "debug structure: {e}"
    );
    // Records cut short.
    std::fs::write(&dbf, &good_dbf[..good_dbf.len() - 20]).unwrap();
    let e = fails_with(&inspect(dir.path()), &["roads.dbf"]);
    assert!(!e.contains("kind:"), "{e}");
    // Missing.
    std::fs::remove_file(&dbf).unwrap();
    fails_with(&inspect(dir.path()), &["roads.dbf", "missing", "roads.shp"]);
    std::fs::write(&dbf, &good_dbf).unwrap();
    // A projected .prj, then one that is not text.
    let prj = dir.path().join("roads.prj");
    std::fs::write(&prj, "PROJCS[\"SWEREF99_TM\"]").unwrap();
    fails_with(&inspect(dir.path()), &["roads.prj", "projected", "WGS-84"]);
    std::fs::write(&prj, b"\xff\xfe\x00garbage").unwrap();
    fails_with(&inspect(dir.path()), &["roads.prj", "not text"]);
    std::fs::remove_file(&prj).unwrap();
    // A truncated .shp (its header is intact, the last record cut) and a
    // damaged .shx, which the reader does not need.
    let good_shp = std::fs::read(&shp).unwrap();
    std::fs::write(&shp, &good_shp[..good_shp.len() - 10]).unwrap();
    fails_with(&inspect(dir.path()), &["roads.shp", "(.shp)"]);
    // A record declaring 800 million parts (found by fuzzing: the reader
    // reserved 3.2 GB for them before failing): refused from its size.
    let mut huge = good_shp.clone();
    huge[144..148].copy_from_slice(&800_000_000i32.to_le_bytes());
    std::fs::write(&shp, &huge).unwrap();
    fails_with(
        &inspect(dir.path()),
        &["roads.shp", "record 1", "800000000 part(s)", "corrupt"],
    );
    // A part starting at a negative point index (found by fuzzing: the
    // reader sized the part as 3 − index points and reserved 2.1 GB).
    let mut bad_part = good_shp.clone();
    bad_part[152..156].copy_from_slice(&(-134_283_264i32).to_le_bytes());
    std::fs::write(&shp, &bad_part).unwrap();
    fails_with(
        &inspect(dir.path()),
        &[
            "roads.shp",
            "record 1",
            "part 1 starts at point -134283264",
            "corrupt",
        ],
    );
    std::fs::write(&shp, &good_shp).unwrap();
    std::fs::write(dir.path().join("roads.shx"), b"not an index").unwrap();
    assert_eq!(inspect(dir.path()).status.code(), Some(0));
}

#[test]
fn bad_option_values_exit_2_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let map = root().join("maps/helsinki.osm.pbf").display().to_string();
    let scn = scenario("dr-straight-10km.toml");
    for args in [
        vec!["network", "inspect", &map, "--grid-n", "3"],
        vec!["network", "inspect", &map, "--grid-n", "4096"],
        vec!["network", "inspect", &map, "--tolerance=-1"],
        vec!["network", "inspect", &map, "--tolerance", "NaN"],
        vec!["simulate", &scn, "--runs", "0"],
        vec!["simulate", &scn, "--runs", "100001"],
        vec!["simulate", &scn, "--seed=-1"],
        vec!["plan", &scn, "--runs", "100001"],
        vec!["match", "--map", &map, "--track", "t.csv", "--method", "x"],
    ] {
        let out = run(&args, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("invalid value"), "{args:?}: {stderr}");
    }
}

// --- 5. Clean output folders -----------------------------------------------------

#[test]
fn a_simulation_never_leaves_an_earlier_runs_files_beside_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("o");
    std::fs::create_dir_all(o.join("plots")).unwrap();
    // An earlier integrated run's files, its report, and a file of the user's.
    for f in [
        "errors.csv",
        "summary.json",
        "tag_passes.csv",
        "report.html",
        "plots/error_vs_time.png",
        "notes.txt",
    ] {
        std::fs::write(o.join(f), "earlier").unwrap();
    }
    let out = run(
        &["simulate", &scenario("dr-straight-10km.toml"), "--out", "o"],
        dir.path(),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut left: Vec<String> = std::fs::read_dir(&o)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(
        left,
        [
            "errors.csv",
            "inputs.json",
            "notes.txt",
            "scenario.toml",
            "summary.json"
        ]
    );
    assert_ne!(
        std::fs::read_to_string(o.join("summary.json")).unwrap(),
        "earlier"
    );
    assert_eq!(
        std::fs::read_to_string(o.join("notes.txt")).unwrap(),
        "earlier"
    );
}

#[test]
fn a_simulation_keeps_a_plan_in_the_same_folder() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("o");
    std::fs::create_dir_all(&o).unwrap();
    for f in ["plan.json", "tags.csv", "profile.csv"] {
        std::fs::write(o.join(f), "plan").unwrap();
    }
    let out = run(
        &["simulate", &scenario("dr-straight-10km.toml"), "--out", "o"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(0));
    for f in ["plan.json", "tags.csv", "profile.csv", "summary.json"] {
        assert!(o.join(f).exists(), "{f}");
    }
}

/// The hidden temporary files (`.NAME.tmp…`) in `o`.
fn temporaries(o: &Path) -> Vec<String> {
    std::fs::read_dir(o)
        .map(|r| {
            r.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with('.') && n.contains(".tmp"))
                .collect()
        })
        .unwrap_or_default()
}

/// Runs `waymark ARGS` in `dir` up to five times (output folder `dir/o`
/// emptied first), sends SIGTERM the moment a temporary file appears in
/// `o`, and asserts that none is ever left behind and that at least once
/// the signal came while a file was being written (exit 130).
fn sigterm_mid_write_leaves_nothing(dir: &Path, args: &[&str], patience_s: u64) {
    let o = dir.join("o");
    let mut caught = 0;
    for _ in 0..5 {
        let _ = std::fs::remove_dir_all(&o);
        let mut child = Command::new(env!("CARGO_BIN_EXE_waymark"))
            .args(args)
            .current_dir(dir)
            .spawn()
            .unwrap();
        let t0 = std::time::Instant::now();
        let mut seen = false;
        while t0.elapsed().as_secs() < patience_s {
            if !temporaries(&o).is_empty() {
                seen = true;
                let _ = Command::new("kill")
                    .args(["-TERM", &child.id().to_string()])
                    .status();
                break;
            }
            if child.try_wait().unwrap().is_some() {
                break;
            }
        }
        let status = child.wait().unwrap();
        assert!(
            temporaries(&o).is_empty(),
            "left behind: {:?}",
            temporaries(&o)
        );
        if seen && status.code() == Some(130) {
            caught += 1;
            break;
        }
    }
    assert!(caught >= 1, "the write was never caught in progress");
}

#[test]
fn sigterm_while_writing_removes_the_temporary_file() {
    // A large errors.csv (200,000 rows, ~15 MB) takes long enough to write
    // and sync that its hidden temporary file can be seen; the command is
    // stopped the moment it appears.
    let dir = tempfile::tempdir().unwrap();
    let text = "output_interval_s = 0.01\nname = \"w\"\n[[route]]\n\
        start = { lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = 45.0 }\n\
        motion = [ { kind = \"accelerate\", to_kmh = 36 }, { kind = \"cruise\", duration_s = 2000 } ]\n\
        [navigator]\nmode = \"dead_reckoning\"\n";
    std::fs::write(dir.path().join("w.toml"), text).unwrap();
    sigterm_mid_write_leaves_nothing(dir.path(), &["simulate", "w.toml", "--out", "o", "-q"], 60);
}

#[test]
fn sigterm_while_match_writes_removes_the_temporary_file() {
    // 300,000 fixes shuttling along 56 m of Mannerheimintie (Helsinki):
    // about 20 MB of matched rows, long enough to write that the hidden
    // temporary file can be seen; `match` is stopped the moment it appears.
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = ([60.16987, 24.93838], [60.17036, 24.93800]);
    let mut csv = String::from("t_s,lat,lon\n");
    for i in 0..300_000u32 {
        let u = f64::from(i % 112) / 56.0;
        let u = if u <= 1.0 { u } else { 2.0 - u };
        csv.push_str(&format!(
            "{:.1},{:.7},{:.7}\n",
            f64::from(i) * 0.1,
            a[0] + u * (b[0] - a[0]),
            a[1] + u * (b[1] - a[1])
        ));
    }
    std::fs::write(dir.path().join("track.csv"), csv).unwrap();
    let map = root().join("maps/helsinki.osm.pbf").display().to_string();
    let args = [
        "match",
        "--map",
        &map,
        "--track",
        "track.csv",
        "--out",
        "o/matched.csv",
        "-q",
    ];
    sigterm_mid_write_leaves_nothing(dir.path(), &args, 120);
}

/// The demo with `n` waypoints alternating between its start and `other`,
/// no stops, `speed_kmh` and `duration_s = 60`.
fn waypoints_scenario(n: usize, other: &str, speed_kmh: f64) -> String {
    let waypoints: Vec<&str> = (0..n)
        .map(|i| {
            if i % 2 == 0 {
                "[60.1660, 24.9380]"
            } else {
                other
            }
        })
        .collect();
    let text = std::fs::read_to_string(scenario("demo.toml"))
        .unwrap()
        .replace(
            "../maps/helsinki.osm.pbf",
            &root().join("maps/helsinki.osm.pbf").display().to_string(),
        )
        .replace(
            "waypoints = [[60.1660, 24.9380], [60.1770, 24.9510], [60.1660, 24.9380]]",
            &format!("waypoints = [{}]", waypoints.join(", ")),
        )
        .replace("speed_kmh = 50\n", &format!("speed_kmh = {speed_kmh}\n"))
        .replace("stops = [ { at_m = 1500, duration_s = 20 } ]\n", "")
        .replace(
            "requirement_m = 20.0\n",
            "requirement_m = 20.0\nduration_s = 60\n",
        );
    assert!(text.contains("duration_s = 60") && text.contains(other));
    assert!(text.contains(&format!("speed_kmh = {speed_kmh}\n")));
    text
}

/// A corner of the demo's streets 250 m from its start: each leg drives
/// round a block (about 0.9 km).
const NEAR: &str = "[60.1680, 24.9400]";
/// The demo's far end, 1.4 km from its start (great-circle).
const FAR: &str = "[60.1770, 24.9510]";

#[test]
fn a_route_too_long_to_drive_in_30_days_is_refused_before_it_is_built() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 4,000 waypoints 1.4 km apart at 5 km/h: at least 4,842 km (the
    // great-circle distances less the 100 m each waypoint may be snapped),
    // 40 days. Refused from the waypoints alone, before the map is loaded
    // (the old binary routed 8,000 km and sampled it, 1.8 GB and 10 s,
    // before the drive's 30-day limit refused it); duration_s = 60 does
    // not lift it, as the route would be built whole.
    std::fs::write(d.join("far.toml"), waypoints_scenario(4000, FAR, 5.0)).unwrap();
    for cmd in ["simulate", "plan"] {
        let out = run(&[cmd, "far.toml", "--out", "o", "-q"], d);
        fails_with(
            &out,
            &[
                "far.toml: route[0]: its 4000 waypoints are 4842 km apart at least \
                 (great-circle distances between consecutive waypoints), a drive of at least \
                 40.4 days at speed_kmh = 5, above the limit of 30 days",
                "use fewer or closer waypoints",
            ],
        );
        assert!(!d.join("o").exists(), "{cmd}: nothing written");
    }
    // 1,000 waypoints 250 m apart at 1 km/h: the great-circle bound (48 m a
    // leg) passes, the routed length (about 900 km, 37 days) does not; it
    // is refused before the route is sampled.
    std::fs::write(d.join("blocks.toml"), waypoints_scenario(1000, NEAR, 1.0)).unwrap();
    let out = run(&["simulate", "blocks.toml", "--out", "o", "-q"], d);
    let err = fails_with(
        &out,
        &[
            "blocks.toml: route[0]: the route through its waypoints is ",
            "days at speed_kmh = 1.0, above the limit of 30 days",
            "use fewer or closer waypoints",
        ],
    );
    let km = routed_km(&err);
    assert!((800.0..1000.0).contains(&km), "{err}");
    assert!(!d.join("o").exists());
    // The same at 2 km/h (about 19 days) is driven: duration_s = 60 stops it.
    std::fs::write(d.join("blocks.toml"), waypoints_scenario(1000, NEAR, 2.0)).unwrap();
    let v = succeeded_finite(&run(
        &[
            "simulate",
            "blocks.toml",
            "--runs",
            "1",
            "--out",
            "o",
            "--json",
            "-q",
        ],
        d,
    ));
    assert_eq!(v["duration_s"].as_f64(), Some(60.0), "{v}");
}

#[test]
fn a_route_too_long_to_hold_in_memory_is_refused_before_it_is_built() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The 30-day limit does not bound a route's memory (at 300 km/h 30
    // days are 216,000 km): its truth keeps points of its lane path and
    // speed profile every metre or two, at least 0.21 GB per 1000 km
    // whatever the IMU rate, the speed and duration_s. 9,000 waypoints
    // 1.4 km apart at 300 km/h: at least 10,897 km (36 hours), whose truth
    // needs at least 2.3 GB, above the 2 GiB limit: refused from the
    // waypoints alone, before the map is loaded.
    std::fs::write(d.join("far.toml"), waypoints_scenario(9000, FAR, 300.0)).unwrap();
    for cmd in ["simulate", "plan"] {
        let out = run(&[cmd, "far.toml", "--out", "o", "-q"], d);
        fails_with(
            &out,
            &[
                "waymark: error: far.toml: route[0]: its 9000 waypoints are 10897 km apart at \
                 least (great-circle distances between consecutive waypoints): building the \
                 truth of a route that long needs at least 2.3 GB of memory, above the limit \
                 of 2 GiB (2.1 GB;",
                "at least 0.21 GB per 1000 km, whatever imu.rate_hz, speed_kmh and duration_s",
                "use fewer or closer waypoints",
            ],
        );
        assert!(!d.join("o").exists(), "{cmd}: nothing written");
    }
    // 11,000 waypoints 250 m apart, each leg round a block, at 50 km/h:
    // the great-circle bound (50 m a leg) passes, as does the drive (about
    // 10,000 km, 8 days); the routed route's truth (about 2.3 GB) does not.
    // Refused after routing, before its plans are made (measured by hand:
    // 0.4 s and 68 MB, where building it would take 2.3 GB).
    std::fs::write(d.join("blocks.toml"), waypoints_scenario(11000, NEAR, 50.0)).unwrap();
    let out = run(&["simulate", "blocks.toml", "--out", "o", "-q"], d);
    let err = fails_with(
        &out,
        &[
            "waymark: error: blocks.toml: route[0]: the route through its 11000 waypoints is ",
            "building its truth needs about ",
            " GB of memory, above the limit of 2 GiB (2.1 GB;",
            "use fewer or closer waypoints",
        ],
    );
    let km = routed_km(&err);
    assert!((9000.0..11000.0).contains(&km), "{err}");
    assert!(!d.join("o").exists());
}

#[test]
fn a_route_through_thousands_of_waypoints_is_simulated() {
    // The lane path summed every lane step from the route's start at each
    // of its points: quadratic in the route's length. 2,000 waypoints
    // between two corners of the demo's streets (a 1,800 km route: each leg
    // drives round a block) took minutes before the first second could be
    // simulated (1,000 waypoints 28 s of CPU, 3,000 waypoints 262 s); now
    // 1,000 take 1 s, 3,000 3 s and 10,000 10 s (BENCHMARKS.md, "Routes
    // through thousands of waypoints").
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("many.toml"), waypoints_scenario(2000, NEAR, 50.0)).unwrap();
    // No deadline here (the project measures speed in BENCHMARKS.md, not
    // in timed tests): the run must build the route and finish.
    let out = Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args([
            "simulate",
            "many.toml",
            "--runs",
            "1",
            "--out",
            "o",
            "--json",
            "-q",
        ])
        .current_dir(d)
        .output()
        .unwrap();
    let v = succeeded_finite(&out);
    assert_eq!(v["duration_s"].as_f64(), Some(60.0), "{v}");
}
