//! Monte Carlo dispatch: checks the scenario's mode against its aiding,
//! prepares the tags once, runs the runs in parallel (integrated or
//! stand-alone runner) and summarizes them.

use super::dead_reckoning::run_once;
use super::integrated::{run_integrated, Prepared};
use super::metrics::{summarize, Summary};
use super::records::RunResult;
use super::tags::Tag;
use super::truth::TruthSource;
use crate::error::Result;
use crate::scenario::{NavMode, Scenario};
use rayon::prelude::*;

/// All runs and their summary.
#[derive(Debug, Clone)]
pub struct SimResult {
    /// Runs in index order.
    pub runs: Vec<RunResult>,
    /// Metrics.
    pub summary: Summary,
}

/// Runs `runs` Monte Carlo runs of a scenario with base seed `seed`.
pub fn simulate(scn: &Scenario, truth: &TruthSource, runs: u64, seed: u64) -> Result<SimResult> {
    simulate_with(scn, truth, &[], runs, seed, None)
}

/// Monte Carlo with extra tags (`--tags`) and a progress callback called
/// after each run (from worker threads).
pub fn simulate_with(
    scn: &Scenario,
    truth: &TruthSource,
    extra_tags: &[Tag],
    runs: u64,
    seed: u64,
    progress: Option<&(dyn Fn() + Sync)>,
) -> Result<SimResult> {
    if runs == 0 {
        return Err(crate::error::Error::InvalidParameter(
            "the number of runs must be at least 1".into(),
        ));
    }
    super::limits::check_simulation_size(scn, truth, runs)?;
    let integrated = scn.navigator().mode == NavMode::Integrated;
    if integrated && scn.rotation.is_some() {
        return Err(crate::error::Error::scenario(
            &scn.path,
            "navigator.mode = \"integrated\" does not support imu.rotation_modulation",
        ));
    }
    if !integrated && scn.aiding().map_matching {
        return Err(crate::error::Error::scenario(
            &scn.path,
            "aiding.map_matching is used only by navigator.mode = \"integrated\"",
        ));
    }
    if !integrated && (!extra_tags.is_empty() || !scn.tags().is_empty()) {
        return Err(crate::error::Error::scenario(
            &scn.path,
            "tags are used only by navigator.mode = \"integrated\"",
        ));
    }
    let prep = if integrated {
        Prepared::new(scn, truth, extra_tags)?
    } else {
        Prepared::default()
    };
    tracing::info!(
        scenario = %scn.name(),
        runs,
        seed,
        tags = prep.tags.len(),
        tag_passes = prep.passes.len(),
        "simulating"
    );
    let t0 = std::time::Instant::now();
    let results: Vec<RunResult> = (0..runs)
        .into_par_iter()
        .map(|run| {
            let r = if integrated {
                run_integrated(scn, truth, &prep, seed, run)
            } else {
                run_once(scn, truth, seed, run)
            };
            tracing::debug!(run, rows = r.rows.len(), "run done");
            if let Some(p) = progress {
                p();
            }
            r
        })
        .collect();
    super::finite::check_runs_finite(scn, &results)?;
    let summary = summarize(scn, seed, &results);
    tracing::info!(
        runs,
        max_horizontal_error_m = summary.max_horizontal_error_m,
        elapsed_ms = t0.elapsed().as_secs_f64() * 1e3,
        "simulation done"
    );
    Ok(SimResult {
        runs: results,
        summary,
    })
}
