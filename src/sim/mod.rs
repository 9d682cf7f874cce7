//! Simulation: the scenario schema, single runs and Monte Carlo, metrics and
//! the output files of `waymark simulate`.

pub mod metrics;
pub mod output;
pub mod run;
pub mod scenario;

pub use metrics::Summary;
pub use run::{simulate, ErrorRow, RunResult, SimResult, TruthSource};
pub use scenario::{NavMode, Scenario};
