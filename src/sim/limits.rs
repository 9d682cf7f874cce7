//! Limits checked before a simulation allocates anything: the number of
//! runs, the simulated duration and the error rows kept in memory (every
//! run keeps its rows at the output interval until the summary is made).
//! Each limit is documented in the README ("Limits and reliability").

use super::truth::TruthSource;
use crate::error::{Error, Result};
use crate::scenario::Scenario;

pub use crate::scenario::MAX_RUNS;

/// Most error rows kept in memory over all runs (runs × rows per run; a row
/// is 88 bytes, so about 1.8 GB).
pub const MAX_STORED_ROWS: u64 = 20_000_000;

/// Bytes of one kept error row (eleven `f64`).
const ROW_BYTES: u64 = std::mem::size_of::<super::records::ErrorRow>() as u64;

/// Longest simulated drive (s): 30 days, the limit of motion commands
/// (`trajectory::motion::MAX_DURATION_S`), also for map routes (whose
/// stops can be long).
pub const MAX_SIMULATED_S: f64 = crate::trajectory::motion::MAX_DURATION_S;

/// Checks `runs` runs of `scn` on `truth` against [`MAX_RUNS`],
/// [`MAX_SIMULATED_S`] and [`MAX_STORED_ROWS`] before any run starts.
pub fn check_simulation_size(scn: &Scenario, truth: &TruthSource, runs: u64) -> Result<()> {
    if runs > MAX_RUNS {
        return Err(Error::InvalidParameter(format!(
            "{runs} Monte Carlo runs: at most {MAX_RUNS} are allowed"
        )));
    }
    let duration = truth.duration_s().min(scn.duration_cap_s());
    if !(duration.is_finite() && duration <= MAX_SIMULATED_S) {
        return Err(Error::scenario(
            &scn.path,
            format!(
                "the drive lasts {duration:.0} s, above the limit of {MAX_SIMULATED_S:.0} s (30 days): \
                 shorten the route, its stops or set duration_s"
            ),
        ));
    }
    let rows_per_run = (duration / scn.output_interval_s).ceil() as u64 + 2;
    let rows = runs.saturating_mul(rows_per_run);
    if rows > MAX_STORED_ROWS {
        return Err(Error::scenario(
            &scn.path,
            format!(
                "{runs} run(s) of {rows_per_run} output rows each ({duration:.0} s every \
                 output_interval_s = {} s) would keep {rows} error rows in memory (about {:.1} GB), \
                 above the limit of {MAX_STORED_ROWS} rows (about {:.1} GB): use fewer runs or a \
                 longer output_interval_s",
                scn.output_interval_s,
                rows as f64 * ROW_BYTES as f64 / 1e9,
                MAX_STORED_ROWS as f64 * ROW_BYTES as f64 / 1e9,
            ),
        ));
    }
    Ok(())
}
