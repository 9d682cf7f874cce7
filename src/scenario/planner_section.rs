//! `[planner]`: the planner's section of a scenario, checked and with
//! every default applied (split from `validate.rs`, which calls it).

use super::check::{short_number, Check};
use super::schema::*;
use super::sections::*;
use crate::error::Result;
use crate::tags::Mounting;
use std::path::Path;

/// Largest `planner.cost.<mounting>`: 1e9 per tag, so that the total of
/// the most tags a plan may place stays far from overflow.
pub const MAX_MOUNTING_COST: f64 = 1e9;

/// Most `planner.cold_starts`: each is at most half an hour of routed
/// trips, a sixteenth of an 8 h planning chain (the default at the most
/// demanding ε and β accepted is about 4 × 25,000).
pub const MAX_COLD_STARTS: usize = 200_000;

/// `[planner]` (or its absence), checked, with every default applied.
pub(super) fn planner(
    c: &Check,
    path: &Path,
    p: PlannerSection,
    vehicle: &VehicleSection,
) -> Result<PlannerOptions> {
    let coverage = p.coverage.unwrap_or_default();
    let vehicle_speed_kmh = c.range(
        "vehicle.speed_kmh",
        vehicle.speed_kmh.unwrap_or(50.0),
        1.0,
        300.0,
    )?;
    let shift_hours = p.shift_hours.unwrap_or(8.0);
    if !(shift_hours.is_finite() && shift_hours > 0.0 && shift_hours <= 168.0) {
        return Err(c.err(format!(
            "planner.shift_hours = {} must be > 0 and at most 168 (a week)",
            short_number(shift_hours)
        )));
    }
    let open_unit = |name: &str, x: f64| -> Result<f64> {
        if x.is_finite() && x > 0.0 && x < 1.0 {
            Ok(x)
        } else {
            Err(c.err(format!(
                "planner.{name} = {} must lie strictly between 0 and 1",
                short_number(x)
            )))
        }
    };
    let violation_probability = open_unit(
        "violation_probability",
        p.violation_probability.unwrap_or(0.01),
    )?;
    let confidence = open_unit("confidence", p.confidence.unwrap_or(0.99))?;
    let requirement_confidence = open_unit(
        "requirement_confidence",
        p.requirement_confidence.unwrap_or(0.95),
    )?;
    if requirement_confidence < 0.5 {
        return Err(c.err(format!(
            "planner.requirement_confidence = {} must be at least 0.5",
            short_number(requirement_confidence)
        )));
    }
    let planning_chains = p.planning_chains.unwrap_or(64) as usize;
    if !(1..=5_000).contains(&planning_chains) {
        return Err(c.err(format!(
            "planner.planning_chains = {planning_chains} must be between 1 and 5000"
        )));
    }
    let cold_starts = p.cold_starts.map(|n| n as usize);
    if let Some(n) = cold_starts.filter(|&n| n > MAX_COLD_STARTS) {
        return Err(c.err(format!(
            "planner.cold_starts = {n} must be at most {MAX_COLD_STARTS}"
        )));
    }
    // The certification's last round needs ln(β/2⁶) / ln(1 − ε) chains
    // without failures, and at most twice that when it allows two (the
    // planner's `chains_allowing`: 1.5–1.8× at ε = 0.01).
    // ln(1 − ε) as ln_1p(−ε): below ε ≈ 1e-16, 1 − ε rounds to 1, and the
    // quotient was −∞, which passed this check (ε = 1e-300 was taken).
    let last_round = 2.0 * ((1.0 - confidence) / 64.0).ln() / (-violation_probability).ln_1p();
    if last_round > 50_000.0 {
        return Err(c.err(format!(
            "planner.violation_probability = {} with confidence = {} needs up to {} fresh \
             chains to certify (limit 50000): allow a larger violation probability",
            short_number(violation_probability),
            short_number(confidence),
            short_number(last_round.round())
        )));
    }
    let validation_chains = p.validation_chains.unwrap_or(20) as usize;
    if !(1..=10_000).contains(&validation_chains) {
        return Err(c.err(format!(
            "planner.validation_chains = {validation_chains} must be between 1 and 10000"
        )));
    }
    let traffic = p.traffic.unwrap_or_default();
    if coverage != Coverage::Network
        && (p.traffic.is_some() || p.destinations.is_some() || p.shift_hours.is_some())
    {
        return Err(c.err(
            "planner.traffic, destinations and shift_hours apply to coverage = \"network\" only",
        ));
    }
    if traffic != Traffic::Trips && p.destinations.is_some() {
        return Err(c.err("planner.destinations applies to traffic = \"trips\" only"));
    }
    let reach_levels = p.reach_levels.unwrap_or(2);
    if !(1..=2).contains(&reach_levels) {
        return Err(c.err(format!(
            "planner.reach_levels = {reach_levels} must be 1 (the single reach) or 2 (early, then \
             calibrated)"
        )));
    }
    if (coverage != Coverage::Network || traffic != Traffic::Trips) && p.reach_levels.is_some() {
        return Err(c.err(
            "planner.reach_levels applies to coverage = \"network\" with traffic = \"trips\" only",
        ));
    }
    for (name, given) in [
        ("cold_starts", p.cold_starts.is_some()),
        ("discarded_beginnings", p.discarded_beginnings.is_some()),
    ] {
        if (coverage != Coverage::Network || traffic != Traffic::Trips || reach_levels != 2)
            && given
        {
            return Err(c.err(format!(
                "planner.{name} applies to coverage = \"network\" with traffic = \"trips\" and \
                 reach_levels = 2 only"
            )));
        }
    }
    let discarded_beginnings = p.discarded_beginnings.map(|n| n as usize);
    if let Some(n) = discarded_beginnings.filter(|&n| n > cold_starts.unwrap_or(MAX_COLD_STARTS)) {
        return Err(c.err(format!(
            "planner.discarded_beginnings = {n} must be at most the chain beginnings drawn \
             (planner.cold_starts = {})",
            cold_starts.unwrap_or(MAX_COLD_STARTS)
        )));
    }
    let names = p.mountings.unwrap_or_else(|| Mounting::ALL.to_vec());
    if names.is_empty() {
        return Err(c.err("planner.mountings is empty"));
    }
    let mut mountings = Vec::with_capacity(names.len());
    for m in names {
        let cost = match p.cost.as_ref().and_then(|c| c.get(&m)) {
            Some(&x) if !(x.is_finite() && x >= 0.0) => {
                return Err(c.err(format!(
                    "planner.cost.{m} = {} must be ≥ 0",
                    short_number(x)
                )))
            }
            // A relative cost or a price per tag; beyond this a plan's total
            // (up to the candidate limit's tags) would overflow, and its
            // check blamed the covariance analysis.
            Some(&x) if x > MAX_MOUNTING_COST => {
                return Err(c.err(format!(
                    "planner.cost.{m} = {} is above the limit of {MAX_MOUNTING_COST:e} \
                     (a relative cost, or a price per tag)",
                    short_number(x)
                )))
            }
            Some(&x) => x,
            None => default_mounting_cost(m),
        };
        mountings.push(MountingChoice { mounting: m, cost });
    }
    let candidate_spacing_m = p.candidate_spacing_m.unwrap_or(match coverage {
        Coverage::Routes => DEFAULT_ROUTE_SPACING_M,
        Coverage::Network => DEFAULT_NETWORK_SPACING_M,
    });
    if !(candidate_spacing_m.is_finite() && candidate_spacing_m >= 1.0) {
        return Err(c.err(format!(
            "planner.candidate_spacing_m = {} must be ≥ 1",
            short_number(candidate_spacing_m)
        )));
    }
    let min_spacing_m = p.min_spacing_m.unwrap_or(0.0);
    if !(min_spacing_m.is_finite() && min_spacing_m >= 0.0) {
        return Err(c.err(format!(
            "planner.min_spacing_m = {} must be ≥ 0",
            short_number(min_spacing_m)
        )));
    }
    for z in &p.forbidden_m {
        if !(z[0].is_finite() && z[1].is_finite() && z[0] <= z[1]) {
            return Err(c.err(format!(
                "planner.forbidden_m: [{}, {}] is not a [from, to] pair",
                short_number(z[0]),
                short_number(z[1])
            )));
        }
    }
    let base = path.parent().unwrap_or(Path::new("."));
    Ok(PlannerOptions {
        coverage,
        tolerate_missed_reads: p.tolerate_missed_reads.unwrap_or(1) as usize,
        mountings,
        candidate_spacing_m,
        min_spacing_m,
        forbidden_m: p.forbidden_m,
        validation_runs: p.validation_runs.unwrap_or(100),
        refine_iterations: p.refine_iterations.unwrap_or(0) as usize,
        existing_tags: p.existing_tags.map(|f| base.join(f)),
        u_turns: p.u_turns.unwrap_or_default(),
        traffic,
        reach_levels,
        destinations: p.destinations.map(|f| base.join(f)),
        shift_s: shift_hours * 3600.0,
        violation_probability,
        confidence,
        requirement_confidence,
        planning_chains,
        cold_starts,
        discarded_beginnings,
        validation_chains,
        vehicle_speed_mps: vehicle_speed_kmh / 3.6,
    })
}
