//! The tag planner: candidate sites along a scenario's route → error budget
//! by covariance analysis of the navigation filter (`budget`) → the fewest
//! tags that hold the requirement with `k` missed reads tolerated
//! (`placement`, exact on one route) → validation by Monte Carlo
//! simulation with the planned tags → export records.
//!
//! One role per file: `settings` (the `[planner]` section checked once),
//! `plan` (plan types), `route` (placement along a route), `budget`
//! (the route's covariance analysis on `crate::sim::covariance`),
//! `stretch` (the tag-free pass's composed stretch maps), `carry`
//! (runs carried by them), `lazy` (reaches on demand),
//! `placement` and `forward` (placement algorithms), `validation`
//! (Monte Carlo and the missed-tags check), `baseline` (uniform spacing),
//! `output` (export records), [`network`] (`coverage = "network"`).

pub(crate) mod baseline;
pub(crate) mod budget;
pub(crate) mod carry;
pub(crate) mod cost;
pub(crate) mod forward;
pub(crate) mod lazy;
pub mod network;
pub(crate) mod output;
pub(crate) mod placement;
pub(crate) mod plan;
pub(crate) mod record;
pub(crate) mod route;
pub(crate) mod settings;
pub(crate) mod stretch;
pub(crate) mod validation;

pub use crate::nav::riccati::generalized_lambda_max;
pub use baseline::{uniform_baseline, uniform_tags};
pub use budget::{AllRead, Budget, BudgetPoint, Site};
pub use lazy::LazyReaches;
pub use plan::{Plan, PlannedTag, UniformBaseline, Validation};
pub use route::{plan, plan_with, plan_with_progress, plan_with_stages, PlanStage};
pub use settings::{
    fix_bound95, lane_width_m, site_speed_mps, Coverage, MountingOption, PlannerSettings,
    DEFAULT_READ_PROBABILITY,
};
pub use validation::{horizontal_bound95, robust, validate_plan};
