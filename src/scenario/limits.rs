//! Size limits of a scenario, checked before any work allocates memory or
//! time in proportion to them: one error naming the field and the limit
//! (README, "Limits and reliability"). Durations, rates and the rows a
//! simulation keeps are checked where they are known: the IMU rate and
//! the motion commands' 30-day limit in validation and the motion compiler,
//! the drive's length and the kept rows in `sim::limits`.

use super::check::Check;
use super::schema::ScenarioFile;
use crate::error::Result;

/// Largest scenario file read (bytes): a scenario with thousands of
/// `[[tag]]` entries is well under 1 MiB.
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;

/// Most Monte Carlo runs of one simulation or plan validation
/// (`planner.validation_runs`, `simulate --runs`, `plan --runs`).
pub const MAX_RUNS: u64 = 100_000;

/// Most consecutive missed reads a plan may tolerate
/// (`planner.tolerate_missed_reads`): the route planner searches windows of
/// the last k + 1 tags, whose number grows as (sites within reach)^k; on
/// the demo's 4 km route k = 2 takes 3 s and 0.1 GB, k = 3 45 s and 1.4 GB,
/// and k = 4 did not finish within 2 minutes.
pub const MAX_TOLERATED_MISSED_READS: u64 = 3;

/// Most refinements of a route plan's reaches (`planner.refine_iterations`;
/// each is a covariance pass and a placement).
pub const MAX_REFINE_ITERATIONS: u64 = 100;

/// Checks the counts of `file` against the limits above, and that a motion
/// route has motion commands.
pub(super) fn check(c: &Check, file: &ScenarioFile) -> Result<()> {
    if let Some(r) = file.route.first() {
        if r.start.is_some() && r.waypoints.is_none() && r.motion.is_empty() {
            return Err(c.err(
                "route[0].motion is empty: give at least one motion command (e.g. \
                 { kind = \"stay\", duration_s = 60 }); a drive of 0 s has nothing to simulate",
            ));
        }
    }
    let Some(p) = &file.planner else {
        return Ok(());
    };
    for (field, value, max) in [
        ("planner.validation_runs", p.validation_runs, MAX_RUNS),
        (
            "planner.tolerate_missed_reads",
            p.tolerate_missed_reads.map(u64::from),
            MAX_TOLERATED_MISSED_READS,
        ),
        (
            "planner.refine_iterations",
            p.refine_iterations.map(u64::from),
            MAX_REFINE_ITERATIONS,
        ),
    ] {
        if let Some(v) = value.filter(|&v| v > max) {
            return Err(c.err(format!("{field} = {v} is above the limit of {max}")));
        }
    }
    Ok(())
}
