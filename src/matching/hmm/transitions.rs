//! Transitions: the Viterbi recursion with per-survivor drift estimates,
//! and the forward–backward smoothing over the lag window.

use super::drift::{emission, Drift, Emission};
use super::geometry::dist;
use super::matcher::HmmMatcher;
use super::probability::{normalise, shift_max_to_zero, softmax_into};
use super::state::{Cand, Step, TransBuf};
use std::collections::VecDeque;

impl HmmMatcher<'_> {
    /// The common part of both models' transitions into `step`: the
    /// great-circle distance from the window's last fix, the longest route
    /// a transition may take, 1/β, and the buffers holding the route
    /// distance of every predecessor × candidate pair (`dist`,
    /// predecessor-major; the searches they need made first). The caller
    /// puts the buffers back in `self.trans_buf`.
    pub(super) fn route_distances(&mut self, step: &Step) -> (f64, f64, f64, TransBuf) {
        let prev = self.window.back().expect("a previous step");
        let gc = dist(step.fix.enu, prev.fix.enu);
        let bound = self.route_bound(gc, step.fix.t_s - prev.fix.t_s);
        let inv_beta = 1.0 / (self.params.beta_m + self.params.beta_per_m * gc);
        // Every predecessor's searches held at once, also when the cache
        // fills part-way (a search emptying it would drop the earlier ones,
        // and the matrix would read those pairs as out of reach).
        self.paths
            .ensure_exits(prev.cands.iter().map(|c| c.at), bound);
        let prev = self.window.back().expect("a previous step");
        let mut bufs = std::mem::take(&mut self.trans_buf);
        bufs.from.clear();
        bufs.from.extend(prev.cands.iter().map(|c| c.at));
        bufs.at.clear();
        bufs.at.extend(step.cands.iter().map(|c| c.at));
        self.paths.point_distance_matrix(
            &bufs.from,
            &bufs.at,
            self.params.backtrack_m,
            &mut bufs.scratch,
            &mut bufs.dist,
        );
        (gc, bound, inv_beta, bufs)
    }

    /// Viterbi recursion from the window's last step into `step`; false when
    /// no candidate can be reached from any previous one. Each candidate's
    /// emission is evaluated under the drift carried by each predecessor
    /// (predicted over the distance between the fixes), and the candidate
    /// takes over the winning predecessor's drift, updated with its own
    /// across-road innovation (per-survivor estimation).
    pub(super) fn transition(&mut self, step: &mut Step) -> bool {
        let (gc, bound, inv_beta, mut bufs) = self.route_distances(step);
        let r2 = self.params.sigma_m * self.params.sigma_m;
        let mut preds = std::mem::take(&mut self.pred_buf);
        preds.clear();
        let prev = self.window.back().expect("a previous step");
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
        // The two directions of a section share its line, so their emissions
        // under a predecessor's drift are equal: computed once per segment.
        bufs.twin.clear();
        for (k, c) in step.cands.iter().enumerate() {
            let j = step.cands[..k].iter().position(|o| o.seg == c.seg);
            bufs.twin.push(j.map_or(u32::MAX, |j| j as u32));
        }
        bufs.em.clear();
        bufs.em.resize(nc * np, None);
        for (k, c) in step.cands.iter_mut().enumerate() {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0, c.road);
            let mut innovation: Option<Emission> = None;
            let twin = bufs.twin[k];
            for (i, p) in prev.cands.iter().enumerate() {
                if prev.score[i] == f64::NEG_INFINITY {
                    continue;
                }
                let Some(d) = bufs.dist[i * nc + k] else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                let charged = c.charged_from(p, d, self.params.uturn_penalty_m);
                let shared = if twin == u32::MAX {
                    None
                } else {
                    bufs.em[twin as usize * np + i]
                };
                let e = match shared {
                    Some(e) => e,
                    None => emission(&c.line, step.fix.enu, &preds[i], r2),
                };
                bufs.em[k * np + i] = Some(e);
                let psi = e.log_p + c.heading - (charged - gc).abs() * inv_beta;
                step.pair[i * nc + k] = psi;
                let s = prev.score[i] + psi;
                if s > best {
                    best = s;
                    arg = i as u32;
                    innovation = Some(e);
                    anchor = Cand::anchor_through(p, d);
                }
            }
            if let Some(e) = innovation {
                any = true;
                c.drift = preds[arg as usize];
                if track {
                    c.drift.update(e.normal, e.nu, e.s);
                }
            }
            c.set_anchor(anchor);
            step.score.push(best);
            step.back.push(arg);
        }
        self.trans_buf = bufs;
        self.pred_buf = preds;
        if any {
            shift_max_to_zero(&mut step.score);
            // Forward (sum-product) recursion on the same weights.
            let m = step.pair.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for w in &mut step.pair {
                // exp(−∞) = 0 without the call (pairs out of reach).
                *w = if *w == f64::NEG_INFINITY {
                    0.0
                } else {
                    (*w - m).exp()
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
        any
    }

    /// The backward vector of every step in the window given every fix in
    /// it, one after another, and where each step's starts: one backward
    /// pass (with the forward vectors, what [`Self::front_posterior`] gives
    /// for each step in turn as the window is emitted from its front, at
    /// the cost of one pass instead of one per step). Reuses the matcher's
    /// buffers (take them back into `beta_flat`).
    pub(super) fn window_betas(&mut self) -> (Vec<f64>, Vec<usize>) {
        let (mut flat, mut at) = std::mem::take(&mut self.beta_flat);
        let len = self.window.len();
        at.clear();
        let mut total = 0;
        for st in &self.window {
            at.push(total);
            total += st.cands.len();
        }
        flat.clear();
        flat.resize(total, 1.0);
        for t in (1..len).rev() {
            let (st, np) = (&self.window[t], self.window[t - 1].cands.len());
            let nc = st.cands.len();
            let (head, tail) = flat.split_at_mut(at[t]);
            let beta = &tail[..nc];
            let next = &mut head[at[t - 1]..at[t - 1] + np];
            if st.pair.len() == np * nc {
                for (i, x) in next.iter_mut().enumerate() {
                    *x = st.pair[i * nc..(i + 1) * nc]
                        .iter()
                        .zip(beta)
                        .map(|(w, b)| w * b)
                        .sum::<f64>();
                }
            }
            // (A chain's first step: ones, normalised as the others.)
            if !normalise(next) {
                next.iter_mut().for_each(|x| *x = 1.0);
            }
        }
        (flat, at)
    }

    /// The smoothed posterior of the window's oldest step given every fix in
    /// the window (forward–backward over the lag window) into `out`.
    pub(super) fn front_posterior(&mut self, out: &mut Vec<f64>) {
        let [mut beta, mut next] = std::mem::take(&mut self.beta_bufs);
        // The incremental products where they apply, else step by step.
        if !self.smoother.front_beta(&self.window, &mut beta) {
            step_beta(&self.window, &mut beta, &mut next);
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

/// The backward vector of the window's oldest step by the step-by-step
/// recursion (each step's vector normalised; a vanishing one, or a chain's
/// first step, restarts from ones) into `beta`, with `next` as scratch.
pub(super) fn step_beta(window: &VecDeque<Step>, beta: &mut Vec<f64>, next: &mut Vec<f64>) {
    let len = window.len();
    beta.clear();
    beta.resize(window[len - 1].cands.len(), 1.0);
    for t in (1..len).rev() {
        let (st, np) = (&window[t], window[t - 1].cands.len());
        let nc = st.cands.len();
        next.clear();
        if st.pair.len() != np * nc {
            next.resize(np, 1.0);
        } else {
            next.extend((0..np).map(|i| {
                st.pair[i * nc..(i + 1) * nc]
                    .iter()
                    .zip(beta.iter())
                    .map(|(w, b)| w * b)
                    .sum::<f64>()
            }));
            if !normalise(next) {
                next.iter_mut().for_each(|x| *x = 1.0);
            }
        }
        std::mem::swap(beta, next);
    }
}
