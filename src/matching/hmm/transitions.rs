//! Transitions: the Viterbi recursion with per-survivor drift estimates,
//! and the forward–backward smoothing over the lag window.
//!
//! Pruning by bounds (exact for the Viterbi path). A pair's weight is ψ =
//! emission + heading + transition, with the transition −|d − gc|/β ≤ 0
//! and the emission at most its quadratic part less ½ (1 − r²/S) (ln x ≥ 1
//! − 1/x; [`super::drift::Quad::bound`]): an upper bound U of ψ costs a
//! few multiplications, where ψ itself needs a route distance (a network
//! search when cold), a logarithm and, for the forward weights, an
//! exponential. Each candidate visits its predecessors by decreasing score
//! V and skips a predecessor when both
//! - V + U < the best score found so far for the candidate (the pair cannot
//!   win the Viterbi step, so the arg-max, the scores and the drift taken
//!   over are exactly those of evaluating every pair), and
//! - ln α + U ≤ ln(ε / n) + the largest ln α + ψ of the pairs evaluated for
//!   the candidate (n predecessors, ε = [`FORWARD_TOLERANCE`]): the skipped
//!   pairs' forward mass, at most n of them, is within ε of the candidate's
//!   forward mass kept.
//!
//! The second rule bounds what the smoothed confidence loses: a skipped
//! pair's weight on every path through it is at most ε/n of the weight of
//! the candidate's kept pairs on the same paths (the backward factor is the
//! candidate's, common to all its pairs), so each step drops at most a
//! share ε of the total path weight and every smoothed probability moves by
//! at most about 2ε per step of the lag window: 2 × 32 × 1e-9 < 1e-7 with the
//! defaults, far below the confidence's printed 1e-3.
//! `tests/matching_pruning.rs` checks both against [`HmmMatcher::exhaustive`].

use super::drift::{emission_quad, Drift, Quad};
use super::geometry::dist;
use super::matcher::HmmMatcher;
use super::probability::{normalise, softmax_into};
use super::state::{Step, ANCHOR_M};

/// Share of a candidate's forward mass the pruned pairs may carry at most
/// (see the module documentation).
pub(super) const FORWARD_TOLERANCE: f64 = 1e-9;

/// Added to every bound so that rounding can never put a pair's weight above
/// its bound (weights are O(1)–O(1e3); rounding errors O(1e-13)).
const BOUND_MARGIN: f64 = 1e-9;

impl HmmMatcher<'_> {
    /// Viterbi recursion from the window's last step into `step`; false when
    /// no candidate can be reached from any previous one. Each candidate's
    /// emission is evaluated under the drift carried by each predecessor
    /// (predicted over the distance between the fixes), and the candidate
    /// takes over the winning predecessor's drift, updated with its own
    /// across-road innovation (per-survivor estimation). Pairs that bounds
    /// rule out are skipped (the module documentation).
    pub(super) fn transition(&mut self, step: &mut Step) -> bool {
        let prev = self.window.back().expect("a previous step");
        let gc = dist(step.fix.enu, prev.fix.enu);
        let bound = self.route_bound(gc, step.fix.t_s - prev.fix.t_s);
        let backtrack = self.params.backtrack_m;
        let inv_beta = 1.0 / (self.params.beta_m + self.params.beta_per_m * gc);
        let r2 = self.params.sigma_m * self.params.sigma_m;
        let uturn_m = self.params.uturn_penalty_m;
        let prune = self.prune;
        let mut preds = std::mem::take(&mut self.pred_buf);
        preds.clear();
        let phi = Drift::decay(gc, self.params.drift_correlation_m.max(1e-6));
        preds.extend(
            prev.cands
                .iter()
                .map(|p| p.drift.predict_by(phi, self.params.drift_sigma_m)),
        );
        let track = self.params.track_drift;
        let mut any = false;
        step.score.clear();
        step.back.clear();
        let (np, nc) = (prev.cands.len(), step.cands.len());
        step.pair.clear();
        step.pair.resize(np * nc, f64::NEG_INFINITY);
        let mut bufs = std::mem::take(&mut self.trans_buf);
        bufs.from.clear();
        bufs.from.extend(prev.cands.iter().map(|c| c.at));
        bufs.at.clear();
        bufs.at.extend(step.cands.iter().map(|c| c.at));
        self.paths
            .prepare_pairs(&bufs.from, &bufs.at, bound, backtrack, &mut bufs.pairs);
        // Predecessors by decreasing score (those out of reach left out),
        // and their log forward probabilities.
        bufs.order.clear();
        bufs.order
            .extend((0..np as u32).filter(|&i| prev.score[i as usize] != f64::NEG_INFINITY));
        bufs.order.sort_unstable_by(|&a, &b| {
            prev.score[b as usize]
                .total_cmp(&prev.score[a as usize])
                .then(a.cmp(&b))
        });
        bufs.log_alpha.clear();
        bufs.log_alpha.extend(prev.alpha.iter().map(|a| a.ln()));
        let ln_tol = (FORWARD_TOLERANCE / np as f64).ln();
        // The two directions of a section share its line, so their emissions
        // under a predecessor's drift are equal: computed once per segment.
        bufs.twin.clear();
        for (k, c) in step.cands.iter().enumerate() {
            let j = step.cands[..k].iter().position(|o| o.seg == c.seg);
            bufs.twin.push(j.map_or(u32::MAX, |j| j as u32));
        }
        bufs.em.clear();
        bufs.em.resize(nc * np, None);
        bufs.scale.clear();
        bufs.scale.resize(nc * np, 1.0);
        for (k, c) in step.cands.iter_mut().enumerate() {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0, c.road);
            let mut innovation: Option<Quad> = None;
            // The largest ln α + ψ over the pairs evaluated.
            let mut kept = f64::NEG_INFINITY;
            let twin = bufs.twin[k];
            for &iu in &bufs.order {
                let i = iu as usize;
                let p = &prev.cands[i];
                // A route is no shorter than the straight line between its
                // ends (a section's length is the sum of its segments'), so
                // a pair whose points lie farther apart than the bound is out
                // of reach, and the transition's charge is at least the
                // straight line's excess over the fixes' distance.
                let e_m = dist(p.pt, c.pt) * (1.0 - 1e-9) - 1e-6;
                if e_m > bound {
                    continue;
                }
                let t_upper = -(e_m - gc).max(0.0) * inv_beta;
                // The emission's quadratic part (shared by the two directions
                // of a segment), and its log-likelihood when computed.
                let (q, known) = match (twin != u32::MAX)
                    .then(|| bufs.em[twin as usize * np + i])
                    .flatten()
                {
                    Some(shared) => shared,
                    None => (
                        emission_quad(&c.line, step.fix.enu, &preds[i], r2),
                        f64::NAN,
                    ),
                };
                bufs.em[k * np + i] = Some((q, known));
                let upper = if known.is_nan() { q.bound(r2) } else { known };
                let v_out = |t: f64| prev.score[i] + upper + c.heading + t + BOUND_MARGIN < best;
                if prune
                    && v_out(t_upper)
                    && bufs.log_alpha[i] + upper + c.heading + t_upper + BOUND_MARGIN
                        <= ln_tol + kept
                {
                    continue;
                }
                let Some(d) = self.paths.pair_distance(&mut bufs.pairs, i, k) else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                // Facing the other way after a short drive: a U-turn (at a
                // node or round a small loop, in one transition or over a few).
                let dot = |u: [f64; 2]| u[0] * c.dir[0] + u[1] * c.dir[1];
                let turned = (dot(p.dir) < -0.5 && d < uturn_m)
                    || (dot(p.anchor_dir) < -0.5
                        && p.anchor_m + d < 2.0 * ANCHOR_M
                        && p.anchor_road == c.road);
                let charged = if turned { d + uturn_m } else { d };
                let t = -(charged - gc).abs() * inv_beta;
                if prune && known.is_nan() && v_out(t) {
                    // Needed by the forward weights only: the weight without
                    // the logarithm, exp(quad + heading + t) · (r²/S)^½,
                    // scaled when the weights are formed.
                    let w = q.quad + c.heading + t;
                    step.pair[i * nc + k] = w;
                    let root = (q.s / r2).sqrt();
                    bufs.scale[i * nc + k] = 1.0 / root;
                    // ln x = 2 ln √x ≤ 2 (√x − 1): a lower bound of ψ.
                    kept = kept.max(bufs.log_alpha[i] + w + (1.0 - root));
                    continue;
                }
                let log_p = if known.is_nan() { q.finish(r2) } else { known };
                bufs.em[k * np + i] = Some((q, log_p));
                let psi = log_p + c.heading + t;
                step.pair[i * nc + k] = psi;
                kept = kept.max(bufs.log_alpha[i] + psi);
                let s = prev.score[i] + psi;
                // The first best in index order, whatever the visiting order.
                if s > best || (s == best && iu < arg) {
                    best = s;
                    arg = iu;
                    innovation = Some(q);
                    anchor = if p.anchor_m + d > ANCHOR_M {
                        (p.dir, d, p.road)
                    } else {
                        (p.anchor_dir, p.anchor_m + d, p.anchor_road)
                    };
                }
            }
            if let Some(q) = innovation {
                any = true;
                c.drift = preds[arg as usize];
                if track {
                    c.drift.update(q.normal, q.nu, q.s);
                }
            }
            c.anchor_dir = anchor.0;
            c.anchor_m = anchor.1;
            c.anchor_road = anchor.2;
            step.score.push(best);
            step.back.push(arg);
        }
        self.pred_buf = preds;
        if any {
            // Renormalise so scores stay near zero on long tracks.
            let m = step.score.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for s in &mut step.score {
                *s -= m;
            }
            // Forward (sum-product) recursion on the same weights.
            let m = step.pair.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for (w, f) in step.pair.iter_mut().zip(&bufs.scale) {
                // exp(−∞) = 0 without the call (pairs out of reach or pruned).
                *w = if *w == f64::NEG_INFINITY {
                    0.0
                } else {
                    (*w - m).exp() * f
                };
            }
            step.alpha.clear();
            step.alpha.resize(nc, 0.0);
            for (i, a) in prev.alpha.iter().enumerate() {
                if *a > 0.0 {
                    for (x, w) in step.alpha.iter_mut().zip(&step.pair[i * nc..(i + 1) * nc]) {
                        *x += a * w;
                    }
                }
            }
            if !normalise(&mut step.alpha) {
                softmax_into(&step.score, &mut step.alpha);
            }
        }
        self.trans_buf = bufs;
        any
    }

    /// The smoothed posterior of every step in the window given every fix
    /// in it: one backward pass (what [`Self::front_posterior`] gives for
    /// each step in turn as the window is emitted from its front, at the
    /// cost of one pass instead of one per step).
    pub(super) fn window_posteriors(&self) -> Vec<Vec<f64>> {
        let len = self.window.len();
        let mut betas: Vec<Vec<f64>> = vec![Vec::new(); len];
        betas[len - 1] = vec![1.0; self.window[len - 1].cands.len()];
        for t in (1..len).rev() {
            let (st, np) = (&self.window[t], self.window[t - 1].cands.len());
            let nc = st.cands.len();
            let beta = &betas[t];
            let mut next: Vec<f64> = if st.pair.len() != np * nc {
                vec![1.0; np]
            } else {
                (0..np)
                    .map(|i| {
                        st.pair[i * nc..(i + 1) * nc]
                            .iter()
                            .zip(beta)
                            .map(|(w, b)| w * b)
                            .sum::<f64>()
                    })
                    .collect()
            };
            if !normalise(&mut next) {
                next.iter_mut().for_each(|x| *x = 1.0);
            }
            betas[t - 1] = next;
        }
        betas
            .into_iter()
            .zip(&self.window)
            .map(|(beta, step)| {
                let mut out: Vec<f64> = step.alpha.iter().zip(&beta).map(|(a, b)| a * b).collect();
                if !normalise(&mut out) {
                    softmax_into(&step.score, &mut out);
                }
                out
            })
            .collect()
    }

    /// The smoothed posterior of the window's oldest step given every fix in
    /// the window (forward–backward over the lag window) into `out`.
    pub(super) fn front_posterior(&mut self, out: &mut Vec<f64>) {
        let len = self.window.len();
        let [mut beta, mut next] = std::mem::take(&mut self.beta_bufs);
        beta.clear();
        beta.resize(self.window[len - 1].cands.len(), 1.0);
        for t in (1..len).rev() {
            let (st, np) = (&self.window[t], self.window[t - 1].cands.len());
            let nc = st.cands.len();
            next.clear();
            if st.pair.len() != np * nc {
                next.resize(np, 1.0);
            } else {
                next.extend((0..np).map(|i| {
                    st.pair[i * nc..(i + 1) * nc]
                        .iter()
                        .zip(&beta)
                        .map(|(w, b)| w * b)
                        .sum::<f64>()
                }));
                if !normalise(&mut next) {
                    next.iter_mut().for_each(|x| *x = 1.0);
                }
            }
            std::mem::swap(&mut beta, &mut next);
        }
        let front = &self.window[0];
        out.clear();
        out.extend(front.alpha.iter().zip(&beta).map(|(a, b)| a * b));
        if !normalise(out) {
            softmax_into(&front.score, out);
        }
        self.beta_bufs = [beta, next];
    }
}
