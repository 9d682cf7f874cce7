//! The report of an area (network coverage) plan: the whole area with
//! every tag, the plan's reach, lower bound and validation, no NaN; and,
//! when the folder holds the area planner's `coverage.geojson` (directed
//! road pieces with `bound_m`, `bound_without_tags_m`, `reason`), the roads
//! coloured by their bound with a colour bar and the reasons summarised.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .output()
        .expect("binary runs")
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn plan(dir: &Path) -> PathBuf {
    let out = dir.join("net");
    let scn = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/helsinki-network-plan.toml");
    ok(&bin(&[
        "plan",
        scn.to_str().unwrap(),
        "--runs",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]));
    out
}

#[test]
fn area_report_draws_every_tag_and_its_figures_and_the_coverage_when_given() {
    let dir = tempfile::tempdir().unwrap();
    let out = plan(dir.path());
    let o = out.to_str().unwrap();
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
    let n = plan["tag_count"].as_u64().unwrap() as usize;
    let kept = plan["existing_kept"].as_u64().unwrap_or(0) as usize;
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(!html.contains("NaN"));
    assert!(html.contains("<h2>Map</h2>"));
    assert_eq!(
        html.matches("class=\"tag\"").count(),
        n + kept,
        "every tag drawn"
    );
    for row in [
        "lower bound on new tags",
        "reach between fixes",
        "roads covered",
        "validation",
        "runs exceeding the requirement",
    ] {
        assert!(html.contains(&format!("<th>{row}</th>")), "{row}");
    }
    // An any_walk plan writes its coverage too (from the walk DP): one
    // piece per directed road, the roads coloured.
    let cov_file: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("coverage.geojson")).unwrap()).unwrap();
    assert_eq!(
        cov_file["features"].as_array().unwrap().len(),
        plan["directed_edges"].as_u64().unwrap() as usize
    );
    assert!(!html.contains("coverage.geojson is absent"));
    assert!(html.contains("class=\"coverage\""));
    // Its worst walks, driven with their tags missed, are in the table.
    assert!(html.contains("<th>worst walks (tags on them missed)</th>"));
    // Without the file the page says the roads are grey.
    std::fs::remove_file(out.join("coverage.geojson")).unwrap();
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("coverage.geojson is absent"));
    assert!(!html.contains("class=\"coverage\""));
    // The verdict under the planner's rule, from the validation's figures
    // (an area plan's runs exceeding are `runs_exceeding`).
    let v = &plan["validation"];
    let (n_thin, within) = (
        v["thinned_samples"].as_u64().unwrap(),
        v["thinned_within"].as_u64().unwrap(),
    );
    assert!(
        html.contains(&format!("{within} of {n_thin} thinned samples within 20 m")),
        "the rule's figures"
    );
    assert!(html.contains(&format!(
        "{} of 2 run(s) exceed it somewhere",
        v["runs_exceeding"].as_u64().unwrap()
    )));
    let level = if v["passed"].as_bool().unwrap() {
        "green"
    } else if within as f64 >= 0.95 * n_thin as f64 {
        "amber"
    } else {
        "red"
    };
    assert!(html.contains(&format!("data-level=\"{level}\">Plan of {n} new tag(s)")));
    assert!(html.contains("<th>walk check</th>") && !html.contains("<th>certification</th>"));
    // Without --baseline nothing compares the plan with its drives
    // without the new tags.
    assert!(!html.contains("What the new tags buy") && !html.contains("Over-budget stretches"));
    // A plan for traffic states its certification instead of a walk check.
    let mut traffic = plan.clone();
    traffic["guarantee"] = serde_json::json!({
        "holds": true, "worst_chain_budget": 1.11,
        "statement": "1007 of 1009 fresh chains hold it"
    });
    std::fs::write(out.join("plan.json"), traffic.to_string()).unwrap();
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains(
        "<th>certification</th><td>holds: 1007 of 1009 fresh chains hold it; the worst certification chain uses 111 % of the error budget"
    ));
    assert!(!html.contains("<th>walk check</th>"));
    baseline_is_shown_beside_the_plan(&out, &plan);
    std::fs::write(out.join("plan.json"), plan.to_string()).unwrap();

    // The area planner's coverage.geojson: three pieces along the first
    // tags, one above the requirement.
    let tags: Vec<[f64; 2]> = plan["tags"]
        .as_array()
        .unwrap()
        .iter()
        .take(6)
        .map(|t| [t["lon"].as_f64().unwrap(), t["lat"].as_f64().unwrap()])
        .collect();
    let features: Vec<serde_json::Value> = tags
        .chunks(2)
        .zip([
            (5.0, "between two tags"),
            (15.0, "dead end"),
            (25.0, "long tunnel"),
        ])
        .map(|(pair, (bound, reason))| {
            serde_json::json!({
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": pair},
                "properties": {"bound_m": bound, "bound_without_tags_m": 10.0 * bound,
                               "reason": reason, "road_id": "way/1"}
            })
        })
        .collect();
    std::fs::write(
        out.join("coverage.geojson"),
        serde_json::json!({"type": "FeatureCollection", "features": features}).to_string(),
    )
    .unwrap();
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(!html.contains("coverage.geojson is absent"));
    let cov = &html[html.find("class=\"coverage\"").unwrap()..];
    let cov = &cov[..cov.find("</g>").unwrap()];
    assert_eq!(cov.matches("<polyline").count(), 3);
    // Coloured by the bound: green-yellow, orange-red, and the colour above
    // the requirement; with the colour bar.
    assert!(cov.contains("stroke=\"hsl(90,85%,42%)\""), "{cov}");
    assert!(cov.contains("stroke=\"hsl(30,85%,42%)\""), "{cov}");
    assert!(cov.contains(waymark::report::OVER_COLOUR));
    assert!(html.contains("class=\"colour-bar\""));
    assert!(html.contains("largest 25.00 m over 3 road piece(s); 1 piece(s) above the requirement"));
    assert!(html.contains("largest 250 m"), "the bound without tags");
    assert!(html.contains("<h3>Why tags are needed</h3>"));
    for reason in ["between two tags", "dead end", "long tunnel"] {
        assert!(html.contains(reason), "{reason}");
    }

    // A damaged coverage.geojson is one clear error.
    std::fs::write(
        out.join("coverage.geojson"),
        r#"{"type":"FeatureCollection","features":[{"type":"Feature","geometry":{"type":"LineString","coordinates":[[24.9,60.1],[24.91,60.1]]},"properties":{"bound_m":"x"}}]}"#,
    )
    .unwrap();
    let r = bin(&["report", o]);
    assert_eq!(r.status.code(), Some(1));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("coverage.geojson") && err.contains("'bound_m' is missing or not a number"),
        "{err}"
    );
}

/// `plan --baseline`: the validation's figures beside those of the same
/// drives without the new tags, and the over-budget stretches both ways.
/// The baseline's objects are made by the library's own types (so their
/// JSON is what `plan` writes), with figures like helsinki-network-plan's
/// without tags and monaco-network-trips' stretches (BENCHMARKS "What the
/// tags buy").
fn baseline_is_shown_beside_the_plan(out: &Path, plan: &serde_json::Value) {
    use waymark::planner::network::{NoTagsValidation, StretchFigures, StretchValidation};
    let (req, conf) = (20.0, 0.95);
    let (lower, passed, rule) = waymark::planner::network::share_rule(218, 303, req, conf);
    let without = NoTagsValidation {
        tags: 0,
        fraction_within_requirement: 0.7166,
        thinned_samples: 303,
        thinned_within: 218,
        share_lower_95: lower,
        passed,
        rule,
        runs_exceeding: 2,
        median_run_max_m: 59.64,
        over_budget_within: Some(1),
        over_budget_max_error_m: Some(24.5),
        max_horizontal_error_m: 138.69,
        worst_path: 1,
        worst_run: 1,
        worst_t_s: 2908.0,
        worst_lat: 60.17,
        worst_lon: 24.94,
        worst_road_id: None,
        map_matching_wrong_road_share: 0.0411,
    };
    let side = |within: usize, max: f64, exceeding: usize| {
        let (share_lower_95, passed, rule) =
            waymark::planner::network::share_rule(within, 320, req, conf);
        StretchFigures {
            thinned_samples: 320,
            thinned_within: within,
            share_lower_95,
            passed,
            rule,
            runs_exceeding: exceeding,
            max_horizontal_error_m: max,
        }
    };
    let stretches = StretchValidation {
        searched_chains: 64,
        stretches: 4,
        runs_per_stretch: 20,
        lead_in_m: 5000.0,
        peak_budget_min: 1.23,
        peak_budget_max: 1.92,
        with_tags: side(320, 1.31, 0),
        without_new_tags: side(305, 25.72, 3),
    };
    let mut p = plan.clone();
    let v = &mut p["validation"];
    v["without_new_tags"] = serde_json::to_value(&without).unwrap();
    v["over_budget_stretches"] = serde_json::to_value(&stretches).unwrap();
    // The stretches the calibrated reach credits (two reach levels).
    let credited = StretchValidation {
        searched_chains: 64,
        stretches: 3,
        runs_per_stretch: 20,
        lead_in_m: 12_400.0,
        peak_budget_min: 1.26,
        peak_budget_max: 1.65,
        with_tags: side(240, 8.73, 0),
        without_new_tags: side(236, 21.59, 2),
    };
    v["credited_stretches"] = serde_json::to_value(&credited).unwrap();
    v["over_budget_samples"] = 3.into();
    v["over_budget_within"] = 3.into();
    v["over_budget_max_error_m"] = 0.23.into();
    v["max_budget_without_tags"] = 1.67.into();
    let v = &p["validation"];
    std::fs::write(out.join("plan.json"), p.to_string()).unwrap();
    ok(&bin(&["report", out.to_str().unwrap()]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(!html.contains("NaN"));
    let section = &html[html
        .find("<h3 id=\"baseline\">What the new tags buy</h3>")
        .expect("the baseline's section")..];
    assert!(section.contains("driven again without any tag"));
    // Each row: the plan's own validation, then the drives without tags.
    let row = |k: &str, a: String, b: &str| {
        let r = format!("<tr><th>{k}</th><td>{a}</td><td>{b}</td></tr>");
        assert!(section.contains(&r), "{r} in {section}");
    };
    row(
        "time within 20 m",
        format!(
            "{:.2} %",
            100.0 * v["fraction_within_requirement"].as_f64().unwrap()
        ),
        "71.66 %",
    );
    row(
        "thinned samples within 20 m",
        format!(
            "{} of {} (lower 95 % bound {:.4})",
            v["thinned_within"],
            v["thinned_samples"],
            v["share_lower_95"].as_f64().unwrap()
        ),
        &format!("218 of 303 (lower 95 % bound {lower:.4})"),
    );
    let (n, within) = (
        v["thinned_samples"].as_u64().unwrap(),
        v["thinned_within"].as_u64().unwrap(),
    );
    let badge = if v["passed"].as_bool().unwrap() {
        "pass\" data-level=\"green\">passed"
    } else if within as f64 >= conf * n as f64 {
        "warn\" data-level=\"amber\">not shown (too few samples)"
    } else {
        "fail\" data-level=\"red\">FAILED"
    };
    row(
        "rule",
        format!("<span class=\"verdict {badge}</span>"),
        "<span class=\"verdict fail\" data-level=\"red\">FAILED</span>",
    );
    row(
        "max horizontal error",
        format!("{:.2} m", v["max_horizontal_error_m"].as_f64().unwrap()),
        "138.69 m",
    );
    row(
        "median of the per-run maxima",
        format!("{:.2} m", v["median_run_max_m"].as_f64().unwrap()),
        "59.64 m",
    );
    row(
        "runs exceeding the requirement",
        format!("{} of 2", v["runs_exceeding"]),
        "2 of 2",
    );
    row(
        "samples where the plan&apos;s budget without tags passes 1",
        "3 of 3 within; max error 0.23 m".into(),
        "1 of 3 within; max error 24.50 m",
    );
    assert!(section.contains("Largest budget without tags on these drives: 1.67"));
    // The stretches, with and without the new tags.
    let section = &section[section
        .find("<h3 id=\"over-budget-stretches\">Over-budget stretches</h3>")
        .expect("the stretches' section")..];
    assert!(section.contains(
        "The 4 stretch(es) where the plan&apos;s budget without tags peaks highest (1.23–1.92) on 64 fresh chain(s), each driven 20 time(s) from 5000 m"
    ));
    let (lower_with, lower_without) = (
        stretches.with_tags.share_lower_95,
        stretches.without_new_tags.share_lower_95,
    );
    row(
        "samples within 20 m",
        format!("320 of 320 (lower 95 % bound {lower_with:.4})"),
        &format!("305 of 320 (lower 95 % bound {lower_without:.4})"),
    );
    // 305 of 320 reaches 0.95 observed, but its lower bound does not.
    assert!(lower_without < conf && !stretches.without_new_tags.passed);
    row(
        "rule",
        "<span class=\"verdict pass\" data-level=\"green\">passed</span>".into(),
        "<span class=\"verdict warn\" data-level=\"amber\">not shown (too few samples)</span>",
    );
    row("max horizontal error", "1.31 m".into(), "25.72 m");
    row(
        "runs exceeding the requirement",
        "0 of 80".into(),
        "3 of 80",
    );
    // The credited stretches, after the over-budget ones: their own
    // heading, figures and run count (3 × 20).
    let section = &section[section
        .find("<h3 id=\"credited-stretches\">Stretches credited by calibration</h3>")
        .expect("the credited stretches' section")..];
    assert!(section.contains(
        "The 3 stretch(es) that the calibrated reach credits: over budget at the single reach (1.26–1.65)"
    ));
    assert!(section.contains("from its chain&apos;s start (up to 12.4 km before it)"));
    row("max horizontal error", "8.73 m".into(), "21.59 m");
    row(
        "runs exceeding the requirement",
        "0 of 60".into(),
        "2 of 60",
    );
}
