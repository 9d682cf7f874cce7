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
    for needle in [
        "the map is not drawn: the scenario recorded in inputs.json, /nowhere/at/all/scenario.toml, is no longer there",
        "/nowhere/tags.csv",
    ] {
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

/// A plan folder (`plan scenarios/demo.toml --runs 0`: two tags, no
/// validation runs, so it is quick).
fn planned(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    let s = bin(&[
        "plan",
        repo("scenarios/demo.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--runs",
        "0",
    ]);
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    out
}

#[test]
fn a_damaged_optional_file_is_named_as_damaged_not_missing() {
    // A garbage inputs.json or scenario.toml (not UTF-8, a folder) was
    // reported as "missing", sending the user to look for a file that is there.
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "sim");
    std::fs::write(sim.join("inputs.json"), b"\xff\xfe garbage").unwrap();
    std::fs::write(sim.join("scenario.toml"), b"\xff\xfe garbage").unwrap();
    let (code, err, html) = report(&sim);
    assert_eq!(code, Some(0), "{err}");
    assert!(html.is_some());
    for needle in [
        "inputs.json cannot be read (the inputs file is not UTF-8 text",
        "scenario.toml cannot be read (the scenario is not UTF-8 text",
    ] {
        assert!(err.contains(needle), "'{needle}' not in: {err}");
    }
    assert!(!err.contains("missing"), "{err}");
    std::fs::remove_file(sim.join("inputs.json")).unwrap();
    std::fs::create_dir(sim.join("inputs.json")).unwrap();
    let (code, err, _) = report(&sim);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("inputs.json cannot be read ("), "{err}");
    // Absent is still "missing".
    std::fs::remove_dir(sim.join("inputs.json")).unwrap();
    std::fs::remove_file(sim.join("scenario.toml")).unwrap();
    let (_, err, _) = report(&sim);
    assert!(err.contains("inputs.json is missing"), "{err}");
    assert!(err.contains("scenario.toml is missing"), "{err}");
}

#[test]
fn a_tags_csv_cut_short_is_noted_against_the_plan() {
    // tags.csv cut short gave a report of fewer tags, or the plan's list
    // under "the rows are the lines of tags.csv", without a word.
    let dir = tempfile::tempdir().unwrap();
    let plan = planned(dir.path(), "plan");
    let whole = std::fs::read_to_string(plan.join("tags.csv")).unwrap();
    let lines: Vec<&str> = whole.lines().collect();
    assert_eq!(lines.len(), 3, "the demo plans two tags: {whole}");
    let table = |html: &str| {
        let at = html.find(" tag(s); the rows are ").expect("a tag table");
        html[at.saturating_sub(3)..at + 80].to_string()
    };

    // Whole: no note, the file's rows.
    let (code, err, html) = report(&plan);
    assert_eq!(code, Some(0), "{err}");
    assert!(!err.contains("tags.csv"), "{err}");
    assert!(table(&html.unwrap()).contains("2 tag(s); the rows are the lines of <code>tags.csv"));

    // Cut at a line end: one row; the plan's second tag is named.
    std::fs::write(
        plan.join("tags.csv"),
        format!("{}\n{}\n", lines[0], lines[1]),
    )
    .unwrap();
    let (code, err, html) = report(&plan);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("tags.csv lacks 1 of plan.json's 2 new tag(s) (first T0002)"),
        "{err}"
    );
    assert!(table(html.as_ref().unwrap()).contains("1 tag(s)"));
    assert!(html.unwrap().contains("lacks 1 of plan.json"));

    // Cut inside the last row's quoted reason: the same, and the cut is named.
    let cut = whole.len() - lines[2].len() / 2;
    std::fs::write(plan.join("tags.csv"), &whole[..cut]).unwrap();
    let (_, err, _) = report(&plan);
    assert!(
        err.contains("tags.csv ends in the middle of a line"),
        "{err}"
    );

    // Cut inside the header: no rows; the table is the plan's, and says so.
    std::fs::write(plan.join("tags.csv"), &whole[..lines[0].len() / 2 + 40]).unwrap();
    let (code, err, html) = report(&plan);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("tags.csv holds no tags while plan.json plans 2"),
        "{err}"
    );
    assert!(table(&html.unwrap()).contains("2 tag(s); the rows are the tags of <code>plan.json"));
}

#[test]
fn a_bad_row_is_named_by_its_own_line() {
    // The report's CSV errors read "line 3: CSV error: record 2 (line: 4,
    // byte: ...): found record with 2 fields, but the previous record has 9
    // fields": two line numbers, the first wrong when a comment line comes
    // before (it counted records, not lines).
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "sim");
    let whole = std::fs::read_to_string(sim.join("errors.csv")).unwrap();
    let mut lines: Vec<String> = whole.lines().map(String::from).collect();
    let fields = lines[0].split(',').count();
    lines.insert(1, "# a comment line".into());
    lines[3] = "1.0,2.0".into(); // line 4 of the file
    std::fs::write(sim.join("errors.csv"), lines.join("\n") + "\n").unwrap();
    let (code, err, page) = report(&sim);
    one_error_line(
        code,
        &err,
        &[
            "errors.csv",
            &format!("line 4: 2 fields, the header has {fields}"),
        ],
    );
    assert!(!err.contains("CSV error"), "{err}");
    assert!(page.is_none());
    // A number that is not one: also by its own line.
    lines[3] = lines[2].replacen(',', ",x", 1);
    std::fs::write(sim.join("errors.csv"), lines.join("\n") + "\n").unwrap();
    let (code, err, _) = report(&sim);
    one_error_line(
        code,
        &err,
        &["errors.csv", "line 4: 'distance_m' is not a number"],
    );
}
