//! Forward placement on one route with the navigation filter's exact state:
//! walk the route, and after each tag put the next one at the furthest
//! candidate site up to which the predicted 95 % bound holds — not from a
//! reach computed once per site, but from the filters the plan itself
//! produces, so the velocity, attitude and sensor calibration the earlier
//! fixes bought are counted.
//!
//! Missed reads: with `k` tolerated, the filters tracked between tags are
//! - `A`: every tag so far read;
//! - `W(c)`, `c = 1..=k`: the last `c` tags missed (a window of misses that
//!   is still open), every earlier tag read;
//! - `P(c, j)`: a window of `c` misses closed `j` reads ago
//!   (`j = 1..=settle`), after which the filter is taken to have settled
//!   back to `A` and is dropped.
//!
//! The next tag must come before any tracked filter's bound leaves the
//! requirement. Dropping `P(c, settle)` is an approximation, so every plan
//! this module returns is re-checked by the caller with the covariance
//! analysis for each window of `k` consecutive missed tags
//! ([`super::robust`]); a plan that fails is not used.
//!
//! Installed tags (`existing`) are passed whenever the route reaches them:
//! when one lies before the furthest admissible site, it is the next tag.
//!
//! Furthest-first is optimal when a later fix never leaves the filter worse
//! off at any later point than an earlier one would; the covariance of a
//! Kalman filter is monotone in the information it has had (Riccati
//! monotonicity, exact here because every filter runs on the same perfect
//! data), which makes that hold in the cases tested, not in general. The
//! caller therefore also brackets the count with a lower bound from the most
//! optimistic reaches and reports whether the plan meets it.

use super::budget::Budget;
use super::placement::Placement;
use crate::nav::Filter;
use crate::sim::tags::Mounting;

/// A candidate site for the forward walk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardSite {
    /// Truth sample index of the site.
    pub sample: usize,
    /// Route distance (m).
    pub distance_m: f64,
    /// The mounting a tag there would have.
    pub mounting: Mounting,
    /// Already installed (always passed, costs nothing).
    pub existing: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    All,
    Open(usize),
    Closed(usize, usize),
}

/// Places tags by walking forward with the exact filters (see the module
/// docs); `sites` in increasing sample order. `settle` is the number of
/// reads after a window of misses during which its filter is still tracked.
pub fn forward_greedy(
    budget: &Budget<'_>,
    sites: &[ForwardSite],
    k: usize,
    requirement_m: f64,
    min_spacing_m: f64,
    settle: usize,
) -> Placement {
    let Some(f0) = budget.initial_filter() else {
        return Placement::Feasible(vec![]);
    };
    let samples = budget.samples();
    let mut states: Vec<(Kind, Filter)> = vec![(Kind::All, f0)];
    let mut cur = 0usize;
    let mut next_site = 0usize;
    let mut last_d = f64::NEG_INFINITY;
    let mut chosen = Vec::new();
    loop {
        // Sites at or before the current tag's sample are behind us.
        while next_site < sites.len() && sites[next_site].sample <= cur {
            next_site += 1;
        }
        // Sample index of the first violation by any tracked filter, each
        // run carried by the stretch maps where its bound provably stays
        // within the requirement (`Budget::first_above`: the same sample
        // as stepping).
        let mut limit = usize::MAX;
        for (_, f0) in &states {
            if budget.bound(&f0.position_cov_enu()) > requirement_m {
                limit = limit.min(cur);
                break;
            }
            // Stopped at the earliest violation found so far (a fix sample
            // for the maps: the stretch holding it is stepped).
            let cap = [limit];
            let stop: &[usize] = if limit == usize::MAX { &[] } else { &cap };
            let level = std::cell::Cell::new(requirement_m);
            budget.run_carrying(cur, &mut f0.clone(), stop, &level, |i, f| {
                if i >= limit {
                    return false;
                }
                if budget.bound(&f.position_cov_enu()) > requirement_m {
                    limit = i;
                    return false;
                }
                true
            });
        }
        if limit == usize::MAX {
            return Placement::Feasible(chosen);
        }
        // Sites before the violation (every filter holds the bound there).
        let in_window: Vec<usize> = (next_site..sites.len())
            .take_while(|&j| sites[j].sample < limit)
            .collect();
        // Each tracked filter just before a site, on first demand (the
        // furthest admissible pick is usually kept): carried by the maps
        // to the site's stretch and stepped to it (`Budget::filter_at`).
        let snaps = Snapshots {
            budget,
            from: cur,
            states: &states,
            cache: std::cell::RefCell::new(std::collections::HashMap::new()),
        };
        // Admissible picks, furthest first; the first installed tag in the
        // window is the next tag whatever else is admissible.
        let order: Vec<usize> = match in_window.iter().find(|&&j| sites[j].existing) {
            Some(&e) => vec![e],
            None => in_window
                .iter()
                .rev()
                .copied()
                .filter(|&j| sites[j].distance_m >= last_d + min_spacing_m)
                .collect(),
        };
        let mut picked = None;
        for (n, &c) in order.iter().enumerate() {
            let next = transition(budget, &states, &snaps, sites[c], k, settle);
            if n + 1 == order.len() || viable(budget, &next, sites, c, requirement_m, min_spacing_m)
            {
                picked = Some((c, next));
                break;
            }
        }
        let Some((c, next)) = picked else {
            return Placement::Infeasible {
                covered_to_m: samples[limit.min(samples.len() - 1)].avp.distance_m,
            };
        };
        let site = sites[c];
        states = next;
        chosen.push(c);
        cur = site.sample;
        last_d = site.distance_m;
        next_site = c + 1;
    }
}

/// The tracked filters just before sites, computed on demand and kept.
struct Snapshots<'s, 'b> {
    budget: &'s Budget<'b>,
    from: usize,
    states: &'s [(Kind, Filter)],
    cache: std::cell::RefCell<std::collections::HashMap<(usize, usize), Filter>>,
}

impl Snapshots<'_, '_> {
    /// Tracked filter `s` (at sample `from`) just before sample `to`.
    fn get(&self, s: usize, to: usize) -> Filter {
        self.cache
            .borrow_mut()
            .entry((s, to))
            .or_insert_with(|| {
                self.budget
                    .filter_at(self.from, self.states[s].1.clone(), to)
            })
            .clone()
    }
}

/// The tracked filters after a tag at `site`: read or missed, per the
/// module docs.
fn transition(
    budget: &Budget<'_>,
    states: &[(Kind, Filter)],
    snaps: &Snapshots<'_, '_>,
    site: ForwardSite,
    k: usize,
    settle: usize,
) -> Vec<(Kind, Filter)> {
    let fix = |mut f: Filter| {
        budget.apply_fix(site.sample, &mut f, site.mounting);
        f
    };
    let mut next = Vec::with_capacity(states.len() + 1);
    for (n, (kind, _)) in states.iter().enumerate() {
        let f = snaps.get(n, site.sample);
        match *kind {
            Kind::All => {
                if k >= 1 {
                    next.push((Kind::Open(1), f.clone()));
                }
                next.push((Kind::All, fix(f)));
            }
            Kind::Open(n) => {
                if n < k {
                    next.push((Kind::Open(n + 1), f.clone()));
                }
                next.push((Kind::Closed(n, 1), fix(f)));
            }
            Kind::Closed(n, j) => {
                if j < settle {
                    next.push((Kind::Closed(n, j + 1), fix(f)));
                }
            }
        }
    }
    next
}

/// Whether, after a tag at site `c`, every tracked filter holds the bound
/// up to the nearest site a next tag may take (or to the route's end): a
/// pick that leaves no room for the next tag is a dead end when a read is
/// missed.
fn viable(
    budget: &Budget<'_>,
    states: &[(Kind, Filter)],
    sites: &[ForwardSite],
    c: usize,
    requirement_m: f64,
    min_spacing_m: f64,
) -> bool {
    let from = sites[c].sample;
    let target = sites[c + 1..]
        .iter()
        .find(|s| s.existing || s.distance_m >= sites[c].distance_m + min_spacing_m)
        .map(|s| s.sample);
    states.iter().all(|(_, f0)| {
        let mut f = f0.clone();
        if budget.bound(&f.position_cov_enu()) > requirement_m {
            return false;
        }
        let mut ok = true;
        budget.run(from, &mut f, |i, f| {
            if budget.bound(&f.position_cov_enu()) > requirement_m {
                ok = false;
                return false;
            }
            target.is_none_or(|t| i < t)
        });
        ok
    })
}
