//! `plan --baseline` on a trips plan with two reach levels: the stretches
//! the calibrated level credits, driven from their chain's start.
//!
//! With two levels ([`super::traffic::calibration_point`]) a calibrated
//! chain budgets a stretch at its class's calibrated reach, several times
//! the single reach, and the plan has no tags on stretches the single
//! reach would have needed them on. This test drives exactly those: on
//! fresh chains of the plan's traffic, the stretches whose budget at the
//! single reach passes 1 but whose budget at the two levels does not (the
//! longest first, one per directed section), each driven from **its chain's
//! start** (so that the simulated navigator calibrates, or not, on the
//! chain's own turns, from the scenario's prior), with the plan's tags and
//! without the new ones. Error samples are taken from where the single
//! reach's budget passes 1 to the stretch's end (one per
//! [`THINNING_S`](super::validation::THINNING_S) and each run's last row)
//! and judged by the validation's rule (`share_rule`).

use super::stretches::{drive_stretches, pick_stretches, StretchDrive, STRETCH_SEARCH_CHAINS};
use super::trips::sample_chains;
use super::types::{NetworkPlan, StretchValidation};
use super::validation::{BudgetProfile, MIN_RUNS_PER_WALK, VALIDATION_CHAIN_S};
use crate::error::Result;
use crate::network::Network;
use crate::route::plan_route_points;
use crate::scenario::Scenario;
use std::sync::Arc;

/// Most chainage from a chain's start to a credited stretch's end (m): the
/// drive from the start is the test's cost.
pub const CREDITED_MAX_DRIVE_M: f64 = 20_000.0;

/// The credited stretches' test (module doc); `None` unless the plan has
/// two reach levels and some searched chain has such a stretch within
/// [`CREDITED_MAX_DRIVE_M`] of its start. `peak_budget_min` and
/// `peak_budget_max` are the stretches' budgets at the single reach;
/// `lead_in_m` is the longest drive from a chain's start to a stretch's
/// resetting turn.
pub(super) fn validate_credited_stretches(
    scn: &Scenario,
    net: &Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
) -> Result<Option<StretchValidation>> {
    let Some(cm) = plan.chain_model.as_ref() else {
        return Ok(None);
    };
    if plan.reach_levels != 2 || !plan.map_matching {
        return Ok(None);
    }
    let one = cm.model.one_level();
    let shift = scn.planner().shift_s.min(VALIDATION_CHAIN_S);
    let chains = sample_chains(
        net,
        &cm.model,
        &cm.dest,
        shift,
        seed,
        0x6361_6c69_6272,
        STRETCH_SEARCH_CHAINS,
    )?;
    // (budget at the single reach, chain, [reset, over, next reset]).
    let mut found: Vec<(f64, usize, [f64; 3])> = Vec::new();
    let mut routes = Vec::with_capacity(chains.len());
    for (ci, chain) in chains.iter().enumerate() {
        let route = plan_route_points(net, &chain.points)?;
        let single = BudgetProfile::new(&one, &route, true);
        let two = BudgetProfile::new(&cm.model, &route, true);
        for (c, u) in single.over_budget() {
            // The resets do not depend on the rates: the same stretch in
            // both views, ending (just before its next reset) within 1.
            let end = (c[2] - 0.5).max(c[0]);
            if c[2] <= CREDITED_MAX_DRIVE_M && two.since_reset(end) <= 1.0 {
                found.push((u, ci, c));
            }
        }
        routes.push(route);
    }
    if found.is_empty() {
        return Ok(None);
    }
    pick_stretches(&mut found, &routes);
    let n = found.len();
    let per = runs.div_ceil(n as u64).max(MIN_RUNS_PER_WALK);
    let peaks = found
        .iter()
        .fold((f64::INFINITY, 0.0f64), |p, s| (p.0.min(s.0), p.1.max(s.0)));
    let lead_in = found.iter().fold(0.0f64, |l, s| l.max(s.2[0]));
    let drives: Vec<_> = found
        .iter()
        .map(|&(_, ci, [_, over, end])| StretchDrive {
            route: &routes[ci],
            from: 0.0,
            to: end,
            over,
        })
        .collect();
    let [with_tags, without_new_tags] = drive_stretches(
        scn,
        net,
        plan,
        &drives,
        per,
        seed,
        0x6361_6c69,
        "credited stretch",
    )?;
    Ok(Some(StretchValidation {
        searched_chains: chains.len(),
        stretches: n,
        runs_per_stretch: per,
        lead_in_m: lead_in,
        peak_budget_min: peaks.0,
        peak_budget_max: peaks.1,
        with_tags,
        without_new_tags,
    }))
}
