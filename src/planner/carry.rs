//! Runs of the route budget carried by the tag-free pass's stretch maps
//! (module `stretch`) where they apply, stepped elsewhere: the same
//! answers as stepping every sample (see `stretch` for why); and the
//! lower bound's optimistic snapshots carried by them
//! ([`Budget::optimistic_sites`]).

use super::budget::{Budget, Site};
use super::stretch::INTERIOR_MARGIN;
use crate::nav::ekf::Mat;
use crate::nav::Filter;
use crate::sim::tags::Mounting;

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
                let level = worst / (1.0 + INTERIOR_MARGIN);
                let (start, mut g) = st.replay_start(m, &p, level, self.work());
                step(start, &mut g, st.bounds[m + 1], &mut worst);
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

/// The relative amount a covariance carried by a map is lowered by in
/// [`Budget::optimistic_sites`] (and each snapshot once more): a map's
/// covariance and the stepped one differ by round-off (≈ 1e-12 relative,
/// measured on the demo's sites; the stretch maps'
/// [`super::stretch::INTERIOR_MARGIN`] is the same figure) and the
/// carried filter's state by round-off too (at most 7e-11 relative
/// in the covariance, measured), so the lowered one is below the stepped
/// one and the lower bound's reaches from it are at least the stepped
/// snapshots' (test `optimistic_snapshots_by_the_maps_are_the_stepped_ones`).
const OPTIMISTIC_MARGIN: f64 = 1e-9;

impl Budget<'_> {
    /// The snapshots of [`Budget::snapshots`] with a fix of `mountings[j]`
    /// read at every site (the lower bound's optimistic filters), from the
    /// tag-free snapshots `sites` (the candidate sites of the tag-free
    /// pass, or some of them, in route order), without stepping most of
    /// the drive: from a boundary of the stretch maps, the covariance is
    /// carried by the whole stretches' maps to the start of the stretch
    /// holding the next site, then by that site's prefix map to the site
    /// (`Stretches::prefixes`), and given to the
    /// tag-free filter there; the fix and the samples up to the first
    /// boundary after the odometer epoch that follows the last fix are
    /// stepped (the fix shifts the propagation intervals until that
    /// epoch, module `stretch`), with the fixes and snapshots of the sites
    /// on the way. Each covariance carried by a map is lowered by
    /// `OPTIMISTIC_MARGIN`, and so is each snapshot, so that every
    /// snapshot is at most the stepped pass's (a lower bound must never
    /// come out above the stepped one by round-off). None when there are
    /// no maps or a site lies at the drive's first sample.
    pub fn optimistic_sites(&self, sites: &[Site], mountings: &[Mounting]) -> Option<Vec<Site>> {
        let st = self.stretches()?;
        let end = *st.bounds.last()?;
        if st.bounds[0] != 0
            || sites.first().is_some_and(|s| s.sample == 0)
            || sites.windows(2).any(|w| w[1].sample < w[0].sample)
            || sites.last().is_some_and(|s| s.sample > end)
        {
            return None;
        }
        let lower = |p: Mat| p * (1.0 - OPTIMISTIC_MARGIN);
        // Each snapshot lowered too: stepped from a lowered covariance
        // through fixes, the lowering fades where the fixes contract it,
        // and the carried filter's state (the tag-free one's) differs from
        // the stepped pass's by round-off (measured on the demo: up to
        // 7e-11 relative above the stepped covariance without this).
        let snapshot = |site: &Site, g: &Filter| {
            let mut filter = g.clone();
            filter.set_covariance(lower(*g.covariance()));
            Site {
                sample: site.sample,
                distance_m: site.distance_m,
                filter,
            }
        };
        let mut out: Vec<Site> = Vec::with_capacity(sites.len());
        // The all-read covariance at boundary `bounds[m]`.
        let mut p = *st.filters[0].covariance();
        let mut m = 0;
        let mut j = 0;
        while j < sites.len() {
            let s = sites[j].sample;
            // The stretch holding the site: bounds[ms] < s ≤ bounds[ms + 1].
            let ms = st.bounds.partition_point(|&b| b < s) - 1;
            for e in &st.elements[m..ms] {
                p = lower(e.apply(&p));
            }
            let prefix = st.prefix_at(s)?;
            p = lower(prefix.apply(&p));
            self.work().add_maps(ms - m + 1);
            let mut g = sites[j].filter.clone();
            g.set_covariance(p);
            // The sites at this sample, then their fixes.
            let first = j;
            while j < sites.len() && sites[j].sample == s {
                out.push(snapshot(&sites[j], &g));
                j += 1;
            }
            for &mt in &mountings[first..j] {
                self.apply_fix(s, &mut g, mt);
            }
            // Step to the first boundary after the epoch after the last fix.
            let target = |i: usize| st.first_after(i).map_or(end, |m| st.bounds[m]);
            let mut to = target(s);
            if s < end {
                self.run(s, &mut g, |i, g| {
                    let first = j;
                    while j < sites.len() && sites[j].sample == i {
                        out.push(snapshot(&sites[j], g));
                        j += 1;
                    }
                    for &mt in &mountings[first..j] {
                        self.apply_fix(i, g, mt);
                    }
                    if j > first {
                        to = target(i);
                    }
                    i < to
                });
            }
            if to >= end {
                break;
            }
            m = st.bounds.partition_point(|&b| b < to);
            p = *g.covariance();
        }
        (out.len() == sites.len()).then_some(out)
    }
}
