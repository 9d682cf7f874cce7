//! The HTML report: one self-contained file.

use super::folder::{ExampleRun, TagRow, TagSource};
use super::plot::{
    error_plot_svg, fault_spans, tag_marks, ErrorSeries, PassKind, PlotDecor, TagMark,
};
use super::sections;
use super::{ErrorRow, PassRow, PlanProfileRow};
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
    /// `calibration.csv` rows (run 0; empty without odometer calibration).
    pub calibration: Vec<super::CalibrationPoint>,
    /// Odometer faults: (from, to) in time (s) and in distance (m).
    pub odometer_faults: Vec<([f64; 2], [f64; 2])>,
    /// `plan.json` as read (a plan).
    pub plan: Option<serde_json::Value>,
    /// A plan's `profile.csv` rows.
    pub plan_profile: Vec<PlanProfileRow>,
    /// The scenario file's text, when the folder has it.
    pub scenario: Option<String>,
    /// The map of the area (SVG with its legend, as HTML), when the
    /// scenario drives on a map.
    pub map_html: Option<String>,
    /// The tag table's rows.
    pub tags: Vec<TagRow>,
    /// Where those rows come from.
    pub tags_source: TagSource,
    /// An area plan's road pieces: predicted bound with and without tags (m).
    pub coverage_bounds: Vec<(f64, Option<f64>)>,
    /// An area plan's road pieces: why tags are needed there.
    pub coverage_reasons: Vec<String>,
    /// The example runs of a Monte Carlo simulation: the median by maximum
    /// error, then the worst (empty: run 0 from `errors.csv` is shown).
    pub examples: Vec<ExampleRun>,
    /// What the folder lacks, shown on the page.
    pub notes: Vec<String>,
}

const CSS: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;color:#1d2330;background:#f6f7f9}\
header{background:#1d3557;color:#fff;padding:18px 32px}header h1{margin:0;font-size:24px}\
header p{margin:6px 0 0;opacity:.85}main{padding:16px 32px;max-width:1100px}\
section{background:#fff;border:1px solid #dde1e7;border-radius:6px;padding:14px 20px;margin:14px 0}\
h2{font-size:18px;margin:4px 0 10px}table{border-collapse:collapse}td,th{padding:4px 14px 4px 0;text-align:left}\
th{color:#555;font-weight:600}.verdict{display:inline-block;padding:6px 12px;border-radius:4px;font-weight:600}\
.pass{background:#d8f3dc;color:#1b4332}.warn{background:#ffe8b3;color:#6b4500}.fail{background:#ffd6d6;color:#7a0b0b}.info{background:#e7ecf5;color:#1d3557}\
.figures,.rule{font-size:14px}.rule{color:#555}.notes{border-color:#e0a800;background:#fffaf0}\
pre{background:#f3f4f6;padding:10px;overflow:auto;font-size:13px}svg{max-width:100%;height:auto}footer{padding:12px 32px;color:#666;font-size:13px}\
.map-box{position:relative;border:1px solid #dde1e7;overflow:hidden;touch-action:none}.map-box svg.wm-map{display:block;width:100%;height:auto;cursor:grab}\
.north-box{position:absolute;top:8px;right:10px;pointer-events:none}.zoom{position:absolute;top:8px;left:8px}\
.zoom button{display:block;width:34px;margin:0 0 4px;font-size:16px;background:#fff;border:1px solid #aaa;border-radius:3px;cursor:pointer}\
.map-tip{position:absolute;display:none;background:rgba(255,255,255,.95);border:1px solid #888;padding:3px 6px;font-size:12px;pointer-events:none;max-width:360px}\
.map-legend{display:flex;flex-wrap:wrap;gap:6px 18px;align-items:center;font-size:13px;color:#444;margin-top:6px}.map-legend .keys span{margin-right:12px}\
.scale-bar .bar{display:inline-block;height:4px;background:#222;vertical-align:middle}\
.scroll{max-height:480px;overflow:auto}table.tags{font-size:12.5px}table.tags td,table.tags th{padding:2px 10px 2px 0;white-space:nowrap}\
table.tags thead th{position:sticky;top:0;background:#fff}tr.existing{color:#777}";

/// The map's pan, zoom and hover script (the project's own, inline).
const MAP_JS: &str = include_str!("map.js");

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

/// The report's plots: a file stem, the series and the decoration. For a
/// simulation, the example run's error against time and distance (the
/// median run by maximum error, or run 0 when the folder has no example
/// files; tag passes marked, odometer faults shaded) and the worst run's
/// against distance, and run 0's odometer calibration over the run where
/// the folder has it ([`super::calibration_plots`]); for a route plan, the
/// predicted bound along the route.
pub fn plots(input: &ReportInput) -> Vec<(&'static str, ErrorSeries, PlotDecor)> {
    let mut out = Vec::new();
    if let Some(s) = &input.summary {
        let requirement = num(&s["requirement_m"]);
        let run0 = ExampleRun {
            label: "run 0".into(),
            rows: input.rows.clone(),
            passes: input.tag_passes.clone(),
        };
        let example = input.examples.first().unwrap_or(&run0);
        let worst = input.examples.get(1);
        let mut plot = |name: &'static str, title: String, run: &ExampleRun, by_time: bool| {
            let x: Vec<f64> = run
                .rows
                .iter()
                .map(|r| if by_time { r.t_s } else { r.distance_m })
                .collect();
            if x.is_empty() || x.iter().all(|v| *v == 0.0) {
                return; // no rows, or a static run with no distance axis
            }
            let series = ErrorSeries {
                envelope: envelope(s, by_time),
                x,
                error: run.rows.iter().map(|r| r.horizontal_m).collect(),
                bound95: run.rows.iter().map(|r| r.bound95_m).collect(),
            };
            let decor = PlotDecor {
                title,
                x_label: if by_time {
                    "time (s)"
                } else {
                    "distance driven (m)"
                }
                .into(),
                requirement_m: requirement,
                error_label: Some(format!("horizontal error ({})", run.label)),
                bound_label: Some(format!("filter 95 % bound ({})", short(&run.label))),
                tag_passes: tag_marks(&run.passes, by_time),
                shaded: fault_spans(&input.odometer_faults, by_time),
                ..Default::default()
            };
            out.push((name, series, decor));
        };
        plot(
            "error_time",
            format!("Horizontal error against time: {}", short(&example.label)),
            example,
            true,
        );
        plot(
            "error_distance",
            format!(
                "Horizontal error against distance: {}",
                short(&example.label)
            ),
            example,
            false,
        );
        if let Some(w) = worst {
            plot(
                "error_distance_worst",
                format!("Horizontal error against distance: {}", short(&w.label)),
                w,
                false,
            );
        }
        out.extend(super::calibration::calibration_plots(
            &input.calibration,
            &input.tag_passes,
            &input.odometer_faults,
        ));
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
            // requirement readable (the clipped part is marked).
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

/// "run 7" of "run 7, the median run by maximum error (3.20 m)".
fn short(label: &str) -> &str {
    label.split(" (").next().unwrap_or(label)
}

/// Renders the report.
pub fn render_html(input: &ReportInput) -> Result<String> {
    let null = serde_json::Value::Null;
    let s = input.summary.as_ref().unwrap_or(&null);
    let p = input.plan.as_ref().unwrap_or(&null);
    let network = p["coverage"].as_str() == Some("network");
    let name = s["name"]
        .as_str()
        .or_else(|| p["scenario"].as_str())
        .unwrap_or("simulation");
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
            escape(s["mode"].as_str().unwrap_or("")),
            s["runs"].as_u64().unwrap_or(1),
            s["seed"].as_u64().unwrap_or(0),
            if plan.is_some() { "; tag plan" } else { "" }
        ),
        (None, _) => format!(
            "{} plan for a {} m requirement",
            if network {
                "area (network coverage)"
            } else {
                "route"
            },
            num(&p["requirement_m"]).unwrap_or(0.0)
        ),
    };
    let _ = write!(
        html,
        "<header><h1>Waymark report: {}</h1><p>{subtitle}</p></header><main>",
        escape(name),
    );
    if let Some(n) = sections::notes(&input.notes) {
        html.push_str(&n);
    }

    // Verdicts.
    html.push_str("<section id=\"verdict\"><h2>Verdict</h2>");
    if input.plan.is_some() {
        html.push_str(&sections::plan_verdict(p));
        if p["validation"].is_object() {
            html.push_str(&sections::rule(sections::confidence(p, s)));
        }
    }
    if input.summary.is_some() {
        html.push_str(&sections::sim_verdict(s));
        if let Some(n) = sections::nees(s) {
            html.push_str(&n);
        }
        if let Some(c) = sections::calibration(s) {
            html.push_str(&c);
        }
        if !p["validation"].is_object() && s["requirement_m"].is_number() {
            html.push_str(&sections::rule(sections::confidence(p, s)));
        }
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
        let table = if network {
            sections::network_table(
                p,
                &input.coverage_bounds,
                &input.coverage_reasons,
                &input.tags,
            )
        } else {
            sections::plan_table(p, missed_text(p))
        };
        let _ = write!(html, "<section id=\"plan\"><h2>Plan</h2>{table}</section>");
    }

    // Summary table.
    if input.summary.is_some() {
        html.push_str("<section id=\"summary\"><h2>Summary</h2>");
        html.push_str(&summary_table(input, s));
        html.push_str("</section>");
    }

    if let Some(map) = &input.map_html {
        let what = if network {
            "The whole area: every road of the map, the plan's tags"
        } else {
            "The route with the network around it"
        };
        let _ = write!(
            html,
            "<section id=\"map\"><h2>Map</h2>{map}<p style=\"font-size:13px;color:#555\">{what}. \
             Drag to pan, wheel or +/− to zoom, double-click or \"fit\" to reset; hover a road or a tag for its details. \
             Local metric (east-north) projection, north up.</p></section>"
        );
    }

    // Plots.
    for (_, series, decor) in plots(input) {
        let svg = error_plot_svg(&series, &decor, (960, 420))?;
        let _ = write!(
            html,
            "<section class=\"plot\"><h2>{}</h2>{}</section>",
            escape(&decor.title),
            strip_xml_decl(&svg)
        );
    }

    if !input.tags.is_empty() {
        // Where the heights come from, as the tag files' metadata says.
        let heights = match (
            p["tag_files"]["heights_known"].as_bool(),
            p["tag_files"]["parameters"]["height_m"].as_str(),
        ) {
            (Some(false), Some(why)) => format!(
                "<p class=\"figures\">Heights: {} (the files say so: KML clamps the tags to the ground with no altitude, GPX has no elevation, GeoJSON points are 2-D, tags.meta.json has heights_source none).</p>",
                escape(why)
            ),
            (Some(true), Some(why)) => format!("<p class=\"figures\">Heights: {}.</p>", escape(why)),
            _ => String::new(),
        };
        let _ = write!(
            html,
            "<section id=\"tags\"><h2>Tags</h2>{heights}{}</section>",
            sections::tag_table(&input.tags, &input.tags_source)
        );
    } else if p["tag_count"].as_u64() == Some(0) {
        // A plan that needs no tag says so where its tags would be listed:
        // installers read this section.
        html.push_str(
            "<section id=\"tags\"><h2>Tags</h2><p id=\"no-tags\">The plan places no tag: \
             every stretch its model checks stays within the requirement without one \
             (see the verdict and the validation above).</p></section>",
        );
    }

    if let Some(scn) = &input.scenario {
        let _ = write!(
            html,
            "<section><h2>Scenario</h2><pre>{}</pre></section>",
            escape(scn)
        );
    }
    let _ = write!(
        html,
        "</main><footer>Made by Waymark {}. Map data © OpenStreetMap contributors, ODbL.</footer>",
        env!("CARGO_PKG_VERSION")
    );
    if input.map_html.is_some() {
        let _ = write!(html, "<script>{MAP_JS}</script>");
    }
    html.push_str("</body></html>\n");
    Ok(html)
}

/// The plan's predicted bound with tags missed, when `plan.json` has it.
fn missed_text(p: &serde_json::Value) -> Option<String> {
    let b = num(&p["predicted_max_bound95_missed_m"])?;
    let k = p["tolerate_missed_reads"].as_u64().unwrap_or(0);
    Some(format!(
        "{b:.2} m with any {k} consecutive tag(s) missed (the worst such window)"
    ))
}

/// The simulation's summary table: only the numbers that exist.
fn summary_table(input: &ReportInput, s: &serde_json::Value) -> String {
    let mut rows: Vec<(String, String)> = Vec::new();
    let mut push = |k: &str, v: Option<String>| {
        if let Some(v) = v {
            rows.push((k.to_string(), v));
        }
    };
    push(
        "duration",
        num(&s["duration_s"]).map(|x| format!("{x:.0} s")),
    );
    push(
        "distance",
        num(&s["distance_m"]).map(|d| format!("{:.2} km", d / 1e3)),
    );
    push(
        "max horizontal error (all runs)",
        num(&s["max_horizontal_error_m"]).map(|x| format!("{x:.2} m")),
    );
    push(
        "RMS horizontal error",
        num(&s["rms_horizontal_error_m"]).map(|x| format!("{x:.2} m")),
    );
    push(
        "95th percentile horizontal error",
        num(&s["p95_horizontal_error_m"]).map(|x| format!("{x:.2} m")),
    );
    push(
        "requirement",
        num(&s["requirement_m"]).map(|x| format!("{x} m")),
    );
    push(
        "time within requirement",
        num(&s["fraction_within_requirement"]).map(|f| format!("{:.2} %", 100.0 * f)),
    );
    push(
        "first exceeded",
        num(&s["time_to_exceed_requirement_s"]).map(|x| format!("{x:.0} s")),
    );
    push("runs", s["runs"].as_u64().map(|r| r.to_string()));
    let maxima = super::folder::per_run_max(s);
    if maxima.len() > 1 {
        let mut m: Vec<f64> = maxima.iter().map(|x| x.1).collect();
        m.sort_by(f64::total_cmp);
        push(
            "per-run maximum error",
            Some(format!(
                "smallest {:.2} m, median {:.2} m, largest {:.2} m",
                m[0],
                m[(m.len() - 1) / 2],
                m[m.len() - 1]
            )),
        );
    }
    for e in &input.examples {
        push("example run", Some(e.label.clone()));
    }
    let example = input.examples.first();
    let passes = example.map_or(&input.tag_passes, |e| &e.passes);
    if !passes.is_empty() {
        let count = |k: PassKind| passes.iter().filter(|p| p.kind == k).count();
        push(
            &format!(
                "tag passes ({})",
                example.map_or("run 0", |e| short(&e.label))
            ),
            Some(format!(
                "{}: {} read and accepted, {} rejected by the filter, {} missed",
                passes.len(),
                count(PassKind::Accepted),
                count(PassKind::Rejected),
                count(PassKind::Missed)
            )),
        );
    }
    for (t, d) in &input.odometer_faults {
        push(
            "odometer fault",
            Some(format!(
                "failed from {:.0} s ({:.2} km) to the end ({:.0} s)",
                t[0],
                d[0] / 1e3,
                t[1]
            )),
        );
    }
    let mut html = String::from("<table class=\"kv\">");
    for (k, v) in rows {
        let _ = write!(html, "<tr><th>{k}</th><td>{}</td></tr>", escape(&v));
    }
    html.push_str("</table>");
    html
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
