//! The HTML report: one self-contained file.

use super::plot::{error_plot_svg, ErrorSeries, PlotDecor};
use super::{bound95, ErrorRow};
use crate::error::Result;
use quick_xml::escape::escape;
use std::fmt::Write;

/// What a report is made from.
#[derive(Debug, Clone)]
pub struct ReportInput {
    /// `summary.json` as read.
    pub summary: serde_json::Value,
    /// `errors.csv` rows (run 0).
    pub rows: Vec<ErrorRow>,
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

/// Renders the report.
pub fn render_html(input: &ReportInput) -> Result<String> {
    let s = &input.summary;
    let name = s["name"].as_str().unwrap_or("simulation");
    let requirement = num(&s["requirement_m"]);
    let mut html = String::new();
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>Waymark report: {}</title><style>{CSS}</style></head><body>",
        escape(name)
    );
    let _ = write!(
        html,
        "<header><h1>Waymark report: {}</h1><p>navigator <b>{}</b>, {} run(s), seed {}</p></header><main>",
        escape(name),
        escape(s["mode"].as_str().unwrap_or("?")),
        s["runs"].as_u64().unwrap_or(1),
        s["seed"].as_u64().map(|x| x.to_string()).unwrap_or_else(|| "?".into()),
    );

    // Verdict.
    let frac = num(&s["fraction_within_requirement"]);
    let verdict = match (requirement, frac) {
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
    };
    let _ = write!(html, "<section><h2>Verdict</h2>{verdict}</section>");

    // Summary table.
    html.push_str("<section><h2>Summary</h2><table>");
    let rows: [(&str, String); 9] = [
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
    for (k, v) in rows {
        let _ = write!(html, "<tr><th>{k}</th><td>{}</td></tr>", escape(&v));
    }
    html.push_str("</table></section>");

    if let Some(map) = &input.map_svg {
        let _ = write!(
            html,
            "<section><h2>Map</h2>{map}<p style=\"font-size:13px;color:#555\">Roads grey, tunnels blue dashed; \
             the route coloured by horizontal error (green 0, red at the requirement); tags: \
             <span style=\"color:{}\">●</span> road surface, <span style=\"color:{}\">●</span> roadside, \
             <span style=\"color:{}\">●</span> ceiling. Local metric (ENU) projection.</p></section>",
            super::map::mounting_colour(crate::tags::Mounting::RoadSurface),
            super::map::mounting_colour(crate::tags::Mounting::Roadside),
            super::map::mounting_colour(crate::tags::Mounting::Ceiling),
        );
    }

    // Plots.
    let bound: Vec<Option<f64>> = input
        .rows
        .iter()
        .map(|r| r.sigma_en_m.map(bound95))
        .collect();
    let error: Vec<f64> = input.rows.iter().map(|r| r.horizontal_m).collect();
    for (title, x_label, x) in [
        (
            "Horizontal error against time",
            "time (s)",
            input.rows.iter().map(|r| r.t_s).collect::<Vec<_>>(),
        ),
        (
            "Horizontal error against distance",
            "distance driven (m)",
            input.rows.iter().map(|r| r.distance_m).collect::<Vec<_>>(),
        ),
    ] {
        if x.iter().all(|v| *v == 0.0) {
            continue; // a static run has no distance axis
        }
        let series = ErrorSeries {
            envelope: envelope(s, x_label.starts_with("time")),
            x,
            error: error.clone(),
            bound95: bound.clone(),
        };
        let decor = PlotDecor {
            title: title.into(),
            x_label: x_label.into(),
            requirement_m: requirement,
            ..Default::default()
        };
        let svg = error_plot_svg(&series, &decor, (960, 420))?;
        let _ = write!(
            html,
            "<section><h2>{title}</h2>{}</section>",
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
