//! The Monte Carlo validation of a network plan: the fresh chains' drives
//! (`super::validation`) and, with `--baseline`, the over-budget
//! stretches (`super::stretches`) and, on a two-level trips plan, the
//! stretches the calibrated level credits (`super::calibrated_stretches`).

use super::calibrated_stretches::validate_credited_stretches;
use super::stretches::validate_stretches;
use super::types::{NetworkPlan, NetworkValidation};
use super::validation::validate_chains;
use crate::error::Result;
use crate::network::Network;
use crate::scenario::Scenario;

/// Monte Carlo validation over `runs` runs on fresh chains of trips
/// (`super::validation`'s module doc). With `baseline`, the same chains,
/// runs and seeds are driven again with only the installed tags (none in a
/// fresh plan), so the report can show what the planned tags buy over map
/// matching alone ([`NetworkValidation::without_new_tags`]), and the
/// stretches the plan's budget marks are driven on their own
/// ([`NetworkValidation::over_budget_stretches`],
/// [`NetworkValidation::credited_stretches`]).
pub fn validate_network_plan(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
    baseline: bool,
) -> Result<NetworkValidation> {
    let mut v = validate_chains(scn, net, plan, runs, seed, baseline)?;
    if baseline {
        v.over_budget_stretches = validate_stretches(scn, net, plan, runs, seed)?;
        v.credited_stretches = validate_credited_stretches(scn, net, plan, runs, seed)?;
    }
    Ok(v)
}
