//! No silent non-finite results in a plan: a NaN or infinity in a figure,
//! a tag's place or the predicted profile is an error naming the figure
//! and the likely cause, before any file is written (JSON would turn it
//! into `null`, a CSV into `NaN`).

use crate::error::{Error, Result};
use crate::planner::network::NetworkPlan;
use crate::planner::Plan;
use crate::scenario::{NavMode, Scenario};
use crate::sim::suspect_sections;
use std::path::Path;

/// The first non-finite figure of `figures` (name, value), as an error
/// naming the sections of `scn` that feed the covariance analysis (the
/// integrated navigator's).
fn check(
    path: &Path,
    scn: &Scenario,
    figures: impl IntoIterator<Item = (String, f64)>,
) -> Result<()> {
    for (name, x) in figures {
        if !x.is_finite() {
            return Err(Error::scenario(
                path,
                format!(
                    "the plan's {name} is {x}, not a finite number: the covariance analysis \
                     diverged; check {}",
                    suspect_sections(scn, NavMode::Integrated)
                ),
            ));
        }
    }
    Ok(())
}

/// Checks a route plan's figures, tags, profiles and validation.
pub(super) fn check_plan(path: &Path, scn: &Scenario, p: &Plan) -> Result<()> {
    let f = |n: &str, x: f64| (n.to_string(), x);
    let mut v = vec![
        f("route_length_m", p.route_length_m),
        f("start_reach_m", p.start_reach_m),
        f("total_cost", p.total_cost),
        f("max_gap_m", p.max_gap_m),
        f("predicted_max_bound95_m", p.predicted_max_bound95_m),
    ];
    for (i, t) in p.tags.iter().enumerate() {
        for (n, x) in [
            ("lat", t.lat),
            ("lon", t.lon),
            ("height_m", t.height_m),
            ("route_distance_m", t.route_distance_m),
            ("t_s", t.t_s),
            ("expected_fix_sigma_m", t.expected_fix_sigma_m),
            ("bound_after_fix_m", t.bound_after_fix_m),
            ("reach_m", t.reach_m),
        ] {
            v.push((format!("tags[{i}].{n}"), x));
        }
    }
    for (name, profile) in [
        ("profile (with tags)", &p.profile_with_tags),
        ("profile (without tags)", &p.profile_without_tags),
    ] {
        for b in profile {
            v.push((format!("{name} bound at t = {:.1} s", b.t_s), b.bound95_m));
            v.push((format!("{name} distance"), b.distance_m));
        }
    }
    if let Some(val) = &p.validation {
        v.push(f(
            "validation max_horizontal_error_m",
            val.max_horizontal_error_m,
        ));
        v.push(f(
            "validation fraction_within_requirement",
            val.fraction_within_requirement,
        ));
    }
    check(path, scn, v)
}

/// Checks a network plan's figures and tags.
pub(super) fn check_network_plan(path: &Path, scn: &Scenario, p: &NetworkPlan) -> Result<()> {
    let f = |n: &str, x: f64| (n.to_string(), x);
    let mut v = vec![
        f("reach_m", p.reach_m),
        f("start_reach_m", p.start_reach_m),
        f("total_cost", p.total_cost),
    ];
    for (i, t) in p.tags.iter().enumerate() {
        for (n, x) in [
            ("lat", t.lat),
            ("lon", t.lon),
            ("height_m", t.height_m),
            ("chainage_m", t.chainage_m),
            ("expected_fix_sigma_m", t.expected_fix_sigma_m),
        ] {
            v.push((format!("tags[{i}].{n}"), x));
        }
    }
    if let Some(val) = &p.validation {
        v.push(f(
            "validation max_horizontal_error_m",
            val.max_horizontal_error_m,
        ));
    }
    check(path, scn, v)
}
