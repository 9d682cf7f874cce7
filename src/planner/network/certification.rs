//! The certification's statistics and its rounds' bookkeeping for
//! `traffic = "trips"` (`super::trips`): the sample sizes of a round, the
//! Clopper–Pearson bounds, a round's outcome, and the exact optimum's own
//! round.

use super::traffic::ChainBudget;
use crate::error::Result;

/// Chains needed so that `(1 − ε)^N ≤ β`.
pub fn chains_needed(epsilon: f64, beta: f64) -> usize {
    (beta.ln() / (1.0 - epsilon).ln()).ceil().max(1.0) as usize
}

/// Violations a certification round may find and still certify: its sample
/// is sized so that up to this many failures keep the Clopper–Pearson upper
/// bound within ε (fixed before the round is drawn, so the test stays
/// exact). Two cost about 1.7× the chains of a zero-failure round and
/// spare the re-planning rounds that a rare near-miss (a chain over its
/// budget by a few per cent) would otherwise trigger.
pub const ALLOWED_VIOLATIONS: usize = 2;

/// The smallest `N` with `clopper_pearson_upper(v, N, β) ≤ ε`: a round of
/// `N` fresh chains certifies with up to `v` violations.
pub fn chains_allowing(epsilon: f64, beta: f64, v: usize) -> usize {
    let mut lo = chains_needed(epsilon, beta).max(v + 1);
    if clopper_pearson_upper(v, lo, beta) <= epsilon {
        return lo;
    }
    let mut hi = lo * 2;
    while clopper_pearson_upper(v, hi, beta) > epsilon {
        lo = hi;
        hi *= 2;
    }
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if clopper_pearson_upper(v, mid, beta) <= epsilon {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// The one-sided upper confidence bound at level `1 − beta` on a
/// probability after `failures` in `n` Bernoulli trials (Clopper–Pearson):
/// the `p` with `P(X ≤ failures | p) = beta`, found by bisection on the
/// binomial tail (computed in log space; one function, so no statistics
/// crate for it).
///
/// ```
/// use waymark::planner::network::clopper_pearson_upper;
/// // No failure in 459 trials: (1 − p)^459 = 0.01 at p ≈ 0.01.
/// let p = clopper_pearson_upper(0, 459, 0.01);
/// assert!((p - (1.0 - 0.01f64.powf(1.0 / 459.0))).abs() < 1e-9);
/// ```
pub fn clopper_pearson_upper(failures: usize, n: usize, beta: f64) -> f64 {
    if n == 0 || failures >= n {
        return 1.0;
    }
    let cdf = |p: f64| -> f64 {
        // P(X ≤ failures), X ~ Bin(n, p).
        let (lp, lq) = (p.ln(), (1.0 - p).ln());
        let mut log_c = 0.0f64; // ln C(n, 0)
        let mut sum = 0.0;
        for i in 0..=failures {
            if i > 0 {
                log_c += ((n - i + 1) as f64).ln() - (i as f64).ln();
            }
            sum += (log_c + i as f64 * lp + (n - i) as f64 * lq).exp();
        }
        sum
    };
    let (mut lo, mut hi) = (failures as f64 / n as f64, 1.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) > beta {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// One-sided lower confidence bound at level `1 − alpha` on a proportion
/// after `successes` in `n` (Clopper–Pearson).
pub fn clopper_pearson_lower(successes: usize, n: usize, alpha: f64) -> f64 {
    if n == 0 {
        return 0.0;
    }
    1.0 - clopper_pearson_upper(n - successes, n, alpha)
}

/// One certification round's outcome.
pub(crate) struct Round {
    /// Chains, violations, β_r, the worst chain, its use and length (km).
    pub(crate) last: (usize, usize, f64, usize, f64, f64),
    pub(crate) holds: bool,
    pub(crate) cbs: Vec<ChainBudget>,
    /// The chains' lengths (km).
    pub(crate) km: Vec<f64>,
    pub(crate) bad: Vec<usize>,
}

/// Tags a selection adds to the `preselected` (installed) sites.
pub(crate) fn new_tags(sel: &[bool], preselected: &[bool]) -> usize {
    sel.iter()
        .zip(preselected)
        .filter(|(a, b)| **a && !**b)
        .count()
}

/// What became of the exact optimum of the planning windows.
pub(crate) enum Optimum {
    /// It is the certified selection.
    Same,
    /// It needs no fewer tags: not tried.
    Costlier,
    /// It needs fewer tags and was checked in round `.0`.
    Tested(usize, Round),
}

/// Checks the exact optimum `s_opt` against the selection `sel` that
/// certification ended with after `rounds` rounds. A different selection
/// with fewer tags gets a test of its own: fresh chains as round
/// `rounds + 1`, at β/2^(rounds + 1). Checking it on the final round's
/// chains would test two selections on one sample, beyond what that round's
/// β_r covers (the union over both at the defaults: ≈ 0.010005 > β). The
/// round after the last is otherwise never drawn (the last one certified,
/// or the rounds ran out), so every selection the plan may report is
/// tested at its own level and the levels sum to Σ β/2^r < β; when the
/// optimum fails, the certified selection and its statement stand.
pub(crate) fn optimum_outcome(
    sel: &[bool],
    s_opt: &[bool],
    preselected: &[bool],
    rounds: usize,
    certify: impl FnOnce(usize, &[bool]) -> Result<Round>,
) -> Result<Optimum> {
    if s_opt == sel {
        Ok(Optimum::Same)
    } else if new_tags(s_opt, preselected) < new_tags(sel, preselected) {
        Ok(Optimum::Tested(rounds + 1, certify(rounds + 1, s_opt)?))
    } else {
        Ok(Optimum::Costlier)
    }
}
