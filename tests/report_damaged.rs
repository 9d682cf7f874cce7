//! `waymark report` on damaged folders (issue 17 point 3), as hit from the
//! command line: what the page is made from (`summary.json`, `plan.json`,
//! the CSVs it plots) is checked and a problem there is one error line
//! naming the file and the field (exit 1); anything else missing or
//! unusable (`inputs.json` pointing nowhere or of the wrong types, the
//! scenario's map gone, a recorded tag file gone, `errors.csv` gone) still
//! gives a report, which says exactly what is missing, as `waymark report`
//! does on stderr.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .output()
        .expect("binary runs")
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A fresh simulate folder (dead reckoning on the Helsinki map, one run).
fn simulated(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    let s = bin(&[
        "simulate",
        repo("scenarios/helsinki-route-dr.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    out
}

/// `report DIR`: exit code, stderr, the page when written.
fn report(dir: &Path) -> (Option<i32>, String, Option<String>) {
    let _ = std::fs::remove_file(dir.join("report.html"));
    let r = bin(&["report", dir.to_str().unwrap()]);
    (
        r.status.code(),
        String::from_utf8_lossy(&r.stderr).into_owned(),
        std::fs::read_to_string(dir.join("report.html")).ok(),
    )
}

fn one_error_line(code: Option<i32>, err: &str, needles: &[&str]) {
    assert_eq!(code, Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
}

#[test]
fn what_the_page_is_made_from_is_checked_with_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    // No results at all.
    let (code, err, _) = report(dir.path());
    one_error_line(code, &err, &["summary.json", "plan.json"]);
    // Not a folder.
    let file = dir.path().join("file.txt");
    std::fs::write(&file, "x").unwrap();
    let (code, err, _) = report(&file);
    one_error_line(code, &err, &["file.txt", "not a folder"]);
    // summary.json lacking what the page shows, or of the wrong types.
    let d = dir.path().join("s");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(d.join("summary.json"), "{\"name\": \"x\"}").unwrap();
    let (code, err, _) = report(&d);
    one_error_line(code, &err, &["summary.json", "'duration_s' is missing"]);
    let sim = simulated(dir.path(), "sim");
    let text = std::fs::read_to_string(sim.join("summary.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["runs"] = "many".into();
    std::fs::write(sim.join("summary.json"), v.to_string()).unwrap();
    let (code, err, _) = report(&sim);
    one_error_line(
        code,
        &err,
        &[
            "summary.json",
            "'runs' is the text \"many\", not a whole number",
        ],
    );
    std::fs::write(sim.join("summary.json"), "[1, 2]").unwrap();
    let (code, err, _) = report(&sim);
    one_error_line(code, &err, &["summary.json", "not a JSON object"]);
    std::fs::write(sim.join("summary.json"), &text).unwrap();
    // A plotted CSV without its column.
    std::fs::write(sim.join("errors.csv"), "t_s,distance_m\n0,0\n").unwrap();
    let (code, err, _) = report(&sim);
    one_error_line(code, &err, &["errors.csv", "missing column 'horizontal_m'"]);
}

#[test]
fn a_folder_missing_its_inputs_gives_a_report_saying_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "sim");
    let (code, err, html) = report(&sim);
    assert_eq!(code, Some(0), "{err}");
    let html = html.unwrap();
    assert!(
        !html.contains("What this folder lacks"),
        "a whole folder lacks nothing"
    );
    assert!(html.contains("<h2>Map</h2>"));

    // inputs.json pointing nowhere: the scenario's map cannot be found.
    std::fs::write(
        sim.join("inputs.json"),
        r#"{"scenario_path": "/nowhere/at/all/scenario.toml", "tags_path": "/nowhere/tags.csv"}"#,
    )
    .unwrap();
    let (code, err, html) = report(&sim);
    assert_eq!(code, Some(0), "{err}");
    let html = html.unwrap();
    assert!(html.contains("What this folder lacks"));
    assert!(!html.contains("<h2>Map</h2>"));
    for needle in ["the map is not drawn", "/nowhere/tags.csv"] {
        assert!(html.contains(needle), "{needle}");
        assert!(err.contains(needle), "stderr lacks {needle}: {err}");
    }
    assert!(err.contains("warning"), "{err}");

    // inputs.json of the wrong types, or not JSON.
    std::fs::write(sim.join("inputs.json"), r#"{"scenario_path": 5}"#).unwrap();
    let (code, err, html) = report(&sim);
    assert_eq!(code, Some(0), "{err}");
    assert!(html
        .unwrap()
        .contains("inputs.json: &apos;scenario_path&apos; is missing or not a string"));
    std::fs::write(sim.join("inputs.json"), "{not json").unwrap();
    let (_, err, _) = report(&sim);
    assert!(err.contains("inputs.json is not valid JSON"), "{err}");
    std::fs::remove_file(sim.join("inputs.json")).unwrap();
    let (_, err, _) = report(&sim);
    assert!(err.contains("inputs.json is missing"), "{err}");

    // errors.csv gone: the verdict and summary still shown, the plot not.
    std::fs::remove_file(sim.join("errors.csv")).unwrap();
    let (code, err, html) = report(&sim);
    assert_eq!(code, Some(0), "{err}");
    let html = html.unwrap();
    assert!(html.contains("errors.csv is missing"));
    assert!(html.contains("<h2>Verdict</h2>") && html.contains("<h2>Summary</h2>"));
    assert!(!html.contains("Horizontal error against time"));
    assert!(!html.contains("NaN"));
}

#[test]
fn a_report_that_cannot_be_completed_leaves_no_page() {
    // `plots` a file, not a folder: the page was written first and stayed
    // behind, without its plots, after the error.
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "sim");
    std::fs::write(sim.join("plots"), "a file of the user's").unwrap();
    let (code, err, page) = report(&sim);
    one_error_line(code, &err, &["plots"]);
    assert!(page.is_none(), "report.html written beside the error");
    assert_eq!(
        std::fs::read_to_string(sim.join("plots")).unwrap(),
        "a file of the user's"
    );
    // `report.html` a folder: refused before any plot is written.
    std::fs::remove_file(sim.join("plots")).unwrap();
    std::fs::create_dir(sim.join("report.html")).unwrap();
    let r = bin(&["report", sim.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&r.stderr);
    one_error_line(r.status.code(), &err, &["report.html", "folder"]);
    assert!(
        !sim.join("plots").exists(),
        "plots written beside the error"
    );
}

#[test]
fn a_huge_file_in_the_folder_is_refused_unread() {
    // The report read the folder's files whole without a limit: an errors.csv
    // of NUL bytes (or a link to /dev/zero) aborted on a failed allocation
    // of 4 GiB (exit 134), a summary.json ran out of memory.
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "sim");
    // Sparse files: their size costs no disk space.
    let sparse = |name: &str, len: u64| {
        let f = std::fs::OpenOptions::new()
            .write(true)
            .truncate(true)
            .open(sim.join(name))
            .unwrap();
        f.set_len(len).unwrap();
    };
    let kept = std::fs::read(sim.join("errors.csv")).unwrap();
    sparse("errors.csv", (1 << 30) + 1);
    let (code, err, page) = report(&sim);
    one_error_line(
        code,
        &err,
        &["errors.csv", "larger than the limit of 1 GiB"],
    );
    assert!(page.is_none());
    std::fs::write(sim.join("errors.csv"), kept).unwrap();
    sparse("summary.json", (1 << 30) + 1);
    let (code, err, _) = report(&sim);
    one_error_line(
        code,
        &err,
        &["summary.json", "larger than the limit of 1 GiB"],
    );
}
