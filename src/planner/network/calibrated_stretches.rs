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

use super::settings::map_route;
use super::trips::sample_chains;
use super::types::{NetworkPlan, StretchFigures, StretchValidation};
use super::validation::{
    drive, open_dem, share_rule, sub_route_pieces, thin_rows, BudgetProfile, MAX_STRETCHES,
    MIN_RUNS_PER_WALK, STRETCH_SEARCH_CHAINS, VALIDATION_CHAIN_S,
};
use crate::error::{Error, Result};
use crate::network::Network;
use crate::route::{plan_route_points, route_from_pieces};
use crate::scenario::Scenario;
use crate::sim::{simulate_with, TruthSource};
use crate::trajectory::SpeedProfile;
use std::collections::HashSet;
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
    found.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut seen = HashSet::new();
    found.retain(|&(_, ci, [_, over, _])| {
        let d = routes[ci].span_at(over).section;
        seen.insert((d.section, d.forward))
    });
    found.truncate(MAX_STRETCHES);
    let (_, _, height_m) = map_route(scn)?;
    let dem = open_dem(scn)?;
    let profile = SpeedProfile {
        speed_mps: scn.planner().vehicle_speed_mps,
        ..Default::default()
    };
    let req = plan.requirement_m;
    let conf = scn.planner().requirement_confidence;
    let n = found.len();
    let per = runs.div_ceil(n as u64).max(MIN_RUNS_PER_WALK);
    let existing: HashSet<&str> = plan
        .tags
        .iter()
        .filter(|t| t.existing)
        .map(|t| t.tag_id.as_str())
        .collect();
    let mut figures = [StretchFigures::default(), StretchFigures::default()];
    let mut counts = [(0usize, 0usize); 2];
    let (mut peaks, mut lead_in) = ((f64::INFINITY, 0.0f64), 0.0f64);
    for (si, &(peak, ci, [reset, over, end])) in found.iter().enumerate() {
        peaks = (peaks.0.min(peak), peaks.1.max(peak));
        lead_in = lead_in.max(reset);
        let pieces = sub_route_pieces(&routes[ci], 0.0, end);
        let route = route_from_pieces(net, &pieces)?;
        let start = route.vertices.first().map_or([0.0, 0.0], |v| v.lat_lon);
        let located = scn.located_at(start);
        let (rp, dirs) = drive(net, &route, &profile, height_m, scn.dt, dem.as_ref())?;
        let all = plan.sim_tags(Some(&dirs));
        let truth = TruthSource::from_route(Arc::clone(net), route, rp);
        let to_chainage = truth.route().map_or(1.0, |r| r.length_m)
            / truth
                .samples()
                .last()
                .map_or(1.0, |x| x.distance_m.max(1.0));
        for (k, f) in figures.iter_mut().enumerate() {
            let tags: Vec<_> = if k == 0 {
                all.clone()
            } else {
                all.iter()
                    .filter(|t| existing.contains(t.id.as_str()))
                    .cloned()
                    .collect()
            };
            let res = simulate_with(
                &located,
                &truth,
                &tags,
                per,
                seed.wrapping_add(0x6361_6c69 + 1000 * si as u64),
                None,
            )?;
            for r in &res.runs {
                let rows: Vec<_> = r
                    .rows
                    .iter()
                    .filter(|row| row.distance_m * to_chainage >= over)
                    .collect();
                let (n_thin, n_within, m) = thin_rows(&rows, req).map_err(|t| {
                    Error::scenario(
                        &scn.path,
                        format!(
                            "credited stretch {si}, run {}: the navigation error is not finite \
                             at t = {t:.0} s",
                            r.run
                        ),
                    )
                })?;
                counts[k].0 += n_thin;
                counts[k].1 += n_within;
                if m > req {
                    f.runs_exceeding += 1;
                }
                f.max_horizontal_error_m = f.max_horizontal_error_m.max(m);
            }
        }
    }
    for (f, &(n_thin, n_within)) in figures.iter_mut().zip(&counts) {
        let (lower, passed, rule) = share_rule(n_within, n_thin, req, conf);
        f.thinned_samples = n_thin;
        f.thinned_within = n_within;
        f.share_lower_95 = lower;
        f.passed = passed;
        f.rule = rule;
    }
    let [with_tags, without_new_tags] = figures;
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
