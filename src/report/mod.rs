//! Reports: plots and a self-contained HTML page (inline SVG and CSS, no
//! scripts, no network) for a `simulate` output folder.

mod html;
mod map;
mod plot;

pub use html::{envelope, render_html, ReportInput};
pub use map::{error_colour, map_svg, mounting_colour, MapOverlay};
pub use plot::{error_plot_png, error_plot_svg, ErrorSeries, PlotDecor};

use crate::error::{Error, Result};
use std::path::Path;

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

/// Reads a `simulate` output folder: `summary.json`, `errors.csv` and, when
/// present, `scenario.toml`.
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
    Ok(ReportInput {
        summary,
        rows,
        scenario,
    })
}
