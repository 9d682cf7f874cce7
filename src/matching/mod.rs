//! Map matching: positions (dead-reckoned, drifting) to points on the road
//! network.
//!
//! Two matchers share one interface ([`Matcher`]): fixes go in one by one,
//! matched points come out in input order.
//! - [`IncrementalMatcher`]: the paper's method (PAPERS.md §3.3): grid
//!   candidates when lost, tracking on one segment, candidates from the
//!   connectivity topology when the segment is left; immediate output.
//! - [`HmmMatcher`]: a hidden-Markov matcher (Viterbi over candidate road
//!   sections, transitions by network distance) with a bounded lag window,
//!   splitting at gaps and off-road stretches.
//!
//! Input/output files ([`track`]: TRACK.csv and MATCHED.csv; [`inputs`]:
//! GPX and GeoJSON tracks, recognised by content), the `match` command's
//! options with defaults from the track ([`options`]), the complete matched
//! path ([`cpath`], written by [`path_out`]), scoring against ground truth
//! ([`evaluate`]) and seeded synthetic tracks along routes (`synthetic`)
//! complete the module; the synthetic tracks' names are re-exported here.

pub mod cpath;
pub mod evaluate;
mod hmm;
mod incremental;
pub mod inputs;
pub mod options;
pub mod path_out;
mod paths;
mod search;
pub mod stream;
pub(crate) mod synthetic;
pub mod track;

pub use hmm::{HmmMatcher, HmmModel, HmmParams};
pub use incremental::{IncrementalMatcher, IncrementalParams};
pub use paths::{MatrixScratch, NetworkDistances, OnSection};
pub use synthetic::{along_route, route_truth, SyntheticTrack, TrackModel};

use crate::network::geometry::{closest_on_segment, coord, norm};
use crate::network::{Network, Oneway, RoadId, SegmentId};
use geo::{Euclidean, Length};

/// One position to match, in the network's ENU frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fix {
    /// Time (s).
    pub t_s: f64,
    /// ENU position (m): east, north.
    pub enu: [f64; 2],
    /// Heading (radians, clockwise from north), where the source gives one.
    pub heading_rad: Option<f64>,
}

/// How a point was matched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatchState {
    /// Incremental matcher: chosen among grid candidates (no usable history).
    Initial,
    /// Incremental matcher: still on the last matched segment.
    Tracking,
    /// Incremental matcher: chosen among the topology's connected segments.
    Update,
    /// Robust matcher: matched.
    Matched,
    /// Not matched (no road near, or inside a reported unmatched span).
    Unmatched,
}

impl MatchState {
    /// The name written to MATCHED.csv.
    pub fn as_str(self) -> &'static str {
        match self {
            MatchState::Initial => "initial",
            MatchState::Tracking => "tracking",
            MatchState::Update => "update",
            MatchState::Matched => "matched",
            MatchState::Unmatched => "unmatched",
        }
    }

    /// Is the point on a road?
    pub fn is_matched(self) -> bool {
        self != MatchState::Unmatched
    }
}

/// The match of one input fix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchedPoint {
    /// Index of the fix in the order it was pushed (0-based).
    pub index: u64,
    /// Time (s) of the fix.
    pub t_s: f64,
    /// The fix's ENU position (m).
    pub fix: [f64; 2],
    /// State; [`MatchState::Unmatched`] leaves the fields below empty.
    pub state: MatchState,
    /// The matched segment.
    pub segment: Option<SegmentId>,
    /// The matched road.
    pub road: Option<RoadId>,
    /// Distance along the road from its start (m).
    pub road_offset_m: f64,
    /// The matched point (ENU, m).
    pub point: [f64; 2],
    /// Distance from the fix to the matched point (m).
    pub distance_m: f64,
    /// Confidence in 0..=1 (the HMM's smoothed posterior probability of the
    /// chosen road over its lag window, under [`HmmModel::Independent`] its
    /// filtered share of the step's Viterbi scores; the incremental
    /// matcher's score f).
    pub confidence: f64,
    /// Direction of travel along the section (`true`: its digitised
    /// direction), where the matcher decides it (the HMM).
    pub forward: Option<bool>,
}

impl MatchedPoint {
    /// An unmatched point.
    pub fn unmatched(index: u64, fix: &Fix) -> Self {
        MatchedPoint {
            index,
            t_s: fix.t_s,
            fix: fix.enu,
            state: MatchState::Unmatched,
            segment: None,
            road: None,
            road_offset_m: f64::NAN,
            point: [f64::NAN; 2],
            distance_m: f64::NAN,
            confidence: 0.0,
            forward: None,
        }
    }
}

/// Why a track was split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BreakReason {
    /// Consecutive fixes too far apart in time or distance.
    Gap,
    /// Fixes with no road within the search radius.
    OffRoad,
    /// No permitted path between the candidates of consecutive fixes.
    NoPath,
}

impl BreakReason {
    /// A short name.
    pub fn as_str(self) -> &'static str {
        match self {
            BreakReason::Gap => "gap",
            BreakReason::OffRoad => "off_road",
            BreakReason::NoPath => "no_path",
        }
    }
}

/// A place where matching was interrupted and restarted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Break {
    /// Why.
    pub reason: BreakReason,
    /// Index and time of the last fix before the break that was matched (if any).
    pub before: Option<(u64, f64)>,
    /// Index and time of the first fix after it.
    pub after: (u64, f64),
}

/// An online map matcher: fixes in, matched points out (in input order).
pub trait Matcher {
    /// Takes the next fix (times must not decrease); appends the points whose
    /// match is now decided to `out`.
    fn push(&mut self, fix: &Fix, out: &mut Vec<MatchedPoint>);
    /// Ends the track: appends every point still undecided.
    fn finish(&mut self, out: &mut Vec<MatchedPoint>);
    /// Breaks found so far.
    fn breaks(&self) -> &[Break];
}

/// Matches a whole track with any matcher.
pub fn match_track<M: Matcher + ?Sized>(matcher: &mut M, fixes: &[Fix]) -> Vec<MatchedPoint> {
    let mut out = Vec::with_capacity(fixes.len());
    for f in fixes {
        matcher.push(f, &mut out);
    }
    matcher.finish(&mut out);
    out
}

/// A run of consecutive unmatched points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnmatchedSpan {
    /// First and last point index.
    pub first: u64,
    /// Last point index (inclusive).
    pub last: u64,
    /// Times of the first and last point (s).
    pub t_s: [f64; 2],
}

/// Runs of unmatched points in a matched track.
pub fn unmatched_spans(points: &[MatchedPoint]) -> Vec<UnmatchedSpan> {
    let mut out = Vec::new();
    unmatched_spans_into(points, &mut out);
    out
}

/// [`unmatched_spans`] into `out` (emptied first).
pub fn unmatched_spans_into(points: &[MatchedPoint], out: &mut Vec<UnmatchedSpan>) {
    out.clear();
    let mut prev_unmatched = false;
    for p in points {
        if p.state.is_matched() {
            prev_unmatched = false;
            continue;
        }
        match out.last_mut() {
            Some(s) if prev_unmatched => {
                s.last = p.index;
                s.t_s[1] = p.t_s;
            }
            _ => out.push(UnmatchedSpan {
                first: p.index,
                last: p.index,
                t_s: [p.t_s, p.t_s],
            }),
        }
        prev_unmatched = true;
    }
}

/// Orthogonal projection of `p` onto segment `seg`: (parameter t in 0..=1,
/// the point, the distance). The closest point is `geo`'s; the distance is
/// the hand-written [`norm`] (`geo`'s `hypot`-based distance measured 5–10×
/// slower here, and this runs for every candidate segment of every fix).
#[inline]
pub(crate) fn project(net: &Network, seg: SegmentId, p: [f64; 2]) -> (f64, [f64; 2], f64) {
    let s = &net.segments[seg as usize];
    let (t, q) = closest_on_segment(&s.line(), coord(p));
    (t, q.into(), norm(p[0] - q.x, p[1] - q.y))
}

/// Cosine of the angle between a heading (clockwise from north) and the
/// directions a segment may be driven in: a two-way segment counts in
/// either direction (|cos|), a one-way one only in its permitted direction.
#[inline]
pub(crate) fn heading_cos(net: &Network, seg: SegmentId, heading_rad: f64) -> f64 {
    let s = &net.segments[seg as usize];
    let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
    let len = Euclidean.length(&s.line());
    if len <= 0.0 {
        return 0.0;
    }
    // Heading clockwise from north: unit vector (sin h, cos h) in (east, north).
    let (sh, ch) = heading_rad.sin_cos();
    let c = (dx * sh + dy * ch) / len;
    match net.sections[s.section as usize].oneway {
        Oneway::Both => c.abs(),
        Oneway::Forward => c,
        Oneway::Backward => -c,
    }
}

/// A matched point on segment `seg` for fix `fix`.
#[inline]
pub(crate) fn matched_on(
    net: &Network,
    index: u64,
    fix: &Fix,
    seg: SegmentId,
    state: MatchState,
    confidence: f64,
) -> MatchedPoint {
    let (t, q, d) = project(net, seg, fix.enu);
    let s = &net.segments[seg as usize];
    MatchedPoint {
        index,
        t_s: fix.t_s,
        fix: fix.enu,
        state,
        segment: Some(seg),
        road: Some(s.road),
        road_offset_m: s.road_offset_m + t * s.length_m,
        point: q,
        distance_m: d,
        confidence,
        forward: None,
    }
}
