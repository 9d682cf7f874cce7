//! Lagrangian relaxation of a set multicover (a trips plan's budget
//! windows; an any-walk plan's witness walks, `super::walk_relax`): a lower
//! bound on the tags any selection needs, and better selections than the
//! plain greedy's.
//!
//! The cover asks, for every budget window `w`, `d_w` = `k + 1` − (the
//! installed tags in it) selected sites at the least total cost. Relaxing
//! those constraints with multipliers `u_w ≥ 0` gives, for any `u`,
//!
//! `L(u) = Σ_w d_w u_w + Σ_s min(0, c_s − Σ_{w ∋ s} u_w)`,
//!
//! a lower bound on the linear programme's optimum and so on every
//! selection's cost. Subgradient steps (Held & Karp 1971; the step rule of
//! Beasley 1990) raise it. Each multiplier vector also prices the sites:
//! the greedy of Caprara, Fischetti & Toth (1999) takes, while a window
//! lacks tags, the site of least score `γ/μ` (`γ` its cost less the
//! multipliers of the windows it would help, `μ` their number; `γ·μ` when
//! `γ < 0`), and redundant sites are then removed, dearest and least
//! attractive first. The best selection found replaces the plain greedy's
//! when it costs less.
//!
//! Written here rather than taken from a crate: the cover is the product's
//! core, the instances are large and sparse (millions of window–site
//! pairs), and the one linear-programming crate in the build (`microlp`,
//! a dense-tableau simplex) solves only the small ones (`super::ilp`,
//! `super::trips::exact_multicover`). Measured against HiGHS on the bundled
//! trips plans in BENCHMARKS.md ("The cover's Lagrangian relaxation").
//!
//! Deterministic: fixed step rules and iteration counts, no clock.

use super::best_site::BestSite;
use super::window_sets::{SiteWindows, WindowSets};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Most subgradient iterations.
pub const MAX_ITERATIONS: usize = 300;

/// Window–site pairs visited by the relaxation at most (about 3 per pair
/// and iteration): bounds its time on large instances (Gothenburg's trips
/// plan got 160 iterations on all its 8.3 M pairs; on the 1.5 M pairs of
/// the windows no other implies, `super::dominance`, it gets all 300).
pub const WORK_BUDGET: usize = 4_000_000_000;

/// The primal heuristic runs every this many iterations.
const PRIMAL_EVERY: usize = 5;

/// Iterations between adaptations of the step factor.
const ADAPT_EVERY: usize = 20;

/// The step factor's start.
const INITIAL_FACTOR: f64 = 2.0;

/// A relative spread of the bounds over `ADAPT_EVERY` iterations above
/// this halves the step factor (below a fiftieth of it, the factor grows).
const WIDE_SPREAD: f64 = 0.05;

/// What the relaxation found besides its selection.
#[derive(Debug, Clone)]
pub(crate) struct Relaxation {
    /// The incumbent was improved.
    pub improved: bool,
    /// The best lower bound on the new tags' total cost.
    pub cost_bound: f64,
    /// A lower bound on the number of new tags (from `cost_bound` and the
    /// dearest candidate's cost).
    pub tag_bound: usize,
    /// Subgradient iterations run.
    pub iterations: usize,
}

/// The relaxation of the cover of `windows` (each needing `demand` selected
/// sites; `site_w` their transpose) starting from the feasible
/// `incumbent`; `cost[s]` > 0 is a new tag's cost at site `s`,
/// `preselected` the installed sites. Returns the best selection
/// (installed sites included: the incumbent unless a cheaper one was
/// found) and what else the relaxation found.
///
/// Edge cases: no window short of installed tags → the incumbent, bound 0;
/// a window with fewer candidates than its demand is the caller's check
/// (the incumbent is then not feasible and is returned as it is).
pub(crate) fn relax(
    windows: &WindowSets,
    site_w: &SiteWindows,
    demand: usize,
    cost: &[f64],
    preselected: &[bool],
    incumbent: Vec<bool>,
) -> (Vec<bool>, Relaxation) {
    let n_sites = preselected.len();
    let fresh_cost = |sel: &[bool]| -> f64 {
        sel.iter()
            .zip(preselected)
            .zip(cost)
            .filter(|((a, p), _)| **a && !**p)
            .map(|(_, c)| *c)
            .sum()
    };
    let mut best = incumbent;
    let mut out = Relaxation {
        improved: false,
        cost_bound: 0.0,
        tag_bound: 0,
        iterations: 0,
    };
    // Residual demand per window (installed tags count).
    let need: Vec<f64> = windows.residual_demand(demand, preselected);
    if need.iter().all(|&d| d == 0.0) {
        return (best, out);
    }
    // The variables: candidates in some window, not installed.
    let vars: Vec<u32> = (0..n_sites)
        .filter(|&s| !preselected[s] && !site_w.get(s).is_empty())
        .map(|s| s as u32)
        .collect();
    let max_cost = vars
        .iter()
        .map(|&s| cost[s as usize])
        .fold(0.0f64, f64::max);
    let mut ub = fresh_cost(&best);
    // Initial multipliers: each window the cheapest share of a site's cost
    // over the windows the site serves.
    let mut u: Vec<f64> = windows
        .iter()
        .zip(&need)
        .map(|(ids, &d)| {
            if d == 0.0 {
                0.0
            } else {
                ids.iter()
                    .filter(|&&s| !preselected[s as usize])
                    .map(|&s| cost[s as usize] / site_w.get(s as usize).len() as f64)
                    .fold(f64::INFINITY, f64::min)
                    .min(1e12)
            }
        })
        .collect();
    let pairs = windows.total_ids().max(1);
    let iterations = MAX_ITERATIONS.min(WORK_BUDGET / (3 * pairs)).max(1);
    let mut reduced = vec![0.0f64; n_sites];
    let mut best_bound = f64::NEG_INFINITY;
    // With integral costs a bound above `ub − 1` proves the incumbent.
    let integral = vars.iter().all(|&s| cost[s as usize].fract() == 0.0);
    // The step factor, adapted every `ADAPT_EVERY` iterations from the
    // spread of the bounds over them (the rule of Caprara, Fischetti & Toth
    // 1999, with a larger start and tolerance: chosen on the five dumped
    // plans of BENCHMARKS.md, where it found the most savings): a wide
    // spread halves it, a flat run raises it by half.
    let mut factor = INITIAL_FACTOR;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for it in 0..iterations {
        out.iterations = it + 1;
        // Reduced costs of the variables.
        let rc: Vec<f64> = vars
            .par_iter()
            .map(|&s| {
                cost[s as usize]
                    - site_w
                        .get(s as usize)
                        .iter()
                        .map(|&w| u[w as usize])
                        .sum::<f64>()
            })
            .collect();
        for (&s, &r) in vars.iter().zip(&rc) {
            reduced[s as usize] = r;
        }
        let bound: f64 = need.iter().zip(&u).map(|(d, x)| d * x).sum::<f64>()
            + rc.iter().map(|&r| r.min(0.0)).sum::<f64>();
        best_bound = best_bound.max(bound);
        (lo, hi) = (lo.min(bound), hi.max(bound));
        if it % ADAPT_EVERY == ADAPT_EVERY - 1 {
            let spread = (hi - lo) / hi.abs().max(1e-9);
            if spread > WIDE_SPREAD {
                factor *= 0.5;
            } else if spread < WIDE_SPREAD / 50.0 {
                factor *= 1.5;
            }
            (lo, hi) = (f64::INFINITY, f64::NEG_INFINITY);
        }
        if it % PRIMAL_EVERY == PRIMAL_EVERY - 1 || it + 1 == iterations {
            let sel = primal(
                windows,
                site_w,
                demand,
                &need,
                cost,
                preselected,
                &u,
                &reduced,
            );
            let c = fresh_cost(&sel);
            if c < ub - 1e-9 {
                ub = c;
                best = sel;
                out.improved = true;
            }
        }
        // Nothing left to gain: the incumbent is proven optimal.
        let gap_closed = if integral {
            (best_bound - 1e-6 * best_bound.abs().max(1.0)).ceil() >= ub - 1e-9
        } else {
            ub - best_bound <= 1e-6 * ub.max(1.0)
        };
        if gap_closed || factor < 1e-4 {
            break;
        }
        // Subgradient: each window's unmet demand at the relaxed optimum,
        // projected where the multiplier is 0 and would go negative.
        let g: Vec<f64> = (0..windows.len())
            .into_par_iter()
            .map(|w| {
                let (d, x) = (need[w], u[w]);
                if d == 0.0 {
                    return 0.0;
                }
                let got = windows
                    .get(w)
                    .iter()
                    .filter(|&&s| !preselected[s as usize] && reduced[s as usize] < 0.0)
                    .count();
                let gi = d - got as f64;
                if x <= 0.0 && gi < 0.0 {
                    0.0
                } else {
                    gi
                }
            })
            .collect();
        let norm2: f64 = g.iter().map(|x| x * x).sum();
        if norm2 == 0.0 {
            // The relaxed optimum meets every window: it is the LP's.
            break;
        }
        let step = factor * (ub - bound).max(1e-9 * ub.max(1.0)) / norm2;
        for (x, gi) in u.iter_mut().zip(&g) {
            *x = (*x + step * gi).max(0.0);
        }
    }
    out.cost_bound = best_bound.max(0.0);
    out.tag_bound = if max_cost > 0.0 {
        let t = out.cost_bound / max_cost;
        (t - 1e-6 * t.max(1.0)).ceil().max(0.0) as usize
    } else {
        0
    };
    (best, out)
}

/// The greedy priced by multipliers `u` found elsewhere (one per window,
/// `u ≥ 0`; `super::lp_bound`'s), with redundancy removal: the same
/// selection rule as the relaxation's own (module doc). Feasible whenever
/// every window has enough candidates.
pub(crate) fn priced_selection(
    windows: &WindowSets,
    site_w: &SiteWindows,
    demand: usize,
    cost: &[f64],
    preselected: &[bool],
    u: &[f64],
) -> Vec<bool> {
    let need: Vec<f64> = windows.residual_demand(demand, preselected);
    let reduced: Vec<f64> = (0..preselected.len())
        .into_par_iter()
        .map(|s| cost[s] - site_w.get(s).iter().map(|&w| u[w as usize]).sum::<f64>())
        .collect();
    primal(
        windows,
        site_w,
        demand,
        &need,
        cost,
        preselected,
        u,
        &reduced,
    )
}

/// The multiplier-priced greedy with redundancy removal (module doc).
#[allow(clippy::too_many_arguments)]
fn primal(
    windows: &WindowSets,
    site_w: &SiteWindows,
    demand: usize,
    need: &[f64],
    cost: &[f64],
    preselected: &[bool],
    u: &[f64],
    reduced: &[f64],
) -> Vec<bool> {
    let n_sites = preselected.len();
    let mut sel = preselected.to_vec();
    // Tags still lacking per window.
    let mut lack: Vec<u32> = need.iter().map(|&d| d as u32).collect();
    let score = |s: usize, lack: &[u32]| -> (f64, usize) {
        let (mut gamma, mut mu) = (cost[s], 0usize);
        for &w in site_w.get(s) {
            if lack[w as usize] > 0 {
                gamma -= u[w as usize];
                mu += 1;
            }
        }
        let sc = if mu == 0 {
            f64::INFINITY
        } else if gamma > 0.0 {
            gamma / mu as f64
        } else {
            gamma * mu as f64
        };
        (sc, mu)
    };
    // The least score first (negated), ties to the lower site index.
    let item = |sc: f64, s: usize| BestSite {
        score: -sc,
        site: s,
        data: sc,
    };
    let mut heap = BinaryHeap::new();
    for (s, &taken) in sel.iter().enumerate() {
        if !taken {
            let (sc, mu) = score(s, &lack);
            if mu > 0 {
                heap.push(item(sc, s));
            }
        }
    }
    // Scores only grow as windows fill (γ rises, μ falls), so a popped
    // site whose score is unchanged is the least.
    while let Some(BestSite {
        site: s, data: sc, ..
    }) = heap.pop()
    {
        let (now, mu) = score(s, &lack);
        if mu == 0 {
            continue;
        }
        if now.total_cmp(&sc) != Ordering::Equal {
            heap.push(item(now, s));
            continue;
        }
        sel[s] = true;
        for &w in site_w.get(s) {
            let l = &mut lack[w as usize];
            *l = l.saturating_sub(1);
        }
    }
    // Redundancy removal: dearest first, then the least attractive at
    // these prices (largest reduced cost), then by index.
    let mut count: Vec<usize> = windows
        .iter()
        .map(|ids| ids.iter().filter(|&&s| sel[s as usize]).count())
        .collect();
    let mut order: Vec<usize> = (0..n_sites)
        .filter(|&s| sel[s] && !preselected[s])
        .collect();
    order.sort_by(|&a, &b| {
        cost[b]
            .total_cmp(&cost[a])
            .then(reduced[b].total_cmp(&reduced[a]))
            .then(a.cmp(&b))
    });
    site_w.remove_redundant(order, &mut sel, &mut count, demand);
    sel
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The greedy's classic trap: two sites (rows) cover every window, but
    /// a site covering more windows at first (column blocks of 8, 4, 2)
    /// leads the greedy to take the three blocks. The priced greedy takes
    /// the two rows, and the bound proves them optimal.
    #[test]
    fn the_relaxation_escapes_the_greedys_trap_and_proves_the_optimum() {
        // Windows: 2 rows × 7 columns; window (r, c) = 7r + c.
        // Sites: 0 = row 0, 1 = row 1, 2 = columns 0–3, 3 = columns 4–5,
        // 4 = column 6.
        let mut sets: Vec<Vec<u32>> = vec![Vec::new(); 14];
        for r in 0..2u32 {
            for c in 0..7u32 {
                let w = &mut sets[(7 * r + c) as usize];
                w.push(r);
                w.push(match c {
                    0..=3 => 2,
                    4 | 5 => 3,
                    _ => 4,
                });
                w.sort_unstable();
            }
        }
        let w = WindowSets::from_vecs(&sets);
        let cost = vec![1.0; 5];
        let pre = vec![false; 5];
        let site_w = SiteWindows::of(&w, 5);
        let greedy = super::super::trips::multicover(&w, &site_w, 1, &cost, &pre).unwrap();
        assert_eq!(greedy, vec![false, false, true, true, true], "the trap");
        let (sel, r) = relax(&w, &site_w, 1, &cost, &pre, greedy);
        assert!(r.improved);
        assert_eq!(sel, vec![true, true, false, false, false]);
        assert!(w.covered_by(&sel, 1));
        // Windows (0, 0) and (1, 4) share no site, so every selection, even
        // fractional, costs at least 2: a bound above 1 proves the two rows.
        assert_eq!(r.tag_bound, 2, "bound {}", r.cost_bound);
    }

    /// On random chains of interval windows (the trips plans' shape) with
    /// installed tags and k = 1: the selection covers every window, never
    /// costs more than the greedy, and the bound never exceeds the exact
    /// optimum (integer programme).
    #[test]
    fn the_selection_is_feasible_and_the_bound_below_the_optimum() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut improved = 0;
        for case in 0..40 {
            let (n, w, cost, pre) = super::super::lp_bound::tests::random_chain(&mut rng);
            let site_w = SiteWindows::of(&w, n);
            let greedy = super::super::trips::multicover(&w, &site_w, 2, &cost, &pre).unwrap();
            let (sel, r) = relax(&w, &site_w, 2, &cost, &pre, greedy.clone());
            assert!(w.covered_by(&sel, 2), "case {case}");
            assert!(pre.iter().zip(&sel).all(|(p, s)| !p || *s));
            let c =
                |s: &[bool]| -> f64 { (0..n).filter(|&i| s[i] && !pre[i]).map(|i| cost[i]).sum() };
            assert!(c(&sel) <= c(&greedy) + 1e-9, "case {case}");
            improved += usize::from(r.improved);
            let (opt, opt_cost) =
                super::super::trips::exact_multicover(n, &w, 2, &cost, &pre, &greedy, 1000)
                    .expect("small instances solve exactly");
            assert!(w.covered_by(&opt, 2));
            // Tolerance: the bound is a sum of floating-point products.
            assert!(
                r.cost_bound <= opt_cost + 1e-6,
                "case {case}: {} > {opt_cost}",
                r.cost_bound
            );
            let fresh = (0..n).filter(|&i| opt[i] && !pre[i]).count();
            assert!(r.tag_bound <= fresh, "case {case}");
        }
        // The relaxation must find something on such instances (measured:
        // see the count printed on failure).
        assert!(improved > 0, "{improved}");
    }
}
