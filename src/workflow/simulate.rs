//! `waymark simulate`: Monte Carlo runs of a scenario, written to a folder.

use super::inputs::{
    check_inputs_outside_outputs, check_out_dir, clear_outputs, keep_inputs, scenario_inputs,
    SIMULATION_OUTPUTS,
};
use super::progress::Progress;
use crate::error::{Error, Result};
use crate::scenario::Scenario;
use crate::sim::tags::{load_tags_csv, refuse_ids_of_scenario_tags, Tag};
use crate::sim::{output, simulate_with, SimResult, TruthSource};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What `waymark simulate` writes beside [`SIMULATION_OUTPUTS`]: the
/// example runs and the record of its inputs (an input must not be one).
const SIMULATION_EXTRA_OUTPUTS: [&str; 5] = [
    "errors_median_run.csv",
    "tag_passes_median_run.csv",
    "errors_worst_run.csv",
    "tag_passes_worst_run.csv",
    "inputs.json",
];

/// What to simulate and where to write it.
#[derive(Debug, Clone, Copy)]
pub struct SimulateJob<'a> {
    /// The scenario file.
    pub scenario: &'a Path,
    /// Extra tags (a tags CSV), for the integrated navigator.
    pub tags: Option<&'a Path>,
    /// Monte Carlo runs (at least 1).
    pub runs: u64,
    /// Base seed (default: the scenario's).
    pub seed: Option<u64>,
    /// The output folder (created if missing).
    pub out_dir: &'a Path,
}

/// What `simulate_folder` did.
#[derive(Debug, Clone)]
pub struct SimulateOutcome {
    /// The runs and their summary.
    pub result: SimResult,
    /// The folder written.
    pub out: PathBuf,
    /// The files written in it.
    pub files: Vec<&'static str>,
    /// Whole job time (s).
    pub elapsed_s: f64,
    /// The planner's validation rule on these runs, as `summary.json`'s
    /// `requirement_rule` records it (`None` without a requirement).
    pub requirement_rule: Option<serde_json::Value>,
    /// What the user should know about the scenario as run (not errors).
    pub notes: Vec<String>,
}

/// Notes on a scenario as simulated: an IMU without error terms under a
/// navigator that reads it (the errors shown then come from the other
/// sensors alone, which a scenario written without `[imu]` may not mean).
pub fn scenario_notes(scn: &Scenario) -> Vec<String> {
    use crate::scenario::NavMode;
    let mut notes = Vec::new();
    let reads_imu = scn.navigator().mode != NavMode::DeadReckoning3d;
    if reads_imu
        && scn.imu.is_error_free()
        && scn.gyro_bias_random() == 0.0
        && scn.accel_bias_random() == 0.0
    {
        notes.push(format!(
            "{}: [imu] has no error terms (no grade, no error fields), so the inertial sensors are perfect \
             and the errors come from the other terms alone; for a real IMU set [imu] grade = \"tactical\" \
             (or navigation, industrial, mems)",
            scn.path.display()
        ));
    }
    notes
}

/// Simulates `job.runs` runs of the scenario and writes `errors.csv`,
/// `summary.json`, `tag_passes.csv` (integrated navigator) and the inputs
/// `waymark report` needs.
pub fn simulate_folder(job: &SimulateJob, progress: &dyn Progress) -> Result<SimulateOutcome> {
    let t0 = Instant::now();
    if job.runs == 0 {
        return Err(Error::InvalidParameter("--runs must be at least 1".into()));
    }
    let scn = Scenario::load(job.scenario)?;
    check_out_dir(job.out_dir)?;
    let mut inputs = scenario_inputs(&scn);
    if let Some(t) = job.tags {
        inputs.push((t.to_path_buf(), "--tags"));
    }
    check_inputs_outside_outputs(
        job.out_dir,
        &[SIMULATION_OUTPUTS, &SIMULATION_EXTRA_OUTPUTS].concat(),
        &inputs,
    )?;
    let truth = TruthSource::new(&scn)?;
    simulate_loaded(job, &scn, &truth, progress, t0)
}

/// [`simulate_folder`] on a loaded scenario and truth.
pub(super) fn simulate_loaded(
    job: &SimulateJob,
    scn: &Scenario,
    truth: &TruthSource,
    progress: &dyn Progress,
    t0: Instant,
) -> Result<SimulateOutcome> {
    let seed = job.seed.unwrap_or(scn.seed());
    let extra: Vec<Tag> = match job.tags {
        Some(p) => load_tags_csv(p)?,
        None => vec![],
    };
    if let Some(p) = job.tags {
        refuse_ids_of_scenario_tags(p, &extra, scn)?;
    }
    if job.runs > 1 {
        progress.start("runs", job.runs);
    }
    let done = std::sync::atomic::AtomicU64::new(0);
    let tick = || {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if job.runs > 1 {
            progress.set(n, job.runs);
        }
    };
    let result = simulate_with(scn, truth, &extra, job.runs, seed, Some(&tick))?;
    if job.runs > 1 {
        progress.finish();
    }
    write_simulation(job, scn, result, t0)
}

/// The first `n` runs of `result` (of seed `seed`) with their own summary:
/// what a simulation of `n` runs with the same seed, scenario and tags
/// gives (each run depends on the base seed and its index only).
pub(super) fn first_runs(scn: &Scenario, seed: u64, mut result: SimResult, n: u64) -> SimResult {
    result.runs.retain(|r| r.run < n);
    let summary = crate::sim::metrics::summarize(scn, seed, &result.runs);
    SimResult {
        runs: result.runs,
        summary,
    }
}

/// Writes the simulation folder of `result` (simulated for `job`): the
/// files [`simulate_folder`] writes.
pub(super) fn write_simulation(
    job: &SimulateJob,
    scn: &Scenario,
    result: SimResult,
    t0: Instant,
) -> Result<SimulateOutcome> {
    clear_outputs(job.out_dir, SIMULATION_OUTPUTS)?;
    output::write(job.out_dir, &result)?;
    let rule = requirement_rule(&result, scn.planner().requirement_confidence);
    if let Some(rule) = &rule {
        // summary.json again, with the rule the report's verdict applies.
        let mut v = serde_json::to_value(&result.summary)
            .map_err(|e| Error::InvalidParameter(format!("summary: {e}")))?;
        v["requirement_rule"] = rule.clone();
        let path = job.out_dir.join("summary.json");
        let json = serde_json::to_string_pretty(&v)
            .map_err(|e| Error::InvalidParameter(format!("summary: {e}")))?;
        crate::fsio::write_atomic(&path, json.as_bytes())?;
    }
    keep_inputs(job.scenario, job.out_dir, job.tags)?;
    let mut files = vec!["errors.csv", "summary.json", "scenario.toml", "inputs.json"];
    files.extend(write_example_runs(job.out_dir, &result)?);
    if result.summary.updates_run0.is_some() {
        files.push("tag_passes.csv");
    }
    if result
        .runs
        .first()
        .is_some_and(|r| !r.calibration_rows.is_empty())
    {
        files.push("calibration.csv");
    }
    Ok(SimulateOutcome {
        result,
        out: job.out_dir.to_path_buf(),
        files,
        elapsed_s: t0.elapsed().as_secs_f64(),
        requirement_rule: rule,
        notes: scenario_notes(scn),
    })
}

/// The planner's validation rule applied to the simulated runs
/// (`summary.json`'s `requirement_rule`): one horizontal error sample per
/// [`THINNING_S`](crate::planner::network::THINNING_S) per run, as the
/// route validation takes them, and the one-sided 95 % Clopper–Pearson
/// lower bound of the share within the requirement against the
/// requirement's confidence `conf`. `None` without a requirement.
pub(super) fn requirement_rule(result: &SimResult, conf: f64) -> Option<serde_json::Value> {
    use crate::planner::network::{share_rule, THINNING_S};
    let req = result.summary.requirement_m?;
    let (mut n, mut within) = (0usize, 0usize);
    for r in &result.runs {
        let mut next = 0.0;
        for row in &r.rows {
            if row.t_s >= next {
                n += 1;
                within += usize::from(row.horizontal_m <= req);
                next += THINNING_S;
            }
        }
    }
    let (lower, passed, rule) = share_rule(within, n, req, conf);
    Some(serde_json::json!({
        "requirement_confidence": conf,
        "thinning_s": THINNING_S,
        "thinned_samples": n,
        "thinned_within": within,
        "share_lower_95": lower,
        "passed": passed,
        "rule": rule,
    }))
}

/// With several runs, the runs the report plots: the median run by maximum
/// horizontal error and the worst (`errors_median_run.csv`,
/// `tag_passes_median_run.csv`, `errors_worst_run.csv`,
/// `tag_passes_worst_run.csv`; see [`crate::report::example_runs`]).
/// With one run, any such files of an earlier run are removed.
fn write_example_runs(dir: &Path, result: &SimResult) -> Result<Vec<&'static str>> {
    use crate::fsio::write_atomic;
    use crate::report::{example_files, example_runs};
    let maxima: Vec<(u64, f64)> = result
        .summary
        .per_run
        .iter()
        .map(|r| (r.run, r.max_horizontal_error_m))
        .collect();
    let mut files = Vec::new();
    for (which, names) in [
        (
            "median",
            ["errors_median_run.csv", "tag_passes_median_run.csv"],
        ),
        (
            "worst",
            ["errors_worst_run.csv", "tag_passes_worst_run.csv"],
        ),
    ] {
        let (e, p) = example_files(which);
        debug_assert_eq!([e.as_str(), p.as_str()], names);
        let pick = example_runs(&maxima)
            .filter(|_| result.runs.len() > 1)
            .map(|(m, w)| if which == "median" { m.0 } else { w.0 });
        let run = pick.and_then(|k| result.runs.iter().find(|r| r.run == k));
        match run {
            Some(r) => {
                write_atomic(&dir.join(&e), output::errors_csv(&r.rows).as_bytes())?;
                files.push(names[0]);
                if r.counts.is_some() {
                    write_atomic(
                        &dir.join(&p),
                        output::tag_passes_csv(&r.tag_passes).as_bytes(),
                    )?;
                    files.push(names[1]);
                }
            }
            None => {
                for f in [&e, &p] {
                    let path = dir.join(f);
                    if path.exists() {
                        std::fs::remove_file(&path).map_err(|err| Error::io(&path, err))?;
                    }
                }
            }
        }
    }
    Ok(files)
}
