//! Robust map matching: a hidden-Markov matcher in the manner of Newson and
//! Krumm (2009), online with a bounded lag window.
//!
//! - States: candidate road sections within the search radius of a fix, one
//!   per section and permitted direction of travel (its nearest point), at
//!   most `max_candidates`. Moving on in the same direction costs the
//!   distance; turning round needs a node (a junction or a dead end), never
//!   happens inside a section, and costs `uturn_penalty_m` more: a path
//!   turning straight back onto the section it left, a transition shorter
//!   than the penalty that ends facing more than 120° from where it started,
//!   or one that faces more than 120° from the direction of travel about
//!   40 m back along the best path (a turn-round spread over several steps,
//!   e.g. round a small triangle of roads). So jitter and drift cannot make
//!   a U-turn; a real one needs strong evidence.
//! - Emission: log p = −½ (d/σ_z)² + κ (cos Δθ − 1), with Δθ the angle between
//!   the heading (the fix's where given, else the displacement since the
//!   previous step) and the state's direction of travel; this is
//!   what tells parallel one-way carriageways apart.
//! - Transition: log p = −|route distance − straight distance| / β, with route
//!   distances from bounded, cached Dijkstra searches honouring one-way roads
//!   ([`super::NetworkDistances`]); no path within the bound: impossible.
//! - Dense tracks: a fix becomes a Viterbi step only once it lies at least
//!   `min_step_m` from the previous step (jitter and backward drift between
//!   steps cannot create loops or U-turns); the fixes in between are matched
//!   afterwards onto the decided path between the two steps. A short backward
//!   move along a one-way section (≤ `backtrack_m`) counts as noise, not as a
//!   drive around the block.
//! - Online: the window holds at most `lag` steps; the oldest is decided by
//!   back-tracing from the newest step's best state. Memory is proportional to
//!   the window (`lag` steps of at most `max_skip` fixes each).
//! - Breaks: a gap (time or distance between consecutive fixes), a fix with no
//!   road within the radius, or no permitted path between consecutive steps
//!   ends the chain (everything in the window is decided) and a new one starts;
//!   each break is recorded, off-road fixes are reported unmatched.
//! - Confidence: the chosen road's share of the step's (filtered) probability.

use super::paths::{NetworkDistances, OnSection};
use super::{project, Break, BreakReason, Fix, MatchState, MatchedPoint, Matcher};
use crate::network::{Network, SectionId, SegmentId};
use std::collections::VecDeque;

/// Parameters of the HMM matcher.
#[derive(Debug, Clone, Copy)]
pub struct HmmParams {
    /// Candidate search radius (m): should exceed the expected position error.
    pub search_radius_m: f64,
    /// Most candidates per step.
    pub max_candidates: usize,
    /// σ_z of the emission (m).
    pub sigma_m: f64,
    /// β of the transition (m).
    pub beta_m: f64,
    /// κ for a heading given with the fix.
    pub kappa_given: f64,
    /// κ for a heading derived from the displacement between steps.
    pub kappa_derived: f64,
    /// Least distance between consecutive steps (m).
    pub min_step_m: f64,
    /// Most fixes between steps (bounds memory when standing still).
    pub max_skip: usize,
    /// Steps in the lag window.
    pub lag: usize,
    /// Distance between consecutive fixes that breaks the track (m).
    pub gap_m: f64,
    /// Time between consecutive fixes that breaks the track (s).
    pub gap_s: f64,
    /// Backward move along a one-way section accepted as noise (m).
    pub backtrack_m: f64,
    /// Extra distance charged for turning round at a node straight back onto
    /// the section just left (m): a U-turn needs strong evidence.
    pub uturn_penalty_m: f64,
    /// Gain of the drift estimate (0 disables it): the offset between
    /// decided fixes and their matched points, low-pass filtered, is
    /// subtracted from new fixes before they are matched (dead-reckoned
    /// positions drift slowly, so the offset persists from step to step).
    pub drift_gain: f64,
}

impl Default for HmmParams {
    fn default() -> Self {
        Self {
            search_radius_m: 50.0,
            max_candidates: 12,
            sigma_m: 20.0,
            beta_m: 5.0,
            kappa_given: 3.0,
            kappa_derived: 1.0,
            min_step_m: 10.0,
            max_skip: 256,
            lag: 32,
            gap_m: 200.0,
            gap_s: 60.0,
            backtrack_m: 15.0,
            uturn_penalty_m: 300.0,
            drift_gain: 0.0,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Cand {
    seg: SegmentId,
    at: OnSection,
    emission: f64,
    /// Unit direction of travel (east, north).
    dir: [f64; 2],
    /// Direction of travel at least [`ANCHOR_M`] back along the best path
    /// into this state, and the distance from there (m).
    anchor_dir: [f64; 2],
    anchor_m: f64,
}

/// Distance back along the path at which the earlier direction of travel is
/// compared with the current one to recognise U-turns (m).
const ANCHOR_M: f64 = 40.0;

#[derive(Debug)]
struct Step {
    index: u64,
    fix: Fix,
    cands: Vec<Cand>,
    score: Vec<f64>,
    back: Vec<u32>,
    /// The fix as given (`fix` is corrected for the estimated drift).
    raw: [f64; 2],
    /// Fixes after this step, before the next (index, corrected fix, fix as given).
    pending: Vec<(u64, Fix, [f64; 2])>,
}

/// The HMM matcher; see the module documentation.
#[derive(Debug)]
pub struct HmmMatcher<'a> {
    net: &'a Network,
    params: HmmParams,
    paths: NetworkDistances<'a>,
    window: VecDeque<Step>,
    index: u64,
    last_fix: Option<Fix>,
    last_step_pos: Option<[f64; 2]>,
    pending_break: Option<BreakReason>,
    last_matched: Option<(u64, f64)>,
    breaks: Vec<Break>,
    drift: [f64; 2],
    seg_buf: Vec<SegmentId>,
    spare: Vec<Step>,
}

impl<'a> HmmMatcher<'a> {
    /// A matcher on `net`.
    pub fn new(net: &'a Network, params: HmmParams) -> Self {
        Self {
            net,
            params,
            paths: {
                let mut p = NetworkDistances::new(net);
                p.uturn_penalty_m = params.uturn_penalty_m;
                p
            },
            window: VecDeque::with_capacity(params.lag + 1),
            index: 0,
            last_fix: None,
            last_step_pos: None,
            pending_break: None,
            last_matched: None,
            breaks: Vec::new(),
            drift: [0.0; 2],
            seg_buf: Vec::with_capacity(64),
            spare: Vec::new(),
        }
    }

    /// Steps currently held in the lag window.
    pub fn window_len(&self) -> usize {
        self.window.len()
    }

    /// Fixes currently held (steps and the fixes between them).
    pub fn held_fixes(&self) -> usize {
        self.window.iter().map(|s| 1 + s.pending.len()).sum()
    }

    /// Candidates of a fix into `cands`.
    fn candidates(&mut self, fix: &Fix, heading: Option<(f64, f64)>, cands: &mut Vec<Cand>) {
        let net = self.net;
        cands.clear();
        self.seg_buf.clear();
        net.grid
            .within_radius_into(fix.enu, self.params.search_radius_m, &mut self.seg_buf);
        let inv2s2 = 0.5 / (self.params.sigma_m * self.params.sigma_m);
        for &seg in &self.seg_buf {
            let (t, _, d) = project(net, seg, fix.enu);
            let s = &net.segments[seg as usize];
            let base = -d * d * inv2s2;
            let offset_m = s.section_offset_m + t * s.length_m;
            let oneway = net.sections[s.section as usize].oneway;
            // One state per permitted direction of the section.
            for forward in [true, false] {
                if !(if forward {
                    oneway.allows_forward()
                } else {
                    oneway.allows_backward()
                }) {
                    continue;
                }
                let mut e = base;
                if let Some((h, kappa)) = heading {
                    e += kappa * (directed_cos(net, seg, h, forward) - 1.0);
                }
                let len = s.length_m.max(1e-9);
                let sign = if forward { 1.0 } else { -1.0 };
                let c = Cand {
                    seg,
                    at: OnSection {
                        section: s.section,
                        offset_m,
                        forward: Some(forward),
                    },
                    emission: e,
                    dir: [
                        sign * (s.b[0] - s.a[0]) / len,
                        sign * (s.b[1] - s.a[1]) / len,
                    ],
                    anchor_dir: [0.0; 2],
                    anchor_m: 0.0,
                };
                match cands
                    .iter_mut()
                    .find(|o| o.at.section == s.section && o.at.forward == Some(forward))
                {
                    Some(o) => {
                        if e > o.emission {
                            *o = c;
                        }
                    }
                    None => cands.push(c),
                }
            }
        }
        cands.sort_unstable_by(|a, b| b.emission.total_cmp(&a.emission));
        cands.truncate(self.params.max_candidates);
    }

    fn new_step(&mut self, index: u64, fix: Fix, raw: [f64; 2]) -> Step {
        match self.spare.pop() {
            Some(mut s) => {
                s.index = index;
                s.fix = fix;
                s.raw = raw;
                s.cands.clear();
                s.score.clear();
                s.back.clear();
                s.pending.clear();
                s
            }
            None => Step {
                index,
                fix,
                raw,
                cands: Vec::with_capacity(self.params.max_candidates),
                score: Vec::with_capacity(self.params.max_candidates),
                back: Vec::with_capacity(self.params.max_candidates),
                pending: Vec::new(),
            },
        }
    }

    /// Viterbi recursion from the window's last step into `step`; false when
    /// no candidate can be reached from any previous one.
    fn transition(&mut self, step: &mut Step) -> bool {
        let prev = self.window.back().expect("a previous step");
        let gc = (step.fix.enu[0] - prev.fix.enu[0]).hypot(step.fix.enu[1] - prev.fix.enu[1]);
        let bound = gc + 2.0 * self.params.search_radius_m + 100.0;
        let backtrack = self.params.backtrack_m;
        let inv_beta = 1.0 / self.params.beta_m;
        for c in &prev.cands {
            for (n, _) in self.paths.exits(c.at).into_iter().flatten() {
                self.paths.ensure(n, bound);
            }
        }
        let prev = self.window.back().expect("a previous step");
        let mut any = false;
        step.score.clear();
        step.back.clear();
        let mut anchors = Vec::with_capacity(step.cands.len());
        for c in &step.cands {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0);
            for (i, p) in prev.cands.iter().enumerate() {
                if prev.score[i] == f64::NEG_INFINITY {
                    continue;
                }
                let Some(d) = self.paths.point_distance_cached(p.at, c.at, backtrack) else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                // Facing the other way after a short drive: a U-turn (at a
                // node or round a small loop, in one transition or over a few).
                let dot = |u: [f64; 2]| u[0] * c.dir[0] + u[1] * c.dir[1];
                let turned = (dot(p.dir) < -0.5 && d < self.params.uturn_penalty_m)
                    || (dot(p.anchor_dir) < -0.5 && p.anchor_m + d < 2.0 * ANCHOR_M);
                let charged = if turned {
                    d + self.params.uturn_penalty_m
                } else {
                    d
                };
                let s = prev.score[i] - (charged - gc).abs() * inv_beta;
                if s > best {
                    best = s;
                    arg = i as u32;
                    anchor = if p.anchor_m + d > ANCHOR_M {
                        (p.dir, d)
                    } else {
                        (p.anchor_dir, p.anchor_m + d)
                    };
                }
            }
            if best > f64::NEG_INFINITY {
                any = true;
            }
            step.score.push(best + c.emission);
            step.back.push(arg);
            anchors.push(anchor);
        }
        for (c, (dir, m)) in step.cands.iter_mut().zip(anchors) {
            c.anchor_dir = dir;
            c.anchor_m = m;
        }
        if any {
            // Renormalise so scores stay near zero on long tracks.
            let m = step.score.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for s in &mut step.score {
                *s -= m;
            }
        }
        any
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
    fn emit_front(&mut self, choice: u32, next_choice: Option<u32>, out: &mut Vec<MatchedPoint>) {
        let step = self.window.pop_front().expect("a step");
        let net = self.net;
        let c = step.cands[choice as usize];
        // The share of the step's probability on the chosen road (both
        // directions, every section of it).
        let road = net.segments[c.seg as usize].road;
        let confidence = share(&step.score, |k| {
            net.segments[step.cands[k].seg as usize].road == road
        });
        let mut point = with_raw(
            super::matched_on(
                net,
                step.index,
                &step.fix,
                c.seg,
                MatchState::Matched,
                confidence,
            ),
            step.raw,
        );
        point.forward = c.at.forward;
        let g = self.params.drift_gain;
        for k in 0..2 {
            self.drift[k] += g * (step.raw[k] - point.point[k] - self.drift[k]);
        }
        out.push(point);
        self.last_matched = Some((step.index, step.fix.t_s));
        if !step.pending.is_empty() {
            let pieces = next_choice.and_then(|nc| {
                let next = self.window.front().expect("the next step");
                let b = next.cands[nc as usize].at;
                let gc =
                    (next.fix.enu[0] - step.fix.enu[0]).hypot(next.fix.enu[1] - step.fix.enu[1]);
                let bound = gc + 2.0 * self.params.search_radius_m + 100.0;
                self.paths.path(c.at, b, bound, self.params.backtrack_m)
            });
            let pieces = pieces.unwrap_or_else(|| {
                let len = net.sections[c.at.section as usize].length_m;
                vec![(c.at.section, 0.0, len)]
            });
            let mut cursor = 0usize;
            for &(index, fix, raw) in &step.pending {
                let (k, seg) = nearest_on_pieces(net, &pieces[cursor..], fix.enu);
                cursor += k;
                let mut m =
                    super::matched_on(net, index, &fix, seg, MatchState::Matched, confidence);
                // Keep the point inside the piece's offset range.
                let (sec, a, b) = pieces[cursor];
                clamp_to_range(net, &mut m, sec, a.min(b), a.max(b), &fix);
                out.push(with_raw(m, raw));
                self.last_matched = Some((index, fix.t_s));
            }
        }
        self.spare.push(step);
    }

    /// Decides every step in the window.
    fn flush(&mut self, out: &mut Vec<MatchedPoint>) {
        if self.window.is_empty() {
            return;
        }
        let mut ch = Vec::new();
        self.choices(self.window.len(), &mut ch);
        for i in 0..ch.len() {
            let next = ch.get(i + 1).copied();
            self.emit_front(ch[i], next, out);
        }
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

/// The point reported against the fix as given.
fn with_raw(mut m: MatchedPoint, raw: [f64; 2]) -> MatchedPoint {
    m.fix = raw;
    m.distance_m = (raw[0] - m.point[0]).hypot(raw[1] - m.point[1]);
    m
}

/// Cosine between a heading and a segment's direction of travel.
fn directed_cos(net: &Network, seg: SegmentId, heading_rad: f64, forward: bool) -> f64 {
    let s = &net.segments[seg as usize];
    let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
    let len = dx.hypot(dy);
    if len <= 0.0 {
        return 0.0;
    }
    let (sh, ch) = heading_rad.sin_cos();
    let c = (dx * sh + dy * ch) / len;
    if forward {
        c
    } else {
        -c
    }
}

fn argmax(v: &[f64]) -> u32 {
    let mut k = 0;
    for (i, x) in v.iter().enumerate() {
        if *x > v[k] {
            k = i;
        }
    }
    k as u32
}

/// The share of the probability in `scores` (log) held by the states `pick` selects.
fn share(scores: &[f64], pick: impl Fn(usize) -> bool) -> f64 {
    let m = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !m.is_finite() {
        return 0.0;
    }
    let (mut part, mut sum) = (0.0, 0.0);
    for (k, s) in scores.iter().enumerate() {
        let p = (s - m).exp();
        sum += p;
        if pick(k) {
            part += p;
        }
    }
    (part / sum).clamp(0.0, 1.0)
}

/// The nearest segment to `p` on the path pieces: (piece index, segment).
fn nearest_on_pieces(
    net: &Network,
    pieces: &[(SectionId, f64, f64)],
    p: [f64; 2],
) -> (usize, SegmentId) {
    let mut best = (0usize, 0 as SegmentId, f64::INFINITY);
    for (k, &(sec, a, b)) in pieces.iter().enumerate() {
        let (lo, hi) = (a.min(b), a.max(b));
        let section = &net.sections[sec as usize];
        for seg in section.segment_ids() {
            let s = &net.segments[seg as usize];
            if s.section_offset_m > hi || s.section_offset_m + s.length_m < lo {
                continue;
            }
            let (t, _, d) = project(net, seg, p);
            let off = s.section_offset_m + t * s.length_m;
            let d = if off < lo || off > hi {
                let off = off.clamp(lo, hi);
                let q = point_at(net, seg, off);
                (p[0] - q[0]).hypot(p[1] - q[1])
            } else {
                d
            };
            if d < best.2 {
                best = (k, seg, d);
            }
        }
        if best.2.is_infinite() && k == 0 {
            best = (0, section.first_segment, f64::INFINITY);
        }
    }
    (best.0, best.1)
}

fn point_at(net: &Network, seg: SegmentId, section_offset: f64) -> [f64; 2] {
    let s = &net.segments[seg as usize];
    let t = if s.length_m > 0.0 {
        ((section_offset - s.section_offset_m) / s.length_m).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [
        s.a[0] + t * (s.b[0] - s.a[0]),
        s.a[1] + t * (s.b[1] - s.a[1]),
    ]
}

/// Moves a matched point into the section offset range `lo..=hi` if outside it.
fn clamp_to_range(
    net: &Network,
    m: &mut MatchedPoint,
    sec: SectionId,
    lo: f64,
    hi: f64,
    fix: &Fix,
) {
    let Some(seg) = m.segment else { return };
    let s = &net.segments[seg as usize];
    if s.section != sec {
        return;
    }
    let off = s.section_offset_m + (m.road_offset_m - s.road_offset_m);
    if off >= lo - 1e-9 && off <= hi + 1e-9 {
        return;
    }
    let off = off.clamp(lo, hi);
    let q = point_at(net, seg, off);
    m.point = q;
    m.road_offset_m = s.road_offset_m + (off - s.section_offset_m).clamp(0.0, s.length_m);
    m.distance_m = (fix.enu[0] - q[0]).hypot(fix.enu[1] - q[1]);
}

impl Matcher for HmmMatcher<'_> {
    fn push(&mut self, raw_fix: &Fix, out: &mut Vec<MatchedPoint>) {
        let index = self.index;
        self.index += 1;
        let raw = raw_fix.enu;
        let fix = &Fix {
            enu: [raw[0] - self.drift[0], raw[1] - self.drift[1]],
            ..*raw_fix
        };
        if let Some(last) = self.last_fix {
            let d = (fix.enu[0] - last.enu[0]).hypot(fix.enu[1] - last.enu[1]);
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
                    last.pending.push((index, *fix, raw));
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
        let mut step = self.new_step(index, *fix, raw);
        let mut cands = std::mem::take(&mut step.cands);
        self.candidates(fix, heading, &mut cands);
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
            if self.transition(&mut step) {
                true
            } else {
                self.pending_break = Some(BreakReason::NoPath);
                false
            }
        } else {
            false
        };
        if !chained {
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
            for c in step.cands.iter_mut() {
                c.anchor_dir = c.dir;
                c.anchor_m = 0.0;
                step.score.push(c.emission - m);
                step.back.push(0);
            }
        }
        self.window.push_back(step);
        if self.window.len() > self.params.lag {
            let mut ch = Vec::with_capacity(2);
            self.choices(2, &mut ch);
            self.emit_front(ch[0], ch.get(1).copied(), out);
        }
    }

    fn finish(&mut self, out: &mut Vec<MatchedPoint>) {
        self.flush(out);
    }

    fn breaks(&self) -> &[Break] {
        &self.breaks
    }
}
