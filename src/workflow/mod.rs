//! Whole jobs, as the commands run them: each loads its inputs once, does its
//! work and writes a complete output folder (every file atomically), then
//! returns what it did as a typed, serializable outcome. The `waymark` binary
//! only parses its arguments, calls one of these and prints the outcome.
//!
//! - [`plan_folder`]: `waymark plan` (route or network coverage);
//! - [`simulate_folder`]: `waymark simulate`;
//! - [`match_file`]: `waymark match`;
//! - [`inspect_map`]: `waymark network inspect`;
//! - [`init_scenario`]: `waymark init` (a commented starting scenario);
//! - [`demo_folder`]: `waymark demo` (plan, simulate with the planned tags,
//!   report), composed of the jobs above on one loaded scenario and map.
//!
//! Progress reaches the caller through a [`Progress`] (notes between steps,
//! counts within long ones); the library never prints.

mod demo;
mod finite;
mod init;
mod inputs;
mod inspect;
mod limits;
mod matching;
mod plan;
mod progress;
mod simulate;
mod summary;

pub use demo::{demo_folder, DemoOutcome};
pub use init::{init_scenario, InitOutcome};
pub use inputs::{check_out_dir, keep_inputs};
pub use inspect::{inspect_map, InspectOutcome};
pub use limits::{MAX_CANDIDATE_SITES, MAX_PLAN_SAMPLES};
pub use matching::{
    match_file, MatchBreak, MatchJob, MatchMethod, MatchOutcome, Timings, UnmatchedSpan,
};
pub use plan::{plan_folder, NetworkPlanFile, PlanFiles, PlanJob, PlanOutcome, RoutePlanFile};
pub use progress::{Progress, Silent};
pub use simulate::{simulate_folder, SimulateJob, SimulateOutcome};

/// A command-line value parser for a number within `lo..=hi` (the message
/// names the value and the range; clap adds the option and exits 2).
pub fn number_in(lo: f64, hi: f64) -> impl Fn(&str) -> std::result::Result<f64, String> + Clone {
    move |s: &str| {
        let x: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a number"))?;
        if x.is_finite() && (lo..=hi).contains(&x) {
            Ok(x)
        } else {
            Err(format!("{x} is outside {lo} to {hi}"))
        }
    }
}
