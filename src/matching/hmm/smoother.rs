//! The lag window's backward vector of its oldest step, kept incrementally.
//!
//! The oldest step's smoothed posterior needs β = W₁ W₂ ⋯ W_L 1, with W_t
//! the pair weights into the window's step t (rows: step t − 1's
//! candidates). Recomputed from scratch for every decided step this costs
//! L matrix–vector products per step (a quarter of `waymark match` on long
//! tracks, fourth round). Here the window is split at a step s (the
//! "two stacks" of sliding-window aggregation): for every step p from the
//! front to s the suffix products F_p = W_{p+1} ⋯ W_s are built once, when
//! the split is made (at the newest step, from there back to the front),
//! and the steps after s are folded into one product G = W_{s+1} ⋯ W_b as
//! they arrive; then β of the front step f is F_f (G 1). Per decided step
//! that is one matrix product for G, one for the rebuild (amortised: a
//! rebuild serves the whole window) and two matrix–vector products,
//! instead of L matrix–vector products.
//!
//! The same products in another order, so the same β up to rounding
//! (relative ~1e-15; every product is rescaled to a largest entry of 1,
//! which a posterior does not see). Where the old recursion would have met
//! a step whose backward vector vanishes (no permitted continuation) and
//! restarted it from ones, the product is zero: then, or on anything
//! unexpected, the caller falls back to the step-by-step recursion.

use super::state::Step;
use std::collections::VecDeque;

/// Incremental backward products of the lag window (see the module
/// documentation). Keyed by the steps' fix indices, so a window that
/// changed in any other way than by appending and deciding is rebuilt.
#[derive(Debug, Default)]
pub(super) struct Smoother {
    /// F_p for the steps from the front to the split: (fix index, start in
    /// `f_flat`, rows); every F has `split_n` columns.
    f: VecDeque<(u64, usize, usize)>,
    f_flat: Vec<f64>,
    split_n: usize,
    /// G (`split_n` × `g_cols`, row-major) and the fix index of the last
    /// step folded into it.
    g: Vec<f64>,
    g_cols: usize,
    last: u64,
    tmp: Vec<f64>,
    gv: Vec<f64>,
}

/// `out` = `a` (r × k) × `b` (k × c), rescaled to a largest entry of 1
/// (all zeros stay zeros); false if an entry is not finite.
fn mul_scaled(a: &[f64], b: &[f64], r: usize, k: usize, c: usize, out: &mut Vec<f64>) -> bool {
    out.clear();
    out.resize(r * c, 0.0);
    for i in 0..r {
        let row = &mut out[i * c..(i + 1) * c];
        for (j, &x) in a[i * k..(i + 1) * k].iter().enumerate() {
            if x != 0.0 {
                for (o, &y) in row.iter_mut().zip(&b[j * c..(j + 1) * c]) {
                    *o += x * y;
                }
            }
        }
    }
    let m = out.iter().copied().fold(0.0f64, f64::max);
    if !m.is_finite() {
        return false;
    }
    if m > 0.0 {
        let inv = 1.0 / m;
        out.iter_mut().for_each(|x| *x *= inv);
    }
    true
}

impl Smoother {
    /// Forgets everything (a new track, a flush).
    pub(super) fn clear(&mut self) {
        self.f.clear();
    }

    /// β of the window's front step (unnormalised) into `out`; false when
    /// the caller must use the step-by-step recursion instead.
    pub(super) fn front_beta(&mut self, window: &VecDeque<Step>, out: &mut Vec<f64>) -> bool {
        let len = window.len();
        if len < 2 {
            return false;
        }
        let front = window[0].index;
        while self.f.front().is_some_and(|e| e.0 < front) {
            self.f.pop_front();
        }
        let valid = self.f.front().is_some_and(|e| e.0 == front)
            && window.iter().any(|s| s.index == self.last);
        if !valid && !self.rebuild(window) {
            self.f.clear();
            return false;
        }
        // Fold the steps after the last one in G.
        let start = window.partition_point(|s| s.index <= self.last);
        for p in start..len {
            let (np, nc) = (window[p - 1].cands.len(), window[p].cands.len());
            if np != self.g_cols || window[p].pair.len() != np * nc {
                self.f.clear();
                return false;
            }
            let mut tmp = std::mem::take(&mut self.tmp);
            let ok = mul_scaled(&self.g, &window[p].pair, self.split_n, np, nc, &mut tmp);
            std::mem::swap(&mut self.g, &mut tmp);
            self.tmp = tmp;
            if !ok {
                self.f.clear();
                return false;
            }
            self.g_cols = nc;
            self.last = window[p].index;
        }
        // β = F_front (G 1).
        let mut gv = std::mem::take(&mut self.gv);
        gv.clear();
        gv.extend(
            self.g
                .chunks_exact(self.g_cols)
                .map(|row| row.iter().sum::<f64>()),
        );
        let (_, at, rows) = self.f[0];
        out.clear();
        out.extend(
            self.f_flat[at..at + rows * self.split_n]
                .chunks_exact(self.split_n)
                .map(|row| row.iter().zip(&gv).map(|(a, b)| a * b).sum::<f64>()),
        );
        self.gv = gv;
        let sum: f64 = out.iter().sum();
        rows == window[0].cands.len() && sum > 0.0 && sum.is_finite()
    }

    /// A new split at the newest step: F for every step back to the front,
    /// G the identity.
    fn rebuild(&mut self, window: &VecDeque<Step>) -> bool {
        let len = window.len();
        let n = window[len - 1].cands.len();
        self.split_n = n;
        self.f.clear();
        self.f_flat.clear();
        // F of the newest step: the identity.
        self.f_flat.resize(n * n, 0.0);
        (0..n).for_each(|i| self.f_flat[i * n + i] = 1.0);
        let mut entries = vec![(window[len - 1].index, 0usize, n)];
        let mut tmp = std::mem::take(&mut self.tmp);
        for p in (0..len - 1).rev() {
            let (np, nc) = (window[p].cands.len(), window[p + 1].cands.len());
            if window[p + 1].pair.len() != np * nc {
                self.tmp = tmp;
                return false;
            }
            let (_, at, rows) = *entries.last().expect("an entry");
            debug_assert_eq!(rows, nc);
            let ok = mul_scaled(
                &window[p + 1].pair,
                &self.f_flat[at..at + nc * n],
                np,
                nc,
                n,
                &mut tmp,
            );
            if !ok {
                self.tmp = tmp;
                return false;
            }
            let at = self.f_flat.len();
            self.f_flat.extend_from_slice(&tmp);
            entries.push((window[p].index, at, np));
        }
        self.tmp = tmp;
        self.f.extend(entries.into_iter().rev());
        self.g.clear();
        self.g.resize(n * n, 0.0);
        (0..n).for_each(|i| self.g[i * n + i] = 1.0);
        self.g_cols = n;
        self.last = window[len - 1].index;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::super::transitions::step_beta;
    use super::super::{HmmMatcher, HmmParams};
    use crate::matching::{Fix, Matcher};
    use crate::network::Network;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// Along a noisy drive over a real map (lines across it, so the window
    /// fills, breaks off road and restarts), the incremental β of the front
    /// step is the step-by-step recursion's to 1e-12 once both are
    /// normalised, after every fix; and the products are used (not only the
    /// fallback).
    #[test]
    fn incremental_front_beta_equals_the_step_by_step_recursion() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let ([x0, y0], [x1, y1]) = net.enu_bounds().unwrap();
        let mut m = HmmMatcher::new(&net, HmmParams::default());
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let noise = Normal::new(0.0, 4.0).unwrap();
        let (mut out, mut a, mut b, mut scratch) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut used, mut compared, mut longest) = (0, 0, 0);
        for i in 0..3000 {
            // Back and forth along diagonals of the map's box.
            let s = f64::from(i % 600) / 600.0;
            let lane = f64::from(i / 600) / 5.0;
            let fix = Fix {
                t_s: f64::from(i),
                enu: [
                    x0 + (x1 - x0) * s + noise.sample(&mut rng),
                    y0 + (y1 - y0) * (lane + (1.0 - lane) * s) + noise.sample(&mut rng),
                ],
                heading_rad: None,
            };
            m.push(&fix, &mut out);
            longest = longest.max(m.window.len());
            if m.window.len() < 2 {
                continue;
            }
            step_beta(&m.window, &mut b, &mut scratch);
            if m.smoother.front_beta(&m.window, &mut a) {
                used += 1;
                let (sa, sb) = (a.iter().sum::<f64>(), b.iter().sum::<f64>());
                for (x, y) in a.iter().zip(&b) {
                    assert!((x / sa - y / sb).abs() <= 1e-12, "{a:?} {b:?}");
                }
            }
            compared += 1;
        }
        assert!(used > compared * 9 / 10, "{used} of {compared}");
        // The window filled (decisions made from it) and emptied (breaks).
        assert!(
            longest == m.params.lag && compared > 1000,
            "{longest} {compared}"
        );
        assert!(!m.breaks().is_empty());
    }
}
