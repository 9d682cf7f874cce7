//! The plan of a route: its tags, its Monte Carlo validation and the
//! uniform-spacing baseline it is compared with.

use super::budget::BudgetPoint;
use crate::sim::tags::{Mounting, Tag};
use serde::Serialize;
use std::collections::BTreeMap;

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
    /// Why the tag is there, with its figures (`route_tag_reasons`).
    pub reason: String,
}

/// Each tag's reason, from the figures the placement worked with: the
/// constraint of docs/DESIGN.md §3 (placement.rs) is that after any fix
/// (or the start, on the prior) the next `k + 1` tags stand within its
/// reach, so a tag's reason names the fix `k + 1` tags back (its anchor:
/// the start for the first `k + 1` tags), that fix's reach, and where the
/// tag stands in that reach; then what the tag's own fix gives. Installed
/// tags say so. `speeds_mps[i]` is the vehicle's speed at tag `i`.
pub(super) fn route_tag_reasons(
    tags: &mut [PlannedTag],
    speeds_mps: &[f64],
    start_reach_m: f64,
    length_m: f64,
    requirement_m: f64,
    k: usize,
) {
    let to = |e: f64| {
        if e >= length_m - 1e-6 {
            format!("the route's end ({length_m:.0} m)")
        } else {
            format!("{e:.0} m")
        }
    };
    let reasons: Vec<String> = (0..tags.len())
        .map(|j| {
            let t = &tags[j];
            let own = format!(
                "its fix (bound {:.2} m) holds the bound to {}",
                t.bound_after_fix_m,
                to(t.reach_m)
            );
            if t.existing {
                return format!("installed already; {own}");
            }
            let (anchor, at, reach, pos) = match j.checked_sub(k + 1) {
                None => (
                    "the start (the prior)".to_string(),
                    0.0,
                    start_reach_m,
                    j + 1,
                ),
                Some(a) => (
                    format!(
                        "the fix at {} ({:.0} m, {:.0} km/h)",
                        tags[a].tag_id,
                        tags[a].route_distance_m,
                        speeds_mps.get(a).copied().unwrap_or(f64::NAN) * 3.6
                    ),
                    tags[a].route_distance_m,
                    tags[a].reach_m,
                    k + 1,
                ),
            };
            let within = if t.route_distance_m <= reach + 1e-6 {
                "within it"
            } else {
                "past it"
            };
            let misses = if k == 0 {
                "with no missed read tolerated, the next tag".to_string()
            } else {
                format!(
                    "with {k} missed read(s) tolerated, each of the next {} tags",
                    k + 1
                )
            };
            format!(
                "{anchor} holds the {requirement_m:.0} m bound to {} (reach {:.0} m); \
                 {misses} must stand within it: this is #{pos}, at {:.0} m along the route, {within}; {own}",
                to(reach),
                (reach.min(length_m) - at).max(0.0),
                t.route_distance_m,
            )
        })
        .collect();
    for (t, r) in tags.iter_mut().zip(reasons) {
        t.reason = r;
    }
}

pub(super) fn ser_mounting<S: serde::Serializer>(
    m: &Mounting,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
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
    /// Runs whose horizontal error exceeds the requirement somewhere.
    pub runs_exceeding_requirement: u64,
    /// The rule of the area planner, applied to the route (docs/DESIGN.md
    /// §3.4): the share of run time within the requirement, one sample
    /// per 30 s per run, must have its one-sided 95 % Clopper–Pearson
    /// lower bound at least `requirement_confidence`.
    pub requirement_confidence: f64,
    /// Thinned samples, and those within the requirement.
    pub thinned_samples: u64,
    /// Thinned samples within the requirement.
    pub thinned_within: u64,
    /// One-sided 95 % Clopper–Pearson lower bound of the share within.
    pub share_lower_95: f64,
    /// The rule held.
    pub passed: bool,
    /// The rule in words, with its figures.
    pub rule: String,
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
    /// Largest predicted 95 % bound with any `tolerate_missed_reads`
    /// consecutive tags missed (m), when computed ([`Plan::missed_bound`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_max_bound95_missed_m: Option<f64>,
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
    /// What the planning cost, in perfect-data filter passes over the
    /// route (all filter steps on every thread over the route's samples,
    /// [`super::Budget::passes`]): a figure that does not depend on the
    /// machine or its load.
    pub filter_passes: f64,
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
    /// Spacings tried (m) and their fractions within the requirement by
    /// the Monte Carlo (NaN: not simulated). The search bisects on the
    /// covariance check and simulates only the longest spacing passing it
    /// (and, should that fail the Monte Carlo, shorter ones by bisection),
    /// so NaN marks a spacing that failed the covariance check or one
    /// shorter than a simulated spacing that passed.
    pub tried: Vec<(f64, f64)>,
    /// The search's covariance checks in filter passes over the route
    /// ([`Plan::filter_passes`]; its Monte Carlo runs not counted).
    pub filter_passes: f64,
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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tag(id: &str, at: f64, reach: f64, existing: bool) -> PlannedTag {
        PlannedTag {
            tag_id: id.into(),
            lat: 0.0,
            lon: 0.0,
            height_m: 0.0,
            route_distance_m: at,
            road_chainage_m: None,
            t_s: 0.0,
            mounting: Mounting::RoadSurface,
            expected_fix_sigma_m: 0.5,
            road_id: None,
            existing,
            tunnel: false,
            lane_width_m: None,
            digitised_forward: None,
            bound_after_fix_m: 0.5,
            reach_m: reach,
            reason: String::new(),
        }
    }

    #[test]
    fn reasons_name_the_fix_k_plus_1_back_and_its_reach() {
        // k = 1 on a 5000 m route, start reach 1500 m: T1 and T2 are the two
        // tags within the start's reach; T3 is anchored on T1 (reach 2600 m
        // = 1600 m past 1000 m), the installed X4 says so.
        let mut tags = vec![
            tag("T1", 1000.0, 2600.0, false),
            tag("T2", 1400.0, 3000.0, false),
            tag("T3", 2500.0, 5000.0, false),
            tag("X4", 2900.0, 5000.0, true),
        ];
        route_tag_reasons(&mut tags, &[10.0; 4], 1500.0, 5000.0, 20.0, 1);
        let r: Vec<&str> = tags.iter().map(|t| t.reason.as_str()).collect();
        assert!(
            r[0].starts_with("the start (the prior) holds the 20 m bound to 1500 m (reach 1500 m)"),
            "{}",
            r[0]
        );
        assert!(
            r[0].contains("this is #1, at 1000 m along the route, within it"),
            "{}",
            r[0]
        );
        assert!(
            r[1].contains("this is #2, at 1400 m along the route, within it"),
            "{}",
            r[1]
        );
        assert!(r[1].contains("each of the next 2 tags"), "{}", r[1]);
        assert!(
            r[2].starts_with(
                "the fix at T1 (1000 m, 36 km/h) holds the 20 m bound to 2600 m (reach 1600 m)"
            ),
            "{}",
            r[2]
        );
        assert!(
            r[2].contains("#2, at 2500 m along the route, within it"),
            "{}",
            r[2]
        );
        assert!(
            r[2].ends_with("holds the bound to the route's end (5000 m)"),
            "{}",
            r[2]
        );
        assert!(r[3].starts_with("installed already; "), "{}", r[3]);
    }

    #[test]
    fn without_missed_reads_the_anchor_is_the_previous_fix() {
        let mut tags = vec![
            tag("T1", 900.0, 2000.0, false),
            tag("T2", 2100.0, 3000.0, false),
        ];
        route_tag_reasons(&mut tags, &[20.0; 2], 1000.0, 3000.0, 10.0, 0);
        assert!(tags[0]
            .reason
            .contains("with no missed read tolerated, the next tag"));
        // A tag past its anchor's reach is reported as such, not hidden.
        assert!(
            tags[1].reason.starts_with(
                "the fix at T1 (900 m, 72 km/h) holds the 10 m bound to 2000 m (reach 1100 m)"
            ) && tags[1]
                .reason
                .contains("at 2100 m along the route, past it"),
            "{}",
            tags[1].reason
        );
    }
}
