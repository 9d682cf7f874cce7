//! Reports: plots and a self-contained HTML page (inline SVG and CSS, no
//! scripts, no network) for a `simulate` or `plan` output folder (or one
//! holding both, as `waymark demo` writes).

mod html;
mod map;
mod plot;

pub use html::{envelope, plots, render_html, ReportInput};
use map::map_svg as render_map;
pub use map::{error_colour, map_svg, mounting_colour, MapOverlay};
pub use plot::{error_plot_png, error_plot_svg, ErrorSeries, PassKind, PlotDecor, TagMark};

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// `inputs.json`: where the scenario and the tag file were when simulated.
fn read_inputs(dir: &Path) -> Option<(PathBuf, Option<PathBuf>)> {
    let text = std::fs::read_to_string(dir.join("inputs.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    let scenario = PathBuf::from(v["scenario_path"].as_str()?);
    let tags = v["tags_path"].as_str().map(PathBuf::from);
    Some((scenario, tags))
}

/// Writes `inputs.json` beside a simulation's results, so `waymark report`
/// can draw the map later.
pub fn write_inputs(dir: &Path, scenario: &Path, tags: Option<&Path>) -> Result<()> {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let v = serde_json::json!({
        "scenario_path": abs(scenario).display().to_string(),
        "tags_path": tags.map(|t| abs(t).display().to_string()),
    });
    crate::fsio::write_atomic(&dir.join("inputs.json"), v.to_string().as_bytes())
}

/// One row of `errors.csv`.
#[derive(Debug, Clone, Copy, Default)]
pub struct ErrorRow {
    /// Time (s).
    pub t_s: f64,
    /// Distance driven (m).
    pub distance_m: f64,
    /// Horizontal error (m).
    pub horizontal_m: f64,
    /// Filter 1-sigma, east and north (m), where the navigator has a filter.
    pub sigma_en_m: Option<[f64; 2]>,
}

/// The filter's horizontal 95 % bound from `errors.csv`'s east and north 1σ:
/// the one definition, [`crate::sim::bound95`] (the circle
/// containing the 95 % ellipse), of the diagonal covariance the file gives
/// (it does not write the east-north correlation).
pub use crate::sim::covariance::bound95_of_sigmas as bound95;

/// Reads `errors.csv` by column name (extra columns are ignored).
pub fn read_errors_csv(path: &Path) -> Result<Vec<ErrorRow>> {
    let fail = |m: String| Error::format(path, m);
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .map_err(|e| fail(format!("cannot read: {e}")))?;
    let headers = r
        .headers()
        .map_err(|e| fail(format!("bad header: {e}")))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let need = |name: &str| col(name).ok_or_else(|| fail(format!("missing column '{name}'")));
    let (it, id, ih) = (need("t_s")?, need("distance_m")?, need("horizontal_m")?);
    let (ise, isn) = (col("sigma_east_m"), col("sigma_north_m"));
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| fail(format!("line {}: {e}", i + 2)))?;
        let num = |k: usize, name: &str| -> Result<f64> {
            rec.get(k)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("line {}: '{name}' is not a number", i + 2)))
        };
        let opt = |k: Option<usize>| {
            k.and_then(|k| rec.get(k))
                .and_then(|v| v.trim().parse::<f64>().ok())
        };
        rows.push(ErrorRow {
            t_s: num(it, "t_s")?,
            distance_m: num(id, "distance_m")?,
            horizontal_m: num(ih, "horizontal_m")?,
            sigma_en_m: match (opt(ise), opt(isn)) {
                (Some(e), Some(n)) => Some([e, n]),
                _ => None,
            },
        });
    }
    if rows.is_empty() {
        return Err(fail("no rows".into()));
    }
    Ok(rows)
}

/// The map of a scenario driven on a road network: the network, and the
/// overlay of the route coloured by `colour_by` (distance driven, value in
/// metres: the horizontal error, or a predicted bound; matched by distance
/// driven ≈ chainage; uncoloured where empty) and the tags (scenario
/// `[[tag]]` entries with a position or an `at_m` chainage, plus
/// `extra_tags`), drawn as SVG. `None` for scenarios driven by motion
/// commands, which have no map. `loaded` is the scenario's map and route when
/// the caller has them already (e.g. a simulation's truth); else they are
/// loaded from the scenario.
pub fn scenario_map(
    scn: &crate::sim::Scenario,
    colour_by: &[(f64, f64)],
    extra_tags: &[crate::sim::tags::Tag],
    loaded: Option<(&crate::network::Network, &crate::route::Route)>,
) -> Result<Option<String>> {
    let crate::scenario::RouteKind::Map { map, waypoints, .. } = &scn.route else {
        return Ok(None);
    };
    let owned;
    let (net, route) = match loaded {
        Some(l) => l,
        None => {
            let net = crate::network::Network::load(map, &crate::network::LoadOptions::default())?;
            let route = crate::route::plan_route(&net, waypoints)?;
            owned = (net, route);
            (&owned.0, &owned.1)
        }
    };
    tracing::info!(
        sections = net.sections.len(),
        "report: drawing the map of {}",
        map.display()
    );
    let error_at = |d: f64| -> f64 {
        if colour_by.is_empty() {
            return 0.0;
        }
        let i = colour_by
            .partition_point(|r| r.0 < d)
            .min(colour_by.len() - 1);
        colour_by[i].1
    };
    let mut overlay = MapOverlay {
        route: route
            .vertices
            .iter()
            .map(|v| (v.lat_lon, error_at(v.chainage_m)))
            .collect(),
        tags: Vec::new(),
        requirement_m: scn.requirement_m(),
    };
    for t in scn.tags() {
        let m = t.mounting;
        let ll = match t.place {
            crate::scenario::TagPlace::LatLonDeg(ll) => Some(ll),
            crate::scenario::TagPlace::AtDistance(at) => {
                let p = route.position_at(at);
                let g = net.frame.to_geodetic([p[0], p[1], 0.0]);
                Some([g.lat_deg(), g.lon_deg()])
            }
            _ => None,
        };
        if let Some(ll) = ll {
            overlay.tags.push((ll, m));
        }
    }
    for t in extra_tags {
        overlay
            .tags
            .push(([t.lat.to_degrees(), t.lon.to_degrees()], t.mounting));
    }
    Ok(Some(render_map(net, &overlay, 960)))
}

/// One row of `tag_passes.csv`, as the report needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassRow {
    /// Time abeam the tag (s).
    pub t_s: f64,
    /// Distance driven (m).
    pub distance_m: f64,
    /// Accepted, rejected or missed.
    pub kind: PassKind,
}

/// Reads `tag_passes.csv` by column name.
pub fn read_tag_passes_csv(path: &Path) -> Result<Vec<PassRow>> {
    read_csv(path, &["t_s", "distance_m", "read"], |v, get| {
        let kind = if v[2] == Some(0.0) {
            PassKind::Missed
        } else if get("accepted").as_deref() == Some("0") {
            PassKind::Rejected
        } else if get("accepted").as_deref() == Some("1") {
            PassKind::Accepted
        } else {
            PassKind::Missed
        };
        Some(PassRow {
            t_s: v[0]?,
            distance_m: v[1]?,
            kind,
        })
    })
}

/// One row of a plan's `profile.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanProfileRow {
    /// Distance along the route (m).
    pub distance_m: f64,
    /// Predicted 95 % bound with the plan's tags, all read (m).
    pub with_tags_m: f64,
    /// Predicted 95 % bound with no tags (m).
    pub without_tags_m: f64,
}

/// Reads a plan's `profile.csv` by column name.
pub fn read_plan_profile_csv(path: &Path) -> Result<Vec<PlanProfileRow>> {
    read_csv(
        path,
        &[
            "distance_m",
            "bound95_with_tags_m",
            "bound95_without_tags_m",
        ],
        |v, _| {
            Some(PlanProfileRow {
                distance_m: v[0]?,
                with_tags_m: v[1]?,
                without_tags_m: v[2]?,
            })
        },
    )
}

/// Reads a CSV file whose `numeric` columns must hold finite numbers; `row`
/// builds a record from them (and any other column by name).
fn read_csv<T>(
    path: &Path,
    numeric: &[&str],
    row: impl Fn(&[Option<f64>], &dyn Fn(&str) -> Option<String>) -> Option<T>,
) -> Result<Vec<T>> {
    let fail = |m: String| Error::format(path, m);
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .map_err(|e| fail(format!("cannot read: {e}")))?;
    let headers = r
        .headers()
        .map_err(|e| fail(format!("bad header: {e}")))?
        .clone();
    let mut cols = Vec::with_capacity(numeric.len());
    for name in numeric {
        cols.push(
            headers
                .iter()
                .position(|h| h == *name)
                .ok_or_else(|| fail(format!("missing column '{name}'")))?,
        );
    }
    let mut out = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| fail(format!("line {}: {e}", i + 2)))?;
        let mut vals = Vec::with_capacity(cols.len());
        for (k, name) in cols.iter().zip(numeric) {
            let v = rec
                .get(*k)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("line {}: '{name}' is not a number", i + 2)))?;
            vals.push(Some(v));
        }
        let get = |name: &str| {
            headers
                .iter()
                .position(|h| h == name)
                .and_then(|k| rec.get(k))
                .map(|v| v.trim().to_string())
        };
        if let Some(t) = row(&vals, &get) {
            out.push(t);
        }
    }
    Ok(out)
}

fn read_json(path: &Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::format(path, format!("invalid JSON: {e}")))?;
    if !v.is_object() {
        return Err(Error::format(path, "not a JSON object"));
    }
    Ok(v)
}

/// Reads an output folder of `simulate` (`summary.json`, `errors.csv`,
/// `tag_passes.csv`), of `plan` (`plan.json`, `profile.csv`, `tags.csv`) or
/// both, and, when present, `scenario.toml` and `inputs.json` (the
/// scenario's and the tag file's original paths, for the map). `loaded`: the
/// scenario's map and route when the caller has them (see [`scenario_map`]).
pub fn read_output_folder(
    dir: &Path,
    loaded: Option<(&crate::network::Network, &crate::route::Route)>,
) -> Result<ReportInput> {
    let summary_path = dir.join("summary.json");
    let plan_path = dir.join("plan.json");
    if !summary_path.exists() && !plan_path.exists() {
        return Err(Error::format(
            dir,
            "no summary.json (from waymark simulate) or plan.json (from waymark plan) in this folder",
        ));
    }
    let summary = summary_path
        .exists()
        .then(|| read_json(&summary_path))
        .transpose()?;
    let rows = match summary {
        Some(_) => read_errors_csv(&dir.join("errors.csv"))?,
        None => Vec::new(),
    };
    let passes_path = dir.join("tag_passes.csv");
    let tag_passes = match (&summary, passes_path.exists()) {
        (Some(_), true) => read_tag_passes_csv(&passes_path)?,
        _ => Vec::new(),
    };
    let plan = plan_path
        .exists()
        .then(|| read_json(&plan_path))
        .transpose()?;
    let profile_path = dir.join("profile.csv");
    let plan_profile = match (&plan, profile_path.exists()) {
        (Some(_), true) => read_plan_profile_csv(&profile_path)?,
        _ => Vec::new(),
    };
    let scenario = std::fs::read_to_string(dir.join("scenario.toml")).ok();
    let map_svg = match (&scenario, read_inputs(dir)) {
        (Some(text), Some((path, tags_path))) => {
            // The map follows the scenario's own folder, as when it was simulated.
            let scn = crate::sim::Scenario::parse(&path, text)?;
            // The tag file as recorded, else the folder's own (a plan's tags.csv).
            let local = dir.join("tags.csv");
            let tags_file = tags_path
                .filter(|p| p.exists())
                .or_else(|| local.exists().then_some(local));
            let extra = match tags_file {
                Some(p) => crate::sim::tags::load_tags_csv(&p)?,
                None => Vec::new(),
            };
            let colour_by: Vec<(f64, f64)> = if rows.is_empty() {
                plan_profile
                    .iter()
                    .map(|p| (p.distance_m, p.with_tags_m))
                    .collect()
            } else {
                rows.iter()
                    .map(|r| (r.distance_m, r.horizontal_m))
                    .collect()
            };
            scenario_map(&scn, &colour_by, &extra, loaded)?
        }
        _ => None,
    };
    Ok(ReportInput {
        summary,
        rows,
        tag_passes,
        odometer_faults: Vec::new(),
        plan,
        plan_profile,
        scenario,
        map_svg,
    }
    .with_faults_from_summary())
}

/// What `waymark report` wrote.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReportFiles {
    /// `DIR/report.html`.
    pub report: PathBuf,
    /// The PNG plots (`DIR/plots/*.png`).
    pub plots: Vec<PathBuf>,
    /// Whether the folder held simulation results.
    pub simulation: bool,
    /// Whether the folder held a plan.
    pub plan: bool,
}

/// Writes `DIR/report.html` and PNG plots in `DIR/plots/` for an output
/// folder of `simulate` and/or `plan`.
pub fn write_report(dir: &Path) -> Result<ReportFiles> {
    write_report_on(dir, None)
}

/// [`write_report`] with the scenario's map and route already loaded (the
/// caller's, e.g. `waymark demo`'s, which planned and simulated on them).
pub fn write_report_on(
    dir: &Path,
    loaded: Option<(&crate::network::Network, &crate::route::Route)>,
) -> Result<ReportFiles> {
    use crate::fsio::write_atomic;
    let input = read_output_folder(dir, loaded)?;
    let html = render_html(&input)?;
    let report = dir.join("report.html");
    write_atomic(&report, html.as_bytes())?;
    let plots_dir = dir.join("plots");
    std::fs::create_dir_all(&plots_dir).map_err(|e| Error::io(&plots_dir, e))?;
    let mut plots = Vec::new();
    for (name, series, decor) in html::plots(&input) {
        let path = plots_dir.join(format!("{name}.png"));
        write_atomic(&path, &error_plot_png(&series, &decor, (1200, 520))?)?;
        plots.push(path);
    }
    tracing::info!(
        "report: wrote {} and {} plot(s)",
        report.display(),
        plots.len()
    );
    Ok(ReportFiles {
        report,
        plots,
        simulation: input.summary.is_some(),
        plan: input.plan.is_some(),
    })
}
