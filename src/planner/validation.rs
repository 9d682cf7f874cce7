//! Checks of a route plan: Monte Carlo validation with its tags, and the
//! covariance check that the bound holds with any `k` consecutive tags
//! missed.

use super::budget::{bound95, AllRead, Budget};
use super::plan::{Plan, Validation};
use crate::error::Result;
use crate::scenario::Scenario;
use crate::sim::tags::Mounting;
use crate::sim::{simulate_with, TruthSource};

/// Monte Carlo validation of a plan with its tags (read with the scenario's
/// read probability): fraction of distance within the requirement and the
/// worst point.
pub fn validate_plan(
    scn: &Scenario,
    truth: &TruthSource,
    plan: &Plan,
    runs: u64,
    seed: u64,
) -> Result<Validation> {
    validate_plan_on(scn, truth, plan, &plan.sim_tags(), runs, seed).map(|(v, _)| v)
}

/// [`validate_plan`] with the tags `tags` simulated in place of the plan's
/// own (`waymark plan` passes its tags as written to `tags.csv`, the
/// coordinates installers get, and its installed tags), giving the
/// simulated runs too (`waymark demo` takes its report's runs from them).
pub(crate) fn validate_plan_on(
    scn: &Scenario,
    truth: &TruthSource,
    plan: &Plan,
    tags: &[crate::sim::tags::Tag],
    runs: u64,
    seed: u64,
) -> Result<(Validation, crate::sim::SimResult)> {
    let res = simulate_with(scn, truth, tags, runs.max(1), seed, None)?;
    let v = validation_of(
        &res,
        plan,
        runs.max(1),
        seed,
        scn.planner().requirement_confidence,
    );
    Ok((v, res))
}

/// The validation figures of simulated runs, with the rule of the
/// requirement's confidence `conf` (`planner.requirement_confidence`).
pub(super) fn validation_of(
    res: &crate::sim::SimResult,
    plan: &Plan,
    runs: u64,
    seed: u64,
    conf: f64,
) -> Validation {
    use super::network::{share_rule, THINNING_S};
    let req = plan.requirement_m;
    let (mut n_thin, mut n_within) = (0u64, 0u64);
    for r in &res.runs {
        let mut next = 0.0;
        for row in &r.rows {
            if row.t_s >= next {
                n_thin += 1;
                n_within += u64::from(row.horizontal_m <= req);
                next += THINNING_S;
            }
        }
    }
    let (lower, passed, rule) = share_rule(n_within as usize, n_thin as usize, req, conf);
    let (mut within, mut total) = (0.0, 0.0);
    let mut worst = (0.0f64, 0u64, 0.0, 0.0);
    let mut exceeding = 0u64;
    for r in &res.runs {
        exceeding += u64::from(r.rows.iter().any(|row| row.horizontal_m > req));
        for w in r.rows.windows(2) {
            let dd = (w[1].distance_m - w[0].distance_m).max(0.0);
            total += dd;
            if w[1].horizontal_m <= req {
                within += dd;
            }
        }
        for row in &r.rows {
            if row.horizontal_m > worst.0 {
                worst = (row.horizontal_m, r.run, row.t_s, row.distance_m);
            }
        }
    }
    Validation {
        runs,
        seed,
        fraction_within_requirement: if total > 0.0 { within / total } else { 1.0 },
        max_horizontal_error_m: worst.0,
        worst_run: worst.1,
        worst_t_s: worst.2,
        worst_distance_m: worst.3,
        runs_exceeding_requirement: exceeding,
        requirement_confidence: conf,
        thinned_samples: n_thin,
        thinned_within: n_within,
        share_lower_95: lower,
        passed,
        rule,
    }
}

/// The bound of a filter's horizontal covariance (re-exported helper).
pub fn horizontal_bound95(c: &[[f64; 3]; 3]) -> f64 {
    bound95(c)
}

/// Whether the predicted bound holds along the route with fixes `fixes`
/// all read, and with any `k` consecutive of them missed.
pub fn robust(
    budget: &Budget<'_>,
    fixes: &[(usize, Mounting)],
    k: usize,
    requirement_m: f64,
    every_m: f64,
) -> bool {
    robust_with_progress(budget, fixes, k, requirement_m, every_m, None)
}

/// [`robust`], calling `progress(done, total)` as the windows of missed
/// tags are checked (from worker threads).
pub fn robust_with_progress(
    budget: &Budget<'_>,
    fixes: &[(usize, Mounting)],
    k: usize,
    requirement_m: f64,
    every_m: f64,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> bool {
    robust_early(budget, fixes, k, requirement_m, every_m, progress).0
}

/// [`robust_with_progress`], also giving its all-read pass: the one a
/// route plan of these fixes makes for its profile, its tags' snapshots
/// and its missed-read bound (`Budget::all_read_gridded` with profile
/// points every `every_m`, snapshots at the fixes and the
/// `MISSED_GRID_M` grid), so that the plan reuses it (one filter pass
/// less on the paper's drive), and, when the check passes with `k > 0`,
/// the largest bound of the windows of `k` missed fixes
/// ([`Budget::missed_worst`], the missed-read bound's own, stopped above
/// the requirement: the same check, and the plan reuses it).
pub(crate) fn robust_all_read(
    budget: &Budget<'_>,
    fixes: &[(usize, Mounting)],
    k: usize,
    requirement_m: f64,
    every_m: f64,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> (bool, AllRead, Option<f64>) {
    let at: Vec<f64> = fixes
        .iter()
        .map(|&(i, _)| budget.samples()[i].avp.distance_m)
        .collect();
    let all = budget.all_read_gridded(fixes, every_m, &at, super::record::MISSED_GRID_M);
    if all.profile.iter().map(|p| p.bound95_m).fold(0.0, f64::max) > requirement_m {
        return (false, all, None);
    }
    if k == 0 || fixes.is_empty() {
        return (true, all, None);
    }
    if all.sites.len() != fixes.len() {
        return (false, all, None);
    }
    let worst = budget.missed_worst(&all, k, requirement_m);
    if let Some(p) = progress {
        p(1, 1);
    }
    let ok = worst <= requirement_m;
    (ok, all, ok.then_some(worst))
}

/// [`robust_with_progress`] with its all-read pass.
fn robust_early(
    budget: &Budget<'_>,
    fixes: &[(usize, Mounting)],
    k: usize,
    requirement_m: f64,
    every_m: f64,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> (bool, AllRead) {
    use rayon::prelude::*;
    // One all-read pass: its worst bound and, for the missed-tag windows,
    // the filter just before each tag and the covariance just after.
    let at: Vec<f64> = fixes
        .iter()
        .map(|&(i, _)| budget.samples()[i].avp.distance_m)
        .collect();
    let all = budget.all_read_gridded(fixes, every_m, &at, super::record::MISSED_GRID_M);
    if all.profile.iter().map(|p| p.bound95_m).fold(0.0, f64::max) > requirement_m {
        return (false, all);
    }
    if k == 0 || fixes.is_empty() {
        return (true, all);
    }
    let n = fixes.len();
    if all.sites.len() != n {
        return (false, all);
    }
    let drops: Vec<usize> = (0..n.saturating_sub(k - 1).max(1)).collect();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let ok = drops.par_iter().all(|&d| {
        let n_done = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if let Some(p) = progress {
            p(n_done, drops.len());
        }
        // Each window stops once its filter has provably settled back
        // within the requirement (Budget::worst_bound_settled).
        budget.worst_bound_settled(
            fixes[d].0,
            all.sites[d].filter.clone(),
            &all,
            d + k,
            requirement_m,
            requirement_m,
        ) <= requirement_m
    });
    (ok, all)
}
