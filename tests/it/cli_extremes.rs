//! Extreme values of a scenario's physical terms as a user types them
//! (1e308, 1e-300, a duplicated id): each is refused through the real
//! binary with one error line naming the file, the field and the limit,
//! exit code 1, and no output folder (the companion of
//! `tests/it/cli_reliability.rs`, whose helpers these mirror).

use crate::common;

use common::{fails_with, run, succeeded_finite};
use std::path::Path;
use std::process::Output;

/// A 110 s motion drive (to 36 km/h, then cruise) navigated by `mode`,
/// starting at `heading_deg`, with `extra` appended; written to `dir/name`.
fn drive(dir: &Path, name: &str, mode: &str, heading_deg: &str, extra: &str) -> String {
    let text = format!(
        "name = \"x\"\n[[route]]\n\
         start = {{ lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = {heading_deg} }}\n\
         motion = [ {{ kind = \"accelerate\", to_kmh = 36 }}, {{ kind = \"cruise\", duration_s = 100 }} ]\n\
         [navigator]\nmode = \"{mode}\"\n{extra}\n"
    );
    std::fs::write(dir.join(name), text).unwrap();
    name.to_string()
}

fn simulate(dir: &Path, scn: &str) -> Output {
    run(&["simulate", scn, "--out", "o", "--json", "-q"], dir)
}

/// The bundled Helsinki map-matching scenario (a 2.8 km drive there and
/// back) with `lines` added to its `[map]` section and its map path made
/// absolute.
fn map_matching(dir: &Path, name: &str, lines: &str) -> String {
    let text = std::fs::read_to_string(common::repo("scenarios/helsinki-route-map-matching.toml"))
        .unwrap();
    let map = common::repo("maps/helsinki.osm.pbf");
    let text = text.replace(
        "path = \"../maps/helsinki.osm.pbf\"\n",
        &format!("path = \"{}\"\n{lines}\n", map.display()),
    );
    std::fs::write(dir.join(name), text).unwrap();
    name.to_string()
}

#[test]
fn an_absurd_map_geometry_error_is_refused_at_its_field() {
    // [map] geometry_error_m = 1e308 was accepted: the map error field
    // overflowed, no matched point was fed (map_matching.fed = 0) and the
    // summary looked like a good run, exit 0. A correlation length of 1e308
    // gave map_matching.max_across_error_m = 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (lines, needles) in [
        (
            "geometry_error_m = 1e308",
            &["map.geometry_error_m", "1e308", "100"][..],
        ),
        (
            "geometry_error_m = 1000",
            &["map.geometry_error_m", "between 0 and 100"][..],
        ),
        (
            "geometry_error_correlation_m = 1e308",
            &["map.geometry_error_correlation_m", "1e308", "1000000"][..],
        ),
        (
            "geometry_error_m = 50\ngeometry_error_correlation_m = 20",
            &[
                "map.geometry_error_m = 50",
                "map.geometry_error_correlation_m = 20",
            ][..],
        ),
    ] {
        let scn = map_matching(d, "map.toml", lines);
        let out = simulate(d, &scn);
        let mut n = vec!["map.toml"];
        n.extend_from_slice(needles);
        fails_with(&out, &n);
        assert!(!d.join("o").exists());
    }
    // At the limits the run is made and its map matching fed points.
    let scn = map_matching(
        d,
        "map.toml",
        "geometry_error_m = 100\ngeometry_error_correlation_m = 400",
    );
    let out = simulate(d, &scn);
    succeeded_finite(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["map_matching"]["fed"].as_u64().unwrap() > 0, "{v}");
}

#[test]
fn a_start_heading_beyond_a_turn_is_refused() {
    // route[0].start.heading_deg = 1e308 was accepted (its sine and cosine
    // are of an arbitrary angle), exit 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for h in ["1e308", "361", "-400"] {
        let scn = drive(d, "h.toml", "dead_reckoning", h, "");
        fails_with(
            &simulate(d, &scn),
            &["h.toml", "route[0].start.heading_deg", "-360", "360"],
        );
        assert!(!d.join("o").exists());
    }
    for h in ["-360", "360", "359.9"] {
        let scn = drive(d, "h.toml", "dead_reckoning", h, "");
        succeeded_finite(&simulate(d, &scn));
    }
}

#[test]
fn an_absurd_tag_survey_error_is_refused() {
    // [[tag]] survey_error_m = [1e308, 1e308] was accepted: the tag's stored
    // place was infinite, exit 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tag = |e: &str| {
        format!(
            "[aiding]\nodometer = true\nrfid = true\n\
             [[tag]]\nat_s = 20\n[[tag]]\nat_s = 50\nsurvey_error_m = {e}"
        )
    };
    for (e, field) in [
        ("[1e308, 1e308]", "tag[1].survey_error_m[0]"),
        ("[0, -1e308]", "tag[1].survey_error_m[1]"),
        ("[100001, 0]", "tag[1].survey_error_m[0]"),
    ] {
        let scn = drive(d, "t.toml", "integrated", "45", &tag(e));
        fails_with(&simulate(d, &scn), &["t.toml", field, "100000"]);
        assert!(!d.join("o").exists());
    }
    // A rogue tag at the limit (100 km away on each axis) is a number the
    // filter's gate rejects.
    let scn = drive(d, "t.toml", "integrated", "45", &tag("[-100000, 100000]"));
    succeeded_finite(&simulate(d, &scn));
}

#[test]
fn absurd_barometer_errors_are_refused_not_turned_into_divergence() {
    // [baro] initial_bias_m = 1e308 and bias_drift_m = 1e308 were accepted
    // (3-D dead reckoning ended 6e306 m off in height, exit 0); noise_m =
    // 1e308 made the run diverge and the error blamed [imu].
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (key, value) in [
        ("initial_bias_m", "1e308"),
        ("initial_bias_m", "-1e308"),
        ("bias_drift_m", "1e308"),
        ("noise_m", "1e308"),
        ("noise_m", "1501"),
    ] {
        let scn = drive(
            d,
            "b.toml",
            "dead_reckoning_3d",
            "45",
            &format!("[baro]\n{key} = {value}"),
        );
        let field = format!("baro.{key}");
        fails_with(&simulate(d, &scn), &["b.toml", &field, "1500"]);
        assert!(!d.join("o").exists());
    }
    // At the limits every navigator that reads the barometer stays finite.
    let baro = "[baro]\ninitial_bias_m = -1500\nnoise_m = 1500\nbias_drift_m = 1500";
    for (mode, extra) in [
        ("dead_reckoning_3d", String::new()),
        ("free_inertial", "vertical_channel = \"baro\"".to_string()),
        (
            "integrated",
            "[aiding]\nodometer = true\nbaro = true".to_string(),
        ),
    ] {
        let scn = drive(d, "b.toml", mode, "45", &format!("{extra}\n{baro}"));
        succeeded_finite(&simulate(d, &scn));
    }
}

#[test]
fn an_absurd_odometer_pulse_length_is_refused() {
    // odometer.pulse_m = 1e308 was accepted: every pulse count was 0, so
    // dead reckoning never moved (its error was the whole drive), exit 0;
    // 1e-300 was accepted as well, as were the same for [diff_odometer].
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (section, mode, value) in [
        ("odometer", "dead_reckoning", "1e308"),
        ("odometer", "dead_reckoning", "1e-300"),
        ("odometer", "dead_reckoning", "5.5"),
        ("odometer", "dead_reckoning", "-0.02"),
        ("diff_odometer", "dead_reckoning_3d", "1e308"),
        ("diff_odometer", "dead_reckoning_3d", "1e-300"),
    ] {
        let scn = drive(
            d,
            "p.toml",
            mode,
            "45",
            &format!("[{section}]\npulse_m = {value}"),
        );
        let field = format!("{section}.pulse_m");
        fails_with(&simulate(d, &scn), &["p.toml", &field, "0.0001", "5"]);
        assert!(!d.join("o").exists());
    }
    // 0 (no quantization) and the ends of the range are taken, and dead
    // reckoning still follows the 1050 m drive: its error at most 50 m above
    // that without quantization.
    for (section, mode) in [
        ("odometer", "dead_reckoning"),
        ("diff_odometer", "dead_reckoning_3d"),
    ] {
        let mut base = None;
        for value in ["0", "0.0001", "5"] {
            let scn = drive(
                d,
                "p.toml",
                mode,
                "45",
                &format!("[{section}]\npulse_m = {value}"),
            );
            let out = simulate(d, &scn);
            succeeded_finite(&out);
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            let max = v["max_horizontal_error_m"].as_f64().unwrap();
            let base = *base.get_or_insert(max);
            assert!(
                max < base + 50.0,
                "{section}.pulse_m = {value}: {max} m, {base} m unquantized"
            );
        }
    }
}

#[test]
fn duplicate_tag_ids_are_refused_naming_both_entries() {
    // Two [[tag]] entries with one id were accepted (the tag CSV reader
    // refuses them), and their fixes and passes could not be told apart.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (tags, needles) in [
        (
            "[[tag]]\nid = \"a\"\nat_s = 20\n[[tag]]\nat_s = 30\n[[tag]]\nid = \"a\"\nat_s = 50",
            &["tag[2].id", "\"a\"", "tag[0]"][..],
        ),
        // An entry without id is tag-N: an explicit id may not take it.
        (
            "[[tag]]\nid = \"tag-1\"\nat_s = 20\n[[tag]]\nat_s = 50",
            &["tag[1]", "\"tag-1\"", "tag[0]"][..],
        ),
    ] {
        let extra = format!("[aiding]\nodometer = true\nrfid = true\n{tags}");
        let scn = drive(d, "d.toml", "integrated", "45", &extra);
        let mut n = vec!["d.toml"];
        n.extend_from_slice(needles);
        fails_with(&simulate(d, &scn), &n);
        assert!(!d.join("o").exists());
    }
}

#[test]
fn a_tag_id_in_both_the_scenario_and_the_tag_file_is_refused() {
    // `simulate --tags t.csv` with a tag of the same id as a [[tag]] of the
    // scenario ran (exit 0), and tag_passes.csv could not tell them apart.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let extra = "[aiding]\nodometer = true\nrfid = true\n[[tag]]\nid = \"a\"\nat_s = 20";
    let scn = drive(d, "d.toml", "integrated", "45", extra);
    std::fs::write(
        d.join("t.csv"),
        "tag_id,lat,lon,mounting\na,30.0,117.0,road_surface\n",
    )
    .unwrap();
    let out = run(&["simulate", &scn, "--tags", "t.csv", "--out", "o"], d);
    fails_with(&out, &["t.csv", "\"a\"", "[[tag]]", "d.toml"]);
    assert!(!d.join("o").exists());
    // Another id: taken.
    std::fs::write(
        d.join("t.csv"),
        "tag_id,lat,lon,mounting\nb,30.0,117.0,road_surface\n",
    )
    .unwrap();
    let out = run(
        &[
            "simulate", &scn, "--tags", "t.csv", "--out", "o", "--json", "-q",
        ],
        d,
    );
    succeeded_finite(&out);
}

#[test]
fn serde_type_errors_print_huge_numbers_short() {
    // seed = 1e308 (an integer field) printed serde's "invalid type:
    // floating point `1000…000`" with all 309 digits.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (line, needle) in [
        ("seed = 1e308", "1e308"),
        ("seed = -1e308", "-1e308"),
        ("seed = 1e-300", "1e-300"),
    ] {
        let scn = drive(d, "s.toml", "dead_reckoning", "45", "");
        let text = std::fs::read_to_string(d.join(&scn)).unwrap();
        std::fs::write(
            d.join(&scn),
            text.replacen("name = \"x\"\n", &format!("name = \"x\"\n{line}\n"), 1),
        )
        .unwrap();
        let e = fails_with(&simulate(d, &scn), &["s.toml", "seed", needle]);
        assert!(e.len() < 200, "{e}");
    }
    // An ordinary seed still runs.
    let scn = drive(d, "s.toml", "dead_reckoning", "45", "");
    let text = std::fs::read_to_string(d.join(&scn)).unwrap();
    std::fs::write(
        d.join(&scn),
        text.replacen("name = \"x\"\n", "name = \"x\"\nseed = 7\n", 1),
    )
    .unwrap();
    succeeded_finite(&simulate(d, &scn));
    // A limit's own message prints the refused value short as well.
    let scn = drive(
        d,
        "n.toml",
        "dead_reckoning",
        "45",
        "[odometer]\nnoise_mps = 1e308",
    );
    fails_with(&simulate(d, &scn), &["odometer.noise_mps", "got 1e308"]);
}

/// [`drive`] dead reckoning with `top` among the top-level fields.
fn drive_top(dir: &Path, name: &str, top: &str) -> String {
    let scn = drive(dir, name, "dead_reckoning", "45", "");
    let text = std::fs::read_to_string(dir.join(&scn)).unwrap();
    let text = text.replacen("name = \"x\"\n", &format!("name = \"x\"\n{top}\n"), 1);
    std::fs::write(dir.join(&scn), text).unwrap();
    scn
}

/// The bundled Helsinki dead-reckoning drive (a 4.1 km map route there and
/// back with a stop) with its map path made absolute, its `stops` line
/// replaced by `stops` (when given) and `extra` appended.
fn map_route(dir: &Path, name: &str, stops: Option<&str>, extra: &str) -> String {
    let text = std::fs::read_to_string(common::repo("scenarios/helsinki-route-dr.toml")).unwrap();
    let map = common::repo("maps/helsinki.osm.pbf");
    let mut text = text.replace("../maps/helsinki.osm.pbf", &map.display().to_string());
    if let Some(s) = stops {
        text = text.replace("stops = [ { at_m = 1500, duration_s = 20 } ]", s);
    }
    std::fs::write(dir.join(name), format!("{text}\n{extra}\n")).unwrap();
    name.to_string()
}

#[test]
fn a_correlation_time_out_of_range_is_refused() {
    // [baro] bias_tau_s had no limit (1e-300 and 1e308 were taken), nor had
    // filter.odometer_scale_tau_s (0 and -5 were taken); at 1e-300 and 0
    // an integrated run with odometer and baro aiding reported an error of
    // exactly 0 m, exit 0. imu.gyro_bias_tau_s and accel_bias_tau_s at
    // 1e-300 made the filter diverge, blaming [imu] as a whole.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let aided = "[aiding]\nodometer = true\nbaro = true";
    for (section, key) in [
        ("baro", "bias_tau_s"),
        ("imu", "gyro_bias_tau_s"),
        ("imu", "accel_bias_tau_s"),
        ("filter", "odometer_scale_tau_s"),
    ] {
        for value in ["1e-300", "1e308", "0", "-5", "9.99", "10000001"] {
            let extra = format!("{aided}\n[{section}]\n{key} = {value}");
            let scn = drive(d, "c.toml", "integrated", "45", &extra);
            let field = format!("{section}.{key}");
            fails_with(
                &simulate(d, &scn),
                &["c.toml", &field, "between 10 and 10000000", value],
            );
            assert!(!d.join("o").exists());
        }
    }
    // At both ends every navigator stays finite, with large Gauss–Markov
    // errors; the aided filter (every step at its longest, 10 s, where it
    // can be) reports an error above 0.
    for tau in ["10", "1e7"] {
        let errors = format!(
            "[imu]\ngyro_bias_instability_dph = 100\naccel_bias_instability_ug = 1000\n\
             gyro_bias_tau_s = {tau}\naccel_bias_tau_s = {tau}\n\
             [baro]\nbias_drift_m = 1500\nbias_tau_s = {tau}"
        );
        for (mode, extra) in [
            ("free_inertial", String::new()),
            ("dead_reckoning", String::new()),
            ("dead_reckoning_3d", String::new()),
            (
                "integrated",
                format!(
                    "{aided}\n[filter]\ninterval_s = 10\nodometer_interval_s = 10\n\
                     odometer_scale_tau_s = {tau}"
                ),
            ),
        ] {
            let scn = drive(d, "c.toml", mode, "45", &format!("{extra}\n{errors}"));
            let v = succeeded_finite(&simulate(d, &scn));
            let max = v["max_horizontal_error_m"].as_f64().unwrap();
            assert!(max > 0.0, "{mode}, τ = {tau}: {v}");
        }
    }
}

#[test]
fn an_absurd_lane_wander_is_refused() {
    // [vehicle] lane_wander_m = 1000 drove the 4.1 km route as 75 km of
    // zigzag (exit 0); at 1e308 the error blamed the route ("only 0.00 m
    // long").
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for value in ["1e308", "1000", "2.01"] {
        let scn = map_route(
            d,
            "w.toml",
            None,
            &format!("[vehicle]\nlane_wander_m = {value}"),
        );
        fails_with(
            &simulate(d, &scn),
            &["w.toml", "vehicle.lane_wander_m", "between 0 and 2", value],
        );
        assert!(!d.join("o").exists());
    }
    // At the limit the drive is still the route: within 5 % of its length
    // without wander.
    let mut length = Vec::new();
    for value in ["0", "2"] {
        let scn = map_route(
            d,
            "w.toml",
            None,
            &format!("[vehicle]\nlane_wander_m = {value}"),
        );
        let v = succeeded_finite(&simulate(d, &scn));
        length.push(v["distance_m"].as_f64().unwrap());
        std::fs::remove_dir_all(d.join("o")).unwrap();
    }
    assert!(
        (length[1] - length[0]).abs() < 0.05 * length[0],
        "{length:?}"
    );
}

#[test]
fn run_settings_out_of_range_are_refused() {
    // duration_s = 1e-300 (or any cap under one output interval) made a run
    // of 0 s whose figures were all 0, exit 0; output_interval_s = 1e308
    // took the metrics from the start and end rows alone; requirement_m =
    // 1e308 and 1e-300 were taken (a plan printed them in full).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (top, needles) in [
        (
            "duration_s = 1e-300",
            &["duration_s = 1e-300", "output_interval_s = 1"][..],
        ),
        (
            "output_interval_s = 5\nduration_s = 4.9",
            &["duration_s = 4.9", "output_interval_s = 5"][..],
        ),
        (
            "output_interval_s = 1e308",
            &["output_interval_s", "86400", "1e308"][..],
        ),
        (
            "requirement_m = 1e308",
            &["requirement_m", "between 0.001 and 100000", "1e308"][..],
        ),
        (
            "requirement_m = 1e-300",
            &["requirement_m", "between 0.001 and 100000", "1e-300"][..],
        ),
    ] {
        let scn = drive_top(d, "r.toml", top);
        let mut n = vec!["r.toml"];
        n.extend_from_slice(needles);
        fails_with(&simulate(d, &scn), &n);
        assert!(!d.join("o").exists());
    }
    // At the limits: a run of one output interval has its rows; the
    // requirement's ends are taken.
    for (top, rows) in [
        ("duration_s = 1", Some(2)),
        ("output_interval_s = 86400", Some(2)),
        ("requirement_m = 0.001", None),
        ("requirement_m = 100000", None),
    ] {
        let scn = drive_top(d, "r.toml", top);
        let v = succeeded_finite(&simulate(d, &scn));
        if let Some(rows) = rows {
            let csv = std::fs::read_to_string(d.join("o/errors.csv")).unwrap();
            assert_eq!(csv.lines().count(), rows + 1, "{top}: {csv}");
        }
        if top == "duration_s = 1" {
            assert_eq!(v["duration_s"].as_f64(), Some(1.0), "{v}");
        }
        std::fs::remove_dir_all(d.join("o")).unwrap();
    }
}

#[test]
fn an_absurd_external_fix_random_walk_is_refused() {
    // [external_fix] random_walk_m_per_rts = 1e308 was taken: the simulated
    // fixes' random walk overflowed, exit 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fix = |rw: &str| {
        format!(
            "[aiding]\nodometer = true\nexternal_fix = true\n[external_fix]\n\
             interval_s = [5, 10]\nwhite_m = 5\nrandom_walk_m_per_rts = {rw}"
        )
    };
    for rw in ["1e308", "1000.5"] {
        let scn = drive(d, "f.toml", "integrated", "45", &fix(rw));
        fails_with(
            &simulate(d, &scn),
            &["f.toml", "external_fix.random_walk_m_per_rts", "1000", rw],
        );
        assert!(!d.join("o").exists());
    }
    let scn = drive(d, "f.toml", "integrated", "45", &fix("1000"));
    succeeded_finite(&simulate(d, &scn));
}

#[test]
fn map_route_stops_print_short_and_stay_within_a_drive() {
    // A stop of 1e308 s made the drive "last 184467440737095520 s" (a
    // saturated count, not the stop); a stop at 1e308 m printed all 309
    // digits.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scn = map_route(
        d,
        "s.toml",
        Some("stops = [ { at_m = 1500, duration_s = 1e308 } ]"),
        "",
    );
    fails_with(
        &simulate(d, &scn),
        &[
            "s.toml",
            "route[0].stops[0].duration_s = 1e308",
            "2592000 s",
        ],
    );
    let scn = map_route(
        d,
        "s.toml",
        Some("stops = [ { at_m = 1e308, duration_s = 20 } ]"),
        "",
    );
    let e = fails_with(
        &simulate(d, &scn),
        &["s.toml", "route[0]", "stop at 1e308 m"],
    );
    assert!(e.len() < 200, "{e}");
    assert!(!d.join("o").exists());
}

/// Writes `m.toml` in `dir`: dead reckoning over the motion commands
/// `motion` (a TOML array's items) from 30° N 117° E.
fn motion_drive(dir: &Path, motion: &str) {
    let text = format!(
        "name = \"x\"\n[[route]]\nstart = {{ lat = 30.0, lon = 117.0 }}\n\
         motion = [ {motion} ]\n[navigator]\nmode = \"dead_reckoning\"\n"
    );
    std::fs::write(dir.join("m.toml"), text).unwrap();
}

#[test]
fn motion_command_errors_print_numbers_short() {
    // accel_mps2 = 1e308 and a turn radius of 1e-300 m printed 309 and 300
    // digits; a stay of 1e308 s said "the commands last 5184000 s" (its
    // samples capped at 60 days).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let acc = "{ kind = \"accelerate\", to_kmh = 36 }";
    for (motion, needles) in [
        (
            "{ kind = \"accelerate\", to_kmh = 36, accel_mps2 = 1e308 }".to_string(),
            &[
                "route[0].motion[0].accel_mps2",
                "between 0.05 and 9.81",
                "1e308",
            ][..],
        ),
        (
            format!("{acc}, {{ kind = \"decelerate\", to_kmh = 0, accel_mps2 = 1e-300 }}"),
            &["route[0].motion[1].accel_mps2", "1e-300"][..],
        ),
        (
            format!("{acc}, {{ kind = \"turn\", angle_deg = 90, radius_m = 1e-300 }}"),
            &["route[0].motion[1] (turn)", "1e-300 m radius", "lateral"][..],
        ),
        (
            "{ kind = \"stay\", duration_s = 1e308 }".to_string(),
            &["route[0].motion", "at least", "30 days"][..],
        ),
    ] {
        motion_drive(d, &motion);
        let mut n = vec!["m.toml"];
        n.extend_from_slice(needles);
        let e = fails_with(&simulate(d, "m.toml"), &n);
        assert!(e.len() < 200, "{e}");
    }
    // The ends of the acceleration range drive.
    for a in ["0.05", "9.81"] {
        motion_drive(
            d,
            &format!("{{ kind = \"accelerate\", to_kmh = 36, accel_mps2 = {a} }}"),
        );
        succeeded_finite(&simulate(d, "m.toml"));
        std::fs::remove_dir_all(d.join("o")).unwrap();
    }
    // A tag beyond the route's end, by a number far beyond it.
    let scn = drive(
        d,
        "t.toml",
        "integrated",
        "45",
        "[aiding]\nodometer = true\nrfid = true\n[[tag]]\nat_s = 1e308",
    );
    fails_with(
        &simulate(d, &scn),
        &["t.toml", "tag[0].at_s = 1e308", "beyond"],
    );
}

/// A plan of [`drive`] (integrated, MEMS, RFID only, 30 m, no missed read
/// tolerated, 2 validation runs) with `planner` added to `[planner]` and
/// `extra` appended.
fn plan_drive(dir: &Path, name: &str, planner: &str, extra: &str) -> String {
    let text = format!(
        "[imu]\ngrade = \"mems\"\n[aiding]\nrfid = true\n\
         [planner]\nvalidation_runs = 2\ntolerate_missed_reads = 0\n{planner}\n{extra}"
    );
    let scn = drive(dir, name, "integrated", "45", &text);
    let text = std::fs::read_to_string(dir.join(&scn)).unwrap();
    let text = text.replacen("name = \"x\"\n", "name = \"x\"\nrequirement_m = 30\n", 1);
    std::fs::write(dir.join(&scn), text).unwrap();
    scn
}

#[test]
fn planner_numbers_print_short() {
    // forbidden_m = [[1e308, 0]] and requirement_confidence = 1e-300
    // printed 309 and 300 digits; violation_probability = 1e-300 passed
    // the certification-size check (ln(1 − ε) was 0).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (planner, needles) in [
        (
            "forbidden_m = [[1e308, 0]]",
            &["planner.forbidden_m", "[1e308, 0]"][..],
        ),
        (
            "requirement_confidence = 1e-300",
            &["planner.requirement_confidence = 1e-300", "0.5"][..],
        ),
        (
            "coverage = \"network\"\nviolation_probability = 1e-300",
            &["planner.violation_probability = 1e-300", "limit 50000"][..],
        ),
    ] {
        let scn = plan_drive(d, "p.toml", planner, "");
        let mut n = vec!["p.toml"];
        n.extend_from_slice(needles);
        let e = fails_with(&run(&["plan", &scn, "--out", "o"], d), &n);
        assert!(e.len() < 250, "{e}");
        assert!(!d.join("o").exists());
    }
}

#[test]
fn a_plan_refuses_an_installed_tag_sharing_a_tag_id_with_the_scenario() {
    // planner.existing_tags with a tag of the same id as a [[tag]] of the
    // scenario was planned (exit 0): the plan's validation simulates both,
    // and their reads could not be told apart (`simulate --tags` refuses
    // the same).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scn = plan_drive(
        d,
        "p.toml",
        "existing_tags = \"t.csv\"",
        "[[tag]]\nid = \"a\"\nat_s = 20",
    );
    // 200 m along the drive.
    let installed =
        |id: &str| format!("tag_id,lat,lon,mounting\n{id},30.0012757,117.0014657,road_surface\n");
    std::fs::write(d.join("t.csv"), installed("a")).unwrap();
    let out = run(&["plan", &scn, "--out", "o"], d);
    fails_with(
        &out,
        &["t.csv", "tag_id \"a\"", "[[tag]]", "p.toml", "unique"],
    );
    assert!(!d.join("o").exists());
    // Another id: planned, the installed tag kept.
    std::fs::write(d.join("t.csv"), installed("b")).unwrap();
    let out = run(&["plan", &scn, "--out", "o", "-q"], d);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("o/plan.json")).unwrap()).unwrap();
    assert_eq!(plan["existing_tags_kept"].as_u64(), Some(1), "{plan}");
}

#[test]
fn a_plan_numbers_its_new_tags_around_the_ids_already_taken() {
    // With an installed tag T0001 (part of an earlier plan, re-planned) and
    // a [[tag]] T0002, the plan numbered its new tags T0001, T0002 again
    // (plan.json held two T0001), exit 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scn = plan_drive(
        d,
        "p.toml",
        "existing_tags = \"t.csv\"",
        "[[tag]]\nid = \"T0002\"\nat_s = 20",
    );
    std::fs::write(
        d.join("t.csv"),
        "tag_id,lat,lon,mounting\nT0001,30.0012757,117.0014657,road_surface\n",
    )
    .unwrap();
    let out = run(&["plan", &scn, "--out", "o", "-q"], d);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("o/plan.json")).unwrap()).unwrap();
    let ids: Vec<&str> = plan["tags"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["tag_id"].as_str().unwrap())
        .collect();
    assert_eq!(plan["existing_tags_kept"].as_u64(), Some(1), "{plan}");
    assert!(ids.len() >= 2, "{ids:?}");
    assert_eq!(ids.iter().filter(|&&i| i == "T0001").count(), 1, "{ids:?}");
    assert!(!ids.contains(&"T0002"), "{ids:?}");
    let unique: std::collections::BTreeSet<&str> = ids.iter().copied().collect();
    assert_eq!(unique.len(), ids.len(), "{ids:?}");
    // tags.csv: the new tags, numbered from T0003.
    let csv = std::fs::read_to_string(d.join("o/tags.csv")).unwrap();
    let first = csv.lines().nth(1).unwrap();
    assert!(first.starts_with("T0003,"), "{csv}");
}

#[test]
fn absurd_odometer_mounting_errors_are_refused() {
    // The IMU's misalignment on the vehicle, the per-run calibration σ and
    // the time-varying scale factor (added with them): beyond their ranges one line naming the file and
    // the field, exit 1, nothing written; inside them a finite run.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (line, field, range) in [
        (
            "misalignment_deg = [0, 1e308]",
            "odometer.misalignment_deg[1] (yaw)",
            "10",
        ),
        (
            "misalignment_deg = [-45, 0]",
            "odometer.misalignment_deg[0] (pitch)",
            "10",
        ),
        (
            "misalignment_sigma_deg = 1e308",
            "odometer.misalignment_sigma_deg",
            "5",
        ),
        (
            "scale_factor_sigma = 1e308",
            "odometer.scale_factor_sigma",
            "0.1",
        ),
        (
            "scale_factor_sigma = -0.001",
            "odometer.scale_factor_sigma",
            "0.1",
        ),
        (
            "scale_factor_instability = 1e308",
            "odometer.scale_factor_instability",
            "0.1",
        ),
        (
            "scale_factor_tau_s = 1e-300",
            "odometer.scale_factor_tau_s",
            "10",
        ),
    ] {
        let scn = drive(
            d,
            "m.toml",
            "dead_reckoning",
            "45",
            &format!("[odometer]\n{line}"),
        );
        fails_with(&simulate(d, &scn), &["m.toml", field, range]);
        assert!(!d.join("o").exists());
    }
    let scn = drive(
        d,
        "m.toml",
        "dead_reckoning",
        "45",
        "[odometer]\nmisalignment_deg = [10, -10]\nmisalignment_sigma_deg = 5\nscale_factor_sigma = 0.1\n\
         scale_factor_instability = 0.1\nscale_factor_tau_s = 10",
    );
    succeeded_finite(&simulate(d, &scn));
}

#[test]
fn an_absurd_pitch_rate_is_refused() {
    // climb's pitch_rate_dps = 1e6 was accepted and the ramp to the grade
    // became one IMU sample (finite, silently not what was asked).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for rate in ["1e6", "90.5", "0"] {
        motion_drive(
            d,
            &format!(
                "{{ kind = \"accelerate\", to_kmh = 36 }}, \
                 {{ kind = \"climb\", grade_percent = 10, distance_m = 200, pitch_rate_dps = {rate} }}"
            ),
        );
        fails_with(&simulate(d, "m.toml"), &["m.toml", "pitch_rate_dps"]);
        assert!(!d.join("o").exists());
    }
    motion_drive(
        d,
        "{ kind = \"accelerate\", to_kmh = 36 }, \
         { kind = \"climb\", grade_percent = 10, distance_m = 200, pitch_rate_dps = 90 }",
    );
    succeeded_finite(&simulate(d, "m.toml"));
}

#[test]
fn a_map_elevation_of_the_wrong_type_says_what_is_expected() {
    // `elevation = 1` gave serde's "data did not match any variant of
    // untagged enum OneOrMany": neither the field's form nor the type.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (line, needles) in [
        (
            "elevation = 1",
            vec!["map.elevation", "integer", "a GeoTIFF path", "list"],
        ),
        (
            "elevation = 1e300",
            vec!["map.elevation", "1e300", "a GeoTIFF path"],
        ),
        (
            "elevation = { file = \"dem.tif\" }",
            vec!["map.elevation", "type: table", "a GeoTIFF path", "list"],
        ),
        ("elevation = true", vec!["map.elevation", "boolean"]),
        // Another field's array, named as TOML names it.
        (
            "geometry_error_m = [1]",
            vec!["map.geometry_error_m", "type: array"],
        ),
        (
            "elevation = [\"dem.tif\", 2]",
            vec!["map.elevation[1]", "integer", "a GeoTIFF path"],
        ),
    ] {
        let scn = map_matching(d, "s.toml", line);
        let e = fails_with(
            &simulate(d, &scn),
            &[&["s.toml: line "][..], &needles].concat(),
        );
        assert!(!e.contains("untagged"), "{e}");
        assert!(e.len() < 250, "{e}");
        assert!(!d.join("o").exists());
    }
    // A path and a list of paths are read as before (here: a missing file).
    for line in ["elevation = \"dem.tif\"", "elevation = [\"dem.tif\"]"] {
        let scn = map_matching(d, "s.toml", line);
        fails_with(&simulate(d, &scn), &["dem.tif"]);
    }
}
