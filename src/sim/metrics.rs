//! Metrics of a simulation: error statistics over all runs' output rows and
//! the time at which each run first exceeds the requirement.

use super::run::RunResult;
use super::scenario::Scenario;
use serde::Serialize;

/// Per-run figures.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RunSummary {
    /// Run index.
    pub run: u64,
    /// Largest horizontal error (m).
    pub max_horizontal_error_m: f64,
    /// Horizontal error at the end (m).
    pub final_horizontal_error_m: f64,
    /// First time the horizontal error exceeded the requirement (s), if it did.
    pub time_to_exceed_requirement_s: Option<f64>,
}

/// The content of `summary.json`.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Summary {
    /// Scenario name.
    pub name: String,
    /// Navigator mode.
    pub mode: String,
    /// Number of Monte Carlo runs.
    pub runs: u64,
    /// Base seed.
    pub seed: u64,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Distance driven (m).
    pub distance_m: f64,
    /// Largest horizontal error over all runs and output times (m).
    pub max_horizontal_error_m: f64,
    /// Root mean square of the horizontal error over all runs and output times (m).
    pub rms_horizontal_error_m: f64,
    /// 95th percentile (nearest rank) of the horizontal error over all runs and output times (m).
    pub p95_horizontal_error_m: f64,
    /// The requirement (m), if the scenario sets one.
    pub requirement_m: Option<f64>,
    /// Share of (run, output time) rows whose horizontal error is within the requirement.
    pub fraction_within_requirement: Option<f64>,
    /// Earliest time any run exceeded the requirement (s); null if none did.
    pub time_to_exceed_requirement_s: Option<f64>,
    /// Error of run 0 at the end, east, north, up (m).
    pub final_error_enu_m: [f64; 3],
    /// Interval of the rows the statistics are taken over (s).
    pub output_interval_s: f64,
    /// IMU rate (Hz).
    pub imu_rate_hz: f64,
    /// Figures per run.
    pub per_run: Vec<RunSummary>,
}

fn mode_name(m: super::scenario::NavMode) -> &'static str {
    use super::scenario::NavMode::*;
    match m {
        FreeInertial => "free_inertial",
        DeadReckoning => "dead_reckoning",
        DeadReckoning3d => "dead_reckoning_3d",
        Integrated => "integrated",
    }
}

/// Summarizes runs.
pub fn summarize(scn: &Scenario, seed: u64, runs: &[RunResult]) -> Summary {
    let req = scn.file.requirement_m;
    let mut all: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.rows.iter().map(|x| x.horizontal_m))
        .collect();
    let n = all.len().max(1) as f64;
    let max = all.iter().cloned().fold(0.0, f64::max);
    let rms = (all.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    all.sort_by(|a, b| a.total_cmp(b));
    let p95 = if all.is_empty() {
        0.0
    } else {
        let rank = (0.95 * all.len() as f64).ceil() as usize;
        all[rank.clamp(1, all.len()) - 1]
    };
    let within = req.map(|r| all.iter().filter(|&&x| x <= r).count() as f64 / n);
    let per_run: Vec<RunSummary> = runs
        .iter()
        .map(|r| RunSummary {
            run: r.run,
            max_horizontal_error_m: r.rows.iter().map(|x| x.horizontal_m).fold(0.0, f64::max),
            final_horizontal_error_m: r.rows.last().map_or(0.0, |x| x.horizontal_m),
            time_to_exceed_requirement_s: req
                .and_then(|q| r.rows.iter().find(|x| x.horizontal_m > q).map(|x| x.t_s)),
        })
        .collect();
    let tte = per_run
        .iter()
        .filter_map(|r| r.time_to_exceed_requirement_s)
        .fold(None, |a: Option<f64>, t| Some(a.map_or(t, |a| a.min(t))));
    let last0 = runs.first().and_then(|r| r.rows.last());
    Summary {
        name: scn.file.name.clone(),
        mode: mode_name(scn.file.navigator.mode).into(),
        runs: runs.len() as u64,
        seed,
        duration_s: last0.map_or(0.0, |x| x.t_s),
        distance_m: last0.map_or(0.0, |x| x.distance_m),
        max_horizontal_error_m: max,
        rms_horizontal_error_m: rms,
        p95_horizontal_error_m: p95,
        requirement_m: req,
        fraction_within_requirement: within,
        time_to_exceed_requirement_s: tte,
        final_error_enu_m: last0.map_or([0.0; 3], |x| [x.east_m, x.north_m, x.up_m]),
        output_interval_s: scn.output_interval_s,
        imu_rate_hz: 1.0 / scn.dt,
        per_run,
    }
}
