//! Chain beginnings in the planning sample of a two-level `trips` plan
//! (`planner.cold_starts`).
//!
//! With two reach levels ([`super::traffic::EdgeModel::with_levels`]) a
//! chain is budgeted at the early reach until its calibration point
//! ([`super::traffic::calibration_point`]) and at the longer calibrated
//! reach after. Every chain begins uncalibrated, so
//! its first kilometres ask more of the tags than the same roads driven
//! later; and they lie anywhere traffic can start. The planning chains are
//! whole shifts, so they bring only `planning_chains` beginnings (64 by
//! default), while every fresh chain of a certification round brings its
//! own: on Gothenburg's trips plan every violation of the certification
//! rounds was a stretch before its chain's calibration point, and the plan
//! needed all six rounds. The straight walks cannot stand in for them: they
//! run at the calibrated reach, and walks at the early reach from every
//! road would budget the whole map at the single reach again.
//!
//! So the planning sample also gets `n` chain beginnings: chains of at most
//! [`COLD_START_S`] drawn exactly as the shifts are (a destination, then
//! trips), from their own random stream; each adds the windows of its
//! stretches that start before its calibration point. They are samples of
//! the same traffic, so the certification's statement is unchanged: it is
//! made on fresh chains the plan never saw, whatever chose the tags.
//! The coverage map shows what the beginnings' early stretches consume
//! ([`EarlyBudgets`]).
//! Measured in BENCHMARKS.md ("Chain beginnings in the planning sample").

use super::coverage::EarlyBudgets;
use super::traffic::{add_windows_before, chain_budget, sample_chains_in};
use super::traffic::{Destinations, EdgeModel};
use super::window_sets::WindowMap;
use crate::error::Result;
use crate::network::Network;
use rayon::prelude::*;

/// Driving time of a chain beginning (s): half an hour, 25 km at 50 km/h.
/// On Gothenburg's trips plan (seed 2, 1,024 beginnings) the 28
/// certification violations of six rounds started 0–10.4 km into their
/// chains and ended by 14.6 km.
pub const COLD_START_S: f64 = 1800.0;

/// Chain beginnings per fresh chain of the first certification round, the
/// default of `planner.cold_starts` (3,696 at ε = β = 0.01): the early
/// risk the planning sample leaves should lie well below the 2 violations
/// in 924 chains that round allows, and that round's size scales as 1/ε.
/// On Gothenburg's trips plan (3 seeds) 1,024 beginnings left rounds 3–6,
/// 4,096 round 1 with 2 violations and 8,192 round 1 with 1, at 62–71 and
/// 72–77 tags against 70–74 without (BENCHMARKS.md).
pub const COLD_STARTS_PER_CHAIN: usize = 4;

/// The random stream of the chain beginnings ("cold").
const COLD_STREAM: u64 = 0x636f_6c64_0000;

/// Beginnings drawn and budgeted at a time.
const COLD_BATCH: usize = 1024;

/// What the chain beginnings added to the planning sample.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct ColdStarts {
    /// Beginnings drawn.
    pub drawn: usize,
    /// Of which with a stretch before calibration over the budget without
    /// tags (the share of chains that need tags early).
    pub over_budget: usize,
}

/// Draws `n` chain beginnings (chains of at most [`COLD_START_S`], or the
/// shift `shift_s` if shorter) and adds to `out` the windows of each one's
/// stretches that start before its calibration point, and their budgets to
/// `budgets` (for the coverage map). Deterministic in `seed`; the windows are
/// added in the beginnings' order.
#[allow(clippy::too_many_arguments)]
pub(crate) fn add_cold_start_windows(
    net: &Network,
    model: &EdgeModel,
    dest: &Destinations,
    shift_s: f64,
    seed: u64,
    n: usize,
    out: &mut WindowMap,
    budgets: &mut EarlyBudgets,
) -> Result<ColdStarts> {
    let mut stats = ColdStarts {
        drawn: n,
        over_budget: 0,
    };
    // In batches: a beginning's budget holds a few thousand entries, and
    // the windows are what is kept.
    for first in (0..n).step_by(COLD_BATCH) {
        let chains = sample_chains_in(
            net,
            model,
            dest,
            shift_s.min(COLD_START_S),
            seed,
            COLD_STREAM,
            first..(first + COLD_BATCH).min(n),
        )?;
        let early: Vec<_> = chains
            .par_iter()
            .map(|c| {
                let cb = chain_budget(model, c, true);
                let over = cb
                    .resets
                    .windows(2)
                    .any(|w| w[0].1 < cb.calibrated_at && w[1].0 - w[0].0 > 1.0);
                (cb, over)
            })
            .collect();
        for (cb, over) in &early {
            if out.full() {
                return Ok(stats);
            }
            stats.over_budget += usize::from(*over);
            add_windows_before(cb, cb.calibrated_at, false, out);
            budgets.add(cb, *over);
        }
    }
    Ok(stats)
}
