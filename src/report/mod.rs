//! Reports: plots and a self-contained HTML page (inline SVG and CSS, no
//! scripts, no network) for a `simulate` output folder.

mod html;
mod map;
mod plot;

pub use html::{envelope, render_html, ReportInput};
use map::map_svg as render_map;
pub use map::{error_colour, map_svg, mounting_colour, MapOverlay};
pub use plot::{error_plot_png, error_plot_svg, ErrorSeries, PlotDecor};

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
    crate::export::write_atomic(&dir.join("inputs.json"), v.to_string().as_bytes())
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

/// 95 % radius of a circular 2-D Gaussian with the mean of the two variances:
/// √(χ²₂(0.95)) = 2.4477 times the per-axis sigma.
pub fn bound95(sigma_en: [f64; 2]) -> f64 {
    2.447_746_830_680_816 * (0.5 * (sigma_en[0].powi(2) + sigma_en[1].powi(2))).sqrt()
}

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
/// overlay of the route coloured by the horizontal error of `rows` (matched
/// by distance driven ≈ chainage) and the tags (scenario `[[tag]]` entries
/// with a position or an `at_m` chainage, plus `extra_tags`). `None` for
/// scenarios driven by motion commands, which have no map.
pub fn scenario_map(
    scn: &crate::sim::Scenario,
    rows: &[ErrorRow],
    extra_tags: &[crate::sim::tags::Tag],
) -> Result<Option<(crate::network::Network, MapOverlay)>> {
    let crate::sim::scenario::RouteKind::Map { map, waypoints, .. } = &scn.route else {
        return Ok(None);
    };
    let net = crate::network::Network::load(map, &crate::network::LoadOptions::default())?;
    let route = crate::route::plan_route(&net, waypoints)?;
    let error_at = |d: f64| -> f64 {
        let i = rows
            .partition_point(|r| r.distance_m < d)
            .min(rows.len() - 1);
        rows[i].horizontal_m
    };
    let mut overlay = MapOverlay {
        route: route
            .vertices
            .iter()
            .map(|v| (v.lat_lon, error_at(v.chainage_m)))
            .collect(),
        tags: Vec::new(),
        requirement_m: scn.file.requirement_m,
    };
    for t in &scn.file.tag {
        let m = t
            .mounting
            .as_deref()
            .and_then(crate::tags::Mounting::parse)
            .unwrap_or(crate::tags::Mounting::RoadSurface);
        let ll = match (t.lat, t.lon, t.at_m) {
            (Some(lat), Some(lon), _) => Some([lat, lon]),
            (_, _, Some(at)) => {
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
    Ok(Some((net, overlay)))
}

/// Reads a `simulate` output folder: `summary.json`, `errors.csv` and, when
/// present, `scenario.toml` and `inputs.json` (the scenario's and the tag
/// file's original paths, for the map).
pub fn read_output_folder(dir: &Path) -> Result<ReportInput> {
    let summary_path = dir.join("summary.json");
    let text = std::fs::read_to_string(&summary_path).map_err(|e| Error::io(&summary_path, e))?;
    let summary: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::format(&summary_path, format!("invalid JSON: {e}")))?;
    if !summary.is_object() {
        return Err(Error::format(&summary_path, "not a JSON object"));
    }
    let rows = read_errors_csv(&dir.join("errors.csv"))?;
    let scenario = std::fs::read_to_string(dir.join("scenario.toml")).ok();
    let map_svg = match (&scenario, read_inputs(dir)) {
        (Some(text), Some((path, tags_path))) => {
            // The map follows the scenario's own folder, as when it was simulated.
            let scn = crate::sim::Scenario::parse(&path, text)?;
            let extra = match tags_path {
                Some(p) => crate::sim::tags::load_tags_csv(&p)?,
                None => Vec::new(),
            };
            scenario_map(&scn, &rows, &extra)?.map(|(net, overlay)| render_map(&net, &overlay, 960))
        }
        _ => None,
    };
    Ok(ReportInput {
        summary,
        rows,
        scenario,
        map_svg,
    })
}
