//! `waymark simulate` run as a real binary on the scenarios in `scenarios/`,
//! checked against closed-form inertial error physics, dead-reckoning error
//! budgets and the rotation-modulation claim; and on bad input.

use crate::common;

use common::{repo, run};

use std::path::{Path, PathBuf};
use waymark::geodesy::{meridian_radius, normal_gravity, prime_vertical_radius};

/// One row of errors.csv.
#[derive(Debug, Clone, Copy)]
struct Row {
    t: f64,
    distance: f64,
    east: f64,
    north: f64,
    up: f64,
    horizontal: f64,
}

/// Runs a scenario (extra CLI args allowed) and returns errors.csv rows and summary.json.
fn simulate(scenario: &str, extra: &[&str]) -> (Vec<Row>, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let path = repo(scenario);
    let mut args = vec!["simulate", path.to_str().unwrap(), "--out", "out"];
    args.extend_from_slice(extra);
    let out = run(&args, dir.path());
    assert!(
        out.status.success(),
        "{scenario}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(dir.path().join("out/errors.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,distance_m,east_m,north_m,up_m,horizontal_m,sigma_east_m,sigma_north_m,sigma_up_m,bound95_m"
    );
    let rows = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 10, "{l}");
            assert!(f[6..].iter().all(|x| x.is_empty()), "{l}");
            let p = |i: usize| f[i].parse::<f64>().unwrap();
            Row {
                t: p(0),
                distance: p(1),
                east: p(2),
                north: p(3),
                up: p(4),
                horizontal: p(5),
            }
        })
        .collect();
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap(),
    )
    .unwrap();
    // Exactly the output files: no temporary files left behind by the atomic writes.
    let mut names: Vec<String> = std::fs::read_dir(dir.path().join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["errors.csv", "inputs.json", "scenario.toml", "summary.json"]
    );
    (rows, summary)
}

fn at(rows: &[Row], t: f64) -> Row {
    *rows
        .iter()
        .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
        .unwrap()
}

/// Earth radius, gravity and Schuler frequency at 30° N on the ellipsoid: the
/// closed forms use the Gaussian mean radius √(R_M R_N).
fn schuler() -> (f64, f64, f64) {
    let lat = 30f64.to_radians();
    let r = (meridian_radius(lat) * prime_vertical_radius(lat)).sqrt();
    let g = normal_gravity(lat, 0.0);
    (r, g, (g / r).sqrt())
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

// Tolerance of the Schuler tests: 3 % (issue 3). The closed forms neglect the
// coupling of the horizontal channels through the Earth rate (Foucault
// oscillation, period 2·12 h/sin 30° = 48 h, and the ω_ie terms of the
// attitude equations); over half a Schuler period these change the north
// error by about 1 %, and rotate part of it into east, which the tests report.

#[test]
fn schuler_north_accelerometer_bias() {
    let (rows, summary) = simulate("scenarios/schuler-accel-bias.toml", &[]);
    let (r, g, ws) = schuler();
    let b = 100e-6 * 9.80665;
    for t in [1266.0, 2532.0] {
        let row = at(&rows, t);
        let expect = r * b / g * (1.0 - (ws * row.t).cos());
        eprintln!(
            "accel bias: t {} s north {:.1} m, closed form {:.1} m, east {:.1} m",
            row.t, row.north, expect, row.east
        );
        assert!(
            rel(row.north, expect) < 0.03,
            "north {} vs {}",
            row.north,
            expect
        );
    }
    // Half a Schuler period: the issue quotes 1,277 m.
    assert!((at(&rows, 2532.0).north - 1277.0).abs() < 0.03 * 1277.0);
    assert_eq!(summary["runs"], 1);
    assert!(summary["time_to_exceed_requirement_s"].is_null());
}

#[test]
fn schuler_east_gyro_bias() {
    let (rows, _) = simulate("scenarios/schuler-gyro-bias.toml", &[]);
    let (r, _, ws) = schuler();
    let eps = 0.01f64.to_radians() / 3600.0;
    for t in [1266.0, 2532.0] {
        let row = at(&rows, t);
        let expect = r * eps * (row.t - (ws * row.t).sin() / ws);
        eprintln!(
            "gyro bias: t {} s north {:.1} m, closed-form magnitude {:.1} m",
            row.t, row.north, expect
        );
        assert!(
            rel(row.north.abs(), expect) < 0.03,
            "north {} vs {}",
            row.north,
            expect
        );
    }
    assert!((at(&rows, 2532.0).north.abs() - 782.0).abs() < 0.03 * 782.0);
}

#[test]
fn schuler_initial_tilt() {
    let (rows, _) = simulate("scenarios/schuler-initial-tilt.toml", &[]);
    let (r, _, ws) = schuler();
    let tilt = (0.5f64 / 60.0).to_radians();
    for t in [1266.0, 2532.0] {
        let row = at(&rows, t);
        // Nose-up pitch error facing north: gravity leaks into a southward force.
        let expect = -r * tilt * (1.0 - (ws * row.t).cos());
        eprintln!(
            "tilt: t {} s north {:.1} m, closed form {:.1} m",
            row.t, row.north, expect
        );
        assert!(
            rel(row.north, expect) < 0.03,
            "north {} vs {}",
            row.north,
            expect
        );
    }
}

#[test]
fn schuler_initial_velocity_error() {
    let (rows, _) = simulate("scenarios/schuler-initial-velocity.toml", &[]);
    let (_, _, ws) = schuler();
    for t in [600.0, 1266.0] {
        let row = at(&rows, t);
        let expect = 0.1 / ws * (ws * row.t).sin();
        eprintln!(
            "velocity: t {} s north {:.2} m, closed form {:.2} m",
            row.t, row.north, expect
        );
        assert!(
            rel(row.north, expect) < 0.03,
            "north {} vs {}",
            row.north,
            expect
        );
    }
}

// Dead-reckoning tolerance: 2 % (issue 3). The remaining differences are the
// trapezoid-rule start and stop of the odometer and, for the heading case,
// the slow gyrocompass-driven change of the inertial heading error over
// 1,000 s (below 0.1 %).

#[test]
fn odometer_dr_scale_factor_gives_proportional_along_track_error() {
    let (rows, _) = simulate("scenarios/dr-straight-10km.toml", &[]);
    let last = rows.last().unwrap();
    assert!(last.distance > 9_999.0);
    // Heading 45°: along-track is the projection on (sin 45°, cos 45°).
    let h = 45f64.to_radians();
    let along = last.east * h.sin() + last.north * h.cos();
    let cross = last.east * h.cos() - last.north * h.sin();
    let expect = 0.002 * last.distance;
    eprintln!("DR scale factor: along {along:.3} m, expected {expect:.3} m, cross {cross:.4} m");
    assert!(rel(along, expect) < 0.02);
    assert!(cross.abs() < 0.02 * expect);
}

#[test]
fn odometer_dr_heading_error_gives_proportional_cross_track_error() {
    let (rows, _) = simulate("scenarios/dr-straight-10km-heading.toml", &[]);
    let last = rows.last().unwrap();
    let h = 45f64.to_radians();
    let along = last.east * h.sin() + last.north * h.cos();
    let cross = last.east * h.cos() - last.north * h.sin();
    let dpsi = (10.0f64 / 60.0).to_radians();
    let expect = dpsi * last.distance;
    eprintln!("DR heading: cross {cross:.3} m, expected {expect:.3} m, along {along:.4} m");
    // Heading error clockwise: the track lies to the right (positive cross-track).
    assert!(rel(cross, expect) < 0.02);
    assert!(along.abs() < 0.02 * expect);
}

/// The paper's 3-D DR drive (PAPERS.md §2.1: heading 45°, pitch 5°, 2'
/// heading error) at 50 min: its horizontal distance and climb, the error
/// along and across the track, and the heading error.
struct Dr3dBudget {
    horiz: f64,
    climb: f64,
    along: f64,
    cross: f64,
    dpsi: f64,
}

fn dr3d_at_50_min(rows: &[Row]) -> (Row, Dr3dBudget) {
    let row = at(rows, 3000.0);
    let pitch = 5f64.to_radians();
    let h = 45f64.to_radians();
    let b = Dr3dBudget {
        horiz: row.distance * pitch.cos(),
        climb: row.distance * pitch.sin(),
        along: row.east * h.sin() + row.north * h.cos(),
        cross: row.east * h.cos() - row.north * h.sin(),
        dpsi: -(2.0f64 / 60.0).to_radians(),
    };
    (row, b)
}

#[test]
fn dr3d_paper_scenario_matches_its_error_budget() {
    // PAPERS.md §2.1. The paper's figures at 50 min (east 29.1, north 48.2,
    // up 14.5 m) are reported beside ours in BENCHMARKS.md; this test
    // checks our 3-D DR against the first-order budget of its error sources:
    // along-track 0.2 % of the horizontal distance, cross-track heading error
    // (2' anticlockwise) × horizontal distance, up 0.3 % of the climb. 2 %.
    let (rows, _) = simulate("scenarios/dr3d-paper.toml", &[]);
    let (
        row,
        Dr3dBudget {
            horiz,
            climb,
            along,
            cross,
            dpsi,
        },
    ) = dr3d_at_50_min(&rows);
    eprintln!(
        "3-D DR at 50 min: east {:.1} m (paper 29.1), north {:.1} m (paper 48.2), up {:.1} m (paper 14.5)",
        row.east, row.north, row.up
    );
    assert!(rel(along, 0.002 * horiz) < 0.02, "along {along}");
    assert!(rel(cross, dpsi * horiz) < 0.02, "cross {cross}");
    assert!(rel(row.up, 0.003 * climb) < 0.02, "up {}", row.up);
}

#[test]
fn dr3d_with_a_noisy_altimeter_keeps_its_error_budget() {
    // The paper's scenario with the default altimeter noise (0.5 m white at
    // 10 Hz) instead of none. Pitch taken per step (sin θ = Δh / S) was
    // mostly noise: every step came out short by cos θ and the drive by
    // 29 % (8.6 km behind at 50 min, measured). Taken over a 25 m baseline
    // (50 σ, src/nav/dr3d.rs) the shortening is σ²/W² = 4e-4 on average,
    // so along-track is (0.2 % − 0.04 %) of the horizontal distance; 0.02 %
    // of the distance (6 m) for the pitch noise's own share. Cross-track is
    // the noise-free test's budget (2 %); up is the climb's 0.3 % within 5 %
    // plus 2 m (4 σ of the last sample's 0.5 m noise).
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo("scenarios/dr3d-paper.toml")).unwrap();
    assert!(text.contains("\nnoise_m = 0.0\n"));
    let noisy = dir.path().join("dr3d-noisy.toml");
    std::fs::write(
        &noisy,
        text.replace("\nnoise_m = 0.0\n", "\nnoise_m = 0.5\n"),
    )
    .unwrap();
    let (rows, _) = simulate(noisy.to_str().unwrap(), &[]);
    let (
        row,
        Dr3dBudget {
            horiz,
            climb,
            along,
            cross,
            dpsi,
        },
    ) = dr3d_at_50_min(&rows);
    eprintln!(
        "3-D DR, noisy altimeter, at 50 min: along {along:.1} m, cross {cross:.1} m, up {:.1} m",
        row.up
    );
    let want = (0.002 - 4e-4) * horiz;
    assert!(
        (along - want).abs() < 2e-4 * horiz,
        "along {along}, want {want}"
    );
    assert!(rel(cross, dpsi * horiz) < 0.02, "cross {cross}");
    assert!(
        (row.up - 0.003 * climb).abs() < 0.05 * 0.003 * climb + 2.0,
        "up {}",
        row.up
    );
}

#[test]
fn a_perfect_imu_is_noted() {
    // A scenario without [imu] simulates a perfect IMU: an integrated run
    // showed 0.2 m after a kilometre without a word on why. Now a note on
    // stderr says so; a graded IMU, or the 3-D DR (no IMU), gets none.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, mode: &str, extra: &str| {
        let text = format!(
            "name = \"x\"\n[[route]]\n\
             start = {{ lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = 45 }}\n\
             motion = [ {{ kind = \"accelerate\", to_kmh = 36 }}, {{ kind = \"cruise\", duration_s = 100 }} ]\n\
             [navigator]\nmode = \"{mode}\"\n[aiding]\nodometer = true\n{extra}"
        );
        std::fs::write(d.join(name), text).unwrap();
        name.to_string()
    };
    let stderr_of = |scn: &str| {
        let out = run(&["simulate", scn, "--out", "o"], d);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let note = "[imu] has no error terms";
    let err = stderr_of(&write("perfect.toml", "integrated", ""));
    assert!(err.contains(note) && err.contains("perfect.toml"), "{err}");
    for (name, mode, extra) in [
        ("graded.toml", "integrated", "[imu]\ngrade = \"tactical\"\n"),
        ("biased.toml", "integrated", "[imu]\ngyro_arw_dprh = 0.1\n"),
        ("dr3d.toml", "dead_reckoning_3d", ""),
    ] {
        let err = stderr_of(&write(name, mode, extra));
        assert!(!err.contains(note), "{name}: {err}");
    }
    // Quiet: nothing.
    let out = run(&["simulate", "perfect.toml", "--out", "o", "-q"], d);
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn rotation_modulation_cuts_the_error_at_least_fivefold() {
    let (off, _) = simulate("scenarios/rotation-modulation-off.toml", &[]);
    let (on, _) = simulate("scenarios/rotation-modulation-on.toml", &[]);
    let e_off = at(&off, 3600.0).horizontal;
    let e_on = at(&on, 3600.0).horizontal;
    eprintln!("rotation modulation: 1 h horizontal error off {e_off:.1} m, on {e_on:.1} m");
    assert!(e_off > 5.0 * e_on, "off {e_off} on {e_on}");
    let max_on = on.iter().map(|r| r.horizontal).fold(0.0, f64::max);
    let max_off = off.iter().map(|r| r.horizontal).fold(0.0, f64::max);
    assert!(max_off > 5.0 * max_on);
}

fn noisy_scenario(dir: &Path) -> PathBuf {
    let p = dir.join("noisy.toml");
    std::fs::write(
        &p,
        r#"
name = "noisy"
requirement_m = 5.0
[[route]]
start = { lat = 45.0, lon = 7.0, heading_deg = 90.0 }
motion = [ { kind = "accelerate", to_kmh = 50 }, { kind = "turn", angle_deg = 90, radius_m = 60 },
           { kind = "climb", grade_percent = 4, distance_m = 300 }, { kind = "cruise", duration_s = 200 } ]
[navigator]
mode = "dead_reckoning"
[imu]
gyro_bias_dph = [1, 1, 1]
gyro_arw_dprh = 0.05
accel_vrw_ugprhz = 50
gyro_bias_instability_dph = 0.5
[odometer]
scale_factor_error = 0.003
noise_mps = 0.05
pulse_m = 0.02
slip = { rate_per_km = 1, length_m = 5, overcount = 0.1 }
"#,
    )
    .unwrap();
    p
}

#[test]
fn same_seed_same_output_and_runs_differ() {
    let dir = tempfile::tempdir().unwrap();
    let p = noisy_scenario(dir.path());
    let ps = p.to_str().unwrap();
    for (out, seed) in [("a", "3"), ("b", "3"), ("c", "4")] {
        let o = run(
            &["simulate", ps, "--runs", "3", "--seed", seed, "--out", out],
            dir.path(),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let read = |d: &str, f: &str| std::fs::read_to_string(dir.path().join(d).join(f)).unwrap();
    assert_eq!(read("a", "errors.csv"), read("b", "errors.csv"));
    assert_eq!(read("a", "summary.json"), read("b", "summary.json"));
    assert_ne!(read("a", "errors.csv"), read("c", "errors.csv"));
    let s: serde_json::Value = serde_json::from_str(&read("a", "summary.json")).unwrap();
    assert_eq!(s["runs"], 3);
    let per = s["per_run"].as_array().unwrap();
    assert_eq!(per.len(), 3);
    assert_ne!(
        per[0]["max_horizontal_error_m"],
        per[1]["max_horizontal_error_m"]
    );
    for key in [
        "duration_s",
        "distance_m",
        "max_horizontal_error_m",
        "rms_horizontal_error_m",
        "p95_horizontal_error_m",
        "requirement_m",
        "fraction_within_requirement",
    ] {
        assert!(s[key].is_number(), "{key}: {}", s[key]);
    }
    let f = s["fraction_within_requirement"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&f));
    assert!(s.get("time_to_exceed_requirement_s").is_some());
}

/// Writes a scenario with `body`, runs it and asserts a clean one-line error
/// naming the file and containing `needle`.
fn bad(body: &str, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(&p, body).unwrap();
    let o = run(&["simulate", "bad.toml", "--out", "out"], dir.path());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("bad.toml"), "{err}");
    assert!(err.contains(needle), "wanted {needle:?} in {err}");
    assert!(!dir.path().join("out").exists());
}

const GOOD_ROUTE: &str = r#"
[[route]]
start = { lat = 30.0, lon = 117.0 }
motion = [ { kind = "stay", duration_s = 10 } ]
"#;

#[test]
fn bad_scenarios_give_clear_errors() {
    bad(
        &format!("name = \"x\"\ncolour = 3\n{GOOD_ROUTE}"),
        "unknown field `colour`",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[imu]\nrate_hz = -100\n"),
        "imu.rate_hz",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[imu]\ngyro_arw_dprh = -0.1\n"),
        "imu.gyro_arw_dprh must be zero or positive",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[imu]\ngyro_bias_dph = [0.01, nan, 0]\n"),
        "imu.gyro_bias_dph[1] must be a finite number",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[imu]\nsurprise = 1\n"),
        "unknown field `surprise`",
    );
    bad(
        "name = \"x\"\n[[route]]\nstart = { lat = 30.0, lon = 117.0 }\nmotion = [ { kind = \"turn\", angle_deg = 90, radius_m = 20 } ]\n",
        "cannot turn while stopped",
    );
    bad(
        "name = \"x\"\n[[route]]\nstart = { lat = 30.0, lon = 117.0 }\nmotion = [ { kind = \"accelerate\", to_kmh = 100 }, { kind = \"turn\", angle_deg = 90, radius_m = 5 } ]\n",
        "lateral acceleration",
    );
    bad(
        "name = \"x\"\n[[route]]\nstart = { lat = 30.0, lon = 117.0 }\nmotion = [ { kind = \"stay\", duration_s = 1e300 } ]\n",
        "30 days",
    );
    bad(
        "name = \"x\"\n[[route]]\nstart = { lat = 30.0, lon = 117.0 }\nmotion = [ { kind = \"fly\", duration_s = 3 } ]\n",
        "kind \"fly\"",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[imu]\nrotation_modulation = {{ rate_dps = 6 }}\n"),
        "rotation_modulation",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[[tag]]\nat_s = 3\nmounting = \"wall\"\n"),
        "tag[0].mounting \"wall\"",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[[tag]]\nlat = 30.0\nat_s = 3\n"),
        "tag[0] needs exactly one of lat+lon, at_s and at_m",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[[tag]]\nat_s = 3000\n"),
        "tag[0].at_s = 3000 is beyond the end of the route",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[aiding]\nmap_matching = true\n"),
        "aiding.map_matching needs a map route",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[aiding]\nexternal_fix = true\n"),
        "aiding.external_fix needs an [external_fix] section",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[navigator]\nmode = \"integrated\"\n[external_fix]\ninterval_s = [10, 50]\nwhite_m = 5\nadaptive = \"magic\"\n"),
        "external_fix.adaptive \"magic\"",
    );
    bad(
        &format!("name = \"x\"\n{GOOD_ROUTE}\n[odometer]\nfailure = {{ from_s = -5 }}\n"),
        "odometer.failure.from_s",
    );
    let map = repo("maps/helsinki.osm.pbf");
    bad(
        &format!(
            "name = \"x\"\n[map]\npath = {:?}\n[[route]]\nwaypoints = [[10.0, 10.0], [10.001, 10.001]]\n",
            map.to_str().unwrap()
        ),
        "route[0]",
    );
}

#[test]
fn missing_scenario_file_is_a_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["simulate", "nope.toml"], dir.path());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("nope.toml") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn map_route_simulates_on_the_bundled_map() {
    let dir = tempfile::tempdir().unwrap();
    let map = repo("maps/helsinki.osm.pbf");
    let p = dir.path().join("city.toml");
    std::fs::write(
        &p,
        format!(
            r#"
name = "city"
requirement_m = 10.0
[map]
path = {:?}
[[route]]
waypoints = [[60.1660, 24.9380], [60.1770, 24.9510], [60.1660, 24.9380]]
speed_kmh = 40
stops = [ {{ at_m = 300, duration_s = 5 }} ]
[navigator]
mode = "dead_reckoning"
[odometer]
scale_factor_error = 0.001
"#,
            map.to_str().unwrap()
        ),
    )
    .unwrap();
    let o = run(&["simulate", "city.toml", "--out", "out"], dir.path());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap(),
    )
    .unwrap();
    let d = s["distance_m"].as_f64().unwrap();
    assert!(d > 500.0, "distance {d}");
    // A perfect IMU and a 0.1 % odometer: the error stays near 0.1 % of the distance.
    let max = s["max_horizontal_error_m"].as_f64().unwrap();
    assert!(max < 0.002 * d + 0.5, "max error {max} over {d} m");
}
