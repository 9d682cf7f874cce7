//! Scores to probabilities: the arg-max of a score vector, normalisation
//! and the soft-max used by the forward–backward smoother; the
//! independent model's max-product step.

pub(super) fn argmax(v: &[f64]) -> u32 {
    let mut k = 0;
    for (i, x) in v.iter().enumerate() {
        if *x > v[k] {
            k = i;
        }
    }
    k as u32
}

/// Scales `v` to sum 1; false (and `v` untouched) when its sum is not a
/// positive finite number.
pub(super) fn normalise(v: &mut [f64]) -> bool {
    let sum: f64 = v.iter().sum();
    if !(sum > 0.0 && sum.is_finite()) {
        return false;
    }
    v.iter_mut().for_each(|x| *x /= sum);
    true
}

/// Shifts log scores so that the largest is 0 (Viterbi scores stay near
/// zero on long tracks). Only called when some score is finite.
pub(super) fn shift_max_to_zero(v: &mut [f64]) {
    let m = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    for s in v {
        *s -= m;
    }
}

/// Probabilities from log scores into `out` (all zero if none is finite).
pub(super) fn softmax_into(scores: &[f64], out: &mut Vec<f64>) {
    let m = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    out.clear();
    if !m.is_finite() {
        out.resize(scores.len(), 0.0);
        return;
    }
    out.extend(scores.iter().map(|s| (s - m).exp()));
    normalise(out);
}

/// One predecessor's turn in [`max_product`]: which candidates it may
/// still win, and its offers.
#[derive(Debug)]
pub(super) struct Offers<'b> {
    i: u32,
    from: f64,
    best: &'b mut [f64],
    arg: &'b mut [u32],
    dist: &'b mut [f64],
}

impl Offers<'_> {
    /// Can this predecessor still win candidate `k`? Not when `k`'s best so
    /// far exceeds its score, or equals it with a lower predecessor (a
    /// transition's cost is never negative).
    #[inline]
    pub(super) fn open(&self, k: usize) -> bool {
        let (b, a) = (self.best[k], self.arg[k]);
        !(self.from < b || (self.from == b && self.i > a))
    }

    /// The transition into candidate `k` at `cost` (not negative) over
    /// route distance `dist_m`.
    #[inline]
    pub(super) fn offer(&mut self, k: usize, cost: f64, dist_m: f64) {
        debug_assert!(
            cost >= 0.0 || cost.is_nan(),
            "a negative transition cost {cost}"
        );
        let s = self.from - cost;
        let (b, a) = (self.best[k], self.arg[k]);
        if s > b || (s == b && b > f64::NEG_INFINITY && self.i < a) {
            self.best[k] = s;
            self.arg[k] = self.i;
            self.dist[k] = dist_m;
        }
    }
}

/// One step of the max-product (Viterbi) recursion, exact but visiting few
/// pairs. `from`: the predecessors' scores (−∞: out of the chain). Into
/// `best`, `arg` and `dist`, for each of `nc` candidates: the best score
/// over the predecessors, the winning predecessor and its route distance;
/// `(−∞, 0, 0)` when none reaches it. `row(i, offers)` offers predecessor
/// `i`'s transitions into the candidates still [`Offers::open`] to it.
/// `order`: scratch.
///
/// The result is the full recursion's, bit for bit (each candidate's best
/// `from[i] − cost`, the lowest such `i` among equal scores, as a scan of
/// the predecessors in index order keeping the first maximum gives): as
/// the cost is never negative, `from[i] − cost <= from[i]` (also in
/// floating point), so predecessors visited in decreasing score (ties by
/// index) stop mattering for a candidate once its best so far exceeds
/// theirs, or equals it with a lower index; and once that holds for every
/// candidate it holds for every later predecessor too.
pub(super) fn max_product<F>(
    from: &[f64],
    nc: usize,
    order: &mut Vec<u32>,
    (best, arg, dist): (&mut Vec<f64>, &mut Vec<u32>, &mut Vec<f64>),
    mut row: F,
) where
    F: FnMut(usize, &mut Offers),
{
    best.clear();
    best.resize(nc, f64::NEG_INFINITY);
    arg.clear();
    arg.resize(nc, 0);
    dist.clear();
    dist.resize(nc, 0.0);
    order.clear();
    order.extend((0..from.len() as u32).filter(|&i| from[i as usize] != f64::NEG_INFINITY));
    // Stable: equal scores keep the index order.
    order.sort_by(|&a, &b| from[b as usize].total_cmp(&from[a as usize]));
    for &i in order.iter() {
        let mut offers = Offers {
            i,
            from: from[i as usize],
            best,
            arg,
            dist,
        };
        if !(0..nc).any(|k| offers.open(k)) {
            break;
        }
        row(i as usize, &mut offers);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalise_and_softmax_handle_degenerate_input() {
        let mut v = vec![0.0, 0.0];
        assert!(!normalise(&mut v));
        let mut out = Vec::new();
        softmax_into(&[f64::NEG_INFINITY, f64::NEG_INFINITY], &mut out);
        assert_eq!(out, vec![0.0, 0.0]);
        softmax_into(&[0.0, 0.0f64.ln_1p()], &mut out);
        assert!((out[0] - 0.5).abs() < 1e-12);
    }

    /// The full recursion [`max_product`] must equal: every pair, the
    /// predecessors in index order, the first maximum kept.
    fn full(from: &[f64], cost: &[Option<(f64, f64)>], nc: usize) -> Vec<(f64, u32, f64)> {
        (0..nc)
            .map(|k| {
                let mut b = (f64::NEG_INFINITY, 0, 0.0);
                for (i, f) in from.iter().enumerate() {
                    if *f == f64::NEG_INFINITY {
                        continue;
                    }
                    if let Some((c, d)) = cost[i * nc + k] {
                        let s = f - c;
                        if s > b.0 {
                            b = (s, i as u32, d);
                        }
                    }
                }
                b
            })
            .collect()
    }

    /// On many seeded random steps with few distinct values (ties in the
    /// scores, the costs and their differences; zero costs; predecessors
    /// out of the chain; pairs without a route), the pruned max-product
    /// step gives the full one's scores (bit for bit), winners and route
    /// distances, and visits fewer pairs.
    #[test]
    fn max_product_equals_the_full_recursion() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (mut visited, mut total, mut ties) = (0usize, 0usize, 0usize);
        let mut order = Vec::new();
        for case in 0..20_000 {
            let (np, nc) = (rng.random_range(1..12), rng.random_range(0..12));
            let levels = rng.random_range(1..5);
            let from: Vec<f64> = (0..np)
                .map(|_| match rng.random_range(0..8) {
                    0 => f64::NEG_INFINITY,
                    _ => -0.5 * rng.random_range(0..levels) as f64,
                })
                .collect();
            let cost: Vec<Option<(f64, f64)>> = (0..np * nc)
                .map(|_| {
                    (rng.random_range(0..5) > 0).then(|| {
                        (
                            0.5 * rng.random_range(0..levels) as f64,
                            rng.random_range(0..100) as f64,
                        )
                    })
                })
                .collect();
            let want = full(&from, &cost, nc);
            let (mut b, mut a, mut d) = (vec![1.0; 3], vec![9; 3], vec![]);
            max_product(
                &from,
                nc,
                &mut order,
                (&mut b, &mut a, &mut d),
                |i, offers| {
                    for k in 0..nc {
                        if offers.open(k) {
                            visited += 1;
                            if let Some((c, dist)) = cost[i * nc + k] {
                                offers.offer(k, c, dist);
                            }
                        }
                    }
                },
            );
            let best: Vec<(f64, u32, f64)> = (0..nc).map(|k| (b[k], a[k], d[k])).collect();
            let bits = |v: &[(f64, u32, f64)]| {
                v.iter()
                    .map(|(s, a, d)| (s.to_bits(), *a, d.to_bits()))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&best), bits(&want), "case {case}: {from:?} {cost:?}");
            total += np * nc;
            for (k, w) in want.iter().enumerate() {
                let n = (0..np)
                    .filter(|&i| {
                        from[i] > f64::NEG_INFINITY
                            && cost[i * nc + k].is_some_and(|(c, _)| from[i] - c == w.0)
                    })
                    .count();
                ties += usize::from(n > 1);
            }
        }
        assert!(ties > 10_000, "{ties}");
        assert!(visited < total * 3 / 4, "{visited} of {total}");
    }
}
