//! Limits of a route plan, checked before planning: the planner's
//! covariance analysis keeps every truth sample of the route in memory, and
//! a filter snapshot at every candidate site (README, "Limits and
//! reliability").

use crate::error::{Error, Result};
use crate::planner::PlannerSettings;
use crate::scenario::Scenario;
use crate::sim::TruthSource;
use crate::trajectory::TruthSample;

/// Most truth samples of a planned route (drive duration × IMU rate): about
/// 28 h at 100 Hz; each sample is kept in memory (about 1.5 GB at the limit).
pub const MAX_PLAN_SAMPLES: u64 = 10_000_000;

/// Most candidate sites of a route plan (route length / candidate
/// spacing), each with a snapshot of the 21-state filter.
pub const MAX_CANDIDATE_SITES: u64 = 200_000;

/// Checks a route plan's size against [`MAX_PLAN_SAMPLES`] and
/// [`MAX_CANDIDATE_SITES`].
pub(super) fn check_route_plan_size(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
) -> Result<()> {
    let duration = truth.duration_s().min(scn.duration_cap_s());
    let samples = (duration / scn.dt).ceil() + 1.0;
    if samples.is_nan() || samples > MAX_PLAN_SAMPLES as f64 {
        let bytes = std::mem::size_of::<TruthSample>() as f64;
        return Err(Error::scenario(
            &scn.path,
            format!(
                "planning a {duration:.0} s drive at imu.rate_hz = {:.0} keeps {samples:.0} truth \
                 samples in memory (about {:.1} GB), above the limit of {MAX_PLAN_SAMPLES}: plan a \
                 shorter route (or set duration_s) or lower imu.rate_hz",
                1.0 / scn.dt,
                samples * bytes / 1e9
            ),
        ));
    }
    let length = match truth {
        TruthSource::Motion(p) => p.distance_m,
        TruthSource::Route(r) => r.plan.distance_m,
    };
    let sites = length / settings.candidate_spacing_m;
    if sites.is_nan() || sites > MAX_CANDIDATE_SITES as f64 {
        return Err(Error::scenario(
            &scn.path,
            format!(
                "a {:.1} km route at planner.candidate_spacing_m = {} has {sites:.0} candidate \
                 sites, above the limit of {MAX_CANDIDATE_SITES}: use a larger candidate_spacing_m",
                length / 1000.0,
                settings.candidate_spacing_m
            ),
        ));
    }
    Ok(())
}
