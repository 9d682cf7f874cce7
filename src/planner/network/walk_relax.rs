//! The Lagrangian relaxation of an `any_walk` plan's cover: fewer tags than
//! the greedy's ([`greedy::greedy`]) where it finds them, and a lower bound.
//!
//! An `any_walk` plan asks that every walk longer than the reach `R` pass
//! `k + 1` selected sites, counted with multiplicity; there are infinitely
//! many walks, so the greedy works in rounds over the *witness* walks the
//! exact walk DP returns for its current selection ([`cover`]). Every
//! witness is a constraint every feasible selection meets (its length
//! exceeds `R` whatever is selected), so the witnesses of all the greedy's
//! rounds form a set multicover — windows of the sites each walk passes,
//! with repeats (up to `k + 1`) when it passes a site again, each needing
//! `k + 1` passes — whose optimum costs at most the walk problem's. Its Lagrangian relaxation (`super::lagrangian`:
//! subgradient optimisation, and the multiplier-priced greedy of Caprara,
//! Fischetti & Toth 1999 with redundancy removal) gives
//!
//! * a **lower bound** on the cost, and so on the new tags, of every
//!   feasible selection of the walk problem (a relaxation of a subset of
//!   its constraints); and
//! * a selection covering the witnesses, cheaper than the greedy's when the
//!   priced greedy finds one. It need not cover every walk.
//!
//! So each round relaxes the witness windows (those no other implies,
//! `super::dominance`: the same feasible selections) from the best feasible
//! selection (the incumbent: the greedy's at first; it covers every walk,
//! so every window) and, when the relaxation finds a cheaper selection `S`,
//! repairs it with the greedy's own rounds started from `S`
//! ([`greedy::greedy_from`]: the exact DP's witnesses against `S`, a greedy
//! multicover of them, until the DP passes; then reverse deletion of the
//! sites added), followed by the exact reverse deletion of `S`'s own sites
//! ([`greedy::LocalChecker`], dearest first). The repaired selection
//! replaces the incumbent when it costs less. When `S` needed no repair it
//! was feasible as it was; otherwise the repair's witnesses (those of `S`
//! first) join the windows and the next round relaxes again. Rounds end
//! when the relaxation finds nothing cheaper than the incumbent on the
//! windows, when `S` passed the DP unrepaired, when the next relaxation
//! would pass [`TOTAL_WORK`], or after [`MAX_ROUNDS`].
//! Every selection returned has passed the exact walk DP.
//!
//! Bounded work: at most [`MAX_ROUNDS`] relaxations (each limited by
//! `lagrangian::WORK_BUDGET`, all together by [`TOTAL_WORK`]) and repairs,
//! and at most [`MAX_WINDOW_IDS`] site ids over the windows (witnesses
//! past it are dropped, and the round in which they were is the last). Deterministic: windows are kept in the
//! order of their ids, and the relaxation and the greedy use no clock and
//! no randomness.

use super::cover::{CoverProblem, Solved, Walk};
use super::dominance::essential_windows;
use super::greedy::{self, LocalChecker};
use super::lagrangian::{self, relax};
use super::lp_bound::{iterations_for, lp_bound};
use super::window_sets::{SiteWindows, WindowMap};

/// Relaxations (each followed by a repair when its selection is cheaper)
/// at most.
pub const MAX_ROUNDS: usize = 6;

/// Window–site pair visits of all the rounds' relaxations at most (about
/// 3 per pair and subgradient iteration, as `lagrangian::WORK_BUDGET`
/// counts them): three relaxations at that budget. A round after the first
/// starts only when its relaxation, at the iterations the relaxation allows
/// itself on its windows, fits. On Gothenburg's plan (8–10 M pairs, about
/// 150 iterations a relaxation) this is 3 rounds, about 45 s on 2 cores;
/// on Helsinki's (0.3–0.4 M pairs, 300 iterations) all [`MAX_ROUNDS`].
pub const TOTAL_WORK: usize = 3 * lagrangian::WORK_BUDGET;

/// Site ids (with repeats) over all the witness windows at most: bounds the
/// memory of the windows and their transpose (8 bytes an id in all).
pub const MAX_WINDOW_IDS: usize = 100_000_000;

/// The linear programme's bound on the witness windows is computed only
/// when the subgradient's tag bound times this reaches the bound the caller
/// already has (`improve`'s `to_beat`, the packing bound): on the measured
/// plans the programme's bound was 1.09–1.23 times the subgradient's
/// (Helsinki's any-walk plan 460 against about 420 with a packing bound of
/// 609, where 2,000 iterations would only cost time; Monaco's with map
/// matching 367 against 333, packing bound 101). A skipped programme
/// loses tightness, never validity.
pub const LP_REACH: f64 = 1.3;

/// What the relaxation found besides its selection.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct WalkRelaxation {
    /// The selection returned costs less than the greedy's.
    pub improved: bool,
    /// The improvement needed the greedy's repair (the relaxation's
    /// selection missed walks the greedy's witnesses did not hold).
    pub repaired: bool,
    /// Relaxations run.
    pub rounds: usize,
    /// Subgradient iterations over all rounds.
    pub iterations: usize,
    /// Primal–dual iterations of the linear programme's bound on the final
    /// windows (`super::lp_bound`; 0 when not run).
    pub lp_iterations: usize,
    /// That programme's bound on the new tags' cost.
    pub lp_cost_bound: f64,
    /// Witness windows (distinct site multisets) in the last relaxation.
    pub windows: usize,
    /// Their site ids, with repeats.
    pub window_ids: usize,
    /// A lower bound on the new tags' total cost of every feasible
    /// selection (the best over the rounds).
    pub cost_bound: f64,
    /// A lower bound on the number of new tags (from `cost_bound` and the
    /// dearest candidate's cost).
    pub tag_bound: usize,
}

/// Cost of the new (not installed) sites of a selection.
fn fresh_cost(p: &CoverProblem, sel: &[bool]) -> f64 {
    (0..sel.len())
        .filter(|&i| sel[i] && !p.sites[i].existing)
        .map(|i| p.sites[i].cost)
        .sum()
}

/// The windows of witness walks, each a walk's sites (sorted, each kept at
/// most `demand` times), held once per distinct multiset, at most
/// [`MAX_WINDOW_IDS`] ids in all (later walks are then dropped).
///
/// A walk passing a site more often than the `demand` passes it needs is
/// met by that site alone however often it passes it, so the repeats
/// beyond `demand` are dropped: the same binary constraint, and a tighter
/// relaxation (a site passed twice would otherwise count twice toward a
/// fractional demand of 1, and the priced greedy would favour it). Only
/// the windows are kept, not the walks' pieces (on Gothenburg's plan the
/// greedy's 400 000 witnesses held several hundred MB of pieces).
pub(crate) struct WitnessWindows {
    wmap: WindowMap,
    demand: usize,
    ids: Vec<u32>,
}

impl WitnessWindows {
    /// No windows; each will need `demand` passes.
    pub fn new(demand: usize) -> Self {
        Self {
            wmap: WindowMap::new(MAX_WINDOW_IDS),
            demand,
            ids: Vec::new(),
        }
    }

    /// Adds the window of a walk (nothing once the windows are full).
    pub fn add(&mut self, w: &Walk) {
        let ids = &mut self.ids;
        ids.clear();
        ids.extend_from_slice(&w.sites);
        ids.sort_unstable();
        let mut run = 0;
        ids.dedup_by(|a, b| {
            run = if a == b { run + 1 } else { 0 };
            run >= self.demand
        });
        let _ = self.wmap.entry(ids);
    }
}

/// Exact reverse deletion of the new sites of a feasible selection, the
/// dearest first (then the higher index): each removal is tested by the
/// walk DP restricted to the site's ball ([`LocalChecker::try_remove`]).
fn prune(p: &CoverProblem, mut sel: Vec<bool>) -> Vec<bool> {
    let mut order: Vec<u32> = (0..sel.len() as u32)
        .filter(|&i| sel[i as usize] && !p.sites[i as usize].existing)
        .collect();
    order.sort_by(|&a, &b| {
        p.sites[b as usize]
            .cost
            .total_cmp(&p.sites[a as usize].cost)
            .then(b.cmp(&a))
    });
    let mut local = LocalChecker::new(p, &sel);
    for s in order {
        if local.try_remove(s) {
            sel[s as usize] = false;
        }
    }
    sel
}

/// The relaxation of the cover of `windows` (the greedy's witnesses, of
/// all its rounds) from the greedy's feasible selection `greedy` (module
/// doc). Returns the best selection found (installed sites included;
/// `greedy` unless a cheaper one passed the walk DP) and what else was
/// found; the windows' linear programme bounds it too when its bound could
/// reach `to_beat` tags (the caller's best bound; [`LP_REACH`]).
///
/// Edge cases: no window (the installed tags alone are feasible), or none
/// short of installed passes → `greedy`, bound 0. `greedy` must be
/// feasible (the bound holds regardless; a cheaper selection is only taken
/// when it passes the DP). Windows full ([`MAX_WINDOW_IDS`]) → the round
/// under way is the last.
pub(crate) fn improve(
    p: &CoverProblem,
    greedy: Vec<bool>,
    mut windows: WitnessWindows,
    to_beat: usize,
) -> (Vec<bool>, WalkRelaxation) {
    let n = p.sites.len();
    let demand = windows.demand;
    let cost: Vec<f64> = p.sites.iter().map(|s| s.cost).collect();
    let pre = p.existing_selection();
    let mut out = WalkRelaxation::default();
    let mut best_cost = fresh_cost(p, &greedy);
    let mut best = greedy;
    let mut work = 0usize;
    while out.rounds < MAX_ROUNDS && windows.wmap.len() > 0 {
        let (all, _) = windows.wmap.sorted();
        let (n_all, ids_all) = (all.len(), all.total_ids());
        // The windows no other implies (`super::dominance`): the same
        // feasible selections on fewer pairs.
        let (ws, _) = essential_windows(all, demand, &pre);
        let ws = &ws;
        let pairs = ws.total_ids().max(1);
        let visits = |iterations: usize| 3 * pairs * iterations;
        let its = lagrangian::MAX_ITERATIONS.min(lagrangian::WORK_BUDGET / visits(1));
        if out.rounds > 0 && work + visits(its.max(1)) > TOTAL_WORK {
            break;
        }
        out.rounds += 1;
        let site_w = SiteWindows::of(ws, n);
        let (s, r) = relax(ws, &site_w, demand, &cost, &pre, best.clone());
        drop(site_w);
        out.iterations += r.iterations;
        work += visits(r.iterations);
        out.windows = n_all;
        out.window_ids = ids_all;
        out.cost_bound = out.cost_bound.max(r.cost_bound);
        out.tag_bound = out.tag_bound.max(r.tag_bound);
        if !r.improved {
            break;
        }
        // Repair: the greedy's rounds from `s`, whose witnesses (the walks
        // `s` misses; none when it was feasible) join the windows, then
        // reverse deletion of its own sites.
        let mut missed = 0usize;
        let mut add = |w: &Walk| {
            missed += 1;
            windows.add(w);
        };
        if let (Solved::Feasible(fixed), _) = greedy::greedy_from(p, s, &mut add) {
            let fixed = prune(p, fixed);
            let c = fresh_cost(p, &fixed);
            if c < best_cost - 1e-9 {
                best_cost = c;
                best = fixed;
                out.improved = true;
                out.repaired = missed > 0;
            }
        }
        if missed == 0 || windows.wmap.full() {
            break;
        }
    }
    // The linear programme of all the windows (the last repair's included):
    // a tighter bound than the subgradient's when the budget affords it,
    // tried only when it could pass `to_beat` ([`LP_REACH`]).
    let (ws, _) = windows.wmap.sorted();
    let could_beat = out.tag_bound as f64 * LP_REACH >= to_beat as f64;
    if could_beat && !ws.is_empty() && iterations_for(ws.total_ids()).is_some() {
        let lp = lp_bound(ws, demand, &cost, &pre);
        out.lp_iterations = lp.iterations;
        out.lp_cost_bound = lp.cost_bound;
        out.cost_bound = out.cost_bound.max(lp.cost_bound);
        out.tag_bound = out.tag_bound.max(lp.tag_bound);
    }
    (best, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::network::cover::tests::{brute_longest, random_problem};
    use crate::planner::network::cover::{check, CoverEdge, CoverSite, EPS};
    use crate::planner::network::ilp::{self, IlpLimits, IlpOutcome};
    use crate::planner::network::window_sets::WindowSets;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The greedy with its witnesses and their windows, as the plan runs it.
    fn greedy_and_witnesses(p: &CoverProblem) -> Option<(Vec<bool>, Vec<Walk>, WitnessWindows)> {
        let mut walks = Vec::new();
        let mut windows = WitnessWindows::new(p.k + 1);
        let mut add = |w: &Walk| {
            walks.push(w.clone());
            windows.add(w);
        };
        match greedy::greedy_from(p, p.existing_selection(), &mut add).0 {
            Solved::Feasible(s) => Some((s, walks, windows)),
            Solved::Infeasible(_) => None,
        }
    }

    /// A window passing site 0 twice and site 1 once, needing 2 passes,
    /// with both selected: dropping site 0 leaves 1 pass, dropping site 1
    /// leaves 2. Redundancy removal must keep site 0 and may drop site 1.
    #[test]
    fn redundancy_removal_counts_repeated_passes() {
        let w = WindowSets::from_vecs(&[vec![0, 0, 1]]);
        let site_w = SiteWindows::of(&w, 2);
        let mut sel = vec![true, true];
        let mut count = vec![3usize];
        site_w.remove_redundant([0, 1], &mut sel, &mut count, 2);
        assert_eq!(sel, vec![true, false]);
        assert_eq!(count, vec![2]);
        assert!(w.covered_by(&sel, 2));
    }

    /// The relaxation on random windows with repeated sites (walks passing
    /// a site again): its selection covers every window counting
    /// multiplicity, costs no more than the incumbent, and its bound stays
    /// below the optimum (enumeration).
    #[test]
    fn the_relaxation_covers_windows_with_repeats() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut improved = 0;
        for case in 0..60 {
            let n = rng.random_range(6..14usize);
            let sets: Vec<Vec<u32>> = (0..rng.random_range(4..20))
                .map(|_| {
                    let mut v: Vec<u32> = (0..rng.random_range(3..8))
                        .map(|_| rng.random_range(0..n as u32))
                        .collect();
                    // Each window passes some sites twice.
                    let twice = v[0];
                    v.push(twice);
                    v.sort_unstable();
                    v
                })
                .collect();
            let w = WindowSets::from_vecs(&sets);
            let cost: Vec<f64> = (0..n).map(|_| rng.random_range(1..4) as f64).collect();
            let pre = vec![false; n];
            let all = vec![true; n];
            let site_w = SiteWindows::of(&w, n);
            let (sel, r) = relax(&w, &site_w, 2, &cost, &pre, all.clone());
            assert!(w.covered_by(&sel, 2), "case {case}");
            improved += usize::from(r.improved);
            // The optimum by enumerating every selection.
            let opt = (0u32..1 << n)
                .map(|m| (0..n).map(|i| m >> i & 1 == 1).collect::<Vec<bool>>())
                .filter(|s| w.covered_by(s, 2))
                .map(|s| (0..n).filter(|&i| s[i]).map(|i| cost[i]).sum::<f64>())
                .fold(f64::INFINITY, f64::min);
            assert!(
                r.cost_bound <= opt + 1e-6,
                "case {case}: {} > {opt}",
                r.cost_bound
            );
        }
        assert!(improved > 30, "{improved}");
    }

    /// A 6 m loop, reach 6.25 m, no missed read: every walk longer than
    /// the reach goes round the loop, so one tag anywhere on it suffices,
    /// and the cheapest is site 1 (cost 1). The greedy's witness walk
    /// passes site 0 (cost 1.5) twice and site 1 once; counting passes, it
    /// takes site 0 (2 passes for 1.5 against 1 for 1). The relaxation,
    /// whose windows count a site at most as often as the demand, takes
    /// site 1, and its bound proves it optimal.
    #[test]
    fn the_relaxation_finds_the_optimum_where_the_greedy_misses_it() {
        let edges = vec![CoverEdge {
            tail: 0,
            head: 0,
            length_m: 6.0,
        }];
        let site = |at_m, cost| CoverSite {
            edge: 0,
            at_m,
            cost,
            existing: false,
        };
        let sites = vec![site(5.75, 1.5), site(1.75, 1.0)];
        let p = CoverProblem::new(1, edges, sites, 6.25, 0).unwrap();
        let (g, walks, windows) = greedy_and_witnesses(&p).unwrap();
        assert_eq!(g, vec![true, false], "the greedy's choice");
        assert!(walks.iter().any(|w| w.sites == [0, 1, 0]), "{walks:?}");
        // Every selection, by the brute-force walk enumeration: the
        // optimum is site 1 alone.
        let feasible: Vec<Vec<bool>> = [[false, false], [true, false], [false, true], [true, true]]
            .iter()
            .map(|s| s.to_vec())
            .filter(|s| brute_longest(&p, s) <= p.reach_m + EPS)
            .collect();
        let opt = feasible
            .iter()
            .map(|s| fresh_cost(&p, s))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(opt, 1.0);
        assert!(fresh_cost(&p, &g) > opt, "the greedy is suboptimal");
        let (sel, r) = improve(&p, g, windows, 0);
        assert_eq!(sel, vec![false, true]);
        assert!(r.improved && !r.repaired, "{r:?}");
        assert_eq!(r.tag_bound, 1, "{r:?}");
        assert!((r.cost_bound - 1.0).abs() < 1e-6, "{r:?}");
    }

    /// On many small random walk problems: the result passes the exact walk
    /// DP and the brute-force walk enumeration, keeps the installed sites,
    /// never costs more than the greedy, and its bounds (cost and tags)
    /// never exceed the exact optimum's (integer programme). Improvements
    /// occur.
    #[test]
    fn the_result_is_feasible_no_dearer_and_bounded_by_the_optimum() {
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        let (mut improved, mut solved, mut bounded) = (0, 0, 0);
        for case in 0..400 {
            let p = random_problem(&mut rng, 14);
            let Some((g, _, windows)) = greedy_and_witnesses(&p) else {
                continue;
            };
            let (sel, r) = improve(&p, g.clone(), windows, 0);
            assert!(check(&p, &sel).feasible(), "case {case}");
            assert!(brute_longest(&p, &sel) <= p.reach_m + EPS, "case {case}");
            assert!(
                (0..sel.len()).all(|i| !p.sites[i].existing || sel[i]),
                "case {case}: an installed site dropped"
            );
            let (c, cg) = (fresh_cost(&p, &sel), fresh_cost(&p, &g));
            assert!(c <= cg + 1e-9, "case {case}: {c} > greedy {cg}");
            assert_eq!(r.improved, c < cg - 1e-9, "case {case}");
            improved += usize::from(r.improved);
            bounded += usize::from(r.tag_bound > 0);
            let IlpOutcome::Optimal { selected, cost, .. } =
                ilp::solve(&p, IlpLimits::default(), Some(&g))
            else {
                continue;
            };
            solved += 1;
            assert!(c >= cost - 1e-9, "case {case}: below the optimum");
            assert!(r.cost_bound <= cost + 1e-6, "case {case}");
            let fresh = (0..selected.len())
                .filter(|&i| selected[i] && !p.sites[i].existing)
                .count();
            assert!(r.tag_bound <= fresh, "case {case}");
        }
        assert!(solved > 200, "{solved}");
        assert!(bounded > 100, "{bounded}");
        assert!(improved > 0, "{improved}");
    }
}
