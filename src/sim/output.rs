//! The files of `waymark simulate --out DIR`: `errors.csv` (run 0's error at
//! the output interval, with the filter's 1-sigma columns and its 95 %
//! horizontal bound, empty for modes without a filter), `summary.json` and,
//! for the integrated navigator, `tag_passes.csv` (run 0's passes by tags)
//! and, where the filter calibrates the odometer, `calibration.csv` (run
//! 0's calibration states over the run). All are written atomically.

use super::monte_carlo::SimResult;
use super::records::{CalibrationRow, ErrorRow, PassRecord};
use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use std::fmt::Write as _;
use std::path::Path;

/// The header of errors.csv.
pub const ERRORS_HEADER: &str = "t_s,distance_m,east_m,north_m,up_m,horizontal_m,\
sigma_east_m,sigma_north_m,sigma_up_m,bound95_m";

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
        for x in [r.sigma_east_m, r.sigma_north_m, r.sigma_up_m, r.bound95_m] {
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

/// The header of calibration.csv.
pub const CALIBRATION_HEADER: &str = "t_s,distance_m,\
scale_factor_truth,scale_factor_estimate,scale_factor_sigma,\
pitch_misalignment_truth_deg,pitch_misalignment_estimate_deg,pitch_misalignment_sigma_deg,\
yaw_misalignment_truth_deg,yaw_misalignment_estimate_deg,yaw_misalignment_sigma_deg";

/// calibration.csv text: run 0's odometer calibration at its error rows'
/// times, each state as the simulated value, the filter's estimate and its
/// 1σ. The scale factor is the odometer's scale-factor error as a ratio
/// (0.003 reads 0.3 % long), as `summary.json`'s `odometer_calibration`
/// gives it; the misalignments are in degrees.
pub fn calibration_csv(rows: &[CalibrationRow]) -> String {
    let mut s = String::with_capacity(128 * (rows.len() + 1));
    s.push_str(CALIBRATION_HEADER);
    s.push('\n');
    for r in rows {
        let _ = write!(s, "{:.3},{:.3}", r.t_s, r.distance_m);
        let [k, pitch, yaw] = r.states;
        for x in k {
            let _ = write!(s, ",{x:.8}");
        }
        for x in pitch.iter().chain(&yaw) {
            let _ = write!(s, ",{:.6}", x.to_degrees());
        }
        s.push('\n');
    }
    s
}

/// The header of tag_passes.csv.
pub const TAG_PASSES_HEADER: &str = "t_s,distance_m,tag_id,mounting,read,accepted,read_t_s,nis";

/// tag_passes.csv text: one row per pass by a tag (run 0), read or missed.
/// `read` and `accepted` are 1 or 0; `accepted`, `read_t_s` and `nis` are
/// empty when the filter did not see a read.
pub fn tag_passes_csv(passes: &[PassRecord]) -> String {
    let mut s = String::with_capacity(64 * (passes.len() + 1));
    s.push_str(TAG_PASSES_HEADER);
    s.push('\n');
    let opt = |x: Option<f64>, d: usize| x.map(|v| format!("{v:.d$}")).unwrap_or_default();
    for p in passes {
        let _ = writeln!(
            s,
            "{:.3},{:.3},{},{},{},{},{},{}",
            p.t_s,
            p.distance_m,
            csv_field(&p.tag_id),
            p.mounting.as_str(),
            u8::from(p.read),
            p.accepted
                .map(|a| u8::from(a).to_string())
                .unwrap_or_default(),
            opt(p.read_t_s, 3),
            opt(p.nis, 3),
        );
    }
    s
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(v: &str) -> std::borrow::Cow<'_, str> {
    if v.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", v.replace('"', "\"\"")).into()
    } else {
        v.into()
    }
}

/// Writes DIR/errors.csv and DIR/summary.json (creating DIR if needed),
/// DIR/tag_passes.csv for the integrated navigator and DIR/calibration.csv
/// where its filter calibrates the odometer.
pub fn write(dir: &Path, result: &SimResult) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let rows = result.runs.first().map_or(&[][..], |r| &r.rows[..]);
    write_atomic(&dir.join("errors.csv"), errors_csv(rows).as_bytes())?;
    if let Some(r) = result.runs.first().filter(|r| r.counts.is_some()) {
        write_atomic(
            &dir.join("tag_passes.csv"),
            tag_passes_csv(&r.tag_passes).as_bytes(),
        )?;
    }
    if let Some(r) = result
        .runs
        .first()
        .filter(|r| !r.calibration_rows.is_empty())
    {
        write_atomic(
            &dir.join("calibration.csv"),
            calibration_csv(&r.calibration_rows).as_bytes(),
        )?;
    }
    let json = serde_json::to_string_pretty(&result.summary)
        .map_err(|e| Error::InvalidParameter(format!("summary: {e}")))?;
    write_atomic(&dir.join("summary.json"), json.as_bytes())
}
