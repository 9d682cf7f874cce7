//! The paper's incremental map matcher (PAPERS.md §3.3).
//!
//! Three candidate states:
//! 1. initial: no usable history; candidates are the segments within the
//!    search radius from the Hilbert grid;
//! 2. tracking: the fix is still on the last matched segment
//!    (0 < η < 1 and d < ε, and, an addition to the paper, the heading within
//!    `max_turn_deg` of the segment's direction): it stays the match
//!    (constant work);
//! 3. update: the fix has left the segment through one of its ends;
//!    candidates are the segments connected at that end (the next or previous
//!    segment of the same section, or, at a section end, the sections meeting
//!    at the node from the connectivity topology), plus the segment itself.
//!
//! An addition to the paper: while tracking, a fix farther than
//! `recheck_m` from the tracked segment's line counts against it; after
//! `recheck_after` such fixes in a row, the segments within ε of the fix are
//! scored (one bounded grid query) and the match moves to another one that
//! lies at most half as far from the fix and scores better, provided it is
//! a parallel road under the fixes: within `parallel_deg` of the tracked
//! segment's direction, within `max_turn_deg` of the heading, and within
//! `switch_m` of every one of those `recheck_after` fixes (a crossing road
//! at a junction passes under a fix without lying along the fixes), and
//! only when the fixes left the tracked line abruptly: their mean distance
//! from it at least `jump_m` above its moving average over `offset_tau_m`
//! of travel. A track drifting slowly away from its road (dead reckoning,
//! or a GNSS bias) onto the road beside it is not a change of road: the
//! rule without this test fired on such drift and lowered the accuracy
//! figures of tests/it/matching_accuracy.rs (BENCHMARKS.md, "Incremental
//! matcher's parallel-road switch"). Constant work per fix: one query per
//! `recheck_after` fixes at most, those fixes kept in a bounded buffer, the
//! average updated in place.
//!
//! The matched segment maximises f = w_d / (1 + d) + w_θ cos Δθ; the matched
//! point is the orthogonal projection. When the best update candidate is
//! farther than ε, or the fix drifted sideways beyond ε, the matcher falls
//! back to the initial state. Heading comes from the fix where given, else
//! from the displacement from the most recent fix at least
//! `heading_baseline_m` away (a sliding baseline).

use super::{heading_cos, matched_on, Break, Fix, MatchState, MatchedPoint, Matcher};
use crate::network::{Network, SectionEnd, SegmentId};

/// Parameters of the incremental matcher.
#[derive(Debug, Clone, Copy)]
pub struct IncrementalParams {
    /// ε: the tracking distance (the paper's node circle radius) (m).
    pub epsilon_m: f64,
    /// Radius of the initial search (m).
    pub search_radius_m: f64,
    /// Weight of distance, w_d (w_θ = 1 − w_d).
    pub w_d: f64,
    /// Displacement over which a heading is derived when the fix has none (m).
    pub heading_baseline_m: f64,
    /// A heading this far (degrees) from the segment's direction of travel
    /// ends tracking even inside the segment (the vehicle has turned off).
    pub max_turn_deg: f64,
    /// Distance from the tracked segment's line beyond which a fix counts
    /// against it (m).
    pub recheck_m: f64,
    /// Fixes in a row beyond `recheck_m` before the nearby segments are
    /// scored again (at most `MAX_RECHECK_AFTER`).
    pub recheck_after: u32,
    /// A parallel road is taken only if each of those fixes lies within this
    /// distance of its line (m): the road under the fixes, not one the
    /// fixes drift towards.
    pub switch_m: f64,
    /// ... and only if it runs within this angle (degrees) of the tracked
    /// segment (a parallel road, not a crossing one at a junction).
    pub parallel_deg: f64,
    /// ... and only if the fixes left the tracked road abruptly: their mean
    /// distance from its line exceeds the distance smoothed over the last
    /// `offset_tau_m` of travel by at least this much (m). A drifting track
    /// moves away from its road slowly (the smoothed distance follows it), a
    /// vehicle changing roads unseen (a jump, a link road missed between two
    /// updates) quickly.
    pub jump_m: f64,
    /// Travel (m) over which the distance from the tracked line is smoothed
    /// (an exponential moving average in distance).
    pub offset_tau_m: f64,
}

/// The largest `recheck_after` remembered (the fixes are kept in a bounded
/// buffer: constant memory and work per fix).
pub const MAX_RECHECK_AFTER: u32 = 16;

impl Default for IncrementalParams {
    fn default() -> Self {
        Self {
            epsilon_m: 40.0,
            search_radius_m: 50.0,
            w_d: 0.5,
            heading_baseline_m: 8.0,
            max_turn_deg: 45.0,
            // Beyond the lane and centreline offsets of a fix on its road
            // (a few metres), short of the 15-35 m between parallel roads.
            recheck_m: 8.0,
            recheck_after: 3,
            // Two σ of a good GNSS fix (2 m); the fixes of a drifting track
            // pass this close to a road beside theirs only briefly.
            switch_m: 4.0,
            parallel_deg: 20.0,
            // A drift growing at a slope s lags its smoothed value by s·τ:
            // 2.5-3.5 m at the 5-7 % of the accuracy tests' 30 m drift, plus
            // 3.5 m (3σ of the mean of three fixes with 2 m noise): below
            // 8 m. A vehicle crossing 15-35 m to a parallel road within a
            // few fixes leaves it 10-30 m behind.
            jump_m: 8.0,
            offset_tau_m: 50.0,
        }
    }
}

/// The paper's incremental matcher; see the module documentation.
#[derive(Debug)]
pub struct IncrementalMatcher<'a> {
    net: &'a Network,
    params: IncrementalParams,
    current: Option<SegmentId>,
    index: u64,
    /// Recent fixes, the oldest at least `heading_baseline_m` from the newest.
    recent: std::collections::VecDeque<[f64; 2]>,
    derived_heading: Option<f64>,
    candidates: Vec<SegmentId>,
    breaks: Vec<Break>,
    last_matched: Option<(u64, f64)>,
    was_unmatched: bool,
    /// Tracking fixes in a row beyond `recheck_m` from the tracked line.
    off_line: u32,
    /// Their positions (the last `recheck_after`).
    off_fixes: std::collections::VecDeque<[f64; 2]>,
    /// The distance from the matched lines, smoothed over `offset_tau_m` of
    /// travel (NaN: none since the last search).
    offset_ema: f64,
    /// The previous matched fix.
    prev: Option<[f64; 2]>,
}

impl<'a> IncrementalMatcher<'a> {
    /// A matcher on `net`.
    pub fn new(net: &'a Network, params: IncrementalParams) -> Self {
        Self {
            net,
            params,
            current: None,
            index: 0,
            recent: std::collections::VecDeque::with_capacity(64),
            derived_heading: None,
            candidates: Vec::with_capacity(64),
            breaks: Vec::new(),
            last_matched: None,
            was_unmatched: false,
            off_line: 0,
            off_fixes: std::collections::VecDeque::with_capacity(MAX_RECHECK_AFTER as usize),
            offset_ema: f64::NAN,
            prev: None,
        }
    }

    /// The paper's score f for a candidate.
    #[inline]
    fn score(&self, seg: SegmentId, p: [f64; 2], heading: Option<f64>) -> (f64, f64) {
        let s = &self.net.segments[seg as usize];
        let d = crate::network::point_segment_distance(p, s.a, s.b);
        let c = heading.map_or(0.0, |h| heading_cos(self.net, seg, h));
        (self.params.w_d / (1.0 + d) + (1.0 - self.params.w_d) * c, d)
    }

    fn best(&self, p: [f64; 2], heading: Option<f64>, max_d: f64) -> Option<(SegmentId, f64)> {
        let mut best: Option<(SegmentId, f64)> = None;
        for &c in &self.candidates {
            let (f, d) = self.score(c, p, heading);
            if d <= max_d && best.is_none_or(|b| f > b.1) {
                best = Some((c, f));
            }
        }
        best
    }

    /// Segments connected to `seg` at one of its ends, into `self.candidates`.
    fn connected(&mut self, seg: SegmentId, at_end: bool) {
        let net = self.net;
        let s = &net.segments[seg as usize];
        let sec = &net.sections[s.section as usize];
        let last = sec.first_segment + sec.segment_count - 1;
        self.candidates.clear();
        self.candidates.push(seg);
        if at_end && seg < last {
            self.candidates.push(seg + 1);
            return;
        }
        if !at_end && seg > sec.first_segment {
            self.candidates.push(seg - 1);
            return;
        }
        let node = if at_end { sec.end } else { sec.start };
        for inc in net.topology.incidences(node) {
            let o = &net.sections[inc.section as usize];
            let cand = match inc.end {
                SectionEnd::Start => o.first_segment,
                SectionEnd::End => o.first_segment + o.segment_count - 1,
            };
            if cand != seg {
                self.candidates.push(cand);
            }
        }
    }

    fn heading(&mut self, fix: &Fix) -> Option<f64> {
        if fix.heading_rad.is_some() {
            return fix.heading_rad;
        }
        // A sliding baseline: the direction from the most recent fix at least
        // `heading_baseline_m` away (bounded buffer, constant work per fix).
        let p = fix.enu;
        let b2 = self.params.heading_baseline_m.powi(2);
        let d2 = |q: [f64; 2]| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
        self.recent.push_back(p);
        while self.recent.len() > 2 && d2(self.recent[1]) >= b2 || self.recent.len() > 256 {
            self.recent.pop_front();
        }
        if let Some(&q) = self.recent.front() {
            if d2(q) >= b2 {
                self.derived_heading = Some((p[0] - q[0]).atan2(p[1] - q[1]));
            }
        }
        self.derived_heading
    }

    /// A segment of a road parallel to `seg` under the recent off-line fixes
    /// (each within `switch_m` of its line), at most half as far from the
    /// fix `p` as `seg` (`d`), agreeing with the heading and scoring better
    /// than `seg` (`f`): one bounded grid query.
    fn parallel_under(
        &mut self,
        seg: SegmentId,
        p: [f64; 2],
        heading: Option<f64>,
        d: f64,
        f: f64,
    ) -> Option<(SegmentId, f64)> {
        let net = self.net;
        self.candidates.clear();
        net.grid
            .within_radius_into(p, self.params.epsilon_m, &mut self.candidates);
        let s = &net.segments[seg as usize];
        let cos_parallel = self.params.parallel_deg.to_radians().cos();
        let cos_turn = self.params.max_turn_deg.to_radians().cos();
        let mut best: Option<(SegmentId, f64)> = None;
        for &c in &self.candidates {
            let o = &net.segments[c as usize];
            if c == seg || o.length_m <= 0.0 || s.length_m <= 0.0 {
                continue;
            }
            let cos = ((s.b[0] - s.a[0]) * (o.b[0] - o.a[0])
                + (s.b[1] - s.a[1]) * (o.b[1] - o.a[1]))
                / (s.length_m * o.length_m);
            if cos.abs() < cos_parallel
                || heading.is_some_and(|h| heading_cos(net, c, h) < cos_turn)
                || self
                    .off_fixes
                    .iter()
                    .any(|&q| line_distance(q, o.a, o.b) > self.params.switch_m)
            {
                continue;
            }
            let (fc, dc) = self.score(c, p, heading);
            if dc <= d / 2.0 && fc > f && best.is_none_or(|b| fc > b.1) {
                best = Some((c, fc));
            }
        }
        best
    }

    fn initial(&mut self, fix: &Fix, heading: Option<f64>) -> Option<(SegmentId, f64)> {
        self.candidates.clear();
        self.net.grid.within_radius_into(
            fix.enu,
            self.params.search_radius_m,
            &mut self.candidates,
        );
        self.best(fix.enu, heading, f64::INFINITY)
    }
}

/// Distance from `p` to the line through `a` and `b` (m).
#[inline]
fn line_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    (p[0] * (a[1] - b[1]) - p[1] * (a[0] - b[0]) + a[0] * b[1] - b[0] * a[1]).abs()
        / (dx * dx + dy * dy).sqrt()
}

impl Matcher for IncrementalMatcher<'_> {
    fn push(&mut self, fix: &Fix, out: &mut Vec<MatchedPoint>) {
        let index = self.index;
        self.index += 1;
        let heading = self.heading(fix);
        let p = fix.enu;
        let eps = self.params.epsilon_m;
        let mut chosen: Option<(SegmentId, f64, MatchState)> = None;
        if let Some(seg) = self.current {
            let s = &self.net.segments[seg as usize];
            // The paper's η (the projection parameter, not clamped, so it
            // tells which end was passed) and d (the distance to the
            // segment's supporting line), written out: `geo`'s
            // `LineLocatePoint` clamps η to 0..=1 and its distances are to
            // the segment, not the line.
            let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
            let len2 = dx * dx + dy * dy;
            let eta = ((p[0] - s.a[0]) * dx + (p[1] - s.a[1]) * dy) / len2;
            let d = line_distance(p, s.a, s.b);
            let turned = heading.is_some_and(|h| {
                heading_cos(self.net, seg, h) < self.params.max_turn_deg.to_radians().cos()
            });
            let inside = eta > 0.0 && eta < 1.0;
            if inside && d < eps && !turned {
                let f = self.score(seg, p, heading).0;
                chosen = Some((seg, f, MatchState::Tracking));
                if d > self.params.recheck_m {
                    self.off_line += 1;
                    if self.off_fixes.len()
                        >= self.params.recheck_after.min(MAX_RECHECK_AFTER) as usize
                    {
                        self.off_fixes.pop_front();
                    }
                    self.off_fixes.push_back(p);
                } else {
                    self.off_line = 0;
                    self.off_fixes.clear();
                }
                if self.off_line >= self.params.recheck_after {
                    self.off_line = 0;
                    let mean = self
                        .off_fixes
                        .iter()
                        .map(|&q| line_distance(q, s.a, s.b))
                        .sum::<f64>()
                        / self.off_fixes.len().max(1) as f64;
                    let left = mean - self.offset_ema >= self.params.jump_m;
                    if left {
                        if let Some((c, fc)) = self.parallel_under(seg, p, heading, d, f) {
                            chosen = Some((c, fc, MatchState::Initial));
                        }
                    }
                    self.off_fixes.clear();
                }
            } else if !inside || turned {
                self.connected(seg, eta >= 0.5);
                if let Some((c, f)) = self.best(p, heading, eps) {
                    chosen = Some((c, f, MatchState::Update));
                }
            }
        }
        if chosen.is_none() {
            chosen = self
                .initial(fix, heading)
                .map(|(c, f)| (c, f, MatchState::Initial));
        }
        match chosen {
            Some((seg, f, state)) => {
                if state != MatchState::Tracking {
                    self.off_line = 0;
                    self.off_fixes.clear();
                }
                let sg = &self.net.segments[seg as usize];
                let d = line_distance(p, sg.a, sg.b);
                if state == MatchState::Initial || self.offset_ema.is_nan() {
                    self.offset_ema = d;
                } else {
                    let ds = self.prev.map_or(0.0, |q| (p[0] - q[0]).hypot(p[1] - q[1]));
                    let a = 1.0 - (-ds / self.params.offset_tau_m).exp();
                    self.offset_ema += a * (d - self.offset_ema);
                }
                self.prev = Some(p);
                self.current = Some(seg);
                if self.was_unmatched {
                    self.breaks.push(Break {
                        reason: super::BreakReason::OffRoad,
                        before: self.last_matched,
                        after: (index, fix.t_s),
                    });
                    self.was_unmatched = false;
                }
                self.last_matched = Some((index, fix.t_s));
                out.push(matched_on(
                    self.net,
                    index,
                    fix,
                    seg,
                    state,
                    f.clamp(0.0, 1.0),
                ));
            }
            None => {
                self.current = None;
                self.offset_ema = f64::NAN;
                self.was_unmatched = true;
                out.push(MatchedPoint::unmatched(index, fix));
            }
        }
    }

    fn finish(&mut self, _out: &mut Vec<MatchedPoint>) {
        // Every point was emitted when pushed.
    }

    fn breaks(&self) -> &[Break] {
        &self.breaks
    }
}
