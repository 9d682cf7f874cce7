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
    let mut raw: Vec<(u32, SectionId, f64, f64)> = Vec::new();
    let mut piece = 0u32;
    // The last point on the path: its position and time.
    let mut cur: Option<(OnSection, [f64; 2], f64)> = None;
    let mut breaks_at: Vec<u64> = breaks.iter().map(|b| b.after.0).collect();
    breaks_at.sort_unstable();
    for (i, p) in points.iter().enumerate() {
        let Some(mut at) = on_section(net, p) else {
            if cur.take().is_some() {
                piece += 1;
            }
            continue;
        };
        let broke = breaks_at.binary_search(&p.index).is_ok();
        let first = cur.is_none() || broke;
        let last = points
            .get(i + 1)
            .is_none_or(|q| q.segment.is_none() || breaks_at.binary_search(&q.index).is_ok());
        if first || last {
            at.offset_m = raw_offset(net, p, at.section);
        }
        let Some((a, a_pt, a_t)) = cur else {
            cur = Some((at, p.point, p.t_s));
            continue;
        };
        if broke {
            piece += 1;
            cur = Some((at, p.point, p.t_s));
            continue;
        }
        match join(paths, net, a, at, a_pt, p.point, p.t_s - a_t, params) {
            Join::Stay => {}
            Join::Pieces(pieces) => {
                for (s, f, t) in pieces {
                    raw.push((piece, s, f, t));
                }
                cur = Some((at, p.point, p.t_s));
            }
            Join::None => {
                piece += 1;
                cur = Some((at, p.point, p.t_s));
            }
        }
    }
    merge(net, &raw)
}

enum Join {
    /// No movement (the second point is the first, or a little behind it).
    Stay,
    /// Driven: (section, from, to) in order.
    Pieces(Vec<(SectionId, f64, f64)>),
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
) -> Join {
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
                    Join::Pieces(vec![(a.section, a.offset_m, b.offset_m)])
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
    match paths.path(a, b, bound, params.backtrack_m) {
        Some(pieces) => {
            let pieces: Vec<_> = pieces
                .into_iter()
                .filter(|(_, f, t)| (t - f).abs() > 1e-9)
                .collect();
            if pieces.is_empty() {
                Join::Stay
            } else {
                Join::Pieces(pieces)
            }
        }
        None => Join::None,
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

/// Merges consecutive pieces on one road that continue each other.
fn merge(net: &Network, raw: &[(u32, SectionId, f64, f64)]) -> Vec<PathStep> {
    let mut out: Vec<Stretch> = Vec::new();
    for &(piece, sec, f, t) in raw {
        let road = net.sections[sec as usize].road;
        let base = section_road_offset(net, sec);
        let (rf, rt) = (base + f, base + t);
        if let Some(last) = out.last_mut() {
            let same_dir = (last.3 - last.2) * (rt - rf) >= 0.0;
            if last.0 == piece && last.1 == road && (last.3 - rf).abs() < 1e-6 && same_dir {
                last.3 = rt;
                last.4.push((sec, f, t));
                continue;
            }
        }
        out.push((piece, road, rf, rt, vec![(sec, f, t)]));
    }
    // Pieces numbered 0, 1, ... (a piece of one point has no step).
    let mut number = 0u32;
    let mut last_piece = None;
    out.into_iter()
        .map(|(piece, road, f, t, secs)| {
            if last_piece.is_some_and(|l| l != piece) {
                number += 1;
            }
            last_piece = Some(piece);
            (number, road, f, t, secs)
        })
        .map(|(piece, road, f, t, secs)| PathStep {
            piece,
            road,
            from_offset_m: f,
            to_offset_m: t,
            sections: secs,
        })
        .collect()
}
