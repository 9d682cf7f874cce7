//! Site reaches computed on first demand for the placement's search
//! ([`Budget::lazy_reaches`]), and sites shown to fall short of the route's
//! end by runs shared by several of them (module `carry`).

use super::budget::{Budget, Site};
use crate::sim::tags::Mounting;
use rayon::prelude::*;

impl<'a> Budget<'a> {
    /// [`Budget::reaches_with_progress`] computed on demand
    /// ([`LazyReaches::get`]): each site's reach is a filter run, and the
    /// placement's search needs only the reaches of the sites it gets to.
    pub fn lazy_reaches<'s>(
        &'s self,
        sites: &'s [Site],
        mountings: &'s [Mounting],
        requirement_m: f64,
        progress: Option<&'s (dyn Fn(usize, usize) + Sync)>,
    ) -> LazyReaches<'s, 'a> {
        LazyReaches {
            budget: self,
            sites,
            mountings,
            requirement_m,
            progress,
            done: std::cell::Cell::new(0),
            cells: (0..sites.len())
                .map(|_| std::cell::OnceCell::new())
                .collect(),
            short: (0..sites.len())
                .map(|_| std::cell::Cell::new(false))
                .collect(),
            certify: false,
            width: std::cell::Cell::new(CERTIFY_FIRST_WIDTH),
            certified: std::cell::Cell::new(0),
        }
    }
}

/// The number of sites [`LazyReaches::reaches_end`] first tries to show
/// short of the end with one run, halved after each failure (no more tries
/// below 2). A cost setting only, the answers are the same: a run costs
/// about as much whether it succeeds (its bound crosses the requirement
/// not long before the end, as the sites' own do) or fails (it runs to the
/// end): on the demo and the Helsinki and Monaco 20 m routes a fixed
/// width of 8 took 1–5 % fewer filter steps for the tag-free reaches than
/// 4 or 16, and doubling the width after each success 34–60 % more (each
/// widening ends in a failure).
const CERTIFY_FIRST_WIDTH: usize = 8;
/// Relative margin of the level the shared run must exceed over the
/// requirement: the comparison of two filters' bounds computed in floating
/// point along different update sequences (round-off ≈ 1e-13 relative).
const CERTIFY_MARGIN: f64 = 1e-6;

/// Site reaches computed on first demand ([`Budget::lazy_reaches`]).
pub struct LazyReaches<'s, 'a> {
    budget: &'s Budget<'a>,
    sites: &'s [Site],
    mountings: &'s [Mounting],
    requirement_m: f64,
    progress: Option<&'s (dyn Fn(usize, usize) + Sync)>,
    done: std::cell::Cell<usize>,
    cells: Vec<std::cell::OnceCell<(f64, f64)>>,
    /// Sites shown to fall short of the route's end without their reach.
    short: Vec<std::cell::Cell<bool>>,
    /// Whether [`LazyReaches::reaches_end`] may show that by shared runs.
    certify: bool,
    /// Sites the next shared run tries to cover (below 2: no more tries).
    width: std::cell::Cell<usize>,
    /// Sites shown short by shared runs.
    certified: std::cell::Cell<usize>,
}

impl std::fmt::Debug for LazyReaches<'_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LazyReaches")
            .field("sites", &self.sites.len())
            .field("computed", &self.done.get())
            .finish()
    }
}

impl LazyReaches<'_, '_> {
    /// Lets [`LazyReaches::reaches_end`] show several sites short of the
    /// end by one filter run (`Budget::falls_short`). Only for snapshots
    /// where a later site's holds no information an earlier one's, carried
    /// on with the fixes at the sites between, lacks: the tag-free pass's
    /// ([`Budget::tag_free`]) or those of a pass reading a tag at every
    /// site ([`Budget::snapshots`] with a fix at every site). Ignored when
    /// the propagations do not restart exactly (map matching:
    /// `PerfectData::restart_invariant`).
    pub fn certifying(mut self) -> Self {
        self.certify = self.budget.restart_invariant();
        self
    }

    /// Whether site `i`'s reach is the route's end (`reach ≥ length`),
    /// exactly as [`LazyReaches::get`] would say; when certifying, a site
    /// not yet computed is first tried with the next few in one run that
    /// reads all their tags (`Budget::falls_short`): when that run's
    /// bound exceeds the requirement before the end, none of them reaches
    /// the end, and none of their reaches is computed.
    pub fn reaches_end(&self, i: usize) -> bool {
        let length = self.budget.length_m();
        if let Some(&(_, r)) = self.cells[i].get() {
            return r >= length;
        }
        if self.short[i].get() {
            return false;
        }
        if self.certify && self.certify_from(i) {
            return false;
        }
        self.get(i).1 >= length
    }

    /// Tries to show sites `i..` short of the end with shared runs, from
    /// the current width down to 2 sites; true when `i` was. The width is
    /// kept after a success and halved after a failure: reaches grow along
    /// the route, so once a narrower run is needed it stays needed.
    fn certify_from(&self, i: usize) -> bool {
        let n = self.sites.len();
        let level = self.requirement_m * (1.0 + CERTIFY_MARGIN);
        loop {
            let w = self.width.get();
            if w < 2 {
                return false;
            }
            let b = (i + w - 1).min(n - 1);
            if b == i {
                return false;
            }
            let s0 = self.budget.steps();
            let ok = self
                .budget
                .falls_short(self.sites, self.mountings, (i, b), level);
            tracing::trace!(
                i,
                b,
                ok,
                steps = self.budget.steps() - s0,
                "shared reach run"
            );
            if ok {
                for c in &self.short[i..=b] {
                    c.set(true);
                }
                self.certified.set(self.certified.get() + b + 1 - i);
                return true;
            }
            self.width.set(w / 2);
        }
    }

    /// Sites shown short of the end by shared runs, without their reach.
    pub fn certified(&self) -> usize {
        self.certified.get()
    }

    /// The bound right after a fix at site `i` and its reach (as
    /// [`Budget::reaches`]). A site not yet computed is computed with the
    /// next few not yet computed after it, one per worker thread, in
    /// parallel (the search asks for sites mostly in route order).
    pub fn get(&self, i: usize) -> (f64, f64) {
        if let Some(&r) = self.cells[i].get() {
            return r;
        }
        let batch: Vec<usize> = (i..self.sites.len())
            .filter(|&j| j == i || (self.cells[j].get().is_none() && !self.short[j].get()))
            .take(rayon::current_num_threads().max(1))
            .collect();
        let (b, sites, mountings, req) =
            (self.budget, self.sites, self.mountings, self.requirement_m);
        let out: Vec<(f64, f64)> = batch
            .par_iter()
            .map(|&j| b.reach_of(&sites[j], mountings[j], req))
            .collect();
        for (&j, r) in batch.iter().zip(out) {
            let _ = self.cells[j].set(r);
            self.done.set(self.done.get() + 1);
            if let Some(p) = self.progress {
                p(self.done.get(), self.sites.len());
            }
        }
        self.cells[i].get().copied().unwrap_or((f64::NAN, f64::NAN))
    }

    /// Sites whose reach was computed.
    pub fn computed(&self) -> usize {
        self.done.get()
    }
}
