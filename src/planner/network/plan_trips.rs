//! A network plan for `traffic = "trips"`: the reach per speed class (with
//! map-matching credit when the navigator matches), the edges' budget
//! rates and geometry, the sampled chains, the multicover and its
//! guarantee, the tags with their reasons and the per-edge coverage.

use super::coverage::{add_early_budgets, add_walk_budgets, edge_budgets, BudgetSource};
use super::instance::{classes_in_use, speed_key, Built};
use super::mm_reach::{
    budget_bound, matched_classes, straight_profiles, CalibrationSite, MatchedReach,
    ReachRequirement, CALIBRATION_M, TURN_DEG,
};
use super::reach::{reach_class, ReachClass};
use super::straight::{walk_budgets, WALK_BUDGET_CAP};
use super::tag_sites::tags_of;
use super::traffic::{Destinations, EdgeModel};
use super::trips::{plan_trips, TripsGuarantee, TripsPlan};
use super::types::NetworkPlan;
use super::window_sets::WindowInfo;
use crate::error::{Error, Result};
use crate::network::Network;
use crate::planner::settings::PlannerSettings;
use crate::route::{snap, SectionPoint};
use crate::scenario::{NavMode, Scenario};
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

/// Snap distance of listed destinations (m).
const DESTINATION_SNAP_M: f64 = 100.0;

/// Largest weight of a listed destination: weights are relative (a share
/// of the trips), and 1e9 destinations of this weight still add up to a
/// finite total (1e308 twice overflowed to infinity, and every trip then
/// started at the last destination).
const MAX_DESTINATION_WEIGHT: f64 = 1e9;

/// Reads `planner.destinations`: `lat,lon[,weight]` per line, an optional
/// header, each point snapped to the nearest road.
fn read_destinations(
    path: &std::path::Path,
    net: &Network,
) -> Result<(Vec<SectionPoint>, Vec<f64>)> {
    let err = |m: String| Error::format(path, m);
    // Limited like a tag file: an endless input (`/dev/zero`) or a huge
    // file is refused, not read until memory runs out.
    let text = crate::fsio::read_text_limited(
        path,
        crate::sim::tags::MAX_TAGS_CSV_BYTES,
        "destinations file",
    )?;
    let mut pts = Vec::new();
    let mut w = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.split(',').map(str::trim).collect();
        let nums: Vec<Option<f64>> = f.iter().map(|x| x.parse::<f64>().ok()).collect();
        if i == 0 && nums.iter().take(2).any(Option::is_none) {
            continue; // header
        }
        if !(2..=3).contains(&f.len()) {
            return Err(err(format!(
                "line {}: expected lat,lon[,weight], got {} fields",
                i + 1,
                f.len()
            )));
        }
        let (Some(lat), Some(lon)) = (nums[0], nums[1]) else {
            return Err(err(format!("line {}: lat and lon must be numbers", i + 1)));
        };
        let weight = match f.get(2) {
            Some(_) => {
                nums[2].ok_or_else(|| err(format!("line {}: weight must be a number", i + 1)))?
            }
            None => 1.0,
        };
        if !(weight.is_finite() && (0.0..=MAX_DESTINATION_WEIGHT).contains(&weight)) {
            return Err(err(format!(
                "line {}: weight {} must be between 0 and {} (weights are relative)",
                i + 1,
                crate::decimal::short_number(weight),
                crate::decimal::short_number(MAX_DESTINATION_WEIGHT)
            )));
        }
        let (p, _, _) = snap(net, [lat, lon], DESTINATION_SNAP_M).map_err(|e| {
            err(format!(
                "line {}: destination ({lat}, {lon}) is off the map: {}",
                i + 1,
                match e {
                    Error::InvalidParameter(m) => m,
                    o => o.to_string(),
                }
            ))
        })?;
        pts.push(p);
        w.push(weight);
        if pts.len() > 1_000_000 {
            return Err(err("more than 1,000,000 destinations".into()));
        }
    }
    Ok((pts, w))
}

/// The method text's account of the coverage map's straight walks that
/// stopped at a limit (`walk_budgets`' stats): empty when none did.
fn coverage_walk_stops(s: super::straight::WalkStats) -> String {
    let mut parts = Vec::new();
    if s.cut > 0 {
        parts.push(format!(
            "{cut} start(s) stopped at {steps} edges entered",
            cut = s.cut,
            steps = super::straight::MAX_STEPS
        ));
    }
    if s.forked > 0 {
        parts.push(format!(
            "{forked} stopped forking at {paths} paths",
            forked = s.forked,
            paths = super::straight::MAX_PATHS
        ));
    }
    if parts.is_empty() {
        return String::new();
    }
    format!(
        "; in coverage.geojson the straight walks from {} (the straight-walk budgets near them \
         may be understated)",
        parts.join(" and ")
    )
}

/// The method text's account of the walk DP's lazy windows
/// (`super::walk_oracle`) with `k` missed reads tolerated.
fn held_walks_text(h: super::walk_oracle::HeldWalks, k: usize) -> String {
    let found = if h.violations == 0 {
        format!(
            "found every walk held by the tags ({} pass(es) or more)",
            k + 1
        )
    } else {
        format!("still found {} walk end(s) unheld", h.violations)
    };
    format!(
        "; on the {roads} directed road(s) within one budget of the {nc} whose speed class gets \
         no turn credit, the walk DP (walks from anywhere along the transitions that do not \
         reset, at most one turn-back, a road's own bends resetting as scanned without the \
         walk's heading history, tag passes counted as along a chain) {found} after {checks} \
         check(s) and {passes} solve(s) more, adding {added} windows",
        roads = h.roads,
        nc = h.no_credit,
        checks = h.checks,
        passes = h.passes,
        added = h.windows
    )
}

/// The method text of a trips plan. Named arguments throughout: a format
/// string mixing positional `{}` with optional parts once printed a count
/// in another's place (introduced in the twenty-first session, found in
/// the twenty-second).
fn trips_method(
    tp: &TripsPlan,
    g: &TripsGuarantee,
    mm: bool,
    chains: usize,
    k: usize,
    walk_stops: super::straight::WalkStats,
) -> String {
    let solver = if tp.exact {
        "exact set multicover (integer programme, microlp)".to_string()
    } else {
        let cover = if tp.lp_priced {
            format!(
                "set multicover by a greedy priced by the windows' linear programme ({lp} \
                 primal–dual iterations; cheaper than the Lagrangian relaxation's, {lr} \
                 subgradient iterations)",
                lp = tp.lp.iterations,
                lr = tp.relaxation.iterations
            )
        } else if tp.relaxation.improved {
            format!(
                "set multicover by Lagrangian relaxation ({lr} subgradient iterations; its priced \
                 greedy beat the plain greedy)",
                lr = tp.relaxation.iterations
            )
        } else {
            format!(
                "greedy set multicover with reverse deletion (Lagrangian relaxation, {lr} \
                 iterations, found nothing cheaper)",
                lr = tp.relaxation.iterations
            )
        };
        let moves = match tp.add_drop.moves {
            0 => "no move improved".to_string(),
            m => format!(
                "{m} move(s), {saved} tag(s) fewer",
                saved = tp.add_drop.tags_saved
            ),
        };
        format!("{cover}; add-drop local search ({moves})")
    };
    let walked = if mm {
        " (a heading change of ≥ 45° within the class's curve distance resets)"
    } else {
        " the traffic used"
    };
    let beginnings = if g.cold_starts > 0 {
        format!(
            ", and of the stretches before calibration of {n} chain beginnings, {over} of them \
             over budget without tags",
            n = g.cold_starts,
            over = g.cold_starts_over_budget
        )
    } else {
        String::new()
    };
    let discard = match tp.discard {
        Some(d) if d.certified => format!(
            "; round 1 certified a cover leaving {left} sampled beginning(s) over budget, \
             {removed} tag(s) fewer than the full cover (sampling and discarding)",
            left = d.left,
            removed = d.removed
        ),
        Some(d) => format!(
            "; a cover leaving {left} sampled beginning(s) over budget ({removed} tag(s) fewer) \
             failed round 1, so the full cover was judged on the same chains",
            left = d.left,
            removed = d.removed
        ),
        None => String::new(),
    };
    let optimum = match tp.optimum_round {
        Some(true) => ", the last the exact optimum's own",
        Some(false) => {
            "; the exact optimum of the windows, with fewer tags, failed a round of its own, so \
             the certified selection stands"
        }
        None => "",
    };
    let lp = if tp.lp.iterations > 0 {
        format!(
            "; lower bound also from the windows' linear programme ({it} primal–dual iterations: \
             {cost:.1} tags' cost)",
            it = tp.lp.iterations,
            cost = tp.lp.cost_bound
        )
    } else {
        String::new()
    };
    let cut = if tp.walks_cut > 0 {
        format!(
            "; the straight walks from {n} start(s) stopped at {steps} edges entered (forks \
             without end; the windows they missed are left to the certification rounds)",
            n = tp.walks_cut,
            steps = super::straight::MAX_STEPS
        )
    } else {
        String::new()
    };
    let forked = if tp.walks_forked > 0 {
        format!(
            "; the straight walks from {n} start(s) stopped forking at {paths} paths (the \
             windows of the paths not followed {left} the certification rounds)",
            n = tp.walks_forked,
            paths = super::straight::MAX_PATHS,
            left = if tp.held.is_some() {
                "and outside the walk DP's graph below are left to"
            } else {
                "are left to"
            }
        )
    } else {
        String::new()
    };
    let held = tp.held.map_or_else(String::new, |h| held_walks_text(h, k));
    let stops = coverage_walk_stops(walk_stops);
    format!(
        "{solver} over the budget windows of every straight walk{walked} and of {chains} sampled \
         chains{beginnings} ({windows} windows); certified on fresh chains ({rounds} \
         round(s){discard}{optimum}){lp}{cut}{forked}{held}{stops}",
        windows = tp.window_sets.len(),
        rounds = g.rounds
    )
}

/// Plans `trips` traffic on a built instance (module doc).
#[allow(clippy::too_many_arguments)]
pub(super) fn plan_network_trips(
    scn: &Scenario,
    settings: &PlannerSettings,
    net: &Network,
    built: Built,
    spacing: f64,
    height_m: f64,
    mut timings: BTreeMap<String, f64>,
    route_ignored: bool,
) -> Result<NetworkPlan> {
    let p = scn.planner();
    let req = settings.requirement_m;
    let k = settings.tolerate_missed_reads;
    let conf = p.requirement_confidence;
    let mm = scn.aiding().map_matching && scn.navigator().mode == NavMode::Integrated;
    let physical = built.physical_edges;
    // The listed destinations are read, snapped and checked before the
    // reach (seconds of filter runs), so that a bad file fails at once;
    // the connectivity check needs the edge model and comes after it.
    let listed = match &p.destinations {
        Some(path) => {
            let (pts, w) = read_destinations(path, net)?;
            let d = Destinations::listed(net, pts, &w).map_err(|e| {
                Error::format(
                    path,
                    match e {
                        Error::InvalidParameter(m) => m,
                        o => o.to_string(),
                    },
                )
            })?;
            Some((path, d))
        }
        None => None,
    };
    // Reach per (speed class, mounting in use).
    let t = Instant::now();
    let (speeds, mountings, classes) = classes_in_use(&built)?;
    let origin = net.frame.origin();
    let site = CalibrationSite {
        lat_deg: origin.lat.to_degrees(),
        lon_deg: origin.lon.to_degrees(),
        height_m,
    };
    let rq = ReachRequirement {
        req_m: req,
        p: conf,
    };
    // The reach per class that the straight walks and calibrated chains
    // budget at, and (two levels) the early reach chains budget at before
    // they are calibrated (`super::traffic::calibration_point`).
    let mut class_reach: BTreeMap<u64, f64> = BTreeMap::new();
    let mut class_early: BTreeMap<u64, f64> = BTreeMap::new();
    let two_levels = mm && p.reach_levels == 2;
    let profiles: BTreeMap<u64, Vec<(f64, f64)>>;
    let mut matched: Vec<MatchedReach> = Vec::new();
    let mut class_curve: BTreeMap<u64, f64> = BTreeMap::new();
    let mut reach_classes: Vec<ReachClass> = Vec::new();
    if mm {
        let mc = matched_classes(scn, site, &speeds, &mountings, rq)?;
        matched = mc.all;
        if two_levels {
            class_reach = mc.calibrated;
            class_early = mc.early;
        } else {
            class_reach = mc.reach;
        }
        class_curve = mc.curve;
        profiles = mc.profiles;
    } else {
        reach_classes = classes
            .par_iter()
            .map(|&(v, m)| reach_class(scn, origin.lat, origin.lon, height_m, v, m, req))
            .collect::<Result<Vec<_>>>()?;
        for (c, &(v, _)) in reach_classes.iter().zip(&classes) {
            let r = class_reach.entry(speed_key(v)).or_insert(f64::INFINITY);
            *r = r.min(c.steady_reach_m.min(c.start_reach_m));
        }
        profiles = straight_profiles(scn, site, &speeds, rq)?;
    }
    timings.insert("reach".into(), t.elapsed().as_secs_f64() * 1e3);
    let reach_m = class_reach
        .values()
        .chain(class_early.values())
        .copied()
        .fold(f64::INFINITY, f64::min);
    let r_ref = class_reach.values().copied().fold(0.0, f64::max);
    if !(reach_m > 0.0 && r_ref.is_finite()) {
        return Err(Error::Infeasible(format!(
            "the {req} m requirement leaves no distance between fixes (reach 0 m)"
        )));
    }
    // The edges as the chains see them.
    let t = Instant::now();
    let prob = &built.problem;
    let mut sites: Vec<Vec<(f64, u32)>> = vec![Vec::new(); physical];
    for (i, s) in prob.sites.iter().enumerate() {
        if (s.edge as usize) < physical {
            sites[s.edge as usize].push((s.at_m, i as u32));
        }
    }
    for v in &mut sites {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let rate: Vec<f64> = built.edge_speed[..physical]
        .iter()
        .map(|&v| 1.0 / class_reach.get(&speed_key(v)).copied().unwrap_or(reach_m))
        .collect();
    let curve: Vec<f64> = built.edge_speed[..physical]
        .iter()
        .map(|&v| {
            if mm {
                class_curve.get(&speed_key(v)).copied().unwrap_or(0.0)
            } else {
                0.0
            }
        })
        .collect();
    let mut model = EdgeModel::new(
        net,
        built.edge_dir[..physical].to_vec(),
        built.edge_speed[..physical].to_vec(),
        rate,
        sites,
        curve,
        if mm {
            (
                super::parallel::PARALLEL_MIN_FACTOR * req,
                super::parallel::PARALLEL_FACTOR * req,
            )
        } else {
            (0.0, 0.0)
        },
    );
    if two_levels {
        let early: Vec<f64> = built.edge_speed[..physical]
            .iter()
            .map(|&v| 1.0 / class_early.get(&speed_key(v)).copied().unwrap_or(reach_m))
            .collect();
        model = model.with_levels(early, CALIBRATION_M);
    }
    let main = super::traffic::main_component(net, &model);
    let dest = match listed {
        Some((path, d)) => {
            if let Some(i) = d.points().iter().position(|q| !main[q.section as usize]) {
                return Err(Error::format(
                    path,
                    format!(
                        "destination {} lies on a road outside the network's main connected \
                         part (trips from or to it cannot be routed both ways)",
                        i + 1
                    ),
                ));
            }
            d
        }
        None => Destinations::by_length(net, &model, &main)?,
    };
    let cost: Vec<f64> = prob.sites.iter().map(|s| s.cost).collect();
    let pre: Vec<bool> = prob.sites.iter().map(|s| s.existing).collect();
    timings.insert("edges".into(), t.elapsed().as_secs_f64() * 1e3);
    let t = Instant::now();
    let road_of = |site: u32| -> String {
        let e = prob.sites[site as usize].edge as usize;
        let (sec, _) = built.edge_dir[e];
        let a = &net.roads[net.sections[sec as usize].road as usize].attributes;
        a.name.clone().unwrap_or_else(|| format!("road {}", a.id))
    };
    let infeasible = |w: &WindowInfo, ids: &[u32]| -> Error {
        let roads: BTreeSet<String> = ids.iter().map(|&s| road_of(s)).collect();
        Error::Infeasible(format!(
            "the {req} m requirement cannot be held with {k} missed read(s) tolerated on a stretch of \
             {:.0} m{}{}: a window of the error budget (reach {:.0}–{:.0} m by speed class) holds only {} \
             candidate site(s), fewer than the {} reads needed (lower planner.candidate_spacing_m = \
             {spacing} m, or allow more mountings)",
            w.stretch_m,
            if w.at_start { " from a chain's start" } else { " without a turn" },
            if roads.is_empty() {
                String::new()
            } else {
                format!(" on {}", roads.into_iter().collect::<Vec<_>>().join(", "))
            },
            reach_m,
            r_ref,
            ids.len(),
            k + 1
        ))
    };
    let tp = plan_trips(
        net,
        &model,
        &dest,
        prob.sites.len(),
        &cost,
        &pre,
        k,
        mm,
        p.shift_s,
        p.planning_chains,
        p.cold_starts,
        p.discarded_beginnings,
        p.violation_probability,
        1.0 - p.confidence,
        scn.seed(),
        infeasible,
        settings.max_window_ids,
        |max_ids, windows| {
            Error::scenario(
                &scn.path,
                format!(
                    "traffic = \"trips\": the plan's budget windows passed {} site ids ({} windows so \
                     far; each holds the candidate sites within one reach, {:.0}–{:.0} m, at \
                     planner.candidate_spacing_m = {spacing} m), the limit that keeps the cover within \
                     memory: raise candidate_spacing_m, turn on map matching ([aiding] map_matching = \
                     true, which resets the budget at turns), or plan traffic = \"any_walk\"",
                    max_ids, windows, reach_m, r_ref
                ),
            )
        },
    )?;
    timings.insert("solve".into(), t.elapsed().as_secs_f64() * 1e3);
    let sel = tp.selected.clone();
    // Tags with their reasons.
    // "a turn of ≥ 45° within 200 m" at the class's curve distance.
    let turn_words = |v_kmh: f64| -> String {
        match class_curve
            .get(&speed_key(v_kmh / 3.6))
            .copied()
            .unwrap_or(0.0)
        {
            w if w > 0.0 => format!("a turn of ≥ {TURN_DEG:.0}° within {w:.0} m"),
            _ => "a tag (turns give no credit at this speed)".to_string(),
        }
    };
    // "parallel road N m away": a warning where map matching may take the
    // wrong road (`super::parallel`).
    let parallel_words = |e: usize| -> String {
        model.parallel[e]
            .map(|d| format!("parallel road {d:.0} m away (map matching may take it); "))
            .unwrap_or_default()
    };
    let reason =
        |i: usize| -> String {
            let site = &prob.sites[i];
            let (sec, _) = built.edge_dir[site.edge as usize];
            let a = &net.roads[net.sections[sec as usize].road as usize].attributes;
            let par = parallel_words(site.edge as usize);
            let tunnel = if a.tunnel {
                format!("tunnel; {par}")
            } else {
                par
            };
            let v = built.edge_speed[site.edge as usize] * 3.6;
            match &tp.site_reason[i] {
                _ if site.existing => "installed already".to_string(),
                Some(w) if mm && (w.at_start || (two_levels && w.early)) => format!(
                    "{tunnel}{:.1} km {} without {} (reach with map matching {:.0} m at \
                 {v:.0} km/h{})",
                    w.stretch_m / 1000.0,
                    if w.at_start {
                        "from a chain's start"
                    } else {
                        "of a chain not yet calibrated"
                    },
                    turn_words(v),
                    class_early
                        .get(&speed_key(v / 3.6))
                        .or(class_reach.get(&speed_key(v / 3.6)))
                        .copied()
                        .unwrap_or(reach_m),
                    if two_levels {
                        " before calibration"
                    } else {
                        ""
                    }
                ),
                Some(w) if mm => {
                    format!(
                "{tunnel}{:.1} km without {} (reach with map matching {:.0} m at {v:.0} km/h)",
                w.stretch_m / 1000.0,
                turn_words(v),
                class_reach.get(&speed_key(v / 3.6)).copied().unwrap_or(reach_m)
            )
                }
                Some(_) => format!(
                "{tunnel}no map matching: every {:.0} m of driving at {v:.0} km/h needs {} read(s)",
                class_reach.get(&speed_key(v / 3.6)).copied().unwrap_or(reach_m),
                k + 1
            ),
                None => "kept by the multicover".to_string(),
            }
        };
    let (tags, total_cost) = tags_of(scn, settings, net, &built, &sel, height_m, reason);
    // Coverage per directed edge: the sampled chains', the chain
    // beginnings' before calibration, then the straight walks' (the windows
    // the tags were chosen for), without the tags and with them read.
    let t = Instant::now();
    let mut coverage = edge_budgets(&tp.chains, &sel, physical);
    add_early_budgets(&mut coverage, &tp.early, &sel);
    let (walks_without, walks_with, walk_stops) =
        walk_budgets(&model, &tp.straight, &tp.used, &sel, WALK_BUDGET_CAP);
    add_walk_budgets(&mut coverage, &walks_with, &walks_without);
    timings.insert("coverage".into(), t.elapsed().as_secs_f64() * 1e3);
    for c in &mut coverage {
        let e = c.edge as usize;
        let v = built.edge_speed[e];
        let r = class_reach.get(&speed_key(v)).copied().unwrap_or(reach_m);
        let prof = profiles
            .get(&speed_key(v))
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        c.speed_kmh = v * 3.6;
        if c.budget_from.is_some() {
            // A budget of 1 reads as the requirement (`budget_bound`).
            c.bound_with_tags_m = budget_bound(prof, c.budget_with_tags, r, req);
            c.bound_without_tags_m = budget_bound(prof, c.budget_without_tags, r, req);
        }
        let (sec, fwd) = built.edge_dir[e];
        c.section = sec;
        c.forward = fwd;
        let a = &net.roads[net.sections[sec as usize].road as usize].attributes;
        let par = parallel_words(e);
        let tunnel = if a.tunnel {
            format!("tunnel; {par}")
        } else {
            par
        };
        let walk = c.budget_from == Some(BudgetSource::StraightWalk);
        // A walk stops once its budget passes the cap: more is possible.
        let up_to = if walk && c.budget_without_tags >= WALK_BUDGET_CAP {
            "over "
        } else {
            "up to "
        };
        let early = class_early
            .get(&speed_key(v))
            .copied()
            .filter(|_| two_levels);
        c.reason = if c.budget_from.is_none() {
            "no sampled chain, chain beginning or straight walk drives here".into()
        } else if c.budget_without_tags <= 1.0 {
            if mm {
                "turns and map matching hold the requirement without tags".into()
            } else {
                "short enough from any start without tags".into()
            }
        } else if mm && c.budget_from == Some(BudgetSource::ChainBeginning) {
            // Budgeted at the early reach until the calibration point: the
            // budget in metres at that reach (a stretch that runs on past
            // the point drove more, at the calibrated reach).
            let e = early.unwrap_or(r);
            format!(
                "{tunnel}up to {:.0} m driven without {} on the early stretch of a chain \
                 not yet calibrated (counted at the reach before calibration, {e:.0} m at \
                 {:.0} km/h; {r:.0} m once calibrated)",
                c.budget_without_tags * e,
                turn_words(v * 3.6),
                v * 3.6
            )
        } else if mm {
            format!(
                "{tunnel}{}{:.0} m driven without {}{} (reach {r:.0} m at {:.0} km/h{})",
                up_to,
                c.budget_without_tags * r,
                turn_words(v * 3.6),
                if walk {
                    " on a straight walk of the network"
                } else {
                    ""
                },
                v * 3.6,
                match early {
                    Some(e) => format!(" once calibrated, {e:.0} m before"),
                    _ => String::new(),
                }
            )
        } else {
            format!(
                "{tunnel}{}{:.0} m driven without a read{} (reach {r:.0} m at {:.0} km/h, no map matching)",
                up_to,
                c.budget_without_tags * r,
                if walk { " on a straight walk of the traffic's transitions" } else { "" },
                v * 3.6
            )
        };
    }
    let max_cost = settings
        .mountings
        .iter()
        .map(|o| o.cost)
        .fold(0.0, f64::max);
    let min_cost = settings
        .mountings
        .iter()
        .map(|o| o.cost)
        .fold(f64::INFINITY, f64::min);
    let existing_kept = tags.iter().filter(|t| t.existing).count();
    let g = tp.guarantee.clone();
    let (steady, start) = if mm {
        (
            matched
                .iter()
                .map(|c| c.tag_reach_m)
                .fold(f64::INFINITY, f64::min),
            matched
                .iter()
                .map(|c| c.start_reach_m)
                .fold(f64::INFINITY, f64::min),
        )
    } else {
        (
            reach_classes
                .iter()
                .map(|c| c.steady_reach_m)
                .fold(f64::INFINITY, f64::min),
            reach_classes
                .iter()
                .map(|c| c.start_reach_m)
                .fold(f64::INFINITY, f64::min),
        )
    };
    let _ = max_cost;
    Ok(NetworkPlan {
        scenario: scn.name().to_string(),
        coverage: "network".into(),
        requirement_m: req,
        tolerate_missed_reads: k,
        method: trips_method(
            &tp,
            &g,
            mm,
            p.planning_chains + g.added_chains,
            k,
            walk_stops,
        ),
        lower_bound: tp.lower_bound,
        lower_bound_cost: (tp.lower_bound as f64 * if min_cost.is_finite() { min_cost } else { 0.0 })
            .max(tp.lp.cost_bound),
        reach_m,
        steady_reach_m: steady,
        start_reach_m: start,
        reach_classes,
        directed_edges: physical,
        u_turns: "trip_ends".into(),
        directed_length_km: built.directed_length_m / 1000.0,
        candidates: prob.sites.len(),
        candidate_spacing_m: spacing,
        existing_kept,
        existing_off_network: built.existing_off,
        tags,
        total_cost,
        verified: g.holds,
        longest_walk_budget: g.worst_chain_budget,
        budget_reference_m: r_ref,
        reach_levels: if two_levels { 2 } else { 1 },
        timings_ms: timings,
        validation: None,
        traffic: "trips".into(),
        map_matching: mm,
        vehicle_speed_kmh: p.vehicle_speed_mps * 3.6,
        requirement_confidence: conf,
        rule: format!(
            "the horizontal error within {req} m with probability {conf} (the bound is the circle \
             holding the 2-D covariance's {conf} ellipse), on every sampled chain of trips, with {k} \
             consecutive missed read(s) tolerated; {}",
            g.statement
        ),
        route_ignored,
        matched_reach: matched,
        guarantee: Some(g),
        windows: tp.window_sets.len(),
        window_ids: tp.window_sets.total_ids(),
        planning_km: tp.planning_km,
        planning_windows: tp.window_sets,
        design_walks: Vec::new(),
        edge_coverage: coverage,
        chain_model: Some(std::sync::Arc::new(super::traffic::ChainModel { model, dest })),
        selected: sel,
        problem: Some(built.problem),
    })
}
