//! Runs of the route budget carried by the tag-free pass's stretch maps
//! (module `stretch`) where they apply, stepped elsewhere: the same
//! answers as stepping every sample (see `stretch` for why).

use super::budget::{Budget, BudgetPoint, Site};
use super::stretch::INTERIOR_MARGIN;
use crate::nav::Filter;
use crate::sim::tags::Mounting;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// The planner's work counters (all threads): filter steps and the
/// stretch maps' operations, each counted in filter steps of the same
/// measured cost for [`Budget::passes`] (the constants in module
/// `stretch`).
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
    /// Stretches replayed (stepped from their start) by carried runs, and
    /// those replayed whole (the run went on after them).
    replays: AtomicU64,
    replays_through: AtomicU64,
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

    /// Stretches replayed, and those of them replayed whole.
    pub(super) fn replays(&self) -> (u64, u64) {
        (
            self.replays.load(Relaxed),
            self.replays_through.load(Relaxed),
        )
    }

    /// The work in filter passes of a route of `samples` steps.
    pub(super) fn passes(&self, samples: usize) -> f64 {
        use super::stretch::{ANCHOR_STEPS, APPLY_STEPS, COMPOSE_STEPS, NODE_PART_STEPS};
        let work = self.steps() as f64
            + self.maps() as f64 * APPLY_STEPS
            + self.anchors() as f64 * ANCHOR_STEPS
            + self.node_parts.load(Relaxed) as f64 * NODE_PART_STEPS
            + self.composed() as f64 * COMPOSE_STEPS;
        work / samples as f64
    }
}

/// What the all-read passes of plans reuse of the tag-free pass: before
/// a plan's first fix its filter is the tag-free one, bit for bit (same
/// steps from the same prior), and a run resumed at an odometer epoch
/// reads what one carried on from the drive's start reads (the odometer
/// interval starts there; no map-matching feed, or there is no record), so
/// an all-read pass can start from the tag-free filter at the last epoch
/// before its first fix, its profile and grid up to there being the
/// tag-free pass's. The demo's plan has its first tag at 1.2 of 4.1 km.
#[derive(Debug)]
pub(crate) struct TagFreeRecord {
    every_m: f64,
    /// (sample, bound) of each profile point of the tag-free pass.
    pub(super) profile: Vec<(usize, f64)>,
    /// (sample, bound) at each point of the missed-read grid.
    grid: Vec<(usize, f64)>,
    next_grid: f64,
    epoch_every: usize,
    /// The tag-free filter at the last odometer epoch before each
    /// candidate site.
    restarts: Vec<(usize, Filter)>,
}

/// An all-read pass's state after its samples up to `epoch` (from the
/// tag-free pass, [`TagFreeRecord::prefix`]).
pub(super) struct Prefix {
    pub epoch: usize,
    pub filter: Filter,
    pub profile: Vec<BudgetPoint>,
    pub grid_max: f64,
    pub next_prof: f64,
    pub next_grid: f64,
}

impl TagFreeRecord {
    /// A record of a tag-free pass with profile points every `every_m`
    /// (the first one, at the first sample, `bound0`).
    pub(super) fn new(every_m: f64, bound0: f64, epoch_every: usize) -> Self {
        Self {
            every_m,
            profile: vec![(0, bound0)],
            grid: vec![],
            next_grid: super::output::MISSED_GRID_M,
            epoch_every,
            restarts: vec![],
        }
    }

    /// At sample `i` of the tag-free pass (filter `f`; the bound of a
    /// profile point made there; the candidate sites not yet passed).
    pub(super) fn visit(
        &mut self,
        budget: &Budget<'_>,
        i: usize,
        f: &Filter,
        profile_bound: Option<f64>,
        sites_m: &[f64],
    ) {
        let samples = budget.samples();
        let d = samples[i].avp.distance_m;
        if let Some(b) = profile_bound {
            self.profile.push((i, b));
        }
        if d >= self.next_grid {
            self.grid.push((i, budget.bound(&f.position_cov_enu())));
            self.next_grid += super::output::MISSED_GRID_M;
        }
        if i % self.epoch_every == 0 {
            // The next site after this sample, when before the next epoch.
            let next = samples[(i + self.epoch_every).min(samples.len() - 1)]
                .avp
                .distance_m;
            let j = sites_m.partition_point(|&x| x <= d);
            if sites_m.get(j).is_some_and(|&x| x <= next) {
                let mut g = f.clone();
                g.take_element();
                self.restarts.push((i, g));
            }
        }
    }

    /// The state of the all-read pass (profile every `every_m`, grid
    /// `grid_m`, snapshots at `sites_m`) whose first fix is at sample
    /// `first_fix`, after the last recorded epoch before it; None when
    /// the pass is not one this record covers.
    pub(super) fn prefix(
        &self,
        budget: &Budget<'_>,
        first_fix: usize,
        every_m: f64,
        sites_m: &[f64],
        grid_m: f64,
    ) -> Option<Prefix> {
        if every_m != self.every_m || grid_m != super::output::MISSED_GRID_M {
            return None;
        }
        let n = self.restarts.partition_point(|(e, _)| *e < first_fix);
        let (epoch, filter) = self.restarts.get(n.checked_sub(1)?)?;
        let s = budget.samples();
        let epoch = *epoch;
        if epoch == 0
            || sites_m
                .first()
                .is_some_and(|&x| x <= s[epoch].avp.distance_m)
        {
            return None;
        }
        let point = |i: usize, b: f64| BudgetPoint {
            t_s: s[i].avp.t,
            distance_m: s[i].avp.distance_m,
            bound95_m: b,
        };
        let mut profile = vec![point(0, self.profile.first()?.1)];
        let mut grid_max = profile[0].bound95_m;
        let (mut next_prof, mut next_grid) = (every_m, grid_m);
        let (mut kp, mut kg) = (1, 0);
        // The all-read pass's points up to the epoch, as it makes them.
        for (i, x) in s.iter().enumerate().take(epoch + 1).skip(1) {
            let d = x.avp.distance_m;
            if d >= next_grid {
                let &(gi, b) = self.grid.get(kg)?;
                if gi != i {
                    return None;
                }
                grid_max = grid_max.max(b);
                kg += 1;
                next_grid += grid_m;
            }
            if d >= next_prof {
                let &(pi, b) = self.profile.get(kp)?;
                if pi != i {
                    return None;
                }
                profile.push(point(i, b));
                kp += 1;
                next_prof += every_m;
            }
        }
        Some(Prefix {
            epoch,
            filter: filter.clone(),
            profile,
            grid_max,
            next_prof,
            next_grid,
        })
    }
}

impl Budget<'_> {
    /// The first sample after `from` where the bound of filter `f` (at
    /// sample `from`, on the truth, reading no more tags) exceeds `level`,
    /// or None if it holds to the route's end, exactly as stepping `f`
    /// says ([`Budget::run_carrying`]). `f` is left along the way.
    pub(super) fn first_above(&self, from: usize, f: &mut Filter, level: f64) -> Option<usize> {
        let mut hit = None;
        let level_c = std::cell::Cell::new(level);
        self.run_carrying(from, f, &[], &level_c, |i, f| {
            if self.bound(&f.position_cov_enu()) > level {
                hit = Some(i);
            }
            hit.is_none()
        });
        hit
    }

    /// The largest bound over the samples after `from` of filter `f` (at
    /// sample `from`, on the truth, reading no more tags), or `floor` when
    /// that is larger; exactly as stepping `f` says when it exceeds
    /// `floor`. `f` is left along the way.
    ///
    /// Two phases: the covariance is carried by the stretch maps to the
    /// route's end, keeping it at each boundary (one map a stretch, no
    /// test); then, from the last stretch back, a stretch is replayed
    /// (stepped from its start with that covariance) only when its
    /// interior bound (module `stretch`) exceeds the largest bound found so
    /// far: every sample of a stretch that is not replayed is at most that.
    /// A run whose bound grows to the end steps about its last stretch,
    /// where carrying it under the worst bound so far stepped every
    /// stretch where it grew.
    pub(super) fn max_to_end(&self, from: usize, f: &mut Filter, floor: f64) -> f64 {
        let mut worst = floor;
        let step = |from: usize, f: &mut Filter, until: usize, worst: &mut f64| {
            self.run(from, f, |i, f| {
                *worst = worst.max(self.bound(&f.position_cov_enu()));
                i < until
            });
        };
        let Some((st, m0)) = self
            .stretches()
            .and_then(|st| st.first_after(from).map(|m| (st, m)))
        else {
            step(from, f, usize::MAX, &mut worst);
            return worst;
        };
        if st.bounds[m0] > from {
            step(from, f, st.bounds[m0], &mut worst);
        }
        let last = st.bounds.len() - 1;
        let mut ps = Vec::with_capacity(last - m0);
        let mut p = *f.covariance();
        for m in m0..last {
            let next = st.elements[m].apply(&p);
            ps.push(p);
            p = next;
        }
        self.work().add_maps(last - m0);
        for m in (m0..last).rev() {
            let p = ps[m - m0];
            let (within, tested) = st.interior_within(m, &p, worst / (1.0 + INTERIOR_MARGIN));
            self.work().add_map(tested, false);
            if !within {
                self.work().add_replay();
                self.work().add_replay_through();
                let mut g = st.filters[m].clone();
                g.set_covariance(p);
                step(st.bounds[m], &mut g, st.bounds[m + 1], &mut worst);
            }
        }
        worst
    }

    /// Filter `f` (at sample `from`, on the truth, reading no more tags)
    /// at sample `to > from`: carried by the stretch maps up to the
    /// stretch that holds `to` (with no level to keep under) and stepped
    /// from there, as stepping `f` gives it up to the maps' round-off.
    pub(super) fn filter_at(&self, from: usize, mut f: Filter, to: usize) -> Filter {
        if to <= from {
            return f;
        }
        let level = std::cell::Cell::new(f64::INFINITY);
        self.run_carrying(from, &mut f, &[to], &level, |i, _| i < to);
        f
    }

    /// [`Budget::run`] with `visit`, but carried by the tag-free pass's
    /// stretch maps (module `stretch`) over stretches without a fix
    /// sample (`fixes`) whose bound provably stays at most `level` there,
    /// where `visit` must do nothing (it is not called there).
    pub(super) fn run_carrying(
        &self,
        from: usize,
        f: &mut Filter,
        fixes: &[usize],
        level: &std::cell::Cell<f64>,
        mut visit: impl FnMut(usize, &mut Filter) -> bool,
    ) {
        let mut step = |from: usize, f: &mut Filter, until: usize| {
            let mut go = true;
            self.run(from, f, |i, f| {
                go = visit(i, f);
                go && i < until
            });
            go
        };
        match self.stretches() {
            Some(st) => st.drive(from, f, fixes, level, step, self.work()),
            None => {
                step(from, f, usize::MAX);
            }
        }
    }

    /// Whether the filter that reads a tag at each of `sites[a..=b]` (with
    /// `mountings`), starting from `sites[a]`'s snapshot, has its bound
    /// above `level_m` at some sample after `sites[b]`'s before the route's
    /// end (the run stops there, or at the end).
    ///
    /// What it proves, when the snapshots are such that each later site's
    /// holds no information that `sites[a]`'s propagated with the fixes at
    /// the sites between lacks (the tag-free pass's snapshots, or a pass
    /// reading a tag at every site) and propagations restart exactly
    /// ([`PerfectData::restart_invariant`]): for every `j` in `a..=b`, the
    /// filter of `sites[j]`'s reach ([`Budget::reaches`]: its snapshot, the
    /// fix there, nothing after) has read only information this one has
    /// read too, through the same Riccati maps (same truth, same update
    /// rows; the state stays on the truth, so no linearisation differs).
    /// An extra update only lowers a covariance and the maps are monotone
    /// in the PSD order, so after `sites[b]` its covariance is at least
    /// this one's and its bound (the largest eigenvalue of the horizontal
    /// block) at least this one's: it exceeds the requirement at or before
    /// the sample where this one exceeds `level_m ≥ requirement`, and its
    /// reach ends before the route's end.
    pub(super) fn falls_short(
        &self,
        sites: &[Site],
        mountings: &[Mounting],
        (a, b): (usize, usize),
        level_m: f64,
    ) -> bool {
        let mut f = sites[a].filter.clone();
        let from = sites[a].sample;
        let last = sites[b].sample;
        let fixes: Vec<(usize, Mounting)> =
            (a..=b).map(|j| (sites[j].sample, mountings[j])).collect();
        let mut k = 0;
        while k < fixes.len() && fixes[k].0 <= from {
            self.apply_fix(from, &mut f, fixes[k].1);
            k += 1;
        }
        if last > from {
            self.run(from, &mut f, |i, f| {
                while k < fixes.len() && fixes[k].0 <= i {
                    self.apply_fix(i, f, fixes[k].1);
                    k += 1;
                }
                i < last
            });
        }
        // After the last fix: carried on by the stretch maps where they
        // apply (the same first sample above the level as stepping).
        let hit = self.first_above(last, &mut f, level_m);
        hit.is_some_and(|i| self.samples()[i - 1].avp.distance_m < self.length_m())
    }
}
