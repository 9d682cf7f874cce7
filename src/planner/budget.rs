//! Error budget along a route by covariance analysis: the integrated
//! navigator's own [`Filter`] is run on perfect data along the truth by the
//! covariance engine ([`crate::sim::covariance`]: ideal IMU increments,
//! exact odometer distances and heights, the map-matching feed when the
//! scenario uses it), so its state stays on the truth and its covariance is
//! the predicted one: no random runs. The predicted 95 % horizontal bound is
//! [`bound95`] (`sqrt(χ²₂(0.95) · λmax)`, a circle containing the 95 %
//! ellipse).
//!
//! A tag fix at a site resets the bound: the filter is taken as it is at the
//! site (from the tag-free pass), given the fix with the mounting's
//! covariance, and propagated on until the bound exceeds the requirement;
//! that distance is the site's reach.

use crate::nav::Filter;
use crate::network::Network;
use crate::scenario::Scenario;
use crate::sim::covariance::PerfectData;
use crate::sim::tags::Mounting;
use crate::sim::TruthSource;
use crate::trajectory::{ideal_imu, TruthSample};
use rayon::prelude::*;

pub use crate::sim::bound::bound95;

/// One point of a budget profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BudgetPoint {
    /// Time (s).
    pub t_s: f64,
    /// Distance along the route (m).
    pub distance_m: f64,
    /// Predicted 95 % horizontal bound (m).
    pub bound95_m: f64,
}

/// A snapshot of the tag-free filter at a candidate site.
#[derive(Debug, Clone)]
pub struct Site {
    /// Index of the truth sample.
    pub sample: usize,
    /// Distance along the route (m).
    pub distance_m: f64,
    /// The filter there.
    pub filter: Filter,
}

/// The covariance analysis of one route.
pub struct Budget<'a> {
    data: PerfectData<'a>,
    samples: Vec<TruthSample>,
    /// The map and the route under the truth, and the route's length per
    /// metre of truth distance, for the lane width at a sample (none
    /// without a map: `[rfid]`'s lane width everywhere); looked up at the
    /// fixes only (a lookup for every sample took about 0.2 passes).
    road: Option<(&'a Network, &'a crate::route::Route, f64)>,
    /// The planner's work so far (all threads), in filter steps and
    /// stretch-map operations ([`Budget::passes`]).
    work: super::cost::Work,
    /// The probability the bound holds with (`planner.requirement_confidence`).
    p: f64,
    /// The tag-free pass's stretch maps (module `stretch`), when the
    /// propagations restart exactly.
    stretches: std::sync::OnceLock<super::stretch::Stretches>,
    /// What the all-read passes reuse of the tag-free pass.
    tag_free_record: std::sync::OnceLock<super::record::TagFreeRecord>,
}

impl std::fmt::Debug for Budget<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Budget")
            .field("samples", &self.samples.len())
            .finish()
    }
}

impl<'a> Budget<'a> {
    /// Prepares the truth (with ideal IMU increments) of a scenario's route;
    /// `network` (the scenario's map) gives each sample's lane width (for
    /// roadside fixes) and feeds map matching when the scenario uses it.
    pub fn new(scn: &'a Scenario, truth: &'a TruthSource, network: Option<&'a Network>) -> Self {
        let cap = scn.duration_cap_s() + 0.5 * scn.dt;
        // Reserved for the whole drive (growing the vector by doubling
        // copied it and touched twice the memory).
        let expect = (cap.min(truth.duration_s()) / scn.dt).max(0.0) as usize + 2;
        let mut samples: Vec<TruthSample> = Vec::with_capacity(expect);
        // The truth's samples (the trajectory) and their ideal IMU
        // increments (inverse strapdown) are about half of the set-up each:
        // made on two threads, in chunks (a pipeline; same samples).
        const CHUNK: usize = 4096;
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<crate::trajectory::Avp>>(8);
        std::thread::scope(|sc| {
            sc.spawn(move || {
                let mut avps = truth.samples().take_while(|a| a.t <= cap);
                loop {
                    let chunk: Vec<_> = avps.by_ref().take(CHUNK).collect();
                    if chunk.is_empty() || tx.send(chunk).is_err() {
                        break;
                    }
                }
            });
            samples.extend(ideal_imu(rx.into_iter().flatten(), scn.dt));
        });
        // The route the truth was compiled from (planned once, with the
        // truth's network; `network` is the same map).
        let road = match (network, truth.route()) {
            (Some(net), Some(route)) => {
                let len = samples.last().map_or(0.0, |s| s.avp.distance_m);
                let scale = if len > 0.0 { route.length_m / len } else { 1.0 };
                Some((net, route, scale))
            }
            _ => None,
        };
        Self {
            data: PerfectData::new(scn)
                .with_map_feed(network.filter(|_| scn.aiding().map_matching)),
            samples,
            road,
            work: super::cost::Work::default(),
            p: scn.planner().requirement_confidence,
            stretches: std::sync::OnceLock::new(),
            tag_free_record: std::sync::OnceLock::new(),
        }
    }

    /// The horizontal bound (m) of a filter's covariance at the
    /// requirement's confidence (`planner.requirement_confidence`): the
    /// circle holding the 2-D covariance's ellipse of that probability
    /// ([`bound95`] at the default 0.95, computed by it so that plans stay
    /// bit-identical).
    pub fn bound(&self, c: &[[f64; 3]; 3]) -> f64 {
        if self.p == 0.95 {
            bound95(c)
        } else {
            crate::sim::bound::bound_at(c, self.p)
        }
    }

    /// Filter steps taken so far through [`Budget::run`] (and the calls
    /// built on it), on every thread.
    pub fn steps(&self) -> u64 {
        self.work.steps()
    }

    /// The planner's cost in filter passes of the route, whatever the load:
    /// [`Budget::steps`] plus the stretch maps' building and applications
    /// in filter steps of the same cost (module `stretch`), over samples.
    pub fn passes(&self) -> f64 {
        self.work
            .passes(self.samples.len().saturating_sub(1).max(1))
    }

    /// The work counters.
    pub(super) fn work(&self) -> &super::cost::Work {
        &self.work
    }

    /// Whether propagations restart exactly
    /// ([`PerfectData::restart_invariant`]).
    pub(super) fn restart_invariant(&self) -> bool {
        self.data.restart_invariant()
    }

    /// The tag-free pass's record for the all-read passes, once made.
    pub(super) fn tag_free_record(&self) -> Option<&super::record::TagFreeRecord> {
        self.tag_free_record.get()
    }

    /// The stretch maps, once the tag-free pass has built them.
    pub(super) fn stretches(&self) -> Option<&super::stretch::Stretches> {
        self.stretches.get()
    }

    /// Covariance ops composed into stretch maps so far.
    pub fn composed(&self) -> u64 {
        self.work.composed()
    }

    /// Stretch maps applied so far (all threads).
    pub fn jumps(&self) -> u64 {
        self.work.maps()
    }

    /// Stretch replays started at a restart point inside their stretch so
    /// far (all threads).
    pub fn restarts(&self) -> u64 {
        self.work.restarts()
    }

    /// The lane width (m) at sample `i`, when the route is on a map.
    pub fn lane_width_at(&self, i: usize) -> Option<f64> {
        let (net, route, scale) = self.road?;
        let s = self.samples.get(i)?;
        let span = route.span_at(s.avp.distance_m * scale);
        let a = &net.model.roads[span.road as usize].attributes;
        // Through f32, as the per-sample table this replaces stored it.
        Some(f64::from(super::settings::lane_width_m(a) as f32))
    }

    /// The truth samples.
    pub fn samples(&self) -> &[TruthSample] {
        &self.samples
    }

    /// Route length (m).
    pub fn length_m(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.avp.distance_m)
    }

    /// Steps the filter on perfect data over samples `from+1..`, calling
    /// `visit(index, filter)` after each; stops when `visit` returns false.
    /// Odometer, constraint, barometer and map-matching updates happen as in
    /// the navigator (the map-matching feed restarts at `from`).
    pub fn run(
        &self,
        from: usize,
        filter: &mut Filter,
        mut visit: impl FnMut(usize, &mut Filter) -> bool,
    ) {
        let epoch = from - from % self.data.odometer_every();
        let mut p = self.data.resume(
            filter,
            self.samples[from].avp.distance_m,
            self.samples[epoch].avp.distance_m,
        );
        let mut n = 0u64;
        for (i, s) in self.samples.iter().enumerate().skip(from + 1) {
            p.step(i, s, filter);
            n += 1;
            if !visit(i, filter) {
                break;
            }
        }
        self.work.add_steps(n);
    }

    /// A filter at the first truth sample with the scenario's prior.
    pub fn initial_filter(&self) -> Option<Filter> {
        let first = self.samples.first()?;
        Some(self.data.filter_at(&first.avp))
    }

    /// The tag-free pass: the bound profile every `every_m` of distance, and
    /// filter snapshots at distances `sites_m` (increasing).
    pub fn tag_free(&self, every_m: f64, sites_m: &[f64]) -> (Vec<BudgetPoint>, Vec<Site>) {
        self.snapshots(&[], every_m, sites_m)
    }

    /// As [`Budget::tag_free`], with fixes (sample index, mounting;
    /// increasing) applied on the way; a snapshot at a fix's sample is taken
    /// before the fix.
    pub fn snapshots(
        &self,
        fixes: &[(usize, Mounting)],
        every_m: f64,
        sites_m: &[f64],
    ) -> (Vec<BudgetPoint>, Vec<Site>) {
        let mut k = 0;
        let Some(mut f) = self.initial_filter() else {
            return (vec![], vec![]);
        };
        let mut prof = vec![BudgetPoint {
            t_s: self.samples[0].avp.t,
            distance_m: self.samples[0].avp.distance_m,
            bound95_m: self.bound(&f.position_cov_enu()),
        }];
        let mut next_prof = every_m;
        let mut sites = Vec::with_capacity(sites_m.len());
        let mut next_site = 0;
        // The tag-free pass records the stretch maps (module `stretch`).
        let mut rec = match self.data.resync_every() {
            Some(sync)
                if fixes.is_empty()
                    && self.data.restart_invariant()
                    && self.stretches.get().is_none() =>
            {
                let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
                let chi2 = self.bound(&unit).powi(2);
                let mut r = super::stretch::Recorder::new(sync, chi2, super::stretch::MIN_SAMPLES);
                r.visit(0, &mut f, true, self.samples.len() == 1);
                Some(r)
            }
            _ => None,
        };
        let mut pending_site = false;
        let mut tfr = rec.as_ref().map(|_| {
            super::record::TagFreeRecord::new(
                every_m,
                prof[0].bound95_m,
                self.data.odometer_every(),
            )
        });
        let n = self.samples.len();
        take_sites(
            &mut sites,
            &mut next_site,
            sites_m,
            0.0,
            (0, self.samples[0].avp.distance_m),
            &f,
        );
        self.run(0, &mut f, |i, f| {
            let a = &self.samples[i].avp;
            if a.distance_m >= next_prof {
                prof.push(BudgetPoint {
                    t_s: a.t,
                    distance_m: a.distance_m,
                    bound95_m: self.bound(&f.position_cov_enu()),
                });
                next_prof += every_m;
            }
            if let Some(t) = tfr.as_mut() {
                let at_prof = prof.len() > t.profile.len();
                t.visit(
                    &self.samples,
                    i,
                    f,
                    |g| self.bound(&g.position_cov_enu()),
                    at_prof.then(|| prof[prof.len() - 1].bound95_m),
                    &sites_m[next_site..],
                );
            }
            if let Some(r) = rec.as_mut() {
                // A stretch starts at the first odometer epoch after a
                // candidate site: a run from a fix there steps to it only.
                let boundary = pending_site && i % r.sync_every() == 0;
                let site_here = next_site < sites_m.len() && sites_m[next_site] <= a.distance_m;
                pending_site &= !boundary;
                pending_site |= site_here;
                if site_here {
                    // The map from the stretch's start to the site (its
                    // ops up to the site's sample; for
                    // `Budget::optimistic_sites`).
                    r.site_prefix(i, f);
                }
                r.visit(i, f, boundary, i + 1 == n);
            }
            take_sites(
                &mut sites,
                &mut next_site,
                sites_m,
                a.distance_m,
                (i, a.distance_m),
                f,
            );
            while k < fixes.len() && fixes[k].0 <= i {
                self.apply_fix(i, f, fixes[k].1);
                k += 1;
            }
            true
        });
        if let Some(st) = rec.and_then(super::stretch::Recorder::finish) {
            let ops: u64 = st.elements.iter().map(|e| e.ops).sum();
            self.work.add_built(ops, 0);
            let _ = self.stretches.set(st);
            if let Some(t) = tfr {
                let _ = self.tag_free_record.set(t);
            }
        }
        (prof, sites)
    }

    /// Distance up to which the bound stays within `requirement_m` from the
    /// start (with the scenario's prior).
    pub fn start_reach(&self, requirement_m: f64) -> f64 {
        let Some(mut f) = self.initial_filter() else {
            return 0.0;
        };
        if self.bound(&f.position_cov_enu()) > requirement_m {
            return 0.0;
        }
        self.reach_from(0, &mut f, requirement_m)
    }

    /// The distance of the last sample before the bound of `f` (at sample
    /// `from`) first exceeds `requirement_m`, or the route's length.
    fn reach_from(&self, from: usize, f: &mut Filter, requirement_m: f64) -> f64 {
        match self.first_above(from, f, requirement_m) {
            Some(i) => self.samples[i - 1].avp.distance_m,
            None => self.length_m(),
        }
    }

    /// The fix a tag of `mounting` gives at truth sample `i`: applied to
    /// `f` with the mounting's covariance at the speed there.
    pub fn apply_fix(&self, i: usize, f: &mut Filter, mounting: Mounting) {
        self.data
            .apply_fix(&self.samples[i].avp, f, mounting, self.lane_width_at(i));
    }

    /// The bound right after a fix, and the reach, of each site
    /// (`mountings[j]` at `sites[j]`), in parallel.
    pub fn reaches(
        &self,
        sites: &[Site],
        mountings: &[Mounting],
        requirement_m: f64,
    ) -> Vec<(f64, f64)> {
        self.reaches_with_progress(sites, mountings, requirement_m, None)
    }

    /// [`Budget::reaches`], calling `progress(done, total)` after each site
    /// (from worker threads).
    pub fn reaches_with_progress(
        &self,
        sites: &[Site],
        mountings: &[Mounting],
        requirement_m: f64,
        progress: Option<&(dyn Fn(usize, usize) + Sync)>,
    ) -> Vec<(f64, f64)> {
        let done = std::sync::atomic::AtomicUsize::new(0);
        let total = sites.len();
        let tick = || {
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(n, total);
            }
        };
        sites
            .par_iter()
            .zip(mountings.par_iter())
            .map(|(s, &m)| {
                tick();
                self.reach_of(s, m, requirement_m)
            })
            .collect()
    }

    /// The bound right after a fix of `mounting` at `site`, and the reach.
    pub(super) fn reach_of(
        &self,
        site: &Site,
        mounting: Mounting,
        requirement_m: f64,
    ) -> (f64, f64) {
        let mut f = site.filter.clone();
        self.apply_fix(site.sample, &mut f, mounting);
        let b0 = self.bound(&f.position_cov_enu());
        if b0 > requirement_m {
            return (b0, site.distance_m);
        }
        (b0, self.reach_from(site.sample, &mut f, requirement_m))
    }

    /// The largest bound from sample `from` on, starting with filter `f`
    /// there and applying `fixes` (sample index, mounting; increasing; those
    /// at or before `from` are applied first); stops early once it exceeds
    /// `stop_above_m`.
    pub fn worst_bound_from(
        &self,
        from: usize,
        mut f: Filter,
        fixes: &[(usize, Mounting)],
        stop_above_m: f64,
    ) -> f64 {
        let mut k = 0;
        let mut worst = self.bound(&f.position_cov_enu());
        while k < fixes.len() && fixes[k].0 <= from {
            self.apply_fix(from, &mut f, fixes[k].1);
            k += 1;
        }
        self.run(from, &mut f, |i, f| {
            worst = worst.max(self.bound(&f.position_cov_enu()));
            while k < fixes.len() && fixes[k].0 <= i {
                self.apply_fix(i, f, fixes[k].1);
                k += 1;
            }
            worst <= stop_above_m
        });
        worst
    }

    /// [`Budget::worst_bound_from`] with `reference`'s fixes from index
    /// `offset` on (stopping early once the bound exceeds `stop_above_m`,
    /// except after the last fix, where the largest bound to the end is
    /// found without stepping most of it: `Budget::max_to_end`),
    /// also stopped as soon as the rest of the route provably cannot raise
    /// the result above `max(worst so far, settle_at_m)`, by comparison
    /// with `reference`, the all-read filter of the same fix list. Returns
    /// the worst bound when it exceeds `settle_at_m` (exactly as
    /// [`Budget::worst_bound_from`] would, up to the early stop above
    /// `stop_above_m`), and some value `≤ settle_at_m` otherwise.
    ///
    /// Why the stop is exact: on perfect data the covariance follows a
    /// Riccati map that is the same for both filters after a fix they both
    /// read (same truth, same measurement rows), and a Riccati map `M` is
    /// monotone (`P ≤ U ⇒ M(P) ≤ M(U)`) and sub-homogeneous
    /// (`M(αU) ≤ α M(U)` for `α ≥ 1`: `Φ αU Φᵀ + Q ≤ α(Φ U Φᵀ + Q)`, and
    /// `((αU)⁻¹ + HᵀR⁻¹H)⁻¹ ≤ α (U⁻¹ + HᵀR⁻¹H)⁻¹`). So after a fix where
    /// `P ≤ αU` (`α` the largest generalized eigenvalue of `P` and the
    /// reference's `U`, at least 1), every later covariance is at most `α`
    /// times the reference's, and every later bound at most `√α` times the
    /// reference's largest bound from there on (the bound scales with the
    /// square root of the covariance and grows with it in the PSD order).
    /// A relative margin of 1e-9 covers round-off.
    pub fn worst_bound_settled(
        &self,
        from: usize,
        mut f: Filter,
        reference: &AllRead,
        offset: usize,
        stop_above_m: f64,
        settle_at_m: f64,
    ) -> f64 {
        let fixes = &reference.fixes[offset.min(reference.fixes.len())..];
        let mut k = 0;
        let worst = self.bound(&f.position_cov_enu());
        while k < fixes.len() && fixes[k].0 <= from {
            self.apply_fix(from, &mut f, fixes[k].1);
            k += 1;
        }
        let settled = |k: usize, f: &Filter, worst: f64| {
            let j = offset + k - 1;
            let rest = reference.after_max[j];
            let alpha =
                crate::nav::riccati::generalized_lambda_max(f.covariance(), &reference.after[j])
                    .max(1.0);
            (alpha * (1.0 + 1e-9)).sqrt() * rest <= worst.max(settle_at_m)
        };
        if k > 0 && settled(k, &f, worst) {
            return worst;
        }
        // Stretches without a fix whose bound cannot exceed the worst so
        // far change nothing here: carried by the stretch maps.
        // Below `settle_at_m` nothing matters: the level the maps carry the
        // run under is the worst so far or that, whichever is larger. After
        // the last fix, the rest is the largest bound to the end
        // (`Budget::max_to_end`).
        let at: Vec<usize> = fixes[k..].iter().map(|x| x.0).collect();
        let level = std::cell::Cell::new(worst.max(settle_at_m));
        let mut tail = (k == fixes.len()).then_some(from);
        if tail.is_none() {
            self.run_carrying(from, &mut f, &at, &level, |i, f| {
                let worst = level.get().max(self.bound(&f.position_cov_enu()));
                level.set(worst);
                let mut fixed = false;
                while k < fixes.len() && fixes[k].0 <= i {
                    self.apply_fix(i, f, fixes[k].1);
                    k += 1;
                    fixed = true;
                }
                if fixed && settled(k, f, worst) {
                    return false;
                }
                if fixed && k == fixes.len() && worst <= stop_above_m {
                    tail = Some(i);
                    return false;
                }
                worst <= stop_above_m
            });
        }
        match tail {
            Some(i) => self.max_to_end(i, &mut f, level.get()),
            None => level.get(),
        }
    }

    /// The bound profile with fixes at the given sites (sample index,
    /// mounting; increasing), all read: the predicted error with a plan.
    pub fn with_fixes(&self, fixes: &[(usize, Mounting)], every_m: f64) -> Vec<BudgetPoint> {
        self.with_fixes_and_snapshots(fixes, every_m, &[]).0
    }

    /// [`Budget::with_fixes`] and, in the same pass, filter snapshots at
    /// distances `sites_m` (increasing; a snapshot at a fix's sample is
    /// taken before the fix, as in [`Budget::snapshots`]).
    pub fn with_fixes_and_snapshots(
        &self,
        fixes: &[(usize, Mounting)],
        every_m: f64,
        sites_m: &[f64],
    ) -> (Vec<BudgetPoint>, Vec<Site>) {
        let a = self.all_read(fixes, every_m, sites_m);
        (a.profile, a.sites)
    }

    /// The all-read pass of `fixes` (sample index, mounting; increasing):
    /// [`Budget::with_fixes_and_snapshots`]'s profile and snapshots and,
    /// for [`Budget::worst_bound_settled`], the covariance right after
    /// each fix's sample and the largest bound at any later sample.
    pub fn all_read(&self, fixes: &[(usize, Mounting)], every_m: f64, sites_m: &[f64]) -> AllRead {
        self.all_read_gridded(fixes, every_m, sites_m, every_m)
    }

    /// [`Budget::all_read`], also giving [`AllRead::grid_max`] on a
    /// profile grid of `grid_m` (the profile [`Budget::all_read`] with
    /// `every_m = grid_m` would give): one pass for both.
    pub fn all_read_gridded(
        &self,
        fixes: &[(usize, Mounting)],
        every_m: f64,
        sites_m: &[f64],
        grid_m: f64,
    ) -> AllRead {
        let mut out = AllRead {
            fixes: fixes.to_vec(),
            profile: vec![],
            sites: Vec::with_capacity(sites_m.len()),
            after: Vec::with_capacity(fixes.len()),
            after_max: vec![0.0; fixes.len()],
            grid_m,
            grid_max: 0.0,
        };
        let mut next_grid = grid_m;
        let Some(mut f) = self.initial_filter() else {
            return out;
        };
        let mut next_site = 0;
        let mut next_prof = every_m;
        // Before the first fix the filter is the tag-free one: its samples
        // up to an odometer epoch before the fix are the tag-free pass's.
        let prefix = fixes.first().and_then(|x| {
            self.tag_free_record()?
                .prefix(&self.samples, x.0, every_m, sites_m, grid_m)
        });
        let start = match prefix {
            Some(pre) => {
                let s = &self.samples;
                out.profile = (pre.profile.iter())
                    .map(|&(i, b)| BudgetPoint {
                        t_s: s[i].avp.t,
                        distance_m: s[i].avp.distance_m,
                        bound95_m: b,
                    })
                    .collect();
                out.grid_max = pre.grid_max;
                (next_prof, next_grid) = (pre.next_prof, pre.next_grid);
                f = pre.filter;
                pre.epoch
            }
            None => {
                take_sites(
                    &mut out.sites,
                    &mut next_site,
                    sites_m,
                    0.0,
                    (0, self.samples[0].avp.distance_m),
                    &f,
                );
                out.profile.push(BudgetPoint {
                    t_s: self.samples[0].avp.t,
                    distance_m: self.samples[0].avp.distance_m,
                    bound95_m: self.bound(&f.position_cov_enu()),
                });
                out.grid_max = out.profile[0].bound95_m;
                0
            }
        };
        // Largest bound over the samples after the j-th fix's sample up to
        // the next fix's, then turned into suffix maxima.
        let mut seg_max = vec![0.0f64; fixes.len()];
        let mut k = 0;
        let apply = |i: usize, f: &mut Filter, after: &mut Vec<_>, k: &mut usize| {
            let start = *k;
            while *k < fixes.len() && fixes[*k].0 <= i {
                self.apply_fix(i, f, fixes[*k].1);
                *k += 1;
            }
            for _ in start..*k {
                after.push(*f.covariance());
            }
        };
        while k < fixes.len() && fixes[k].0 == start {
            apply(start, &mut f, &mut out.after, &mut k);
        }
        self.run(start, &mut f, |i, f| {
            let a = &self.samples[i].avp;
            let b = self.bound(&f.position_cov_enu());
            if k > 0 {
                seg_max[k - 1] = seg_max[k - 1].max(b);
            }
            let at_fix = k < fixes.len() && fixes[k].0 == i;
            let at_end = i + 1 == self.samples.len();
            if a.distance_m >= next_grid || at_fix || at_end {
                out.grid_max = out.grid_max.max(b);
                if a.distance_m >= next_grid {
                    next_grid += grid_m;
                }
            }
            if a.distance_m >= next_prof || at_fix || at_end {
                // Recorded before a fix at this sample: the peak just before it.
                out.profile.push(BudgetPoint {
                    t_s: a.t,
                    distance_m: a.distance_m,
                    bound95_m: b,
                });
                if a.distance_m >= next_prof {
                    next_prof += every_m;
                }
            }
            take_sites(
                &mut out.sites,
                &mut next_site,
                sites_m,
                a.distance_m,
                (i, a.distance_m),
                f,
            );
            apply(i, f, &mut out.after, &mut k);
            true
        });
        let mut m = 0.0f64;
        for j in (0..fixes.len()).rev() {
            m = m.max(seg_max[j]);
            out.after_max[j] = m;
        }
        out
    }
}

/// The all-read pass of a fix list ([`Budget::all_read`]).
#[derive(Debug, Clone)]
pub struct AllRead {
    /// The fixes (sample index, mounting).
    pub fixes: Vec<(usize, Mounting)>,
    /// The bound profile (every `every_m`, before each fix, at the end).
    pub profile: Vec<BudgetPoint>,
    /// The snapshots at the distances asked for.
    pub sites: Vec<Site>,
    /// The covariance just after each fix's sample (all its fixes applied).
    pub after: Vec<crate::nav::ekf::Mat>,
    /// The largest bound at any sample after each fix's sample (m).
    pub after_max: Vec<f64>,
    /// The grid (m) of [`AllRead::grid_max`].
    pub grid_m: f64,
    /// The largest bound of the profile on the grid asked for
    /// ([`Budget::all_read_gridded`]; else of [`AllRead::profile`]).
    pub grid_max: f64,
}

/// Snapshots `f` as a [`Site`] at `(sample, distance_m)` for every site
/// distance in `sites_m` (from `*next`) at or before `reached_m`.
fn take_sites(
    sites: &mut Vec<Site>,
    next: &mut usize,
    sites_m: &[f64],
    reached_m: f64,
    (sample, distance_m): (usize, f64),
    f: &Filter,
) {
    while *next < sites_m.len() && sites_m[*next] <= reached_m {
        let mut filter = f.clone();
        // Not the tag-free pass's stretch map under construction.
        filter.take_element();
        sites.push(Site {
            sample,
            distance_m,
            filter,
        });
        *next += 1;
    }
}
