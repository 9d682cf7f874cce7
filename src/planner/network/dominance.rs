//! The rows of the windows' linear programme that matter: windows still
//! short, and not implied by another window.
//!
//! A window `u` implies a window `w` when every variable site of `u` is in
//! `w` (as many times) and `u` needs at least as many: for any `x ≥ 0`,
//! `A_w x ≥ A_u x ≥ d_u ≥ d_w`. Such a `w` can be dropped from the
//! programme without changing its optimum (nor any selection's
//! feasibility), and its multiplier is 0. Budget windows nest heavily:
//! a chain's stretch that needs `k + 1` tags holds the shorter stretch of
//! the same road that needs them too, and the straight walks through a
//! junction repeat each other's windows past it. On Gothenburg's trips plan
//! 77 % of the windows, holding 73 % of the window–site pairs, are implied
//! (BENCHMARKS.md, "Implied windows"), so each iteration of
//! `super::lp_bound` visits a quarter of the pairs.
//!
//! The search is complete and cheap: a window inside `w` starts (its first
//! variable site) at one of `w`'s sites, so `w`'s candidates are the
//! windows starting at its sites, on average (windows ÷ sites) per site. A
//! 64-bit signature of each window's sites rejects most candidates before
//! the exact test, a merge of two sorted lists. Among windows with the same
//! sites and need, the first is kept. Deterministic (no hashing by address,
//! results collected in window order).

use super::window_sets::WindowSets;
use rayon::prelude::*;

/// Candidate tests (window pairs sharing a first site) the search makes at
/// most; past it every window still short is kept.
pub(crate) const MAX_CANDIDATE_TESTS: u64 = 4_000_000_000;

/// The rows kept: their sites (variable ones only), needs, and the window
/// each came from.
pub(crate) struct Rows {
    /// Per kept window, its variable sites (sorted, with repeats).
    pub sets: WindowSets,
    /// Per kept window, the selected sites it still needs (> 0).
    pub need: Vec<f64>,
    /// Per kept window, its index among the windows given.
    pub window: Vec<u32>,
}

/// The windows with `need > 0` that no other window implies (module doc),
/// restricted to the sites with `var` set (one flag per site). `windows`'
/// ids are sorted within each window (as [`WindowSets`] keeps them).
///
/// Edge cases: a window with no variable site is kept when it still needs
/// sites (it makes the programme infeasible; the caller's business); no
/// window short → no rows; past [`MAX_CANDIDATE_TESTS`] candidate tests
/// (long windows sharing their sites: Liechtenstein without map matching
/// would need 1.6·10¹¹ to 8.3·10¹¹, Gothenburg's trips plan needs 1.3·10⁹)
/// the search is skipped and every window still short is a row.
pub(crate) fn essential_rows(windows: &WindowSets, need: &[f64], var: &[bool]) -> Rows {
    essential_rows_within(windows, need, var, MAX_CANDIDATE_TESTS)
}

/// [`essential_rows`] with at most `max_tests` candidate tests: past them,
/// every window still short is kept.
fn essential_rows_within(windows: &WindowSets, need: &[f64], var: &[bool], max_tests: u64) -> Rows {
    let n = windows.len();
    // One of 64 bits per site (a multiplicative hash of its id).
    let bit = |s: u32| 1u64 << (s.wrapping_mul(0x9E37_79B9) >> 26);
    let (sig, size): (Vec<u64>, Vec<u32>) = (0..n)
        .into_par_iter()
        .map(|w| {
            windows
                .get(w)
                .iter()
                .filter(|&&s| var[s as usize])
                .fold((0u64, 0u32), |(m, c), &s| (m | bit(s), c + 1))
        })
        .unzip();
    let implies = |u: usize, w: usize| -> bool {
        if need[u] < need[w] || size[u] > size[w] || sig[u] & !sig[w] != 0 {
            return false;
        }
        // Multiset inclusion of u's variable sites in w's (both sorted).
        let (vu, vw) = (windows.get(u), windows.get(w));
        let mut j = 0;
        for &s in vu.iter().filter(|&&s| var[s as usize]) {
            while j < vw.len() && (vw[j] < s || !var[vw[j] as usize]) {
                j += 1;
            }
            if j == vw.len() || vw[j] != s {
                return false;
            }
            j += 1;
        }
        // Equal rows: the first is kept.
        size[u] < size[w] || need[u] > need[w] || u < w
    };
    // Windows by their first variable site: every window inside `w` is
    // listed under one of `w`'s sites, exactly once.
    let first: Vec<Option<u32>> = (0..n)
        .map(|w| windows.get(w).iter().copied().find(|&s| var[s as usize]))
        .collect();
    let mut start = vec![0usize; var.len() + 1];
    for &f in first.iter().flatten() {
        start[f as usize + 1] += 1;
    }
    for i in 0..var.len() {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut by_first = vec![0u32; start[var.len()]];
    for (w, f) in first.iter().enumerate() {
        if let Some(f) = f {
            by_first[fill[*f as usize]] = w as u32;
            fill[*f as usize] += 1;
        }
    }
    // The candidate tests the search would make: on long windows that
    // share their sites (plans without map matching) they grow with the
    // square of the windows' length, so past the budget no window is
    // dropped (all are kept: a valid, larger programme).
    let tests: u64 = (0..n)
        .into_par_iter()
        .filter(|&w| need[w] > 0.0)
        .map(|w| {
            let ids = windows.get(w);
            ids.iter()
                .enumerate()
                .filter(|&(i, &s)| var[s as usize] && (i == 0 || ids[i - 1] != s))
                .map(|(_, &s)| (start[s as usize + 1] - start[s as usize]) as u64)
                .sum::<u64>()
        })
        .sum();
    let search = tests <= max_tests;
    let keep: Vec<bool> = (0..n)
        .into_par_iter()
        .map(|w| {
            if need[w] <= 0.0 {
                return false;
            }
            if !search {
                return true;
            }
            let ids = windows.get(w);
            !ids.iter().enumerate().any(|(i, &s)| {
                // Each distinct variable site once.
                var[s as usize]
                    && (i == 0 || ids[i - 1] != s)
                    && by_first[start[s as usize]..start[s as usize + 1]]
                        .iter()
                        .any(|&u| u as usize != w && implies(u as usize, w))
            })
        })
        .collect();
    let kept = keep.iter().filter(|&&k| k).count();
    let ids: usize = (0..n).filter(|&w| keep[w]).map(|w| size[w] as usize).sum();
    let mut sets = WindowSets::with_capacity(kept, ids);
    let mut rows_need = Vec::with_capacity(kept);
    let mut window = Vec::with_capacity(kept);
    let mut buf: Vec<u32> = Vec::new();
    for w in (0..n).filter(|&w| keep[w]) {
        buf.clear();
        buf.extend(windows.get(w).iter().copied().filter(|&s| var[s as usize]));
        sets.push(&buf);
        rows_need.push(need[w]);
        window.push(w as u32);
    }
    Rows {
        sets,
        need: rows_need,
        window,
    }
}

/// The windows a cover needs: those of [`essential_rows`] for `demand`
/// selected sites per window once the installed sites `preselected` count,
/// with all their sites (installed ones included), in window order, and
/// their indices among `windows`.
///
/// A selection holding `preselected` covers these windows exactly when it
/// covers all of `windows` (each dropped window is met or implied by a kept
/// one), so greedy, relaxation and add-drop may work on them alone and name
/// the same feasible selections.
///
/// Edge cases: every window met by installed sites → no windows.
pub(crate) fn essential_windows(
    windows: &WindowSets,
    demand: usize,
    preselected: &[bool],
) -> (WindowSets, Vec<u32>) {
    let need = windows.residual_demand(demand, preselected);
    let free: Vec<bool> = preselected.iter().map(|&p| !p).collect();
    let rows = essential_rows(windows, &need, &free);
    let ids = rows
        .window
        .iter()
        .map(|&w| windows.get(w as usize).len())
        .sum();
    let mut sets = WindowSets::with_capacity(rows.window.len(), ids);
    for &w in &rows.window {
        sets.push(windows.get(w as usize));
    }
    (sets, rows.window)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn rows(sets: &[Vec<u32>], need: &[f64], var: &[bool]) -> Vec<(Vec<u32>, f64, u32)> {
        let w = WindowSets::from_vecs(sets);
        let r = essential_rows(&w, need, var);
        (0..r.sets.len())
            .map(|i| (r.sets.get(i).to_vec(), r.need[i], r.window[i]))
            .collect()
    }

    #[test]
    fn nested_windows_keep_the_inner_one() {
        let var = vec![true; 6];
        let got = rows(
            &[vec![0, 1, 2, 3], vec![1, 2], vec![1, 2, 4], vec![4, 5]],
            &[2.0, 2.0, 2.0, 2.0],
            &var,
        );
        assert_eq!(got, vec![(vec![1, 2], 2.0, 1), (vec![4, 5], 2.0, 3)]);
    }

    #[test]
    fn a_smaller_need_or_a_repeat_decides() {
        let var = vec![true; 4];
        // [1, 2] needs 1 and does not imply [0, 1, 2] needing 2; the
        // repeated site: [1, 1] is not inside [0, 1, 2] (one 1 there).
        let got = rows(
            &[vec![0, 1, 2], vec![1, 2], vec![1, 1], vec![1, 1, 3]],
            &[2.0, 1.0, 2.0, 2.0],
            &var,
        );
        assert_eq!(
            got.iter().map(|r| r.2).collect::<Vec<_>>(),
            vec![0, 1, 2],
            "{got:?}"
        );
        // Equal rows: the first stays.
        let got = rows(&[vec![0, 1], vec![0, 1]], &[1.0, 1.0], &var);
        assert_eq!(got.iter().map(|r| r.2).collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn installed_sites_and_met_windows_leave_the_rows() {
        // Site 0 installed: window 0's variable part is [1, 2], which
        // window 1 ([1, 2, 3]) holds; window 2 is met.
        let var = vec![false, true, true, true];
        let got = rows(
            &[vec![0, 1, 2], vec![1, 2, 3], vec![2, 3]],
            &[1.0, 1.0, 0.0],
            &var,
        );
        assert_eq!(got, vec![(vec![1, 2], 1.0, 0)]);
    }

    /// A random stretch of consecutive sites among `n` (a window along a
    /// chain).
    fn stretch(rng: &mut ChaCha8Rng, n: usize) -> Vec<u32> {
        let a = rng.random_range(0..n as u32);
        let b = rng.random_range(a..n as u32) + 1;
        (a..b).collect()
    }

    /// On random chains: the kept rows admit exactly the integer selections
    /// all windows admit (every subset of the sites, by brute force), and
    /// no kept row is implied by another (the search is complete).
    #[test]
    fn dropped_windows_are_implied_by_kept_ones() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xd0);
        for _ in 0..200 {
            let n = rng.random_range(4..12usize);
            let var: Vec<bool> = (0..n).map(|_| rng.random_bool(0.9)).collect();
            let mut sets = Vec::new();
            let mut need = Vec::new();
            for _ in 0..rng.random_range(1..12) {
                let mut s = stretch(&mut rng, n);
                if rng.random_bool(0.2) {
                    s.push(s[0]);
                    s.sort_unstable();
                }
                sets.push(s);
                need.push(rng.random_range(0..3) as f64);
            }
            let got = rows(&sets, &need, &var);
            for x in 0..(1u32 << n) {
                let chosen = |s: u32| var[s as usize] && x >> s & 1 == 1;
                let meets =
                    |ids: &[u32], d: f64| ids.iter().filter(|&&s| chosen(s)).count() as f64 >= d;
                let all = sets.iter().zip(&need).all(|(s, &d)| meets(s, d));
                let kept = got.iter().all(|(s, d, _)| meets(s, *d));
                assert_eq!(
                    all, kept,
                    "sets {sets:?} need {need:?} var {var:?} kept {got:?}"
                );
            }
            for (i, (a, da, _)) in got.iter().enumerate() {
                for (j, (b, db, _)) in got.iter().enumerate() {
                    let inside = |x: &[u32], y: &[u32]| {
                        let mut y = y.to_vec();
                        x.iter()
                            .all(|s| y.iter().position(|t| t == s).map(|p| y.remove(p)).is_some())
                    };
                    assert!(
                        // (An empty row, an infeasible programme, is kept
                        // as it is and implies every row vacuously.)
                        i == j || a.is_empty() || !(inside(a, b) && da >= db),
                        "row {a:?} ({da}) implies row {b:?} ({db}): {got:?}"
                    );
                }
            }
        }
    }

    /// The windows kept for a cover with installed sites admit exactly the
    /// selections (holding the installed sites) that all windows admit,
    /// keep their full site lists, and name their place among all windows.
    #[test]
    fn essential_windows_admit_the_same_selections() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xe5);
        for _ in 0..200 {
            let n = rng.random_range(4..12usize);
            let pre: Vec<bool> = (0..n).map(|_| rng.random_bool(0.15)).collect();
            let demand = rng.random_range(1..3usize);
            let sets: Vec<Vec<u32>> = (0..rng.random_range(1..12))
                .map(|_| stretch(&mut rng, n))
                .collect();
            let all = WindowSets::from_vecs(&sets);
            let (sub, kept) = essential_windows(&all, demand, &pre);
            assert_eq!(sub.len(), kept.len());
            for (i, &w) in kept.iter().enumerate() {
                assert_eq!(sub.get(i), all.get(w as usize));
            }
            assert!(kept.windows(2).all(|p| p[0] < p[1]), "{kept:?}");
            for x in 0..(1u32 << n) {
                let sel: Vec<bool> = (0..n).map(|s| pre[s] || x >> s & 1 == 1).collect();
                assert_eq!(
                    all.covered_by(&sel, demand),
                    sub.covered_by(&sel, demand),
                    "sets {sets:?} pre {pre:?} demand {demand} kept {kept:?} sel {sel:?}"
                );
            }
        }
    }

    /// Past the budget of candidate tests nothing is dropped: every window
    /// still short is a row (a valid, larger programme).
    #[test]
    fn past_the_test_budget_every_short_window_is_kept() {
        let sets = [vec![0, 1, 2, 3], vec![1, 2], vec![1, 2, 4], vec![4, 5]];
        let w = WindowSets::from_vecs(&sets);
        let var = vec![true; 6];
        let need = [2.0, 2.0, 0.0, 2.0];
        assert_eq!(
            essential_rows_within(&w, &need, &var, u64::MAX).window,
            vec![1, 3]
        );
        let all = essential_rows_within(&w, &need, &var, 0);
        assert_eq!(all.window, vec![0, 1, 3]);
        assert_eq!(all.sets.get(0), &[0, 1, 2, 3]);
    }
}
