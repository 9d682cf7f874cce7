//! The uniform-spacing baseline a plan is compared with: tags every
//! multiple of the candidate spacing, held to the plan's own standard.

use super::budget::Budget;
use super::plan::{Plan, UniformBaseline, Validation};
use super::settings::PlannerSettings;
use super::validation::{robust, validation_of};
use crate::error::Result;
use crate::scenario::{RouteKind, Scenario};
use crate::sim::tags::{Mounting, Tag};
use crate::sim::{simulate_with, TruthSource};

/// Tags every `spacing_m` along the truth route (from `spacing_m` on), with
/// the preferred mounting allowed off tunnels, numbered `U0001`… around the
/// ids already taken (installed tags, `[[tag]]`s), which the baseline's
/// validation simulates beside them.
pub fn uniform_tags(
    truth: &TruthSource,
    scn: &Scenario,
    settings: &PlannerSettings,
    spacing_m: f64,
) -> Vec<Tag> {
    let m = settings
        .mountings
        .iter()
        .find(|o| !o.tunnel_only)
        .map_or(Mounting::RoadSurface, |o| o.mounting);
    let cap = scn.duration_cap_s() + 0.5 * scn.dt;
    let mut sites = UniformSites::new(spacing_m);
    let mut ids = super::settings::NewTagIds::new("U", 4, scn, settings);
    let mut tags = Vec::new();
    for a in truth.samples().take_while(|a| a.t <= cap) {
        if sites.take(a.distance_m) {
            tags.push(Tag {
                id: ids.next_id(),
                lat: a.state.lat,
                lon: a.state.lon,
                height_m: Some(a.state.h),
                mounting: m,
                survey_error_m: [0.0, 0.0],
                lane_width_m: None,
            });
        }
    }
    // The last sample is the route's end: no tag exactly there.
    tags
}

/// Picks the samples of a uniform layout: the first sample at or past each
/// multiple of the spacing (one per sample), as distances come in order.
struct UniformSites {
    spacing_m: f64,
    next_m: f64,
    last_m: f64,
}

impl UniformSites {
    fn new(spacing_m: f64) -> Self {
        Self {
            spacing_m,
            next_m: spacing_m,
            last_m: f64::NEG_INFINITY,
        }
    }

    /// Whether the sample at distance `d` gets a tag.
    fn take(&mut self, d: f64) -> bool {
        if d >= self.next_m && d > self.last_m {
            self.last_m = d;
            self.next_m += self.spacing_m;
            true
        } else {
            false
        }
    }
}

/// Finds the uniform baseline by bisection over multiples of the candidate
/// spacing (assuming a longer spacing never does better), held to the same
/// standard as a plan: the covariance analysis keeps the predicted 95 %
/// bound within the requirement with every tag read and with any
/// `tolerate_missed_reads` consecutive tags missed, and the Monte Carlo
/// validation keeps at least `min_fraction` of distance within it. The
/// bisection runs on the covariance check (a few filter passes); the Monte
/// Carlo validates only the longest spacing passing it, and shorter ones,
/// again by bisection, only should that one fail: one validation in the
/// usual case, where every spacing the search crossed used to be simulated.
pub fn uniform_baseline(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
    runs: u64,
    seed: u64,
    min_fraction: f64,
) -> Result<Option<UniformBaseline>> {
    let step = settings.candidate_spacing_m;
    let length = truth.samples().last().map_or(0.0, |a| a.distance_m);
    let req = settings.requirement_m;
    let k = settings.tolerate_missed_reads;
    // The truth's network (loaded once with the truth).
    let net = match &scn.route {
        RouteKind::Map { .. } => truth.network().map(|n| &**n),
        _ => None,
    };
    let budget = Budget::new(scn, truth, net);
    let mut tried: Vec<(f64, f64)> = Vec::new();
    // The covariance check of tags every `n` candidate spacings (a few
    // filter passes' work at most).
    let covariance_ok = |n: u64, tried: &mut Vec<(f64, f64)>| -> bool {
        let spacing = n as f64 * step;
        let tags = uniform_tags(truth, scn, settings, spacing);
        // The same sites as samples (the budget's samples are the truth's,
        // capped alike) for the covariance check.
        let mut sites = UniformSites::new(spacing);
        let fixes: Vec<(usize, Mounting)> = budget
            .samples()
            .iter()
            .enumerate()
            .filter(|(_, sm)| sites.take(sm.avp.distance_m))
            .zip(&tags)
            .map(|((i, _), t)| (i, t.mounting))
            .collect();
        let ok = robust(&budget, &fixes, k, req, step);
        tried.push((spacing, f64::NAN));
        ok
    };
    // The Monte Carlo validation of tags every `n` candidate spacings:
    // whether it keeps `min_fraction` of distance within the requirement,
    // the validation, and the tag count.
    let validate = |n: u64, tried: &mut Vec<(f64, f64)>| -> Result<(bool, Validation, usize)> {
        let spacing = n as f64 * step;
        let tags = uniform_tags(truth, scn, settings, spacing);
        let p = Plan {
            scenario: scn.name().to_string(),
            requirement_m: req,
            tolerate_missed_reads: k,
            method: "uniform".into(),
            lower_bound: 0,
            optimal: false,
            existing_off_route: 0,
            route_length_m: length,
            candidates: 0,
            start_reach_m: 0.0,
            tags: vec![],
            total_cost: 0.0,
            max_gap_m: 0.0,
            predicted_max_bound95_m: 0.0,
            predicted_max_bound95_missed_m: None,
            profile_without_tags: vec![],
            profile_with_tags: vec![],
            validation: None,
            uniform_baseline: None,
            filter_passes: 0.0,
        };
        let res = simulate_with(scn, truth, &tags, runs.max(1), seed, None)?;
        let v = validation_of(
            &res,
            &p,
            runs.max(1),
            seed,
            scn.planner().requirement_confidence,
        );
        match tried.iter_mut().find(|t| t.0 == spacing) {
            Some(t) => t.1 = v.fraction_within_requirement,
            None => tried.push((spacing, v.fraction_within_requirement)),
        }
        Ok((v.fraction_within_requirement >= min_fraction, v, tags.len()))
    };
    let hi_n = ((length / step).ceil() as u64).max(1);
    // The longest spacing that passes the covariance check, by bisection
    // (the cheap test first; the smallest spacing must pass, else there is
    // no baseline).
    if !covariance_ok(1, &mut tried) {
        return Ok(None);
    }
    let (mut lo, mut hi) = (1u64, hi_n + 1);
    // Invariant: lo passes; hi does not (or is beyond the route).
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if covariance_ok(mid, &mut tried) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // Its Monte Carlo validation: usually the only one the search runs.
    // Should it keep too little distance within the requirement, the
    // longest shorter spacing that does, by bisection over the Monte Carlo
    // alone (shorter spacings pass the covariance check: a longer spacing
    // never does better).
    let (ok, v, c) = validate(lo, &mut tried)?;
    let (mut best_v, mut best_c) = (ok.then_some(v), c);
    if best_v.is_none() {
        let (mut good, mut bad) = (0u64, lo);
        // Invariant: `good` passes (0: none found yet); `bad` does not.
        while bad - good > 1 {
            let mid = good + (bad - good) / 2;
            let (ok, v, c) = validate(mid, &mut tried)?;
            if ok {
                good = mid;
                best_v = Some(v);
                best_c = c;
            } else {
                bad = mid;
            }
        }
        if good == 0 {
            return Ok(None);
        }
        lo = good;
    }
    tried.sort_by(|a, b| a.0.total_cmp(&b.0));
    tracing::info!(
        spacings_tried = tried.len(),
        filter_passes = budget.passes(),
        "uniform baseline searched"
    );
    Ok(best_v.map(|validation| UniformBaseline {
        spacing_m: lo as f64 * step,
        tag_count: best_c,
        min_fraction,
        tolerate_missed_reads: k,
        validation,
        tried,
        filter_passes: budget.passes(),
    }))
}
