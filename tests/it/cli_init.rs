//! `waymark init` writes a commented starting scenario the other commands
//! accept; `[imu] grade` presets fill the fields a scenario leaves out and
//! every given field overrides them.

use std::path::Path;
use std::process::{Command, Output};
use waymark::scenario::{Coverage, ImuGrade, RouteKind, Scenario};
use waymark::units::DPH;

fn bin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .output()
        .expect("binary runs")
}

fn text_of(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap()
}

fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

#[test]
fn init_writes_scenarios_that_parse_on_a_map_and_without() {
    let dir = tempfile::tempdir().unwrap();
    // Without a map: a motion-command drive, the industrial preset.
    let plain = dir.path().join("plain.toml");
    let o = bin(&["init", "--out", plain.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&plain).unwrap();
    assert!(text.starts_with("# A starting scenario"), "commented");
    let scn = Scenario::load(&plain).unwrap();
    assert!(matches!(scn.route, RouteKind::Motion { .. }));
    // No map to match against.
    assert!(!scn.aiding().map_matching);
    let [g, _, arw, _] = ImuGrade::Industrial.figures();
    assert!((scn.imu.gyro_bias[0] - g * DPH).abs() < 1e-15);
    assert!(scn.imu.gyro_arw > 0.0 && arw > 0.0);
    // It is not overwritten.
    let o = bin(&["init", "--out", plain.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("already exists") && err.lines().count() == 1,
        "{err}"
    );

    // On a map, network coverage: the waypoints route on it.
    let area = dir.path().join("sub/area.toml");
    let o = bin(&[
        "init",
        "--map",
        &repo("maps/helsinki.osm.pbf"),
        "--network",
        "--out",
        area.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["waypoints"].as_array().unwrap().len(), 2);
    let scn = Scenario::load(&area).unwrap();
    assert_eq!(scn.planner().coverage, Coverage::Network);
    // On a map the navigator matches it: the area planner's model credits
    // the turns (without, Liechtenstein's init plan needs 981 tags and 6 min
    // instead of 28 tags and 48 s; BENCHMARKS.md).
    assert!(scn.aiding().map_matching);
    // The map-accuracy keys it shows commented out are the defaults: the
    // file means the same with them given.
    let text = text_of(&area);
    assert!(text.contains("# geometry_error_m = 4.8\n"), "{text}");
    let given = dir.path().join("sub/given.toml");
    std::fs::write(&given, text.replace("# geometry_error", "geometry_error")).unwrap();
    let with_keys = Scenario::load(&given).unwrap();
    assert_eq!(with_keys.map_error, scn.map_error);
    let RouteKind::Map { map, waypoints, .. } = &scn.route else {
        panic!("not on the map")
    };
    let net = waymark::network::Network::load(map, &Default::default()).unwrap();
    let route = waymark::route::plan_route(&net, waypoints).unwrap();
    assert!(route.length_m > 500.0, "{}", route.length_m);

    // --network needs --map: a command-line error.
    let o = bin(&[
        "init",
        "--network",
        "--out",
        dir.path().join("x.toml").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn an_output_named_with_250_bytes_is_written() {
    // Its temporary file `.NAME.tmpPID` was past the file systems' 255
    // bytes: "File name too long (os error 36)".
    let dir = tempfile::tempdir().unwrap();
    let name = "s".repeat(245) + ".toml";
    assert_eq!(name.len(), 250);
    let p = dir.path().join(&name);
    let o = bin(&["init", "--out", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    Scenario::load(&p).unwrap();
    // Nothing else is left in the folder (no temporary file).
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, [name]);
}

#[test]
fn grade_presets_fill_left_out_fields_and_given_fields_override() {
    let dir = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(repo("scenarios/demo.toml")).unwrap();
    let map = repo("maps/helsinki.osm.pbf");
    let base = base.replace("../maps/helsinki.osm.pbf", &map);
    let imu_start = base.find("[imu]").unwrap();
    let imu_end = imu_start + base[imu_start..].find("\n\n").unwrap();
    for (grade, extra) in [
        ("navigation", ""),
        ("tactical", ""),
        ("industrial", ""),
        ("mems", "gyro_arw_dprh = 0.9\n"),
    ] {
        let text = format!(
            "{}[imu]\ngrade = \"{grade}\"\n{extra}{}",
            &base[..imu_start],
            &base[imu_end..]
        );
        let path = dir.path().join(format!("{grade}.toml"));
        std::fs::write(&path, &text).unwrap();
        let scn = Scenario::load(&path).unwrap();
        let g: ImuGrade = toml::Value::String(grade.into()).try_into().unwrap();
        let [bias, accel, arw, _] = g.figures();
        assert!((scn.imu.gyro_bias[2] - bias * DPH).abs() < 1e-15, "{grade}");
        assert!(
            (scn.imu.accel_bias[0] - accel * 1e-6 * waymark::units::G0).abs() < 1e-12,
            "{grade}"
        );
        let want_arw = if extra.is_empty() { arw } else { 0.9 };
        // deg/√h → rad/√s.
        let got = scn.imu.gyro_arw / (1f64.to_radians() / 60.0);
        assert!((got - want_arw).abs() < 1e-9, "{grade}: {got}");
    }
    // An unknown grade names the field and the choices.
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        format!(
            "{}[imu]\ngrade = \"consumer\"\n{}",
            &base[..imu_start],
            &base[imu_end..]
        ),
    )
    .unwrap();
    let e = Scenario::load(&path).unwrap_err().to_string();
    assert!(e.contains("grade") && e.contains("mems"), "{e}");
}
