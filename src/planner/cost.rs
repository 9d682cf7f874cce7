//! The planner's cost counters (issue 14): filter steps and the stretch
//! maps' operations, each priced in filter steps of the same measured
//! cost, so that `Budget::passes` counts the planner's work in filter
//! passes of the route whatever the machine's load.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// The cost of applying one stretch map, in filter steps (one IMU sample
/// of `Budget::run`), for the planner's pass count: 14.9 µs a map
/// (21×21 solve and products) against 0.28–0.33 µs a step.
pub(super) const APPLY_STEPS: f64 = 50.0;
/// The cost of testing one anchor of an interior bound, in filter steps:
/// 0.2–0.35 µs an anchor (whole reaches less their steps and maps). With
/// these two, the counted work of the maps was 1.1 times the measured on
/// the demo's 204 reaches and 0.9–1.1 times on the Monaco 20 m route's.
pub(super) const ANCHOR_STEPS: f64 = 1.5;
/// The cost of composing one covariance op (a propagation or an accepted
/// update) into a stretch map during the tag-free pass, in filter steps:
/// the recording pass took 2.0–2.2 times a plain tag-free pass on the
/// demo (11,157 ops over 53,137 samples: 4.8–5.9 steps an op, three runs).
pub(super) const COMPOSE_STEPS: f64 = 6.0;
/// The cost of building one stretch's part of a node (a composition and
/// the carried anchor), in filter steps: 28 µs a part against 0.28–0.33
/// µs a step. A part's test is charged as an anchor's
/// ([`ANCHOR_STEPS`]: two 21-element rows against `P` and a 21×21 dot).
pub(super) const NODE_PART_STEPS: f64 = 95.0;

/// The cost of one candidate tested by the exact placement's search
/// (`placement::search`: one table look-up, its window's expansion shared
/// among the candidates it tests), in filter steps: on the paper's drive
/// (the one route where the search is a noticeable share, 10.7 M and
/// 14.0 M candidates tested by its two searches) a search re-run on its
/// reaches, all computed, took 7.3–10 ns a candidate against 0.27–0.28 µs
/// a step of one tag-free pass in the same run (two runs). On the short
/// routes a search tests a few thousand candidates at 40–60 ns each
/// (the windows' set-up is shared by fewer): this undercounts them by a
/// few hundredths of a pass at most.
pub(super) const SEARCH_TEST_STEPS: f64 = 0.035;

/// The planner's work counters (all threads): filter steps and the
/// stretch maps' operations, each counted in filter steps of the same
/// measured cost for `Budget::passes` (the constants above).
#[derive(Debug, Default)]
pub(crate) struct Work {
    steps: AtomicU64,
    /// Stretch (or node) maps applied.
    maps: AtomicU64,
    /// Anchors (or node parts) tested.
    anchors: AtomicU64,
    /// Stretches composed into nodes.
    node_parts: AtomicU64,
    /// Covariance ops composed into stretch maps.
    composed: AtomicU64,
    /// Candidates tested by the exact placement's searches.
    searched: AtomicU64,
    /// Stretches replayed (stepped from their start) by carried runs, and
    /// those replayed whole (the run went on after them).
    replays: AtomicU64,
    replays_through: AtomicU64,
    /// Replays started at a restart point inside their stretch.
    restarts: AtomicU64,
}

impl Work {
    pub(super) fn add_steps(&self, n: u64) {
        self.steps.fetch_add(n, Relaxed);
    }

    /// Counts `anchors` anchors tested, and one map applied when `applied`.
    pub(super) fn add_map(&self, anchors: usize, applied: bool) {
        self.anchors.fetch_add(anchors as u64, Relaxed);
        self.maps.fetch_add(u64::from(applied), Relaxed);
    }

    /// Counts the recording's ops composed and node parts built.
    pub(super) fn add_built(&self, ops: u64, node_parts: u64) {
        self.composed.fetch_add(ops, Relaxed);
        self.node_parts.fetch_add(node_parts, Relaxed);
    }

    /// Counts `n` maps applied without a test.
    pub(super) fn add_maps(&self, n: usize) {
        self.maps.fetch_add(n as u64, Relaxed);
    }

    /// Counts `n` candidates tested by a placement search.
    pub(super) fn add_searched(&self, n: u64) {
        self.searched.fetch_add(n, Relaxed);
    }

    /// Candidates tested by the placement searches.
    pub(super) fn searched(&self) -> u64 {
        self.searched.load(Relaxed)
    }

    pub(super) fn add_replay(&self) {
        self.replays.fetch_add(1, Relaxed);
    }

    pub(super) fn steps(&self) -> u64 {
        self.steps.load(Relaxed)
    }

    pub(super) fn maps(&self) -> u64 {
        self.maps.load(Relaxed)
    }

    pub(super) fn anchors(&self) -> u64 {
        self.anchors.load(Relaxed)
    }

    pub(super) fn composed(&self) -> u64 {
        self.composed.load(Relaxed)
    }

    pub(super) fn add_replay_through(&self) {
        self.replays_through.fetch_add(1, Relaxed);
    }

    pub(super) fn add_restart(&self) {
        self.restarts.fetch_add(1, Relaxed);
    }

    pub(super) fn restarts(&self) -> u64 {
        self.restarts.load(Relaxed)
    }

    /// Stretches replayed, and those of them replayed whole.
    pub(super) fn replays(&self) -> (u64, u64) {
        (
            self.replays.load(Relaxed),
            self.replays_through.load(Relaxed),
        )
    }

    /// The work in filter passes of a route of `samples` steps.
    pub(super) fn passes(&self, samples: usize) -> f64 {
        let work = self.steps() as f64
            + self.maps() as f64 * APPLY_STEPS
            + self.anchors() as f64 * ANCHOR_STEPS
            + self.node_parts.load(Relaxed) as f64 * NODE_PART_STEPS
            + self.composed() as f64 * COMPOSE_STEPS
            + self.searched() as f64 * SEARCH_TEST_STEPS;
        work / samples as f64
    }
}
