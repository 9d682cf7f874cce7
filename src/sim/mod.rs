//! Simulation (of a [`crate::scenario::Scenario`]): single runs and Monte Carlo, metrics and
//! the output files of `waymark simulate`.

pub mod integrated;
pub mod map_feed;
pub mod metrics;
pub mod output;
pub mod run;
pub mod tags;

pub use crate::scenario::{NavMode, Scenario};
pub use metrics::Summary;
pub use run::{
    simulate, simulate_with, ErrorRow, PassRecord, Prepared, RunResult, SimResult, TagEvent,
    TruthSource,
};
