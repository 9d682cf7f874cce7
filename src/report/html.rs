//! The HTML report: one self-contained file.

use super::plot::{error_plot_svg, ErrorSeries, PassKind, PlotDecor, TagMark};
use super::{bound95, ErrorRow, PassRow, PlanProfileRow};
use crate::error::Result;
use quick_xml::escape::escape;
use std::fmt::Write;

/// What a report is made from.
#[derive(Debug, Clone, Default)]
pub struct ReportInput {
    /// `summary.json` as read (a simulation's results).
    pub summary: Option<serde_json::Value>,
    /// `errors.csv` rows (run 0).
    pub rows: Vec<ErrorRow>,
    /// `tag_passes.csv` rows (run 0).
    pub tag_passes: Vec<PassRow>,
    /// Odometer faults: (from, to) in time (s) and in distance (m).
    pub odometer_faults: Vec<([f64; 2], [f64; 2])>,
    /// `plan.json` as read (a plan).
    pub plan: Option<serde_json::Value>,
    /// A plan's `profile.csv` rows.
    pub plan_profile: Vec<PlanProfileRow>,
    /// The scenario file's text, when the folder has it.
    pub scenario: Option<String>,
    /// The map of the area as SVG, when the scenario drives on a map.
    pub map_svg: Option<String>,
}

const CSS: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;color:#1d2330;background:#f6f7f9}\
header{background:#1d3557;color:#fff;padding:18px 32px}header h1{margin:0;font-size:24px}\
header p{margin:6px 0 0;opacity:.85}main{padding:16px 32px;max-width:1100px}\
section{background:#fff;border:1px solid #dde1e7;border-radius:6px;padding:14px 20px;margin:14px 0}\
h2{font-size:18px;margin:4px 0 10px}table{border-collapse:collapse}td,th{padding:4px 14px 4px 0;text-align:left}\
th{color:#555;font-weight:600}.verdict{display:inline-block;padding:6px 12px;border-radius:4px;font-weight:600}\
.pass{background:#d8f3dc;color:#1b4332}.fail{background:#ffd6d6;color:#7a0b0b}.info{background:#e7ecf5;color:#1d3557}\
pre{background:#f3f4f6;padding:10px;overflow:auto;font-size:13px}svg{max-width:100%;height:auto}footer{padding:12px 32px;color:#666;font-size:13px}";

fn num(v: &serde_json::Value) -> Option<f64> {
    v.as_f64()
}

impl ReportInput {
    /// Fills `odometer_faults` from `summary.json`'s `odometer_faults`.
    pub fn with_faults_from_summary(mut self) -> Self {
        if let Some(list) = self
            .summary
            .as_ref()
            .and_then(|s| s["odometer_faults"].as_array())
        {
            self.odometer_faults = list
                .iter()
                .filter_map(|f| {
                    Some((
                        [f["from_s"].as_f64()?, f["to_s"].as_f64()?],
                        [f["from_m"].as_f64()?, f["to_m"].as_f64()?],
                    ))
                })
                .collect();
        }
        self
    }
}

/// The report's plots: a file stem, the series and the decoration. Error
/// against time and distance for a simulation (tag passes marked, odometer
/// faults shaded); the predicted bound along the route for a plan.
pub fn plots(input: &ReportInput) -> Vec<(&'static str, ErrorSeries, PlotDecor)> {
    let mut out = Vec::new();
    if let Some(s) = &input.summary {
        let requirement = num(&s["requirement_m"]);
        let bound: Vec<Option<f64>> = input
            .rows
            .iter()
            .map(|r| r.sigma_en_m.map(bound95))
            .collect();
        let error: Vec<f64> = input.rows.iter().map(|r| r.horizontal_m).collect();
        for (name, title, x_label, by_time) in [
            (
                "error_time",
                "Horizontal error against time",
                "time (s)",
                true,
            ),
            (
                "error_distance",
                "Horizontal error against distance",
                "distance driven (m)",
                false,
            ),
        ] {
            let x: Vec<f64> = input
                .rows
                .iter()
                .map(|r| if by_time { r.t_s } else { r.distance_m })
                .collect();
            if x.iter().all(|v| *v == 0.0) {
                continue; // a static run has no distance axis
            }
            let series = ErrorSeries {
                envelope: envelope(s, by_time),
                x,
                error: error.clone(),
                bound95: bound.clone(),
            };
            let decor = PlotDecor {
                title: title.into(),
                x_label: x_label.into(),
                requirement_m: requirement,
                tag_passes: input
                    .tag_passes
                    .iter()
                    .map(|p| TagMark {
                        x: if by_time { p.t_s } else { p.distance_m },
                        kind: p.kind,
                    })
                    .collect(),
                shaded: input
                    .odometer_faults
                    .iter()
                    .map(|(t, d)| if by_time { (t[0], t[1]) } else { (d[0], d[1]) })
                    .collect(),
                ..Default::default()
            };
            out.push((name, series, decor));
        }
    }
    if let (Some(p), false) = (&input.plan, input.plan_profile.is_empty()) {
        let requirement = num(&p["requirement_m"]);
        let tags = p["tags"].as_array().map(Vec::as_slice).unwrap_or_default();
        let series = ErrorSeries {
            x: input.plan_profile.iter().map(|r| r.distance_m).collect(),
            error: input.plan_profile.iter().map(|r| r.with_tags_m).collect(),
            bound95: input
                .plan_profile
                .iter()
                .map(|r| Some(r.without_tags_m))
                .collect(),
            envelope: None,
        };
        let decor = PlotDecor {
            title: "Predicted 95 % horizontal bound along the route".into(),
            x_label: "distance along the route (m)".into(),
            y_label: Some("predicted 95 % bound (m)".into()),
            requirement_m: requirement,
            error_label: Some("with the planned tags (all read)".into()),
            bound_label: Some("without tags".into()),
            // The bound without tags can grow to kilometres: keep the
            // requirement readable.
            y_max: requirement.map(|r| 2.5 * r),
            tag_label: Some("planned tag".into()),
            tag_passes: tags
                .iter()
                .filter_map(|t| t["route_distance_m"].as_f64())
                .map(|x| TagMark {
                    x,
                    kind: PassKind::Accepted,
                })
                .collect(),
            ..Default::default()
        };
        out.push(("plan_profile", series, decor));
    }
    out
}

/// The verdict of a simulation: within the requirement 99 % of the time.
fn sim_verdict(s: &serde_json::Value) -> String {
    let requirement = num(&s["requirement_m"]);
    match (requirement, num(&s["fraction_within_requirement"])) {
        (Some(r), Some(f)) if f >= 0.99 => format!(
            "<span class=\"verdict pass\">Meets the {r} m requirement: {:.2} % of the time within it</span>",
            100.0 * f
        ),
        (Some(r), Some(f)) => format!(
            "<span class=\"verdict fail\">Does not meet the {r} m requirement: {:.2} % of the time within it{}</span>",
            100.0 * f,
            num(&s["time_to_exceed_requirement_s"])
                .map(|t| format!(", first exceeded at {t:.0} s"))
                .unwrap_or_default()
        ),
        _ => "<span class=\"verdict info\">No requirement set in the scenario</span>".into(),
    }
}

/// The verdict of a plan: its Monte Carlo validation keeps 99 % of the
/// distance within the requirement.
fn plan_verdict(p: &serde_json::Value) -> String {
    let r = num(&p["requirement_m"]).unwrap_or(f64::NAN);
    let predicted = num(&p["predicted_max_bound95_m"]).unwrap_or(f64::NAN);
    let n = p["tag_count"].as_u64().unwrap_or(0);
    let v = &p["validation"];
    match (num(&v["fraction_within_requirement"]), v["runs"].as_u64()) {
        (Some(f), Some(runs)) if f >= 0.99 => format!(
            "<span class=\"verdict pass\">Plan validated: with {n} new tag(s), {:.2} % of the distance within {r} m over {runs} Monte Carlo run(s); predicted max 95 % bound {predicted:.2} m</span>",
            100.0 * f
        ),
        (Some(f), Some(runs)) => format!(
            "<span class=\"verdict fail\">Plan not validated: with {n} new tag(s), {:.2} % of the distance within {r} m over {runs} Monte Carlo run(s) (99 % asked); predicted max 95 % bound {predicted:.2} m</span>",
            100.0 * f
        ),
        _ if predicted <= r => format!(
            "<span class=\"verdict info\">Predicted max 95 % bound {predicted:.2} m with {n} new tag(s), within {r} m; not validated by simulation</span>"
        ),
        _ => format!(
            "<span class=\"verdict fail\">Predicted max 95 % bound {predicted:.2} m exceeds {r} m; not validated by simulation</span>"
        ),
    }
}

/// The plan's summary table.
fn plan_table(p: &serde_json::Value) -> String {
    let mut rows: Vec<(&str, String)> = Vec::new();
    let by = p["tags_by_mounting"]
        .as_object()
        .map(|m| {
            m.iter()
                .map(|(k, v)| format!("{} {}", v.as_u64().unwrap_or(0), k.replace('_', " ")))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "none".into());
    rows.push((
        "new tags",
        format!("{} ({by})", p["tag_count"].as_u64().unwrap_or(0)),
    ));
    if let Some(k) = p["existing_tags_kept"].as_u64().filter(|k| *k > 0) {
        rows.push(("installed tags kept", k.to_string()));
    }
    rows.push(("total cost", fmt_opt(num(&p["total_cost"]), "", 1)));
    rows.push((
        "route length",
        fmt_opt(num(&p["route_length_m"]).map(|d| d / 1e3), "km", 2),
    ));
    rows.push((
        "largest gap between tags",
        fmt_opt(num(&p["max_gap_m"]), "m", 0),
    ));
    rows.push(("requirement", fmt_opt(num(&p["requirement_m"]), "m", 1)));
    rows.push((
        "missed reads tolerated",
        p["tolerate_missed_reads"]
            .as_u64()
            .map(|k| k.to_string())
            .unwrap_or_default(),
    ));
    rows.push((
        "predicted max 95 % bound (all read)",
        fmt_opt(num(&p["predicted_max_bound95_m"]), "m", 2),
    ));
    let v = &p["validation"];
    if v.is_object() {
        rows.push((
            "validation",
            format!(
                "{} run(s), seed {}: {} of the distance within the requirement; max horizontal error {}",
                v["runs"].as_u64().unwrap_or(0),
                v["seed"].as_u64().unwrap_or(0),
                fmt_opt(num(&v["fraction_within_requirement"]).map(|f| 100.0 * f), "%", 2),
                fmt_opt(num(&v["max_horizontal_error_m"]), "m", 2),
            ),
        ));
    } else {
        rows.push(("validation", "not run".into()));
    }
    let b = &p["uniform_baseline"];
    if b.is_object() {
        rows.push((
            "uniform baseline",
            format!(
                "{} tag(s) every {}: {} of the distance within the requirement",
                b["tag_count"].as_u64().unwrap_or(0),
                fmt_opt(num(&b["spacing_m"]), "m", 0),
                fmt_opt(
                    num(&b["validation"]["fraction_within_requirement"]).map(|f| 100.0 * f),
                    "%",
                    2
                ),
            ),
        ));
    }
    rows.push(("method", p["method"].as_str().unwrap_or("?").to_string()));
    let mut html = String::from("<table>");
    for (k, v) in rows {
        let _ = write!(html, "<tr><th>{k}</th><td>{}</td></tr>", escape(&v));
    }
    html.push_str("</table>");
    html
}

/// Renders the report.
pub fn render_html(input: &ReportInput) -> Result<String> {
    let null = serde_json::Value::Null;
    let s = input.summary.as_ref().unwrap_or(&null);
    let p = input.plan.as_ref().unwrap_or(&null);
    let name = s["name"]
        .as_str()
        .or_else(|| p["scenario"].as_str())
        .unwrap_or("simulation");
    let requirement = num(&s["requirement_m"]);
    let mut html = String::new();
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>Waymark report: {}</title><style>{CSS}</style></head><body>",
        escape(name)
    );
    let subtitle = match (&input.summary, &input.plan) {
        (Some(_), plan) => format!(
            "navigator <b>{}</b>, {} run(s), seed {}{}",
            escape(s["mode"].as_str().unwrap_or("?")),
            s["runs"].as_u64().unwrap_or(1),
            s["seed"]
                .as_u64()
                .map(|x| x.to_string())
                .unwrap_or_else(|| "?".into()),
            if plan.is_some() { "; tag plan" } else { "" }
        ),
        (None, _) => format!(
            "tag plan for a {} m requirement",
            num(&p["requirement_m"]).unwrap_or(f64::NAN)
        ),
    };
    let _ = write!(
        html,
        "<header><h1>Waymark report: {}</h1><p>{subtitle}</p></header><main>",
        escape(name),
    );

    // Verdicts.
    html.push_str("<section><h2>Verdict</h2>");
    if input.plan.is_some() {
        let _ = write!(html, "<p>{}</p>", plan_verdict(p));
    }
    if input.summary.is_some() {
        let _ = write!(html, "<p>{}</p>", sim_verdict(s));
        let mm = &s["map_matching"];
        if mm.is_object() {
            let _ = write!(
                html,
                "<p>Map matching: {} fixes fed, {} accepted, {} rejected; {:.1} % on the wrong road; largest across-road error of an accepted fix {:.1} m.</p>",
                mm["fed"].as_u64().unwrap_or(0),
                mm["accepted"].as_u64().unwrap_or(0),
                mm["rejected"].as_u64().unwrap_or(0),
                100.0 * num(&mm["wrong_road_share"]).unwrap_or(0.0),
                num(&mm["max_across_error_m"]).unwrap_or(0.0),
            );
        }
    }
    html.push_str("</section>");

    if input.plan.is_some() {
        let _ = write!(html, "<section><h2>Plan</h2>{}</section>", plan_table(p));
    }

    // Summary table.
    if input.summary.is_some() {
        let frac = num(&s["fraction_within_requirement"]);
        html.push_str("<section><h2>Summary</h2><table>");
        let mut rows: Vec<(&str, String)> = vec![
            ("duration", fmt_opt(num(&s["duration_s"]), "s", 0)),
            (
                "distance",
                fmt_opt(num(&s["distance_m"]).map(|d| d / 1e3), "km", 2),
            ),
            (
                "max horizontal error",
                fmt_opt(num(&s["max_horizontal_error_m"]), "m", 2),
            ),
            (
                "RMS horizontal error",
                fmt_opt(num(&s["rms_horizontal_error_m"]), "m", 2),
            ),
            (
                "95th percentile horizontal error",
                fmt_opt(num(&s["p95_horizontal_error_m"]), "m", 2),
            ),
            ("requirement", fmt_opt(requirement, "m", 1)),
            (
                "fraction within requirement",
                fmt_opt(frac.map(|f| 100.0 * f), "%", 2),
            ),
            (
                "first exceeded",
                fmt_opt(num(&s["time_to_exceed_requirement_s"]), "s", 0),
            ),
            (
                "runs",
                s["runs"]
                    .as_u64()
                    .map(|r| r.to_string())
                    .unwrap_or_default(),
            ),
        ];
        if !input.tag_passes.is_empty() {
            let count = |k: PassKind| input.tag_passes.iter().filter(|p| p.kind == k).count();
            rows.push((
                "tag passes (run 0)",
                format!(
                    "{}: {} read and accepted, {} rejected by the filter, {} missed",
                    input.tag_passes.len(),
                    count(PassKind::Accepted),
                    count(PassKind::Rejected),
                    count(PassKind::Missed)
                ),
            ));
        }
        for (t, d) in &input.odometer_faults {
            rows.push((
                "odometer fault",
                format!(
                    "failed from {:.0} s ({:.2} km) to the end ({:.0} s)",
                    t[0],
                    d[0] / 1e3,
                    t[1]
                ),
            ));
        }
        for (k, v) in rows {
            let _ = write!(html, "<tr><th>{k}</th><td>{}</td></tr>", escape(&v));
        }
        html.push_str("</table></section>");
    }

    if let Some(map) = &input.map_svg {
        let colour = if input.rows.is_empty() {
            "the route coloured by the predicted 95 % bound with the tags (green 0, red at the requirement)"
        } else {
            "the route coloured by horizontal error (green 0, red at the requirement)"
        };
        let _ = write!(
            html,
            "<section><h2>Map</h2>{map}<p style=\"font-size:13px;color:#555\">Roads grey, tunnels blue dashed; \
             {colour}; tags: \
             <span style=\"color:{}\">●</span> road surface, <span style=\"color:{}\">●</span> roadside, \
             <span style=\"color:{}\">●</span> ceiling. Local metric (ENU) projection.</p></section>",
            super::map::mounting_colour(crate::tags::Mounting::RoadSurface),
            super::map::mounting_colour(crate::tags::Mounting::Roadside),
            super::map::mounting_colour(crate::tags::Mounting::Ceiling),
        );
    }

    // Plots.
    for (_, series, decor) in plots(input) {
        let svg = error_plot_svg(&series, &decor, (960, 420))?;
        let _ = write!(
            html,
            "<section><h2>{}</h2>{}</section>",
            escape(&decor.title),
            strip_xml_decl(&svg)
        );
    }

    if let Some(scn) = &input.scenario {
        let _ = write!(
            html,
            "<section><h2>Scenario</h2><pre>{}</pre></section>",
            escape(scn)
        );
    }
    let _ = writeln!(
        html,
        "</main><footer>Made by Waymark {}. Map data © OpenStreetMap contributors, ODbL.</footer></body></html>",
        env!("CARGO_PKG_VERSION")
    );
    Ok(html)
}

/// The Monte Carlo envelope from `summary.json`'s `profile` (median, 95th
/// percentile, max over runs), against time or distance; none for one run.
pub fn envelope(summary: &serde_json::Value, by_time: bool) -> Option<(Vec<f64>, [Vec<f64>; 3])> {
    if summary["runs"].as_u64().unwrap_or(1) < 2 {
        return None;
    }
    let profile = summary["profile"].as_array()?;
    let key = if by_time { "t_s" } else { "distance_m" };
    let mut x = Vec::with_capacity(profile.len());
    let mut env: [Vec<f64>; 3] = Default::default();
    for p in profile {
        let vals = [
            p[key].as_f64()?,
            p["median_m"].as_f64()?,
            p["p95_m"].as_f64()?,
            p["max_m"].as_f64()?,
        ];
        x.push(vals[0]);
        for k in 0..3 {
            env[k].push(vals[k + 1]);
        }
    }
    (!x.is_empty()).then_some((x, env))
}

fn strip_xml_decl(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

fn fmt_opt(v: Option<f64>, unit: &str, decimals: usize) -> String {
    match v {
        Some(x) => format!("{x:.decimals$} {unit}"),
        None => "—".into(),
    }
}
