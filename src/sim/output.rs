//! The files of `waymark simulate --out DIR`: `errors.csv` (run 0's error at
//! the output interval, with the filter's 1-sigma columns, empty for modes
//! without a filter) and `summary.json`. Both are written atomically.

use super::run::{ErrorRow, SimResult};
use crate::error::{Error, Result};
use crate::export::write_atomic;
use std::fmt::Write as _;
use std::path::Path;

/// The header of errors.csv.
pub const ERRORS_HEADER: &str =
    "t_s,distance_m,east_m,north_m,up_m,horizontal_m,sigma_east_m,sigma_north_m,sigma_up_m";

/// errors.csv text for rows.
pub fn errors_csv(rows: &[ErrorRow]) -> String {
    let mut s = String::with_capacity(64 * (rows.len() + 1));
    s.push_str(ERRORS_HEADER);
    s.push('\n');
    for r in rows {
        let _ = write!(
            s,
            "{:.3},{:.3},{:.4},{:.4},{:.4},{:.4}",
            r.t_s, r.distance_m, r.east_m, r.north_m, r.up_m, r.horizontal_m
        );
        for x in [r.sigma_east_m, r.sigma_north_m, r.sigma_up_m] {
            if x.is_finite() {
                let _ = write!(s, ",{x:.4}");
            } else {
                s.push(',');
            }
        }
        s.push('\n');
    }
    s
}

/// Writes DIR/errors.csv and DIR/summary.json (creating DIR if needed).
pub fn write(dir: &Path, result: &SimResult) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let rows = result.runs.first().map_or(&[][..], |r| &r.rows[..]);
    write_atomic(&dir.join("errors.csv"), errors_csv(rows).as_bytes())?;
    let json = serde_json::to_string_pretty(&result.summary)
        .map_err(|e| Error::InvalidParameter(format!("summary: {e}")))?;
    write_atomic(&dir.join("summary.json"), json.as_bytes())
}
