//! The reach of each (speed class, mounting): a straight, turn-free drive
//! with the scenario's prior, propagated by the covariance engine
//! ([`crate::sim::covariance`]) and fixed each time the 95 % bound reaches
//! the requirement, until the distances between fixes settle.

use crate::error::{Error, Result};
use crate::scenario::Scenario;
use crate::sim::bound::bound95;
use crate::sim::covariance::PerfectData;
use crate::sim::tags::Mounting;
use crate::trajectory::{ideal_imu, Extent, Motion, MotionPlan, Start};
use serde::Serialize;

/// Longest straight drive of the reach analysis (m), and its time cap (s).
const DRIVE_MAX_M: f64 = 100_000.0;
const DRIVE_MAX_S: f64 = 7_200.0;

/// The reach of one speed class and mounting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReachClass {
    /// Speed (km/h).
    pub speed_kmh: f64,
    /// Mounting of the fixes.
    pub mounting: String,
    /// Distance from the start (prior) until the bound reaches the requirement (m).
    pub start_reach_m: f64,
    /// Distances between successive fixes placed where the bound reaches
    /// the requirement (m), until periodic.
    pub periods_m: Vec<f64>,
    /// The smallest of them (m).
    pub steady_reach_m: f64,
    /// 95 % bound right after a fix in steady state (m).
    pub bound_after_fix_m: f64,
    /// The drive ended before the bound reached the requirement (the reach
    /// is at least this).
    pub capped: bool,
}

/// The reach of one class: a straight drive north at `speed_mps` from
/// (`lat`, `lon`) with the scenario's prior, fixed by `mounting` each time
/// the 95 % bound exceeds `req`.
pub fn reach_class(
    scn: &Scenario,
    lat: f64,
    lon: f64,
    height_m: f64,
    speed_mps: f64,
    mounting: Mounting,
    req: f64,
) -> Result<ReachClass> {
    let dt = scn.dt;
    let dist = DRIVE_MAX_M.min(speed_mps * DRIVE_MAX_S);
    let start = Start {
        lat,
        lon,
        h: height_m,
        heading: 0.0,
        pitch: 0.0,
        roll: 0.0,
        speed_mps,
    };
    let plan = MotionPlan::new(
        start,
        &[Motion::Cruise {
            extent: Extent::Distance(dist),
        }],
        dt,
    )?;
    // The covariance engine on this synthetic drive: no map matching, and
    // the scenario's odometer failure (a time and distance on its route)
    // does not apply.
    let data = PerfectData::new(scn).without_faults();
    let mut samples = ideal_imu(plan.trajectory(), dt);
    let Some(first) = samples.next() else {
        return Err(Error::InvalidParameter("empty reach drive".into()));
    };
    let mut f = data.filter_at(&first.avp);
    let b0 = bound95(&f.position_cov_enu());
    if b0 > req {
        return Err(Error::Infeasible(format!(
            "the navigator's initial position uncertainty (95 % bound {b0:.2} m, from \
             navigator.initial_position_sigma_m / filter.position_sigma_m) already exceeds the {req} m \
             requirement where a vehicle starts"
        )));
    }
    let mut start_reach: Option<f64> = None;
    let mut periods: Vec<f64> = Vec::new();
    let (mut last_fix, mut prev_d) = (0.0, 0.0);
    let mut bound_after = f64::NAN;
    let mut prop = data.start(&f, 0.0);
    for (n, s) in samples.enumerate() {
        let i = n + 1;
        prop.step(i, &s, &mut f);
        if bound95(&f.position_cov_enu()) > req {
            let reach = prev_d - last_fix;
            match start_reach {
                None => start_reach = Some(reach),
                Some(_) => periods.push(reach),
            }
            // The fix, as the budget applies it.
            let a = &s.avp;
            data.apply_fix(a, &mut f, mounting, None);
            bound_after = bound95(&f.position_cov_enu());
            if bound_after > req {
                return Err(Error::Infeasible(format!(
                    "requirement_m = {req} m is below what a {} fix leaves \
                     (95 % bound {bound_after:.2} m right after the fix at {:.0} km/h)",
                    mounting.as_str(),
                    speed_mps * 3.6
                )));
            }
            last_fix = a.distance_m;
            let settled = periods.len() >= 3 && {
                let t = &periods[periods.len() - 3..];
                let (lo, hi) = t
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
                hi - lo <= (0.002 * hi).max(0.5)
            };
            // The binding (smallest) period came early and the profile has
            // grown for three periods since: later periods are longer still.
            let growing = periods.len() >= 4 && {
                let t = &periods[periods.len() - 4..];
                let min = periods.iter().copied().fold(f64::INFINITY, f64::min);
                t.windows(2).all(|w| w[1] >= w[0]) && t[0] > min
            };
            if settled || growing || periods.len() >= 12 {
                break;
            }
        }
        prev_d = s.avp.distance_m;
    }
    let capped_tail = prev_d - last_fix;
    let (start_reach_m, steady, capped) = match (start_reach, periods.is_empty()) {
        (None, _) => (prev_d, prev_d, true),
        (Some(s0), true) => (s0, capped_tail, true),
        (Some(s0), false) => (
            s0,
            periods.iter().copied().fold(f64::INFINITY, f64::min),
            false,
        ),
    };
    Ok(ReachClass {
        speed_kmh: speed_mps * 3.6,
        mounting: mounting.as_str().into(),
        start_reach_m,
        periods_m: periods,
        steady_reach_m: steady,
        bound_after_fix_m: bound_after,
        capped,
    })
}
