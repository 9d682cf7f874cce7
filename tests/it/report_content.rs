//! What the report shows: tag passes marked (read, rejected, missed) and
//! odometer faults shaded on a simulation's plots, from the files `simulate`
//! records; and the report of a `plan` output folder (map with the tags, the
//! predicted bound profile, the plan summary, the verdict, the scenario).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .args(args)
        .output()
        .expect("binary runs")
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A legend entry (or any text) as plotters writes it in SVG.
fn legend(label: &str) -> String {
    format!(">\n{label}\n</text>")
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The RFID paper's odometer-failure case (odometer failed from 3600 s, tags
/// at 5000, 5800, 7900 and 10000 s), cut at 6000 s, with a read probability
/// of 0.5: with seed 2, run 0 reads the first tag and misses the second.
fn short_odfail_scenario(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo("scenarios/rfid-paper-integrated-odfail-tags.toml"))
        .unwrap()
        .replace(
            "requirement_m = 20.0\n",
            "requirement_m = 20.0\nduration_s = 6000\n",
        );
    assert!(text.contains("duration_s = 6000"));
    let path = dir.join("odfail-short.toml");
    std::fs::write(&path, format!("{text}\n[rfid]\nread_probability = 0.5\n")).unwrap();
    path
}

#[test]
fn simulate_records_tag_passes_and_odometer_faults_and_the_report_shows_them() {
    let dir = tempfile::tempdir().unwrap();
    let scn = short_odfail_scenario(dir.path());
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let sim = bin(&["simulate", scn.to_str().unwrap(), "--seed", "2", "--out", o]);
    ok(&sim);
    // The summary names what the filter learnt of the odometer.
    let stdout = String::from_utf8_lossy(&sim.stdout);
    assert!(
        stdout.contains("odometer calibration at the end, RMS error / RMS filter σ over 1 run(s): scale factor "),
        "{stdout}"
    );

    // tag_passes.csv: the two tags passed before 6000 s, one read and
    // accepted, one missed.
    let passes = std::fs::read_to_string(out.join("tag_passes.csv")).unwrap();
    let mut lines = passes.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,distance_m,tag_id,mounting,read,accepted,read_t_s,nis"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2, "{passes}");
    for (row, t, id) in [(&rows[0], 5000.0, "tag-0"), (&rows[1], 5800.0, "tag-1")] {
        let t_s: f64 = row[0].parse().unwrap();
        assert!((t_s - t).abs() < 0.5, "{passes}");
        assert_eq!(row[2], id);
        assert_eq!(row[3], "road_surface");
    }
    // The distance driven at a pass is the truth's: 83.3 km/h cruise.
    let d0: f64 = rows[0][1].parse().unwrap();
    let d1: f64 = rows[1][1].parse().unwrap();
    assert!(((d1 - d0) / 800.0 - 83.3 / 3.6).abs() < 0.5, "{d0} {d1}");
    assert_eq!(&rows[0][4..6], ["1", "1"], "first pass read and accepted");
    let read_t: f64 = rows[0][6].parse().unwrap();
    assert!((read_t - 5000.0).abs() < 0.1);
    assert!(rows[0][7].parse::<f64>().unwrap() >= 0.0, "NIS recorded");
    assert_eq!(&rows[1][4..], ["0", "", "", ""], "second pass missed");

    // summary.json: the odometer failure as an interval of time and distance.
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let faults = summary["odometer_faults"].as_array().unwrap();
    assert_eq!(faults.len(), 1);
    assert_eq!(faults[0]["kind"], "odometer_failure");
    assert_eq!(faults[0]["from_s"], 3600.0);
    assert_eq!(faults[0]["to_s"], 6000.0);
    let from_m = faults[0]["from_m"].as_f64().unwrap();
    assert!(from_m > 80_000.0 && from_m < d0, "{from_m}");

    // calibration.csv: run 0's odometer calibration at every error row,
    // ending on summary.json's state at the end.
    let cal_csv = std::fs::read_to_string(out.join("calibration.csv")).unwrap();
    let errors = std::fs::read_to_string(out.join("errors.csv")).unwrap();
    assert_eq!(cal_csv.lines().count(), errors.lines().count());
    let cal_rows: Vec<Vec<f64>> = cal_csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let (first, last) = (&cal_rows[0], cal_rows.last().unwrap());
    let end = &summary["odometer_calibration"]["scale_factor"];
    // Columns: truth, estimate, σ of the scale factor; written to 1e-8.
    for (k, key) in [(2, "truth_run0"), (3, "estimate_run0"), (4, "sigma_run0")] {
        assert!((last[k] - end[key].as_f64().unwrap()).abs() < 1e-8, "{key}");
    }
    // The filter starts knowing nothing (estimate 0) and learns: its σ
    // shrinks from the prior.
    assert_eq!(first[3], 0.0);
    assert!(last[4] < 0.5 * first[4], "{first:?} {last:?}");
    // The misalignments: none simulated; the filter's σ in degrees.
    assert!(last[5] == 0.0 && last[8] == 0.0 && last[7] > 0.0 && last[10] > 0.0);

    // The report: the time and distance plots and the three calibration
    // plots shade the fault and mark the passes.
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for label in ["odometer fault", "tag read", "tag missed"] {
        assert_eq!(
            html.matches(&legend(label)).count(),
            5,
            "legend '{label}' in the time, distance and calibration plots"
        );
    }
    for title in ["scale factor", "pitch misalignment", "yaw misalignment"] {
        assert!(
            html.contains(&format!(
                "<h2>Odometer {title}: estimation error (run 0)</h2>"
            )),
            "{title}"
        );
    }
    assert!(!html.contains(&legend("tag read, rejected by the filter")));
    // Each plot: one tick per pass plus the legend's swatch, in its own colour.
    assert_eq!(
        html.matches("stroke=\"#B400A0\"").count(),
        5 * 2,
        "read ticks"
    );
    assert_eq!(
        html.matches("stroke=\"#969696\"").count(),
        5 * 2,
        "missed ticks"
    );
    // The shaded fault: a translucent orange rectangle from 3600 s (time plot).
    assert!(
        html.matches("fill=\"#FFA500\"").count() >= 2,
        "shaded faults"
    );
    assert!(
        html.contains("failed from 3600 s"),
        "fault in the summary table"
    );
    assert!(html.contains("2: 1 read and accepted, 0 rejected by the filter, 1 missed"));
    // What the filter learnt of the odometer: the scenario's scale factor
    // (0.131 %) beside the estimate, no misalignment simulated.
    let cal = &summary["odometer_calibration"];
    assert_eq!(cal["scale_factor"]["truth_run0"], 0.00131);
    assert_eq!(cal["yaw_misalignment_deg"]["truth_run0"], 0.0);
    assert!(cal["scale_factor"]["sigma_run0"].as_f64().unwrap() > 0.0);
    assert!(
        html.contains("Odometer calibration at the end")
            && html.contains("scale factor ")
            && html.contains("(simulated 1.31e-3)"),
        "calibration paragraph"
    );
    for png in [
        "error_time.png",
        "error_distance.png",
        "calibration_scale_factor.png",
        "calibration_pitch.png",
        "calibration_yaw.png",
    ] {
        assert!(out.join("plots").join(png).exists(), "{png}");
    }
    // Every plot is one the report knows by name (to clear it when stale).
    for f in std::fs::read_dir(out.join("plots")).unwrap() {
        let name = f.unwrap().file_name().to_string_lossy().into_owned();
        let stem = name.strip_suffix(".png").unwrap();
        assert!(waymark::report::PLOT_NAMES.contains(&stem), "{name}");
    }

    // A folder written before calibration.csv existed: a note, no plots.
    std::fs::remove_file(out.join("calibration.csv")).unwrap();
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("calibration.csv is missing"));
    assert!(!html.contains("estimation error (run 0)"));
    assert!(!out.join("plots/calibration_yaw.png").exists());
    // A damaged calibration.csv or tag_passes.csv is one clear line naming
    // it and the problem, exit 1, not a panic.
    let damaged = |file: &str, text: &str, problem: &str| {
        std::fs::write(out.join(file), text).unwrap();
        let r = bin(&["report", o]);
        assert_eq!(r.status.code(), Some(1));
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(file) && err.contains(problem), "{err}");
    };
    damaged(
        "calibration.csv",
        "t_s,distance_m,scale_factor_truth\n0,0,0.001\n",
        "missing column 'scale_factor_estimate'",
    );
    std::fs::remove_file(out.join("calibration.csv")).unwrap();
    damaged(
        "tag_passes.csv",
        "t_s,distance_m,tag_id,mounting,read\n5000,x,tag-0,road_surface,1\n",
        "line 2: 'distance_m' is not a number",
    );
}

#[test]
fn a_scenario_without_faults_or_tags_records_none() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("dr");
    ok(&bin(&[
        "simulate",
        repo("scenarios/dr-straight-10km.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["odometer_faults"], serde_json::json!([]));
    assert!(
        summary["odometer_calibration"].is_null(),
        "no filter, no calibration"
    );
    assert!(
        !out.join("tag_passes.csv").exists(),
        "no filter, no tag passes"
    );
    ok(&bin(&["report", out.to_str().unwrap()]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(!html.contains(&legend("odometer fault")));
    assert!(!html.contains(&legend("tag read")));
    assert!(!html.contains("Odometer calibration"));
}

#[test]
fn report_of_a_plan_folder_shows_the_map_profile_summary_and_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let o = out.to_str().unwrap();
    ok(&bin(&[
        "plan",
        repo("scenarios/demo.toml").to_str().unwrap(),
        "--runs",
        "4",
        "--out",
        o,
    ]));
    for f in ["profile.csv", "scenario.toml", "inputs.json", "plan.json"] {
        assert!(out.join(f).exists(), "plan wrote {f}");
    }
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
    let n = plan["tag_count"].as_u64().unwrap();
    assert!(n >= 1);
    // profile.csv: the bound with tags never above the bound without.
    let profile = std::fs::read_to_string(out.join("profile.csv")).unwrap();
    let mut lines = profile.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,distance_m,bound95_with_tags_m,bound95_without_tags_m"
    );
    let rows: Vec<[f64; 4]> = lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect();
    assert!(rows.len() > 50);
    assert!(rows.iter().all(|r| r[2] <= r[3] + 1e-6));
    let max_with = rows.iter().map(|r| r[2]).fold(0.0, f64::max);
    let predicted = plan["predicted_max_bound95_m"].as_f64().unwrap();
    assert!(
        (max_with - predicted).abs() < 0.01,
        "{max_with} {predicted}"
    );
    assert!(rows.iter().map(|r| r[3]).fold(0.0, f64::max) > 20.0);
    // The bound with any one tag missed: no lower than all read, and within
    // the requirement, which the plan was checked to hold with one missed
    // (the check samples the profile at the candidate spacing, this every
    // 50 m: 5 cm of slack for the sampling).
    let missed = plan["predicted_max_bound95_missed_m"].as_f64().unwrap();
    assert!(missed >= predicted - 1e-9 && missed <= 20.05, "{missed}");

    let r = bin(&["report", o]);
    ok(&r);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2>Verdict</h2>"));
    assert!(
        html.contains(&format!("\">Plan of {n} new tag(s) ")),
        "plan verdict"
    );
    assert!(html.contains("4 Monte Carlo run(s)"));
    assert!(html.contains("<h2>Plan</h2>"));
    assert!(
        html.contains(&format!("<th>new tags</th><td>{n} (")),
        "tags by mounting"
    );
    for row in [
        "total cost",
        "largest gap between tags",
        "predicted max 95 % bound, all tags read",
        "predicted max 95 % bound, tags missed",
        "missed reads tolerated",
    ] {
        assert!(html.contains(&format!("<th>{row}</th>")), "{row}");
    }
    // The map: the roads, the route coloured by the predicted bound, and one
    // circle per tag in the road-surface or roadside colour.
    assert!(html.contains("<h2>Map</h2>"));
    assert!(html.matches("<polyline").count() > 500, "Helsinki roads");
    assert!(html.contains("route: predicted 95 % bound with the tags, all read (m)"));
    let circles = html.matches("<circle").count();
    assert_eq!(circles as u64, n, "one circle per planned tag");
    assert!(html.contains("fill=\"#f39c12\"") || html.contains("fill=\"#27ae60\""));
    // The predicted profile with and without tags, the tags marked.
    assert!(html.contains("<h2>Predicted 95 % horizontal bound along the route</h2>"));
    for label in [
        "with the planned tags (all read)",
        "without tags",
        "planned tag",
        "requirement 20 m",
    ] {
        assert!(html.contains(&legend(label)), "{label}");
    }
    assert!(html.contains("<h2>Scenario</h2>") && html.contains("name = &quot;demo&quot;"));
    // The tag table: one row per tag, and where the heights come from (no
    // elevation model on a map).
    let table = &html[html.find("id=\"tag-table\"").unwrap()..];
    let body = &table[table.find("<tbody>").unwrap()..table.find("</tbody>").unwrap()];
    assert_eq!(body.matches("<tr").count() as u64, n);
    // Each tag's reason (plan.json, tags.csv), in its own column.
    assert!(table[..table.find("</thead>").unwrap()].contains("<th>reason</th>"));
    assert_eq!(
        body.matches("m bound to ").count() as u64,
        n,
        "one reason per row"
    );
    for t in plan["tags"].as_array().unwrap() {
        let reason = t["reason"].as_str().unwrap();
        let figure = &reason[..reason.find(" (reach").unwrap()];
        assert!(body.contains(figure), "{figure}");
    }
    assert!(html.contains("Heights: none (no [map] elevation)"));
    assert!(!html.contains("<h2>Summary</h2>"), "no simulation here");
    assert!(out.join("plots/plan_profile.png").exists());

    // The verdict follows the planner's rule on the validation's thinned
    // samples (plan.json), not a share of the distance: the same runs shown
    // green, amber or red as their samples change.
    let v = &plan["validation"];
    assert_eq!(v["requirement_confidence"].as_f64(), Some(0.95));
    let verdict_with = |samples: u64, within: u64| -> String {
        let mut p = plan.clone();
        p["validation"]["thinned_samples"] = samples.into();
        p["validation"]["thinned_within"] = within.into();
        std::fs::write(out.join("plan.json"), p.to_string()).unwrap();
        ok(&bin(&["report", o]));
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        let i = html.find("class=\"verdict ").expect("a verdict badge");
        let level = &html[html[i..].find("data-level=\"").unwrap() + i + 12..];
        level[..level.find('"').unwrap()].to_string()
    };
    // 59 of 59: lower bound 0.05^(1/59) = 0.9505 ≥ 0.95; 58 of 58: 0.9497.
    assert_eq!(verdict_with(59, 59), "green");
    assert_eq!(verdict_with(58, 58), "amber");
    // 96 % observed but a lower bound below 0.95 (1000 samples: 0.9482,
    // the beta quantile Beta(960, 41) at 0.05).
    assert_eq!(verdict_with(1000, 960), "amber");
    assert_eq!(verdict_with(1000, 940), "red");
    // Without the rule's figures (an older plan.json): never green.
    let mut p = plan.clone();
    p["validation"]
        .as_object_mut()
        .unwrap()
        .retain(|k, _| !k.starts_with("thinned"));
    std::fs::write(out.join("plan.json"), p.to_string()).unwrap();
    ok(&bin(&["report", o]));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("data-level=\"amber\""));
    assert!(html.contains("the rule cannot be applied"));
}
