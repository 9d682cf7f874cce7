//! Tag placement along a scenario's route: candidate sites → the route
//! budget's reaches ([`super::budget`]) → the fewest tags holding the
//! requirement with `k` missed reads tolerated ([`super::placement`], exact
//! on one route; refined and forward variants kept when the covariance
//! analysis confirms them) → the plan, validated on request.

use super::budget::Budget;
use super::forward;
use super::placement::{place_lazy_with_end, place_with, Candidate, Placement};
use super::plan::{Plan, PlannedTag};
use super::settings::{site_speed_mps, Coverage, PlannerSettings};
use super::validation::{robust_all_read, robust_with_progress, validate_plan};
use crate::error::{Error, Result};
use crate::network::{Network, RoadAttributes};
use crate::scenario::{RouteKind, Scenario};
use crate::sim::tags::Mounting;
use crate::sim::TruthSource;

/// Road context along a map route: attributes at a route distance.
struct RoadContext<'a> {
    net: &'a std::sync::Arc<Network>,
    route: &'a crate::route::Route,
    scale: std::cell::Cell<f64>,
    /// The truth (its lane path's distance → route chainage, issue 12).
    truth: &'a TruthSource,
}

impl RoadContext<'_> {
    /// Route chainage at a truth distance.
    fn chainage(&self, distance_m: f64) -> f64 {
        self.truth
            .chainage_at(distance_m)
            .unwrap_or(distance_m * self.scale.get())
    }

    fn at(&self, distance_m: f64) -> &RoadAttributes {
        let span = self.route.span_at(self.chainage(distance_m));
        &self.net.model.roads[span.road as usize].attributes
    }

    /// Chainage along the road (its digitised direction, from its first
    /// section present in the map) at a route distance.
    fn road_chainage_m(&self, distance_m: f64) -> f64 {
        let c = self.chainage(distance_m);
        let span = self.route.span_at(c);
        let road = &self.net.model.roads[span.road as usize];
        let before: f64 = road
            .sections
            .iter()
            .take_while(|&&s| s != span.section.section)
            .map(|&s| self.net.sections[s as usize].length_m)
            .sum();
        let sign = if span.to_offset_m >= span.from_offset_m {
            1.0
        } else {
            -1.0
        };
        let off = span.from_offset_m + sign * (c - span.start_chainage_m).max(0.0);
        before
            + off.clamp(
                span.from_offset_m.min(span.to_offset_m),
                span.from_offset_m.max(span.to_offset_m),
            )
    }
}

/// Plans tags for a scenario's route (validated by `validation_runs` Monte
/// Carlo runs when `validate`).
pub fn plan(scn: &Scenario, seed: u64, validate: bool) -> Result<Plan> {
    let settings = PlannerSettings::from_scenario(scn)?;
    let truth = TruthSource::new(scn)?;
    plan_with(scn, &truth, &settings, seed, validate)
}

/// [`plan`] with a truth and settings given.
pub fn plan_with(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
    seed: u64,
    validate: bool,
) -> Result<Plan> {
    plan_with_progress(scn, truth, settings, seed, validate, None)
}

/// [`plan_with`], calling `progress(done, total)` as the candidate sites'
/// reaches are computed (from worker threads; once per refinement pass too).
pub fn plan_with_progress(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
    seed: u64,
    validate: bool,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<Plan> {
    let staged = progress.map(|p| move |_: PlanStage, done: usize, total: usize| p(done, total));
    plan_with_stages(
        scn,
        truth,
        settings,
        seed,
        validate,
        staged
            .as_ref()
            .map(|p| p as &(dyn Fn(PlanStage, usize, usize) + Sync)),
    )
}

/// The long steps of a route plan, for progress reports: each is a loop
/// over the candidate sites, computing their reaches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanStage {
    /// Reaches from the tag-free filter (the first placement).
    TagFreeReaches,
    /// Reaches recomputed from a plan's own filter (refinement passes).
    RefinedReaches,
    /// The most optimistic reaches (the lower bound).
    OptimisticReaches,
    /// The covariance check of a candidate plan with any `k` consecutive
    /// tags missed (one unit per window).
    MissedTagCheck,
}

impl PlanStage {
    /// A short label for a progress bar.
    pub fn label(self) -> &'static str {
        match self {
            Self::TagFreeReaches => "reaches (tag-free)",
            Self::RefinedReaches => "reaches (refined)",
            Self::OptimisticReaches => "reaches (lower bound)",
            Self::MissedTagCheck => "missed-tag check",
        }
    }
}

/// [`plan_with`], calling `progress(stage, done, total)` as each stage's
/// candidate sites are done (from worker threads; `done` restarts at 1 for
/// each stage, and a stage may come more than once), so that a caller can
/// draw one bar per stage with an ETA.
pub fn plan_with_stages(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
    seed: u64,
    validate: bool,
    progress: Option<&(dyn Fn(PlanStage, usize, usize) + Sync)>,
) -> Result<Plan> {
    let stage = |st: PlanStage| {
        move |done: usize, total: usize| {
            if let Some(p) = progress {
                p(st, done, total);
            }
        }
    };
    let (tag_free_tick, refined_tick, optimistic_tick, check_tick) = (
        stage(PlanStage::TagFreeReaches),
        stage(PlanStage::RefinedReaches),
        stage(PlanStage::OptimisticReaches),
        stage(PlanStage::MissedTagCheck),
    );
    tracing::info!(scenario = %scn.name(), requirement_m = settings.requirement_m, "planning tags");
    if settings.coverage == Coverage::Network {
        return Err(Error::InvalidParameter(
            "planner.coverage = \"network\" plans with planner::network::plan_network".into(),
        ));
    }
    let req = settings.requirement_m;
    // Road context (tunnels, road ids) and the network for map matching:
    // the truth's own map and route, loaded and planned once.
    let ctx = match (&scn.route, truth.network(), truth.route()) {
        (RouteKind::Map { .. }, Some(net), Some(route)) => Some(RoadContext {
            net,
            route,
            scale: std::cell::Cell::new(1.0),
            truth,
        }),
        _ => None,
    };
    let budget = Budget::new(scn, truth, ctx.as_ref().map(|c| &**c.net));
    let length = budget.length_m();
    if length <= 0.0 {
        return Err(Error::scenario(
            &scn.path,
            "the route has no length to plan",
        ));
    }
    if let Some(c) = ctx.as_ref() {
        c.scale.set(c.route.length_m / length);
    }
    // Best possible fix against the requirement.
    settings.check_best_fix(&scn.rfid)?;
    // Candidate sites.
    // Installed tags: on the route where the path passes within 15 m.
    let samples = budget.samples();
    let mut existing_at: Vec<(f64, usize)> = Vec::new();
    let mut existing_off_route = 0usize;
    for (ti, t) in settings.existing_tags.iter().enumerate() {
        let (rm, rn) = crate::geodesy::radii(t.lat);
        let best = samples
            .iter()
            .map(|sm| {
                let a = &sm.avp;
                let de = (a.state.lon - t.lon) * rn * t.lat.cos();
                let dn = (a.state.lat - t.lat) * rm;
                (de.hypot(dn), a.distance_m)
            })
            .fold((f64::INFINITY, 0.0), |b, x| if x.0 < b.0 { x } else { b });
        if best.0 <= 15.0 {
            existing_at.push((best.1, ti));
        } else {
            existing_off_route += 1;
        }
    }
    existing_at.sort_by(|a, b| a.0.total_cmp(&b.0));
    existing_at.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-6);
    let mut site_list: Vec<(f64, Option<usize>)> =
        existing_at.iter().map(|&(d, i)| (d, Some(i))).collect();
    let mut d = settings.candidate_spacing_m;
    while d < length {
        if !settings.forbidden_m.iter().any(|z| d >= z[0] && d <= z[1])
            && !existing_at.iter().any(|e| (e.0 - d).abs() < 1.0)
        {
            site_list.push((d, None));
        }
        d += settings.candidate_spacing_m;
    }
    site_list.sort_by(|a, b| a.0.total_cmp(&b.0));
    let sites_m: Vec<f64> = site_list.iter().map(|x| x.0).collect();
    let phase = |name: &str| {
        tracing::info!(
            phase = name,
            filter_passes = budget.passes(),
            steps = budget.steps(),
            map_jumps = budget.jumps(),
            anchors = budget.work().anchors(),
            searched = budget.work().searched(),
            replays = ?budget.work().replays(),
            "planner cost so far"
        );
    };
    let (profile, sites) = budget.tag_free(settings.candidate_spacing_m, &sites_m);
    phase("tag-free pass");
    let mut mountings = Vec::with_capacity(sites.len());
    let mut tunnels = Vec::with_capacity(sites.len());
    for (n, s) in sites.iter().enumerate() {
        let road = ctx.as_ref().map(|c| c.at(s.distance_m));
        let tunnel = road.is_some_and(|a| a.tunnel);
        let o = settings
            .mountings
            .iter()
            .find(|o| o.allowed_on(tunnel))
            .unwrap_or(&settings.mountings[0]);
        mountings.push(match site_list[n].1 {
            Some(ti) => settings.existing_tags[ti].mounting,
            None => o.mounting,
        });
        tunnels.push(tunnel);
    }
    let site_existing: Vec<Option<usize>> =
        site_list.iter().take(sites.len()).map(|x| x.1).collect();
    // Keep sites whose mounting is allowed there.
    let keep: Vec<bool> = sites
        .iter()
        .zip(&mountings)
        .zip(&tunnels)
        .zip(&site_existing)
        .map(|(((_, m), &tun), ex)| {
            ex.is_some()
                || settings
                    .mountings
                    .iter()
                    .any(|o| o.mounting == *m && o.allowed_on(tun))
        })
        .collect();
    let site_existing: Vec<Option<usize>> = site_existing
        .into_iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(s, _)| s)
        .collect();
    let is_existing: Vec<bool> = site_existing.iter().map(Option::is_some).collect();
    let sites: Vec<_> = sites
        .into_iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(s, _)| s)
        .collect();
    let mountings: Vec<_> = mountings
        .into_iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(s, _)| s)
        .collect();
    let tunnels: Vec<_> = tunnels
        .into_iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(s, _)| s)
        .collect();
    // The tag-free reaches, each computed when the placement's search first
    // needs it (a filter run per site).
    let tag_free = budget
        .lazy_reaches(&sites, &mountings, req, Some(&tag_free_tick))
        .certifying();
    let start_reach = budget.start_reach(req);
    let at_m: Vec<f64> = sites.iter().map(|s| s.distance_m).collect();
    let k = settings.tolerate_missed_reads;
    if start_reach <= 0.0 {
        let b0 = budget
            .initial_filter()
            .map_or(f64::NAN, |f| budget.bound(&f.position_cov_enu()));
        return Err(Error::Infeasible(format!(
            "the navigator's initial position uncertainty (bound {b0:.2} m at the requirement's confidence, from \
             navigator.initial_position_sigma_m / filter.position_sigma_m) already exceeds the {req} m \
             requirement at the start of the route"
        )));
    }
    // The placement searches' work (candidates tested), counted with the
    // filter's.
    let tested = std::cell::Cell::new(0);
    let placed = place_lazy_with_end(
        length,
        start_reach,
        &at_m,
        &|i| tag_free.get(i).1,
        &|i| tag_free.reaches_end(i),
        &is_existing,
        k,
        settings.min_spacing_m,
        &tested,
    );
    budget.work().add_searched(tested.take());
    phase("tag-free reaches and placement");
    tracing::debug!(
        computed = tag_free.computed(),
        shown_short = tag_free.certified(),
        sites = sites.len(),
        "tag-free reaches computed"
    );
    let chosen = match placed {
        Placement::Feasible(c) => c,
        Placement::Infeasible { covered_to_m } => {
            let road = ctx
                .as_ref()
                .map(|c| {
                    let a = c.at(covered_to_m);
                    format!(
                        " (road {}{})",
                        a.id,
                        a.name
                            .as_ref()
                            .map(|n| format!(" \"{n}\""))
                            .unwrap_or_default()
                    )
                })
                .unwrap_or_default();
            let next = at_m
                .iter()
                .copied()
                .find(|&a| a > covered_to_m)
                .unwrap_or(length);
            return Err(Error::Infeasible(format!(
                "the {req} m requirement cannot be held with {k} missed read(s) tolerated \
                 beyond route distance {covered_to_m:.0} m{road}; the stretch {covered_to_m:.0}–{next:.0} m \
                 of {length:.0} m cannot be covered (no candidate site reaches it)"
            )));
        }
    };
    // Refinement: the reaches above start from the tag-free filter, whose
    // velocity and attitude uncertainty the planned fixes would have kept
    // smaller. Recompute them from the filter as the plan leaves it (all
    // planned fixes read), re-place, and keep the new plan only when the
    // covariance analysis confirms it: the bound holds with every tag read
    // and with any k consecutive tags missed.
    let mut chosen = chosen;
    // Reaches from a refined filter, when a refinement was kept.
    let mut refined_reaches: Option<Vec<(f64, f64)>> = None;
    let mut refined = 0;
    // The plan whose filter the snapshots come from (accepted or not).
    let mut basis = chosen.clone();
    for _ in 0..settings.refine_iterations {
        let fixes: Vec<(usize, Mounting)> = basis
            .iter()
            .map(|&i| (sites[i].sample, mountings[i]))
            .collect();
        let at: Vec<f64> = sites.iter().map(|s| s.distance_m).collect();
        let (_, sites2) = budget.snapshots(&fixes, settings.candidate_spacing_m, &at);
        if sites2.len() != sites.len() {
            break;
        }
        let reaches2 = budget.reaches_with_progress(&sites2, &mountings, req, Some(&refined_tick));
        let cands2: Vec<Candidate> = sites2
            .iter()
            .zip(&reaches2)
            .map(|(s, &(_, r))| Candidate {
                at_m: s.distance_m,
                reach_m: r,
            })
            .collect();
        let placed = place_with(
            length,
            start_reach,
            &cands2,
            &is_existing,
            k,
            settings.min_spacing_m,
            &tested,
        );
        budget.work().add_searched(tested.take());
        let Placement::Feasible(c2) = placed else {
            break;
        };
        if c2 == basis {
            break;
        }
        let fixes2: Vec<(usize, Mounting)> = c2
            .iter()
            .map(|&i| (sites[i].sample, mountings[i]))
            .collect();
        if c2.len() < chosen.len()
            && robust_with_progress(
                &budget,
                &fixes2,
                k,
                req,
                settings.candidate_spacing_m,
                Some(&check_tick),
            )
        {
            chosen = c2.clone();
            refined_reaches = Some(reaches2);
            refined += 1;
        }
        basis = c2;
    }
    phase("refinement");
    let new_count = |c: &[usize]| c.iter().filter(|&&i| !is_existing[i]).count();
    // Forward placement with the plan's own filters (module `forward`):
    // kept when it needs fewer new tags and passes the covariance check
    // with any k consecutive tags missed.
    let fwd_sites: Vec<forward::ForwardSite> = sites
        .iter()
        .enumerate()
        .map(|(i, s)| forward::ForwardSite {
            sample: s.sample,
            distance_m: s.distance_m,
            mounting: mountings[i],
            existing: is_existing[i],
        })
        .collect();
    let mut forward_used = false;
    // Without installed tags, a route the start does not cover needs at
    // least k + 1 new tags whatever the plan (see the lower bound below):
    // a plan with that many cannot be bettered, so the forward walk, kept
    // only when it needs fewer, is not run.
    let trivial = if start_reach >= length { 0 } else { k + 1 };
    let at_trivial = !is_existing.iter().any(|&e| e) && new_count(&chosen) == trivial;
    let fw = if at_trivial {
        Placement::Feasible(chosen.clone())
    } else {
        forward::forward_greedy(&budget, &fwd_sites, k, req, settings.min_spacing_m, k + 1)
    };
    phase("forward placement");
    // The all-read pass of the forward check, when kept: the plan's own.
    let mut checked = None;
    if let Placement::Feasible(c3) = fw {
        if new_count(&c3) < new_count(&chosen) {
            let fixes3: Vec<(usize, Mounting)> = c3
                .iter()
                .map(|&i| (sites[i].sample, mountings[i]))
                .collect();
            let (ok, all, worst) = robust_all_read(
                &budget,
                &fixes3,
                k,
                req,
                settings.candidate_spacing_m,
                Some(&check_tick),
            );
            if ok {
                chosen = c3;
                forward_used = true;
                checked = Some((all, worst));
            }
            phase("forward check");
        }
    }
    // Lower bound: the most optimistic reaches (each site's filter having
    // read a tag at every earlier candidate site). By the monotonicity of
    // the filter's covariance in the information it has had, no plan on
    // these sites reaches further from any site, so the exact placement on
    // these reaches needs no more tags than any feasible plan.
    // Without installed tags, a route the start does not cover needs at
    // least k + 1 tags: the (k+1)-th must come within the start's reach,
    // whatever is read. A plan with exactly that many is minimal, and the
    // placement on the optimistic reaches (below) finds the same count, as
    // it lies between this bound and any feasible plan's; so it is skipped.
    let lower_bound = if !is_existing.iter().any(|&e| e) && new_count(&chosen) == trivial {
        trivial
    } else {
        let all: Vec<(usize, Mounting)> = sites
            .iter()
            .zip(&mountings)
            .map(|(s, &m)| (s.sample, m))
            .collect();
        // Carried by the stretch maps where there are some (the stepped
        // pass read a fix at every site: 1.0 pass on the paper's drive).
        let opt_sites = budget
            .optimistic_sites(&sites, &mountings)
            .unwrap_or_else(|| {
                let at: Vec<f64> = sites.iter().map(|s| s.distance_m).collect();
                budget.snapshots(&all, settings.candidate_spacing_m, &at).1
            });
        if opt_sites.len() == sites.len() {
            // Each site's snapshot has read a tag at every earlier site.
            let r = budget
                .lazy_reaches(&opt_sites, &mountings, req, Some(&optimistic_tick))
                .certifying();
            let opt_at: Vec<f64> = opt_sites.iter().map(|s| s.distance_m).collect();
            let placed = place_lazy_with_end(
                length,
                start_reach,
                &opt_at,
                &|i| r.get(i).1,
                &|i| r.reaches_end(i),
                &is_existing,
                k,
                settings.min_spacing_m,
                &tested,
            );
            budget.work().add_searched(tested.take());
            match placed {
                Placement::Feasible(c) => new_count(&c),
                Placement::Infeasible { .. } => 0,
            }
        } else {
            0
        }
    };
    phase("lower bound");
    // Each chosen tag's bound after its fix and reach, from the plan's own
    // filter (every planned tag read).
    let fixes: Vec<(usize, Mounting)> = chosen
        .iter()
        .map(|&i| (sites[i].sample, mountings[i]))
        .collect();
    // The plan's profile, and its filter at each chosen site (before the
    // fix there), in one all-read pass; `Budget::snapshots` and
    // `Budget::with_fixes` step and fix the filter the same way except for
    // a fix at the first sample (applied before the first step by the
    // latter, after it by the former), so that case keeps its own pass.
    let at: Vec<f64> = chosen.iter().map(|&i| sites[i].distance_m).collect();
    // Also the missed-read bound's all-read pass (its profile grid).
    // (The forward check's, when it checked this plan: the same pass.)
    // (And the check's missed-read windows' largest bound.)
    let (all, windows_worst) = match checked {
        Some((a, w)) if a.fixes == fixes && a.grid_m == super::output::MISSED_GRID_M => (a, w),
        _ => (
            budget.all_read_gridded(
                &fixes,
                settings.candidate_spacing_m,
                &at,
                super::output::MISSED_GRID_M,
            ),
            None,
        ),
    };
    let own = if fixes.iter().all(|f| f.0 > 0) {
        all.sites.clone()
    } else {
        budget
            .snapshots(&fixes, settings.candidate_spacing_m, &at)
            .1
    };
    let with = all.profile.clone();
    let chosen_reach: Vec<(f64, f64)> = if own.len() == chosen.len() {
        let m: Vec<Mounting> = chosen.iter().map(|&i| mountings[i]).collect();
        budget.reaches(&own, &m, req)
    } else {
        chosen
            .iter()
            .map(|&i| {
                refined_reaches
                    .as_ref()
                    .map_or_else(|| tag_free.get(i), |r| r[i])
            })
            .collect()
    };
    let mut tags = Vec::with_capacity(chosen.len());
    let mut speeds = Vec::with_capacity(chosen.len());
    let mut n_new = 0;
    let mut new_ids = super::settings::NewTagIds::new("T", 4, scn, settings);
    for (n, &i) in chosen.iter().enumerate() {
        let s = &sites[i];
        let a = &samples[s.sample].avp;
        let existing = site_existing[i].map(|ti| &settings.existing_tags[ti]);
        if existing.is_none() {
            n_new += 1;
        }
        let road = ctx.as_ref().map(|c| c.at(s.distance_m));
        let speed = site_speed_mps(a.state.v[0].hypot(a.state.v[1]), road);
        speeds.push(speed);
        let lane = budget.lane_width_at(s.sample);
        let (sa, sc) = scn
            .rfid
            .with_lane_width(lane)
            .fix_sigmas(mountings[i], speed);
        tags.push(PlannedTag {
            tag_id: existing.map_or_else(|| new_ids.next_id(), |t| t.id.clone()),
            lat: existing.map_or(a.state.lat, |t| t.lat).to_degrees(),
            lon: existing.map_or(a.state.lon, |t| t.lon).to_degrees(),
            height_m: existing.and_then(|t| t.height_m).unwrap_or(a.state.h),
            existing: existing.is_some(),
            route_distance_m: s.distance_m,
            road_chainage_m: ctx.as_ref().map(|c| c.road_chainage_m(s.distance_m)),
            t_s: a.t,
            mounting: mountings[i],
            expected_fix_sigma_m: sa.max(sc),
            road_id: road.map(|r| r.id.clone()),
            tunnel: tunnels[i],
            lane_width_m: lane,
            digitised_forward: ctx.as_ref().map(|c| {
                let sp = c.route.span_at(s.distance_m * c.scale.get());
                sp.to_offset_m >= sp.from_offset_m
            }),
            bound_after_fix_m: chosen_reach[n].0,
            reach_m: chosen_reach[n].1,
            reason: String::new(),
        });
    }
    super::plan::route_tag_reasons(&mut tags, &speeds, start_reach, length, req, k);
    let mut max_gap: f64 = 0.0;
    let mut prev = 0.0;
    for t in &tags {
        max_gap = max_gap.max(t.route_distance_m - prev);
        prev = t.route_distance_m;
    }
    max_gap = max_gap.max(length - prev);
    phase("plan's reaches and profile");
    let predicted = with.iter().map(|p| p.bound95_m).fold(0.0, f64::max);
    let total_cost = tags
        .iter()
        .filter(|t| !t.existing)
        .map(|t| {
            settings
                .mountings
                .iter()
                .find(|o| o.mounting == t.mounting)
                .map_or(1.0, |o| o.cost)
        })
        .fold(0.0, |a, c| a + c);
    let n_cands = sites.len();
    let mut plan = Plan {
        scenario: scn.name().to_string(),
        requirement_m: req,
        tolerate_missed_reads: k,
        method: if forward_used {
            "forward: furthest site each step with the plan's own filters (missed-read windows tracked), checked by covariance with any k consecutive tags missed".into()
        } else if refined > 0 {
            format!(
                "exact: breadth-first search over the last k+1 tags (single route), reaches refined {refined}x from the planned filter and confirmed with any k consecutive tags missed"
            )
        } else {
            "exact: breadth-first search over the last k+1 tags (single route) on tag-free reaches"
                .into()
        },
        lower_bound,
        optimal: lower_bound == n_new,
        existing_off_route,
        route_length_m: length,
        candidates: n_cands,
        start_reach_m: start_reach,
        tags,
        total_cost,
        max_gap_m: max_gap,
        predicted_max_bound95_m: predicted,
        predicted_max_bound95_missed_m: None,
        profile_without_tags: profile,
        profile_with_tags: with,
        validation: None,
        uniform_baseline: None,
        filter_passes: 0.0,
    };
    // The largest bound with any k consecutive tags missed, on the same
    // covariance analysis.
    plan.predicted_max_bound95_missed_m =
        plan.missed_bound_reusing(&budget, Some((&all, windows_worst)));
    phase("missed-tag bound");
    plan.filter_passes = budget.passes();
    if validate {
        plan.validation = Some(validate_plan(
            scn,
            truth,
            &plan,
            settings.validation_runs,
            seed,
        )?);
    }
    Ok(plan)
}
