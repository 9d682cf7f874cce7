//! Planning for `traffic = "trips"`: tags so that sampled chains of trips
//! hold the error budget (set multicover over the chains' budget windows,
//! the path-cover view of the flow-refuelling models), and the guarantee
//! stated for a fresh chain by an a-posteriori test on chains the plan never
//! saw.
//!
//! The cover: the lazy greedy with reverse deletion ([`multicover`]), then
//! the Lagrangian relaxation from it (`super::lagrangian`), whose selection
//! is kept when it costs less, then add-drop local search on the result
//! (`super::add_drop`); then the windows' linear programme
//! (`super::lp_bound`), whose multipliers price the greedy again (with its
//! own add-drop moves; the cheapest selection wins) and whose bound joins
//! the packing and relaxation bounds; the exact integer programme replaces them all
//! when at most [`EXACT_MAX_SITES`] sites appear and its optimum, when it
//! needs fewer tags, passes a certification round of its own
//! ([`optimum_outcome`]).
//!
//! # The guarantee
//!
//! After planning on `planning_chains` sampled chains (with two reach
//! levels, also on the stretches before calibration of chain beginnings,
//! `super::cold_starts`), `M` fresh chains are
//! drawn independently and checked under the same model. If at most `v`
//! fail, where `M` was chosen beforehand so that the one-sided
//! Clopper–Pearson upper bound after `v` = [`ALLOWED_VIOLATIONS`] failures
//! is ε ([`chains_allowing`]), then with confidence `1 − β` a fresh chain
//! violates with probability at most `ε`: a plan whose violation
//! probability exceeded ε would show at most `v` failures in `M`
//! independent chains with probability below β (the scenario approach's
//! a-posteriori assessment, Campi & Garatti 2008/2018, with no support
//! constraints; it holds whatever chose the tags). If more fail, their
//! windows join the planning set, the plan is extended and a
//! *new* fresh sample is drawn; round `r` uses `β_r = β / 2^r`, so the
//! stopping rule keeps the total error probability within `Σ β_r ≤ β`.
//! After [`MAX_ROUNDS`] rounds the plan reports the failures and the
//! Clopper–Pearson upper bound on the violation probability instead. The
//! exact optimum of small instances is a second selection: it is reported
//! only after passing the next round, `r + 1` at `β_{r+1}`, on chains of
//! its own, a round the stopping rule never draws otherwise.

use super::add_drop::{add_drop, AddDrop};
use super::best_site::BestSite;
pub use super::certification::{
    chains_allowing, chains_needed, clopper_pearson_lower, clopper_pearson_upper,
    ALLOWED_VIOLATIONS,
};
pub(crate) use super::certification::{new_tags, optimum_outcome, Optimum, Round};
use super::cold_starts::{add_cold_start_windows, ColdStarts, COLD_STARTS_PER_CHAIN};
use super::coverage::EarlyBudgets;
use super::discard::{discard, Discarded, DISCARD_SHARE};
use super::dominance::essential_windows;
use super::lagrangian::priced_selection;
use super::lagrangian::{relax, Relaxation};
use super::lp_bound::{lp_duals_within, LpBound, MAX_ITERATIONS as LP_MAX};
use super::straight::straight_windows;
pub(crate) use super::traffic::sample_chains;
use super::traffic::{add_windows, chain_budget, chain_use, ChainBudget};
use super::traffic::{Destinations, EdgeModel};
use super::walk_oracle::{hold_walks, HeldWalks, WalkOracle};
use super::window_sets::{SiteWindows, WindowInfo, WindowMap, WindowSets};
use crate::error::{Error, Result};
use crate::network::Network;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::{BinaryHeap, HashSet};

/// Largest instance (sites in windows) solved exactly.
pub const EXACT_MAX_SITES: usize = 150;

/// Most certification rounds.
pub const MAX_ROUNDS: usize = 6;

/// Most site ids over a plan's distinct budget windows (the planning
/// chains' windows and the straight walks'). The ids are held twice at the
/// peak, 4 bytes each (the windows, and while they are sorted or covered,
/// their sorted copy or each site's windows), with about 40 bytes per
/// window besides; measured in BENCHMARKS.md ("Trips plans on a whole map:
/// the windows' memory"). Beyond it the plan stops with an error naming the
/// scenario rather than running out of memory.
pub const MAX_TRIPS_WINDOW_IDS: usize = 1_000_000_000;

/// What the a-posteriori test established.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TripsGuarantee {
    /// The statement, in words.
    pub statement: String,
    /// ε: the violation probability bounded.
    pub epsilon: f64,
    /// β: 1 − the confidence.
    pub beta: f64,
    /// Chains in the planning sample (the first round's).
    pub planning_chains: usize,
    /// Chain beginnings whose stretches before calibration joined the
    /// planning sample (`planner.cold_starts`; 0 with one reach level).
    pub cold_starts: usize,
    /// Of which with such a stretch over the budget without tags.
    pub cold_starts_over_budget: usize,
    /// Sampled chain beginnings the reported selection leaves over budget
    /// (sampling and discarding, `super::discard`; 0 for a full cover).
    pub beginnings_left_over_budget: usize,
    /// Chains added to the planning set from failed certification rounds.
    pub added_chains: usize,
    /// Fresh chains checked in the final round (`N`).
    pub certification_chains: usize,
    /// Violations a round may find and still certify
    /// ([`ALLOWED_VIOLATIONS`]; `N` was sized for them before the round
    /// was drawn).
    pub allowed_violations: usize,
    /// Of which violating the budget.
    pub violations: usize,
    /// Certification rounds run.
    pub rounds: usize,
    /// The statement holds (the final round had no violation).
    pub holds: bool,
    /// One-sided upper confidence bound (1 − β) on the violation
    /// probability from the final round (Clopper–Pearson).
    pub violation_upper_bound: f64,
    /// Hours of driving per chain.
    pub shift_hours: f64,
    /// The worst chain of the final round: its budget use with the
    /// tolerated reads missed (≤ 1 holds), length and index.
    pub worst_chain_budget: f64,
    /// Length of the worst chain (km).
    pub worst_chain_km: f64,
    /// Index of the worst chain in the final round.
    pub worst_chain: usize,
}

/// Greedy set multicover: every window holds `demand` selected sites at the
/// least total cost (lazy greedy by windows served per cost, then reverse
/// deletion), with the windows' transpose `site_w` over
/// `preselected.len()` sites. `Err(w)`: window `w` has fewer than `demand`
/// candidates.
pub(crate) fn multicover(
    windows: &WindowSets,
    site_w: &SiteWindows,
    demand: usize,
    cost: &[f64],
    preselected: &[bool],
) -> std::result::Result<Vec<bool>, usize> {
    if let Some(w) = windows.iter().position(|ids| ids.len() < demand) {
        return Err(w);
    }
    let n_sites = preselected.len();
    let mut sel = preselected.to_vec();
    let mut count: Vec<usize> = windows
        .iter()
        .map(|ids| ids.iter().filter(|&&s| sel[s as usize]).count())
        .collect();
    let gain = |s: usize, count: &[usize]| -> usize {
        site_w
            .get(s)
            .iter()
            .filter(|&&w| count[w as usize] < demand)
            .count()
    };
    let score = |g: usize, s: usize| g as f64 / cost[s].max(1e-9);
    let mut heap = BinaryHeap::new();
    for (s, &taken) in sel.iter().enumerate() {
        if !taken {
            let g = gain(s, &count);
            if g > 0 {
                heap.push(BestSite {
                    score: score(g, s),
                    site: s,
                    data: g,
                });
            }
        }
    }
    while let Some(BestSite {
        site: s, data: g, ..
    }) = heap.pop()
    {
        let g_now = gain(s, &count);
        if g_now == 0 {
            continue;
        }
        if g_now != g {
            heap.push(BestSite {
                score: score(g_now, s),
                site: s,
                data: g_now,
            });
            continue;
        }
        sel[s] = true;
        for &w in site_w.get(s) {
            count[w as usize] += 1;
        }
    }
    // Reverse deletion: the dearest first, then the least used.
    let mut order: Vec<usize> = (0..n_sites)
        .filter(|&s| sel[s] && !preselected[s])
        .collect();
    order.sort_by(|&a, &b| {
        cost[b]
            .total_cmp(&cost[a])
            .then(site_w.get(a).len().cmp(&site_w.get(b).len()))
            .then(a.cmp(&b))
    });
    site_w.remove_redundant(order, &mut sel, &mut count, demand);
    Ok(sel)
}

/// Exact set multicover by integer programming (`microlp` branch and
/// bound, warm-started by `warm`) when at most `max_vars` sites appear in
/// windows: the optimal selection and its cost, or `None` (too large, or
/// the node budget ran out).
pub(crate) fn exact_multicover(
    n_sites: usize,
    windows: &WindowSets,
    demand: usize,
    cost: &[f64],
    preselected: &[bool],
    warm: &[bool],
    max_vars: usize,
) -> Option<(Vec<bool>, f64)> {
    let mut var_of: Vec<Option<microlp::Variable>> = vec![None; n_sites];
    let mut prob = microlp::Problem::new(microlp::OptimizationDirection::Minimize);
    let mut n_vars = 0;
    for w in windows.iter() {
        for &s in w {
            let s = s as usize;
            if var_of[s].is_none() {
                n_vars += 1;
                if n_vars > max_vars {
                    return None;
                }
                var_of[s] = Some(if preselected[s] {
                    prob.add_var(0.0, (1.0, 1.0))
                } else {
                    prob.add_binary_var(cost[s])
                });
            }
        }
    }
    for w in windows.iter() {
        let expr: Vec<(microlp::Variable, f64)> = w
            .iter()
            .filter_map(|&s| var_of[s as usize].map(|v| (v, 1.0)))
            .collect();
        prob.add_constraint(expr.as_slice(), microlp::ComparisonOp::Ge, demand as f64);
    }
    let mut opts = microlp::SolveOptions::default();
    opts.node_limit = Some(20_000);
    opts.warm_start = Some(
        var_of
            .iter()
            .enumerate()
            .filter_map(|(i, v)| v.map(|v| (v, if warm[i] { 1.0 } else { 0.0 })))
            .collect(),
    );
    match prob.solve_with(opts) {
        Ok(microlp::SolveOutcome::Solution(sol))
            if sol.status() == microlp::SolutionStatus::Optimal =>
        {
            let mut sel = preselected.to_vec();
            for (i, v) in var_of.iter().enumerate() {
                if let Some(v) = v {
                    if sol[*v] > 0.5 {
                        sel[i] = true;
                    }
                }
            }
            Some((sel, sol.objective()))
        }
        _ => None,
    }
}

/// A lower bound on the number of new tags: windows sharing no candidate
/// site each need their own (`demand` minus installed ones).
pub(crate) fn packing_bound(
    windows: &WindowSets,
    demand: usize,
    preselected: &[bool],
    n_sites: usize,
) -> usize {
    let mut order: Vec<usize> = (0..windows.len()).collect();
    order.sort_by(|&a, &b| {
        windows
            .get(a)
            .len()
            .cmp(&windows.get(b).len())
            .then(a.cmp(&b))
    });
    let mut used = vec![false; n_sites];
    let mut lb = 0;
    for w in order {
        let ids = windows.get(w);
        if ids.iter().any(|&s| used[s as usize]) {
            continue;
        }
        let have = ids.iter().filter(|&&s| preselected[s as usize]).count();
        lb += demand.saturating_sub(have);
        for &s in ids {
            used[s as usize] = true;
        }
    }
    lb
}

/// Scales of the linear programme's multipliers that price the greedy: the
/// multipliers themselves and two perturbations (Caprara, Fischetti & Toth
/// 1999 perturb theirs likewise); on Gothenburg's trips plan scale 1 gave
/// 309 tags and 0.99 and 1.01 308 (BENCHMARKS.md, "The lower bound from
/// the linear programme").
const LP_PRICE_SCALES: [f64; 3] = [1.0, 0.99, 1.01];

/// A cover that left sampled beginnings over budget, tested in round 1
/// (`super::discard`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DiscardOutcome {
    /// Tags fewer than the full cover.
    pub removed: usize,
    /// Sampled beginnings it left over budget.
    pub left: usize,
    /// Round 1 certified it (else the full cover was judged on the same
    /// chains).
    pub certified: bool,
}

/// One solve of the planning windows.
struct Solve {
    sel: Vec<bool>,
    relaxation: Relaxation,
    add_drop: AddDrop,
    lp: LpBound,
    lp_priced: bool,
}

/// The outcome of planning on trips.
pub(crate) struct TripsPlan {
    /// The selection is the exact optimum of the planning windows.
    pub exact: bool,
    /// Whether the exact optimum, when it needed fewer tags than the
    /// certified selection, passed a round of its own (`None`: no such
    /// round was drawn).
    pub optimum_round: Option<bool>,
    /// The cover leaving sampled beginnings over budget, when one was
    /// tried.
    pub discard: Option<DiscardOutcome>,
    /// The final solve's Lagrangian relaxation (its selection improved on
    /// the greedy's, its bound, its iterations).
    pub relaxation: Relaxation,
    /// The final solve's add-drop local search.
    pub add_drop: AddDrop,
    /// The bound from the final windows' linear programme.
    pub lp: LpBound,
    /// The selection is the greedy priced by that programme's multipliers
    /// (with add-drop moves), cheaper than the relaxation's.
    pub lp_priced: bool,
    pub selected: Vec<bool>,
    pub lower_bound: usize,
    pub guarantee: TripsGuarantee,
    /// Per site: the longest stretch of a window it serves (m) and whether
    /// that stretch starts a chain.
    pub site_reason: Vec<Option<WindowInfo>>,
    /// The windows of the final planning set (site ids, sorted).
    pub window_sets: WindowSets,
    /// The chains of the planning set and of the final certification round
    /// (for the coverage map).
    pub chains: Vec<ChainBudget>,
    /// The chain beginnings' stretches before calibration (for the
    /// coverage map; empty without beginnings).
    pub early: EarlyBudgets,
    /// Trips' ends and lengths of the first planning chains (for the
    /// validation's independence, only counts are kept).
    pub planning_km: f64,
    /// Straight-walk starts whose enumeration stopped at
    /// [`super::straight::MAX_STEPS`] edges (the windows they missed are
    /// left to the certification rounds).
    pub walks_cut: usize,
    /// Starts of straight walks that stopped forking at the paths' limit
    /// (`super::straight::WalkStats::forked`), summed like `walks_cut`.
    pub walks_forked: usize,
    /// The junction transitions the straight walks followed and the edges
    /// they started from (for the coverage map's walks,
    /// [`super::straight::walk_budgets`]).
    pub straight: HashSet<(u32, u32)>,
    pub used: Vec<bool>,
    /// The walk DP's lazy windows where straight walks stopped at a limit
    /// (map matching on; `super::walk_oracle`), `None` where none did or
    /// no class lacks turn credit.
    pub held: Option<HeldWalks>,
}

/// Plans tags for trips (module doc).
#[allow(clippy::too_many_arguments)]
pub(crate) fn plan_trips(
    net: &Network,
    model: &EdgeModel,
    dest: &Destinations,
    n_sites: usize,
    cost: &[f64],
    preselected: &[bool],
    k: usize,
    map_matching: bool,
    shift_s: f64,
    planning_chains: usize,
    cold_starts: Option<usize>,
    discard_beginnings: Option<usize>,
    epsilon: f64,
    beta: f64,
    seed: u64,
    mut infeasible: impl FnMut(&WindowInfo, &[u32]) -> Error,
    max_ids: usize,
    too_large: impl Fn(usize, usize) -> Error,
) -> Result<TripsPlan> {
    let demand = k + 1;
    let plan_chains = sample_chains(
        net,
        model,
        dest,
        shift_s,
        seed,
        0x7472_6970_7331,
        planning_chains,
    )?;
    let planning_km = plan_chains.iter().map(|c| c.length_m).sum::<f64>() / 1000.0;
    let mut budgets: Vec<ChainBudget> = plan_chains
        .par_iter()
        .map(|c| chain_budget(model, c, map_matching))
        .collect();
    drop(plan_chains);
    let mut wmap = WindowMap::new(max_ids);
    let full = |wmap: &WindowMap| -> Result<()> {
        if wmap.full() {
            Err(too_large(max_ids, wmap.len()))
        } else {
            Ok(())
        }
    };
    // With map matching, every straight walk of the network (turns reset);
    // without, the transitions the sampled traffic used.
    let mut straight: HashSet<(u32, u32)> = if map_matching {
        super::straight::geometric_straight(net, model)
    } else {
        HashSet::new()
    };
    let mut used = vec![false; model.dir.len()];
    for cb in &budgets {
        add_windows(cb, &mut wmap);
        straight.extend(cb.straight.iter().copied());
        for p in &cb.pieces {
            used[p.0 as usize] = true;
        }
    }
    // Chain beginnings: their stretches before calibration (two levels
    // only; with one level a beginning is like any other stretch).
    let mut early = EarlyBudgets::default();
    let cold = if map_matching && model.calibration_m.is_finite() {
        let n = cold_starts.unwrap_or(
            COLD_STARTS_PER_CHAIN * chains_allowing(epsilon, beta / 2.0, ALLOWED_VIOLATIONS),
        );
        early = EarlyBudgets::new(model.dir.len());
        add_cold_start_windows(net, model, dest, shift_s, seed, n, &mut wmap, &mut early)?
    } else {
        ColdStarts::default()
    };
    full(&wmap)?;
    // Walk starts cut at the step limit: without map matching each round
    // walks again from every edge used, so its count replaces the last;
    // with it, each round walks from fresh edges only, so counts add up.
    let first_walks = straight_windows(model, &straight, &used, &mut wmap);
    let (mut walks_cut, mut walks_forked) = (first_walks.cut, first_walks.forked);
    full(&wmap)?;
    // Where straight walks stopped at a limit (map matching on), the walk
    // DP finds the walks a selection leaves unheld (`super::walk_oracle`).
    let oracle_for = |straight: &HashSet<(u32, u32)>, stopped: usize| {
        (map_matching && stopped > 0)
            .then(|| WalkOracle::new(model, straight, n_sites, k))
            .flatten()
    };
    let mut oracle = oracle_for(&straight, walks_cut + walks_forked);
    let mut held_walks = HeldWalks::default();
    // The cover of the windows in the order of their ids (deterministic):
    // the greedy, then the Lagrangian relaxation from it (a cheaper
    // selection when it finds one, and a lower bound), then add-drop moves.
    let solve = |wmap: &mut WindowMap,
                 infeasible: &mut dyn FnMut(&WindowInfo, &[u32]) -> Error,
                 weight: Option<f64>|
     -> Result<Solve> {
        let (all, infos) = wmap.sorted();
        // The windows no other implies (`super::dominance`): the same
        // feasible selections, a fifth of the pairs on Gothenburg's plan.
        let (windows, kept) = essential_windows(all, demand, preselected);
        let windows = &windows;
        // One transpose for all (on a whole map it is the largest array).
        let site_w = SiteWindows::of(windows, n_sites);
        let greedy = multicover(windows, &site_w, demand, cost, preselected).map_err(|w| {
            let w = kept[w] as usize;
            infeasible(&infos[w], all.get(w))
        })?;
        let (mut sel, relaxation) = relax(windows, &site_w, demand, cost, preselected, greedy);
        let mut ad = add_drop(windows, &site_w, demand, cost, preselected, &mut sel);
        // The linear programme's multipliers price the greedy again (they
        // are much nearer the programme's optimum than the subgradient's);
        // each selection gets its own add-drop moves and the cheapest wins.
        // Nothing to price when the bound proves the incumbent optimal.
        let fresh = |s: &[bool]| -> f64 {
            (0..n_sites)
                .filter(|&i| s[i] && !preselected[i])
                .map(|i| cost[i])
                .sum()
        };
        let (lp, y) = lp_duals_within(
            windows,
            demand,
            cost,
            preselected,
            LP_MAX,
            weight,
            Some(fresh(&sel)),
        );
        let mut lp_priced = false;
        if !lp.proved && !y.is_empty() {
            for scale in LP_PRICE_SCALES {
                let u: Vec<f64> = y.iter().map(|v| v * scale).collect();
                let mut s = priced_selection(windows, &site_w, demand, cost, preselected, &u);
                let a = add_drop(windows, &site_w, demand, cost, preselected, &mut s);
                if windows.covered_by(&s, demand) && fresh(&s) < fresh(&sel) - 1e-9 {
                    (sel, ad, lp_priced) = (s, a, true);
                }
            }
        }
        Ok(Solve {
            sel,
            relaxation,
            add_drop: ad,
            lp,
            lp_priced,
        })
    };
    // A solve, then (with the oracle) the windows of the walks its
    // selection leaves unheld and a solve again, until none is left, a
    // check adds no window or after [`MAX_PASSES`] (lazy constraints).
    let solve_held = |wmap: &mut WindowMap,
                      infeasible: &mut dyn FnMut(&WindowInfo, &[u32]) -> Error,
                      weight: Option<f64>,
                      oracle: Option<&WalkOracle>,
                      held: &mut HeldWalks|
     -> Result<Solve> {
        let s = solve(wmap, infeasible, weight)?;
        let Some(o) = oracle else { return Ok(s) };
        let repair = |new: &WindowSets, cur: &[bool]| {
            let site_w = SiteWindows::of(new, n_sites);
            multicover(new, &site_w, demand, cost, cur).ok()
        };
        hold_walks(
            o,
            wmap,
            held,
            s,
            |s: &Solve| &s.sel,
            repair,
            |wmap: &mut WindowMap, s: &Solve| {
                full(wmap)?;
                solve(wmap, infeasible, Some(s.lp.weight))
            },
        )
    };
    let Solve {
        mut sel,
        mut relaxation,
        mut add_drop,
        mut lp,
        mut lp_priced,
    } = solve_held(
        &mut wmap,
        &mut infeasible,
        None,
        oracle.as_ref(),
        &mut held_walks,
    )?;
    // Sampling and discarding (`super::discard`): a cover that leaves a few
    // sampled beginnings over budget, judged in round 1 beside the full
    // cover (kept here).
    let max_left = discard_beginnings.unwrap_or_else(|| {
        let m1 = chains_allowing(epsilon, beta / 2.0, ALLOWED_VIOLATIONS);
        (DISCARD_SHARE * (ALLOWED_VIOLATIONS * cold.drawn) as f64 / m1 as f64).floor() as usize
    });
    let mut discarded: Option<(Vec<bool>, Discarded)> = None;
    if max_left > 0 && !early.over.is_empty() {
        let full_cover = sel.clone();
        let (ws, infos) = wmap.sorted();
        let d = discard(
            ws,
            infos,
            k,
            preselected,
            cost,
            &early.over,
            max_left,
            &mut sel,
        );
        // The smaller cover must still hold every walk the oracle checks.
        if oracle.as_ref().is_some_and(|o| !o.holds(&sel)) {
            sel = full_cover;
        } else if d.removed > 0 {
            discarded = Some((full_cover, d));
        }
    }
    let mut discard_outcome: Option<DiscardOutcome> = None;
    let mut added = 0usize;
    let mut last = (0usize, 0usize, 0.0f64, 0usize, 0.0f64, 0.0f64);
    let mut rounds = 0;
    let mut holds = false;
    let mut final_budgets: Vec<ChainBudget> = Vec::new();
    // A round's chains judged against selection `s` at level `beta_r`.
    let judge = |cbs: Vec<ChainBudget>, km: Vec<f64>, s: &[bool], beta_r: f64| -> Round {
        let m = cbs.len();
        let uses: Vec<f64> = cbs.par_iter().map(|cb| chain_use(cb, s, k)).collect();
        let bad: Vec<usize> = (0..m).filter(|&i| uses[i] > 1.0 + 1e-9).collect();
        let (wi, wu) =
            uses.iter().enumerate().fold(
                (0usize, 0.0f64),
                |a, (i, &u)| if u > a.1 { (i, u) } else { a },
            );
        Round {
            last: (
                m,
                bad.len(),
                beta_r,
                wi,
                wu,
                km.get(wi).copied().unwrap_or(0.0),
            ),
            holds: clopper_pearson_upper(bad.len(), m, beta_r) <= epsilon,
            cbs,
            km,
            bad,
        }
    };
    // Round `r`: `M` fresh chains (its own stream) checked against `s` at
    // confidence 1 − `beta_r`.
    let certify = |r: usize, beta_r: f64, s: &[bool]| -> Result<Round> {
        let m = chains_allowing(epsilon, beta_r, ALLOWED_VIOLATIONS);
        let fresh = sample_chains(
            net,
            model,
            dest,
            shift_s,
            seed,
            0x6365_7274_0000 + r as u64,
            m,
        )?;
        let cbs: Vec<ChainBudget> = fresh
            .par_iter()
            .map(|c| chain_budget(model, c, map_matching))
            .collect();
        let km = fresh.iter().map(|c| c.length_m / 1000.0).collect();
        Ok(judge(cbs, km, s, beta_r))
    };
    for r in 1..=MAX_ROUNDS {
        rounds = r;
        // Round 1 with a cover leaving beginnings uncovered: its β/2 is
        // shared by two selections judged on the same chains, that cover
        // and the full one (β/4 each; the union bound holds whatever their
        // dependence), so the full cover is judged in round 1 as without
        // discarding, on a sample sized for β/4.
        let split = r == 1 && discarded.is_some();
        let beta_r = beta / 2f64.powi(r as i32) / if split { 2.0 } else { 1.0 };
        let mut round = certify(r, beta_r, &sel)?;
        if split {
            let (full_cover, d) = discarded.take().expect("split only with a discarded cover");
            discard_outcome = Some(DiscardOutcome {
                removed: d.removed,
                left: d.left,
                certified: round.holds,
            });
            if !round.holds {
                sel = full_cover;
                round = judge(round.cbs, round.km, &sel, beta_r);
            }
        }
        let Round {
            last: l,
            holds: h,
            cbs,
            bad,
            ..
        } = round;
        last = l;
        if h {
            holds = true;
            final_budgets = cbs;
            break;
        }
        if r == MAX_ROUNDS {
            final_budgets = cbs;
            break;
        }
        // With map matching the straight transitions are the network's
        // geometry (fixed), so only edges newly driven add straight walks;
        // without, the traffic's transitions grow and every walk is redone.
        let mut fresh_used = vec![false; model.dir.len()];
        for &i in &bad {
            add_windows(&cbs[i], &mut wmap);
            straight.extend(cbs[i].straight.iter().copied());
            for p in &cbs[i].pieces {
                if !used[p.0 as usize] {
                    fresh_used[p.0 as usize] = true;
                }
                used[p.0 as usize] = true;
            }
        }
        let ws = straight_windows(
            model,
            &straight,
            if map_matching { &fresh_used } else { &used },
            &mut wmap,
        );
        (walks_cut, walks_forked) = if map_matching {
            (walks_cut + ws.cut, walks_forked + ws.forked)
        } else {
            (ws.cut, ws.forked)
        };
        full(&wmap)?;
        added += bad.len();
        budgets.extend(bad.iter().map(|&i| cbs[i].clone()));
        if map_matching && walks_cut + walks_forked > 0 {
            oracle = oracle_for(&straight, walks_cut + walks_forked);
        }
        Solve {
            sel,
            relaxation,
            add_drop,
            lp,
            lp_priced,
        } = solve_held(
            &mut wmap,
            &mut infeasible,
            Some(lp.weight),
            oracle.as_ref(),
            &mut held_walks,
        )?;
    }
    let (windows, infos) = wmap.into_sorted();
    // A certified selection that leaves beginnings uncovered is bounded
    // among the selections holding the same windows (those it holds); the
    // bounds of the full windows do not apply to it.
    let smaller = discard_outcome.is_some_and(|d| d.certified);
    let held: Option<WindowSets> = smaller.then(|| windows.held_by(&sel, demand));
    let bound_windows = held.as_ref().unwrap_or(&windows);
    let mut lower_bound = packing_bound(bound_windows, demand, preselected, n_sites);
    if held.is_some() {
        let (ess, _) = essential_windows(bound_windows, demand, preselected);
        let (b, _) = lp_duals_within(
            &ess,
            demand,
            cost,
            preselected,
            LP_MAX,
            Some(lp.weight),
            None,
        );
        lower_bound = lower_bound.max(b.tag_bound);
    } else {
        // The windows have not changed since the last solve: its
        // relaxation's bound holds for them. So does its linear
        // programme's.
        lower_bound = lower_bound.max(relaxation.tag_bound).max(lp.tag_bound);
    }
    // Small instances: the exact optimum (its tag count is then the bound).
    let mut exact = false;
    let mut optimum_round = None;
    if let Some((s_opt, _)) = exact_multicover(
        n_sites,
        bound_windows,
        demand,
        cost,
        preselected,
        &sel,
        EXACT_MAX_SITES,
    ) {
        // The optimum of the planning windows bounds every selection that
        // satisfies them. With the oracle it is tried only when it holds
        // every walk the oracle checks.
        lower_bound = lower_bound.max(new_tags(&s_opt, preselected));
        let at_level = |r: usize, s: &[bool]| certify(r, beta / 2f64.powi(r as i32), s);
        let outcome = match &oracle {
            Some(o) if !o.holds(&s_opt) => Optimum::Costlier,
            _ => optimum_outcome(&sel, &s_opt, preselected, rounds, at_level)?,
        };
        match outcome {
            Optimum::Same => exact = true,
            Optimum::Costlier => {}
            Optimum::Tested(r, opt) => {
                optimum_round = Some(opt.holds);
                if opt.holds {
                    sel = s_opt;
                    exact = true;
                    holds = true;
                    rounds = r;
                    last = opt.last;
                    final_budgets = opt.cbs;
                }
            }
        }
    }
    let (m, nbad, beta_r, wi, wu, wkm) = last;
    let upper = clopper_pearson_upper(nbad, m, beta_r);
    // The level of the final round: round 1 shared between two selections
    // when a cover left beginnings uncovered.
    let level = match discard_outcome {
        Some(d) if rounds == 1 => format!(
            "β/4 (round 1's β/2 shared by two selections judged on its chains: the cover \
             leaving {} sampled beginning(s) over budget, and the full cover)",
            d.left
        ),
        _ => format!("β/2^{rounds}"),
    };
    let statement = if holds {
        format!(
            "with confidence {:.4} (1 − β), a fresh chain of {:.1} h of trips violates the requirement \
             with probability at most ε = {epsilon} under the planning model: {held} of {m} fresh chains of \
             certification round {rounds}{own} hold it, {nbad} violate (at most {ALLOWED_VIOLATIONS} allowed; \
             Clopper–Pearson upper bound {upper:.4} ≤ ε at confidence 1 − {level})",
            1.0 - beta,
            shift_s / 3600.0,
            held = m - nbad,
            own = if optimum_round == Some(true) {
                " (the exact optimum's own round)"
            } else {
                ""
            },
        )
    } else {
        format!(
            "NOT established: {nbad} of {m} fresh chains of round {rounds} violate the model's \
             budget; with confidence 1 − {level} the violation probability is at most {upper:.4} \
             (Clopper–Pearson), above ε = {epsilon}"
        )
    };
    // Reasons: the longest stretch of a window each selected site serves.
    let mut site_reason: Vec<Option<WindowInfo>> = vec![None; n_sites];
    for (w, ids) in windows.iter().enumerate() {
        for &s in ids {
            if sel[s as usize] {
                let r = &mut site_reason[s as usize];
                if r.as_ref().is_none_or(|x| infos[w].stretch_m > x.stretch_m) {
                    *r = Some(infos[w].clone());
                }
            }
        }
    }
    budgets.extend(final_budgets);
    let left_over = early
        .over
        .iter()
        .filter(|cb| chain_use(cb, &sel, k) > 1.0 + 1e-9)
        .count();
    Ok(TripsPlan {
        exact,
        optimum_round,
        discard: discard_outcome,
        relaxation,
        lp,
        lp_priced,
        add_drop,
        selected: sel,
        lower_bound,
        guarantee: TripsGuarantee {
            statement,
            epsilon,
            beta,
            planning_chains,
            cold_starts: cold.drawn,
            cold_starts_over_budget: cold.over_budget,
            beginnings_left_over_budget: left_over,
            added_chains: added,
            certification_chains: m,
            allowed_violations: ALLOWED_VIOLATIONS,
            violations: nbad,
            rounds,
            holds,
            violation_upper_bound: upper,
            shift_hours: shift_s / 3600.0,
            worst_chain_budget: wu,
            worst_chain_km: wkm,
            worst_chain: wi,
        },
        site_reason,
        window_sets: windows,
        chains: budgets,
        early,
        planning_km,
        walks_cut,
        walks_forked,
        straight,
        used,
        held: oracle.is_some().then_some(held_walks),
    })
}
