//! Simulation: single runs and Monte Carlo, metrics and the output files of
//! `waymark simulate`, and the perfect-data covariance analysis the planner
//! builds on.
//!
//! One role per file, each importing only the files above it (no circle):
//! - [`tags`]: tags and the RFID model; `map_feed`: the map-matching feed;
//! - `records`: the rows and records a run produces, and their recorder;
//! - `lanes`: the truth's lane path (lane offsets, changes, wander);
//! - `truth`: the truth source (with its loaded map and route) and the
//!   start of a run;
//! - `passes`: passes by tags (from the truth) and per-run reads;
//! - `dead_reckoning`: the stand-alone navigators' runner;
//! - `integrated`: the integrated navigator's runner and its filter settings;
//! - `map_error`: the map's geometry error field, drawn per run;
//! - `bound`: the one definition of the horizontal 95 % bound;
//! - `covariance`: the perfect-data covariance engine;
//! - `finite`: a diverged run (NaN, infinity) as an error with its likely cause;
//! - `metrics`: the summary of the runs;
//! - `limits`: the size limits checked before a simulation starts;
//! - `monte_carlo`: Monte Carlo dispatch;
//! - `output`: the files of `waymark simulate`.

pub(crate) mod bound;
pub(crate) mod covariance;
pub(crate) mod dead_reckoning;
pub(crate) mod finite;
pub(crate) mod integrated;
pub(crate) mod lanes;
pub(crate) mod limits;
pub(crate) mod map_error;
pub(crate) mod map_feed;
pub(crate) mod metrics;
pub(crate) mod monte_carlo;
pub(crate) mod output;
pub(crate) mod passes;
pub(crate) mod records;
pub mod tags;
pub(crate) mod truth;

pub use crate::scenario::{NavMode, Scenario};
pub use bound::{bound95, bound95_of_sigmas, bound_at, lambda_max_2x2, CHI2_2_95};
pub use finite::{check_runs_finite, suspect_sections};
pub use integrated::Prepared;
pub use limits::{check_simulation_size, MAX_RUNS, MAX_SIMULATED_S, MAX_STORED_ROWS};
pub use map_feed::FeedCounts;
pub use metrics::{
    CalibrationState, CalibrationSummary, FaultInterval, MapMatchingSummary, NeesSummary,
    ProfilePoint, RunSummary, Summary, TagSummary,
};
pub use monte_carlo::{simulate, simulate_staged, simulate_with, SimResult, StagedRuns};
pub use output::write as write_output;
pub use passes::{draw_reads, find_passes, TagPass, TagRead};
pub use records::{CalibrationRow, ErrorRow, PassRecord, RunResult, TagEvent};
pub use truth::{RouteTruth, TruthSource};
