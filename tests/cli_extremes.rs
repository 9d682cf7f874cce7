//! Extreme values of a scenario's physical terms as a user types them
//! (1e308, 1e-300, a duplicated id): each is refused through the real
//! binary with one error line naming the file, the field and the limit,
//! exit code 1, and no output folder (the companion of
//! `tests/cli_reliability.rs`, whose helpers these mirror).

mod common;

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
