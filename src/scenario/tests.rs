//! Tests of the scenario's parsing and validation.

use super::*;
use crate::units::G0;
use std::path::Path;

/// The scenario sketch of DESIGN.md parses as written (map route, all sections).
#[test]
fn design_sketch_parses() {
    let text = r#"
name = "tunnel-run"
requirement_m = 20.0
duration_s = 3600
[map]
path = "maps/helsinki.osm.pbf"
[[route]]
waypoints = [[60.170, 24.940], [60.175, 24.950]]
speed_kmh = 40
[vehicle]
width_m = 2.5
[navigator]
mode = "integrated"
[imu]
rate_hz = 100
gyro_bias_dph = [0.01, 0.01, 0.01]
accel_bias_ug = [50, 50, 50]
gyro_arw_dprh = 0.001
accel_vrw_ugprhz = 5
[odometer]
scale_factor_error = 0.00131
failure = { from_s = 3600 }
[aiding]
odometer = true
rfid = true
map_matching = false
baro = true
[rfid]
read_probability = 0.977
[planner]
coverage = "routes"
tolerate_missed_reads = 1
mountings = ["road_surface", "roadside", "ceiling"]
"#;
    let s = Scenario::parse(Path::new("/x/scn.toml"), text).unwrap();
    match &s.route {
        RouteKind::Map {
            map,
            waypoints,
            profile,
            ..
        } => {
            assert_eq!(map, Path::new("/x/maps/helsinki.osm.pbf"));
            assert_eq!(waypoints.len(), 2);
            assert!((profile.speed_mps - 40.0 / 3.6).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(s.navigator().mode, NavMode::Integrated);
    // Units converted at the edge: 0.01 °/h and 50 µg.
    assert!((s.imu.gyro_bias[0] - 0.01f64.to_radians() / 3600.0).abs() < 1e-20);
    assert!((s.imu.accel_bias[2] - 50e-6 * G0).abs() < 1e-15);
    assert_eq!(s.odometer.failure.unwrap().from_s, Some(3600.0));
}

#[test]
fn errors_name_the_file_and_line() {
    let e = Scenario::parse(Path::new("a.toml"), "name = \"x\"\n\nbogus = 1\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("a.toml: line 3:") && e.contains("bogus"),
        "{e}"
    );
    let e = Scenario::parse(
        Path::new("a.toml"),
        "name = \"x\"\n[[route]]\nstart = { lat = 95.0, lon = 0.0 }\n",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("route[0].start.lat"), "{e}");
}

/// A minimal motion route, for tests that look at other sections.
const ROUTE: &str = "name = \"x\"\n[[route]]\nstart = { lat = 30.0, lon = 117.0 }\nmotion = [ { kind = \"stay\", duration_s = 10 } ]\n";

fn parse_err(extra: &str) -> String {
    Scenario::parse(Path::new("bad.toml"), &format!("{ROUTE}{extra}"))
        .unwrap_err()
        .to_string()
}

#[test]
fn unknown_coverage_names_the_file_line_and_field() {
    let e = parse_err("[planner]\ncoverage = \"everything\"\n");
    assert_eq!(
        e,
        "bad.toml: line 6: planner.coverage \"everything\" is not one of routes, network"
    );
}

#[test]
fn unknown_u_turns_names_the_field() {
    let e = parse_err("[planner]\nu_turns = \"never\"\n");
    assert_eq!(
        e,
        "bad.toml: line 6: planner.u_turns \"never\" is not one of anywhere, dead_ends"
    );
}

#[test]
fn unknown_mountings_name_the_field() {
    let e = parse_err("[planner]\nmountings = [\"road_surface\", \"ceilling\"]\n");
    assert_eq!(
        e,
        "bad.toml: line 6: planner.mountings[1] \"ceilling\" is not one of road_surface, roadside, ceiling"
    );
    let e = parse_err("[planner]\ncost = { roadside = 1, tunnel = 2 }\n");
    assert_eq!(
        e,
        "bad.toml: line 6: planner.cost \"tunnel\" is not one of road_surface, roadside, ceiling"
    );
    let e = parse_err("[[tag]]\nat_s = 1\n[[tag]]\nat_s = 2\nmounting = \"wall\"\n");
    assert_eq!(
        e,
        "bad.toml: line 9: tag[1].mounting \"wall\" is not one of road_surface, roadside, ceiling"
    );
}

#[test]
fn unknown_modes_and_kinds_name_the_field() {
    let e = parse_err("[navigator]\nmode = \"magic\"\n");
    assert!(
        e.contains("navigator.mode \"magic\" is not one of free_inertial, dead_reckoning, dead_reckoning_3d, integrated"),
        "{e}"
    );
    let e = parse_err("[external_fix]\ninterval_s = [1, 2]\nwhite_m = 1\nadaptive = \"kalman\"\n");
    assert!(
        e.contains("line 8: external_fix.adaptive \"kalman\" is not one of none, sage_husa"),
        "{e}"
    );
    let e = Scenario::parse(
        Path::new("bad.toml"),
        "name = \"x\"\n[[route]]\nstart = { lat = 30.0, lon = 117.0 }\nmotion = [ { kind = \"stay\", duration_s = 1 }, { kind = \"fly\", duration_s = 3 } ]\n",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("line 4: route[0].motion[1].kind \"fly\" is not one of stay, accelerate"),
        "{e}"
    );
}

#[test]
fn defaults_are_applied_once() {
    let s = Scenario::parse(Path::new("a.toml"), ROUTE).unwrap();
    assert_eq!(s.name(), "x");
    assert_eq!(s.seed(), 1);
    assert_eq!(s.requirement_m(), None);
    assert_eq!(s.duration_cap_s(), f64::INFINITY);
    assert_eq!(s.filter().odometer_interval_s, 0.1);
    assert_eq!(s.filter().interval_s, 0.1);
    assert_eq!(s.navigator().vertical_tau_s, DEFAULT_VERTICAL_TAU_S);
    assert!(!s.aiding().non_holonomic);
    let p = s.planner();
    assert_eq!(p.coverage, Coverage::Routes);
    assert_eq!(p.u_turns, UTurns::Anywhere);
    assert_eq!(p.candidate_spacing_m, DEFAULT_ROUTE_SPACING_M);
    assert_eq!(p.validation_runs, 100);
    assert_eq!(p.mountings.len(), 3);
    assert_eq!(p.mountings[2].cost, 3.0);
    let s = Scenario::parse(
        Path::new("a.toml"),
        &format!("{ROUTE}seed = 7\n[planner]\ncoverage = \"network\"\nu_turns = \"dead_ends\"\n")
            .replacen("seed = 7\n", "", 1)
            .replacen(
                "name = \"x\"\n",
                "name = \"x\"\nseed = 7\nduration_s = 60\n",
                1,
            ),
    )
    .unwrap();
    assert_eq!(s.seed(), 7);
    assert_eq!(s.duration_cap_s(), 60.0);
    assert_eq!(s.planner().coverage, Coverage::Network);
    assert_eq!(s.planner().u_turns, UTurns::DeadEnds);
    assert_eq!(s.planner().candidate_spacing_m, DEFAULT_NETWORK_SPACING_M);
    // Two reach levels unless asked for one.
    assert_eq!(s.planner().reach_levels, 2);
}

#[test]
fn reach_levels_are_one_or_two_and_for_trips_only() {
    let net = "[planner]\ncoverage = \"network\"\n";
    let ok = |extra: &str| {
        Scenario::parse(Path::new("a.toml"), &format!("{ROUTE}{net}{extra}"))
            .unwrap()
            .planner()
            .reach_levels
    };
    assert_eq!(ok("reach_levels = 1\n"), 1);
    assert_eq!(ok("reach_levels = 2\n"), 2);
    for bad in ["reach_levels = 0\n", "reach_levels = 3\n"] {
        let e = parse_err(&format!("{net}{bad}"));
        assert!(
            e.starts_with("bad.toml: planner.reach_levels = ") && e.contains("must be 1"),
            "{e}"
        );
    }
    let e = parse_err(&format!("{net}traffic = \"any_walk\"\nreach_levels = 2\n"));
    assert!(e.contains("reach_levels applies to"), "{e}");
    let e = parse_err("[planner]\nreach_levels = 1\n");
    assert!(e.contains("reach_levels applies to"), "{e}");
    // Not a number: serde names the field.
    let e = parse_err(&format!("{net}reach_levels = \"two\"\n"));
    assert!(e.contains("reach_levels"), "{e}");
}

#[test]
fn cold_starts_are_bounded_and_for_two_level_trips_only() {
    use super::planner_section::MAX_COLD_STARTS;
    let net = "[planner]\ncoverage = \"network\"\n";
    let ok = |extra: &str| {
        Scenario::parse(Path::new("a.toml"), &format!("{ROUTE}{net}{extra}"))
            .unwrap()
            .planner()
            .cold_starts
    };
    // Default: none given, the planner derives it from ε and β.
    assert_eq!(ok(""), None);
    assert_eq!(ok("cold_starts = 0\n"), Some(0));
    assert_eq!(
        ok(&format!("cold_starts = {MAX_COLD_STARTS}\n")),
        Some(MAX_COLD_STARTS)
    );
    let e = parse_err(&format!("{net}cold_starts = {}\n", MAX_COLD_STARTS + 1));
    assert!(
        e.starts_with("bad.toml: planner.cold_starts = ") && e.contains("at most"),
        "{e}"
    );
    for other in [
        "traffic = \"any_walk\"\ncold_starts = 10\n",
        "reach_levels = 1\ncold_starts = 10\n",
    ] {
        let e = parse_err(&format!("{net}{other}"));
        assert!(e.contains("cold_starts applies to"), "{e}");
    }
    let e = parse_err("[planner]\ncold_starts = 10\n");
    assert!(e.contains("cold_starts applies to"), "{e}");
    let e = parse_err(&format!("{net}cold_starts = -1\n"));
    assert!(e.contains("cold_starts"), "{e}");
}

#[test]
fn discarded_beginnings_are_at_most_the_beginnings_and_for_two_level_trips_only() {
    let net = "[planner]\ncoverage = \"network\"\n";
    let ok = |extra: &str| {
        Scenario::parse(Path::new("a.toml"), &format!("{ROUTE}{net}{extra}"))
            .unwrap()
            .planner()
            .discarded_beginnings
    };
    // Default: none given, the planner derives it from the certification.
    assert_eq!(ok(""), None);
    assert_eq!(ok("discarded_beginnings = 0\n"), Some(0));
    assert_eq!(
        ok("cold_starts = 100\ndiscarded_beginnings = 100\n"),
        Some(100)
    );
    let e = parse_err(&format!(
        "{net}cold_starts = 100\ndiscarded_beginnings = 101\n"
    ));
    assert!(
        e.starts_with("bad.toml: planner.discarded_beginnings = 101 must be at most")
            && e.contains("cold_starts = 100")
            && !e.contains('\n'),
        "{e}"
    );
    for other in [
        "traffic = \"any_walk\"\ndiscarded_beginnings = 10\n",
        "reach_levels = 1\ndiscarded_beginnings = 10\n",
    ] {
        let e = parse_err(&format!("{net}{other}"));
        assert!(e.contains("discarded_beginnings applies to"), "{e}");
    }
    let e = parse_err("[planner]\ndiscarded_beginnings = 10\n");
    assert!(e.contains("discarded_beginnings applies to"), "{e}");
    let e = parse_err(&format!("{net}discarded_beginnings = -1\n"));
    assert!(e.contains("discarded_beginnings"), "{e}");
}

#[test]
fn unknown_fields_name_their_table() {
    let e = parse_err("[imu]\nsurprise = 1\n");
    assert!(
        e.starts_with("bad.toml: line 6: imu: unknown field `surprise`"),
        "{e}"
    );
    let e = parse_err("[external_fix]\ninterval_s = [1, 2]\n");
    assert_eq!(e, "bad.toml: line 5: external_fix: missing field `white_m`");
}

/// `[map] geometry_error_m` / `geometry_error_correlation_m`: defaults, set
/// values, and one error naming the file and the field for each bad value.
#[test]
fn map_geometry_error_is_validated() {
    let scn = |extra: &str| {
        format!(
            "name = \"x\"\n[map]\npath = \"m.osm\"\n{extra}\n[[route]]\nwaypoints = [[60.17, 24.94], [60.175, 24.95]]\n[imu]\nrate_hz = 100\n"
        )
    };
    let p = Path::new("/x/scn.toml");
    let d = Scenario::parse(p, &scn("")).unwrap();
    assert_eq!(d.map_error.sigma_m, sections::DEFAULT_MAP_GEOMETRY_ERROR_M);
    assert_eq!(d.map_error.correlation_m, 200.0);
    let s = Scenario::parse(
        p,
        &scn("geometry_error_m = 0\ngeometry_error_correlation_m = 50"),
    )
    .unwrap();
    assert_eq!(s.map_error.sigma_m, 0.0);
    assert_eq!(s.map_error.correlation_m, 50.0);
    for (extra, field) in [
        ("geometry_error_m = -1", "map.geometry_error_m"),
        ("geometry_error_m = nan", "map.geometry_error_m"),
        ("geometry_error_m = inf", "map.geometry_error_m"),
        (
            "geometry_error_correlation_m = 0",
            "map.geometry_error_correlation_m",
        ),
        (
            "geometry_error_correlation_m = -5",
            "map.geometry_error_correlation_m",
        ),
        (
            "geometry_error_correlation_m = inf",
            "map.geometry_error_correlation_m",
        ),
    ] {
        let e = Scenario::parse(p, &scn(extra)).unwrap_err().to_string();
        assert!(e.contains("scn.toml") && e.contains(field), "{extra}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

/// `[map] elevation`: one file or a list, resolved against the scenario's
/// folder; an empty list and a constant `route[0].height_m` beside it are
/// errors naming the field.
#[test]
fn map_elevation_is_one_file_or_a_list() {
    let base = |map: &str, route: &str| {
        format!(
            "name = \"e\"\n[map]\npath = \"m.osm.pbf\"\n{map}\n[[route]]\n\
             waypoints = [[60.17, 24.94], [60.175, 24.95]]\n{route}\n"
        )
    };
    let load = |t: &str| Scenario::parse(Path::new("/data/scn/s.toml"), t);
    let s = load(&base("", "")).unwrap();
    assert!(s.elevation.is_empty());
    let s = load(&base("elevation = \"dem.tif\"", "")).unwrap();
    assert_eq!(
        s.elevation,
        vec![Path::new("/data/scn/dem.tif").to_path_buf()]
    );
    let s = load(&base("elevation = [\"a.tif\", \"../b.tif\"]", "")).unwrap();
    assert_eq!(
        s.elevation,
        vec![
            Path::new("/data/scn/a.tif").to_path_buf(),
            Path::new("/data/scn/../b.tif").to_path_buf()
        ]
    );
    let e = load(&base("elevation = []", "")).unwrap_err().to_string();
    assert!(e.contains("map.elevation is an empty list"), "{e}");
    let e = load(&base("elevation = \"dem.tif\"", "height_m = 5"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("route[0].height_m") && e.contains("map.elevation"),
        "{e}"
    );
    let e = load(&base("elevation = 3", "")).unwrap_err().to_string();
    assert!(e.contains("elevation"), "{e}");
}

/// A network plan's candidate sites, counted on the map before planning:
/// `ceil(length / spacing)` per permitted direction of each section, at
/// least one.
#[test]
fn network_candidate_sites_are_counted_per_direction() {
    use crate::network::{model_from_polylines, Oneway, RoadAttributes};
    let road = |id: &str, oneway| RoadAttributes::new(id, "residential", oneway);
    // 0.001° of latitude ≈ 111.4 m (two-way: 3 sites each way at 50 m),
    // 0.0001° ≈ 11.1 m (one-way: 1 site), far apart (no shared node).
    let net = model_from_polylines(vec![
        (
            road("a", Oneway::Both),
            vec![vec![[60.0, 24.0], [60.001, 24.0]]],
        ),
        (
            road("b", Oneway::Forward),
            vec![vec![[60.0, 24.01], [60.0001, 24.01]]],
        ),
    ])
    .unwrap();
    let scn = |spacing: &str| {
        Scenario::parse(
            Path::new("a.toml"),
            &format!("{ROUTE}[planner]\ncandidate_spacing_m = {spacing}\n"),
        )
        .unwrap()
    };
    assert_eq!(check_network_candidates(&scn("50"), &net).unwrap(), 7);
    // Every metre: 112 per direction of the 111.4 m road, 12 on the other.
    assert_eq!(check_network_candidates(&scn("1"), &net).unwrap(), 236);
}

#[test]
fn odometer_mounting_errors_are_checked_and_set_the_filter_priors() {
    let e = parse_err("[odometer]\nmisalignment_deg = [0, 12]\n");
    assert!(
        e.starts_with("bad.toml: ")
            && e.contains("odometer.misalignment_deg[1] (yaw) must be between -10 and 10, got 12"),
        "{e}"
    );
    // Read exactly: a third number is refused, not dropped.
    let e = parse_err("[odometer]\nmisalignment_deg = [0.1, 0.2, 0.3]\n");
    assert!(
        e.contains("invalid length 3, expected an array of length 2"),
        "{e}"
    );
    let e = parse_err("[odometer]\nscale_factor_sigma = -1e-3\n");
    assert!(
        e.contains("odometer.scale_factor_sigma must be between 0 and 0.1"),
        "{e}"
    );
    let e = parse_err("[odometer]\nmisalignment_sigma_deg = nan\n");
    assert!(e.contains("odometer.misalignment_sigma_deg"), "{e}");
    let e = parse_err(
        "[imu]\nrotation_modulation = { rate_dps = 6 }\n[odometer]\nmisalignment_deg = [0.1, 0]\n",
    );
    assert!(
        e.contains("cannot be combined with imu.rotation_modulation"),
        "{e}"
    );
    // The filter's priors cover the simulated errors: the larger fixed
    // angle with the per-run σ, and the fixed scale factor with its σ.
    let s = Scenario::parse(
        Path::new("a.toml"),
        &format!(
            "{ROUTE}[odometer]\nscale_factor_error = 3e-3\nscale_factor_sigma = 4e-3\n\
             misalignment_deg = [0.3, -0.4]\nmisalignment_sigma_deg = 0.3\n"
        ),
    )
    .unwrap();
    let f = s.filter();
    assert!((f.odometer_scale_sigma - 5e-3).abs() < 1e-15);
    assert!((f.odometer_misalignment_sigma - 0.5f64.to_radians()).abs() < 1e-15);
    assert_eq!(
        s.odometer.misalignment,
        [0.3f64.to_radians(), (-0.4f64).to_radians()]
    );
    // Without them, the defaults of before (5e-4 at least, 0.2°, a random
    // constant), and the time-varying part's correlation time 3600 s.
    let s = Scenario::parse(Path::new("a.toml"), ROUTE).unwrap();
    assert_eq!(s.filter().odometer_scale_sigma, 5e-4);
    assert_eq!(s.filter().odometer_scale_tau_s, 1e6);
    assert_eq!(s.filter().odometer_misalignment_sigma, 0.2f64.to_radians());
    assert_eq!(s.odometer.scale_factor_tau_s, 3600.0);
    // A time-varying scale factor: checked, and the filter's state follows
    // it (σ with the others, the process's correlation time).
    let e = parse_err("[odometer]\nscale_factor_instability = 0.2\n");
    assert!(
        e.contains("odometer.scale_factor_instability must be between 0 and 0.1"),
        "{e}"
    );
    let e = parse_err("[odometer]\nscale_factor_tau_s = 1\n");
    assert!(e.contains("odometer.scale_factor_tau_s"), "{e}");
    let s = Scenario::parse(
        Path::new("a.toml"),
        &format!("{ROUTE}[odometer]\nscale_factor_error = 3e-3\nscale_factor_instability = 4e-3\nscale_factor_tau_s = 600\n"),
    )
    .unwrap();
    assert!((s.filter().odometer_scale_sigma - 5e-3).abs() < 1e-15);
    assert_eq!(s.filter().odometer_scale_tau_s, 600.0);
}
