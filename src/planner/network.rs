//! `coverage = "network"`: tags so that every drivable road of the map, in
//! each permitted direction, holds the requirement on *any* path through the
//! network, with `k = tolerate_missed_reads` missed reads tolerated.
//!
//! # Model (conservative, as stated)
//!
//! * **Graph.** Directed edges are (road section, direction) for every
//!   section of the loaded (drivable) network in each permitted direction
//!   (one-way honoured); nodes are the topology's junctions and road ends.
//!   Any turn at a node is allowed, U-turns included (the topology's
//!   successors; `planner.u_turns = "anywhere"`, the default). With
//!   `u_turns = "dead_ends"` a walk turns back only where a single road ends:
//!   each directed edge then has its own end nodes, joined by 1 mm
//!   connectors (no sites) for each permitted transition, so the same walk
//!   machinery applies. Turning round inside a road is not modelled.
//! * **Tags serve one direction**: a road-surface tag in one lane, a roadside
//!   post on the right of travel (right-hand traffic), a ceiling reader above
//!   one lane. A one-way road has one directed edge, so its tags serve all its
//!   traffic.
//! * **Candidates** every `candidate_spacing_m` along each directed edge
//!   (default **50 m** for networks, coarser than a route's 20 m: the graph
//!   is large and the reach is hundreds of metres or more): `ceil(ℓ/d)` sites
//!   evenly spread, so an edge shorter than the spacing gets one at its
//!   midpoint. Each site takes the cheapest allowed mounting (ceiling only in
//!   tunnels) and its cost. Installed tags (`existing_tags`) snap to a
//!   directed edge within 15 m — among the roads there, the one the point
//!   fits best as a lane centre (so a tag next to a junction or a parallel
//!   carriageway keeps its own road), in the direction whose right-hand side
//!   it is on (digitised forward on the centreline) — and count as free
//!   selected sites. `forbidden_m` (stretches of *route* distance) and
//!   `min_spacing_m` do not apply to networks and are rejected.
//! * **Error budget.** The reach `R` comes from the navigation [`Filter`]
//!   itself by covariance analysis (perfect data, as in [`super::budget`]),
//!   on the worst case the network allows: a straight, turn-free drive (no
//!   help from turns; map matching ignored, so no along- or cross-track help)
//!   at the speed `min(route speed_kmh, road maxspeed)` of each speed class
//!   present (5 km/h classes, ≥ 10 km/h; slower is more time per metre), and
//!   each mounting in use (fix quality). Starting with the scenario's prior,
//!   the drive is fixed each time the 95 % bound reaches the requirement,
//!   until the distances between fixes settle (periodic profile): the first
//!   distance is `R_start` (a vehicle entering anywhere with the prior), the
//!   later ones give `R_steady = min` of them (the filter's velocity and
//!   attitude uncertainty after earlier fixes included). Fixes at most
//!   `R_steady` apart keep the bound within the requirement if a shorter gap
//!   never leaves the filter worse off (covariance monotone in the gap).
//!   Each speed class `c` gets `R_c = min(R_steady, R_start)` over the
//!   mountings in use, and a metre of road in class `c` consumes `1/R_c` of
//!   the error budget (the instance measures it as `R_ref/R_c` metres
//!   against the fastest class's reach `R_ref`): exact when the error grows
//!   with time alone (`R_c ∝ v_c`) or with distance alone (`R_c` equal),
//!   an approximation for mixtures, checked by the validation. Stops
//!   (standing still) are not modelled.
//! * **Constraint**: every directed walk (revisiting edges and looping
//!   allowed) that consumes more than the error budget passes at least
//!   `k + 1` tags (with multiplicity). Checked exactly by dynamic programming
//!   ([`network_cover::check`]).
//! * **Optimisation**: minimum total cost. Exact by integer programming with
//!   lazy walk constraints ([`network_ilp`]) when the instance is small
//!   (≤ [`ILP_MAX_CANDIDATES`] candidates) and the solver finishes within its
//!   node budget; otherwise greedy set multicover with exact reverse deletion
//!   ([`network_cover::greedy`]). The plan reports the method and a lower
//!   bound: the larger of a packing bound (edge-disjoint walks longer than
//!   `R`, each needing `k + 1` tags) and the integer programme's bound.
//! * **Validation**: Monte Carlo runs of the real navigator (`sim`) over
//!   seeded random origin–destination shortest paths of 1.5–4 km, each with
//!   the planned tags of the directions it drives, read with the scenario's
//!   read probability.

use super::network_cover::{self as cover, CoverEdge, CoverProblem, CoverSite, Solved, Walk};
use super::network_ilp::{self as ilp, IlpLimits, IlpOutcome};
use super::{lane_width_m, PlannerSettings};
use crate::error::{Error, Result};
use crate::export::{ExportMetadata, TagRecord};
use crate::nav::integrated::along_across_covariance;
use crate::nav::Filter;
use crate::network::{Network, SectionId};
use crate::planner::budget::bound95;
use crate::sim::integrated::filter_config;
use crate::sim::run::{simulate_with, TruthSource};
use crate::sim::scenario::{RouteKind, Scenario};
use crate::sim::tags::{Mounting, Tag};
use crate::tags::TagPayload;
use crate::trajectory::{ideal_imu, Extent, Motion, MotionPlan, RoutePlan, SpeedProfile, Start};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::time::Instant;

/// Default candidate spacing on networks (m).
pub const DEFAULT_NETWORK_SPACING_M: f64 = 50.0;
/// Largest instance (candidate sites) tried with the exact method.
pub const ILP_MAX_CANDIDATES: usize = 150;
/// Installed tags farther than this from every road are ignored (m).
pub const EXISTING_SNAP_M: f64 = 15.0;
/// Length of a junction connector when U-turns are restricted (m).
const CONNECTOR_M: f64 = 1e-3;
/// Longest straight drive of the reach analysis (m), and its time cap (s).
const DRIVE_MAX_M: f64 = 100_000.0;
const DRIVE_MAX_S: f64 = 7_200.0;

/// The reach of one speed class and mounting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReachClass {
    /// Speed (km/h).
    pub speed_kmh: f64,
    /// Mounting of the fixes.
    pub mounting: String,
    /// Distance from the start (prior) until the bound reaches the requirement (m).
    pub start_reach_m: f64,
    /// Distances between successive fixes placed where the bound reaches
    /// the requirement (m), until periodic.
    pub periods_m: Vec<f64>,
    /// The smallest of them (m).
    pub steady_reach_m: f64,
    /// 95 % bound right after a fix in steady state (m).
    pub bound_after_fix_m: f64,
    /// The drive ended before the bound reached the requirement (the reach
    /// is at least this).
    pub capped: bool,
}

/// One tag of a network plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NetworkTag {
    /// Identifier.
    pub tag_id: String,
    /// Latitude of the tag (lane centre of its direction; degrees).
    pub lat: f64,
    /// Longitude (degrees).
    pub lon: f64,
    /// Latitude on the road's centreline (degrees).
    pub centre_lat: f64,
    /// Longitude on the road's centreline (degrees).
    pub centre_lon: f64,
    /// Height (m).
    pub height_m: f64,
    /// Road input id.
    pub road_id: String,
    /// Road name.
    pub road_name: Option<String>,
    /// Distance along the road (way) in its digitised direction (m).
    pub chainage_m: f64,
    /// Travel direction served: the road's digitised direction or against it.
    pub digitised_forward: bool,
    /// The road is one-way.
    pub oneway: bool,
    /// Mounting.
    #[serde(serialize_with = "super::ser_mounting")]
    pub mounting: Mounting,
    /// Expected 1σ fix error (larger axis, m).
    pub expected_fix_sigma_m: f64,
    /// In a tunnel.
    pub tunnel: bool,
    /// Installed already (`existing_tags`).
    pub existing: bool,
    /// Cost (0 for installed tags).
    pub cost: f64,
    /// Lateral offset of the lane centre right of the road centreline (m).
    pub lane_offset_m: f64,
    /// Directed edge index (internal).
    #[serde(skip)]
    pub edge: u32,
    /// Section (internal).
    #[serde(skip)]
    pub section: SectionId,
}

/// Monte Carlo validation over sampled paths.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NetworkValidation {
    /// Runs in all.
    pub runs: u64,
    /// Sampled paths.
    pub paths: usize,
    /// Runs per path.
    pub runs_per_path: u64,
    /// Total length of the paths (km).
    pub paths_length_km: f64,
    /// Base seed.
    pub seed: u64,
    /// Fraction of distance (all runs, all paths) within the requirement.
    pub fraction_within_requirement: f64,
    /// Largest horizontal error (m).
    pub max_horizontal_error_m: f64,
    /// Where: path index, run, time (s), distance along the path (m).
    pub worst_path: usize,
    /// Run of the worst point.
    pub worst_run: u64,
    /// Time of the worst point (s).
    pub worst_t_s: f64,
    /// Distance along its path (m).
    pub worst_distance_m: f64,
    /// Position of the worst point (degrees).
    pub worst_lat: f64,
    /// Longitude of the worst point (degrees).
    pub worst_lon: f64,
    /// Road of the worst point (input id), when found.
    pub worst_road_id: Option<String>,
}

/// A network coverage plan.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkPlan {
    /// Scenario name.
    pub scenario: String,
    /// Always `"network"`.
    pub coverage: String,
    /// Requirement (m).
    pub requirement_m: f64,
    /// Consecutive missed reads tolerated.
    pub tolerate_missed_reads: usize,
    /// Placement method.
    pub method: String,
    /// Lower bound on the number of new tags.
    pub lower_bound: usize,
    /// Lower bound on the cost of new tags.
    pub lower_bound_cost: f64,
    /// Reach of the slowest speed class, min(steady, start) over the
    /// mountings in use (m): the tightest.
    pub reach_m: f64,
    /// Reach of the fastest class (m): the budget's reference; a metre of
    /// a road of class c consumes `1/R_c` of the budget.
    pub budget_reference_m: f64,
    /// Steady-state reach between fixes (m).
    pub steady_reach_m: f64,
    /// Reach from the prior at a start (m).
    pub start_reach_m: f64,
    /// Reach per speed class and mounting.
    pub reach_classes: Vec<ReachClass>,
    /// Directed edges (section, direction).
    pub directed_edges: usize,
    /// Where walks may turn back: "anywhere" or "dead_ends".
    pub u_turns: String,
    /// Length of all directed edges (km).
    pub directed_length_km: f64,
    /// Candidate sites (installed tags included).
    pub candidates: usize,
    /// Candidate spacing (m).
    pub candidate_spacing_m: f64,
    /// Installed tags kept / ignored (farther than 15 m from every road).
    pub existing_kept: usize,
    /// Installed tags ignored.
    pub existing_off_network: usize,
    /// Tags (new and installed).
    pub tags: Vec<NetworkTag>,
    /// Total cost of new tags.
    pub total_cost: f64,
    /// The dynamic programme finds no walk consuming more than the budget
    /// with ≤ k passes.
    pub verified: bool,
    /// Largest budget fraction consumed by a walk with at most k passes
    /// (≤ 1 when verified; capped just above 1).
    pub longest_walk_budget: f64,
    /// Time per stage (ms): load, reach, build, solve.
    pub timings_ms: BTreeMap<String, f64>,
    /// Monte Carlo validation, when run.
    pub validation: Option<NetworkValidation>,
    /// The instance (for checks; not serialised).
    #[serde(skip)]
    pub problem: Option<CoverProblem>,
    /// The selection (per site).
    #[serde(skip)]
    pub selected: Vec<bool>,
}

impl NetworkPlan {
    /// New tags.
    pub fn tag_count(&self) -> usize {
        self.tags.iter().filter(|t| !t.existing).count()
    }

    /// New tags by mounting.
    pub fn by_mounting(&self) -> BTreeMap<String, usize> {
        let mut m = BTreeMap::new();
        for t in self.tags.iter().filter(|t| !t.existing) {
            *m.entry(t.mounting.as_str().to_string()).or_insert(0) += 1;
        }
        m
    }

    /// Export records of the new tags (with payloads) and metadata.
    pub fn export(&self, scn: &Scenario) -> Result<(Vec<TagRecord>, ExportMetadata)> {
        let mut recs = Vec::new();
        for t in self.tags.iter().filter(|t| !t.existing) {
            let payload = TagPayload {
                lat_deg: t.lat,
                lon_deg: t.lon,
                height_m: t.height_m,
                mounting: t.mounting,
            }
            .to_hex()?;
            // Side of the road's digitised direction the tag is on: the
            // lane (and roadside post) right of travel.
            let side = if t.oneway && t.mounting != Mounting::Roadside {
                "centre"
            } else if t.digitised_forward {
                "right"
            } else {
                "left"
            };
            recs.push(TagRecord {
                tag_id: t.tag_id.clone(),
                lat: t.lat,
                lon: t.lon,
                height_m: t.height_m,
                road_id: Some(t.road_id.clone()),
                chainage_m: Some(t.chainage_m),
                side: Some(side.to_string()),
                lateral_offset_m: Some(match t.mounting {
                    Mounting::Roadside => scn.rfid.roadside_distance_m,
                    _ => 0.0,
                }),
                mounting: t.mounting,
                expected_fix_sigma_m: Some(t.expected_fix_sigma_m),
                redundancy_group: Some(t.edge),
                payload_hex: Some(payload),
            });
        }
        let mut meta = ExportMetadata::new(Some(self.requirement_m));
        let r = &scn.rfid;
        let p = &mut meta.parameters;
        p.insert("scenario".into(), self.scenario.clone());
        p.insert("coverage".into(), "network".into());
        p.insert("method".into(), self.method.clone());
        p.insert("reach_m".into(), format!("{:.1}", self.reach_m));
        p.insert(
            "budget_reference_m".into(),
            format!("{:.1}", self.budget_reference_m),
        );
        p.insert("u_turns".into(), self.u_turns.clone());
        p.insert(
            "tolerate_missed_reads".into(),
            self.tolerate_missed_reads.to_string(),
        );
        p.insert("read_probability".into(), r.read_probability.to_string());
        p.insert(
            "candidate_spacing_m".into(),
            self.candidate_spacing_m.to_string(),
        );
        p.insert(
            "roadside_distance_m".into(),
            r.roadside_distance_m.to_string(),
        );
        p.insert("vehicle_width_m".into(), r.vehicle_width_m.to_string());
        p.insert(
            "chainage_m".into(),
            "distance along the road (road_id) in its digitised direction".into(),
        );
        p.insert(
            "side".into(),
            "side of the road's digitised direction (right-hand traffic: the lane of the direction served); \
             the position is the lane centre; lateral_offset_m is a roadside post's distance right of it"
                .into(),
        );
        p.insert(
            "redundancy_group".into(),
            "directed road section (section and direction) the tag serves".into(),
        );
        meta.attribution = Some("© OpenStreetMap contributors, ODbL".into());
        Ok((recs, meta))
    }

    /// The tags as the simulator takes them, on the centreline (where the
    /// simulated vehicles drive), only those of the given directed sections
    /// (all when `None`).
    pub fn sim_tags(&self, only: Option<&HashSet<(SectionId, bool)>>) -> Vec<Tag> {
        self.tags
            .iter()
            .filter(|t| only.is_none_or(|s| s.contains(&(t.section, t.digitised_forward))))
            .map(|t| Tag {
                id: t.tag_id.clone(),
                lat: t.centre_lat.to_radians(),
                lon: t.centre_lon.to_radians(),
                height_m: Some(t.height_m),
                mounting: t.mounting,
                survey_error_m: [0.0, 0.0],
                lane_width_m: None,
            })
            .collect()
    }
}

/// The speed profile and height of a network scenario's route (vehicles'
/// speed), or an error when the scenario has no map.
fn map_route(scn: &Scenario) -> Result<(&std::path::Path, &SpeedProfile, f64)> {
    match &scn.route {
        RouteKind::Map {
            map,
            profile,
            height_m,
            ..
        } => Ok((map.as_path(), profile, *height_m)),
        RouteKind::Motion { .. } => Err(Error::scenario(
            &scn.path,
            "planner.coverage = \"network\" needs a road map: give [map] and a [[route]] with \
             waypoints (its speed_kmh is the vehicles' speed); a motion-command route has no network",
        )),
    }
}

/// Loads the road network of a network-coverage scenario.
pub fn scenario_network(scn: &Scenario) -> Result<Network> {
    let (map, _, _) = map_route(scn)?;
    Network::load(map, &Default::default())
}

/// Where walks may turn back onto the road they came along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UTurns {
    /// At any junction or road end (`"anywhere"`, the default): the
    /// topology's successors, the most conservative.
    Anywhere,
    /// Only at dead ends (`"dead_ends"`: nodes where a single road ends).
    DeadEnds,
}

/// Checks the network-specific settings: candidate spacing and U-turns.
fn check_settings(scn: &Scenario, settings: &PlannerSettings) -> Result<(f64, UTurns)> {
    let p = scn.file.planner.as_ref();
    if !settings.forbidden_m.is_empty() {
        return Err(Error::scenario(
            &scn.path,
            "planner.forbidden_m gives stretches of route distance and does not apply to \
             coverage = \"network\"",
        ));
    }
    if settings.min_spacing_m > 0.0 {
        return Err(Error::scenario(
            &scn.path,
            "planner.min_spacing_m is not supported with coverage = \"network\"",
        ));
    }
    let u = match p.and_then(|p| p.u_turns.as_deref()) {
        None | Some("anywhere") => UTurns::Anywhere,
        Some("dead_ends") => UTurns::DeadEnds,
        Some(o) => {
            return Err(Error::scenario(
                &scn.path,
                format!("planner.u_turns = \"{o}\" is not one of anywhere, dead_ends"),
            ))
        }
    };
    Ok((
        p.and_then(|p| p.candidate_spacing_m)
            .unwrap_or(DEFAULT_NETWORK_SPACING_M),
        u,
    ))
}

/// The reach of one class: a straight drive north at `speed_mps` from
/// (`lat`, `lon`) with the scenario's prior, fixed by `mounting` each time
/// the 95 % bound exceeds `req`.
pub fn reach_class(
    scn: &Scenario,
    lat: f64,
    lon: f64,
    height_m: f64,
    speed_mps: f64,
    mounting: Mounting,
    req: f64,
) -> Result<ReachClass> {
    let dt = scn.dt;
    let dist = DRIVE_MAX_M.min(speed_mps * DRIVE_MAX_S);
    let start = Start {
        lat,
        lon,
        h: height_m,
        heading: 0.0,
        pitch: 0.0,
        roll: 0.0,
        speed_mps,
    };
    let plan = MotionPlan::new(
        start,
        &[Motion::Cruise {
            extent: Extent::Distance(dist),
        }],
        dt,
    )?;
    let cfg = filter_config(scn);
    let aid = scn.file.aiding;
    let odo_every =
        ((scn.file.filter.odometer_interval_s.unwrap_or(0.1) / dt).round() as usize).max(1);
    let baro_every = (1.0 / dt).round().max(1.0) as usize;
    let mut samples = ideal_imu(plan.trajectory(), dt);
    let Some(first) = samples.next() else {
        return Err(Error::InvalidParameter("empty reach drive".into()));
    };
    let mut f = Filter::new(first.avp.state, first.avp.t, dt, cfg);
    let b0 = bound95(&f.position_cov_enu());
    if b0 > req {
        return Err(Error::InvalidParameter(format!(
            "infeasible: the navigator's initial position uncertainty (95 % bound {b0:.2} m, from \
             navigator.initial_position_sigma_m / filter.position_sigma_m) already exceeds the {req} m \
             requirement where a vehicle starts"
        )));
    }
    let mut start_reach: Option<f64> = None;
    let mut periods: Vec<f64> = Vec::new();
    let (mut last_fix, mut prev_d) = (0.0, 0.0);
    let mut odo_acc = 0.0;
    let mut bound_after = f64::NAN;
    for (n, s) in samples.enumerate() {
        let i = n + 1;
        f.step(&s.imu);
        odo_acc += s.avp.distance_m - prev_d;
        if i % odo_every == 0 {
            if aid.odometer {
                f.update_odometer(odo_acc);
            } else if cfg.use_nhc {
                f.update_constraints();
            }
            odo_acc = 0.0;
        }
        if aid.baro && i % baro_every == 0 {
            let var = scn.baro.noise_m.powi(2).max(0.01);
            f.update_height(s.avp.t, s.avp.state.h, var);
        }
        if bound95(&f.position_cov_enu()) > req {
            let reach = prev_d - last_fix;
            match start_reach {
                None => start_reach = Some(reach),
                Some(_) => periods.push(reach),
            }
            // The fix, as the budget applies it.
            let a = &s.avp;
            let speed = a.state.v[0].hypot(a.state.v[1]);
            let fw = a.state.q.transform_vector(&[0.0, 1.0, 0.0].into());
            let (sa, sc) = scn.rfid.fix_sigmas(mounting, speed);
            let cov = along_across_covariance(fw[0].atan2(fw[1]), sa, sc);
            f.update_position(
                a.t,
                a.state.lat,
                a.state.lon,
                Some(a.state.h),
                cov,
                scn.rfid.height_sigma_m.powi(2).max(1e-4),
            );
            bound_after = bound95(&f.position_cov_enu());
            if bound_after > req {
                return Err(Error::InvalidParameter(format!(
                    "infeasible: requirement_m = {req} m is below what a {} fix leaves \
                     (95 % bound {bound_after:.2} m right after the fix at {:.0} km/h)",
                    mounting.as_str(),
                    speed_mps * 3.6
                )));
            }
            last_fix = a.distance_m;
            let settled = periods.len() >= 3 && {
                let t = &periods[periods.len() - 3..];
                let (lo, hi) = t
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
                hi - lo <= (0.002 * hi).max(0.5)
            };
            // The binding (smallest) period came early and the profile has
            // grown for three periods since: later periods are longer still.
            let growing = periods.len() >= 4 && {
                let t = &periods[periods.len() - 4..];
                let min = periods.iter().copied().fold(f64::INFINITY, f64::min);
                t.windows(2).all(|w| w[1] >= w[0]) && t[0] > min
            };
            if settled || growing || periods.len() >= 12 {
                break;
            }
        }
        prev_d = s.avp.distance_m;
    }
    let capped_tail = prev_d - last_fix;
    let (start_reach_m, steady, capped) = match (start_reach, periods.is_empty()) {
        (None, _) => (prev_d, prev_d, true),
        (Some(s0), true) => (s0, capped_tail, true),
        (Some(s0), false) => (
            s0,
            periods.iter().copied().fold(f64::INFINITY, f64::min),
            false,
        ),
    };
    Ok(ReachClass {
        speed_kmh: speed_mps * 3.6,
        mounting: mounting.as_str().into(),
        start_reach_m,
        periods_m: periods,
        steady_reach_m: steady,
        bound_after_fix_m: bound_after,
        capped,
    })
}

/// The instance built from a network.
struct Built {
    problem: CoverProblem,
    /// Per directed edge: section, forward.
    edge_dir: Vec<(SectionId, bool)>,
    /// Per site: mounting, installed tag index.
    site_mounting: Vec<Mounting>,
    site_existing: Vec<Option<usize>>,
    /// Speed (m/s) per directed edge.
    edge_speed: Vec<f64>,
    existing_off: usize,
    directed_length_m: f64,
    /// Directed road edges (connectors come after them).
    physical_edges: usize,
    /// Budget metres per metre of each edge (R_ref / R of its speed class).
    edge_scale: Vec<f64>,
}

fn edge_speed(scn_speed: f64, maxspeed_kmh: Option<f64>) -> f64 {
    let v = maxspeed_kmh.map_or(scn_speed, |m| (m / 3.6).min(scn_speed));
    // 5 km/h classes, rounded down (slower is the worse case); a speed
    // below 5 km/h is its own class (at least 1 km/h).
    let kmh = (v * 3.6 / 5.0).floor() * 5.0;
    let kmh = if kmh < 5.0 { (v * 3.6).max(1.0) } else { kmh };
    kmh / 3.6
}

fn build(
    net: &Network,
    settings: &PlannerSettings,
    scn_speed: f64,
    spacing: f64,
    reach_m: f64,
    u_turns: UTurns,
) -> Result<Built> {
    let mut edges = Vec::new();
    let mut edge_dir = Vec::new();
    let mut edge_speed_v = Vec::new();
    let mut sites = Vec::new();
    let mut site_mounting = Vec::new();
    let mut site_existing = Vec::new();
    let mut dir_index: BTreeMap<(SectionId, bool), u32> = BTreeMap::new();
    let mut directed_length_m = 0.0;
    for (si, s) in net.sections.iter().enumerate() {
        if s.length_m.is_nan() || s.length_m <= 0.0 {
            continue;
        }
        let a = &net.roads[s.road as usize].attributes;
        for fwd in [true, false] {
            let allowed = if fwd {
                s.oneway.allows_forward()
            } else {
                s.oneway.allows_backward()
            };
            if !allowed {
                continue;
            }
            let (tail, head) = if fwd {
                (s.start, s.end)
            } else {
                (s.end, s.start)
            };
            let e = edges.len() as u32;
            edges.push(CoverEdge {
                tail,
                head,
                length_m: s.length_m,
            });
            dir_index.insert((si as SectionId, fwd), e);
            edge_dir.push((si as SectionId, fwd));
            edge_speed_v.push(edge_speed(scn_speed, a.maxspeed_kmh));
            directed_length_m += s.length_m;
            if let Some(o) = settings.mountings.iter().find(|o| o.allowed_on(a.tunnel)) {
                let n = (s.length_m / spacing).ceil().max(1.0) as usize;
                for i in 0..n {
                    sites.push(CoverSite {
                        edge: e,
                        at_m: (i as f64 + 0.5) * s.length_m / n as f64,
                        cost: o.cost,
                        existing: false,
                    });
                    site_mounting.push(o.mounting);
                    site_existing.push(None);
                }
            }
        }
    }
    if edges.is_empty() {
        return Err(Error::InvalidParameter(
            "the map has no drivable road section to cover".into(),
        ));
    }
    // Installed tags: the best-fitting directed edge within 15 m.
    let mut existing_off = 0;
    for (ti, t) in settings.existing_tags.iter().enumerate() {
        let p = net.frame.to_enu(&crate::geodesy::Geodetic {
            lat: t.lat,
            lon: t.lon,
            height: 0.0,
        });
        let p2 = [p[0], p[1]];
        // Among the segments within 15 m, the one the tag fits best as a
        // lane-centre point: its lateral offset closest to half a lane (two-way
        // roads) or to the centreline (one-way), projection inside the
        // segment preferred. The side gives the direction served.
        let mut best: Option<(f64, u32, f64, f64)> = None; // (score, segment, offset, cross)
        for (seg_id, d) in net.rtree.nearest_iter(p2) {
            if d > EXISTING_SNAP_M {
                break;
            }
            let seg = &net.segments[seg_id as usize];
            let (dx, dy) = (seg.b[0] - seg.a[0], seg.b[1] - seg.a[1]);
            let l2 = (dx * dx + dy * dy).max(1e-12);
            let raw = ((p2[0] - seg.a[0]) * dx + (p2[1] - seg.a[1]) * dy) / l2;
            let tpar = raw.clamp(0.0, 1.0);
            let cross = (dx * (p2[1] - seg.a[1]) - dy * (p2[0] - seg.a[0])) / l2.sqrt();
            let sec = &net.sections[seg.section as usize];
            let expected = if sec.oneway.is_oneway() {
                0.0
            } else {
                0.5 * lane_width_m(&net.roads[sec.road as usize].attributes)
            };
            let outside = (raw - tpar).abs() * l2.sqrt();
            let score = (cross.abs() - expected).abs() + outside;
            if best.is_none_or(|b| score < b.0 - 1e-9) {
                best = Some((
                    score,
                    seg_id,
                    seg.section_offset_m + tpar * seg.length_m,
                    cross,
                ));
            }
        }
        let Some((_, seg_id, off, cross)) = best else {
            existing_off += 1;
            continue;
        };
        let seg = &net.segments[seg_id as usize];
        // Right of the digitised direction (or on it): forward; left: backward.
        let prefer_fwd = cross <= 0.0;
        let sec = seg.section;
        let pick = [prefer_fwd, !prefer_fwd]
            .into_iter()
            .find_map(|f| dir_index.get(&(sec, f)).map(|&e| (e, f)));
        let Some((e, fwd)) = pick else {
            existing_off += 1;
            continue;
        };
        let len = edges[e as usize].length_m;
        sites.push(CoverSite {
            edge: e,
            at_m: if fwd { off } else { len - off },
            cost: 0.0,
            existing: true,
        });
        site_mounting.push(t.mounting);
        site_existing.push(Some(ti));
    }
    // U-turns only at dead ends: every directed edge gets its own end
    // nodes, joined by connectors (1 mm, no sites) for each permitted
    // transition; the walk model is unchanged and walks gain at most 1 mm per
    // junction (conservative).
    let physical = edges.len();
    let nodes = match u_turns {
        UTurns::Anywhere => net.nodes.len(),
        UTurns::DeadEnds => {
            for e in 0..physical {
                let (sec, fwd) = edge_dir[e];
                let v = edges[e].head;
                for d in net.topology.departures(net, v) {
                    let Some(&e2) = dir_index.get(&(d.section, d.forward)) else {
                        continue;
                    };
                    let u_turn = d.section == sec && d.forward != fwd;
                    if u_turn && net.topology.degree(v) > 1 {
                        continue;
                    }
                    edges.push(CoverEdge {
                        tail: 2 * e as u32 + 1,
                        head: 2 * e2,
                        length_m: CONNECTOR_M,
                    });
                }
            }
            for (e, ed) in edges.iter_mut().enumerate().take(physical) {
                ed.tail = 2 * e as u32;
                ed.head = 2 * e as u32 + 1;
            }
            2 * physical
        }
    };
    let problem =
        CoverProblem::new(nodes, edges, sites, reach_m, settings.tolerate_missed_reads)
            .map_err(|m| Error::InvalidParameter(format!("network coverage instance: {m}")))?;
    Ok(Built {
        problem,
        edge_dir,
        site_mounting,
        site_existing,
        edge_speed: edge_speed_v,
        existing_off,
        directed_length_m,
        physical_edges: physical,
        edge_scale: vec![1.0; physical],
    })
}

/// A point of a section at `offset` from its start: centreline
/// (lat, lon in degrees), ENU, the road offset and the digitised heading
/// (ENU unit vector).
fn section_point(
    net: &Network,
    sec: SectionId,
    offset: f64,
) -> ([f64; 2], [f64; 2], f64, [f64; 2]) {
    let segs = net.section_segments(sec);
    let i = segs
        .partition_point(|g| g.section_offset_m + g.length_m < offset)
        .min(segs.len() - 1);
    let g = &segs[i];
    let t = if g.length_m > 0.0 {
        ((offset - g.section_offset_m) / g.length_m).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let ll = [
        g.a_lat_lon[0] + t * (g.b_lat_lon[0] - g.a_lat_lon[0]),
        g.a_lat_lon[1] + t * (g.b_lat_lon[1] - g.a_lat_lon[1]),
    ];
    let enu = [
        g.a[0] + t * (g.b[0] - g.a[0]),
        g.a[1] + t * (g.b[1] - g.a[1]),
    ];
    let (dx, dy) = (g.b[0] - g.a[0], g.b[1] - g.a[1]);
    let n = dx.hypot(dy).max(1e-12);
    (ll, enu, g.road_offset_m + t * g.length_m, [dx / n, dy / n])
}

/// Names the roads of a walk for an infeasibility report.
fn describe_walk(net: &Network, built: &Built, w: &Walk) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut seen = BTreeSet::new();
    let mut pieces: Vec<&(u32, f64, f64)> = w.pieces.iter().collect();
    pieces.sort_by(|a, b| (b.2 - b.1).total_cmp(&(a.2 - a.1)));
    for &&(e, a, b) in pieces
        .iter()
        .filter(|p| (p.0 as usize) < built.physical_edges)
        .take(3)
    {
        let (sec, fwd) = built.edge_dir[e as usize];
        if !seen.insert((sec, fwd)) {
            continue;
        }
        let f = built.edge_scale[e as usize];
        let (a, b) = (a / f, b / f);
        let s = &net.sections[sec as usize];
        let len = s.length_m;
        let (sa, sb) = if fwd { (a, b) } else { (len - b, len - a) };
        let (_, _, ra, _) = section_point(net, sec, sa);
        let (_, _, rb, _) = section_point(net, sec, sb);
        let at = &net.roads[s.road as usize].attributes;
        parts.push(format!(
            "road {}{} ({} its digitised direction, chainage {:.0}–{:.0} m{})",
            at.id,
            at.name
                .as_ref()
                .map(|n| format!(" \"{n}\""))
                .unwrap_or_default(),
            if fwd { "along" } else { "against" },
            ra.min(rb),
            ra.max(rb),
            if at.tunnel { ", tunnel" } else { "" }
        ));
    }
    parts.join(", ")
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
    let (map, _, _) = map_route(scn)?;
    let t0 = Instant::now();
    let net = Network::load(map, &Default::default())?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut plan = plan_network_on(scn, settings, &net)?;
    plan.timings_ms.insert("load".into(), load_ms);
    if validate && settings.validation_runs > 0 {
        plan.validation = Some(validate_network_plan(
            scn,
            &net,
            &plan,
            settings.validation_runs,
            seed,
        )?);
    }
    Ok(plan)
}

/// [`plan_network`] on a loaded network, without validation.
pub fn plan_network_on(
    scn: &Scenario,
    settings: &PlannerSettings,
    net: &Network,
) -> Result<NetworkPlan> {
    let (_, profile, height_m) = map_route(scn)?;
    let (spacing, u_turns) = check_settings(scn, settings)?;
    let req = settings.requirement_m;
    let k = settings.tolerate_missed_reads;
    settings.check_best_fix(&scn.rfid)?;
    let mut timings = BTreeMap::new();
    // Instance with a placeholder reach, to learn the speed classes and mountings.
    let t = Instant::now();
    let mut built = build(net, settings, profile.speed_mps, spacing, 1.0, u_turns)?;
    timings.insert("build".into(), t.elapsed().as_secs_f64() * 1e3);
    // Reach per (speed, mounting) class in use.
    let t = Instant::now();
    let speeds: BTreeSet<u64> = built
        .edge_speed
        .iter()
        .map(|v| (v * 3.6 * 100.0).round() as u64)
        .collect();
    let mountings: BTreeSet<&'static str> =
        built.site_mounting.iter().map(|m| m.as_str()).collect();
    let classes: Vec<(f64, Mounting)> = speeds
        .iter()
        .flat_map(|&s| {
            mountings
                .iter()
                .filter_map(move |m| Mounting::parse(m).map(|m| (s as f64 / 360.0, m)))
        })
        .collect();
    if classes.is_empty() {
        return Err(Error::InvalidParameter(
            "no candidate site: none of planner.mountings is allowed on any road (ceiling only in tunnels)"
                .into(),
        ));
    }
    let origin = net.frame.origin();
    let reach_classes: Vec<ReachClass> = classes
        .par_iter()
        .map(|&(v, m)| reach_class(scn, origin.lat, origin.lon, height_m, v, m, req))
        .collect::<Result<Vec<_>>>()?;
    timings.insert("reach".into(), t.elapsed().as_secs_f64() * 1e3);
    let steady = reach_classes
        .iter()
        .map(|c| c.steady_reach_m)
        .fold(f64::INFINITY, f64::min);
    let start = reach_classes
        .iter()
        .map(|c| c.start_reach_m)
        .fold(f64::INFINITY, f64::min);
    // Reach per speed class: the smallest over the mountings in use, steady
    // and from the prior.
    let key = |v: f64| (v * 3.6 * 100.0).round() as u64;
    let mut class_reach: BTreeMap<u64, f64> = BTreeMap::new();
    for (c, &(v, _)) in reach_classes.iter().zip(&classes) {
        let r = class_reach.entry(key(v)).or_insert(f64::INFINITY);
        *r = r.min(c.steady_reach_m.min(c.start_reach_m));
    }
    let reach_m = class_reach.values().copied().fold(f64::INFINITY, f64::min);
    let r_ref = class_reach.values().copied().fold(0.0, f64::max);
    if !(reach_m > 0.0 && r_ref.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "infeasible: the {req} m requirement leaves no distance between fixes (reach 0 m)"
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
    let infeasible = |w: &Walk| -> Error {
        let metres: f64 = w
            .pieces
            .iter()
            .filter(|x| (x.0 as usize) < built.physical_edges)
            .map(|x| (x.2 - x.1) / built.edge_scale[x.0 as usize])
            .sum();
        Error::InvalidParameter(format!(
            "infeasible: the {req} m requirement cannot be held with {k} missed read(s) tolerated on a walk of \
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
    let (greedy_sel, st) = match cover::greedy_with_stats(p) {
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
            method.push_str(&greedy_method);
            greedy_sel
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
    };
    // Tags.
    let mut tags = Vec::new();
    let mut n_new = 0;
    let mut total_cost = 0.0;
    for (i, site) in p.sites.iter().enumerate() {
        if !sel[i] {
            continue;
        }
        let (sec, fwd) = built.edge_dir[site.edge as usize];
        let s = &net.sections[sec as usize];
        let a = &net.roads[s.road as usize].attributes;
        let at = site.at_m / built.edge_scale[site.edge as usize];
        let off = if fwd { at } else { s.length_m - at };
        let (ll, enu, chain, dir) = section_point(net, sec, off);
        let oneway = s.oneway.is_oneway();
        let lane = if oneway { 0.0 } else { 0.5 * lane_width_m(a) };
        // Right of travel: digitised right when forward, left when backward.
        let sign = if fwd { 1.0 } else { -1.0 };
        let right = [dir[1] * sign, -dir[0] * sign];
        let g = net
            .frame
            .to_geodetic([enu[0] + lane * right[0], enu[1] + lane * right[1], 0.0]);
        let existing = built.site_existing[i].map(|ti| &settings.existing_tags[ti]);
        let m = built.site_mounting[i];
        let (sa, sc) = scn.rfid.fix_sigmas(m, built.edge_speed[site.edge as usize]);
        if existing.is_none() {
            n_new += 1;
            total_cost += site.cost;
        }
        tags.push(NetworkTag {
            tag_id: existing.map_or_else(|| format!("N{n_new:05}"), |t| t.id.clone()),
            lat: existing.map_or(g.lat_deg(), |t| t.lat.to_degrees()),
            lon: existing.map_or(g.lon_deg(), |t| t.lon.to_degrees()),
            centre_lat: ll[0],
            centre_lon: ll[1],
            height_m: existing.and_then(|t| t.height_m).unwrap_or(height_m),
            road_id: a.id.clone(),
            road_name: a.name.clone(),
            chainage_m: chain,
            digitised_forward: fwd,
            oneway,
            mounting: m,
            expected_fix_sigma_m: sa.max(sc),
            tunnel: a.tunnel,
            existing: existing.is_some(),
            cost: site.cost,
            lane_offset_m: lane,
            edge: site.edge,
            section: sec,
        });
    }
    let existing_kept = tags.iter().filter(|t| t.existing).count();
    Ok(NetworkPlan {
        scenario: scn.file.name.clone(),
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
        u_turns: match u_turns {
            UTurns::Anywhere => "anywhere".into(),
            UTurns::DeadEnds => "dead_ends".into(),
        },
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
        timings_ms: timings,
        validation: None,
        selected: sel,
        problem: Some(built.problem),
    })
}

/// Monte Carlo validation over `runs` runs on seeded random
/// origin–destination shortest paths (1.5–4 km where the map allows; up to
/// 10 paths, the runs split between them).
pub fn validate_network_plan(
    scn: &Scenario,
    net: &Network,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
) -> Result<NetworkValidation> {
    use rand::{Rng, SeedableRng};
    let (_, profile, height_m) = map_route(scn)?;
    let runs = runs.max(1);
    let n_paths = runs.min(10) as usize;
    let per_path = runs.div_ceil(n_paths as u64);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6e65_7477_6f72_6b00);
    let nodes = &net.nodes;
    if nodes.len() < 2 {
        return Err(Error::InvalidParameter(
            "the network is too small to sample validation paths".into(),
        ));
    }
    let (mut within, mut total) = (0.0, 0.0);
    let mut worst = (0.0f64, 0usize, 0u64, 0.0, 0.0, [0.0, 0.0], None);
    let mut paths = 0usize;
    let mut length = 0.0;
    let mut attempts = 0;
    while paths < n_paths && attempts < 20 * n_paths {
        attempts += 1;
        let o = rng.random_range(0..nodes.len());
        let mut best: Option<(usize, f64)> = None;
        for _ in 0..100 {
            let d = rng.random_range(0..nodes.len());
            let dist = (nodes[o].enu[0] - nodes[d].enu[0]).hypot(nodes[o].enu[1] - nodes[d].enu[1]);
            if (1500.0..=4000.0).contains(&dist) {
                best = Some((d, dist));
                break;
            }
            if dist <= 4000.0 && best.is_none_or(|b| dist > b.1) {
                best = Some((d, dist));
            }
        }
        let Some((d, dist)) = best else { continue };
        if dist < 200.0 {
            continue;
        }
        let Ok(route) = crate::route::plan_route(net, &[nodes[o].lat_lon, nodes[d].lat_lon]) else {
            continue;
        };
        if route.length_m < 200.0 {
            continue;
        }
        let Ok(rp) = RoutePlan::new(net, &route, profile, &[], height_m, scn.dt) else {
            continue;
        };
        let dirs: HashSet<(SectionId, bool)> = route
            .spans
            .iter()
            .map(|s| (s.section.section, s.section.forward))
            .collect();
        let tags = plan.sim_tags(Some(&dirs));
        let truth = TruthSource::Route(Box::new(rp));
        let res = simulate_with(
            scn,
            &truth,
            &tags,
            per_path,
            seed + 1000 * paths as u64,
            None,
        )?;
        length += route.length_m;
        for r in &res.runs {
            for w in r.rows.windows(2) {
                let dd = (w[1].distance_m - w[0].distance_m).max(0.0);
                total += dd;
                if w[1].horizontal_m <= plan.requirement_m {
                    within += dd;
                }
            }
            for row in &r.rows {
                if row.horizontal_m > worst.0 {
                    worst = (
                        row.horizontal_m,
                        paths,
                        r.run,
                        row.t_s,
                        row.distance_m,
                        [0.0, 0.0],
                        None,
                    );
                }
            }
        }
        if worst.1 == paths && worst.0 > 0.0 {
            // Where the worst point is (truth position at its time).
            if let Some(a) = truth.samples().find(|a| a.t >= worst.3 - 0.5 * scn.dt) {
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
        paths += 1;
    }
    if paths == 0 {
        return Err(Error::InvalidParameter(
            "no validation path could be sampled on the network (too small or disconnected)".into(),
        ));
    }
    Ok(NetworkValidation {
        runs: per_path * paths as u64,
        paths,
        runs_per_path: per_path,
        paths_length_km: length / 1000.0,
        seed,
        fraction_within_requirement: if total > 0.0 { within / total } else { 1.0 },
        max_horizontal_error_m: worst.0,
        worst_path: worst.1,
        worst_run: worst.2,
        worst_t_s: worst.3,
        worst_distance_m: worst.4,
        worst_lat: worst.5[0],
        worst_lon: worst.5[1],
        worst_road_id: worst.6,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::{model_from_polylines, Oneway, RoadAttributes};

    fn road(id: &str, oneway: Oneway, maxspeed: Option<f64>) -> RoadAttributes {
        RoadAttributes {
            id: id.into(),
            name: Some(format!("Street {id}")),
            highway: "residential".into(),
            oneway,
            lanes: None,
            width_m: None,
            maxspeed_kmh: maxspeed,
            tunnel: false,
            bridge: false,
            layer: 0,
        }
    }

    /// A 600 m × 600 m block near Helsinki: four two-way streets and a
    /// one-way diagonal.
    fn block() -> Network {
        let (la, lo) = (60.17f64, 24.94f64);
        let dlat = 600.0 / 111_400.0;
        let dlon = 600.0 / (111_400.0 * la.to_radians().cos());
        let c = [
            [la, lo],
            [la, lo + dlon],
            [la + dlat, lo + dlon],
            [la + dlat, lo],
        ];
        let mut roads = Vec::new();
        for i in 0..4 {
            roads.push((
                road(&format!("{}", i + 1), Oneway::Both, Some(50.0)),
                vec![vec![c[i], c[(i + 1) % 4]]],
            ));
        }
        roads.push((
            road("9", Oneway::Forward, Some(30.0)),
            vec![vec![c[0], c[2]]],
        ));
        Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap()
    }

    fn scenario() -> Scenario {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenarios/helsinki-network-plan.toml");
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("candidate_spacing_m = 50", "candidate_spacing_m = 200");
        Scenario::parse(&path, &text).unwrap()
    }

    #[test]
    fn small_network_is_planned_exactly_and_verified() {
        let scn = scenario();
        let s = PlannerSettings::from_scenario(&scn).unwrap();
        let net = block();
        let p = plan_network_on(&scn, &s, &net).unwrap();
        // 4 two-way streets + 1 one-way: 9 directed edges, ⌈ℓ / 200 m⌉
        // candidates each.
        assert_eq!(p.directed_edges, 9);
        let want: usize = net
            .sections
            .iter()
            .map(|x| {
                let n = (x.length_m / 200.0).ceil() as usize;
                if x.oneway.is_oneway() {
                    n
                } else {
                    2 * n
                }
            })
            .sum();
        assert_eq!(p.candidates, want);
        assert!((25..=40).contains(&want), "{want}");
        assert!(p.method.starts_with("exact"), "{}", p.method);
        assert!(p.verified);
        let prob = p.problem.as_ref().unwrap();
        assert!(cover::check(prob, &p.selected).feasible());
        // Exact: the lower bound is the optimum's cost, and the greedy is
        // never cheaper.
        assert!((p.lower_bound_cost - p.total_cost).abs() < 1e-9);
        if let Solved::Feasible(g) = cover::greedy(prob) {
            assert!(g.iter().filter(|&&x| x).count() >= p.tag_count());
        }
        // The 30 km/h one-way street adds a slower speed class.
        assert!(p
            .reach_classes
            .iter()
            .any(|c| (c.speed_kmh - 30.0).abs() < 1e-6));
        // Every two-way street forms a cycle with its U-turns: ≥ 1 tag each.
        assert!(p.tag_count() >= 4);
        // Tags on the one-way street sit on its centreline, others on the
        // lane right of travel.
        for t in &p.tags {
            assert_eq!(t.oneway, t.road_id == "9");
        }
        // U-turns only at dead ends (there are none here): fewer walks, so
        // the optimum cannot cost more; still exact and verified.
        let path = scn.path.clone();
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("candidate_spacing_m = 50", "candidate_spacing_m = 200")
            .replace(
                "coverage = \"network\"",
                "coverage = \"network\"\nu_turns = \"dead_ends\"",
            );
        let scn2 = Scenario::parse(&path, &text).unwrap();
        let p2 = plan_network_on(&scn2, &s, &net).unwrap();
        assert_eq!(p2.u_turns, "dead_ends");
        assert!(
            p2.verified && p2.method.starts_with("exact"),
            "{}",
            p2.method
        );
        assert!(p2.total_cost <= p.total_cost);
        assert_eq!(p2.directed_edges, 9);
        let bad = text.replace("\"dead_ends\"", "\"sometimes\"");
        let scn3 = Scenario::parse(&path, &bad).unwrap();
        let e = plan_network_on(&scn3, &s, &net).unwrap_err().to_string();
        assert!(e.contains("not one of anywhere, dead_ends"), "{e}");
    }

    #[test]
    fn reach_analysis_agrees_with_the_route_budget_on_a_straight_drive() {
        // The same straight drive north as a motion-command route: the route
        // planner's covariance budget (budget.rs) must find the same start
        // reach and the same reach after a fix where the bound first exceeds
        // the requirement (to one IMU sample: 50 km/h × 10 ms = 0.14 m).
        let text = r#"name = "straight"
requirement_m = 20.0
[[route]]
start = { lat = 60.17, lon = 24.94, height_m = 0.0, heading_deg = 0.0, speed_kmh = 50 }
motion = [ { kind = "cruise", distance_m = 12000 } ]
[navigator]
mode = "integrated"
[imu]
rate_hz = 100
gyro_bias_dph = [10, 10, 10]
accel_bias_ug = [1000, 1000, 1000]
gyro_arw_dprh = 0.3
accel_vrw_ugprhz = 100
[odometer]
scale_factor_error = 0.01
[aiding]
odometer = true
baro = true
rfid = true
"#;
        let scn = Scenario::parse(std::path::Path::new("straight.toml"), text).unwrap();
        let truth = TruthSource::new(&scn).unwrap();
        let budget = crate::planner::budget::Budget::new(&scn, &truth, None);
        let req = 20.0;
        let m = Mounting::RoadSurface;
        let c = reach_class(
            &scn,
            60.17f64.to_radians(),
            24.94f64.to_radians(),
            0.0,
            50.0 / 3.6,
            m,
            req,
        )
        .unwrap();
        let r0 = budget.start_reach(req);
        assert!(
            (c.start_reach_m - r0).abs() < 0.2,
            "{} vs {r0}",
            c.start_reach_m
        );
        assert!(c.start_reach_m > 500.0 && c.start_reach_m < 10_000.0);
        // The fix sample: the first past the start reach.
        let fix_at = budget
            .samples()
            .iter()
            .find(|x| x.avp.distance_m > r0 + 1e-9)
            .unwrap()
            .avp
            .distance_m;
        let (_, sites) = budget.tag_free(100.0, &[fix_at]);
        let (_, reach_abs) = budget.reaches(&sites, &[m], req)[0];
        let period = reach_abs - sites[0].distance_m;
        assert!(
            (c.periods_m[0] - period).abs() < 0.2,
            "{:?} vs {period}",
            c.periods_m
        );
        assert!(!c.capped && c.steady_reach_m <= c.periods_m[0]);
    }

    #[test]
    fn speed_classes_round_down_to_5_kmh_and_respect_the_scenario_speed() {
        let v = 50.0 / 3.6;
        assert!((edge_speed(v, Some(30.0)) * 3.6 - 30.0).abs() < 1e-9);
        assert!((edge_speed(v, Some(80.0)) * 3.6 - 50.0).abs() < 1e-9);
        assert!((edge_speed(v, None) * 3.6 - 50.0).abs() < 1e-9);
        assert!((edge_speed(v, Some(3.0)) * 3.6 - 3.0).abs() < 1e-9);
        assert!((edge_speed(v, Some(8.0)) * 3.6 - 5.0).abs() < 1e-9);
        assert!((edge_speed(v, Some(47.0)) * 3.6 - 45.0).abs() < 1e-9);
    }
}
