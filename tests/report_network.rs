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
