//! Tag placement on one route: the fewest tags such that the predicted error
//! bound stays within the requirement everywhere, even when any `k`
//! consecutive tags are missed.
//!
//! Each candidate site `i` (route distance `c_i`) has a reach `e_i`: after a
//! fix there, the bound stays within the requirement up to `e_i`. The start
//! of the route is a site that is always "read" (the initial condition) with
//! its own reach. Chosen tags `t_1 < … < t_m` are feasible when, with `t_0`
//! the start and `t_{m+1} = … = L` (the route's end),
//! `min(t_{i+k+1}, L) ≤ e(t_i)` for every `i ≥ 0`: after any tag is read,
//! the next `k` may be missed and the one after must still come before the
//! bound runs out (so the last `k + 1` tags must each reach the end).
//!
//! [`place`] is a breadth-first search over the last `k + 1` chosen sites
//! (the whole state the constraint looks at), layer by layer in the number
//! of tags, so the first feasible layer found is the minimum: it is exact
//! for any reaches, monotone or not.

use rustc_hash::FxHashMap;

/// A candidate site.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Route distance of the site (m).
    pub at_m: f64,
    /// Route distance up to which the bound holds after a fix here (m).
    pub reach_m: f64,
}

/// The outcome of placement.
#[derive(Debug, Clone, PartialEq)]
pub enum Placement {
    /// Indices of the chosen candidates, in route order (a minimum set).
    Feasible(Vec<usize>),
    /// No set of candidates covers the route: the bound cannot be held
    /// beyond `covered_to_m` (the furthest any choice reaches).
    Infeasible {
        /// Furthest route distance any choice of tags covers (m).
        covered_to_m: f64,
    },
}

/// Places tags on a route of length `length_m` with start reach
/// `start_reach_m`, `candidates` in increasing `at_m`, tolerating `k`
/// consecutive missed reads, with at least `min_spacing_m` between tags.
pub fn place(
    length_m: f64,
    start_reach_m: f64,
    candidates: &[Candidate],
    k: usize,
    min_spacing_m: f64,
) -> Placement {
    const START: usize = usize::MAX;
    let reach = |i: usize| {
        if i == START {
            start_reach_m
        } else {
            candidates[i].reach_m
        }
    };
    let at = |i: usize| {
        if i == START {
            f64::NEG_INFINITY
        } else {
            candidates[i].at_m
        }
    };
    let start = vec![START; k + 1];
    if start_reach_m >= length_m {
        return Placement::Feasible(vec![]);
    }
    // State: the last k+1 sites (oldest first). Parent links for the path.
    let mut parent: FxHashMap<Vec<usize>, Option<Vec<usize>>> = FxHashMap::default();
    parent.insert(start.clone(), None);
    let mut layer = vec![start];
    let mut covered = start_reach_m;
    while !layer.is_empty() {
        let mut next = Vec::new();
        for w in &layer {
            let limit = reach(w[0]);
            let last = *w.last().expect("k+1 ≥ 1");
            let from = at(last) + min_spacing_m.max(0.0);
            // First candidate strictly after the last one (and spaced).
            let lo = if last == START {
                0
            } else {
                candidates.partition_point(|c| c.at_m <= from.max(at(last)))
            };
            for (j, c) in candidates.iter().enumerate().skip(lo) {
                if c.at_m > limit {
                    break;
                }
                if last != START && c.at_m < from {
                    continue;
                }
                let mut nw: Vec<usize> = w[1..].to_vec();
                nw.push(j);
                if parent.contains_key(&nw) {
                    continue;
                }
                parent.insert(nw.clone(), Some(w.clone()));
                let r0 = reach(nw[0]);
                covered = covered.max(r0);
                // Done when every tag of the window (the oldest, and the
                // last k, any of which may be the last read) reaches the end.
                if nw.iter().all(|&i| reach(i) >= length_m) {
                    // Walk back.
                    let mut out = Vec::new();
                    let mut s = Some(nw);
                    while let Some(st) = s {
                        let l = *st.last().expect("non-empty");
                        if l == START {
                            break;
                        }
                        out.push(l);
                        s = parent[&st].clone();
                    }
                    out.reverse();
                    return Placement::Feasible(out);
                }
                next.push(nw);
            }
        }
        layer = next;
    }
    // The furthest distance up to which some choice holds the bound even
    // with k missed reads.
    Placement::Infeasible {
        covered_to_m: covered.min(length_m),
    }
}

/// Whether chosen candidate indices (increasing) satisfy the coverage
/// constraint directly (for tests and checks).
pub fn feasible(
    length_m: f64,
    start_reach_m: f64,
    candidates: &[Candidate],
    chosen: &[usize],
    k: usize,
    min_spacing_m: f64,
) -> bool {
    let m = chosen.len();
    for w in chosen.windows(2) {
        if candidates[w[1]].at_m - candidates[w[0]].at_m < min_spacing_m
            || candidates[w[1]].at_m <= candidates[w[0]].at_m
        {
            return false;
        }
    }
    // t_0 = start; t_{i+k+1} (or L) must be within reach of t_i.
    for i in 0..=m {
        let r = if i == 0 {
            start_reach_m
        } else {
            candidates[chosen[i - 1]].reach_m
        };
        let j = i + k + 1;
        let next = if j <= m {
            candidates[chosen[j - 1]].at_m
        } else {
            length_m
        };
        if next > r {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn brute(l: f64, s: f64, c: &[Candidate], k: usize, sp: f64) -> Option<usize> {
        let n = c.len();
        let mut best: Option<usize> = None;
        for mask in 0u32..(1 << n) {
            let chosen: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
            if feasible(l, s, c, &chosen, k, sp) {
                let m = chosen.len();
                best = Some(best.map_or(m, |b: usize| b.min(m)));
            }
        }
        best
    }

    #[test]
    fn exact_against_brute_force_on_small_cases() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
        let mut feasible_cases = 0;
        let mut infeasible_cases = 0;
        for case in 0..600 {
            let n = rng.random_range(1..=12);
            let l = 100.0;
            let mut at: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..l)).collect();
            at.sort_by(f64::total_cmp);
            let cands: Vec<Candidate> = at
                .iter()
                .map(|&a| Candidate {
                    at_m: a,
                    // Reaches of varied lengths, not necessarily monotone.
                    reach_m: a + rng.random_range(10.0..90.0),
                })
                .collect();
            let s = rng.random_range(0.0..40.0);
            let k = case % 3;
            let sp = if case % 4 == 0 { 5.0 } else { 0.0 };
            let want = brute(l, s, &cands, k, sp);
            match place(l, s, &cands, k, sp) {
                Placement::Feasible(ch) => {
                    assert!(feasible(l, s, &cands, &ch, k, sp), "case {case}: {ch:?}");
                    assert_eq!(Some(ch.len()), want, "case {case}");
                    feasible_cases += 1;
                }
                Placement::Infeasible { .. } => {
                    assert_eq!(want, None, "case {case}");
                    infeasible_cases += 1;
                }
            }
        }
        // Both outcomes exercised.
        assert!(
            feasible_cases > 50 && infeasible_cases > 50,
            "{feasible_cases} {infeasible_cases}"
        );
    }

    #[test]
    fn uniform_reach_needs_the_obvious_count() {
        // Reach 100 m after every fix, sites every 10 m over 1000 m, start
        // reach 100 m: k = 0 needs a tag at least every 100 m → 9 tags;
        // k = 1 needs every 50 m → 19.
        let cands: Vec<Candidate> = (1..100)
            .map(|i| Candidate {
                at_m: 10.0 * i as f64,
                reach_m: 10.0 * i as f64 + 100.0,
            })
            .collect();
        match place(1000.0, 100.0, &cands, 0, 0.0) {
            Placement::Feasible(ch) => assert_eq!(ch.len(), 9),
            p => panic!("{p:?}"),
        }
        match place(1000.0, 100.0, &cands, 1, 0.0) {
            Placement::Feasible(ch) => assert_eq!(ch.len(), 19),
            p => panic!("{p:?}"),
        }
    }

    #[test]
    fn gap_in_candidates_is_infeasible_and_named() {
        // No site between 200 and 600 m; reach 100 m.
        let cands: Vec<Candidate> = (1..100)
            .map(|i| 10.0 * i as f64)
            .filter(|a| !(*a > 200.0 && *a < 600.0))
            .map(|a| Candidate {
                at_m: a,
                reach_m: a + 100.0,
            })
            .collect();
        match place(1000.0, 100.0, &cands, 0, 0.0) {
            Placement::Infeasible { covered_to_m } => assert_eq!(covered_to_m, 300.0),
            p => panic!("{p:?}"),
        }
    }
}
