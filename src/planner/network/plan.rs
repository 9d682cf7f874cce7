//! Planning network coverage: the instance with a reach per speed class,
//! solved exactly (integer programme) when small, else by the greedy, and
//! the selected sites as tags.

use super::cover::{self, Solved, Walk};
use super::coverage::{BudgetSource, EdgeCoverage};
use super::greedy;
use super::ilp::{self, IlpLimits, IlpOutcome};
use super::instance::{build, classes_in_use, describe_walk, speed_key};
use super::mm_reach::{budget_bound, straight_profiles, CalibrationSite, ReachRequirement};
use super::reach::{reach_class, ReachClass};
use super::settings::{check_settings, map_route, ILP_MAX_CANDIDATES};
use super::types::NetworkPlan;
use super::validate::validate_network_plan;
use super::walk_relax::{self, WalkRelaxation};
use super::walks::{through_budgets, walk_budgets, worst_walks, DESIGN_WALKS};
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::planner::settings::PlannerSettings;
use crate::scenario::Scenario;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::time::Instant;

/// The method of a plan the greedy solved: its own when the relaxation
/// found nothing cheaper.
fn relaxed_method(r: &WalkRelaxation, greedy: &str) -> String {
    let what = format!(
        "{} window(s) of the greedy's violating walks, {} round(s), {} subgradient iterations{}",
        r.windows,
        r.rounds,
        r.iterations,
        if r.lp_iterations > 0 {
            format!(
                "; lower bound also from their linear programme, {} primal–dual iterations: {:.1}",
                r.lp_iterations, r.lp_cost_bound
            )
        } else {
            String::new()
        }
    );
    if r.improved {
        format!(
            "set multicover by Lagrangian relaxation ({what}; its priced greedy{} beat the plain greedy), \
             exact reverse deletion, verified by the walk DP; from {greedy}",
            if r.repaired {
                ", repaired by greedy rounds over the walks it missed,"
            } else {
                ""
            }
        )
    } else {
        format!("{greedy} (Lagrangian relaxation: {what}, found nothing cheaper)")
    }
}

/// Plans network coverage for a scenario: loads its map, computes the
/// reach, places tags, and validates with `validation_runs` Monte Carlo runs
/// when `validate`.
pub fn plan_network(
    scn: &Scenario,
    settings: &PlannerSettings,
    seed: u64,
    validate: bool,
) -> Result<NetworkPlan> {
    let (net, mut plan) = plan_network_loaded(scn, settings)?;
    if validate && settings.validation_runs > 0 {
        plan.validation = Some(validate_network_plan(
            scn,
            &net,
            &plan,
            settings.validation_runs,
            seed,
            false,
        )?);
    }
    Ok(plan)
}

/// Loads a network-coverage scenario's map once and plans on it, without
/// validation: the loaded network (to share with the validation) and the
/// plan, whose timings include the load.
pub fn plan_network_loaded(
    scn: &Scenario,
    settings: &PlannerSettings,
) -> Result<(std::sync::Arc<Network>, NetworkPlan)> {
    let (map, _, _) = map_route(scn)?;
    let t0 = Instant::now();
    let net = std::sync::Arc::new(Network::load(map, &Default::default())?);
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut plan = plan_network_on(scn, settings, &net)?;
    plan.timings_ms.insert("load".into(), load_ms);
    Ok((net, plan))
}

/// [`plan_network`] on a loaded network, without validation.
pub fn plan_network_on(
    scn: &Scenario,
    settings: &PlannerSettings,
    net: &Network,
) -> Result<NetworkPlan> {
    let o = net.frame.origin();
    let scn_had_no_route = !super::settings::has_waypoints(scn);
    let located = scn.located_at([o.lat.to_degrees(), o.lon.to_degrees()]);
    let scn = &located;
    let (_, _, height_m) = map_route(scn)?;
    let speed_mps = scn.planner().vehicle_speed_mps;
    let (spacing, u_turns) = check_settings(scn, settings)?;
    // The candidate sites against their limit before anything is sized by
    // them (every caller of the library, not only the command).
    crate::scenario::check_network_candidates(scn, &net.model)?;
    let req = settings.requirement_m;
    let k = settings.tolerate_missed_reads;
    settings.check_best_fix(&scn.rfid)?;
    let mut timings = BTreeMap::new();
    // Instance with a placeholder reach, to learn the speed classes and mountings.
    let t = Instant::now();
    let mut built = build(net, settings, speed_mps, spacing, 1.0, u_turns, None)?;
    timings.insert("build".into(), t.elapsed().as_secs_f64() * 1e3);
    if scn.planner().traffic == crate::scenario::Traffic::Trips {
        return super::plan_trips::plan_network_trips(
            scn,
            settings,
            net,
            built,
            spacing,
            height_m,
            timings,
            !scn_had_no_route,
        );
    }
    // Reach per (speed, mounting) class in use.
    let t = Instant::now();
    let (speeds, mountings, classes) = classes_in_use(&built)?;
    let origin = net.frame.origin();
    let site = CalibrationSite {
        lat_deg: origin.lat.to_degrees(),
        lon_deg: origin.lon.to_degrees(),
        height_m,
    };
    let key = speed_key;
    let mut class_reach: BTreeMap<u64, f64> = BTreeMap::new();
    let mm =
        scn.aiding().map_matching && scn.navigator().mode == crate::scenario::NavMode::Integrated;
    let mut matched: Vec<super::mm_reach::MatchedReach> = Vec::new();
    let mut reach_classes: Vec<ReachClass> = Vec::new();
    let profiles: BTreeMap<u64, Vec<(f64, f64)>>;
    let (steady, start);
    if mm {
        // Map matching credited (docs/DESIGN.md §3.4): the matched reach per
        // speed class, and walks that end at every turn map matching observes.
        let mc = super::mm_reach::matched_classes(
            scn,
            site,
            &speeds,
            &mountings,
            ReachRequirement {
                req_m: req,
                p: scn.planner().requirement_confidence,
            },
        )?;
        matched = mc.all;
        class_reach = mc.reach;
        profiles = mc.profiles;
        let turns = mc.turns;
        steady = matched
            .iter()
            .map(|c| c.tag_reach_m)
            .fold(f64::INFINITY, f64::min);
        start = matched
            .iter()
            .map(|c| c.start_reach_m)
            .fold(f64::INFINITY, f64::min);
        let resets = |a: (SectionId, bool), b: (SectionId, bool)| -> bool {
            let (_, h0) = super::traffic::end_headings(net, a.0, a.1);
            let (h1, _) = super::traffic::end_headings(net, b.0, b.1);
            let attrs = &net.roads[net.sections[b.0 as usize].road as usize].attributes;
            let v = super::instance::road_speed(speed_mps, attrs.maxspeed_kmh, &attrs.highway);
            turns.get(&key(v)).copied().unwrap_or(false)
                && super::traffic::resets(super::traffic::turn_deg(h0, h1))
        };
        built = build(
            net,
            settings,
            speed_mps,
            spacing,
            1.0,
            u_turns,
            Some(&resets),
        )?;
    } else {
        reach_classes = classes
            .par_iter()
            .map(|&(v, m)| reach_class(scn, origin.lat, origin.lon, height_m, v, m, req))
            .collect::<Result<Vec<_>>>()?;
        steady = reach_classes
            .iter()
            .map(|c| c.steady_reach_m)
            .fold(f64::INFINITY, f64::min);
        start = reach_classes
            .iter()
            .map(|c| c.start_reach_m)
            .fold(f64::INFINITY, f64::min);
        // Reach per speed class: the smallest over the mountings in use,
        // steady and from the prior.
        for (c, &(v, _)) in reach_classes.iter().zip(&classes) {
            let r = class_reach.entry(key(v)).or_insert(f64::INFINITY);
            *r = r.min(c.steady_reach_m.min(c.start_reach_m));
        }
        let rq = ReachRequirement {
            req_m: req,
            p: scn.planner().requirement_confidence,
        };
        profiles = straight_profiles(scn, site, &speeds, rq)?;
    }
    timings.insert("reach".into(), t.elapsed().as_secs_f64() * 1e3);
    let reach_m = class_reach.values().copied().fold(f64::INFINITY, f64::min);
    let r_ref = class_reach.values().copied().fold(0.0, f64::max);
    if !(reach_m > 0.0 && r_ref.is_finite()) {
        return Err(Error::Infeasible(format!(
            "the {req} m requirement leaves no distance between fixes (reach 0 m)"
        )));
    }
    // Error budget consumed: a metre of a road in speed class c uses
    // 1/R_c of it, so the instance measures it as R_ref/R_c metres against
    // the reach R_ref (exact when the error grows with time alone, or with
    // distance alone; a mixture is approximated).
    for e in 0..built.physical_edges {
        let r = class_reach
            .get(&key(built.edge_speed[e]))
            .copied()
            .unwrap_or(reach_m);
        built.edge_scale[e] = r_ref / r;
        built.problem.edges[e].length_m *= built.edge_scale[e];
    }
    for site in &mut built.problem.sites {
        site.at_m *= built.edge_scale[site.edge as usize];
    }
    built.problem.reach_m = r_ref;
    let p = &built.problem;
    // Solve.
    let t = Instant::now();
    let (lb_pack, lb_pack_cost, _) = cover::packing_lower_bound(p);
    let mut method = String::new();
    let mut lb_cost = lb_pack_cost;
    let mut selected: Option<Vec<bool>> = None;
    let mut lb_relax = 0usize;
    let infeasible = |w: &Walk| -> Error {
        let metres: f64 = w
            .pieces
            .iter()
            .filter(|x| (x.0 as usize) < built.physical_edges)
            .map(|x| (x.2 - x.1) / built.edge_scale[x.0 as usize])
            .sum();
        Error::Infeasible(format!(
            "the {req} m requirement cannot be held with {k} missed read(s) tolerated on a walk of \
             {:.0} m through {}: its candidate sites cannot give {} read(s) within the error budget \
             (reach R = {:.0} m on the slowest roads, {:.0} m on the fastest; candidate spacing {spacing} m{})",
            metres,
            describe_walk(net, &built, w),
            k + 1,
            reach_m,
            r_ref,
            if reach_m < spacing * (k + 1) as f64 {
                "; R is shorter than the spacing allows: lower planner.candidate_spacing_m"
            } else {
                ""
            }
        ))
    };
    // The greedy first: a feasible selection, the warm start of the exact
    // method and the fallback.
    // Its witnesses (the violating walks of all its rounds) are the
    // windows of the Lagrangian relaxation below.
    let mut windows = walk_relax::WitnessWindows::new(p.k + 1);
    let (greedy_sel, st) =
        match greedy::greedy_from(p, p.existing_selection(), &mut |w| windows.add(w)) {
            (Solved::Feasible(s), st) => (s, st),
            (Solved::Infeasible(w), _) => return Err(infeasible(&w)),
        };
    let greedy_method = format!(
        "greedy: set multicover over violating walks ({} round(s), {} tag(s) added), exact reverse deletion ({} removed), verified by the walk DP",
        st.rounds, st.added, st.removed
    );
    if p.sites.len() <= ILP_MAX_CANDIDATES {
        match ilp::solve(p, IlpLimits::default(), Some(&greedy_sel)) {
            IlpOutcome::Optimal {
                selected: s,
                cost,
                rounds,
                constraints,
            } => {
                method = format!(
                    "exact: integer programme with lazy walk constraints ({rounds} round(s), {constraints} walk constraints; microlp, warm-started by the greedy), verified by the walk DP"
                );
                lb_cost = lb_cost.max(cost);
                selected = Some(s);
            }
            IlpOutcome::Infeasible(w) => return Err(infeasible(&w)),
            IlpOutcome::GaveUp {
                lower_bound_cost,
                reason,
            } => {
                lb_cost = lb_cost.max(lower_bound_cost);
                method = format!("(exact method gave up: {reason}) ");
            }
        }
    }
    let sel = match selected {
        Some(s) => s,
        None => {
            // The Lagrangian relaxation of the witnesses' multicover: a
            // cheaper selection (verified by the walk DP) when it finds one,
            // and a lower bound.
            let tr = Instant::now();
            let (s, r) = walk_relax::improve(p, greedy_sel, windows, lb_pack);
            timings.insert("relax".into(), tr.elapsed().as_secs_f64() * 1e3);
            lb_cost = lb_cost.max(r.cost_bound);
            lb_relax = r.tag_bound;
            method.push_str(&relaxed_method(&r, &greedy_method));
            s
        }
    };
    timings.insert("solve".into(), t.elapsed().as_secs_f64() * 1e3);
    let res = cover::check(p, &sel);
    let max_cost = settings
        .mountings
        .iter()
        .map(|o| o.cost)
        .fold(0.0, f64::max);
    let lb_count = if max_cost > 0.0 {
        lb_pack.max((lb_cost / max_cost - 1e-9).ceil().max(0.0) as usize)
    } else {
        lb_pack
    }
    .max(lb_relax);
    // What the walk DP says per road: the budgets behind coverage.geojson
    // and the tags' reasons.
    let physical = built.physical_edges;
    let wb = walk_budgets(p, &sel, physical);
    let through = through_budgets(p, physical);
    let class_of = |e: usize| -> (f64, f64) {
        let v = built.edge_speed[e];
        (
            v * 3.6,
            class_reach.get(&key(v)).copied().unwrap_or(reach_m),
        )
    };
    let without_what = if mm {
        "a turn map matching observes"
    } else {
        "a read"
    };
    let tunnel_of = |e: usize| -> &'static str {
        let (sec, _) = built.edge_dir[e];
        if net.roads[net.sections[sec as usize].road as usize]
            .attributes
            .tunnel
        {
            "tunnel; "
        } else {
            ""
        }
    };
    let reason = |i: usize| -> String {
        let site = &p.sites[i];
        let e = site.edge as usize;
        if site.existing {
            return "installed already".to_string();
        }
        let (v, r) = class_of(e);
        let (t, capped) = through[e];
        format!(
            "{}walks of {}{:.1} km through here without {without_what} (reach {}{r:.0} m at {v:.0} km/h; \
             every walk longer than the reach needs {} read(s))",
            tunnel_of(e),
            if capped { "over " } else { "" },
            t * r / 1000.0,
            if mm { "with map matching " } else { "" },
            k + 1
        )
    };
    let (tags, total_cost) =
        super::tag_sites::tags_of(scn, settings, net, &built, &sel, height_m, reason);
    let existing_kept = tags.iter().filter(|t| t.existing).count();
    let edge_coverage: Vec<EdgeCoverage> = (0..physical)
        .map(|e| {
            let (v, r) = class_of(e);
            let prof = profiles.get(&key(v / 3.6)).map(Vec::as_slice).unwrap_or(&[]);
            // A budget of 1 reads as the requirement (`budget_bound`).
            let bound = |b: f64| budget_bound(prof, b, r, req);
            let (sec, fwd) = built.edge_dir[e];
            let without = wb.without[e];
            let reason = if without <= 1.0 {
                if mm {
                    "turns and map matching hold the requirement without tags".to_string()
                } else {
                    "short enough from any start without tags".to_string()
                }
            } else {
                format!(
                    "{}walks of {}{:.0} m reach here without {without_what} (reach {r:.0} m at {v:.0} km/h)",
                    tunnel_of(e),
                    if without * p.reach_m >= p.reach_m + 1.0 - 1e-6 { "over " } else { "" },
                    without * r
                )
            };
            EdgeCoverage {
                edge: e as u32,
                section: sec,
                forward: fwd,
                passes: None,
                beginning_passes: None,
                budget_with_tags: wb.all_read[e],
                budget_without_tags: without,
                budget_from: Some(BudgetSource::AnyWalk),
                budget_missed: Some(wb.missed[e]),
                bound_with_tags_m: bound(wb.all_read[e]),
                bound_without_tags_m: bound(without),
                bound_missed_m: bound(wb.missed[e]),
                speed_kmh: v,
                reason,
            }
        })
        .collect();
    // The DP's worst walks, which the validation drives with their tags
    // missed.
    let sel_sites: Vec<usize> = (0..sel.len()).filter(|&i| sel[i]).collect();
    let design_walks = if res.feasible() {
        worst_walks(net, &built, &sel, DESIGN_WALKS, |s| {
            sel_sites
                .binary_search(&(s as usize))
                .ok()
                .and_then(|i| tags.get(i))
                .map(|t| t.tag_id.clone())
        })
    } else {
        Vec::new()
    };
    // The traffic the validation samples (chains of trips over every
    // permitted road): edges at their planning speeds.
    let model = super::traffic::EdgeModel::new(
        net,
        built.edge_dir[..physical].to_vec(),
        built.edge_speed[..physical].to_vec(),
        vec![0.0; physical],
        vec![Vec::new(); physical],
        vec![0.0; physical],
        (0.0, 0.0),
    );
    let main = super::traffic::main_component(net, &model);
    let dest = super::traffic::Destinations::by_length(net, &model, &main)?;
    let chain_model = super::traffic::ChainModel { model, dest };
    Ok(NetworkPlan {
        scenario: scn.name().to_string(),
        coverage: "network".into(),
        requirement_m: req,
        tolerate_missed_reads: k,
        method,
        lower_bound: lb_count,
        lower_bound_cost: lb_cost,
        reach_m,
        steady_reach_m: steady,
        start_reach_m: start,
        reach_classes,
        directed_edges: built.physical_edges,
        u_turns: u_turns.as_str().into(),
        directed_length_km: built.directed_length_m / 1000.0,
        candidates: p.sites.len(),
        candidate_spacing_m: spacing,
        existing_kept,
        existing_off_network: built.existing_off,
        tags,
        total_cost,
        verified: res.feasible(),
        longest_walk_budget: res.longest_m / r_ref,
        budget_reference_m: r_ref,
        reach_levels: 1,
        timings_ms: timings,
        validation: None,
        traffic: "any_walk".into(),
        map_matching: mm,
        vehicle_speed_kmh: scn.planner().vehicle_speed_mps * 3.6,
        requirement_confidence: 0.95,
        rule: format!(
            "the predicted 95 % horizontal bound (conservative circle of the 2-D covariance) within \
             {req} m on every walk through the network, with {k} consecutive missed read(s) tolerated"
        ),
        route_ignored: super::settings::has_waypoints(scn) && !scn_had_no_route,
        matched_reach: matched,
        guarantee: None,
        windows: 0,
        window_ids: 0,
        planning_km: 0.0,
        planning_windows: Default::default(),
        design_walks,
        edge_coverage,
        chain_model: Some(std::sync::Arc::new(chain_model)),
        selected: sel,
        problem: Some(built.problem),
    })
}
