//! The types of a network plan: its tags, its Monte Carlo validation and
//! the plan itself.

use super::cover::CoverProblem;
use super::reach::ReachClass;
use crate::network::SectionId;
use crate::sim::tags::{Mounting, Tag};
use serde::Serialize;
use std::collections::{BTreeMap, HashSet};

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
    #[serde(serialize_with = "crate::planner::plan::ser_mounting")]
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
    /// Why the plan needs a tag here.
    pub reason: String,
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
    /// Sampled chains of trips.
    pub paths: usize,
    /// Runs per chain.
    pub runs_per_path: u64,
    /// Total length of the chains (km).
    pub paths_length_km: f64,
    /// Base seed.
    pub seed: u64,
    /// Fraction of distance (all runs, all paths) within the requirement.
    pub fraction_within_requirement: f64,
    /// Largest horizontal error (m).
    pub max_horizontal_error_m: f64,
    /// Where: path index, run, time (s), distance along the path (m).
    pub worst_path: usize,
    /// Hours driven per run over all chains.
    pub chain_hours: f64,
    /// Error samples thinned for the interval (one per 30 s per run).
    pub thinned_samples: usize,
    /// Of which within the requirement.
    pub thinned_within: usize,
    /// One-sided 95 % Clopper–Pearson lower bound of the share within.
    pub share_lower_95: f64,
    /// The share required (`requirement_confidence`).
    pub requirement_confidence: f64,
    /// The rule holds.
    pub passed: bool,
    /// The rule in words, with the figures.
    pub rule: String,
    /// Runs whose maximum error exceeds the requirement.
    pub runs_exceeding: usize,
    /// Median over runs of each run's maximum error (m).
    pub median_run_max_m: f64,
    /// Map-matching fixes fed (all runs).
    pub map_matching_fed: u64,
    /// Share of them on the wrong road.
    pub map_matching_wrong_road_share: f64,
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
    /// Thinned samples where the planner's own budget along the drive,
    /// without tags, exceeds 1 (its predicted bound would pass the
    /// requirement there had no tag been read since the last turn map
    /// matching observes): the only samples where the validation tests
    /// what the tags are for.
    /// `None` for plans without map matching's credit (no budget resets).
    pub over_budget_samples: Option<usize>,
    /// Of which within the requirement.
    pub over_budget_within: Option<usize>,
    /// Largest horizontal error (m) at any 1 Hz sample over budget (0 when
    /// none).
    pub over_budget_max_error_m: Option<f64>,
    /// Largest budget without tags met on the validation drives (1: the
    /// predicted bound reaches the requirement).
    pub max_budget_without_tags: Option<f64>,
    /// `any_walk`: the walk DP's worst walks driven with their tags missed.
    pub design_walks: Option<DesignWalkValidation>,
    /// `plan --baseline`: the same chains, runs and seeds driven with only
    /// the installed tags (none in a fresh plan): what the navigator does
    /// without the planned tags. `None` without `--baseline`.
    pub without_new_tags: Option<NoTagsValidation>,
    /// `plan --baseline`: the stretches where the planner's budget without
    /// tags passes 1, driven with and without the new tags. `None` without
    /// `--baseline` or when no searched chain passes 1.
    pub over_budget_stretches: Option<StretchValidation>,
    /// `plan --baseline` with two reach levels: the stretches the
    /// calibrated level credits (over budget at the single reach, within
    /// it at the two levels), each driven from its chain's start, with and
    /// without the new tags (`super::calibrated_stretches`; its
    /// `peak_budget_*` are budgets at the single reach, `lead_in_m` the
    /// longest drive before a stretch). `None` otherwise, or when no
    /// searched chain has one.
    pub credited_stretches: Option<StretchValidation>,
}

/// The stretches of fresh chains of the plan's traffic where the
/// planner's budget without tags passes 1 (its predicted bound would pass the requirement),
/// each driven from a lead-in before its resetting turn to the next reset,
/// with the plan's tags and without the new ones (same runs and seeds),
/// judged on the samples over budget by the validation's rule.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StretchValidation {
    /// Fresh chains searched for stretches (sampled, not driven).
    pub searched_chains: usize,
    /// Stretches driven (the largest budgets first).
    pub stretches: usize,
    /// Runs per stretch, each way.
    pub runs_per_stretch: u64,
    /// Route driven before each stretch's resetting turn (m).
    pub lead_in_m: f64,
    /// Smallest and largest budget at a driven stretch's end.
    pub peak_budget_min: f64,
    /// Largest budget at a driven stretch's end.
    pub peak_budget_max: f64,
    /// With the plan's tags.
    pub with_tags: StretchFigures,
    /// With only the installed tags (none in a fresh plan).
    pub without_new_tags: StretchFigures,
}

/// The share rule's figures on thinned samples (`share_rule`): one side of
/// [`StretchValidation`], and flattened into [`DesignWalkValidation`].
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct StretchFigures {
    /// Samples thinned (one per 30 s per run, and each run's end; over
    /// budget only for a stretch).
    pub thinned_samples: usize,
    /// Of which within the requirement.
    pub thinned_within: usize,
    /// One-sided 95 % Clopper–Pearson lower bound of the share within.
    pub share_lower_95: f64,
    /// The rule holds.
    pub passed: bool,
    /// The rule in words, with the figures.
    pub rule: String,
    /// Runs whose maximum (over budget, for a stretch) exceeds the
    /// requirement.
    pub runs_exceeding: usize,
    /// Largest horizontal error (m; over budget, for a stretch).
    pub max_horizontal_error_m: f64,
}

/// The validation's baseline: the same chains, runs and seeds as the
/// plan's validation, driven with only the installed tags (none in a fresh
/// plan), judged by the same rule.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoTagsValidation {
    /// Installed tags kept in the baseline (0 in a fresh plan).
    pub tags: usize,
    /// Share of run time within the requirement.
    pub fraction_within_requirement: f64,
    /// Error samples thinned for the interval (one per 30 s per run).
    pub thinned_samples: usize,
    /// Of which within the requirement.
    pub thinned_within: usize,
    /// One-sided 95 % Clopper–Pearson lower bound of the share within.
    pub share_lower_95: f64,
    /// The rule holds without the planned tags.
    pub passed: bool,
    /// The rule in words, with the figures.
    pub rule: String,
    /// Runs whose maximum error exceeds the requirement.
    pub runs_exceeding: usize,
    /// Median over runs of each run's maximum error (m).
    pub median_run_max_m: f64,
    /// Of the validation's samples over budget (`over_budget_samples`),
    /// those within the requirement without the planned tags (`None`
    /// without map matching's credit).
    pub over_budget_within: Option<usize>,
    /// Largest error (m) at any 1 Hz sample over budget, without the tags.
    pub over_budget_max_error_m: Option<f64>,
    /// Largest horizontal error (m).
    pub max_horizontal_error_m: f64,
    /// Chain of the worst point.
    pub worst_path: usize,
    /// Run of the worst point.
    pub worst_run: u64,
    /// Time of the worst point (s).
    pub worst_t_s: f64,
    /// Latitude of the worst point (degrees).
    pub worst_lat: f64,
    /// Longitude of the worst point (degrees).
    pub worst_lon: f64,
    /// Road of the worst point (input id), when found.
    pub worst_road_id: Option<String>,
    /// Share of map-matching fixes on the wrong road.
    pub map_matching_wrong_road_share: f64,
}

/// `any_walk` plans: the validation on the walk DP's worst walks, each
/// driven from its lead-in with the (at most k) tags on it missed on
/// purpose and every other tag read: the design case itself.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignWalkValidation {
    /// Walks driven.
    pub walks: usize,
    /// Runs per walk.
    pub runs_per_walk: u64,
    /// The rule on the samples from each walk's start; its largest error
    /// is at the walk `worst_walk`.
    #[serde(flatten)]
    pub figures: StretchFigures,
    /// Index of that walk in `design_walks`.
    pub worst_walk: usize,
    /// Per walk: the largest error over its runs (m).
    pub walk_max_m: Vec<f64>,
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
    /// Reach levels the chains were budgeted with: 2 (the early reach until
    /// a chain is calibrated, the calibrated reach after: `trips` with map
    /// matching and `planner.reach_levels = 2`), else 1.
    pub reach_levels: u8,
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
    /// The traffic served: "trips" or "any_walk".
    pub traffic: String,
    /// Map matching credited by the error model.
    pub map_matching: bool,
    /// The vehicles' speed (km/h), capped per road by maxspeed or class.
    pub vehicle_speed_kmh: f64,
    /// Probability with which the error must lie within the requirement
    /// (the bound's confidence).
    pub requirement_confidence: f64,
    /// What "within the requirement" means for this plan, in words.
    pub rule: String,
    /// The scenario's `[[route]]` was ignored (network coverage needs the
    /// map alone).
    pub route_ignored: bool,
    /// The map-matching reach per speed class and mounting (map matching
    /// on).
    pub matched_reach: Vec<super::mm_reach::MatchedReach>,
    /// `trips`: the stated guarantee.
    pub guarantee: Option<super::trips::TripsGuarantee>,
    /// `trips`: budget windows in the planning set.
    pub windows: usize,
    /// `trips`: site ids over those windows (what their memory grows with).
    pub window_ids: usize,
    /// `trips`: km of driving in the planning sample.
    pub planning_km: f64,
    /// `any_walk`: the walk DP's worst walks (longest first), which the
    /// validation drives with their tags missed.
    pub design_walks: Vec<super::walks::DesignWalk>,
    /// `trips`: the planning windows (site ids that must hold k + 1 tags).
    #[serde(skip)]
    pub planning_windows: super::WindowSets,
    /// The traffic model (edges and destinations) the validation samples
    /// its chains from.
    #[serde(skip)]
    pub(crate) chain_model: Option<std::sync::Arc<super::traffic::ChainModel>>,
    /// Per directed edge: what the plan predicts (for `coverage.geojson`).
    #[serde(skip)]
    pub edge_coverage: Vec<super::coverage::EdgeCoverage>,
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
