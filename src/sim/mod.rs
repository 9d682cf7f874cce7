//! Simulation: single runs and Monte Carlo, metrics and the output files of
//! `waymark simulate`, and the perfect-data covariance analysis the planner
//! builds on.
//!
//! One role per file, each importing only the files above it (no circle):
//! - [`tags`]: tags and the RFID model; [`map_feed`]: the map-matching feed;
//! - [`records`]: the rows and records a run produces, and their recorder;
//! - [`truth`]: the truth source (with its loaded map and route) and the
//!   start of a run;
//! - [`passes`]: passes by tags (from the truth) and per-run reads;
//! - [`dead_reckoning`]: the stand-alone navigators' runner;
//! - [`integrated`]: the integrated navigator's runner and its filter settings;
//! - [`covariance`]: the perfect-data covariance engine and the 95 % bound;
//! - [`metrics`]: the summary of the runs;
//! - [`monte_carlo`]: Monte Carlo dispatch;
//! - [`output`]: the files of `waymark simulate`.

pub mod covariance;
pub mod dead_reckoning;
pub mod integrated;
pub mod map_error;
pub mod map_feed;
pub mod metrics;
pub mod monte_carlo;
pub mod output;
pub mod passes;
pub mod records;
pub mod tags;
pub mod truth;

pub use crate::scenario::{NavMode, Scenario};
pub use integrated::Prepared;
pub use metrics::Summary;
pub use monte_carlo::{simulate, simulate_with, SimResult};
pub use records::{ErrorRow, PassRecord, RunResult, TagEvent};
pub use truth::{RouteTruth, TruthSource};
