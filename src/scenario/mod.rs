//! The scenario: what is simulated and planned, read from a TOML file.
//!
//! Two layers, like a command line's raw flags and its validated options:
//!
//! - [`schema`]: the file as serde reads it ([`ScenarioFile`] and its
//!   sections). Field names carry their units (`_m`, `_s`, `_deg`, `_dph`,
//!   `_ug`, `_kmh`, ...); unknown fields are errors; every closed set of
//!   options ([`NavMode`], [`VerticalChannel`], [`MotionKind`], [`Adaptive`],
//!   [`Coverage`], [`UTurns`], [`Mounting`](crate::tags::Mounting)) is a serde
//!   enum, so an unknown value is an error naming the file, the line and the
//!   field.
//! - [`Scenario`]: the result of one validation pass
//!   ([`Scenario::load`], [`Scenario::parse`]) that checks every number,
//!   applies every default and converts every unit to SI (with the constants
//!   of [`crate::units`]). The rest of the crate reads only this: typed
//!   sections ([`Navigator`], [`Aiding`], [`FilterSettings`],
//!   [`ExternalFix`], [`ScenarioTag`], [`PlannerOptions`]), the sensor models
//!   and the route ([`RouteKind`]).
//!
//! Errors name the file and the field, e.g.
//! `bad.toml: line 14: planner.coverage "everything" is not one of routes, network`.

mod check;
mod limits;
mod planner_section;
mod presets;
mod route;
pub mod schema;
mod sections;
mod validate;

pub(crate) use check::{short_number, shorten_numbers};
pub use limits::{
    check_network_candidates, check_route_memory, route_truth_bytes, RouteCounts,
    LANE_PROFILE_BYTES_PER_M, MAX_ACCEL_ERROR_UG, MAX_GYRO_ARW_DPRH, MAX_GYRO_ERROR_DPH,
    MAX_NETWORK_CANDIDATE_SITES, MAX_REFINE_ITERATIONS, MAX_ROUTE_TRUTH_BYTES, MAX_RUNS,
    MAX_SCENARIO_BYTES, MAX_TOLERATED_MISSED_READS,
};
pub use presets::{starter_scenario, ImuGrade, Starter};
pub use schema::{
    Adaptive, Coverage, MotionKind, NavMode, ScenarioFile, Traffic, UTurns, VerticalChannel,
};
pub use sections::{
    default_mounting_cost, Aiding, ExternalFix, FilterSettings, LaneModel, MapErrorModel,
    MountingChoice, Navigator, PlannerOptions, RouteKind, Scenario, ScenarioTag, TagPlace,
    DEFAULT_LANE_WANDER_M, DEFAULT_NETWORK_SPACING_M, DEFAULT_ROUTE_SPACING_M,
    DEFAULT_VERTICAL_TAU_S, LANE_PATH_SPACING_M,
};

#[cfg(test)]
mod tests;
