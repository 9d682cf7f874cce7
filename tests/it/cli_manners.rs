//! Command-line manners of every command, on the real binary: `--help` with
//! examples, `--json` (one JSON object on stdout), `--quiet` (nothing on
//! stderr on success), `-v` (log lines on stderr), no progress bars when
//! stderr is not a terminal, one-line errors.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// stdout as exactly one JSON object.
fn json(o: &Output) -> serde_json::Value {
    ok(o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stdout)));
    assert!(v.is_object());
    v
}

fn has_keys(v: &serde_json::Value, keys: &[&str]) {
    for k in keys {
        assert!(v.get(k).is_some(), "missing key '{k}' in {v}");
    }
}

#[test]
fn every_command_help_has_an_example() {
    let dir = tempfile::tempdir().unwrap();
    for cmd in [
        &[][..],
        &["demo"],
        &["network"],
        &["network", "inspect"],
        &["simulate"],
        &["match"],
        &["plan"],
        &["report"],
    ] {
        let mut args = cmd.to_vec();
        args.push("--help");
        let o = run(&args, dir.path());
        ok(&o);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("Example"), "waymark {cmd:?} --help:\n{text}");
        assert!(
            text.contains("waymark "),
            "{cmd:?}: an example command line"
        );
        for flag in ["--quiet", "--verbose"] {
            assert!(text.contains(flag), "{cmd:?} --help lists {flag}");
        }
        if !cmd.is_empty() && cmd != ["network"] {
            assert!(text.contains("--json"), "{cmd:?} --help lists --json");
        }
    }
    let o = run(&["--help"], dir.path());
    assert!(String::from_utf8_lossy(&o.stdout).contains("Exit codes: 0 success, 1"));
}

#[test]
fn bad_command_lines_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &["simulate"][..],
        &["frobnicate"],
        &["simulate", "x.toml", "--runs", "many"],
        &["-q", "-v", "network", "inspect", "x.osm"],
        // Either side of the subcommand: clap alone passed these (exit 1
        // here, for the missing map, or 0 with INFO logs on a real one).
        &["-q", "network", "inspect", "x.osm", "-v"],
        &["-v", "network", "inspect", "x.osm", "-q"],
    ] {
        let o = run(args, dir.path());
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"));
    }
}

#[test]
fn network_inspect_json_keeps_its_keys_and_quiet_is_silent() {
    let dir = tempfile::tempdir().unwrap();
    let map = repo("maps/helsinki.osm.pbf");
    let v = json(&run(&["network", "inspect", &map, "--json"], dir.path()));
    has_keys(
        &v,
        &[
            "roads",
            "sections",
            "segments",
            "nodes",
            "length_km",
            "tunnels",
            "oneway_share",
            "components",
            "grid",
            "defects",
            "skipped",
            "timings_ms",
        ],
    );
    has_keys(&v["tunnels"], &["count", "length_km"]);
    has_keys(&v["components"], &["weak", "strong"]);
    has_keys(&v["grid"], &["n", "occupied_cells"]);
    assert_eq!(v["roads"], 960);

    let o = run(&["network", "inspect", &map, "-q"], dir.path());
    ok(&o);
    assert!(o.stdout.is_empty() && o.stderr.is_empty(), "{}", stderr(&o));

    // Default: no log lines; -v: info lines from the library on stderr.
    let o = run(&["network", "inspect", &map], dir.path());
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    let o = run(&["network", "inspect", &map, "-v"], dir.path());
    ok(&o);
    let log = stderr(&o);
    assert!(
        log.contains("INFO") && log.contains("loaded map") && log.contains("roads=960"),
        "{log}"
    );
    assert!(!log.contains("DEBUG"), "-v is info, not debug: {log}");
}

#[test]
fn simulate_json_quiet_verbose_and_no_progress_bar_off_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    // A scenario with a real IMU: one without error terms gets a note on
    // stderr (simulate_cli::a_perfect_imu_is_noted), which this test would
    // take for a progress bar.
    let scn = repo("scenarios/helsinki-route-dr.toml");
    let o = run(
        &[
            "simulate", &scn, "--runs", "3", "--out", "a", "--json", "-q",
        ],
        dir.path(),
    );
    let v = json(&o);
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    has_keys(
        &v,
        &[
            "runs",
            "duration_s",
            "distance_m",
            "max_horizontal_error_m",
            "rms_horizontal_error_m",
            "p95_horizontal_error_m",
            "requirement_m",
            "fraction_within_requirement",
            "time_to_exceed_requirement_s",
            "odometer_faults",
            "out",
            "files",
        ],
    );
    assert_eq!(v["runs"], 3);
    assert!(
        v.get("profile").is_none(),
        "the long profile stays in summary.json"
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("a/summary.json")).unwrap()).unwrap();
    assert_eq!(
        v["max_horizontal_error_m"],
        summary["max_horizontal_error_m"]
    );

    // --json without -q: the text summary moves to stderr, stdout stays JSON.
    let o = run(&["simulate", &scn, "--out", "b", "--json"], dir.path());
    json(&o);
    assert!(
        stderr(&o).contains("horizontal error max"),
        "{}",
        stderr(&o)
    );

    // Text mode: the summary on stdout; stderr empty, as it is not a terminal
    // (no progress bar for the three runs).
    let o = run(&["simulate", &scn, "--runs", "3", "--out", "c"], dir.path());
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("horizontal error max"));
    assert!(o.stderr.is_empty(), "{}", stderr(&o));

    // -q: nothing at all on success.
    let o = run(&["simulate", &scn, "--out", "d", "-q"], dir.path());
    ok(&o);
    assert!(o.stdout.is_empty() && o.stderr.is_empty());

    // -v and -vv: log lines on stderr.
    let o = run(&["simulate", &scn, "--out", "e", "-v"], dir.path());
    ok(&o);
    let log = stderr(&o);
    assert!(log.contains("INFO") && log.contains("simulating"), "{log}");
    let o = run(&["simulate", &scn, "--out", "f", "-vv"], dir.path());
    ok(&o);
    assert!(stderr(&o).contains("DEBUG"), "{}", stderr(&o));

    // Errors stay one line, with nothing on stdout, whatever the flags.
    for flags in [&["--json"][..], &["-q"], &["-v"]] {
        let mut args = vec!["simulate", "missing.toml"];
        args.extend_from_slice(flags);
        let o = run(&args, dir.path());
        assert_eq!(o.status.code(), Some(1));
        let e = stderr(&o);
        assert_eq!(e.trim_end().lines().count(), 1, "{flags:?}: {e}");
        assert!(e.starts_with("waymark: error: ") && e.contains("missing.toml"));
        assert!(o.stdout.is_empty());
    }
}

#[test]
fn plan_and_report_json() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "plan",
            &repo("scenarios/demo.toml"),
            "--runs",
            "2",
            "--out",
            "p",
            "--json",
            "-q",
        ],
        dir.path(),
    );
    let v = json(&o);
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    has_keys(
        &v,
        &[
            "tag_count",
            "requirement_m",
            "method",
            "lower_bound",
            "validation",
            "tags_by_mounting",
            "max_gap_m",
            "total_cost",
            "out",
            "files",
        ],
    );
    assert_eq!(v["validation"]["runs"], 2);
    let o = run(&["report", "p", "--json", "-q"], dir.path());
    let r = json(&o);
    assert!(o.stderr.is_empty());
    assert_eq!(r["plan"], true);
    assert_eq!(r["simulation"], false);
    assert!(r["report"].as_str().unwrap().ends_with("report.html"));
    assert_eq!(r["plots"].as_array().unwrap().len(), 1);
    // Text mode of report: one line on stdout.
    let o = run(&["report", "p"], dir.path());
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("wrote "));
    assert!(o.stderr.is_empty());
}

#[test]
fn match_json() {
    use waymark::matching::{along_route, TrackModel};
    use waymark::network::{LoadOptions, Network};
    let dir = tempfile::tempdir().unwrap();
    let map = repo("maps/helsinki.osm.pbf");
    let net = Network::load(Path::new(&map), &LoadOptions::default()).unwrap();
    let route =
        waymark::route::plan_route(&net, &[[60.1660, 24.9380], [60.1770, 24.9510]]).unwrap();
    let track = along_route(
        &net,
        &route,
        &TrackModel {
            spacing_m: 10.0,
            speed_mps: 10.0,
            drift_max_m: 5.0,
            noise_sigma_m: 1.0,
            heading_sigma_deg: None,
            seed: 3,
        },
    );
    let mut csv = String::from("t_s,lat,lon\n");
    for f in &track.fixes {
        let g = net.frame.to_geodetic([f.enu[0], f.enu[1], 0.0]);
        let _ = writeln!(csv, "{:.2},{:.8},{:.8}", f.t_s, g.lat_deg(), g.lon_deg());
    }
    let mut truth = String::from("road_id,length_m\n");
    for (r, l) in &track.truth {
        let _ = writeln!(truth, "{r},{l:.2}");
    }
    std::fs::write(dir.path().join("track.csv"), csv).unwrap();
    std::fs::write(dir.path().join("truth.csv"), truth).unwrap();
    let args = [
        "match",
        "--map",
        &map,
        "--track",
        "track.csv",
        "--truth",
        "truth.csv",
    ];
    let mut a = args.to_vec();
    a.extend(["--json", "-q"]);
    let o = run(&a, dir.path());
    let v = json(&o);
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    has_keys(
        &v,
        &[
            "points",
            "tracks",
            "matched",
            "matched_share",
            "breaks",
            "unmatched_spans",
            "score",
            "timings_ms",
            "out",
        ],
    );
    assert_eq!(v["points"].as_u64().unwrap() as usize, track.fixes.len());
    assert!(v["matched_share"].as_f64().unwrap() > 0.95);
    assert!(v["score"]["recall_length"].as_f64().unwrap() > 0.9);
    assert!(dir.path().join("matched.csv").exists());
    // Without -q the summary goes to stderr as before; -q silences it.
    let o = run(&args, dir.path());
    ok(&o);
    assert!(stderr(&o).contains("waymark match:"));
    let mut a = args.to_vec();
    a.push("-q");
    let o = run(&a, dir.path());
    ok(&o);
    assert!(o.stderr.is_empty() && o.stdout.is_empty());
}

#[test]
fn demo_json_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["demo", "--out", "d", "--json", "-q"], dir.path());
    let v = json(&o);
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    has_keys(
        &v,
        &["out", "report", "files", "plan", "simulation", "elapsed_s"],
    );
    assert!(v["plan"]["tag_count"].as_u64().unwrap() >= 1);
    assert_eq!(v["plan"]["requirement_m"], 20.0);
    assert_eq!(v["simulation"]["runs"], 20);
    for f in v["files"].as_array().unwrap() {
        let f = f.as_str().unwrap();
        assert!(dir.path().join("d").join(f).exists(), "missing {f}");
    }
    let _: PathBuf = PathBuf::from(v["report"].as_str().unwrap());
}

/// On a terminal (a pseudo-terminal from util-linux `script`, where
/// installed) the Monte Carlo progress bar is drawn on stderr; `-q` hides it.
#[test]
fn progress_bar_only_on_a_terminal_and_not_with_quiet() {
    let Some(script) = ["/usr/bin/script", "/bin/script"]
        .into_iter()
        .find(|p| Path::new(p).exists())
    else {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scn = repo("scenarios/dr-straight-10km.toml");
    let bin = env!("CARGO_BIN_EXE_waymark");
    let mut logs = Vec::new();
    for quiet in ["", "-q"] {
        let log = dir.path().join(format!("tty{quiet}.log"));
        let cmd = format!("{bin} {quiet} simulate {scn} --runs 100 --out o >/dev/null");
        let o = Command::new(script)
            .args(["-qc", &cmd, log.to_str().unwrap()])
            .current_dir(dir.path())
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap();
        ok(&o);
        logs.push(String::from_utf8_lossy(&std::fs::read(&log).unwrap()).into_owned());
    }
    assert!(logs[0].contains("/100 runs"), "bar drawn: {}", logs[0]);
    assert!(!logs[1].contains("/100 runs"), "-q: no bar: {}", logs[1]);
}

#[test]
fn a_result_that_cannot_be_written_fails_but_a_closed_pipe_does_not() {
    // stdout on a full disk (`--json > out.json`) lost the result with exit
    // 0; stderr that cannot be written made the error path panic (exit 101).
    let full = Path::new("/dev/full");
    if !full.exists() {
        eprintln!("skipped: no /dev/full on this system");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let map = repo("tests/data/small.osm");
    let waymark = || {
        let mut c = Command::new(env!("CARGO_BIN_EXE_waymark"));
        c.current_dir(dir.path());
        c
    };
    let dev_full = || std::fs::OpenOptions::new().write(true).open(full).unwrap();
    for args in [
        vec!["network", "inspect", map.as_str(), "--json"],
        vec!["network", "inspect", map.as_str()],
    ] {
        let out = waymark().args(&args).stdout(dev_full()).output().unwrap();
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(
            err.starts_with("waymark: error: standard output: ") && err.contains("No space"),
            "{args:?}: {err}"
        );
    }
    let out = waymark()
        .args(["network", "inspect", "missing.osm"])
        .stderr(dev_full())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    // A reader that stops early (`| head`) is no error.
    let mut child = waymark()
        .args(["network", "inspect", map.as_str(), "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}
