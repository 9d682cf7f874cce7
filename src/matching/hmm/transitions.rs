//! Transitions: the Viterbi recursion with per-survivor drift estimates,
//! and the forward–backward smoothing over the lag window.

use super::drift::{emission_with, innovation, Drift, Emission};
use super::geometry::dist;
use super::matcher::HmmMatcher;
use super::probability::{normalise, shift_max_to_zero, softmax_into};
use super::state::{Cand, Step};
use std::collections::VecDeque;

impl HmmMatcher<'_> {
    /// The common part of both models' transitions into `step`: the
    /// great-circle distance from the window's last fix, the longest route
    /// a transition may take, 1/β, and the buffers holding the route
    /// distance of every predecessor × candidate pair (`dist`,
    /// predecessor-major; the searches they need made first). The caller
    /// puts the buffers back in `self.trans_buf`.
    #[cfg(test)]
    pub(super) fn route_distances(
        &mut self,
        step: &Step,
    ) -> (f64, f64, f64, super::state::TransBuf) {
        let (gc, bound, inv_beta) = self.route_distances_into(step);
        (gc, bound, inv_beta, std::mem::take(&mut self.trans_buf))
    }

    /// [`Self::route_distances`] leaving the buffers in `self.trans_buf`
    /// (no move of them per step).
    fn route_distances_into(&mut self, step: &Step) -> (f64, f64, f64) {
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
        let bufs = &mut self.trans_buf;
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
        (gc, bound, inv_beta)
    }

    /// Viterbi recursion from the window's last step into `step`; false when
    /// no candidate can be reached from any previous one. Each candidate's
    /// emission is evaluated under the drift carried by each predecessor
    /// (predicted over the distance between the fixes), and the candidate
    /// takes over the winning predecessor's drift, updated with its own
    /// across-road innovation (per-survivor estimation).
    ///
    /// An emission is a function of the candidate's segment and the
    /// predecessor's predicted drift alone, so it is computed once per
    /// segment (the two directions of a section share its line) and per
    /// class of predecessors whose predicted drifts are equal bit for bit
    /// (states that took over the same drift and were updated by the same
    /// line: the two directions of a section again); its `ln` comes from a
    /// cache of exact logarithms. The class of the previous step's best
    /// state predicts the common drift, under which the candidate search
    /// ranked the candidates: its emissions' log-likelihoods are those the
    /// search computed (kept by section, found through the candidates'
    /// ranking keys), and a candidate whose best
    /// predecessor is of that class takes the innovation alone
    /// ([`innovation`]). The same numbers as the recursion that computes
    /// every pair's emission (`check::reference`, compared in the tests
    /// below).
    pub(super) fn transition(&mut self, step: &mut Step) -> bool {
        #[cfg(test)]
        let input = check::copy_if_checking(step);
        let prev = self.window.back().expect("a previous step");
        // Directed states (one per direction of travel, as the candidates
        // are made): each pair's route distance read from its
        // predecessor's search as the pair is visited; else from the
        // matrix of every pair.
        let directed = prev
            .cands
            .iter()
            .chain(&step.cands)
            .all(|c| c.at.forward.is_some());
        let (gc, bound, inv_beta) = if directed {
            let gc = dist(step.fix.enu, prev.fix.enu);
            let bound = self.route_bound(gc, step.fix.t_s - prev.fix.t_s);
            let inv_beta = 1.0 / (self.params.beta_m + self.params.beta_per_m * gc);
            // Every predecessor's searches held at once (see
            // `route_distances_into`).
            self.paths
                .ensure_exits(prev.cands.iter().map(|c| c.at), bound);
            (gc, bound, inv_beta)
        } else {
            self.route_distances_into(step)
        };
        let r2 = self.params.sigma_m * self.params.sigma_m;
        let (uturn, track) = (self.params.uturn_penalty_m, self.params.track_drift);
        let backtrack = self.params.backtrack_m;
        let bufs = &mut self.trans_buf;
        let preds = &mut self.pred_buf;
        let paths = &self.paths;
        preds.clear();
        let prev = self.window.back().expect("a previous step");
        let phi = Drift::decay(gc, self.params.drift_correlation_m.max(1e-6));
        preds.extend(
            prev.cands
                .iter()
                .map(|p| p.drift.predict_by(phi, self.params.drift_sigma_m)),
        );
        let (np, nc) = (prev.cands.len(), step.cands.len());
        step.pair.clear();
        step.pair.resize(np * nc, f64::NEG_INFINITY);
        // Each candidate's first candidate on the same segment (itself if
        // none), each predecessor's first with the same drift bits.
        bufs.twin.clear();
        for (k, c) in step.cands.iter().enumerate() {
            let j = step.cands[..k].iter().position(|o| o.seg == c.seg);
            bufs.twin.push(j.unwrap_or(k) as u32);
        }
        bufs.class.clear();
        for (i, d) in preds.iter().enumerate() {
            let j = preds[..i].iter().position(|o| o.same_bits(d));
            bufs.class.push(j.unwrap_or(i) as u32);
        }
        bufs.entries.clear();
        if directed {
            bufs.entries
                .extend(step.cands.iter().map(|c| paths.directed_entry(c.at)));
        }
        // Emissions by (drift class, first candidate on the segment),
        // class-major.
        // (Slots are marked when filled; the emissions' memory is only
        // grown, never cleared.)
        bufs.em_set.clear();
        bufs.em_set.resize(nc * np, false);
        if bufs.em.len() < nc * np {
            bufs.em.resize(nc * np, Emission::default());
        }
        // Each candidate's best score so far, its predecessor, the route
        // distance and the emission's slot: predecessors in index order,
        // the first maximum kept (as a scan of each candidate's
        // predecessors in index order gives).
        step.score.clear();
        step.score.resize(nc, f64::NEG_INFINITY);
        step.back.clear();
        step.back.resize(nc, 0);
        bufs.win_d.clear();
        bufs.win_d.resize(nc, 0.0);
        bufs.win_em.clear();
        bufs.win_em.resize(nc, 0);
        let ln = &mut bufs.ln;
        // The per-candidate vectors as slices of the candidates' number
        // (their indices checked once, not per pair).
        let (score, back) = (&mut step.score[..nc], &mut step.back[..nc]);
        let (win_d, win_em) = (&mut bufs.win_d[..nc], &mut bufs.win_em[..nc]);
        let twin = &bufs.twin[..nc];
        let entries = &bufs.entries[..if directed { nc } else { 0 }];
        let (em, em_set) = (&mut bufs.em[..nc * np], &mut bufs.em_set[..nc * np]);
        let cands = &step.cands[..nc];
        // The candidate search's emissions, under the common drift: the
        // best predecessor's predicted drift (checked bit for bit), so the
        // emissions of that predecessor's class. Only their
        // log-likelihoods: a winner of that class takes its innovation
        // from `innovation` (the same bits as the emission's).
        let best = self.drift_state as usize;
        let mut ranked = 0..0;
        if best < np && self.key_buf.len() == nc && preds[best].same_bits(&self.rank_drift) {
            let class = bufs.class[best] as usize;
            ranked = class * nc..(class + 1) * nc;
            let near = &self.near_lines[..];
            for (e, key) in em[ranked.clone()].iter_mut().zip(&self.key_buf) {
                e.log_p = near[(key.1 >> 1) as usize].3;
            }
            em_set[ranked.clone()].fill(true);
        }
        for (i, p) in prev.cands.iter().enumerate() {
            let from = prev.score[i];
            if from == f64::NEG_INFINITY {
                continue;
            }
            let (xn, xc) = if directed {
                paths.directed_exit(p.at)
            } else {
                (0, 0.0)
            };
            let src = paths.cached_source(xn);
            let row_em = bufs.class[i] as usize * nc;
            let pred = &preds[i];
            let row = &mut step.pair[i * nc..(i + 1) * nc];
            for (k, c) in cands.iter().enumerate() {
                let d = if directed {
                    src.directed_distance(p.at, xc, c.at, entries[k], backtrack)
                } else {
                    bufs.dist[i * nc + k]
                };
                let Some(d) = d else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                let charged = c.charged_from(p, d, uturn);
                let at = row_em + twin[k] as usize;
                let log_p = if em_set[at] {
                    em[at].log_p
                } else {
                    let e = emission_with(&c.line, step.fix.enu, pred, r2, |x| ln.ln(x));
                    em[at] = e;
                    em_set[at] = true;
                    e.log_p
                };
                let psi = log_p + c.heading - (charged - gc).abs() * inv_beta;
                row[k] = psi;
                let s = from + psi;
                if s > score[k] {
                    score[k] = s;
                    back[k] = i as u32;
                    win_d[k] = d;
                    win_em[k] = at as u32;
                }
            }
        }
        let mut any = false;
        #[cfg(test)]
        let mut ranked_winners = 0;
        for (k, c) in step.cands.iter_mut().enumerate() {
            if step.score[k] > f64::NEG_INFINITY {
                any = true;
                let arg = step.back[k] as usize;
                c.drift = preds[arg];
                if track {
                    let w = bufs.win_em[k] as usize;
                    let (normal, nu, s) = if ranked.contains(&w) {
                        #[cfg(test)]
                        {
                            ranked_winners += 1;
                        }
                        innovation(&c.line, step.fix.enu, &c.drift, r2)
                    } else {
                        let e = bufs.em[w];
                        (e.normal, e.nu, e.s)
                    };
                    c.drift.update(normal, nu, s);
                }
                c.set_anchor(Cand::anchor_through(&prev.cands[arg], bufs.win_d[k]));
            } else {
                c.set_anchor((c.dir, 0.0, c.road));
            }
        }
        if any {
            forward(step, &prev.alpha);
        }
        #[cfg(test)]
        check::against_reference(self, input, step, any, (!ranked.is_empty(), ranked_winners));
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
            if st.pair.len() == np * nc && nc > 0 {
                for (x, row) in next.iter_mut().zip(st.pair.chunks_exact(nc)) {
                    *x = row.iter().zip(beta).map(|(w, b)| w * b).sum::<f64>();
                }
            } else if st.pair.len() == np * nc {
                // (No candidate: every row's sum is empty.)
                next.iter_mut()
                    .for_each(|x| *x = std::iter::empty::<f64>().sum());
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

/// The forward (sum-product) recursion into `step` from the previous
/// step's forward vector `prev_alpha`, on the pair log-weights in
/// `step.pair` (made weights, scaled to a largest of 1, in place); the
/// Viterbi scores shifted to a largest of 0. Only when some candidate is
/// reached.
///
/// One pass over the rows after the largest log-weight: each row's weights
/// made and, when its predecessor's forward probability is positive,
/// added to the candidates' in the same order (predecessor by
/// predecessor) as the two passes it replaced (`check::forward_two_passes`,
/// compared in the tests): the same numbers.
fn forward(step: &mut Step, prev_alpha: &[f64]) {
    shift_max_to_zero(&mut step.score);
    let nc = step.cands.len();
    // The largest log-weight: `f64::max`'s fold but for the sign of a zero
    // (which `w − m` does not see: exp(±0) = 1, and `w − 0 = w − (−0)`
    // for any other `w`); NaN skipped as `f64::max` skips it.
    let mut m = f64::NEG_INFINITY;
    for &w in &step.pair {
        if w > m {
            m = w;
        }
    }
    step.alpha.clear();
    step.alpha.resize(nc, 0.0);
    let alpha = &mut step.alpha[..nc];
    for (i, row) in step.pair.chunks_exact_mut(nc.max(1)).enumerate() {
        for w in row.iter_mut() {
            // exp(−∞) = 0 without the call (pairs out of reach).
            *w = if *w == f64::NEG_INFINITY {
                0.0
            } else {
                (*w - m).exp()
            };
        }
        let a = prev_alpha.get(i).copied().unwrap_or(0.0);
        if a > 0.0 {
            for (x, w) in alpha.iter_mut().zip(&*row) {
                *x += a * w;
            }
        }
    }
    if !normalise(&mut step.alpha) {
        softmax_into(&step.score, &mut step.alpha);
    }
}

/// The recursion as it was before the emissions were shared by segment and
/// drift class (every pair's emission computed, but the two directions of
/// a section's), run beside [`HmmMatcher::transition`] on a copy of each
/// step while a test asks for it, and compared bit for bit.
#[cfg(test)]
pub(super) mod check {
    use super::super::drift::{emission, Drift, Emission};
    use super::super::matcher::HmmMatcher;
    use super::super::probability::{normalise, shift_max_to_zero, softmax_into};
    use super::super::state::{Cand, Step};
    use std::cell::Cell;

    /// What the comparisons covered.
    #[derive(Debug, Default, Clone, Copy)]
    pub(crate) struct Stats {
        /// Steps compared.
        pub(crate) steps: usize,
        /// Pairs within the route bound (an emission each in the
        /// reference), and of them those whose emission the fast path
        /// took from another pair: the other direction of the segment,
        /// another predecessor of the same drift, or both.
        pub(crate) pairs: usize,
        pub(crate) by_twin: usize,
        pub(crate) by_class: usize,
        pub(crate) by_both: usize,
        /// Steps no candidate of which is reached.
        pub(crate) unreached: usize,
        /// Steps where the common drift (that of the candidate search)
        /// equals the best predecessor's predicted drift bit for bit.
        pub(crate) common_is_best: usize,
        /// Steps whose emissions for that predecessor's class came from
        /// the candidate search, and the candidates that took their
        /// innovation from [`super::super::drift::innovation`] (their best
        /// predecessor in that class).
        pub(crate) ranked: usize,
        pub(crate) ranked_winners: usize,
    }

    thread_local! {
        /// `Some` while a test compares the two recursions.
        pub(crate) static STATS: Cell<Option<Stats>> = const { Cell::new(None) };
    }

    /// A copy of the step about to be transitioned, while checking.
    pub(super) fn copy_if_checking(step: &Step) -> Option<Step> {
        STATS.get()?;
        Some(Step {
            index: step.index,
            fix: step.fix,
            cands: step.cands.clone(),
            score: Vec::new(),
            back: Vec::new(),
            alpha: Vec::new(),
            pair: Vec::new(),
            pending: Vec::new(),
        })
    }

    /// Runs the reference recursion on `input` (the step before
    /// [`HmmMatcher::transition`]) and compares it with `step` (after).
    pub(super) fn against_reference(
        m: &mut HmmMatcher,
        input: Option<Step>,
        step: &Step,
        any: bool,
        (ranked, ranked_winners): (bool, usize),
    ) {
        let (Some(mut st), Some(mut full)) = (STATS.get(), input) else {
            return;
        };
        let mut n = [0usize; 4];
        // The common drift that placed and ranked this step's candidates,
        // against the best predecessor's drift predicted to this fix.
        let common_is_best = {
            let prev = m.window.back().expect("a previous step");
            let best = super::super::probability::argmax(&prev.score) as usize;
            let gc = super::dist(full.fix.enu, prev.fix.enu);
            let phi = Drift::decay(gc, m.params.drift_correlation_m.max(1e-6));
            let pred = prev.cands[best]
                .drift
                .predict_by(phi, m.params.drift_sigma_m);
            pred.same_bits(&m.common_drift(full.fix.enu))
        };
        let full_any = reference(m, &mut full, &mut n);
        assert_eq!(any, full_any, "reached");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&step.score), bits(&full.score), "scores");
        assert_eq!(step.back, full.back, "back-pointers");
        if any {
            assert_eq!(bits(&step.pair), bits(&full.pair), "pair weights");
            assert_eq!(bits(&step.alpha), bits(&full.alpha), "forward vector");
        }
        for (a, b) in step.cands.iter().zip(&full.cands) {
            assert!(a.drift.same_bits(&b.drift), "drift");
            assert_eq!(bits(&a.anchor_dir), bits(&b.anchor_dir), "anchor direction");
            assert_eq!(
                a.anchor_m.to_bits(),
                b.anchor_m.to_bits(),
                "anchor distance"
            );
            assert_eq!(a.anchor_road, b.anchor_road, "anchor road");
        }
        st.steps += 1;
        st.pairs += n[0];
        st.by_twin += n[1];
        st.by_class += n[2];
        st.by_both += n[3];
        st.unreached += usize::from(!any);
        st.common_is_best += usize::from(common_is_best);
        st.ranked += usize::from(ranked);
        st.ranked_winners += ranked_winners;
        STATS.set(Some(st));
    }

    /// The drift model's recursion as it was (each pair's emission
    /// computed with `f64::ln`, shared only with the other direction of
    /// the same section). Into `n`: the pairs evaluated, and of them those
    /// [`HmmMatcher::transition`] took from another candidate on the same
    /// segment, from another predecessor of the same drift, or both.
    fn reference(m: &mut HmmMatcher, step: &mut Step, n: &mut [usize; 4]) -> bool {
        let (gc, bound, inv_beta, bufs) = m.route_distances(step);
        // The fast path's classes (the buffers are scratch, rebuilt each step).
        let (fast_twin, fast_class) = (bufs.twin.clone(), bufs.class.clone());
        let r2 = m.params.sigma_m * m.params.sigma_m;
        let mut preds: Vec<Drift> = Vec::new();
        let prev = m.window.back().expect("a previous step");
        let phi = Drift::decay(gc, m.params.drift_correlation_m.max(1e-6));
        preds.extend(
            prev.cands
                .iter()
                .map(|p| p.drift.predict_by(phi, m.params.drift_sigma_m)),
        );
        let track = m.params.track_drift;
        let mut any = false;
        step.score.clear();
        step.back.clear();
        let (np, nc) = (prev.cands.len(), step.cands.len());
        step.pair.clear();
        step.pair.resize(np * nc, f64::NEG_INFINITY);
        let twin: Vec<u32> = (0..nc)
            .map(|k| {
                let c = &step.cands[k];
                let j = step.cands[..k].iter().position(|o| o.seg == c.seg);
                j.map_or(u32::MAX, |j| j as u32)
            })
            .collect();
        let mut em: Vec<Option<Emission>> = vec![None; nc * np];
        for (k, c) in step.cands.iter_mut().enumerate() {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0, c.road);
            let mut innovation: Option<Emission> = None;
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
                let (t, cl) = (fast_twin[k] as usize != k, fast_class[i] as usize != i);
                n[0] += 1;
                n[1] += usize::from(t && !cl);
                n[2] += usize::from(cl && !t);
                n[3] += usize::from(t && cl);
                let charged = c.charged_from(p, d, m.params.uturn_penalty_m);
                let shared = if twin[k] == u32::MAX {
                    None
                } else {
                    em[twin[k] as usize * np + i]
                };
                let e = match shared {
                    Some(e) => e,
                    None => emission(&c.line, step.fix.enu, &preds[i], r2),
                };
                em[k * np + i] = Some(e);
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
        m.trans_buf = bufs;
        if any {
            forward_two_passes(step, &prev.alpha);
        }
        any
    }

    /// The forward recursion as it was: every pair's weight made, then the
    /// rows added up (the code `super::forward` replaced).
    fn forward_two_passes(step: &mut Step, prev_alpha: &[f64]) {
        shift_max_to_zero(&mut step.score);
        let nc = step.cands.len();
        let m = step.pair.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for w in &mut step.pair {
            *w = if *w == f64::NEG_INFINITY {
                0.0
            } else {
                (*w - m).exp()
            };
        }
        step.alpha.clear();
        step.alpha.resize(nc, 0.0);
        for (i, a) in prev_alpha.iter().enumerate() {
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
}

#[cfg(test)]
mod tests {
    use super::check::{Stats, STATS};
    use crate::matching::inputs::read_track_file;
    use crate::matching::options::MatchOptions;
    use crate::matching::track::FileMatcher;
    use crate::matching::{match_track, Fix, HmmMatcher, HmmParams};
    use crate::network::{LoadOptions, Network};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use std::path::Path;

    fn load(rel: &str) -> Network {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
        Network::load(&p, &LoadOptions::default()).unwrap()
    }

    /// The drift model's transition with its emissions shared by segment
    /// and drift class and their logarithms cached equals the recursion
    /// computing each pair's emission (scores, back-pointers, pair
    /// weights, forward vectors and each state's drift and anchor, bit for
    /// bit) at every step of the real traces (each with the radius from σ̂
    /// and fastmm's 100 m and 80 m) and of seeded noisy drives across a
    /// map; and the shared emissions are used, by segment and by class.
    #[test]
    fn shared_emissions_equal_the_pairwise_recursion() {
        STATS.set(Some(Stats::default()));
        let d = "tests/data/real";
        let fmm = load(&format!("{d}/fmm-network.geojson"));
        let i13 = load(&format!("{d}/issue-13.osm"));
        let i70 = load(&format!("{d}/issue-70.osm"));
        let cases = [
            (&fmm, "fmm-trips.geojson"),
            (&i70, "issue-70.gpx"),
            (&i13, "issue-13.gpx"),
            (&i13, "issue-127.gpx"),
        ];
        for (net, track) in cases {
            let (rows, _) =
                read_track_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join(d).join(track))
                    .unwrap();
            for radius_m in [None, Some(100.0), Some(80.0)] {
                let opts = MatchOptions {
                    radius_m,
                    ..MatchOptions::default()
                };
                let (points, _) = FileMatcher::new(net).match_rows(&rows, &opts);
                assert_eq!(points.len(), rows.len(), "{track}");
            }
        }
        let real = STATS.get().unwrap();
        // Noisy drives along lines across two maps (off road at times:
        // breaks and new chains), fixes 3 m to 60 m apart.
        let small = load("tests/data/small.osm");
        for (net, spacing, seed) in [
            (&small, 3.0, 1),
            (&small, 10.0, 2),
            (&fmm, 20.0, 3),
            (&fmm, 60.0, 4),
        ] {
            let ([x0, y0], [x1, y1]) = net.enu_bounds().unwrap();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let noise = Normal::new(0.0, 5.0).unwrap();
            let len = (x1 - x0).hypot(y1 - y0);
            let n = (len / spacing) as usize;
            for lane in 0..8 {
                let fixes: Vec<Fix> = (0..n)
                    .map(|i| {
                        let s = i as f64 / n as f64;
                        let l = f64::from(lane) / 8.0;
                        Fix {
                            t_s: i as f64 * spacing / 10.0,
                            enu: [
                                x0 + (x1 - x0) * s + noise.sample(&mut rng),
                                y0 + (y1 - y0) * (l + (1.0 - l) * s) + noise.sample(&mut rng),
                            ],
                            heading_rad: None,
                        }
                    })
                    .collect();
                let mut m = HmmMatcher::new(net, HmmParams::default());
                assert_eq!(match_track(&mut m, &fixes).len(), fixes.len());
            }
        }
        let all = STATS.get().unwrap();
        STATS.set(None);
        println!("real traces: {real:?}\nall: {all:?}");
        assert!(real.steps > 100, "{real:?}");
        assert!(all.steps > real.steps + 500, "{all:?}");
        // Sharing by segment, by drift class and by both exercised.
        assert!(
            real.by_twin > 0 && real.by_class > 0 && real.by_both > 0,
            "{real:?}"
        );
        assert!(all.unreached > 0, "{all:?}");
        // The candidate search's drift is the best predecessor's predicted
        // drift at every step (so its emissions are the transition's for
        // that predecessor's class).
        assert_eq!(all.common_is_best, all.steps, "{all:?}");
        // And the transition takes them, at every step; winners of that
        // class take their innovation without the emission.
        assert_eq!(all.ranked, all.steps, "{all:?}");
        assert!(real.ranked_winners > 100, "{real:?}");
    }
}
