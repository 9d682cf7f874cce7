//! `plan --baseline`: the stretches where the planner's budget without
//! tags passes 1, driven on their own with the plan's tags and without
//! the new ones ([`validate_stretches`]), and the drive both stretch tests
//! share ([`drive_stretches`], which `super::calibrated_stretches` uses
//! too).

use super::settings::map_route;
use super::trips::sample_chains;
use super::types::{NetworkPlan, StretchFigures, StretchValidation};
use super::validation::{
    drive, open_dem, share_rule, thin_rows, BudgetProfile, MIN_RUNS_PER_WALK, VALIDATION_CHAIN_S,
};
use crate::error::{Error, Result};
use crate::network::Network;
use crate::route::{plan_route_points, route_from_pieces, Route};
use crate::scenario::Scenario;
use crate::sim::{simulate_with, TruthSource};
use crate::trajectory::SpeedProfile;
use std::collections::HashSet;

/// Most over-budget stretches the baseline's stretch test drives.
pub const MAX_STRETCHES: usize = 8;

/// Chains of [`VALIDATION_CHAIN_S`] sampled (not driven) to find the
/// stretches: the validation's own chains meet only a few.
pub const STRETCH_SEARCH_CHAINS: usize = 64;

/// Route driven before a stretch's resetting turn (m): the navigator's
/// start (its initial alignment, the planner's shorter start reach) is
/// kept away from the stretch, and the turns on the way let map matching
/// settle the filter as on a long drive.
pub const STRETCH_LEAD_IN_M: f64 = 5000.0;

/// Most route driven past the point where a stretch's budget passes 1 (m):
/// a long straight (a motorway) is tested on its first kilometres, where
/// the planner already needs a tag.
pub const STRETCH_MAX_OVER_M: f64 = 5000.0;

/// The pieces of `route` between chainages `c0` and `c1` (m), as
/// [`route_from_pieces`] takes them.
pub(super) fn sub_route_pieces(
    route: &crate::route::Route,
    c0: f64,
    c1: f64,
) -> Vec<(crate::network::DirectedSection, f64, f64)> {
    let mut out = Vec::new();
    for sp in &route.spans {
        let (s0, s1) = (sp.start_chainage_m, sp.end_chainage_m);
        if s1 <= c0 || s0 >= c1 {
            continue;
        }
        let (a, b) = (c0.max(s0), c1.min(s1));
        if b - a < 1e-3 {
            continue;
        }
        let off = |x: f64| {
            if s1 > s0 {
                sp.from_offset_m + (x - s0) / (s1 - s0) * (sp.to_offset_m - sp.from_offset_m)
            } else {
                sp.from_offset_m
            }
        };
        out.push((sp.section, off(a), off(b)));
    }
    out
}

/// `plan --baseline`: the stretches where the planner's budget without
/// tags passes 1 on [`STRETCH_SEARCH_CHAINS`] fresh chains of the plan's
/// traffic (their own random stream; the largest budgets first, at most
/// [`MAX_STRETCHES`]), each driven from
/// [`STRETCH_LEAD_IN_M`] before its resetting turn to the next reset,
/// with the plan's tags and without the new ones, the same runs and seeds
/// both ways; past [`STRETCH_MAX_OVER_M`] over budget a drive stops. Plans
/// without map matching's credit have no such stretches (`None`). Samples
/// are taken over budget only (one per
/// [`THINNING_S`](super::validation::THINNING_S) and each run's last row,
/// where the budget peaks). `None` when no chain passes 1.
pub(super) fn validate_stretches(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
) -> Result<Option<StretchValidation>> {
    let Some(cm) = plan.chain_model.as_ref() else {
        return Ok(None);
    };
    // Without map matching's credit the budget resets only where a chain
    // starts: every chain is one stretch, which the validation drives.
    if !plan.map_matching {
        return Ok(None);
    }
    let (found, routes) = search_stretches(scn, net, plan, seed, 0x7374_7265_7463, |route| {
        BudgetProfile::new(&cm.model, route, plan.map_matching).over_budget()
    })?;
    let test = StretchTest {
        stream: 0x7374_7265,
        what: "over-budget stretch",
        lead_in_m: |_: &[Found]| STRETCH_LEAD_IN_M,
        span: |&[reset, over, end]: &[f64; 3]| {
            (
                (reset - STRETCH_LEAD_IN_M).max(0.0),
                end.min(over + STRETCH_MAX_OVER_M),
            )
        },
    };
    test.run(scn, net, plan, found, &routes, runs, seed)
}

/// A stretch found on a searched chain: (peak budget, chain, [reset,
/// over, next reset]), the chainages (m) of its resetting turn, of where
/// its budget passes 1 and of the next reset.
pub(super) type Found = (f64, usize, [f64; 3]);

/// Samples [`STRETCH_SEARCH_CHAINS`] chains of the plan's traffic of at most
/// [`VALIDATION_CHAIN_S`] (random stream `stream`), routes each and keeps
/// the stretches `find` gives on its route, as ([reset, over, next reset],
/// peak budget). Returns them with the routes (indexed by chain).
pub(super) fn search_stretches(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    seed: u64,
    stream: u64,
    mut find: impl FnMut(&Route) -> Vec<([f64; 3], f64)>,
) -> Result<(Vec<Found>, Vec<Route>)> {
    let Some(cm) = plan.chain_model.as_ref() else {
        return Ok((Vec::new(), Vec::new()));
    };
    let shift = scn.planner().shift_s.min(VALIDATION_CHAIN_S);
    let chains = sample_chains(
        net,
        &cm.model,
        &cm.dest,
        shift,
        seed,
        stream,
        STRETCH_SEARCH_CHAINS,
    )?;
    let mut found: Vec<Found> = Vec::new();
    let mut routes = Vec::with_capacity(chains.len());
    for (ci, chain) in chains.iter().enumerate() {
        let route = plan_route_points(net, &chain.points)?;
        found.extend(find(&route).into_iter().map(|(c, u)| (u, ci, c)));
        routes.push(route);
    }
    Ok((found, routes))
}

/// How a stretch test drives the stretches it found: the drive's random
/// stream, the name of a stretch in errors, the `lead_in_m` it reports and
/// each stretch's drive (from, to) in chainage (m) from its [reset, over,
/// next reset].
pub(super) struct StretchTest<L, S> {
    pub stream: u64,
    pub what: &'static str,
    pub lead_in_m: L,
    pub span: S,
}

impl<L: Fn(&[Found]) -> f64, S: Fn(&[f64; 3]) -> (f64, f64)> StretchTest<L, S> {
    /// Picks the stretches ([`pick_stretches`]), drives each
    /// `runs / stretches` times (at least [`MIN_RUNS_PER_WALK`]) with
    /// [`drive_stretches`] and reports them; `None` when none was found.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run(
        &self,
        scn: &Scenario,
        net: &std::sync::Arc<Network>,
        plan: &NetworkPlan,
        mut found: Vec<Found>,
        routes: &[Route],
        runs: u64,
        seed: u64,
    ) -> Result<Option<StretchValidation>> {
        if found.is_empty() {
            return Ok(None);
        }
        pick_stretches(&mut found, routes);
        let n = found.len();
        let per = runs.div_ceil(n as u64).max(MIN_RUNS_PER_WALK);
        let peaks = found
            .iter()
            .fold((f64::INFINITY, 0.0f64), |p, s| (p.0.min(s.0), p.1.max(s.0)));
        let drives: Vec<_> = found
            .iter()
            .map(|(_, ci, c)| {
                let (from, to) = (self.span)(c);
                StretchDrive {
                    route: &routes[*ci],
                    from,
                    to,
                    over: c[1],
                }
            })
            .collect();
        let [with_tags, without_new_tags] =
            drive_stretches(scn, net, plan, &drives, per, seed, self.stream, self.what)?;
        Ok(Some(StretchValidation {
            searched_chains: routes.len(),
            stretches: n,
            runs_per_stretch: per,
            lead_in_m: (self.lead_in_m)(&found),
            peak_budget_min: peaks.0,
            peak_budget_max: peaks.1,
            with_tags,
            without_new_tags,
        }))
    }
}

/// Orders stretches found as (peak budget, chain, [reset, over, next
/// reset]) by their peak, the largest first, keeps one per directed
/// section where the budget passes 1 (chains that drove the same straight
/// give the same test) and at most [`MAX_STRETCHES`].
pub(super) fn pick_stretches(found: &mut Vec<Found>, routes: &[Route]) {
    found.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut seen = HashSet::new();
    found.retain(|&(_, ci, [_, over, _])| {
        let d = routes[ci].span_at(over).section;
        seen.insert((d.section, d.forward))
    });
    found.truncate(MAX_STRETCHES);
}

/// A stretch's drive: its chain's route from chainage `from` to `to` (m),
/// error samples taken from chainage `over` on.
pub(super) struct StretchDrive<'a> {
    pub route: &'a Route,
    pub from: f64,
    pub to: f64,
    pub over: f64,
}

/// Drives each stretch `per` times with the plan's tags on the directions
/// it drives and again with only the installed ones, the same seeds both
/// ways (stretch `si` seeded `seed + stream + 1000 si`); samples each run
/// past `over` (one per [`THINNING_S`](super::validation::THINNING_S) and
/// its last row) and judges them by [`share_rule`]. Returns the figures
/// with the tags and without the new ones; `what` names a stretch in
/// errors.
#[allow(clippy::too_many_arguments)]
pub(super) fn drive_stretches(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    stretches: &[StretchDrive],
    per: u64,
    seed: u64,
    stream: u64,
    what: &str,
) -> Result<[StretchFigures; 2]> {
    let (_, _, height_m) = map_route(scn)?;
    let dem = open_dem(scn)?;
    let profile = SpeedProfile {
        speed_mps: scn.planner().vehicle_speed_mps,
        ..Default::default()
    };
    let req = plan.requirement_m;
    let conf = scn.planner().requirement_confidence;
    let existing: HashSet<&str> = plan
        .tags
        .iter()
        .filter(|t| t.existing)
        .map(|t| t.tag_id.as_str())
        .collect();
    let mut figures = [StretchFigures::default(), StretchFigures::default()];
    let mut counts = [(0usize, 0usize); 2];
    for (si, s) in stretches.iter().enumerate() {
        let pieces = sub_route_pieces(s.route, s.from, s.to);
        let route = route_from_pieces(net, &pieces)?;
        let start = route.vertices.first().map_or([0.0, 0.0], |v| v.lat_lon);
        let located = scn.located_at(start);
        let (rp, dirs) = drive(net, &route, &profile, height_m, scn.dt, dem.as_ref())?;
        let all = plan.sim_tags(Some(&dirs));
        let truth = TruthSource::from_route(std::sync::Arc::clone(net), route, rp);
        let to_chainage = truth.route().map_or(1.0, |r| r.length_m)
            / truth
                .samples()
                .last()
                .map_or(1.0, |x| x.distance_m.max(1.0));
        for (k, f) in figures.iter_mut().enumerate() {
            let tags: Vec<_> = if k == 0 {
                all.clone()
            } else {
                all.iter()
                    .filter(|t| existing.contains(t.id.as_str()))
                    .cloned()
                    .collect()
            };
            let res = simulate_with(
                &located,
                &truth,
                &tags,
                per,
                seed.wrapping_add(stream + 1000 * si as u64),
                None,
            )?;
            for r in &res.runs {
                let rows: Vec<_> = r
                    .rows
                    .iter()
                    .filter(|row| s.from + row.distance_m * to_chainage >= s.over)
                    .collect();
                let (n_thin, n_within, m) = thin_rows(&rows, req).map_err(|t| {
                    Error::scenario(
                        &scn.path,
                        format!(
                            "{what} {si}, run {}: the navigation error is not finite at \
                             t = {t:.0} s",
                            r.run
                        ),
                    )
                })?;
                counts[k].0 += n_thin;
                counts[k].1 += n_within;
                if m > req {
                    f.runs_exceeding += 1;
                }
                f.max_horizontal_error_m = f.max_horizontal_error_m.max(m);
            }
        }
    }
    for (f, &(n_thin, n_within)) in figures.iter_mut().zip(&counts) {
        let (lower, passed, rule) = share_rule(n_within, n_thin, req, conf);
        f.thinned_samples = n_thin;
        f.thinned_within = n_within;
        f.share_lower_95 = lower;
        f.passed = passed;
        f.rule = rule;
    }
    Ok(figures)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::DirectedSection;
    use crate::route::RouteSpan;

    #[test]
    fn sub_route_pieces_cut_spans_at_chainages_in_both_directions() {
        let span = |section, forward, c0, c1, f, t| RouteSpan {
            start_chainage_m: c0,
            end_chainage_m: c1,
            section: DirectedSection { section, forward },
            road: 0,
            from_offset_m: f,
            to_offset_m: t,
        };
        let route = Route {
            vertices: Vec::new(),
            spans: vec![
                span(1, true, 0.0, 100.0, 10.0, 110.0),
                span(2, false, 100.0, 250.0, 200.0, 50.0),
            ],
            length_m: 250.0,
            waypoints: Vec::new(),
        };
        let p = sub_route_pieces(&route, 50.0, 180.0);
        assert_eq!(p.len(), 2);
        assert_eq!((p[0].0.section, p[0].0.forward), (1, true));
        assert!((p[0].1 - 60.0).abs() < 1e-9 && (p[0].2 - 110.0).abs() < 1e-9);
        assert_eq!((p[1].0.section, p[1].0.forward), (2, false));
        assert!((p[1].1 - 200.0).abs() < 1e-9 && (p[1].2 - 120.0).abs() < 1e-9);
        // A range inside one span, and one touching a span only at its end.
        let q = sub_route_pieces(&route, 120.0, 130.0);
        assert_eq!(q.len(), 1);
        assert!((q[0].1 - 180.0).abs() < 1e-9 && (q[0].2 - 170.0).abs() < 1e-9);
        assert_eq!(sub_route_pieces(&route, 100.0, 100.0).len(), 0);
    }
}
