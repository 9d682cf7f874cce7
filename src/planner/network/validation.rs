//! Monte Carlo validation of a network plan by the simulator, on chains of
//! trips sampled independently of the planning sample (their own random
//! stream): `validation_chains` chains (default 20) of one hour of driving
//! (or the shift, when shorter), the runs shared between them, each run
//! with the planned tags of the directions its chain drives, read with the
//! scenario's read probability, and the scenario's map errors (a fresh map
//! error field per run when map matching is on), over the terrain of the
//! scenario's elevation model when it has one (tags then carry its heights:
//! the plan command assigns them before validating).
//!
//! # The rule (what "within the requirement" means)
//!
//! The plan's bound is the horizontal radius holding with probability
//! `requirement_confidence` (p). The validation tests the same statistic:
//! the share of run time with the horizontal error within the requirement.
//! Consecutive 1 Hz errors are strongly correlated, so the share is
//! estimated from samples thinned to one every [`THINNING_S`] per run
//! (errors decorrelate over the minutes between turns and tags; thinning
//! keeps the binomial interval honest rather than narrow), and the plan
//! passes when the one-sided 95 % Clopper–Pearson lower bound of that
//! share is at least p. Each run's maximum and the number of runs whose
//! maximum exceeds the requirement are reported beside it.

use super::settings::map_route;
use super::trips::{clopper_pearson_lower, sample_chains};
use super::types::{DesignWalkValidation, NetworkPlan, NetworkValidation};
use crate::elevation::Dem;
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::route::{plan_route_points, route_from_pieces};
use crate::scenario::Scenario;
use crate::sim::{simulate_with, TruthSource};
use crate::trajectory::{route_heights, RoutePlan, SpeedProfile};
use std::collections::HashSet;

/// One error sample per run every this many seconds for the share's
/// confidence interval (s).
pub const THINNING_S: f64 = 30.0;

/// The validation's rule on thinned samples (`within` of `n` within
/// `req` m): the one-sided 95 % Clopper–Pearson lower bound of the share
/// within, whether it reaches `conf`, and the rule in words with its
/// figures. Route and area plans state the same rule. The words end as
/// the report's verdict does: "passed" (green), "not shown" when the
/// observed share reaches `conf` but the samples are too few for the bound
/// to (amber: run more), "FAILED" when the observed share itself falls
/// short (red); `passed` is true only in the first case.
///
/// ```
/// use waymark::planner::network::share_rule;
/// // 60 of 60 within: the bound 0.05^(1/60) = 0.9513 reaches 0.95.
/// let (lower, passed, rule) = share_rule(60, 60, 20.0, 0.95);
/// assert!(passed && (lower - 0.05f64.powf(1.0 / 60.0)).abs() < 1e-9 && rule.ends_with("passed"));
/// // 30 of 30: every sample within, but the bound is 0.9049.
/// let (_, passed, rule) = share_rule(30, 30, 20.0, 0.95);
/// assert!(!passed && rule.contains("not shown"));
/// // 900 of 1000: the observed share is below 0.95.
/// let (_, passed, rule) = share_rule(900, 1000, 20.0, 0.95);
/// assert!(!passed && rule.ends_with("FAILED"));
/// ```
pub fn share_rule(within: usize, n: usize, req: f64, conf: f64) -> (f64, bool, String) {
    let lower = clopper_pearson_lower(within, n, 0.05);
    let passed = lower >= conf;
    let verdict = if passed {
        "passed".to_string()
    } else if n > 0 && within as f64 / n as f64 >= conf {
        format!(
            "not shown: the observed share {:.4} reaches {conf}, but {n} samples are too few \
             to show it with 95 % confidence (run more)",
            within as f64 / n as f64
        )
    } else {
        "FAILED".to_string()
    };
    let rule = format!(
        "share of run time within {req} m (one sample per {THINNING_S:.0} s per run) with its \
         one-sided 95 % Clopper–Pearson lower bound at least {conf}: {within} of {n} samples, \
         lower bound {lower:.4} → {verdict}"
    );
    (lower, passed, rule)
}
/// The scenario's elevation model, if it has one.
fn open_dem(scn: &Scenario) -> Result<Option<Dem>> {
    if scn.elevation.is_empty() {
        Ok(None)
    } else {
        Dem::open(&scn.elevation).map(Some)
    }
}

/// A validation drive along `route`: its plan on the terrain (`[map]
/// elevation`, as a route plan's simulation drives it; level at the map's
/// height without one) and the directed sections it drives (whose tags
/// take part).
fn drive(
    net: &Network,
    route: &crate::route::Route,
    profile: &SpeedProfile,
    height_m: f64,
    dt: f64,
    dem: Option<&Dem>,
) -> Result<(RoutePlan, HashSet<(SectionId, bool)>)> {
    let rp = RoutePlan::new(net, route, profile, &[], height_m, dt)?;
    let rp = match dem {
        Some(d) => rp.with_heights(&route_heights(net, route, d)?),
        None => rp,
    };
    let dirs = route
        .spans
        .iter()
        .map(|s| (s.section.section, s.section.forward))
        .collect();
    Ok((rp, dirs))
}

/// Driving per validation chain (s), unless the shift is shorter.
pub const VALIDATION_CHAIN_S: f64 = 3600.0;

/// Monte Carlo validation over `runs` runs on fresh chains of trips (module
/// doc).
pub fn validate_network_plan(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
) -> Result<NetworkValidation> {
    let (_, _, height_m) = map_route(scn)?;
    let Some(cm) = plan.chain_model.as_ref() else {
        return Err(Error::InvalidParameter(
            "the plan carries no traffic model to validate on".into(),
        ));
    };
    let p = scn.planner();
    let dem = open_dem(scn)?;
    let n_chains = p.validation_chains.min(runs.max(1) as usize).max(1);
    let per_chain = runs.max(1).div_ceil(n_chains as u64);
    let shift = p.shift_s.min(VALIDATION_CHAIN_S);
    let chains = sample_chains(
        net,
        &cm.model,
        &cm.dest,
        shift,
        seed,
        0x7661_6c69_6400,
        n_chains,
    )?;
    let profile = SpeedProfile {
        speed_mps: p.vehicle_speed_mps,
        ..Default::default()
    };
    let req = plan.requirement_m;
    let (mut n_thin, mut n_within_thin) = (0usize, 0usize);
    let (mut within_t, mut total_t) = (0.0, 0.0);
    let mut run_max: Vec<f64> = Vec::new();
    let mut worst = (0.0f64, 0usize, 0u64, 0.0, 0.0, [0.0, 0.0], None);
    let mut hours = 0.0;
    let mut length = 0.0;
    let mut fed = 0u64;
    let mut wrong = 0u64;
    for (ci, chain) in chains.iter().enumerate() {
        let route = plan_route_points(net, &chain.points)?;
        let start = route.vertices.first().map_or([0.0, 0.0], |v| v.lat_lon);
        let located = scn.located_at(start);
        let (rp, dirs) = drive(net, &route, &profile, height_m, scn.dt, dem.as_ref())?;
        let tags = plan.sim_tags(Some(&dirs));
        length += route.length_m;
        let truth = TruthSource::from_route(std::sync::Arc::clone(net), route, rp);
        hours += truth.duration_s() / 3600.0;
        let res = simulate_with(
            &located,
            &truth,
            &tags,
            per_chain,
            seed.wrapping_add(1000 * ci as u64),
            None,
        )?;
        for r in &res.runs {
            if let Some(c) = r.map_feed {
                fed += c.fed;
                wrong += c.wrong_road;
            }
            let mut next_thin = 0.0;
            let mut m = 0.0f64;
            for w in r.rows.windows(2) {
                let dt = (w[1].t_s - w[0].t_s).max(0.0);
                total_t += dt;
                if w[1].horizontal_m <= req {
                    within_t += dt;
                }
            }
            for row in &r.rows {
                if !row.horizontal_m.is_finite() {
                    return Err(Error::scenario(
                        &scn.path,
                        format!(
                            "validation chain {ci}, run {}: the navigation error is not finite \
                             at t = {:.0} s (the solution diverged: check {})",
                            r.run,
                            row.t_s,
                            crate::sim::suspect_sections(scn, scn.navigator().mode)
                        ),
                    ));
                }
                m = m.max(row.horizontal_m);
                if row.t_s >= next_thin {
                    n_thin += 1;
                    if row.horizontal_m <= req {
                        n_within_thin += 1;
                    }
                    next_thin += THINNING_S;
                }
                if row.horizontal_m > worst.0 {
                    worst = (
                        row.horizontal_m,
                        ci,
                        r.run,
                        row.t_s,
                        row.distance_m,
                        [0.0, 0.0],
                        None,
                    );
                }
            }
            run_max.push(m);
        }
        if worst.1 == ci && worst.0 > 0.0 {
            if let (Some(a), Some(route)) = (
                truth.samples().find(|a| a.t >= worst.3 - 0.5 * scn.dt),
                truth.route(),
            ) {
                worst.5 = [a.state.lat.to_degrees(), a.state.lon.to_degrees()];
                let scale = route.length_m
                    / truth
                        .samples()
                        .last()
                        .map_or(1.0, |x| x.distance_m.max(1.0));
                let span = route.span_at(worst.4 * scale);
                worst.6 = Some(net.roads[span.road as usize].attributes.id.clone());
            }
        }
    }
    let conf = p.requirement_confidence;
    let (lower, passed, rule) = share_rule(n_within_thin, n_thin, req, conf);
    let exceeding = run_max.iter().filter(|&&m| m > req).count();
    let mut sorted = run_max.clone();
    sorted.sort_by(f64::total_cmp);
    let median_max = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    Ok(NetworkValidation {
        runs: per_chain * chains.len() as u64,
        paths: chains.len(),
        runs_per_path: per_chain,
        paths_length_km: length / 1000.0,
        chain_hours: hours,
        seed,
        fraction_within_requirement: if total_t > 0.0 {
            within_t / total_t
        } else {
            1.0
        },
        thinned_samples: n_thin,
        thinned_within: n_within_thin,
        share_lower_95: lower,
        requirement_confidence: conf,
        passed,
        runs_exceeding: exceeding,
        median_run_max_m: median_max,
        map_matching_fed: fed,
        map_matching_wrong_road_share: if fed > 0 {
            wrong as f64 / fed as f64
        } else {
            0.0
        },
        rule,
        max_horizontal_error_m: worst.0,
        worst_path: worst.1,
        worst_run: worst.2,
        worst_t_s: worst.3,
        worst_distance_m: worst.4,
        worst_lat: worst.5[0],
        worst_lon: worst.5[1],
        worst_road_id: worst.6,
        design_walks: validate_design_walks(scn, net, plan, runs, seed)?,
    })
}

/// Fewest runs per design walk.
const MIN_RUNS_PER_WALK: u64 = 20;

/// `any_walk` plans: each of the walk DP's worst walks driven from its
/// lead-in, the (at most k) tags on it missed on purpose and every other
/// tag read (read probability 1): the case the plan is designed to. Error
/// samples are taken from the walk's start, one per [`THINNING_S`] and at
/// each run's end (where the walk's budget peaks), and judged by
/// [`share_rule`]. `None` for plans without design walks.
fn validate_design_walks(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
) -> Result<Option<DesignWalkValidation>> {
    if plan.design_walks.is_empty() {
        return Ok(None);
    }
    let (_, _, height_m) = map_route(scn)?;
    let dem = open_dem(scn)?;
    let n = plan.design_walks.len();
    let per_walk = runs.div_ceil(n as u64).max(MIN_RUNS_PER_WALK);
    let profile = SpeedProfile {
        speed_mps: scn.planner().vehicle_speed_mps,
        ..Default::default()
    };
    let req = plan.requirement_m;
    let (mut n_thin, mut n_within) = (0usize, 0usize);
    let mut exceeding = 0usize;
    let mut walk_max = vec![0.0f64; n];
    for (wi, w) in plan.design_walks.iter().enumerate() {
        let route = route_from_pieces(net, &w.pieces)?;
        let mut located = scn.located_at(w.start_lat_lon);
        located.rfid.read_probability = 1.0;
        located.rfid.read_probability_by_mounting = [None; 3];
        let (rp, dirs) = drive(net, &route, &profile, height_m, scn.dt, dem.as_ref())?;
        let tags: Vec<_> = plan
            .sim_tags(Some(&dirs))
            .into_iter()
            .filter(|t| !w.missed_tags.contains(&t.id))
            .collect();
        let truth = TruthSource::from_route(std::sync::Arc::clone(net), route, rp);
        let res = simulate_with(
            &located,
            &truth,
            &tags,
            per_walk,
            seed.wrapping_add(0x7761_6c6b + 1000 * wi as u64),
            None,
        )?;
        for r in &res.runs {
            let mut next = f64::NEG_INFINITY;
            let mut m = 0.0f64;
            let walk_rows: Vec<_> = r
                .rows
                .iter()
                .filter(|row| row.distance_m >= w.lead_in_m)
                .collect();
            for (i, row) in walk_rows.iter().enumerate() {
                if !row.horizontal_m.is_finite() {
                    return Err(Error::InvalidParameter(format!(
                        "design walk {wi}, run {}: the navigation error is not finite at t = {:.0} s",
                        r.run, row.t_s
                    )));
                }
                m = m.max(row.horizontal_m);
                if row.t_s >= next || i + 1 == walk_rows.len() {
                    n_thin += 1;
                    if row.horizontal_m <= req {
                        n_within += 1;
                    }
                    next = row.t_s + THINNING_S;
                }
            }
            if m > req {
                exceeding += 1;
            }
            walk_max[wi] = walk_max[wi].max(m);
        }
    }
    let (lower, passed, rule) =
        share_rule(n_within, n_thin, req, scn.planner().requirement_confidence);
    let (worst_walk, max_err) = walk_max
        .iter()
        .copied()
        .enumerate()
        .fold((0, 0.0), |a, (i, m)| if m > a.1 { (i, m) } else { a });
    Ok(Some(DesignWalkValidation {
        walks: n,
        runs_per_walk: per_walk,
        thinned_samples: n_thin,
        thinned_within: n_within,
        share_lower_95: lower,
        passed,
        rule,
        runs_exceeding: exceeding,
        max_horizontal_error_m: max_err,
        worst_walk,
        walk_max_m: walk_max,
    }))
}
