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
use super::types::{
    DesignWalkValidation, NetworkPlan, NetworkValidation, NoTagsValidation, StretchFigures,
};
use crate::elevation::Dem;
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::route::{plan_route_points, route_from_pieces};
use crate::scenario::Scenario;
use crate::sim::{simulate_with, ErrorRow, TruthSource};
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
pub(super) fn open_dem(scn: &Scenario) -> Result<Option<Dem>> {
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
pub(super) fn drive(
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

/// What driving the validation chains gave: the time and thinned-sample
/// counts within the requirement, each run's maximum, the worst sample and
/// the map feed's counts.
struct ChainOutcome {
    n_thin: usize,
    n_within_thin: usize,
    within_t: f64,
    total_t: f64,
    run_max: Vec<f64>,
    /// Error, chain, run, time, distance along, position, road.
    worst: (f64, usize, u64, f64, f64, [f64; 2], Option<String>),
    hours: f64,
    length_m: f64,
    fed: u64,
    wrong: u64,
    /// Thinned samples where the planner's budget without tags exceeds 1
    /// (its predicted bound beyond the requirement), and of them within.
    over_budget: usize,
    over_budget_within: usize,
    /// Largest error (m) at any 1 Hz row over budget, and the largest
    /// budget met.
    over_budget_max_m: f64,
    max_budget: f64,
}

/// The planner's budget along one chain without tags: consumed since the
/// last reset (a turn map matching observes, the chain's start), as a
/// function of the chainage.
pub(super) struct BudgetProfile {
    /// Chainage (m) and budget at each piece end, the start first.
    c: Vec<f64>,
    b: Vec<f64>,
    /// Resets: chainage (m) and budget, in order.
    reset_c: Vec<f64>,
    reset_b: Vec<f64>,
}

impl BudgetProfile {
    /// The profile along a validation drive's route: its spans as the
    /// planner's pieces (as `traffic::sample_chain` makes them), then the
    /// planner's own budget view of that chain.
    pub(super) fn new(
        model: &super::traffic::EdgeModel,
        route: &crate::route::Route,
        mm: bool,
    ) -> Self {
        let mut chain = super::traffic::Chain {
            points: Vec::new(),
            pieces: Vec::new(),
            length_m: route.length_m,
            duration_s: 0.0,
        };
        // Chainage along the route at each piece's end.
        let mut ends = Vec::new();
        for sp in &route.spans {
            let Some(&e) = model.index.get(&(sp.section.section, sp.section.forward)) else {
                continue;
            };
            let len_e = model.length[e as usize];
            let (a0, a1) = if sp.section.forward {
                (sp.from_offset_m, sp.to_offset_m)
            } else {
                (len_e - sp.from_offset_m, len_e - sp.to_offset_m)
            };
            let (a0, a1) = (a0.clamp(0.0, len_e), a1.clamp(0.0, len_e));
            if a1 - a0 <= 0.0 {
                continue;
            }
            chain.pieces.push(super::traffic::Piece { edge: e, a0, a1 });
            ends.push(sp.end_chainage_m);
        }
        let cb = super::traffic::chain_budget(model, &chain, mm);
        let (mut c, mut b) = (vec![0.0], vec![0.0]);
        for (&x, &(_, _, b1)) in ends.iter().zip(&cb.pieces) {
            c.push(x);
            b.push(b1);
        }
        let reset_b: Vec<f64> = cb.resets.iter().map(|r| r.0).collect();
        let mut out = Self {
            c,
            b,
            reset_c: Vec::new(),
            reset_b,
        };
        // The budget view's own chainage runs over the pieces alone; its
        // resets are placed on the route by their budget position.
        out.reset_c = out
            .reset_b
            .iter()
            .map(|&rb| out.chainage_at_budget(rb))
            .collect();
        out
    }

    /// The first chainage (m) where the budget reaches `rb`.
    fn chainage_at_budget(&self, rb: f64) -> f64 {
        let (b, c) = (&self.b, &self.c);
        let i = b.partition_point(|&v| v < rb);
        if i == 0 {
            0.0
        } else if i >= b.len() {
            c[c.len() - 1]
        } else if b[i] > b[i - 1] {
            c[i - 1] + (rb - b[i - 1]) / (b[i] - b[i - 1]) * (c[i] - c[i - 1])
        } else {
            c[i - 1]
        }
    }

    /// The stretches between two resets whose budget passes 1: (reset,
    /// where the budget reaches 1, the next reset) in chainage (m), and the
    /// budget used at that next reset.
    pub(super) fn over_budget(&self) -> Vec<([f64; 3], f64)> {
        (1..self.reset_b.len())
            .filter(|&j| self.reset_b[j] - self.reset_b[j - 1] > 1.0)
            .map(|j| {
                let over = self.chainage_at_budget(self.reset_b[j - 1] + 1.0);
                (
                    [self.reset_c[j - 1], over, self.reset_c[j]],
                    self.reset_b[j] - self.reset_b[j - 1],
                )
            })
            .collect()
    }

    /// Budget consumed since the last reset at chainage `x` (m).
    pub(super) fn since_reset(&self, x: f64) -> f64 {
        let i = self.c.partition_point(|&v| v <= x);
        let b = if i == 0 {
            0.0
        } else if i >= self.c.len() {
            self.b[self.b.len() - 1]
        } else {
            let (c0, c1) = (self.c[i - 1], self.c[i]);
            let t = if c1 > c0 { (x - c0) / (c1 - c0) } else { 0.0 };
            self.b[i - 1] + t * (self.b[i] - self.b[i - 1])
        };
        let j = self.reset_c.partition_point(|&v| v <= x);
        let r = if j == 0 { 0.0 } else { self.reset_b[j - 1] };
        (b - r).max(0.0)
    }
}

impl ChainOutcome {
    /// Median over runs of each run's maximum error (m).
    fn median_run_max(&self) -> f64 {
        let mut sorted = self.run_max.clone();
        sorted.sort_by(f64::total_cmp);
        sorted.get(sorted.len() / 2).copied().unwrap_or(0.0)
    }

    /// Share of run time within the requirement (1 without any time).
    fn fraction_within(&self) -> f64 {
        if self.total_t > 0.0 {
            self.within_t / self.total_t
        } else {
            1.0
        }
    }

    /// Runs whose maximum exceeds `req`.
    fn exceeding(&self, req: f64) -> usize {
        self.run_max.iter().filter(|&&m| m > req).count()
    }
}

/// Drives every chain `per_chain` times with the plan's tags on the
/// directions it drives (only the installed ones when `existing_only`),
/// the runs of chain `ci` seeded `seed + 1000 ci`.
#[allow(clippy::too_many_arguments)]
fn drive_chains(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    chains: &[super::traffic::Chain],
    per_chain: u64,
    seed: u64,
    existing_only: bool,
) -> Result<ChainOutcome> {
    let (_, _, height_m) = map_route(scn)?;
    let p = scn.planner();
    let dem = open_dem(scn)?;
    let profile = SpeedProfile {
        speed_mps: p.vehicle_speed_mps,
        ..Default::default()
    };
    let req = plan.requirement_m;
    let mut o = ChainOutcome {
        n_thin: 0,
        n_within_thin: 0,
        within_t: 0.0,
        total_t: 0.0,
        run_max: Vec::new(),
        worst: (0.0, 0, 0, 0.0, 0.0, [0.0, 0.0], None),
        hours: 0.0,
        length_m: 0.0,
        fed: 0,
        wrong: 0,
        over_budget: 0,
        over_budget_within: 0,
        over_budget_max_m: 0.0,
        max_budget: 0.0,
    };
    let cm = plan.chain_model.as_ref();
    // The installed tags, which alone are driven with `existing_only`.
    let installed: HashSet<&str> = plan
        .tags
        .iter()
        .filter(|t| t.existing)
        .map(|t| t.tag_id.as_str())
        .collect();
    for (ci, chain) in chains.iter().enumerate() {
        let route = plan_route_points(net, &chain.points)?;
        let start = route.vertices.first().map_or([0.0, 0.0], |v| v.lat_lon);
        let located = scn.located_at(start);
        let (rp, dirs) = drive(net, &route, &profile, height_m, scn.dt, dem.as_ref())?;
        // Without map matching's credit the planner's chains carry no
        // budget between resets (`any_walk` plans its walks instead).
        let profile_b = cm
            .filter(|_| plan.map_matching)
            .map(|cm| BudgetProfile::new(&cm.model, &route, plan.map_matching));
        let mut tags = plan.sim_tags(Some(&dirs));
        if existing_only {
            tags.retain(|t| installed.contains(t.id.as_str()));
        }
        o.length_m += route.length_m;
        let truth = TruthSource::from_route(std::sync::Arc::clone(net), route, rp);
        // Sample distances (along the simulated drive) to the route's chainage.
        let to_chainage = truth.route().map_or(1.0, |r| r.length_m)
            / truth
                .samples()
                .last()
                .map_or(1.0, |x| x.distance_m.max(1.0));
        o.hours += truth.duration_s() / 3600.0;
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
                o.fed += c.fed;
                o.wrong += c.wrong_road;
            }
            let mut next_thin = 0.0;
            let mut m = 0.0f64;
            for w in r.rows.windows(2) {
                let dt = (w[1].t_s - w[0].t_s).max(0.0);
                o.total_t += dt;
                if w[1].horizontal_m <= req {
                    o.within_t += dt;
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
                let u = profile_b
                    .as_ref()
                    .map_or(0.0, |pb| pb.since_reset(row.distance_m * to_chainage));
                o.max_budget = o.max_budget.max(u);
                if u > 1.0 {
                    o.over_budget_max_m = o.over_budget_max_m.max(row.horizontal_m);
                }
                if row.t_s >= next_thin {
                    o.n_thin += 1;
                    if row.horizontal_m <= req {
                        o.n_within_thin += 1;
                    }
                    if u > 1.0 {
                        o.over_budget += 1;
                        if row.horizontal_m <= req {
                            o.over_budget_within += 1;
                        }
                    }
                    next_thin += THINNING_S;
                }
                if row.horizontal_m > o.worst.0 {
                    o.worst = (
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
            o.run_max.push(m);
        }
        if o.worst.1 == ci && o.worst.0 > 0.0 {
            if let (Some(a), Some(route)) = (
                truth.samples().find(|a| a.t >= o.worst.3 - 0.5 * scn.dt),
                truth.route(),
            ) {
                o.worst.5 = [a.state.lat.to_degrees(), a.state.lon.to_degrees()];
                let scale = route.length_m
                    / truth
                        .samples()
                        .last()
                        .map_or(1.0, |x| x.distance_m.max(1.0));
                let span = route.span_at(o.worst.4 * scale);
                o.worst.6 = Some(net.roads[span.road as usize].attributes.id.clone());
            }
        }
    }
    Ok(o)
}

/// [`validate_network_plan`](super::validate_network_plan) but for the
/// stretches driven on their own (`super::stretches`,
/// `super::calibrated_stretches`, which the caller adds).
pub(super) fn validate_chains(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
    baseline: bool,
) -> Result<NetworkValidation> {
    let Some(cm) = plan.chain_model.as_ref() else {
        return Err(Error::InvalidParameter(
            "the plan carries no traffic model to validate on".into(),
        ));
    };
    let p = scn.planner();
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
    let req = plan.requirement_m;
    let conf = p.requirement_confidence;
    let o = drive_chains(scn, net, plan, &chains, per_chain, seed, false)?;

    let (lower, passed, rule) = share_rule(o.n_within_thin, o.n_thin, req, conf);

    let without_new_tags = if baseline {
        let b = drive_chains(scn, net, plan, &chains, per_chain, seed, true)?;

        let (lower, passed, rule) = share_rule(b.n_within_thin, b.n_thin, req, conf);
        Some(NoTagsValidation {
            tags: plan.tags.iter().filter(|t| t.existing).count(),
            fraction_within_requirement: b.fraction_within(),
            thinned_samples: b.n_thin,
            thinned_within: b.n_within_thin,
            share_lower_95: lower,
            passed,
            rule,
            runs_exceeding: b.exceeding(req),
            median_run_max_m: b.median_run_max(),
            over_budget_within: plan.map_matching.then_some(b.over_budget_within),
            over_budget_max_error_m: plan.map_matching.then_some(b.over_budget_max_m),
            max_horizontal_error_m: b.worst.0,
            worst_path: b.worst.1,
            worst_run: b.worst.2,
            worst_t_s: b.worst.3,
            worst_lat: b.worst.5[0],
            worst_lon: b.worst.5[1],
            worst_road_id: b.worst.6.clone(),
            map_matching_wrong_road_share: if b.fed > 0 {
                b.wrong as f64 / b.fed as f64
            } else {
                0.0
            },
        })
    } else {
        None
    };
    Ok(NetworkValidation {
        runs: per_chain * chains.len() as u64,
        paths: chains.len(),
        runs_per_path: per_chain,
        paths_length_km: o.length_m / 1000.0,
        chain_hours: o.hours,
        seed,
        fraction_within_requirement: o.fraction_within(),
        thinned_samples: o.n_thin,
        thinned_within: o.n_within_thin,
        share_lower_95: lower,
        requirement_confidence: conf,
        passed,
        runs_exceeding: o.exceeding(req),
        median_run_max_m: o.median_run_max(),
        map_matching_fed: o.fed,
        map_matching_wrong_road_share: if o.fed > 0 {
            o.wrong as f64 / o.fed as f64
        } else {
            0.0
        },
        rule,
        max_horizontal_error_m: o.worst.0,
        worst_path: o.worst.1,
        worst_run: o.worst.2,
        worst_t_s: o.worst.3,
        worst_distance_m: o.worst.4,
        worst_lat: o.worst.5[0],
        worst_lon: o.worst.5[1],
        worst_road_id: o.worst.6,
        over_budget_samples: plan.map_matching.then_some(o.over_budget),
        over_budget_within: plan.map_matching.then_some(o.over_budget_within),
        over_budget_max_error_m: plan.map_matching.then_some(o.over_budget_max_m),
        max_budget_without_tags: plan.map_matching.then_some(o.max_budget),
        design_walks: validate_design_walks(scn, net, plan, runs, seed)?,
        without_new_tags,
        over_budget_stretches: None,
        credited_stretches: None,
    })
}

/// One run's error samples over `rows`: one per [`THINNING_S`] and the last
/// row (where a walk's or stretch's budget peaks). Returns the samples, of
/// them those within `req`, and the largest error over every row; `Err`
/// with the time (s) of the first row whose error is not finite.
pub(super) fn thin_rows(
    rows: &[&ErrorRow],
    req: f64,
) -> std::result::Result<(usize, usize, f64), f64> {
    let (mut n, mut within, mut m) = (0usize, 0usize, 0.0f64);
    let mut next = f64::NEG_INFINITY;
    for (i, row) in rows.iter().enumerate() {
        if !row.horizontal_m.is_finite() {
            return Err(row.t_s);
        }
        m = m.max(row.horizontal_m);
        if row.t_s >= next || i + 1 == rows.len() {
            n += 1;
            if row.horizontal_m <= req {
                within += 1;
            }
            next = row.t_s + THINNING_S;
        }
    }
    Ok((n, within, m))
}

/// Fewest runs per design walk.
pub(super) const MIN_RUNS_PER_WALK: u64 = 20;

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
            let walk_rows: Vec<_> = r
                .rows
                .iter()
                .filter(|row| row.distance_m >= w.lead_in_m)
                .collect();
            let (n, within, m) = thin_rows(&walk_rows, req).map_err(|t| {
                Error::InvalidParameter(format!(
                    "design walk {wi}, run {}: the navigation error is not finite at t = {t:.0} s",
                    r.run
                ))
            })?;
            n_thin += n;
            n_within += within;
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
        figures: StretchFigures {
            thinned_samples: n_thin,
            thinned_within: n_within,
            share_lower_95: lower,
            passed,
            rule,
            runs_exceeding: exceeding,
            max_horizontal_error_m: max_err,
        },
        worst_walk,
        walk_max_m: walk_max,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A profile from piece ends and reset budgets, resets placed as
    /// `BudgetProfile::new` places them.
    fn profile(c: &[f64], b: &[f64], resets: &[f64]) -> BudgetProfile {
        let mut p = BudgetProfile {
            c: c.to_vec(),
            b: b.to_vec(),
            reset_c: Vec::new(),
            reset_b: resets.to_vec(),
        };
        p.reset_c = resets.iter().map(|&r| p.chainage_at_budget(r)).collect();
        p
    }

    #[test]
    fn budget_since_the_last_reset_and_the_stretches_past_one() {
        // Pieces ending at 100, 300 and 600 m with budgets 0.5, 1.5 and
        // 1.8; resets at the start, at 100 m (budget 0.5) and at the end.
        let p = profile(
            &[0.0, 100.0, 300.0, 600.0],
            &[0.0, 0.5, 1.5, 1.8],
            &[0.0, 0.5, 1.8],
        );
        assert_eq!(p.reset_c, vec![0.0, 100.0, 600.0]);
        // Linear within a piece, measured from the last reset at or before x.
        assert!((p.since_reset(50.0) - 0.25).abs() < 1e-12);
        assert!((p.since_reset(100.0) - 0.0).abs() < 1e-12);
        assert!((p.since_reset(200.0) - 0.5).abs() < 1e-12);
        assert!((p.since_reset(450.0) - 1.15).abs() < 1e-12);
        // Past the end the budget holds its last value (then the end's
        // own reset clears it).
        assert!((p.since_reset(599.0) - (1.8 - 0.001 - 0.5)).abs() < 1e-9);
        // One stretch passes 1: from the reset at 100 m, over budget from
        // 300 m (budget 1.5 = 0.5 + 1), to the next reset at 600 m, peak 1.3.
        let s = p.over_budget();
        assert_eq!(s.len(), 1);
        let ([r, o, e], u) = s[0];
        assert_eq!((r, e), (100.0, 600.0));
        assert!(
            (o - 300.0).abs() < 1e-9 && (u - 1.3).abs() < 1e-12,
            "{o} {u}"
        );
    }

    #[test]
    fn a_flat_budget_maps_to_the_first_chainage_reaching_it() {
        // A piece of rate 0 (100 to 200 m): budget 0.4 is reached at 100 m.
        let p = profile(
            &[0.0, 100.0, 200.0, 400.0],
            &[0.0, 0.4, 0.4, 1.6],
            &[0.0, 1.6],
        );
        assert_eq!(p.chainage_at_budget(0.4), 100.0);
        assert!((p.chainage_at_budget(1.0) - 300.0).abs() < 1e-9);
        // Below the start and past the end: clamped.
        assert_eq!(p.chainage_at_budget(-1.0), 0.0);
        assert_eq!(p.chainage_at_budget(9.0), 400.0);
        let s = p.over_budget();
        assert_eq!(s.len(), 1);
        assert!((s[0].0[1] - 300.0).abs() < 1e-9);
    }
}
