//! What the all-read passes of plans reuse of the tag-free pass
//! ([`TagFreeRecord`]).

use super::budget::{Budget, Site};
use crate::nav::ekf::Mat;
use crate::nav::Filter;
use crate::sim::tags::Mounting;
use crate::trajectory::TruthSample;

/// The profile grid (m) of `Plan::missed_bound`'s all-read bound (the
/// tag-free pass records its points for the all-read passes).
pub const MISSED_GRID_M: f64 = 50.0;

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
    /// (sample, bound) of each profile point.
    pub profile: Vec<(usize, f64)>,
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
            next_grid: MISSED_GRID_M,
            epoch_every,
            restarts: vec![],
        }
    }

    /// At sample `i` of the tag-free pass (filter `f`; the bound of a
    /// profile point made there; the candidate sites not yet passed).
    pub(super) fn visit(
        &mut self,
        samples: &[TruthSample],
        i: usize,
        f: &Filter,
        bound: impl Fn(&Filter) -> f64,
        profile_bound: Option<f64>,
        sites_m: &[f64],
    ) {
        let d = samples[i].avp.distance_m;
        if let Some(b) = profile_bound {
            self.profile.push((i, b));
        }
        if d >= self.next_grid {
            self.grid.push((i, bound(f)));
            self.next_grid += MISSED_GRID_M;
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
        s: &[TruthSample],
        first_fix: usize,
        every_m: f64,
        sites_m: &[f64],
        grid_m: f64,
    ) -> Option<Prefix> {
        if every_m != self.every_m || grid_m != MISSED_GRID_M {
            return None;
        }
        let n = self.restarts.partition_point(|(e, _)| *e < first_fix);
        let (epoch, filter) = self.restarts.get(n.checked_sub(1)?)?;
        let epoch = *epoch;
        if epoch == 0
            || sites_m
                .first()
                .is_some_and(|&x| x <= s[epoch].avp.distance_m)
        {
            return None;
        }
        let mut profile = vec![(0, self.profile.first()?.1)];
        let mut grid_max = profile[0].1;
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
                profile.push((i, b));
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
    /// ([`super::stretch::Stretches::prefixes`]), and given to the
    /// tag-free filter there; the fix and the samples up to the first
    /// boundary after the odometer epoch that follows the last fix are
    /// stepped (the fix shifts the propagation intervals until that
    /// epoch, module `stretch`), with the fixes and snapshots of the sites
    /// on the way. Each covariance carried by a map is lowered by
    /// [`OPTIMISTIC_MARGIN`], and so is each snapshot, so that every
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
