//! What the all-read passes of plans reuse of the tag-free pass
//! ([`TagFreeRecord`]).

use crate::nav::Filter;
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
