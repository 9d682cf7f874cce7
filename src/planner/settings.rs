//! Planner settings: the scenario's `[planner]` read and checked once with
//! its defaults, the mountings' costs and read probabilities, and the road
//! quantities (lane width, speed at a site) the planners share.

use crate::error::{Error, Result};
use crate::network::RoadAttributes;
use crate::scenario::{NavMode, Scenario};
use crate::sim::bound::bound95_of_sigmas;
use crate::sim::tags::{Mounting, RfidModel, Tag};

/// Default read probability of a tag (the RFID paper's field test).
pub const DEFAULT_READ_PROBABILITY: f64 = 0.977;

/// Lane width (m) of a road from its OSM attributes: `width / lanes` when
/// both are given (a carriageway width over its lanes), else a default by
/// road class. The one definition is [`crate::network::lane_width_m`]
/// (shared with the simulated vehicle's lane).
pub fn lane_width_m(a: &RoadAttributes) -> f64 {
    crate::network::lane_width_m(a)
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
    bound95_of_sigmas([a, c])
}

pub use crate::scenario::Coverage;

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
    /// `traffic = "trips"`: most site ids over the plan's budget windows
    /// (a memory limit; [`MAX_TRIPS_WINDOW_IDS`](crate::planner::network::MAX_TRIPS_WINDOW_IDS)
    /// unless a caller lowers it).
    pub max_window_ids: usize,
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
            if o.read_probability <= 0.0 {
                // Tags that are never read cannot hold any bound: a plan of
                // them would be tags for nothing (validated as dead
                // reckoning).
                return Err(bad(format!(
                    "{m} tags are never read (rfid.read_probability or \
                     rfid.read_probability_{m} = 0): planning needs a read probability above 0, \
                     or planner.mountings without {m}",
                    m = c.mounting
                )));
            }
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
        if let Some(f) = &p.existing_tags {
            crate::sim::tags::refuse_ids_of_scenario_tags(f, &existing_tags, scn)?;
        }
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
            max_window_ids: crate::planner::network::MAX_TRIPS_WINDOW_IDS,
        })
    }
}

/// Ids of a plan's new tags: `prefix` and a number of `width` digits from
/// 1 on, skipping the ids of the installed tags (`existing_tags`) and of
/// the scenario's `[[tag]]`s. A re-plan with part of an earlier plan
/// installed (its `T0001` and `T0003`, say) numbered its new tags from
/// `T0001` again: two tags of one id in `tags.csv` and `plan.json`.
pub(crate) struct NewTagIds {
    prefix: &'static str,
    width: usize,
    n: usize,
    taken: std::collections::HashSet<String>,
}

impl NewTagIds {
    pub(crate) fn new(
        prefix: &'static str,
        width: usize,
        scn: &Scenario,
        settings: &PlannerSettings,
    ) -> Self {
        let taken = settings
            .existing_tags
            .iter()
            .map(|t| t.id.clone())
            .chain(scn.tags().iter().map(|t| t.id.clone()))
            .collect();
        Self {
            prefix,
            width,
            n: 0,
            taken,
        }
    }

    /// The next free id.
    pub(crate) fn next_id(&mut self) -> String {
        loop {
            self.n += 1;
            let id = format!("{}{:0w$}", self.prefix, self.n, w = self.width);
            if !self.taken.contains(&id) {
                return id;
            }
        }
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
            return Err(Error::Infeasible(format!(
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
            lanes,
            width_m: width,
            maxspeed_kmh: Some(50.0),
            ..RoadAttributes::new("1", highway, oneway)
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
