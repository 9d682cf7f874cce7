//! The complete matched path: the roads driven, in driving order, between
//! and through the matched points (FMM's `cpath`, GraphHopper's route).
//!
//! Consecutive matched points are joined along their section when the
//! second lies ahead of the first in the direction of travel, else by the
//! shortest permitted path between them (one-way roads honoured, the
//! direction the matcher decided at each point kept), searched within the
//! same bound the HMM's transitions use. A short move backwards along the
//! section (at most `backtrack_m`: noise) adds nothing. The path is split
//! into continuous pieces where the matcher broke the track, at unmatched
//! points, and where no permitted path joins two points.
//!
//! A piece starts and ends where its first and last fixes project onto
//! their matched sections (the fixes as given: a drift estimated along the
//! road is least observed at a track's ends, and a peer's path, FMM's,
//! ends at the same projections); the points in between are the matcher's.
//!
//! Pieces of consecutive sections of one road that continue each other are
//! merged, so a row is a stretch of road driven without leaving it.

use super::hmm::route_bound;
use super::paths::{NetworkDistances, OnSection};
use super::{Break, HmmParams, MatchedPoint};
use crate::network::{Network, RoadId, SectionId};

/// One stretch of the complete path along a road.
#[derive(Debug, Clone, PartialEq)]
pub struct PathStep {
    /// The continuous piece it belongs to (0, 1, ... in driving order).
    pub piece: u32,
    /// The road.
    pub road: RoadId,
    /// Where the stretch starts, as distance along the road from its start (m).
    pub from_offset_m: f64,
    /// Where it ends (m); less than `from_offset_m` when driven against the
    /// road's digitised direction.
    pub to_offset_m: f64,
    /// Sections driven, in order, with section offsets (from, to) (m).
    pub sections: Vec<(SectionId, f64, f64)>,
}

impl PathStep {
    /// The length driven (m).
    pub fn length_m(&self) -> f64 {
        (self.to_offset_m - self.from_offset_m).abs()
    }
}

/// Builds the complete path of one matched track (points in input order,
/// the matcher's breaks with indices within the track).
pub fn complete_path(
    net: &Network,
    points: &[MatchedPoint],
    breaks: &[Break],
    params: &HmmParams,
) -> Vec<PathStep> {
    let mut paths = NetworkDistances::new(net);
    paths.uturn_penalty_m = params.uturn_penalty_m;
    complete_path_with(&mut paths, net, points, breaks, params)
}

/// [`complete_path`] with the network searches of `paths` (e.g. the
/// matcher's own, whose cache already holds most of them).
pub fn complete_path_with(
    paths: &mut NetworkDistances,
    net: &Network,
    points: &[MatchedPoint],
    breaks: &[Break],
    params: &HmmParams,
) -> Vec<PathStep> {
    let mut b = PathBuilder::default();
    let mut steps = Vec::new();
    b.complete_into(paths, net, points, breaks, params, &mut steps);
    steps
}

/// The complete path built point by point as the matcher emits them (a
/// streamed track): memory of one point and one stretch, plus the steps
/// not yet taken from [`PathBuilder::steps`].
#[derive(Debug, Default)]
pub struct PathBuilder {
    /// Finished steps, in driving order (the caller may drain them).
    pub steps: Vec<PathStep>,
    /// The point waiting for its successor (whether it ends a piece).
    held: Option<MatchedPoint>,
    piece: u32,
    /// The last point on the path: its position and time.
    cur: Option<(OnSection, [f64; 2], f64)>,
    /// The stretch being merged.
    open: Option<Stretch>,
    number: u32,
    last_piece: Option<u32>,
    /// The pieces of the last join (kept: no allocation per join).
    join_buf: Vec<(SectionId, f64, f64)>,
    /// Emptied section lists of earlier steps ([`Self::recycle`]), taken by
    /// new stretches before any is allocated.
    spare: Vec<Vec<(SectionId, f64, f64)>>,
}

/// Whether the matcher broke the track before point `index` (`breaks`
/// sorted by that index, as the matchers record them).
fn broke_at(breaks: &[Break], index: u64) -> bool {
    breaks.binary_search_by_key(&index, |b| b.after.0).is_ok()
}

impl PathBuilder {
    /// The complete path of one whole track into `out` (emptied first):
    /// what [`complete_path_with`] gives, with this builder's buffers (its
    /// state is reset first; `steps` is left empty). Section lists of the
    /// steps in `out` are kept for the new steps ([`Self::recycle`]), so a
    /// kept builder and output allocate nothing once grown.
    pub fn complete_into(
        &mut self,
        paths: &mut NetworkDistances,
        net: &Network,
        points: &[MatchedPoint],
        breaks: &[Break],
        params: &HmmParams,
        out: &mut Vec<PathStep>,
    ) {
        self.recycle(out);
        self.recycle_steps();
        self.held = None;
        self.piece = 0;
        self.cur = None;
        self.open = None;
        self.number = 0;
        self.last_piece = None;
        // The matchers record their breaks in order: no sorted copy then.
        let sorted;
        let breaks = if breaks.is_sorted_by_key(|b| b.after.0) {
            breaks
        } else {
            let mut v = breaks.to_vec();
            v.sort_by_key(|b| b.after.0);
            sorted = v;
            &sorted[..]
        };
        std::mem::swap(&mut self.steps, out);
        // Each point with its successor (what `push` then `finish` give,
        // without holding a copy of each point).
        for (i, p) in points.iter().enumerate() {
            self.point(paths, net, p, points.get(i + 1), breaks, params);
        }
        if let Some(st) = self.open.take() {
            self.close(st);
        }
        std::mem::swap(&mut self.steps, out);
    }

    /// Takes the steps of `steps` (left empty), keeping their section
    /// lists for the stretches built next.
    pub fn recycle(&mut self, steps: &mut Vec<PathStep>) {
        for st in steps.drain(..) {
            let mut secs = st.sections;
            secs.clear();
            self.spare.push(secs);
        }
    }

    /// [`Self::recycle`] of this builder's own [`Self::steps`].
    fn recycle_steps(&mut self) {
        let mut steps = std::mem::take(&mut self.steps);
        self.recycle(&mut steps);
        self.steps = steps;
    }

    /// The next point of the track, in order; `breaks`: the matcher's
    /// breaks so far (a point's break is recorded before it is emitted).
    pub fn push(
        &mut self,
        paths: &mut NetworkDistances,
        net: &Network,
        p: &MatchedPoint,
        breaks: &[Break],
        params: &HmmParams,
    ) {
        if let Some(h) = self.held.take() {
            self.point(paths, net, &h, Some(p), breaks, params);
        }
        self.held = Some(*p);
    }

    /// The track ended: the last point and the last stretch.
    pub fn finish(
        &mut self,
        paths: &mut NetworkDistances,
        net: &Network,
        breaks: &[Break],
        params: &HmmParams,
    ) {
        if let Some(h) = self.held.take() {
            self.point(paths, net, &h, None, breaks, params);
        }
        if let Some(st) = self.open.take() {
            self.close(st);
        }
    }

    fn point(
        &mut self,
        paths: &mut NetworkDistances,
        net: &Network,
        p: &MatchedPoint,
        next: Option<&MatchedPoint>,
        breaks: &[Break],
        params: &HmmParams,
    ) {
        let Some(mut at) = on_section(net, p) else {
            if self.cur.take().is_some() {
                self.piece += 1;
            }
            return;
        };
        let broke = broke_at(breaks, p.index);
        let first = self.cur.is_none() || broke;
        let last = next.is_none_or(|q| q.segment.is_none() || broke_at(breaks, q.index));
        if first || last {
            at.offset_m = raw_offset(net, p, at.section);
        }
        let Some((a, a_pt, a_t)) = self.cur else {
            self.cur = Some((at, p.point, p.t_s));
            return;
        };
        if broke {
            self.piece += 1;
            self.cur = Some((at, p.point, p.t_s));
            return;
        }
        let mut pieces = std::mem::take(&mut self.join_buf);
        let joined = join(
            paths,
            net,
            a,
            at,
            a_pt,
            p.point,
            p.t_s - a_t,
            params,
            &mut pieces,
        );
        match joined {
            Join::Stay => {}
            Join::Pieces => {
                for &(s, f, t) in &pieces {
                    self.raw(net, self.piece, s, f, t);
                }
                self.cur = Some((at, p.point, p.t_s));
            }
            Join::None => {
                self.piece += 1;
                self.cur = Some((at, p.point, p.t_s));
            }
        }
        self.join_buf = pieces;
    }

    /// Merges a driven piece into the open stretch when it continues it on
    /// the same road, else closes that stretch and opens another.
    fn raw(&mut self, net: &Network, piece: u32, sec: SectionId, f: f64, t: f64) {
        let road = net.sections[sec as usize].road;
        let base = section_road_offset(net, sec);
        let (rf, rt) = (base + f, base + t);
        if let Some(last) = self.open.as_mut() {
            let same_dir = (last.3 - last.2) * (rt - rf) >= 0.0;
            if last.0 == piece && last.1 == road && (last.3 - rf).abs() < 1e-6 && same_dir {
                last.3 = rt;
                last.4.push((sec, f, t));
                return;
            }
        }
        // A recycled list, else room for a few sections from the start
        // (most stretches hold one to four): no reallocation as it grows.
        let mut secs = self.spare.pop().unwrap_or_else(|| Vec::with_capacity(4));
        secs.push((sec, f, t));
        if let Some(st) = self.open.replace((piece, road, rf, rt, secs)) {
            self.close(st);
        }
    }

    /// A finished stretch as a step; pieces numbered 0, 1, ... (a piece of
    /// one point has no step).
    fn close(&mut self, (piece, road, f, t, secs): Stretch) {
        if self.last_piece.is_some_and(|l| l != piece) {
            self.number += 1;
        }
        self.last_piece = Some(piece);
        self.steps.push(PathStep {
            piece: self.number,
            road,
            from_offset_m: f,
            to_offset_m: t,
            sections: secs,
        });
    }
}

enum Join {
    /// No movement (the second point is the first, or a little behind it).
    Stay,
    /// Driven: (section, from, to) in order, in the join's buffer.
    Pieces,
    /// No permitted path within the bound.
    None,
}

#[allow(clippy::too_many_arguments)]
fn join(
    paths: &mut NetworkDistances,
    net: &Network,
    a: OnSection,
    b: OnSection,
    a_pt: [f64; 2],
    b_pt: [f64; 2],
    dt_s: f64,
    params: &HmmParams,
    pieces: &mut Vec<(SectionId, f64, f64)>,
) -> Join {
    pieces.clear();
    if a.section == b.section {
        let delta = b.offset_m - a.offset_m;
        let dir = match (a.forward, b.forward) {
            (Some(x), Some(y)) if x != y => None,
            (x, y) => Some(x.or(y)),
        };
        if let Some(dir) = dir {
            let oneway = net.sections[a.section as usize].oneway;
            let fwd_ok = dir.unwrap_or(true) && oneway.allows_forward();
            let bwd_ok = !dir.unwrap_or(false) && oneway.allows_backward();
            let ahead = (delta >= 0.0 && fwd_ok) || (delta <= 0.0 && bwd_ok);
            if ahead {
                return if delta == 0.0 {
                    Join::Stay
                } else {
                    pieces.push((a.section, a.offset_m, b.offset_m));
                    Join::Pieces
                };
            }
            // Behind the direction of travel by a little: noise.
            let behind = match dir {
                Some(true) => -delta,
                Some(false) => delta,
                None => delta.abs(),
            };
            if behind <= params.backtrack_m {
                return Join::Stay;
            }
        }
    }
    let gc = (b_pt[0] - a_pt[0]).hypot(b_pt[1] - a_pt[1]);
    let bound = route_bound(params, gc, dt_s);
    if paths.path_into(a, b, bound, params.backtrack_m, pieces) {
        pieces.retain(|(_, f, t)| (t - f).abs() > 1e-9);
        if pieces.is_empty() {
            Join::Stay
        } else {
            Join::Pieces
        }
    } else {
        Join::None
    }
}

/// Where a matched point lies: its section, offset and direction of travel.
fn on_section(net: &Network, p: &MatchedPoint) -> Option<OnSection> {
    let seg = &net.segments[p.segment? as usize];
    Some(OnSection {
        section: seg.section,
        offset_m: seg.section_offset_m + (p.road_offset_m - seg.road_offset_m),
        forward: p.forward,
    })
}

/// Section offset of the fix as given (`p.fix`) projected onto `sec`.
fn raw_offset(net: &Network, p: &MatchedPoint, sec: SectionId) -> f64 {
    let mut best = (f64::INFINITY, 0.0);
    for seg in net.sections[sec as usize].segment_ids() {
        let (t, _, d) = super::project(net, seg, p.fix);
        if d < best.0 {
            let s = &net.segments[seg as usize];
            best = (d, s.section_offset_m + t * s.length_m);
        }
    }
    best.1
}

/// Offset of a section's start along its road (m).
fn section_road_offset(net: &Network, sec: SectionId) -> f64 {
    let s = &net.sections[sec as usize];
    let seg = &net.segments[s.first_segment as usize];
    seg.road_offset_m - seg.section_offset_m
}

/// A stretch being merged: piece, road, road offsets, sections.
type Stretch = (u32, RoadId, f64, f64, Vec<(SectionId, f64, f64)>);
