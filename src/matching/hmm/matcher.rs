//! The matcher: its window and state, deciding the oldest step, and the
//! [`Matcher`] interface.

use super::drift::{innovation, Drift};
use super::geometry::{clamp_to_range, dist, nearest_on_pieces, with_raw};
use super::params::{route_bound, HmmModel, HmmParams};
use super::probability::{argmax, normalise, softmax_into};
use super::state::Step;
use crate::matching::paths::NetworkDistances;
use crate::matching::{matched_on, Break, BreakReason, Fix, MatchState, MatchedPoint, Matcher};
use crate::network::{Network, SectionId, SegmentId};
use std::collections::VecDeque;

/// The HMM matcher; see the module documentation.
#[derive(Debug)]
pub struct HmmMatcher<'a> {
    pub(super) net: &'a Network,
    pub(super) params: HmmParams,
    pub(super) paths: NetworkDistances<'a>,
    pub(super) window: VecDeque<Step>,
    pub(super) index: u64,
    pub(super) last_fix: Option<Fix>,
    pub(super) last_step_pos: Option<[f64; 2]>,
    pub(super) pending_break: Option<BreakReason>,
    pub(super) last_matched: Option<(u64, f64)>,
    pub(super) breaks: Vec<Break>,
    /// The drift of the newest step's best state, and where that fix was:
    /// the common estimate that places and ranks the next step's candidates
    /// and starts a new chain after a break.
    pub(super) drift: Drift,
    pub(super) drift_at: Option<[f64; 2]>,
    /// That state's index in the newest step (a hint: checked before use).
    pub(super) drift_state: u32,
    pub(super) seg_buf: Vec<SegmentId>,
    pub(super) near_buf: Vec<(SectionId, SegmentId, f64, f64)>,
    /// The candidates' ranking keys, and the logarithms they took.
    pub(super) key_buf: Vec<(f64, u32)>,
    /// The candidate search's scratch: by section id, its index in
    /// `near_buf` (`u32::MAX` when not listed; reset after each search);
    /// by index in `near_buf`, the segment's line, the heading terms of
    /// its two directions and its emission's log-likelihood.
    pub(super) near_slot: Vec<u32>,
    pub(super) near_lines: Vec<(super::drift::Line, f64, f64, f64)>,
    /// The drift the last candidate search placed and ranked with (its
    /// candidates' `log_p` are under it).
    pub(super) rank_drift: Drift,
    pub(super) ln_cache: super::drift::LnCache,
    pub(super) post_buf: Vec<f64>,
    /// The backward pass's two vectors.
    pub(super) beta_bufs: [Vec<f64>; 2],
    /// The front step's backward vector, kept incrementally.
    pub(super) smoother: super::smoother::Smoother,
    pub(super) pred_buf: Vec<Drift>,
    pub(super) spare: Vec<Step>,
    pub(super) trans_buf: super::state::TransBuf,
    /// The back-traced choices; every step's backward vector, one after
    /// another, and where each starts (a flush's single backward pass).
    pub(super) choice_buf: Vec<u32>,
    pub(super) beta_flat: (Vec<f64>, Vec<usize>),
    /// The decided path between two steps (kept: no allocation per step).
    pub(super) path_buf: Vec<(SectionId, f64, f64)>,
}

impl<'a> HmmMatcher<'a> {
    /// A matcher on `net`.
    pub fn new(net: &'a Network, params: HmmParams) -> Self {
        Self::with_distances(net, params, NetworkDistances::new(net))
    }

    /// A matcher on `net` starting from the network searches of `paths`
    /// (e.g. those of the previous track of a file: [`Self::into_distances`]).
    pub fn with_distances(
        net: &'a Network,
        params: HmmParams,
        mut paths: NetworkDistances<'a>,
    ) -> Self {
        paths.uturn_penalty_m = params.uturn_penalty_m;
        Self {
            net,
            params,
            paths,
            window: VecDeque::with_capacity(params.lag + 1),
            index: 0,
            last_fix: None,
            last_step_pos: None,
            pending_break: None,
            last_matched: None,
            breaks: Vec::new(),
            drift: Drift::prior(params.drift_sigma_m),
            drift_at: None,
            drift_state: 0,
            seg_buf: Vec::with_capacity(64),
            near_buf: Vec::with_capacity(64),
            key_buf: Vec::with_capacity(64),
            near_slot: Vec::new(),
            near_lines: Vec::new(),
            rank_drift: Drift::prior(params.drift_sigma_m),
            ln_cache: Default::default(),
            post_buf: Vec::with_capacity(params.max_candidates),
            beta_bufs: [
                Vec::with_capacity(params.max_candidates),
                Vec::with_capacity(params.max_candidates),
            ],
            smoother: Default::default(),
            pred_buf: Vec::with_capacity(params.max_candidates),
            spare: Vec::new(),
            trans_buf: super::state::TransBuf::with_capacity(params.max_candidates),
            choice_buf: Vec::with_capacity(params.lag + 1),
            beta_flat: (Vec::new(), Vec::new()),
            path_buf: Vec::new(),
        }
    }

    /// Makes this matcher a fresh one with `params` for the next track
    /// (what [`Self::with_distances`] gives with this matcher's network
    /// searches), keeping its buffers: a file of many short tracks does not
    /// allocate them again for each.
    pub fn restart(&mut self, params: HmmParams) {
        self.params = params;
        self.paths.uturn_penalty_m = params.uturn_penalty_m;
        self.spare.extend(self.window.drain(..));
        self.smoother.clear();
        self.index = 0;
        self.last_fix = None;
        self.last_step_pos = None;
        self.pending_break = None;
        self.last_matched = None;
        self.breaks.clear();
        self.drift = Drift::prior(params.drift_sigma_m);
        self.drift_at = None;
    }

    /// The matcher's cached network searches (for the complete path, whose
    /// joins are mostly the transitions the matcher already searched).
    pub fn distances_mut(&mut self) -> &mut NetworkDistances<'a> {
        &mut self.paths
    }

    /// The matcher's network searches, to start the next track's matcher.
    pub fn into_distances(self) -> NetworkDistances<'a> {
        self.paths
    }

    /// Steps currently held in the lag window.
    pub fn window_len(&self) -> usize {
        self.window.len()
    }

    /// Fixes currently held (steps and the fixes between them).
    pub fn held_fixes(&self) -> usize {
        self.window.iter().map(|s| 1 + s.pending.len()).sum()
    }

    /// The drift predicted over `ds_m` metres from `d`.
    pub(super) fn predict(&self, d: &Drift, ds_m: f64) -> Drift {
        d.predict(
            ds_m,
            self.params.drift_correlation_m.max(1e-6),
            self.params.drift_sigma_m,
        )
    }

    /// The common drift predicted to the fix at `p`.
    pub(super) fn common_drift(&self, p: [f64; 2]) -> Drift {
        if self.independent() {
            // The independent model's drift is its prior, always.
            return Drift::prior(self.params.drift_sigma_m);
        }
        match self.drift_at {
            Some(q) => self.predict(&self.drift, dist(p, q)),
            None => self.drift,
        }
    }

    /// Is the model [`HmmModel::Independent`]?
    pub(super) fn independent(&self) -> bool {
        self.params.model == HmmModel::Independent
    }

    /// The longest route a transition may take ([`route_bound`]).
    pub(super) fn route_bound(&self, gc_m: f64, dt_s: f64) -> f64 {
        route_bound(&self.params, gc_m, dt_s)
    }

    /// Back-traces the window from its newest step's best state: the chosen
    /// candidate of the first `n` steps.
    fn choices(&self, n: usize, out: &mut Vec<u32>) {
        out.clear();
        let len = self.window.len();
        out.resize(len, 0);
        let last = &self.window[len - 1];
        let mut k = argmax(&last.score);
        for i in (0..len).rev() {
            out[i] = k;
            if i > 0 {
                k = self.window[i].back[k as usize];
            }
        }
        out.truncate(n);
    }

    /// Decides and emits the oldest step (given its choice and the next step's).
    /// `known`: the front step's smoothed posterior is already in
    /// `post_buf` (a flush computes every step's in one backward pass).
    fn emit_front(
        &mut self,
        choice: u32,
        next_choice: Option<u32>,
        known: bool,
        out: &mut Vec<MatchedPoint>,
    ) {
        let mut post = std::mem::take(&mut self.post_buf);
        if !known {
            if self.independent() {
                self.front_filtered(&mut post);
            } else {
                self.front_posterior(&mut post);
            }
        }
        let step = self.window.pop_front().expect("a step");
        let net = self.net;
        let c = &step.cands[choice as usize];
        // The smoothed probability of the chosen road (both directions,
        // every section of it).
        let confidence = step
            .cands
            .iter()
            .zip(&post)
            .filter(|(k, _)| k.road == c.road)
            .map(|(_, p)| p)
            .sum::<f64>()
            .clamp(0.0, 1.0);
        self.post_buf = post;
        // Matched points: the fixes less the chosen state's drift, projected.
        let b = c.drift.mean;
        let corrected = |f: &Fix| Fix {
            enu: [f.enu[0] - b[0], f.enu[1] - b[1]],
            ..*f
        };
        let mut m = matched_on(
            net,
            step.index,
            &corrected(&step.fix),
            c.seg,
            MatchState::Matched,
            confidence,
        );
        // No drift (the independent model's, always): the fix corrected is
        // the fix as given (but for the sign of a zero), and so is the
        // distance to it, bit for bit.
        let mut point = if b == [0.0; 2] {
            m.fix = step.fix.enu;
            m
        } else {
            with_raw(m, step.fix.enu)
        };
        point.forward = c.at.forward;
        out.push(point);
        self.last_matched = Some((step.index, step.fix.t_s));
        if !step.pending.is_empty() {
            let mut pieces = std::mem::take(&mut self.path_buf);
            let on_path = next_choice.is_some_and(|nc| {
                let next = self.window.front().expect("the next step");
                let b = next.cands[nc as usize].at;
                let gc = dist(next.fix.enu, step.fix.enu);
                let bound = self.route_bound(gc, next.fix.t_s - step.fix.t_s);
                self.paths
                    .path_into(c.at, b, bound, self.params.backtrack_m, &mut pieces)
            });
            if !on_path {
                let len = net.sections[c.at.section as usize].length_m;
                pieces.clear();
                pieces.push((c.at.section, 0.0, len));
            }
            let mut cursor = 0usize;
            for (index, raw) in &step.pending {
                let fix = corrected(raw);
                let (k, seg) = nearest_on_pieces(net, &pieces[cursor..], fix.enu);
                cursor += k;
                let mut m = matched_on(net, *index, &fix, seg, MatchState::Matched, confidence);
                // Keep the point inside the piece's offset range.
                let (sec, a, b) = pieces[cursor];
                clamp_to_range(net, &mut m, sec, a.min(b), a.max(b), &fix);
                // The direction of travel along the decided path (on the
                // step's own section without a path: the step's).
                m.forward = if on_path && a != b {
                    Some(b > a)
                } else {
                    c.at.forward
                };
                out.push(with_raw(m, raw.enu));
                self.last_matched = Some((*index, fix.t_s));
            }
            self.path_buf = pieces;
        }
        self.spare.push(step);
    }

    /// Decides every step in the window.
    fn flush(&mut self, out: &mut Vec<MatchedPoint>) {
        if self.window.is_empty() {
            return;
        }
        self.smoother.clear();
        let mut ch = std::mem::take(&mut self.choice_buf);
        self.choices(self.window.len(), &mut ch);
        if self.independent() {
            // No backward pass: each step's filtered confidence.
            for i in 0..ch.len() {
                let next = ch.get(i + 1).copied();
                self.emit_front(ch[i], next, false, out);
            }
            self.choice_buf = ch;
            return;
        }
        let (betas, at) = self.window_betas();
        for i in 0..ch.len() {
            // The posterior of step i, now at the window's front.
            let front = self.window.front().expect("a step");
            let beta = &betas[at[i]..at[i] + front.cands.len()];
            let mut post = std::mem::take(&mut self.post_buf);
            post.clear();
            post.extend(front.alpha.iter().zip(beta).map(|(a, b)| a * b));
            if !normalise(&mut post) {
                softmax_into(&front.score, &mut post);
            }
            self.post_buf = post;
            let next = ch.get(i + 1).copied();
            self.emit_front(ch[i], next, true, out);
        }
        self.beta_flat = (betas, at);
        self.choice_buf = ch;
    }

    fn start_chain(&mut self, reason: Option<BreakReason>, index: u64, t_s: f64) {
        if let Some(r) = reason {
            self.breaks.push(Break {
                reason: r,
                before: self.last_matched,
                after: (index, t_s),
            });
        }
    }
}

impl Matcher for HmmMatcher<'_> {
    fn push(&mut self, raw_fix: &Fix, out: &mut Vec<MatchedPoint>) {
        let index = self.index;
        self.index += 1;
        // A missing time (NaN) is allowed: such fixes are chained by
        // distance alone; an infinite time is not a time.
        if !(raw_fix.enu[0].is_finite() && raw_fix.enu[1].is_finite() && !raw_fix.t_s.is_infinite())
        {
            // Nothing to match, and nothing to let into the drift estimates;
            // what is held is decided first, so points stay in input order.
            self.flush(out);
            out.push(MatchedPoint::unmatched(index, raw_fix));
            return;
        }
        let fix = &Fix {
            heading_rad: raw_fix.heading_rad.filter(|h| h.is_finite()),
            ..*raw_fix
        };
        if let Some(last) = self.last_fix {
            let d = dist(fix.enu, last.enu);
            // A missing time (NaN) is no gap: the distance decides.
            if (d > self.params.gap_m || fix.t_s - last.t_s > self.params.gap_s)
                && self.pending_break.is_none()
            {
                self.pending_break = Some(BreakReason::Gap);
            }
        }
        self.last_fix = Some(*fix);

        // Between steps: held until the next step decides the path.
        if self.pending_break.is_none() {
            if let Some(last) = self.window.back_mut() {
                let (dx, dy) = (fix.enu[0] - last.fix.enu[0], fix.enu[1] - last.fix.enu[1]);
                if dx * dx + dy * dy < self.params.min_step_m.powi(2)
                    && last.pending.len() < self.params.max_skip
                {
                    last.pending.push((index, *fix));
                    return;
                }
            }
        }

        let heading = match fix.heading_rad {
            Some(h) => Some((h, self.params.kappa_given)),
            None => self.last_step_pos.and_then(|q| {
                let (dx, dy) = (fix.enu[0] - q[0], fix.enu[1] - q[1]);
                (dx * dx + dy * dy >= self.params.min_step_m.powi(2) * 0.99)
                    .then(|| (dx.atan2(dy), self.params.kappa_derived))
            }),
        };
        self.last_step_pos = Some(fix.enu);
        let common = self.common_drift(fix.enu);
        let mut step = self.new_step(index, *fix);
        let mut cands = std::mem::take(&mut step.cands);
        self.candidates(fix, heading, &common, &mut cands);
        step.cands = cands;

        if step.cands.is_empty() {
            // Off road: decide everything held, report this fix unmatched.
            self.flush(out);
            if self.last_matched.is_some() {
                // Off road says more than a jump into it.
                self.pending_break = Some(BreakReason::OffRoad);
            }
            out.push(MatchedPoint::unmatched(index, raw_fix));
            self.spare.push(step);
            return;
        }

        let chained = if self.pending_break.is_none() && !self.window.is_empty() {
            let reached = if self.independent() {
                self.transition_independent(&mut step)
            } else {
                self.transition(&mut step)
            };
            if reached {
                true
            } else {
                self.pending_break = Some(BreakReason::NoPath);
                false
            }
        } else {
            false
        };
        if !chained {
            // A new chain: every state starts from the common drift (the
            // last estimate, relaxed towards the prior over the distance
            // since it was made).
            self.flush(out);
            let reason = self.pending_break.take();
            if self.last_matched.is_some() {
                self.start_chain(reason, index, fix.t_s);
            }
            step.score.clear();
            step.back.clear();
            let m = step
                .cands
                .iter()
                .map(|c| c.emission)
                .fold(f64::NEG_INFINITY, f64::max);
            let r2 = self.params.sigma_m * self.params.sigma_m;
            for c in step.cands.iter_mut() {
                c.anchor_dir = c.dir;
                c.anchor_m = 0.0;
                c.anchor_road = c.road;
                c.drift = common;
                if self.params.track_drift && !self.independent() {
                    // (The emission's innovation: no logarithm needed.)
                    let (normal, nu, s) = innovation(&c.line, fix.enu, &common, r2);
                    c.drift.update(normal, nu, s);
                }
                step.score.push(c.emission - m);
                step.back.push(0);
            }
            step.pair.clear();
            if self.independent() {
                // No forward vector in the independent model.
                step.alpha.clear();
            } else {
                softmax_into(&step.score, &mut step.alpha);
            }
        }
        let best = argmax(&step.score) as usize;
        self.drift = step.cands[best].drift;
        self.drift_state = best as u32;
        self.drift_at = Some(fix.enu);
        self.window.push_back(step);
        if self.window.len() > self.params.lag {
            let mut ch = std::mem::take(&mut self.choice_buf);
            self.choices(2, &mut ch);
            self.emit_front(ch[0], ch.get(1).copied(), false, out);
            self.choice_buf = ch;
        }
    }

    fn finish(&mut self, out: &mut Vec<MatchedPoint>) {
        self.flush(out);
    }

    fn breaks(&self) -> &[Break] {
        &self.breaks
    }
}
