//! Metrics of a simulation: error statistics over all runs' output rows and
//! the time at which each run first exceeds the requirement.

use super::records::RunResult;
use crate::scenario::Scenario;
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
    /// Runs whose horizontal error exceeded the requirement at some time.
    pub runs_exceeding_requirement: Option<u64>,
    /// Statistics over runs at each output time (decimated to at most 500 points).
    pub profile: Vec<ProfilePoint>,
    /// Filter consistency (integrated mode).
    pub nees: Option<NeesSummary>,
    /// Tag reads (integrated mode).
    pub tags: Option<TagSummary>,
    /// The map-matching feed over all runs (integrated mode with
    /// `aiding.map_matching`).
    pub map_matching: Option<MapMatchingSummary>,
    /// Update counts of run 0 (integrated mode).
    pub updates_run0: Option<crate::nav::integrated::UpdateCounts>,
    /// Odometer faults injected by the scenario (`[odometer] failure`) while
    /// the navigator uses the odometer, as intervals of time and distance.
    pub odometer_faults: Vec<FaultInterval>,
    /// What the filter learnt of the odometer's calibration by the end of
    /// the runs (integrated mode with odometer aiding).
    pub odometer_calibration: Option<CalibrationSummary>,
}

/// One calibration state at the end of the runs: the simulated value, the
/// filter's estimate and its σ.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CalibrationState {
    /// Run 0's simulated value.
    pub truth_run0: f64,
    /// Run 0's estimate at the end.
    pub estimate_run0: f64,
    /// Run 0's filter σ at the end.
    pub sigma_run0: f64,
    /// Over the runs: RMS of the final estimate minus the simulated value.
    pub rms_error: f64,
    /// Over the runs: RMS of the final filter σ (a consistent filter's is
    /// about `rms_error`).
    pub rms_sigma: f64,
}

/// The filter's odometer calibration states at the end of the runs
/// (`summary.json`'s `odometer_calibration`): the scale-factor error (the
/// odometer reads (1 + δK) v) and the IMU-to-vehicle misalignment in
/// degrees (the vehicle's forward axis is [−yaw, 1, pitch] in the IMU's
/// axes), as `[odometer]` states them.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CalibrationSummary {
    /// Scale-factor error (ratio).
    pub scale_factor: CalibrationState,
    /// Pitch misalignment (deg).
    pub pitch_misalignment_deg: CalibrationState,
    /// Yaw misalignment (deg).
    pub yaw_misalignment_deg: CalibrationState,
}

impl CalibrationSummary {
    /// From the runs' [`RunResult::calibration`] (`None` if run 0 has none).
    fn of(runs: &[RunResult]) -> Option<Self> {
        let first = runs.first()?.calibration?;
        let all: Vec<[[f64; 3]; 3]> = runs.iter().filter_map(|r| r.calibration).collect();
        let n = all.len() as f64;
        let state = |i: usize, scale: f64| {
            let rms = |f: &dyn Fn(&[[f64; 3]; 3]) -> f64| {
                (all.iter().map(|c| f(c).powi(2)).sum::<f64>() / n).sqrt() * scale
            };
            CalibrationState {
                truth_run0: first[i][0] * scale,
                estimate_run0: first[i][1] * scale,
                sigma_run0: first[i][2] * scale,
                rms_error: rms(&|c| c[i][1] - c[i][0]),
                rms_sigma: rms(&|c| c[i][2]),
            }
        };
        let deg = 1f64.to_degrees();
        Some(CalibrationSummary {
            scale_factor: state(0, 1.0),
            pitch_misalignment_deg: state(1, deg),
            yaw_misalignment_deg: state(2, deg),
        })
    }
}

/// An interval during which a sensor is faulty (run 0's time and distance).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct FaultInterval {
    /// What fails (`odometer_failure`).
    pub kind: String,
    /// Start (s).
    pub from_s: f64,
    /// End (s): the end of the run.
    pub to_s: f64,
    /// Distance driven at the start (m).
    pub from_m: f64,
    /// Distance driven at the end (m).
    pub to_m: f64,
}

/// The scenario's odometer failure as an interval of run 0's rows; none if
/// the navigator does not use the odometer or the failure starts after the run.
fn odometer_faults(scn: &Scenario, rows: &[super::records::ErrorRow]) -> Vec<FaultInterval> {
    use crate::scenario::NavMode;
    let uses_odometer = match scn.navigator().mode {
        NavMode::DeadReckoning => true,
        NavMode::Integrated => scn.aiding().odometer,
        _ => false,
    };
    let (Some(f), Some(last)) = (scn.odometer.failure, rows.last()) else {
        return vec![];
    };
    if !uses_odometer {
        return vec![];
    }
    let start = rows.iter().position(|r| {
        f.from_s.is_some_and(|s| r.t_s >= s) || f.from_m.is_some_and(|m| r.distance_m >= m)
    });
    let Some(k) = start else {
        return vec![];
    };
    // The exact start where the scenario gives it, else the first row at or past it.
    let (from_s, from_m) = match (f.from_s, f.from_m) {
        (Some(s), None) => (s, rows[k].distance_m),
        (None, Some(m)) => (rows[k].t_s, m),
        _ => (rows[k].t_s, rows[k].distance_m),
    };
    vec![FaultInterval {
        kind: "odometer_failure".into(),
        from_s,
        to_s: last.t_s,
        from_m,
        to_m: last.distance_m,
    }]
}

/// Horizontal error statistics over runs at one output time.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ProfilePoint {
    /// Time (s).
    pub t_s: f64,
    /// Distance travelled (m).
    pub distance_m: f64,
    /// RMS over runs (m).
    pub rms_m: f64,
    /// Median over runs (m).
    pub median_m: f64,
    /// 95th percentile over runs (m).
    pub p95_m: f64,
    /// Largest over runs (m).
    pub max_m: f64,
    /// Mean filter 1σ horizontal (√(σE² + σN²)) over runs (m), if a filter ran.
    pub sigma_h_m: Option<f64>,
    /// Run-averaged horizontal NEES, if a filter ran.
    pub nees_h: Option<f64>,
}

/// Average horizontal NEES over runs against its chi-square band.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct NeesSummary {
    /// Degrees of freedom per run (2: east, north).
    pub dof: u32,
    /// Runs averaged.
    pub runs: u64,
    /// Two-sided 95 % band of the run-averaged NEES: χ²(runs·dof)/runs quantiles.
    pub band_95: [f64; 2],
    /// Mean over output times of the run-averaged NEES.
    pub mean: f64,
    /// Share of output times whose run-averaged NEES is inside the band.
    pub fraction_within_band: f64,
    /// Share above the band (the filter over-confident).
    pub fraction_above_band: f64,
}

/// The map-matching feed over all runs.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MapMatchingSummary {
    /// Fixes offered to the filter.
    pub fed: u64,
    /// Accepted by its gate.
    pub accepted: u64,
    /// Rejected by its gate.
    pub rejected: u64,
    /// Share of fed fixes on the wrong road (the matched road's true centre
    /// line more than `map_feed::WRONG_ROAD_M` from the truth).
    pub wrong_road_share: f64,
    /// Largest across-road error of an accepted fix against the truth (m).
    pub max_across_error_m: f64,
}

impl MapMatchingSummary {
    /// Sums the feeds of `runs`; `None` when no run had one.
    pub fn of(runs: &[RunResult]) -> Option<Self> {
        let feeds: Vec<_> = runs.iter().filter_map(|r| r.map_feed).collect();
        if feeds.is_empty() {
            return None;
        }
        let fed: u64 = feeds.iter().map(|c| c.fed).sum();
        let accepted: u64 = feeds.iter().map(|c| c.accepted).sum();
        let wrong: u64 = feeds.iter().map(|c| c.wrong_road).sum();
        Some(Self {
            fed,
            accepted,
            rejected: fed - accepted,
            wrong_road_share: wrong as f64 / fed.max(1) as f64,
            max_across_error_m: feeds
                .iter()
                .map(|c| c.max_across_error_m)
                .fold(0.0, f64::max),
        })
    }
}

/// Tag reads over all runs, and run 0's rejected reads.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TagSummary {
    /// Reads accepted by the filter, all runs.
    pub accepted: u64,
    /// Reads rejected by the gate, all runs.
    pub rejected: u64,
    /// Rejected reads of run 0.
    pub rejected_run0: Vec<super::records::TagEvent>,
}

/// The p quantile of χ²(k) (Wilson–Hilferty; within 0.5 % for k ≥ 10).
pub fn chi2_quantile(k: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

fn profile_and_nees(runs: &[RunResult]) -> (Vec<ProfilePoint>, Option<NeesSummary>) {
    let n_rows = runs.iter().map(|r| r.rows.len()).min().unwrap_or(0);
    let stride = n_rows.div_ceil(500).max(1);
    let nr = runs.len() as f64;
    let mut profile = Vec::new();
    let mut col = Vec::with_capacity(runs.len());
    for i in 0..n_rows {
        if i % stride != 0 && i + 1 != n_rows {
            continue;
        }
        col.clear();
        col.extend(runs.iter().map(|r| r.rows[i].horizontal_m));
        col.sort_by(|a, b| a.total_cmp(b));
        let rank = (0.95 * col.len() as f64).ceil() as usize;
        let r0 = &runs[0].rows[i];
        let sig: f64 = runs
            .iter()
            .map(|r| r.rows[i].sigma_east_m.hypot(r.rows[i].sigma_north_m))
            .sum::<f64>()
            / nr;
        profile.push(ProfilePoint {
            t_s: r0.t_s,
            distance_m: r0.distance_m,
            rms_m: (col.iter().map(|x| x * x).sum::<f64>() / nr).sqrt(),
            median_m: if col.len() % 2 == 1 {
                col[col.len() / 2]
            } else {
                0.5 * (col[col.len() / 2 - 1] + col[col.len() / 2])
            },
            p95_m: col[rank.clamp(1, col.len()) - 1],
            max_m: *col.last().unwrap_or(&0.0),
            sigma_h_m: sig.is_finite().then_some(sig),
            nees_h: {
                let m = runs.iter().map(|r| r.rows[i].nees_h).sum::<f64>() / nr;
                m.is_finite().then_some(m)
            },
        });
    }
    let has = runs
        .first()
        .is_some_and(|r| r.rows.iter().any(|x| x.nees_h.is_finite()));
    if !has {
        return (profile, None);
    }
    let dof = 2.0;
    let lo = chi2_quantile(nr * dof, -1.959_964) / nr;
    let hi = chi2_quantile(nr * dof, 1.959_964) / nr;
    let (mut sum, mut n, mut inside, mut above) = (0.0, 0usize, 0usize, 0usize);
    // Skip the first row (t = 0: the prior alone).
    for i in 1..n_rows {
        let m = runs.iter().map(|r| r.rows[i].nees_h).sum::<f64>() / nr;
        if !m.is_finite() {
            continue;
        }
        sum += m;
        n += 1;
        if m >= lo && m <= hi {
            inside += 1;
        } else if m > hi {
            above += 1;
        }
    }
    let nn = n.max(1) as f64;
    (
        profile,
        Some(NeesSummary {
            dof: 2,
            runs: runs.len() as u64,
            band_95: [lo, hi],
            mean: sum / nn,
            fraction_within_band: inside as f64 / nn,
            fraction_above_band: above as f64 / nn,
        }),
    )
}

/// Summarizes runs.
pub fn summarize(scn: &Scenario, seed: u64, runs: &[RunResult]) -> Summary {
    let req = scn.requirement_m();
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
    let (profile, nees) = profile_and_nees(runs);
    let integrated = runs.first().is_some_and(|r| r.counts.is_some());
    let tags = integrated.then(|| TagSummary {
        accepted: runs
            .iter()
            .map(|r| r.tag_events.iter().filter(|e| e.accepted).count() as u64)
            .sum(),
        rejected: runs
            .iter()
            .map(|r| r.tag_events.iter().filter(|e| !e.accepted).count() as u64)
            .sum(),
        rejected_run0: runs[0]
            .tag_events
            .iter()
            .filter(|e| !e.accepted)
            .cloned()
            .collect(),
    });
    let exceeding = req.map(|_| {
        per_run
            .iter()
            .filter(|r| r.time_to_exceed_requirement_s.is_some())
            .count() as u64
    });
    Summary {
        name: scn.name().to_string(),
        mode: scn.navigator().mode.as_str().into(),
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
        runs_exceeding_requirement: exceeding,
        profile,
        nees,
        tags,
        map_matching: MapMatchingSummary::of(runs),
        updates_run0: runs.first().and_then(|r| r.counts),
        odometer_faults: runs
            .first()
            .map_or_else(Vec::new, |r| odometer_faults(scn, &r.rows)),
        odometer_calibration: CalibrationSummary::of(runs),
    }
}
