//! The tag planner: candidate sites along a scenario's route → error budget
//! by covariance analysis of the navigation filter ([`budget`]) → the fewest
//! tags that hold the requirement with `k` missed reads tolerated
//! ([`placement`], exact on one route) → validation by Monte Carlo
//! simulation with the planned tags → export records.

pub mod budget;
pub mod forward;
pub mod network;
pub mod network_cover;
pub mod network_ilp;
pub mod placement;

use crate::error::{Error, Result};
use crate::export::{ExportMetadata, TagRecord};
use crate::network::Network;
use crate::network::RoadAttributes;
pub use crate::scenario::Coverage;
use crate::scenario::{NavMode, RouteKind, Scenario};
use crate::sim::run::{simulate_with, TruthSource};
use crate::sim::tags::{Mounting, RfidModel, Tag};
use crate::tags::TagPayload;
use budget::{bound95, Budget, BudgetPoint, CHI2_2_95};
use placement::{place_with, Candidate, Placement};
use serde::Serialize;
use std::collections::BTreeMap;

/// Default read probability of a tag (the RFID paper's field test).
pub const DEFAULT_READ_PROBABILITY: f64 = 0.977;

/// Lane width (m) of a road from its OSM attributes: `width / lanes` when
/// both are given (a carriageway width over its lanes), else a default by
/// road class.
pub fn lane_width_m(a: &RoadAttributes) -> f64 {
    if let (Some(w), Some(n)) = (a.width_m, a.lanes) {
        if n > 0 && w > 0.0 {
            return (w / f64::from(n)).clamp(2.5, 5.0);
        }
    }
    if let (Some(w), None) = (a.width_m, a.lanes) {
        // A two-way road's width holds two lanes, a one-way road's one.
        let n = if a.oneway.is_oneway() { 1.0 } else { 2.0 };
        return (w / n).clamp(2.5, 5.0);
    }
    match a.highway.trim_end_matches("_link") {
        "motorway" | "trunk" => 3.75,
        "primary" | "secondary" => 3.5,
        "tertiary" | "unclassified" => 3.25,
        _ => 3.0,
    }
}

/// Speed (m/s) at a site: the truth's speed when moving, else the road's
/// `maxspeed`, else 30 km/h.
pub fn site_speed_mps(truth_speed: f64, road: Option<&RoadAttributes>) -> f64 {
    if truth_speed > 0.5 {
        truth_speed
    } else {
        road.and_then(|a| a.maxspeed_kmh).unwrap_or(30.0) / 3.6
    }
}

/// What a mounting costs, how often it is read and where it may go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MountingOption {
    /// The mounting.
    pub mounting: Mounting,
    /// Installed cost of one tag (arbitrary units).
    pub cost: f64,
    /// Probability that a pass is read.
    pub read_probability: f64,
    /// Only inside tunnels (ceiling readers).
    pub tunnel_only: bool,
}

impl MountingOption {
    /// Defaults: road surface cost 1, roadside 1, ceiling 3 (a reader in the
    /// roof is expensive) and tunnels only; read probability 0.977.
    pub fn default_for(m: Mounting) -> Self {
        Self {
            mounting: m,
            cost: crate::scenario::default_mounting_cost(m),
            read_probability: DEFAULT_READ_PROBABILITY,
            tunnel_only: m == Mounting::Ceiling,
        }
    }

    /// Whether this mounting may go on a road (tunnel or not).
    pub fn allowed_on(&self, tunnel: bool) -> bool {
        !self.tunnel_only || tunnel
    }
}

/// The 95 % horizontal bound (m) of a fix of a mounting at speed `v`.
pub fn fix_bound95(rfid: &RfidModel, m: Mounting, v: f64) -> f64 {
    let (a, c) = rfid.fix_sigmas(m, v);
    (CHI2_2_95 * a.max(c).powi(2)).sqrt()
}

/// Planner settings, from the scenario's `[planner]` with defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannerSettings {
    /// What the plan covers.
    pub coverage: Coverage,
    /// Horizontal requirement (m).
    pub requirement_m: f64,
    /// Consecutive missed reads tolerated.
    pub tolerate_missed_reads: usize,
    /// Allowed mountings, in preference order.
    pub mountings: Vec<MountingOption>,
    /// Candidate spacing (m).
    pub candidate_spacing_m: f64,
    /// Smallest spacing between tags (m).
    pub min_spacing_m: f64,
    /// Forbidden stretches of route distance (m).
    pub forbidden_m: Vec<[f64; 2]>,
    /// Monte Carlo validation runs.
    pub validation_runs: u64,
    /// Refinements of the reaches from the planned filter (0 = none).
    pub refine_iterations: usize,
    /// Tags already installed (`existing_tags`), kept in every plan.
    pub existing_tags: Vec<Tag>,
}

impl PlannerSettings {
    /// The scenario's planner settings (validated with the scenario); checks
    /// that the scenario can be planned and reads its existing tags.
    pub fn from_scenario(scn: &Scenario) -> Result<Self> {
        let bad = |m: String| Error::scenario(&scn.path, m);
        let requirement_m = scn
            .requirement_m()
            .ok_or_else(|| bad("planning needs requirement_m".into()))?;
        if !(requirement_m.is_finite() && requirement_m > 0.0) {
            return Err(bad(format!(
                "requirement_m = {requirement_m} must be positive"
            )));
        }
        if scn.navigator().mode != NavMode::Integrated {
            return Err(bad(
                "planning needs navigator.mode = \"integrated\" (the filter whose covariance is the budget)"
                    .into(),
            ));
        }
        if !scn.aiding().rfid {
            return Err(bad("planning needs aiding.rfid = true".into()));
        }
        let p = scn.planner();
        let mut mountings = Vec::new();
        for c in &p.mountings {
            let mut o = MountingOption::default_for(c.mounting);
            o.read_probability = scn.rfid.read_probability_of(c.mounting);
            o.cost = c.cost;
            mountings.push(o);
        }
        // Preference: cheapest, then most accurate.
        mountings.sort_by(|a, b| {
            a.cost.total_cmp(&b.cost).then(
                fix_bound95(&scn.rfid, a.mounting, 10.0)
                    .total_cmp(&fix_bound95(&scn.rfid, b.mounting, 10.0)),
            )
        });
        let existing_tags = match &p.existing_tags {
            Some(f) => crate::sim::tags::load_tags_csv(f)?,
            None => vec![],
        };
        Ok(Self {
            coverage: p.coverage,
            requirement_m,
            tolerate_missed_reads: p.tolerate_missed_reads,
            mountings,
            candidate_spacing_m: p.candidate_spacing_m,
            min_spacing_m: p.min_spacing_m,
            forbidden_m: p.forbidden_m.clone(),
            validation_runs: p.validation_runs,
            refine_iterations: p.refine_iterations,
            existing_tags,
        })
    }
}

impl PlannerSettings {
    /// An error when the requirement is below the best fix any allowed
    /// mounting can give (its 95 % bound at 10 m/s).
    pub fn check_best_fix(&self, rfid: &RfidModel) -> Result<()> {
        let req = self.requirement_m;
        let best_fix = self
            .mountings
            .iter()
            .map(|o| fix_bound95(rfid, o.mounting, 10.0))
            .fold(f64::INFINITY, f64::min);
        if best_fix >= req {
            return Err(Error::InvalidParameter(format!(
                "requirement_m = {req} m is below the best possible tag fix (95 % bound {best_fix:.2} m with {})",
                self.mountings
                    .iter()
                    .map(|o| o.mounting.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        Ok(())
    }
}

/// One planned tag.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlannedTag {
    /// Identifier.
    pub tag_id: String,
    /// Latitude, longitude (degrees).
    pub lat: f64,
    /// Longitude (degrees).
    pub lon: f64,
    /// Height (m).
    pub height_m: f64,
    /// Distance along the route (m).
    pub route_distance_m: f64,
    /// Chainage along the road `road_id` in its digitised direction (m),
    /// when on a map.
    pub road_chainage_m: Option<f64>,
    /// Time the vehicle passes (s).
    pub t_s: f64,
    /// Mounting.
    #[serde(serialize_with = "ser_mounting")]
    pub mounting: Mounting,
    /// Expected 1σ fix error (larger axis, m).
    pub expected_fix_sigma_m: f64,
    /// Road input id, when the route is on a map.
    pub road_id: Option<String>,
    /// Already installed (from `existing_tags`), not a new tag.
    pub existing: bool,
    /// Whether the site is in a tunnel.
    pub tunnel: bool,
    /// Lane width at the site (m; from the road's OSM `width`/`lanes` or
    /// its class), when on a map.
    pub lane_width_m: Option<f64>,
    /// Whether the vehicle drives in the road's digitised direction there.
    pub digitised_forward: Option<bool>,
    /// Predicted 95 % bound just after the fix (m).
    pub bound_after_fix_m: f64,
    /// Route distance up to which the bound holds after this fix (m).
    pub reach_m: f64,
}

fn ser_mounting<S: serde::Serializer>(m: &Mounting, s: S) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(m.as_str())
}

/// Monte Carlo validation of a plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    /// Runs.
    pub runs: u64,
    /// Base seed.
    pub seed: u64,
    /// Fraction of distance (over all runs) within the requirement.
    pub fraction_within_requirement: f64,
    /// Largest horizontal error over all runs (m).
    pub max_horizontal_error_m: f64,
    /// Where it happened: run, time (s), route distance (m).
    pub worst_run: u64,
    /// Time of the worst point (s).
    pub worst_t_s: f64,
    /// Route distance of the worst point (m).
    pub worst_distance_m: f64,
}

/// A plan for one route.
#[derive(Debug, Clone, Serialize)]
pub struct Plan {
    /// Scenario name.
    pub scenario: String,
    /// Requirement (m).
    pub requirement_m: f64,
    /// Consecutive missed reads tolerated.
    pub tolerate_missed_reads: usize,
    /// Placement method.
    pub method: String,
    /// Lower bound on the number of new tags: exact placement on the most
    /// optimistic reaches (each site's filter having read a tag at every
    /// earlier candidate).
    pub lower_bound: usize,
    /// Whether the plan's new-tag count equals the lower bound (proven
    /// minimal for these candidate sites and mountings).
    pub optimal: bool,
    /// Installed tags (`existing_tags`) more than 15 m from the route, ignored.
    pub existing_off_route: usize,
    /// Route length (m).
    pub route_length_m: f64,
    /// Candidate sites considered.
    pub candidates: usize,
    /// Distance the bound holds from the start without tags (m).
    pub start_reach_m: f64,
    /// The tags, in route order.
    pub tags: Vec<PlannedTag>,
    /// Total cost.
    pub total_cost: f64,
    /// Largest distance between consecutive tags, start and end included (m).
    pub max_gap_m: f64,
    /// Largest predicted 95 % bound along the route with every tag read (m).
    pub predicted_max_bound95_m: f64,
    /// Predicted bound profile without tags (distance, bound).
    #[serde(skip)]
    pub profile_without_tags: Vec<BudgetPoint>,
    /// Predicted bound profile with the plan (all read).
    #[serde(skip)]
    pub profile_with_tags: Vec<BudgetPoint>,
    /// Monte Carlo validation, when run.
    pub validation: Option<Validation>,
    /// The uniform-spacing baseline, when computed.
    pub uniform_baseline: Option<UniformBaseline>,
}

/// Tags at a uniform spacing along the route: the largest spacing (a
/// multiple of the candidate spacing) that passes the plan's own covariance
/// check (any `k` consecutive tags missed) and whose Monte Carlo validation
/// keeps at least `min_fraction` of distance within the requirement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UniformBaseline {
    /// Spacing (m).
    pub spacing_m: f64,
    /// Tags at that spacing.
    pub tag_count: usize,
    /// Fraction of distance within the requirement asked for.
    pub min_fraction: f64,
    /// Consecutive missed tags the covariance check tolerated (as the plan).
    pub tolerate_missed_reads: usize,
    /// Its validation.
    pub validation: Validation,
    /// Spacings tried (m) and their fractions within the requirement (NaN:
    /// failed the covariance check, not simulated).
    pub tried: Vec<(f64, f64)>,
}

impl Plan {
    /// New tags to install (installed ones not counted).
    pub fn tag_count(&self) -> usize {
        self.tags.iter().filter(|t| !t.existing).count()
    }

    /// Installed tags kept in the plan.
    pub fn existing_count(&self) -> usize {
        self.tags.len() - self.tag_count()
    }

    /// Tags by mounting.
    pub fn by_mounting(&self) -> BTreeMap<String, usize> {
        let mut m = BTreeMap::new();
        for t in self.tags.iter().filter(|t| !t.existing) {
            *m.entry(t.mounting.as_str().to_string()).or_insert(0) += 1;
        }
        m
    }

    /// The tags as the simulator takes them.
    pub fn sim_tags(&self) -> Vec<Tag> {
        self.tags
            .iter()
            .map(|t| Tag {
                id: t.tag_id.clone(),
                lat: t.lat.to_radians(),
                lon: t.lon.to_radians(),
                height_m: Some(t.height_m),
                mounting: t.mounting,
                survey_error_m: [0.0, 0.0],
                lane_width_m: t.lane_width_m,
            })
            .collect()
    }

    /// Export records (with payloads) and metadata.
    pub fn export(&self, scn: &Scenario) -> Result<(Vec<TagRecord>, ExportMetadata)> {
        let mut recs = Vec::with_capacity(self.tags.len());
        for (i, t) in self.tags.iter().enumerate().filter(|(_, t)| !t.existing) {
            let payload = TagPayload {
                lat_deg: t.lat,
                lon_deg: t.lon,
                height_m: t.height_m,
                mounting: t.mounting,
            }
            .to_hex()?;
            recs.push(TagRecord {
                tag_id: t.tag_id.clone(),
                lat: t.lat,
                lon: t.lon,
                height_m: t.height_m,
                road_id: t.road_id.clone(),
                // Along the road where there is one (what installers
                // measure), else along the route.
                chainage_m: Some(t.road_chainage_m.unwrap_or(t.route_distance_m)),
                // Roadside readers look right (right-hand traffic): the
                // post is on the right of travel, i.e. left of the road's
                // digitised direction when driving against it.
                side: Some(
                    match (t.mounting, t.digitised_forward) {
                        (Mounting::Roadside, Some(false)) => "left",
                        (Mounting::Roadside, _) => "right",
                        _ => "centre",
                    }
                    .to_string(),
                ),
                // Roadside tags stand x to the right of the lane centre
                // (their stored point is the lane centre abeam).
                lateral_offset_m: Some(match t.mounting {
                    Mounting::Roadside => scn.rfid.roadside_distance_m,
                    _ => 0.0,
                }),
                mounting: t.mounting,
                expected_fix_sigma_m: Some(t.expected_fix_sigma_m),
                // Tags within one window of k+1 consecutive tags back each other up.
                redundancy_group: Some((i / (self.tolerate_missed_reads + 1)) as u32),
                payload_hex: Some(payload),
            });
        }
        let mut meta = ExportMetadata::new(Some(self.requirement_m));
        let r = &scn.rfid;
        let p = &mut meta.parameters;
        p.insert("scenario".into(), self.scenario.clone());
        p.insert("method".into(), self.method.clone());
        p.insert(
            "tolerate_missed_reads".into(),
            self.tolerate_missed_reads.to_string(),
        );
        p.insert("read_probability".into(), r.read_probability.to_string());
        p.insert("lane_width_m".into(), r.lane_width_m.to_string());
        p.insert("vehicle_width_m".into(), r.vehicle_width_m.to_string());
        p.insert(
            "roadside_distance_m".into(),
            r.roadside_distance_m.to_string(),
        );
        p.insert(
            "roadside_angle_deg".into(),
            format!("{:.3}", r.roadside_angle.to_degrees()),
        );
        p.insert("read_time_s".into(), r.read_time_s.to_string());
        p.insert(
            "road_surface_sigma_m".into(),
            r.road_surface_sigma_m.to_string(),
        );
        p.insert("ceiling_sigma_m".into(), r.ceiling_sigma_m.to_string());
        p.insert(
            "chainage_m".into(),
            if matches!(scn.route, RouteKind::Map { .. }) {
                "distance along road_id in its digitised direction".into()
            } else {
                "distance along the planned route".into()
            },
        );
        if matches!(scn.route, RouteKind::Map { .. }) {
            meta.attribution = Some("© OpenStreetMap contributors, ODbL".into());
        }
        Ok((recs, meta))
    }
}

/// Road context along a map route: attributes at a route distance.
struct RoadContext {
    net: Network,
    route: crate::route::Route,
    scale: std::cell::Cell<f64>,
}

impl RoadContext {
    fn at(&self, distance_m: f64) -> &RoadAttributes {
        let span = self.route.span_at(distance_m * self.scale.get());
        &self.net.model.roads[span.road as usize].attributes
    }

    /// Chainage along the road (its digitised direction, from its first
    /// section present in the map) at a route distance.
    fn road_chainage_m(&self, distance_m: f64) -> f64 {
        let c = distance_m * self.scale.get();
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
    tracing::info!(scenario = %scn.name(), requirement_m = settings.requirement_m, "planning tags");
    if settings.coverage == Coverage::Network {
        return Err(Error::InvalidParameter(
            "planner.coverage = \"network\" plans with planner::network::plan_network".into(),
        ));
    }
    let req = settings.requirement_m;
    // Road context (tunnels, road ids) and the network for map matching.
    let ctx = match &scn.route {
        RouteKind::Map { map, waypoints, .. } => {
            let net = Network::load(map, &Default::default())?;
            let route = crate::route::plan_route(&net, waypoints)?;
            Some(RoadContext {
                net,
                route,
                scale: std::cell::Cell::new(1.0),
            })
        }
        RouteKind::Motion { .. } => None,
    };
    let budget = Budget::new(scn, truth, ctx.as_ref().map(|c| &c.net));
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
    let (profile, sites) = budget.tag_free(settings.candidate_spacing_m, &sites_m);
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
    let reaches = budget.reaches_with_progress(&sites, &mountings, req, progress);
    let start_reach = budget.start_reach(req);
    let cands: Vec<Candidate> = sites
        .iter()
        .zip(&reaches)
        .map(|(s, &(_, r))| Candidate {
            at_m: s.distance_m,
            reach_m: r,
        })
        .collect();
    let k = settings.tolerate_missed_reads;
    if start_reach <= 0.0 {
        let b0 = budget
            .initial_filter()
            .map_or(f64::NAN, |f| bound95(&f.position_cov_enu()));
        return Err(Error::InvalidParameter(format!(
            "infeasible: the navigator's initial position uncertainty (95 % bound {b0:.2} m, from \
             navigator.initial_position_sigma_m / filter.position_sigma_m) already exceeds the {req} m \
             requirement at the start of the route"
        )));
    }
    let chosen = match place_with(
        length,
        start_reach,
        &cands,
        &is_existing,
        k,
        settings.min_spacing_m,
    ) {
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
            let next = cands
                .iter()
                .find(|c| c.at_m > covered_to_m)
                .map_or(length, |c| c.at_m);
            return Err(Error::InvalidParameter(format!(
                "infeasible: the {req} m requirement cannot be held with {k} missed read(s) tolerated \
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
    let mut reaches = reaches;
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
        let reaches2 = budget.reaches_with_progress(&sites2, &mountings, req, progress);
        let cands2: Vec<Candidate> = sites2
            .iter()
            .zip(&reaches2)
            .map(|(s, &(_, r))| Candidate {
                at_m: s.distance_m,
                reach_m: r,
            })
            .collect();
        let Placement::Feasible(c2) = place_with(
            length,
            start_reach,
            &cands2,
            &is_existing,
            k,
            settings.min_spacing_m,
        ) else {
            break;
        };
        if c2 == basis {
            break;
        }
        let fixes2: Vec<(usize, Mounting)> = c2
            .iter()
            .map(|&i| (sites[i].sample, mountings[i]))
            .collect();
        if c2.len() < chosen.len() && robust(&budget, &fixes2, k, req, settings.candidate_spacing_m)
        {
            chosen = c2.clone();
            reaches = reaches2;
            refined += 1;
        }
        basis = c2;
    }
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
    let fw = forward::forward_greedy(&budget, &fwd_sites, k, req, settings.min_spacing_m, k + 1);
    if let Placement::Feasible(c3) = fw {
        if new_count(&c3) < new_count(&chosen) {
            let fixes3: Vec<(usize, Mounting)> = c3
                .iter()
                .map(|&i| (sites[i].sample, mountings[i]))
                .collect();
            if robust(&budget, &fixes3, k, req, settings.candidate_spacing_m) {
                chosen = c3;
                forward_used = true;
            }
        }
    }
    // Lower bound: the most optimistic reaches (each site's filter having
    // read a tag at every earlier candidate site). By the monotonicity of
    // the filter's covariance in the information it has had, no plan on
    // these sites reaches further from any site, so the exact placement on
    // these reaches needs no more tags than any feasible plan.
    let lower_bound = {
        let all: Vec<(usize, Mounting)> = sites
            .iter()
            .zip(&mountings)
            .map(|(s, &m)| (s.sample, m))
            .collect();
        let at: Vec<f64> = sites.iter().map(|s| s.distance_m).collect();
        let (_, opt_sites) = budget.snapshots(&all, settings.candidate_spacing_m, &at);
        if opt_sites.len() == sites.len() {
            let r = budget.reaches_with_progress(&opt_sites, &mountings, req, progress);
            let c: Vec<Candidate> = opt_sites
                .iter()
                .zip(&r)
                .map(|(s, &(_, r))| Candidate {
                    at_m: s.distance_m,
                    reach_m: r,
                })
                .collect();
            match place_with(
                length,
                start_reach,
                &c,
                &is_existing,
                k,
                settings.min_spacing_m,
            ) {
                Placement::Feasible(c) => new_count(&c),
                Placement::Infeasible { .. } => 0,
            }
        } else {
            0
        }
    };
    // Each chosen tag's bound after its fix and reach, from the plan's own
    // filter (every planned tag read).
    {
        let fixes: Vec<(usize, Mounting)> = chosen
            .iter()
            .map(|&i| (sites[i].sample, mountings[i]))
            .collect();
        let at: Vec<f64> = chosen.iter().map(|&i| sites[i].distance_m).collect();
        let (_, own) = budget.snapshots(&fixes, settings.candidate_spacing_m, &at);
        if own.len() == chosen.len() {
            let m: Vec<Mounting> = chosen.iter().map(|&i| mountings[i]).collect();
            let r = budget.reaches(&own, &m, req);
            for (n, &i) in chosen.iter().enumerate() {
                reaches[i] = r[n];
            }
        }
    }
    let mut tags = Vec::with_capacity(chosen.len());
    let mut n_new = 0;
    for &i in &chosen {
        let s = &sites[i];
        let a = &samples[s.sample].avp;
        let existing = site_existing[i].map(|ti| &settings.existing_tags[ti]);
        if existing.is_none() {
            n_new += 1;
        }
        let road = ctx.as_ref().map(|c| c.at(s.distance_m));
        let speed = site_speed_mps(a.state.v[0].hypot(a.state.v[1]), road);
        let lane = budget.lane_width_at(s.sample);
        let (sa, sc) = scn
            .rfid
            .with_lane_width(lane)
            .fix_sigmas(mountings[i], speed);
        tags.push(PlannedTag {
            tag_id: existing.map_or_else(|| format!("T{n_new:04}"), |t| t.id.clone()),
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
            bound_after_fix_m: reaches[i].0,
            reach_m: reaches[i].1,
        });
    }
    let mut max_gap: f64 = 0.0;
    let mut prev = 0.0;
    for t in &tags {
        max_gap = max_gap.max(t.route_distance_m - prev);
        prev = t.route_distance_m;
    }
    max_gap = max_gap.max(length - prev);
    let fixes: Vec<(usize, Mounting)> = chosen
        .iter()
        .map(|&i| (sites[i].sample, mountings[i]))
        .collect();
    let with = budget.with_fixes(&fixes, settings.candidate_spacing_m);
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
    let n_cands = cands.len();
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
        profile_without_tags: profile,
        profile_with_tags: with,
        validation: None,
        uniform_baseline: None,
    };
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

/// Monte Carlo validation of a plan with its tags (read with the scenario's
/// read probability): fraction of distance within the requirement and the
/// worst point.
pub fn validate_plan(
    scn: &Scenario,
    truth: &TruthSource,
    plan: &Plan,
    runs: u64,
    seed: u64,
) -> Result<Validation> {
    let res = simulate_with(scn, truth, &plan.sim_tags(), runs.max(1), seed, None)?;
    Ok(validation_of(&res, plan, runs.max(1), seed))
}

fn validation_of(
    res: &crate::sim::run::SimResult,
    plan: &Plan,
    runs: u64,
    seed: u64,
) -> Validation {
    let req = plan.requirement_m;
    let (mut within, mut total) = (0.0, 0.0);
    let mut worst = (0.0f64, 0u64, 0.0, 0.0);
    for r in &res.runs {
        for w in r.rows.windows(2) {
            let dd = (w[1].distance_m - w[0].distance_m).max(0.0);
            total += dd;
            if w[1].horizontal_m <= req {
                within += dd;
            }
        }
        for row in &r.rows {
            if row.horizontal_m > worst.0 {
                worst = (row.horizontal_m, r.run, row.t_s, row.distance_m);
            }
        }
    }
    Validation {
        runs,
        seed,
        fraction_within_requirement: if total > 0.0 { within / total } else { 1.0 },
        max_horizontal_error_m: worst.0,
        worst_run: worst.1,
        worst_t_s: worst.2,
        worst_distance_m: worst.3,
    }
}

/// The bound of a filter's horizontal covariance (re-exported helper).
pub fn horizontal_bound95(c: &[[f64; 3]; 3]) -> f64 {
    bound95(c)
}

/// Tags every `spacing_m` along the truth route (from `spacing_m` on), with
/// the preferred mounting allowed off tunnels.
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
    let mut tags = Vec::new();
    for a in truth.samples().take_while(|a| a.t <= cap) {
        if sites.take(a.distance_m) {
            tags.push(Tag {
                id: format!("U{:04}", tags.len() + 1),
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
/// validation keeps at least `min_fraction` of distance within it.
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
    let net = match &scn.route {
        RouteKind::Map { map, .. } => Some(Network::load(map, &Default::default())?),
        _ => None,
    };
    let budget = Budget::new(scn, truth, net.as_ref());
    let mut tried = Vec::new();
    let mut check = |n: u64| -> Result<(bool, Option<Validation>, usize)> {
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
        if !robust(&budget, &fixes, k, req, step) {
            tried.push((spacing, f64::NAN));
            return Ok((false, None, tags.len()));
        }
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
            profile_without_tags: vec![],
            profile_with_tags: vec![],
            validation: None,
            uniform_baseline: None,
        };
        let res = simulate_with(scn, truth, &tags, runs.max(1), seed, None)?;
        let v = validation_of(&res, &p, runs.max(1), seed);
        tried.push((spacing, v.fraction_within_requirement));
        Ok((
            v.fraction_within_requirement >= min_fraction,
            Some(v),
            tags.len(),
        ))
    };
    let hi_n = ((length / step).ceil() as u64).max(1);
    // The smallest spacing must pass, else there is no baseline.
    let (ok, mut best_v, mut best_c) = check(1)?;
    if !ok {
        return Ok(None);
    }
    let (mut lo, mut hi) = (1u64, hi_n + 1);
    // Invariant: lo passes; hi does not (or is beyond the route).
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let (ok, v, c) = check(mid)?;
        if ok {
            lo = mid;
            best_v = v;
            best_c = c;
        } else {
            hi = mid;
        }
    }
    tried.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(best_v.map(|validation| UniformBaseline {
        spacing_m: lo as f64 * step,
        tag_count: best_c,
        min_fraction,
        tolerate_missed_reads: k,
        validation,
        tried,
    }))
}

/// Whether the predicted bound holds along the route with fixes `fixes`
/// all read, and with any `k` consecutive of them missed.
pub fn robust(
    budget: &Budget<'_>,
    fixes: &[(usize, Mounting)],
    k: usize,
    requirement_m: f64,
    every_m: f64,
) -> bool {
    use rayon::prelude::*;
    let worst = |f: &[(usize, Mounting)]| {
        budget
            .with_fixes(f, every_m)
            .iter()
            .map(|p| p.bound95_m)
            .fold(0.0, f64::max)
    };
    if worst(fixes) > requirement_m {
        return false;
    }
    if k == 0 || fixes.is_empty() {
        return true;
    }
    let n = fixes.len();
    // Each window of k missed tags starts from the all-read filter just
    // before its first tag (snapshots from one all-read pass).
    let at: Vec<f64> = fixes
        .iter()
        .map(|&(i, _)| budget.samples()[i].avp.distance_m)
        .collect();
    let (_, snaps) = budget.snapshots(fixes, every_m, &at);
    if snaps.len() != n {
        return false;
    }
    let drops: Vec<usize> = (0..n.saturating_sub(k - 1).max(1)).collect();
    drops.par_iter().all(|&d| {
        let rest = &fixes[(d + k).min(n)..];
        budget.worst_bound_from(fixes[d].0, snaps[d].filter.clone(), rest, requirement_m)
            <= requirement_m
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Oneway;

    fn road(
        highway: &str,
        lanes: Option<u32>,
        width: Option<f64>,
        oneway: Oneway,
    ) -> RoadAttributes {
        RoadAttributes {
            id: "1".into(),
            name: None,
            highway: highway.into(),
            oneway,
            lanes,
            width_m: width,
            maxspeed_kmh: Some(50.0),
            tunnel: false,
            bridge: false,
            layer: 0,
        }
    }

    #[test]
    fn lane_width_from_osm_width_and_lanes_or_class_defaults() {
        assert_eq!(
            lane_width_m(&road("primary", Some(4), Some(14.0), Oneway::Both)),
            3.5
        );
        // Width without lanes: two lanes on a two-way road, one on a one-way road.
        assert_eq!(
            lane_width_m(&road("residential", None, Some(6.4), Oneway::Both)),
            3.2
        );
        assert_eq!(
            lane_width_m(&road("residential", None, Some(4.0), Oneway::Forward)),
            4.0
        );
        // Class defaults; links as their road; implausible widths clamped.
        assert_eq!(
            lane_width_m(&road("motorway_link", None, None, Oneway::Forward)),
            3.75
        );
        assert_eq!(
            lane_width_m(&road("service", None, None, Oneway::Both)),
            3.0
        );
        assert_eq!(
            lane_width_m(&road("primary", Some(1), Some(40.0), Oneway::Both)),
            5.0
        );
    }

    #[test]
    fn speed_from_truth_else_maxspeed() {
        let r = road("primary", None, None, Oneway::Both);
        assert_eq!(site_speed_mps(12.0, Some(&r)), 12.0);
        assert!((site_speed_mps(0.0, Some(&r)) - 50.0 / 3.6).abs() < 1e-12);
        assert!((site_speed_mps(0.0, None) - 30.0 / 3.6).abs() < 1e-12);
    }

    #[test]
    fn mounting_options_ceiling_only_in_tunnels() {
        let c = MountingOption::default_for(Mounting::Ceiling);
        assert!(c.allowed_on(true) && !c.allowed_on(false));
        let r = MountingOption::default_for(Mounting::Roadside);
        assert!(r.allowed_on(true) && r.allowed_on(false));
        assert_eq!(r.read_probability, DEFAULT_READ_PROBABILITY);
        assert!(c.cost > r.cost);
    }

    #[test]
    fn roadside_fix_bound_follows_the_paper_example() {
        // D = 3.75 m, d = 3 m, θ = 15°, v = 40 km/h, t0 = 20 ms, x = 5.63 m:
        // dx = 0.375 m, dy = 1.286 m (paper 1.285), dr = 1.340 m (paper 1.338).
        let m = RfidModel {
            vehicle_width_m: 3.0,
            ..RfidModel::default()
        };
        let v = 40.0 / 3.6;
        let (along, across) = m.fix_sigmas(Mounting::Roadside, v);
        let dy = 5.63 * 15f64.to_radians().tan() - v * 0.02;
        assert!((along - dy).abs() < 1e-12 && (dy - 1.285).abs() < 2e-3);
        assert!((across * 3f64.sqrt() - 0.375).abs() < 1e-12);
        assert!((0.375f64.hypot(dy) - 1.338).abs() < 3e-3);
        // The planner's 95 % bound of that fix: √χ²₂(0.95) × the larger σ.
        assert!((fix_bound95(&m, Mounting::Roadside, v) - 2.4477 * dy).abs() < 1e-3);
        // Road surface and ceiling are far tighter.
        assert!(fix_bound95(&m, Mounting::RoadSurface, v) < 0.6);
        assert!(fix_bound95(&m, Mounting::Ceiling, v) < 0.3);
    }
}
