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

use super::stretches::{search_stretches, Found, StretchTest};
use super::types::{NetworkPlan, StretchValidation};
use super::validation::BudgetProfile;
use crate::error::Result;
use crate::network::Network;
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
    let (found, routes) = search_stretches(scn, net, plan, seed, 0x6361_6c69_6272, |route| {
        let single = BudgetProfile::new(&one, route, true);
        let two = BudgetProfile::new(&cm.model, route, true);
        // The resets do not depend on the rates: the same stretch in both
        // views, ending (just before its next reset) within 1.
        single
            .over_budget()
            .into_iter()
            .filter(|(c, _)| {
                let end = (c[2] - 0.5).max(c[0]);
                c[2] <= CREDITED_MAX_DRIVE_M && two.since_reset(end) <= 1.0
            })
            .collect()
    })?;
    let test = StretchTest {
        stream: 0x6361_6c69,
        what: "credited stretch",
        lead_in_m: |f: &[Found]| f.iter().fold(0.0f64, |l, s| l.max(s.2[0])),
        span: |c: &[f64; 3]| (0.0, c[2]),
    };
    test.run(scn, net, plan, found, &routes, runs, seed)
}
