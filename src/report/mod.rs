//! Reports: plots and a self-contained HTML page (inline SVG, CSS and the
//! project's own small script for the map's pan, zoom and hover details;
//! nothing loaded from the network) for a `simulate` or `plan` output
//! folder (or one holding both, as `waymark demo` writes).

mod baseline;
mod calibration;
mod folder;
mod html;
mod map;
mod plot;
mod sections;
pub mod verdict;

pub use calibration::{calibration_plots, read_calibration_csv, CalibrationPoint};
pub use folder::{
    example_files, example_runs, merge_plan_tags, per_run_max, read_coverage, read_tag_table,
    ExampleRun, TagRow, TagSource,
};
pub use html::{envelope, plots, render_html, ReportInput};
pub use map::{
    error_colour, map_legend, map_svg, mounting_colour, CoveragePiece, MapOverlay, MapTag,
    OVER_COLOUR,
};
pub use plot::{error_plot_png, error_plot_svg, ErrorSeries, PassKind, PlotDecor, TagMark};

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

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
    /// The filter's horizontal 95 % bound (m): the file's `bound95_m` (from
    /// the full covariance), or for a file without that column (written
    /// before it existed) [`bound95`] of `sigma_en_m`, which is below the
    /// full covariance's bound where east and north are correlated.
    pub bound95_m: Option<f64>,
}

/// The filter's horizontal 95 % bound from `errors.csv`'s east and north 1σ:
/// the one definition, [`crate::sim::bound95`] (the circle
/// containing the 95 % ellipse), of the diagonal covariance they give (the
/// east-north correlation left out). Used for files without the
/// `bound95_m` column, which carries the full covariance's bound.
pub use crate::sim::bound::bound95_of_sigmas as bound95;

/// Every plot a report can draw (`plots/NAME.png`).
pub const PLOT_NAMES: [&str; 7] = [
    "error_time",
    "error_distance",
    "error_distance_worst",
    "plan_profile",
    "calibration_scale_factor",
    "calibration_pitch",
    "calibration_yaw",
];

/// Reads `errors.csv` by column name (extra columns are ignored).
pub fn read_errors_csv(path: &Path) -> Result<Vec<ErrorRow>> {
    let fail = |m: String| Error::format(path, m);
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(folder::open_limited(path).map_err(|e| fail(format!("cannot read: {e}")))?);
    let headers = r
        .headers()
        .map_err(|e| fail(format!("bad header: {e}")))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let need = |name: &str| col(name).ok_or_else(|| fail(format!("missing column '{name}'")));
    let (it, id, ih) = (need("t_s")?, need("distance_m")?, need("horizontal_m")?);
    let (ise, isn) = (col("sigma_east_m"), col("sigma_north_m"));
    let ib = col("bound95_m");
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| fail(folder::record_error(&e, i)))?;
        // The record's own line: comment lines and quoted line ends move it.
        let line = rec.position().map_or(i as u64 + 2, |p| p.line());
        let num = |k: usize, name: &str| -> Result<f64> {
            rec.get(k)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("line {line}: '{name}' is not a number")))
        };
        let opt = |k: Option<usize>| {
            k.and_then(|k| rec.get(k))
                .and_then(|v| v.trim().parse::<f64>().ok())
        };
        let sigma_en_m = match (opt(ise), opt(isn)) {
            (Some(e), Some(n)) => Some([e, n]),
            _ => None,
        };
        let bound95_m = match ib {
            Some(_) => opt(ib).filter(|b| b.is_finite()),
            None => sigma_en_m.map(bound95),
        };
        rows.push(ErrorRow {
            t_s: num(it, "t_s")?,
            distance_m: num(id, "distance_m")?,
            horizontal_m: num(ih, "horizontal_m")?,
            sigma_en_m,
            bound95_m,
        });
    }
    if rows.is_empty() {
        return Err(fail("no rows".into()));
    }
    Ok(rows)
}

/// The map of a scenario on a road network, as the report's HTML block
/// (the map, its north arrow, zoom buttons, hover box and legend): the
/// network, and `overlay` (the route coloured by error or bound, the tags,
/// an area plan's road pieces). With `route_colour_by` (distance driven,
/// value in metres; matched by distance ≈ chainage) the scenario's route is
/// drawn; an area plan (`overlay.fit_network`) draws none. `None` for
/// scenarios driven by motion commands, which have no map. `loaded` is the
/// scenario's map and route when the caller has them already.
pub fn scenario_map(
    scn: &crate::sim::Scenario,
    route_colour_by: Option<&[(f64, f64)]>,
    mut overlay: MapOverlay,
    what: &str,
    loaded: Option<(&crate::network::Network, &crate::route::Route)>,
) -> Result<Option<String>> {
    let crate::scenario::RouteKind::Map { map, waypoints, .. } = &scn.route else {
        return Ok(None);
    };
    let owned_net;
    let owned_route;
    let (net, route) = match loaded {
        Some((n, r)) => (n, Some(r)),
        None => {
            owned_net =
                crate::network::Network::load(map, &crate::network::LoadOptions::default())?;
            let route = match route_colour_by {
                Some(_) => Some(crate::route::plan_route(&owned_net, waypoints)?),
                None => None,
            };
            owned_route = route;
            (&owned_net, owned_route.as_ref())
        }
    };
    tracing::info!(
        sections = net.sections.len(),
        "report: drawing the map of {}",
        map.display()
    );
    if let (Some(colour_by), Some(route)) = (route_colour_by, route) {
        let value_at = |d: f64| -> f64 {
            if colour_by.is_empty() {
                return 0.0;
            }
            let i = colour_by
                .partition_point(|r| r.0 < d)
                .min(colour_by.len() - 1);
            colour_by[i].1
        };
        overlay.route = route
            .vertices
            .iter()
            .map(|v| (v.lat_lon, value_at(v.chainage_m)))
            .collect();
        // Scenario tags placed by chainage along the route.
        for t in scn.tags() {
            if let crate::scenario::TagPlace::AtDistance(at) = t.place {
                let p = route.position_at(at);
                let g = net.frame.to_geodetic([p[0], p[1], 0.0]);
                overlay.tags.push(MapTag {
                    lat_lon: [g.lat_deg(), g.lon_deg()],
                    mounting: t.mounting,
                    info: format!("scenario tag at {at:.0} m · {}", t.mounting),
                });
            }
        }
    }
    for t in scn.tags() {
        if let crate::scenario::TagPlace::LatLonDeg(ll) = t.place {
            overlay.tags.push(MapTag {
                lat_lon: ll,
                mounting: t.mounting,
                info: format!("scenario tag · {}", t.mounting),
            });
        }
    }
    let svg = map_svg(net, &overlay, 960);
    let legend = map_legend(&overlay, what, Some(map::map_view_width_m(net, &overlay)));
    Ok(Some(format!(
        "<div class=\"map-box\">{svg}<div class=\"north-box\">{}</div>\
         <div class=\"zoom\"><button type=\"button\" data-zoom=\"0.5\" title=\"zoom in\">+</button>\
         <button type=\"button\" data-zoom=\"2\" title=\"zoom out\">−</button>\
         <button type=\"button\" data-zoom=\"reset\" title=\"fit\">fit</button></div>\
         <div class=\"map-tip\"></div></div>{legend}",
        map::NORTH_ARROW
    )))
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
        .from_reader(folder::open_limited(path).map_err(|e| fail(format!("cannot read: {e}")))?);
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
        let rec = rec.map_err(|e| fail(folder::record_error(&e, i)))?;
        let line = rec.position().map_or(i as u64 + 2, |p| p.line());
        let mut vals = Vec::with_capacity(cols.len());
        for (k, name) in cols.iter().zip(numeric) {
            let v = rec
                .get(*k)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("line {line}: '{name}' is not a number")))?;
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

/// `read(path)` when the folder's summary says the file was written
/// (`expected`) and it is there; a note "NAME is missing: `lacking`" when
/// expected and absent; nothing otherwise.
fn expected_file<T>(
    path: &Path,
    expected: bool,
    lacking: &str,
    notes: &mut Vec<String>,
    read: impl Fn(&Path) -> Result<Vec<T>>,
) -> Result<Vec<T>> {
    match (expected, path.exists()) {
        (true, true) => read(path),
        (true, false) => {
            let name = path.file_name().map_or_else(
                || path.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            notes.push(format!("{name} is missing: {lacking}"));
            Ok(Vec::new())
        }
        _ => Ok(Vec::new()),
    }
}

/// Reads an output folder of `simulate` (`summary.json`, `errors.csv`,
/// `tag_passes.csv`, the example runs), of `plan` (`plan.json`,
/// `profile.csv`, `tags.csv`, an area plan's `coverage.geojson`) or both,
/// and, when present, `scenario.toml` and `inputs.json` (the scenario's and
/// the tag file's original paths, for the map). `summary.json` and
/// `plan.json` must hold what the page is made from (else an error naming
/// the file and the key); any other file missing or unusable is a note in
/// [`ReportInput::notes`]. `loaded`: the scenario's map and route when the
/// caller has them (see [`scenario_map`]).
pub fn read_output_folder(
    dir: &Path,
    loaded: Option<(&crate::network::Network, &crate::route::Route)>,
) -> Result<ReportInput> {
    use folder::{read_json, require};
    if !dir.is_dir() {
        return Err(Error::format(dir, "not a folder"));
    }
    let summary_path = dir.join("summary.json");
    let plan_path = dir.join("plan.json");
    if !summary_path.exists() && !plan_path.exists() {
        return Err(Error::format(
            dir,
            "no summary.json (from waymark simulate) or plan.json (from waymark plan) in this folder",
        ));
    }
    let mut notes = Vec::new();
    let summary = summary_path
        .exists()
        .then(|| read_json(&summary_path))
        .transpose()?;
    if let Some(s) = &summary {
        require(
            &summary_path,
            s,
            &["duration_s", "distance_m", "max_horizontal_error_m"],
            &["requirement_m", "fraction_within_requirement"],
            &["runs", "seed"],
            &["name", "mode"],
        )?;
    }
    let plan = plan_path
        .exists()
        .then(|| read_json(&plan_path))
        .transpose()?;
    if let Some(p) = &plan {
        require(&plan_path, p, &["requirement_m"], &[], &["tag_count"], &[])?;
        if !p["tags"].is_array() {
            return Err(Error::format(&plan_path, "'tags' is missing or not a list"));
        }
    }
    let errors_path = dir.join("errors.csv");
    let rows = match (&summary, errors_path.exists()) {
        (Some(_), true) => read_errors_csv(&errors_path)?,
        (Some(_), false) => {
            notes.push("errors.csv is missing: run 0's error is not plotted".into());
            Vec::new()
        }
        _ => Vec::new(),
    };
    // A file the summary says the simulation wrote: read, or noted missing.
    let has = |key: &str| summary.as_ref().is_some_and(|s| s[key].is_object());
    let tag_passes = expected_file(
        &dir.join("tag_passes.csv"),
        has("updates_run0"),
        "tag passes are not marked",
        &mut notes,
        read_tag_passes_csv,
    )?;
    let calibration = expected_file(
        &dir.join("calibration.csv"),
        has("odometer_calibration"),
        "the odometer's calibration over the run is not plotted",
        &mut notes,
        read_calibration_csv,
    )?;
    // The example runs: the median by maximum error and the worst.
    let mut examples = Vec::new();
    if let Some(s) = summary.as_ref().filter(|s| s["runs"].as_u64() > Some(1)) {
        if let Some((median, worst)) = example_runs(&per_run_max(s)) {
            for (which, (run, max), why) in [
                ("median", median, "the median run by maximum error"),
                ("worst", worst, "the worst run"),
            ] {
                let label = format!("run {run}, {why} ({max:.2} m)");
                if let Some(x) = folder::read_example(dir, which, label)? {
                    examples.push(x);
                }
            }
            if examples.is_empty() {
                notes.push(format!(
                    "{} are missing (written by this version's simulate): run 0 is plotted, not the median run",
                    example_files("median").0
                ));
            }
        }
    }
    let plan_profile = match &plan {
        Some(p) => folder::read_profile(dir, p, &mut notes)?,
        None => Vec::new(),
    };
    let network_plan = plan
        .as_ref()
        .is_some_and(|p| p["coverage"].as_str() == Some("network"));
    // The tag table: the folder's installer file, else the tag file simulated with.
    let scenario_path = dir.join("scenario.toml");
    let scenario = match folder::read_optional(
        &scenario_path,
        crate::scenario::MAX_SCENARIO_BYTES,
        "scenario",
    ) {
        folder::Optional::Text(t) => Some(t),
        folder::Optional::Absent => {
            notes.push("scenario.toml is missing: the map and the scenario are not shown".into());
            None
        }
        folder::Optional::Unreadable(e) => {
            notes.push(format!(
                "scenario.toml cannot be read ({}): the map and the scenario are not shown",
                folder::without_path(&e, &scenario_path)
            ));
            None
        }
    };
    let inputs = folder::read_inputs(dir, &mut notes);
    let local_tags = dir.join("tags.csv");
    let tags_file = if local_tags.exists() {
        Some(local_tags.clone())
    } else {
        match inputs.as_ref().and_then(|i| i.1.clone()) {
            Some(p) if p.exists() => Some(p),
            Some(p) => {
                notes.push(format!(
                    "the tag file recorded in inputs.json, {}, is missing: its tags are not shown",
                    p.display()
                ));
                None
            }
            None => None,
        }
    };
    if plan.is_some() && !dir.join("tags.csv").exists() {
        notes.push(
            "tags.csv is missing: the tag table holds the plan's tags without payloads".into(),
        );
    }
    // The folder's own tags.csv by name, a recorded tag file by its path.
    let tags_label = |p: &Path| {
        if p == local_tags.as_path() {
            "tags.csv".to_string()
        } else {
            p.display().to_string()
        }
    };
    let mut tags = match &tags_file {
        Some(p) => {
            if folder::ends_mid_line(p) {
                notes.push(format!(
                    "{} ends in the middle of a line: it may have been cut short, so its last tag may be wrong or missing",
                    tags_label(p)
                ));
            }
            read_tag_table(p)?
        }
        None => Vec::new(),
    };
    let mut tags_source = match &tags_file {
        Some(p) => TagSource::File(
            p.file_name()
                .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into()),
        ),
        None => TagSource::Plan,
    };
    if let Some(p) = &plan {
        let planned: Vec<&str> = p["tags"]
            .as_array()
            .into_iter()
            .flatten()
            .filter(|t| t["existing"].as_bool() != Some(true))
            .filter_map(|t| t["tag_id"].as_str())
            .collect();
        if let (Some(file), false) = (&tags_file, tags.is_empty()) {
            // The installer file against the plan: a file cut short at a
            // line end, or edited, lacks some of the plan's new tags.
            let ids: std::collections::HashSet<&str> =
                tags.iter().map(|t| t.tag_id.as_str()).collect();
            let lacking: Vec<&str> = planned
                .iter()
                .copied()
                .filter(|id| !ids.contains(id))
                .collect();
            if let Some(first) = lacking.first() {
                notes.push(format!(
                    "{} lacks {} of plan.json's {} new tag(s) (first {first}): it may have been cut short or edited; the table shows the file's tags",
                    tags_label(file),
                    lacking.len(),
                    planned.len()
                ));
            }
        }
        if !tags.is_empty() {
            merge_plan_tags(&mut tags, p);
        } else {
            if let (Some(file), false) = (&tags_file, planned.is_empty()) {
                notes.push(format!(
                    "{} holds no tags while plan.json plans {}: the table shows plan.json's tags, without payloads",
                    tags_label(file),
                    planned.len()
                ));
            }
            // No tags in a file: the plan's own list.
            tags = p["tags"]
                .as_array()
                .into_iter()
                .flatten()
                .filter_map(TagRow::from_plan_tag)
                .collect();
            tags_source = TagSource::Plan;
        }
    }
    let coverage_path = dir.join("coverage.geojson");
    let coverage = if coverage_path.exists() {
        read_coverage(&coverage_path)?
    } else {
        Vec::new()
    };
    let requirement = summary
        .as_ref()
        .and_then(|s| s["requirement_m"].as_f64())
        .or_else(|| plan.as_ref().and_then(|p| p["requirement_m"].as_f64()));
    let map_html = match (&scenario, &inputs) {
        (Some(text), Some((path, _))) => {
            // The map follows the scenario's own folder, as when it was simulated.
            match crate::sim::Scenario::parse(path, text) {
                Ok(scn) => {
                    let mut overlay = folder::overlay(requirement);
                    overlay.tags = folder::map_tags(&tags);
                    overlay.coverage = coverage.iter().map(|c| c.0.clone()).collect();
                    overlay.fit_network = network_plan;
                    let colour_by: Vec<(f64, f64)> = if rows.is_empty() {
                        plan_profile
                            .iter()
                            .map(|p| (p.distance_m, p.with_tags_m))
                            .collect()
                    } else {
                        let r = examples.first().map_or(&rows, |e| &e.rows);
                        r.iter().map(|r| (r.distance_m, r.horizontal_m)).collect()
                    };
                    let what = if network_plan {
                        "roads: predicted 95 % bound with the tags, all read (m)".to_string()
                    } else if rows.is_empty() {
                        "route: predicted 95 % bound with the tags, all read (m)".to_string()
                    } else {
                        format!(
                            "route: horizontal error of {} (m)",
                            examples
                                .first()
                                .map_or("run 0".to_string(), |e| e.label.clone())
                        )
                    };
                    let drawn = scenario_map(
                        &scn,
                        (!network_plan).then_some(&colour_by[..]),
                        overlay,
                        &what,
                        loaded,
                    );
                    match drawn {
                        Ok(m) => m,
                        Err(e) if !path.exists() => {
                            // The map's path is relative to where the
                            // scenario was: say that place is gone.
                            notes.push(format!(
                                "the map is not drawn: the scenario recorded in inputs.json, {}, is no longer there, and its map is looked for beside it ({e})",
                                path.display()
                            ));
                            None
                        }
                        Err(e) => {
                            notes.push(format!("the map is not drawn: {e}"));
                            None
                        }
                    }
                }
                Err(e) => {
                    notes.push(format!(
                        "scenario.toml cannot be read ({e}): the map is not drawn"
                    ));
                    None
                }
            }
        }
        // Without the scenario or inputs.json: noted where each was read.
        _ => None,
    };
    if network_plan && coverage.is_empty() {
        notes.push(
            "coverage.geojson is absent: roads are drawn grey, not coloured by their predicted bound"
                .into(),
        );
    }
    Ok(ReportInput {
        summary,
        rows,
        tag_passes,
        calibration,
        odometer_faults: Vec::new(),
        plan,
        plan_profile,
        scenario,
        map_html,
        tags,
        tags_source,
        coverage_reasons: coverage.iter().map(|c| c.2.clone()).collect(),
        coverage_bounds: coverage.iter().map(|c| (c.0.value_m, c.1)).collect(),
        examples,
        notes,
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
    /// What the folder lacked (also shown on the page).
    pub missing: Vec<String>,
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
    if report.is_dir() {
        return Err(Error::format(
            &report,
            "the report's path is an existing folder",
        ));
    }
    // The plots first, the page that shows them last: a failure on the way
    // leaves no new page without its plots.
    let plots_dir = dir.join("plots");
    std::fs::create_dir_all(&plots_dir).map_err(|e| Error::io(&plots_dir, e))?;
    let mut plots = Vec::new();
    let mut written = Vec::new();
    for (name, series, decor) in html::plots(&input) {
        let path = plots_dir.join(format!("{name}.png"));
        write_atomic(&path, &error_plot_png(&series, &decor, (1200, 520))?)?;
        plots.push(path);
        written.push(name);
    }
    // A plot an earlier report drew from files no longer there (a run
    // fewer, calibration.csv removed) would be taken for this one's.
    for name in PLOT_NAMES.iter().filter(|n| !written.contains(n)) {
        let path = plots_dir.join(format!("{name}.png"));
        if path.exists() {
            std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
        }
    }
    write_atomic(&report, html.as_bytes())?;
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
        missing: input.notes.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Vec<ErrorRow> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("errors.csv");
        std::fs::write(&p, text).unwrap();
        read_errors_csv(&p).unwrap()
    }

    #[test]
    fn the_bound_column_is_read_and_older_files_fall_back_to_the_sigmas() {
        let head =
            "t_s,distance_m,east_m,north_m,up_m,horizontal_m,sigma_east_m,sigma_north_m,sigma_up_m";
        // σ_E = σ_N = 2 m fully correlated: the full covariance's bound is
        // 2.4477·√8 = 6.92 m, the diagonal's 2.4477·2 = 4.90 m.
        let new = read(&format!(
            "{head},bound95_m\n0,0,1,1,0,1.4142,2,2,1,6.9232\n1,10,0,0,0,0,,,,\n"
        ));
        assert_eq!(new[0].bound95_m, Some(6.9232));
        assert_eq!(new[1].bound95_m, None);
        assert_eq!(new[1].sigma_en_m, None);
        let old = read(&format!("{head}\n0,0,1,1,0,1.4142,2,2,1\n"));
        assert_eq!(old[0].bound95_m, Some(bound95([2.0, 2.0])));
        assert!((old[0].bound95_m.unwrap() - 4.8955).abs() < 1e-4);
    }
}
