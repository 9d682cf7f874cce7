//! Simulation: single runs and Monte Carlo, metrics and the output files of
//! `waymark simulate`, and the perfect-data covariance analysis the planner
//! builds on.
//!
//! One role per file, imported downwards only:
//! `records` (row types) ← `truth` (truth source, run start) ←
//! `dead_reckoning` / `integrated` (runners; `tags`, `map_feed`) ←
//! `covariance` (perfect-data engine) · `metrics` ← `monte_carlo`
//! (dispatch) ← `output` (files).

pub mod covariance;
pub mod dead_reckoning;
pub mod integrated;
pub mod map_feed;
pub mod metrics;
pub mod monte_carlo;
pub mod output;
pub mod passes;
pub mod records;
pub mod scenario;
pub mod tags;
pub mod truth;

pub use integrated::Prepared;
pub use metrics::Summary;
pub use monte_carlo::{simulate, simulate_with, SimResult};
pub use records::{ErrorRow, PassRecord, RunResult, TagEvent};
pub use scenario::{NavMode, Scenario};
pub use truth::{RouteTruth, TruthSource};
