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
//! * **Error budget.** The reach `R` comes from the navigation [`Filter`](crate::nav::Filter)
//!   itself by covariance analysis (perfect data, as in `crate::planner::budget`, through `crate::sim::covariance`),
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
//!   ([`cover::check`]).
//! * **Optimisation**: minimum total cost. Exact by integer programming with
//!   lazy walk constraints (`ilp`) when the instance is small
//!   (≤ [`ILP_MAX_CANDIDATES`] candidates) and the solver finishes within its
//!   node budget; otherwise greedy set multicover with exact reverse deletion
//!   ([`greedy::greedy`]), then the Lagrangian relaxation of the multicover
//!   of the greedy's violating walks (`walk_relax`), whose selection,
//!   checked by the walk DP, replaces the greedy's when it costs less. The
//!   plan reports the method and a lower bound: the largest of a packing
//!   bound (edge-disjoint walks longer than `R`, each needing `k + 1`
//!   tags), the integer programme's bound and the relaxation's.
//! * **Validation**: Monte Carlo runs of the real navigator (`sim`) over
//!   seeded random origin–destination shortest paths of 1.5–4 km, each with
//!   the planned tags of the directions it drives, read with the scenario's
//!   read probability.
//!
//! Files: `reach` (the reach per speed class, by the covariance engine),
//! `instance` (the directed graph, candidate sites and installed tags),
//! [`cover`] (the walk DP check and the greedy; public, so that a plan can be
//! verified from outside the crate), `ilp` (the exact
//! integer programme), `plan` (the planning entry points), `validation`
//! (Monte Carlo over sampled paths), `stretches` (`--baseline`'s
//! over-budget stretches and the drive it shares with
//! `calibrated_stretches`), `types` (the plan's types),
//! `settings` (the network-specific settings), `walk_relax` (the
//! Lagrangian relaxation of `any_walk` plans), `walks` (the walk DP's
//! per-road budgets and worst walks of `any_walk` plans), `window_sets`
//! (the budget windows of `trips` plans, stored flat).

pub(crate) mod add_drop;
pub(crate) mod best_site;
pub(crate) mod calibrated_stretches;
pub(crate) mod certification;
pub(crate) mod cold_starts;
pub mod cover;
pub(crate) mod coverage;
pub(crate) mod discard;
pub(crate) mod dominance;
pub mod greedy;
pub(crate) mod ilp;
pub(crate) mod instance;
pub(crate) mod lagrangian;
pub(crate) mod lp_bound;
pub(crate) mod mm_reach;
pub(crate) mod parallel;
pub(crate) mod plan;
pub(crate) mod plan_trips;
pub(crate) mod reach;
pub(crate) mod settings;
pub(crate) mod simulated_reach;
pub(crate) mod straight;
pub(crate) mod stretches;
pub(crate) mod tag_sites;
pub(crate) mod traffic;
pub(crate) mod trips;
pub(crate) mod turns;
pub(crate) mod types;
pub(crate) mod validate;
pub(crate) mod validation;
pub(crate) mod walk_oracle;
pub(crate) mod walk_relax;
pub(crate) mod walks;
mod window_sets;

pub use coverage::{coverage_geojson, BudgetSource, EdgeCoverage};
pub use mm_reach::{
    matched_reach, CalibrationSite, MatchedReach, ReachRequirement, CALIBRATION_M,
    CALIBRATION_TURNS, CALIBRATION_TURN_DEG,
};
pub use plan::{plan_network, plan_network_loaded, plan_network_on};
pub use reach::{reach_class, ReachClass};
pub use settings::{
    scenario_network, UTurns, DEFAULT_NETWORK_SPACING_M, EXISTING_SNAP_M, ILP_MAX_CANDIDATES,
};
pub use simulated_reach::{
    simulated_reach, turn_reach, upper_order_statistic, RoadRuns, SimulatedDrive, SimulatedReach,
    TurnLead,
};
pub use trips::{
    chains_allowing, chains_needed, clopper_pearson_lower, clopper_pearson_upper, TripsGuarantee,
    ALLOWED_VIOLATIONS, MAX_TRIPS_WINDOW_IDS,
};
pub use turns::TURN_DEG;
pub use types::{
    DesignWalkValidation, NetworkPlan, NetworkTag, NetworkValidation, NoTagsValidation,
    StretchFigures, StretchValidation,
};
pub use validate::validate_network_plan;
pub use validation::{share_rule, THINNING_S};
pub use walks::DesignWalk;
pub use window_sets::WindowSets;

#[cfg(test)]
mod tests {
    use super::cover::Solved;
    use super::instance::edge_speed;
    use super::*;
    use crate::network::Network;
    use crate::network::{model_from_polylines, Oneway, RoadAttributes};
    use crate::planner::settings::PlannerSettings;
    use crate::scenario::Scenario;
    use crate::sim::tags::Mounting;
    use crate::sim::TruthSource;

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
        if let Solved::Feasible(g) = greedy::greedy(prob) {
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
        // Validated with the scenario: loading fails.
        let e = Scenario::parse(&path, &bad).unwrap_err().to_string();
        assert!(e.contains("not one of anywhere, dead_ends"), "{e}");
    }

    #[test]
    fn any_walk_plan_explains_every_road_and_drives_its_worst_walks() {
        let scn = scenario();
        let s = PlannerSettings::from_scenario(&scn).unwrap();
        let net = std::sync::Arc::new(block());
        let p = plan_network_on(&scn, &s, &net).unwrap();
        assert!(p.verified);
        // Coverage: every directed road, the design case within the budget,
        // fewer reads never better.
        assert_eq!(p.edge_coverage.len(), p.directed_edges);
        for c in &p.edge_coverage {
            let m = c.budget_missed.unwrap();
            assert!(m <= 1.0 + 1e-9, "{c:?}");
            assert!(c.budget_with_tags <= m + 1e-9 && m <= c.budget_without_tags.max(m));
            assert!(c.passes.is_none() && !c.reason.is_empty());
            // A budget within 1 reads as a bound within the requirement
            // (profile interpolation: 1 cm).
            assert!(
                c.bound_missed_m
                    .is_some_and(|b| b <= s.requirement_m + 0.01),
                "{c:?}"
            );
        }
        // Every new tag says how long the tag-free walks through it are.
        assert!(p
            .tags
            .iter()
            .all(|t| t.reason.contains("km through here without a read")));
        // The worst walks: the first is the DP's longest, each within the
        // budget with at most k tags on it, drivable as given.
        let w = &p.design_walks;
        assert!(!w.is_empty());
        assert!(
            (w[0].budget - p.longest_walk_budget).abs() < 1e-6,
            "{} vs {}",
            w[0].budget,
            p.longest_walk_budget
        );
        for d in w {
            assert!(d.budget <= 1.0 + 1e-9 && d.missed_tags.len() <= s.tolerate_missed_reads);
            let r = crate::route::route_from_pieces(&net, &d.pieces).unwrap();
            assert!(
                (r.length_m - d.length_m - d.lead_in_m).abs() < 1.0,
                "{} vs {}",
                r.length_m,
                d.length_m
            );
        }
        // Driven with their tags missed: the design case holds.
        let v = validate_network_plan(&scn, &net, &p, 4, 7, false).unwrap();
        let d = v.design_walks.unwrap();
        assert_eq!(d.walks, w.len());
        assert!(d.figures.passed, "{}", d.figures.rule);
        assert_eq!(d.walk_max_m.len(), w.len());
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

#[cfg(test)]
mod tests_trips;
