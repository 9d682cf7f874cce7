//! The Viterbi state: a candidate (one section and direction of travel)
//! and a step of the lag window.

use super::drift::{Drift, Emission, Line, LnCache};
use crate::matching::paths::{MatrixScratch, OnSection};
use crate::matching::Fix;
use crate::network::{NodeId, RoadId, SegmentId};

#[derive(Debug, Clone, Copy)]
pub(super) struct Cand {
    pub(super) seg: SegmentId,
    pub(super) line: Line,
    pub(super) at: OnSection,
    /// Emission under the common drift (candidate ranking, chain starts).
    pub(super) emission: f64,
    /// The heading part of the emission.
    pub(super) heading: f64,
    /// Unit direction of travel (east, north).
    pub(super) dir: [f64; 2],
    /// Direction of travel at least [`ANCHOR_M`] back along the best path
    /// into this state, and the distance from there (m).
    pub(super) anchor_dir: [f64; 2],
    pub(super) anchor_m: f64,
    /// The road of this state and of the state at the anchor.
    pub(super) road: RoadId,
    pub(super) anchor_road: RoadId,
    /// The drift estimated along the best path into this state, this
    /// step's fix included.
    pub(super) drift: Drift,
}

impl Cand {
    /// The route distance `d_m` from predecessor `p` to this candidate as a
    /// transition charges it: `uturn_m` more when the vehicle would face the
    /// other way after a short drive, a U-turn at a node or round a small
    /// loop, in one transition (facing against `p` within `uturn_m`) or over
    /// a few (facing against `p`'s anchor within 2 [`ANCHOR_M`] on the
    /// anchor's road). Both models' rule.
    #[inline]
    pub(super) fn charged_from(&self, p: &Cand, d_m: f64, uturn_m: f64) -> f64 {
        let dot = |u: [f64; 2]| u[0] * self.dir[0] + u[1] * self.dir[1];
        // (The cheap tests first: the same booleans.)
        let turned = (d_m < uturn_m && dot(p.dir) < -0.5)
            || (p.anchor_road == self.road
                && p.anchor_m + d_m < 2.0 * ANCHOR_M
                && dot(p.anchor_dir) < -0.5);
        if turned {
            d_m + uturn_m
        } else {
            d_m
        }
    }

    /// Sets this candidate's anchor (direction, distance back, road).
    #[inline]
    pub(super) fn set_anchor(&mut self, (dir, m, road): ([f64; 2], f64, RoadId)) {
        self.anchor_dir = dir;
        self.anchor_m = m;
        self.anchor_road = road;
    }

    /// The anchor (direction, distance back, road) a candidate takes over
    /// from its best predecessor `p`, `d_m` back along the route: `p`'s own
    /// place once the anchor would lie more than [`ANCHOR_M`] back.
    #[inline]
    pub(super) fn anchor_through(p: &Cand, d_m: f64) -> ([f64; 2], f64, RoadId) {
        if p.anchor_m + d_m > ANCHOR_M {
            (p.dir, d_m, p.road)
        } else {
            (p.anchor_dir, p.anchor_m + d_m, p.anchor_road)
        }
    }
}

/// Distance back along the path at which the earlier direction of travel is
/// compared with the current one to recognise U-turns (m).
pub(super) const ANCHOR_M: f64 = 40.0;

#[derive(Debug)]
pub(super) struct Step {
    pub(super) index: u64,
    /// The fix as given.
    pub(super) fix: Fix,
    pub(super) cands: Vec<Cand>,
    pub(super) score: Vec<f64>,
    pub(super) back: Vec<u32>,
    /// Forward (filtered) probability of each candidate, normalised.
    pub(super) alpha: Vec<f64>,
    /// Transition × emission weights from the previous step's candidates
    /// (rows) into this step's (columns), scaled to a largest weight of 1;
    /// empty at a chain's first step.
    pub(super) pair: Vec<f64>,
    /// Fixes after this step, before the next (index, fix).
    pub(super) pending: Vec<(u64, Fix)>,
}

/// Buffers of the transition step, kept between steps (no allocation per step).
#[derive(Debug, Default)]
pub(super) struct TransBuf {
    /// The predecessors' and the candidates' points.
    pub(super) from: Vec<OnSection>,
    pub(super) at: Vec<OnSection>,
    pub(super) scratch: MatrixScratch,
    /// Route distances, predecessor-major.
    pub(super) dist: Vec<Option<f64>>,
    /// For each candidate, the first one on the same segment (itself if
    /// none).
    pub(super) twin: Vec<u32>,
    /// For each predecessor, the first one whose predicted drift is the
    /// same bit for bit (itself if none).
    pub(super) class: Vec<u32>,
    /// Emissions computed, by (predecessor, candidate), predecessor-major,
    /// and which slots this step filled.
    pub(super) em: Vec<Emission>,
    pub(super) em_set: Vec<bool>,
    /// The emissions' logarithms.
    pub(super) ln: LnCache,
    /// Each candidate's entry node and the distance from it (directed
    /// states).
    pub(super) entries: Vec<(NodeId, f64)>,
    /// Each candidate's best predecessor's route distance and emission slot.
    pub(super) win_d: Vec<f64>,
    pub(super) win_em: Vec<u32>,
}

impl TransBuf {
    /// Buffers for up to `n` candidates per step.
    pub(super) fn with_capacity(n: usize) -> Self {
        Self {
            from: Vec::with_capacity(n),
            at: Vec::with_capacity(n),
            scratch: MatrixScratch::with_capacity(n),
            dist: Vec::with_capacity(n * n),
            twin: Vec::with_capacity(n),
            class: Vec::with_capacity(n),
            em: Vec::with_capacity(n * n),
            em_set: Vec::with_capacity(n * n),
            ln: LnCache::default(),
            entries: Vec::with_capacity(n),
            win_d: Vec::with_capacity(n),
            win_em: Vec::with_capacity(n),
        }
    }
}
