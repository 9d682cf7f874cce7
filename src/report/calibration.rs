//! The odometer's calibration over the run (`calibration.csv`, run 0): how
//! fast the filter learns the scale factor and the mounting misalignment,
//! as one plot per state of the estimation error beside the filter's 95 %
//! interval.

use super::plot::{fault_spans, tag_marks, ErrorSeries, PlotDecor};
use super::{read_csv, PassRow};
use crate::error::Result;
use crate::sim::output::CALIBRATION_HEADER;
use std::path::Path;

/// One row of `calibration.csv`: each state as (simulated, estimate, 1σ),
/// the scale factor as a ratio, the misalignments in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationPoint {
    /// Time (s).
    pub t_s: f64,
    /// Distance driven (m).
    pub distance_m: f64,
    /// Scale-factor error (ratio): simulated, estimate, σ.
    pub scale_factor: [f64; 3],
    /// Pitch misalignment (°): simulated, estimate, σ.
    pub pitch_deg: [f64; 3],
    /// Yaw misalignment (°): simulated, estimate, σ.
    pub yaw_deg: [f64; 3],
}

/// Reads `calibration.csv` by column name (extra columns are ignored);
/// every column must hold finite numbers.
pub fn read_calibration_csv(path: &Path) -> Result<Vec<CalibrationPoint>> {
    // The columns simulate writes, in its order.
    let columns: Vec<&str> = CALIBRATION_HEADER.split(',').collect();
    read_csv(path, &columns, |v, _| {
        let three = |i: usize| Some([v[i]?, v[i + 1]?, v[i + 2]?]);
        Some(CalibrationPoint {
            t_s: v[0]?,
            distance_m: v[1]?,
            scale_factor: three(2)?,
            pitch_deg: three(5)?,
            yaw_deg: three(8)?,
        })
    })
}

/// The two-sided 95 % quantile of a normal: the filter's 95 % interval of
/// one state is ±1.96σ.
const Z95: f64 = 1.959_963_984_540_054;

/// One plot per calibration state against distance (against time for a
/// drive that does not move): the absolute error of the estimate and the
/// filter's 95 % interval half-width 1.96σ, the scale factor in percent,
/// the misalignments in degrees; run 0's tag passes marked and its
/// odometer faults (time, distance intervals) shaded. The y axis
/// holds the whole error curve and three times the final interval, so the
/// prior's wide interval at the start is clipped. None without rows.
pub fn calibration_plots(
    rows: &[CalibrationPoint],
    passes: &[PassRow],
    odometer_faults: &[([f64; 2], [f64; 2])],
) -> Vec<(&'static str, ErrorSeries, PlotDecor)> {
    if rows.is_empty() {
        return Vec::new();
    }
    let by_time = rows.iter().all(|r| r.distance_m == 0.0);
    let x: Vec<f64> = rows
        .iter()
        .map(|r| if by_time { r.t_s } else { r.distance_m })
        .collect();
    // (file stem, title, y label, unit), the state's columns, the factor
    // to the unit.
    type Names = (&'static str, &'static str, &'static str, &'static str);
    type State = (Names, fn(&CalibrationPoint) -> [f64; 3], f64);
    let states: [State; 3] = [
        (
            (
                "calibration_scale_factor",
                "Odometer scale factor: estimation error (run 0)",
                "scale-factor error (%)",
                "%",
            ),
            |r| r.scale_factor,
            100.0,
        ),
        (
            (
                "calibration_pitch",
                "Odometer pitch misalignment: estimation error (run 0)",
                "pitch misalignment error (°)",
                "°",
            ),
            |r| r.pitch_deg,
            1.0,
        ),
        (
            (
                "calibration_yaw",
                "Odometer yaw misalignment: estimation error (run 0)",
                "yaw misalignment error (°)",
                "°",
            ),
            |r| r.yaw_deg,
            1.0,
        ),
    ];
    states
        .into_iter()
        .map(|((name, title, y_label, unit), get, scale)| {
            let series = ErrorSeries {
                x: x.clone(),
                error: rows
                    .iter()
                    .map(|r| {
                        let [truth, est, _] = get(r);
                        scale * (est - truth).abs()
                    })
                    .collect(),
                bound95: rows.iter().map(|r| Some(scale * Z95 * get(r)[2])).collect(),
                envelope: None,
            };
            // The prior's interval dwarfs the converged one: the axis holds
            // the whole error curve and three times the final interval
            // (the prior's clipped part is marked as clipped).
            let top = series.error.iter().fold(0.0f64, |a, &b| a.max(b)) * 1.2;
            let last = series.bound95.last().copied().flatten().unwrap_or(0.0);
            let y_max = Some(top.max(3.0 * last)).filter(|&y| y > 0.0);
            let decor = PlotDecor {
                title: title.into(),
                x_label: if by_time {
                    "time (s)"
                } else {
                    "distance driven (m)"
                }
                .into(),
                y_label: Some(y_label.into()),
                y_unit: Some(unit.into()),
                error_label: Some("|estimate − simulated|".into()),
                bound_label: Some("filter 95 % (1.96σ)".into()),
                y_max,
                tag_passes: tag_marks(passes, by_time),
                shaded: fault_spans(odometer_faults, by_time),
                ..Default::default()
            };
            (name, series, decor)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_read_by_name_and_plotted_as_errors_beside_their_interval() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("calibration.csv");
        let write = |header_tail: &str, rows: &str| {
            std::fs::write(&p, format!("{CALIBRATION_HEADER}{header_tail}\n{rows}")).unwrap()
        };
        write(
            ",extra",
            "0,0,0.002,0,0.003,0.5,0,1,-0.25,0,1,x\n10,100,0.002,0.0015,0.0002,0.5,0.48,0.01,-0.25,-0.3,0.02,y\n",
        );
        let rows = read_calibration_csv(&p).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].yaw_deg, [-0.25, -0.3, 0.02]);
        let plots = calibration_plots(&rows, &[], &[]);
        assert_eq!(plots.len(), 3);
        let (name, s, d) = &plots[0];
        assert_eq!(*name, "calibration_scale_factor");
        assert_eq!(s.x, vec![0.0, 100.0]);
        // 0.2 % then 0.05 % of error; 1.96 × 0.3 % then 1.96 × 0.02 %.
        assert!((s.error[0] - 0.2).abs() < 1e-12 && (s.error[1] - 0.05).abs() < 1e-12);
        assert!((s.bound95[1].unwrap() - 0.0392).abs() < 1e-4);
        assert_eq!(d.x_label, "distance driven (m)");
        let yaw = &plots[2].1;
        assert!((yaw.error[1] - 0.05).abs() < 1e-12);
        // A column that is not a number names the file, the line and the column.
        write("", "0,0,0.002,nan,0.003,0.5,0,1,-0.25,0,1\n");
        let e = read_calibration_csv(&p).unwrap_err().to_string();
        assert!(e.contains("calibration.csv") && e.contains("line 2"), "{e}");
        assert!(e.contains("scale_factor_estimate"), "{e}");
    }
}
