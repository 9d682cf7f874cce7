//! The map-matching reach measured on the **simulated error** instead of
//! the covariance engine's bound: the calibration roads of
//! [`super::mm_reach`] driven `runs` times by the Monte Carlo simulator
//! (true sensor and map errors, the real map feed), and the distance after
//! each reset where the error's 95th percentile first exceeds the
//! requirement.
//!
//! A measurement for the planner's model, not yet a planning input. The
//! engine's bound is 1.35–2× conservative in distance on these drives
//! (BENCHMARKS.md, "The calibration drives' corners"), but an uncalibrated
//! vehicle's first gradual turn is the other way round: its bound stays
//! above the requirement while its simulated error does not. A reach taken
//! from the simulated error needs both figures, so each speed class drives
//! five roads:
//!
//! * **start**: straight from the navigator's prior;
//! * **first turn, sharp / curve**: a straight as long as the engine's start
//!   reach, then a turn of [`TURN_DEG`](super::turns::TURN_DEG) at a corner or spread over
//!   [`CURVE_M`] (the least-informed first reset);
//! * **calibrated turn, sharp / curve**: the warm-up of right-angle legs
//!   ([`super::mm_reach::WARM_UP_LEGS`]), then the same turn.
//!
//! Each turn's reach is counted from [`CURVE_M`] past the turn's first
//! corner, where the planner's stretch starts (`super::turns`).
//!
//! # The statistic
//!
//! At every [`STEP_M`] after the reset the horizontal errors of the runs
//! are sorted. `q95` is the ⌈0.95 n⌉-th smallest; `upper` is the smallest
//! order statistic that lies above the true 95th percentile with at least
//! 95 % probability (the distribution-free binomial bound,
//! [`upper_order_statistic`]; the largest of 59 runs, the 5th largest of
//! 200 when the errors at a point are independent between runs, which
//! they are: every run has its own seed). The reach is where the statistic
//! first exceeds the requirement; a drive that ends first gives its length
//! and `capped`.
//!
//! # The cost
//!
//! Each road is built whole (`after_m` past its reset), but its runs are
//! simulated only as far as the statistics need: advanced together in
//! stages ([`crate::sim::simulate_staged`]) to `STAGE_M` (250 m) past the grid
//! point being compared, and stopped once both statistics have crossed the
//! requirement. A staged run is the same computation on the same truth,
//! stopped earlier, and a run's rows up to a sample do not depend on the
//! samples after it: so the figures are those of the whole drives, bit for
//! bit. A road cut short instead would not give them: the network's frame
//! is centred on the road, and each run's map error is drawn in that frame
//! (BENCHMARKS.md, "Cheaper simulated reach"). One difference: a run that
//! diverges (a non-finite error) after the runs stop is no longer an error.
//!
//! A cap ([`RoadRuns::max_after_m`]) stops the runs that far past the
//! reset on the same road: the figures below it are the uncapped ones, bit
//! for bit, the others the cap (`capped`). The roads that never cross,
//! driven whole otherwise, are most of the fast classes' cost.
//!
//! # Other turn roads
//!
//! [`turn_reach`] measures the same turn after another lead
//! ([`TurnLead`]): fewer warm-up legs than the calibrated turn's, a
//! first straight of any length (the early reach's fixed point, BENCHMARKS.md,
//! "How many turns calibrate a vehicle, and the early reach"), or legs
//! shorter than the warm-up's (BENCHMARKS.md, "Calibration by turns closer
//! together than 500 m").

use super::mm_reach::{
    run_bound, synthetic_drive, turn_legs, warm_up_legs, CalibrationSite, ReachRequirement,
    CALIBRATION_M, DRIVE_MAX_M, DRIVE_MAX_S, WARM_UP_LEGS,
};
use super::turns::CURVE_M;
use crate::error::{Error, Result};
use crate::scenario::Scenario;
use crate::sim::{simulate_staged, ErrorRow, TruthSource};
use serde::Serialize;

/// Spacing of the distances where the runs' errors are compared (m).
pub const STEP_M: f64 = 25.0;

/// One calibration road's reach, by the engine's bound and by the
/// simulated error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimulatedDrive {
    /// Which road ("start", "first turn, sharp", …).
    pub name: String,
    /// Where the reset's stretch starts on the road (m from its start).
    pub from_m: f64,
    /// Distance after `from_m` where the engine's bound first exceeds the
    /// requirement (m; 0 when it already does).
    pub bound_reach_m: f64,
    /// The same for the runs' 95th percentile (m).
    pub q95_reach_m: f64,
    /// The same for the 95 % upper confidence bound of the 95th percentile
    /// (m; `None` with fewer than 59 runs, too few for such a bound).
    pub upper_reach_m: Option<f64>,
    /// The road ended before one of the three reached the requirement (its
    /// figure is the road's length after `from_m`, a lower bound).
    pub capped: bool,
}

/// The simulated reaches of one speed class.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimulatedReach {
    /// Speed (km/h).
    pub speed_kmh: f64,
    /// Monte Carlo runs per road.
    pub runs: u64,
    /// The five roads, in the module's order.
    pub drives: Vec<SimulatedDrive>,
}

/// How each road is driven: `runs` simulated drives from `seed`, each road
/// running `after_m` past its reset (and within the calibration's 30 km /
/// 90 min).
///
/// `max_after_m` stops the runs that far past the reset instead of at the
/// road's end. The road itself is the same (`after_m` long: a road cut
/// short would change every run's map error, the module doc says why), so
/// every figure below the cap is the uncapped one, bit for bit; a figure
/// that would lie beyond it is the cap, with `capped` set. A planner would
/// cap at the map's longest turn-free stretch: a reach beyond it buys
/// nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadRuns {
    /// Monte Carlo runs per road.
    pub runs: u64,
    /// The first run's seed.
    pub seed: u64,
    /// Length of each road past its reset (m, at least 500).
    pub after_m: f64,
    /// Distance past the reset where the runs stop (m; `None`: the road's
    /// end).
    pub max_after_m: Option<f64>,
}

impl RoadRuns {
    /// `runs` from `seed` on roads running `after_m` past their reset, to
    /// the road's end.
    pub fn new(runs: u64, seed: u64, after_m: f64) -> Self {
        Self {
            runs,
            seed,
            after_m,
            max_after_m: None,
        }
    }

    /// The same, the runs stopped `max_after_m` past the reset.
    pub fn capped_at(self, max_after_m: f64) -> Self {
        Self {
            max_after_m: Some(max_after_m),
            ..self
        }
    }

    /// The cap, checked (the road's length is checked with its speed).
    fn check(&self) -> Result<()> {
        if let Some(c) = self.max_after_m {
            if !(c > 0.0 && c.is_finite()) {
                return Err(Error::InvalidParameter(format!(
                    "the runs' cap past the reset must be positive, not {c} m"
                )));
            }
        }
        Ok(())
    }
}

/// The smallest `k` (1-based) such that the `k`-th smallest of `n`
/// independent samples lies at or above the distribution's `p`-quantile
/// with probability at least `conf`: P(Bin(n, p) ≤ k − 1) ≥ `conf`. `None`
/// when even the largest sample is not enough (`1 − pⁿ < conf`).
///
/// ```
/// use waymark::planner::network::upper_order_statistic;
/// // 59 samples: the largest, since 1 − 0.95⁵⁹ = 0.952.
/// assert_eq!(upper_order_statistic(59, 0.95, 0.95), Some(59));
/// assert_eq!(upper_order_statistic(58, 0.95, 0.95), None);
/// ```
pub fn upper_order_statistic(n: usize, p: f64, conf: f64) -> Option<usize> {
    if n == 0 || !(0.0..1.0).contains(&p) || !(0.0..1.0).contains(&conf) {
        return None;
    }
    // The binomial pmf by its recurrence from P(0) = (1 − p)ⁿ, in logs so
    // that large n does not underflow the first terms.
    let (lp, lq) = (p.ln(), (1.0 - p).ln());
    let mut log_pmf = n as f64 * lq;
    let mut cdf = 0.0;
    for j in 0..n {
        cdf += log_pmf.exp();
        if cdf >= conf {
            return Some(j + 1);
        }
        log_pmf += ((n - j) as f64).ln() - ((j + 1) as f64).ln() + lp - lq;
    }
    None
}

/// How far the runs are advanced at a time past the grid point being
/// compared (m): the overshoot beyond the crossing, against one parallel
/// stage per `STAGE_M`.
const STAGE_M: f64 = 250.0;

/// One road's measurement: the drive and how far its runs were simulated
/// (m from the road's start; the road's end when they ran to it).
struct Measured {
    drive: SimulatedDrive,
    #[cfg_attr(not(test), allow(dead_code))]
    simulated_m: f64,
}

/// The engine's bound on one road: its reach after `from_m`, `true` if the
/// road ends first; and the road's length after `from_m`.
fn bound_reach(
    scn: &Scenario,
    truth: &TruthSource,
    from_m: f64,
    rq: ReachRequirement,
) -> Result<(f64, bool, f64)> {
    let end = truth.samples().last().map_or(0.0, |s| s.distance_m);
    let length_after = (end - from_m).max(0.0);
    Ok(match run_bound(scn, truth, from_m, rq)? {
        Some(x) => ((x - from_m).max(0.0), false, length_after),
        None => (length_after, true, length_after),
    })
}

/// The runs' errors at `at` m along the road, sorted: each run's first row
/// at or beyond `at`; `None` if a run has none.
fn errors_at(rows: &mut dyn Iterator<Item = &[ErrorRow]>, at: f64) -> Option<Vec<f64>> {
    let mut e = Vec::with_capacity(rows.size_hint().0);
    for r in rows {
        let i = r.partition_point(|x| x.distance_m < at);
        e.push(r.get(i)?.horizontal_m);
    }
    e.sort_by(f64::total_cmp);
    Some(e)
}

/// The two order statistics of `n` runs compared with the requirement:
/// the 95th percentile's rank and its upper bound's (1-based; `None`
/// below 59 runs).
fn ranks(n: usize) -> (usize, Option<usize>) {
    let k95 = ((0.95 * n as f64).ceil() as usize).clamp(1, n.max(1));
    (k95, upper_order_statistic(n, 0.95, 0.95))
}

/// One road: the engine's bound and `runs` simulated drives, advanced
/// together ([`simulate_staged`]) only as far as the comparison needs.
///
/// On the grid of [`STEP_M`] after `from_m`, each statistic's reach is its
/// first point above `req`, the road's remaining length (and `capped`) if
/// none is or a run ends first. Every run's error at a point is its first
/// row at or beyond it, and a run's rows up to any distance are those of
/// its whole drive (the truth is the whole road, built before the runs; a
/// run never reads what lies ahead of it): so the runs are advanced
/// [`STAGE_M`] past the point being compared, and stopped once both
/// statistics have crossed. The figures are those of the whole drive.
///
/// With a cap (`mc.max_after_m`) the grid ends at the cap instead of the
/// road's end, and the runs are advanced no further: a figure beyond the
/// cap is the cap, `capped`.
fn measure(
    scn: &Scenario,
    name: &str,
    truth: &TruthSource,
    from_m: f64,
    rq: ReachRequirement,
    mc: &RoadRuns,
) -> Result<Measured> {
    let req = rq.req_m;
    let (mut bound_reach_m, mut bound_capped, mut length_after) =
        bound_reach(scn, truth, from_m, rq)?;
    // The cap: the grid and the runs end there; the engine's bound (one
    // cheap run) is clipped to it.
    let cap = mc.max_after_m.filter(|&c| c < length_after);
    if let Some(c) = cap {
        length_after = c;
        if bound_reach_m > c {
            (bound_reach_m, bound_capped) = (c, true);
        }
    }
    let (q95, upper, simulated_m) = simulate_staged(scn, truth, mc.runs, mc.seed, |st| {
        let (k95, ku) = ranks(st.len());
        let (mut q95, mut upper) = (None, None);
        let mut ahead = f64::NEG_INFINITY;
        let mut d = 0.0;
        while d <= length_after {
            let at = from_m + d;
            if at > ahead {
                ahead = at + STAGE_M;
                if cap.is_some() {
                    // Still at or beyond `at`: the rows there are made.
                    ahead = ahead.min(from_m + length_after);
                }
                st.advance_to(ahead);
            }
            let mut rows = (0..st.len()).map(|i| st.rows(i));
            let Some(e) = errors_at(&mut rows, at) else {
                break;
            };
            if q95.is_none() && e[k95 - 1] > req {
                q95 = Some(d);
            }
            if let Some(k) = ku {
                if upper.is_none() && e[k - 1] > req {
                    upper = Some(d);
                }
            }
            if q95.is_some() && (ku.is_none() || upper.is_some()) {
                break;
            }
            d += STEP_M;
        }
        let simulated_m = (0..st.len())
            .filter_map(|i| st.rows(i).last().map(|r| r.distance_m))
            .fold(0.0f64, f64::max);
        Ok((q95, ku.map(|_| upper), simulated_m))
    })?;
    let q_capped = q95.is_none();
    let upper_capped = upper.is_some_and(|u| u.is_none());
    Ok(Measured {
        drive: SimulatedDrive {
            name: name.into(),
            from_m,
            bound_reach_m,
            q95_reach_m: q95.unwrap_or(length_after),
            upper_reach_m: upper.map(|u| u.unwrap_or(length_after)),
            capped: bound_capped || q_capped || upper_capped,
        },
        simulated_m,
    })
}

/// The five calibration roads of speed class `speed_mps` at `site`, each
/// driven `runs` times from `seed` and measured against `rq` (the engine's
/// bound at its confidence, the runs' error at 95 %). Each road runs at
/// most `after_m` past its reset (and within the calibration's 30 km /
/// 90 min).
pub fn simulated_reach(
    scn: &Scenario,
    site: CalibrationSite,
    speed_mps: f64,
    rq: ReachRequirement,
    mc: &RoadRuns,
) -> Result<SimulatedReach> {
    mc.check()?;
    let drives = roads(
        scn,
        site,
        speed_mps,
        rq,
        mc.after_m,
        &mut |scn, name, truth, from_m| Ok(measure(scn, name, truth, from_m, rq, mc)?.drive),
    )?;
    Ok(SimulatedReach {
        speed_kmh: speed_mps * 3.6,
        runs: mc.runs,
        drives,
    })
}

/// One road to measure: the located scenario, its name, its truth and
/// where the reset's stretch starts (m).
type Measure<'m> = dyn FnMut(&Scenario, &str, &TruthSource, f64) -> Result<SimulatedDrive> + 'm;

/// The five roads of [`simulated_reach`] at `site`, built one at a time
/// and handed to `measure`, in the module's order.
fn roads(
    scn: &Scenario,
    site: CalibrationSite,
    speed_mps: f64,
    rq: ReachRequirement,
    after_m: f64,
    measure: &mut Measure<'_>,
) -> Result<Vec<SimulatedDrive>> {
    check_road(speed_mps, after_m)?;
    let scn = scn.located_at([site.lat_deg, site.lon_deg]);
    let total = DRIVE_MAX_M.min(speed_mps * DRIVE_MAX_S).max(2_000.0);
    let first = first_straight(&scn, site, speed_mps, rq)?;
    let mut drives = Vec::with_capacity(5);
    // Start: the straight from the prior, to `after_m`.
    let (truth, _) = synthetic_drive(&scn, site, speed_mps, &[(0.0, total.min(after_m))])?;
    drives.push(measure(&scn, "start", &truth, 0.0)?);
    drop(truth);
    for lead in [TurnLead::WarmUp(0), TurnLead::WarmUp(WARM_UP_LEGS)] {
        let [s, c] = turn_roads(&scn, site, speed_mps, first, lead, after_m, measure)?;
        drives.push(s);
        drives.push(c);
    }
    Ok(drives)
}

/// The speed and the road's length past its reset, checked.
fn check_road(speed_mps: f64, after_m: f64) -> Result<()> {
    if !(speed_mps > 0.0 && speed_mps.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "speed {speed_mps} m/s: must be positive"
        )));
    }
    if !(after_m >= 500.0 && after_m.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "the roads must run at least 500 m past their reset, not {after_m} m"
        )));
    }
    Ok(())
}

/// The first turn's straight: the engine's start reach (as the planner
/// budgets it) on the calibration's full straight, at least 200 m.
/// `scn` is located at `site`.
fn first_straight(
    scn: &Scenario,
    site: CalibrationSite,
    speed_mps: f64,
    rq: ReachRequirement,
) -> Result<f64> {
    let total = DRIVE_MAX_M.min(speed_mps * DRIVE_MAX_S).max(2_000.0);
    let (long, _) = synthetic_drive(scn, site, speed_mps, &[(0.0, total)])?;
    Ok(run_bound(scn, &long, 0.0, rq)?.unwrap_or(total).max(200.0))
}

/// What a turn road drives before its turn of [`TURN_DEG`](super::turns::TURN_DEG).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TurnLead {
    /// `k` warm-up legs of `WARM_UP_LEG_M` (500 m) alternating north and
    /// east (`k − 1` right-angle turns), the first no longer than the
    /// engine's start reach. `WarmUp(0)`: the first-turn road (a straight
    /// as long as the engine's start reach); `WarmUp(WARM_UP_LEGS)`: the
    /// calibrated-turn road.
    WarmUp(usize),
    /// A straight of this length (m) from the prior: a first turn after it.
    Straight(f64),
    /// `legs` legs of `leg_m` alternating north and east (`legs − 1`
    /// right-angle turns), the first not cut to the start reach; if they
    /// total less than [`CALIBRATION_M`], the last runs on to make that
    /// total (a straight on its heading). Turns closer together than the
    /// warm-up's 500 m, against the planner's calibration rule.
    Legs {
        /// How many legs (at least 1).
        legs: usize,
        /// Each leg's length (m, at least 50).
        leg_m: f64,
    },
}

impl TurnLead {
    /// The lead's legs (heading degrees, length m); `first` is the engine's
    /// start reach.
    fn legs(self, first: f64) -> Vec<(f64, f64)> {
        match self {
            TurnLead::WarmUp(0) => vec![(0.0, first)],
            TurnLead::WarmUp(k) => warm_up_legs(first, k),
            TurnLead::Straight(l) => vec![(0.0, l)],
            TurnLead::Legs { legs, leg_m } => {
                let mut v: Vec<(f64, f64)> = (0..legs)
                    .map(|i| (if i % 2 == 0 { 0.0 } else { 90.0 }, leg_m))
                    .collect();
                let short = CALIBRATION_M - legs as f64 * leg_m;
                if let Some(last) = v.last_mut().filter(|_| short > 0.0) {
                    last.1 += short;
                }
                v
            }
        }
    }

    /// The lead's parameters, checked.
    fn check(self) -> Result<()> {
        match self {
            TurnLead::WarmUp(_) => Ok(()),
            TurnLead::Straight(l) if l >= 50.0 && l.is_finite() => Ok(()),
            TurnLead::Straight(l) => Err(Error::InvalidParameter(format!(
                "the straight before the turn must be at least 50 m, not {l} m"
            ))),
            TurnLead::Legs { legs, leg_m }
                if legs >= 1
                    && leg_m >= 50.0
                    && leg_m.is_finite()
                    && legs as f64 * leg_m <= DRIVE_MAX_M =>
            {
                Ok(())
            }
            TurnLead::Legs { legs, leg_m } => Err(Error::InvalidParameter(format!(
                "the lead's legs: at least 1 leg of at least 50 m, at most {DRIVE_MAX_M} m \
                 in all; not {legs} of {leg_m} m"
            ))),
        }
    }

    /// The road's name, with `kind` ("sharp" or "curve").
    fn name(self, kind: &str) -> String {
        match self {
            TurnLead::WarmUp(0) => format!("first turn, {kind}"),
            TurnLead::WarmUp(WARM_UP_LEGS) => format!("calibrated turn, {kind}"),
            TurnLead::WarmUp(k) => format!("after {k} legs, {kind}"),
            TurnLead::Straight(l) => format!("after {l:.0} m, {kind}"),
            TurnLead::Legs { legs, leg_m } => format!("after {legs} x {leg_m:.0} m, {kind}"),
        }
    }
}

/// The turn of [`TURN_DEG`](super::turns::TURN_DEG) after `lead`, sharp and spread over
/// [`CURVE_M`], each road running `after_m` past its turn; each handed to
/// `measure` from [`CURVE_M`] past the turn's first corner, where the
/// planner's stretch starts. `scn` is located at `site`; `first` is the
/// engine's start reach ([`first_straight`]).
fn turn_roads(
    scn: &Scenario,
    site: CalibrationSite,
    speed_mps: f64,
    first: f64,
    lead: TurnLead,
    after_m: f64,
    measure: &mut Measure<'_>,
) -> Result<[SimulatedDrive; 2]> {
    let lead_legs = lead.legs(first);
    let [sharp, curve] = turn_legs(&lead_legs, CURVE_M, after_m);
    let mut one = |legs: &[(f64, f64)], kind: &str| -> Result<SimulatedDrive> {
        let (truth, corners) = synthetic_drive(scn, site, speed_mps, legs)?;
        // The turn's first corner ends the lead's last leg.
        let at = corners
            .get(lead_legs.len() - 1)
            .copied()
            .ok_or_else(|| Error::InvalidParameter("calibration road without its turn".into()))?;
        measure(scn, &lead.name(kind), &truth, at + CURVE_M)
    };
    Ok([one(&sharp, "sharp")?, one(&curve, "curve")?])
}

/// The turn of [`TURN_DEG`](super::turns::TURN_DEG) after `lead` ([`TurnLead`]) in speed class
/// `speed_mps` at `site`: sharp and spread over `CURVE_M` (200 m), each road
/// driven and measured as [`simulated_reach`]'s (its turn roads are
/// `WarmUp(0)` and `WarmUp(WARM_UP_LEGS)`, the same figures).
pub fn turn_reach(
    scn: &Scenario,
    site: CalibrationSite,
    speed_mps: f64,
    rq: ReachRequirement,
    mc: &RoadRuns,
    lead: TurnLead,
) -> Result<[SimulatedDrive; 2]> {
    mc.check()?;
    check_road(speed_mps, mc.after_m)?;
    lead.check()?;
    let scn = scn.located_at([site.lat_deg, site.lon_deg]);
    // The engine's start reach, which only the warm-up legs use.
    let first = match lead {
        TurnLead::WarmUp(_) => first_straight(&scn, site, speed_mps, rq)?,
        TurnLead::Straight(l) => l,
        TurnLead::Legs { leg_m, .. } => leg_m,
    };
    turn_roads(
        &scn,
        site,
        speed_mps,
        first,
        lead,
        mc.after_m,
        &mut |scn, name, truth, from_m| Ok(measure(scn, name, truth, from_m, rq, mc)?.drive),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::network::turns::TURN_DEG;

    /// The measurement before the runs were staged, kept as the reference:
    /// every run simulates the whole road ([`simulate_with`]), then each
    /// statistic is searched on the grid separately.
    fn measure_whole(
        scn: &Scenario,
        name: &str,
        truth: &TruthSource,
        from_m: f64,
        rq: ReachRequirement,
        runs: u64,
        seed: u64,
    ) -> Result<SimulatedDrive> {
        use crate::sim::simulate_with;
        let req = rq.req_m;
        let (bound_reach_m, bound_capped, length_after) = bound_reach(scn, truth, from_m, rq)?;
        let res = simulate_with(scn, truth, &[], runs, seed, None)?;
        let errors_at = |d: f64| -> Option<Vec<f64>> {
            let at = from_m + d;
            let mut e = Vec::with_capacity(res.runs.len());
            for r in &res.runs {
                let i = r.rows.partition_point(|x| x.distance_m < at);
                e.push(r.rows.get(i)?.horizontal_m);
            }
            e.sort_by(f64::total_cmp);
            Some(e)
        };
        let crossing = |k: usize| -> (f64, bool) {
            let mut d = 0.0;
            while d <= length_after {
                match errors_at(d) {
                    Some(e) if e[k - 1] > req => return (d, false),
                    Some(_) => {}
                    None => break,
                }
                d += STEP_M;
            }
            (length_after, true)
        };
        let (k95, ku) = ranks(res.runs.len());
        let (q95_reach_m, q_capped) = crossing(k95);
        let upper = ku.map(crossing);
        Ok(SimulatedDrive {
            name: name.into(),
            from_m,
            bound_reach_m,
            q95_reach_m,
            upper_reach_m: upper.map(|u| u.0),
            capped: bound_capped || q_capped || upper.is_some_and(|u| u.1),
        })
    }

    /// Where the tests lay out their roads (the example's site).
    const HELSINKI: CalibrationSite = CalibrationSite {
        lat_deg: 60.17,
        lon_deg: 24.94,
        height_m: 10.0,
    };

    /// The requirement of `req_m` m at 0.95.
    fn rq(req_m: f64) -> ReachRequirement {
        ReachRequirement { req_m, p: 0.95 }
    }

    fn trips() -> Scenario {
        Scenario::load(std::path::Path::new(
            "scenarios/helsinki-network-trips.toml",
        ))
        .unwrap()
    }

    /// The staged runs give the figures of the whole drives, bit for bit,
    /// and stop short of the road's end once both statistics have crossed.
    /// 59 runs (the fewest with an upper bound) at 30 km/h on a road with a
    /// sharp turn 400 m from its start, measured from `CURVE_M` past it:
    /// requirements that both statistics cross early (3 and 5 m: the upper
    /// bound at 25 and 450 m, the 95th percentile at 150 and 500 m), that
    /// only the upper bound crosses (8 m) and that neither does (15 m): the
    /// last two capped, their runs driven to the road's end.
    #[test]
    fn staged_runs_give_the_whole_drives_figures() {
        let v = 30.0 / 3.6;
        let scn = trips().located_at([HELSINKI.lat_deg, HELSINKI.lon_deg]);
        let (truth, corners) =
            synthetic_drive(&scn, HELSINKI, v, &[(0.0, 400.0), (TURN_DEG, 1_500.0)]).unwrap();
        let from = corners[0] + CURVE_M;
        let end = truth.samples().last().unwrap().distance_m;
        for req in [3.0, 5.0, 8.0, 15.0] {
            let staged = measure(
                &scn,
                "road",
                &truth,
                from,
                rq(req),
                &RoadRuns::new(59, 3, 1_500.0),
            )
            .unwrap();
            let whole = measure_whole(&scn, "road", &truth, from, rq(req), 59, 3).unwrap();
            assert_eq!(staged.drive, whole, "req {req} m");
            let crossed = !whole.capped;
            assert!(whole.upper_reach_m.is_some());
            if crossed {
                // Stopped within a stage and a row past the crossing.
                let stop = from + whole.q95_reach_m + STAGE_M + 30.0;
                assert!(
                    staged.simulated_m <= stop && stop < end,
                    "req {req} m: simulated to {} m, crossing at {} m, road {end} m",
                    staged.simulated_m,
                    from + whole.q95_reach_m
                );
            } else {
                assert!(staged.simulated_m >= end - 1.0, "req {req} m");
            }
        }
    }

    /// The five roads of [`simulated_reach`] (3 runs at 50 km/h, 500 m past
    /// each reset) give the figures of the whole drives.
    #[test]
    fn five_roads_give_the_whole_drives_figures() {
        let scn = trips();
        let v = 50.0 / 3.6;
        let (runs, seed) = (3, 1);
        let mc = RoadRuns::new(runs, seed, 500.0);
        let r = simulated_reach(&scn, HELSINKI, v, rq(20.0), &mc).unwrap();
        let whole = roads(
            &scn,
            HELSINKI,
            v,
            rq(20.0),
            500.0,
            &mut |scn, name, truth, from_m| {
                measure_whole(scn, name, truth, from_m, rq(20.0), runs, seed)
            },
        )
        .unwrap();
        assert_eq!(r.drives, whole);
    }

    /// A cap stops the runs `max_after_m` past the reset: a figure that
    /// crosses before it is the uncapped one, bit for bit; one beyond it is
    /// the cap, `capped`. The road of
    /// `staged_runs_give_the_whole_drives_figures` (59 runs, 30 km/h, 1.3 km
    /// past the reset), capped at 300 m: at 3 m both statistics cross
    /// before the cap (25 and 150 m), at 5 m neither does (450 and 500 m),
    /// at 15 m nothing crosses on the whole road.
    #[test]
    fn a_cap_keeps_the_figures_below_it() {
        let v = 30.0 / 3.6;
        let scn = trips().located_at([HELSINKI.lat_deg, HELSINKI.lon_deg]);
        let (truth, corners) =
            synthetic_drive(&scn, HELSINKI, v, &[(0.0, 400.0), (TURN_DEG, 1_500.0)]).unwrap();
        let from = corners[0] + CURVE_M;
        let cap = 300.0;
        let mc = RoadRuns::new(59, 3, 1_500.0);
        let (mut below, mut beyond) = (0, 0);
        for req in [3.0, 5.0, 15.0] {
            let whole = measure(&scn, "road", &truth, from, rq(req), &mc).unwrap();
            let capped = measure(&scn, "road", &truth, from, rq(req), &mc.capped_at(cap)).unwrap();
            let (w, c) = (&whole.drive, &capped.drive);
            let want = |x: f64| if x <= cap { x } else { cap };
            let wu = w.upper_reach_m.unwrap();
            assert_eq!(c.bound_reach_m, want(w.bound_reach_m), "req {req} m");
            assert_eq!(c.q95_reach_m, want(w.q95_reach_m), "req {req} m");
            assert_eq!(c.upper_reach_m, Some(want(wu)), "req {req} m");
            let over = [w.bound_reach_m, w.q95_reach_m, wu]
                .iter()
                .filter(|&&x| x > cap)
                .count();
            assert_eq!(c.capped, over > 0, "req {req} m");
            below += 3 - over;
            beyond += over;
            // The runs stopped at the cap (within a row) or sooner.
            assert!(
                capped.simulated_m <= from + cap + 30.0,
                "req {req} m: simulated to {} m",
                capped.simulated_m
            );
        }
        assert!(below >= 2 && beyond >= 5, "{below} below, {beyond} beyond");
        for bad in [0.0, -1.0, f64::NAN] {
            let mc = mc.capped_at(bad);
            assert!(simulated_reach(&scn, HELSINKI, v, rq(3.0), &mc).is_err());
        }
    }

    /// [`turn_reach`]: `WarmUp(0)` and `WarmUp(WARM_UP_LEGS)` are
    /// [`simulated_reach`]'s turn roads, figure for figure (3 runs at
    /// 50 km/h, 500 m); the stretch after two legs starts `CURVE_M` past
    /// the second 500 m leg, after a straight `CURVE_M` past it.
    #[test]
    fn turn_reach_after_its_lead() {
        let scn = trips();
        let v = 50.0 / 3.6;
        let mc = RoadRuns::new(3, 1, 500.0);
        let r = simulated_reach(&scn, HELSINKI, v, rq(20.0), &mc).unwrap();
        let reach = |lead| turn_reach(&scn, HELSINKI, v, rq(20.0), &mc, lead);
        assert_eq!(reach(TurnLead::WarmUp(0)).unwrap()[..], r.drives[1..3]);
        assert_eq!(
            reach(TurnLead::WarmUp(WARM_UP_LEGS)).unwrap()[..],
            r.drives[3..5]
        );
        for (lead, at, name) in [
            (TurnLead::WarmUp(2), 1_000.0, "after 2 legs"),
            (TurnLead::Straight(800.0), 800.0, "after 800 m"),
        ] {
            let [s, c] = reach(lead).unwrap();
            assert_eq!(s.name, format!("{name}, sharp"));
            assert_eq!(c.name, format!("{name}, curve"));
            for d in [&s, &c] {
                assert!(
                    (d.from_m - CURVE_M - at).abs() < 0.003 * at,
                    "{}: turn at {} m",
                    d.name,
                    d.from_m - CURVE_M
                );
            }
        }
        assert!(reach(TurnLead::Straight(10.0)).is_err());
    }

    /// `TurnLead::Legs`: its legs alternate north and east, `leg_m` each,
    /// the last run on to `CALIBRATION_M` in all when they are shorter;
    /// its roads put the turn where the legs end, the stretch `CURVE_M`
    /// past it (the roads built and located, no run simulated); bad
    /// parameters are refused before any run.
    #[test]
    fn legs_lead_geometry() {
        let lead = |legs, leg_m| TurnLead::Legs { legs, leg_m };
        for (legs, leg_m, total) in [
            (6, 100.0, CALIBRATION_M),
            (31, 100.0, 3_100.0),
            (6, 200.0, CALIBRATION_M),
            (1, 50.0, CALIBRATION_M),
        ] {
            let l = lead(legs, leg_m).legs(1e9);
            assert_eq!(l.len(), legs, "{legs} x {leg_m} m");
            for (i, &(h, len)) in l.iter().enumerate() {
                assert_eq!(h, if i % 2 == 0 { 0.0 } else { 90.0 }, "leg {i}");
                if i + 1 < legs {
                    assert_eq!(len, leg_m, "leg {i}");
                }
            }
            let sum: f64 = l.iter().map(|x| x.1).sum();
            assert!((sum - total).abs() < 1e-9, "{legs} x {leg_m} m: {sum} m");
        }
        // Six legs of 500 m are the warm-up's (its first leg not cut).
        assert_eq!(
            lead(WARM_UP_LEGS, 500.0).legs(0.0),
            TurnLead::WarmUp(WARM_UP_LEGS).legs(1e9)
        );
        let scn = trips().located_at([HELSINKI.lat_deg, HELSINKI.lon_deg]);
        let v = 10.0 / 3.6;
        for (legs, leg_m, turn_at) in [(6, 100.0, CALIBRATION_M), (31, 100.0, 3_100.0)] {
            // The corners: every leg's end, the last the turn's.
            let l = lead(legs, leg_m).legs(0.0);
            let mut road = l.clone();
            road.push((l[legs - 1].0 + TURN_DEG, 1_000.0));
            let (_, corners) = synthetic_drive(&scn, HELSINKI, v, &road).unwrap();
            assert_eq!(corners.len(), legs, "{legs} x {leg_m} m");
            let mut at = 0.0;
            for (c, &(_, len)) in corners.iter().zip(&l) {
                at += len;
                assert!((c - at).abs() < 0.003 * at, "corner at {c} m, want {at} m");
            }
            let mut seen = Vec::new();
            let after = 1_000.0;
            turn_roads(
                &scn,
                HELSINKI,
                v,
                0.0,
                lead(legs, leg_m),
                after,
                &mut |_, name, truth, from_m| {
                    let end = truth.samples().last().unwrap().distance_m;
                    seen.push((name.to_string(), from_m, end));
                    Ok(SimulatedDrive {
                        name: name.into(),
                        from_m,
                        bound_reach_m: 0.0,
                        q95_reach_m: 0.0,
                        upper_reach_m: None,
                        capped: false,
                    })
                },
            )
            .unwrap();
            assert_eq!(seen.len(), 2);
            for (i, (name, from_m, end)) in seen.iter().enumerate() {
                let kind = ["sharp", "curve"][i];
                assert_eq!(name, &format!("after {legs} x {leg_m:.0} m, {kind}"));
                let turn = from_m - CURVE_M;
                assert!(
                    (turn - turn_at).abs() < 0.003 * turn_at,
                    "{name}: turn at {turn} m"
                );
                // The road runs `after` past its turn (sharp) or past the
                // curve's last corner, to the 0.3 % of the layout's
                // degree-length approximation; less the corners' arcs: the
                // truth's distance falls behind the road's chainage by
                // about 2.1 m at each right-angle corner (an arc of radius
                // 5 m, `CORNER_VERTEX_M`), so the stretch is measured from
                // that much further along (64 m after 31 legs).
                let past = end - turn;
                let tol = 0.003 * end;
                let arcs = 2.5 * legs as f64;
                assert!(
                    past > after - arcs - tol && past < after + CURVE_M + tol,
                    "{name}: {past} m"
                );
            }
        }
        let mc = RoadRuns::new(3, 1, 500.0);
        for bad in [
            lead(0, 100.0),
            lead(6, 40.0),
            lead(6, f64::NAN),
            lead(6, f64::INFINITY),
            lead(1_000, 100.0),
        ] {
            let e = turn_reach(&trips(), HELSINKI, v, rq(20.0), &mc, bad);
            assert!(
                matches!(e, Err(Error::InvalidParameter(_))),
                "{bad:?}: {e:?}"
            );
        }
    }

    /// The order statistic against the binomial CDF summed directly from
    /// its pmf (a different computation from the recurrence in logs): k − 1
    /// is the first count whose CDF reaches 0.95. The two agree to about
    /// 1e-12 at these sizes, far inside the gaps between successive CDF
    /// values (≥ 1e-4 near 0.95 for n ≤ 400).
    #[test]
    fn upper_order_statistic_is_the_binomial_bound() {
        let cdf = |n: usize, p: f64, k: usize| -> f64 {
            (0..=k)
                .map(|j| {
                    let mut c = 1.0f64;
                    for i in 0..j {
                        c *= (n - i) as f64 / (i + 1) as f64;
                    }
                    c * p.powi(j as i32) * (1.0 - p).powi((n - j) as i32)
                })
                .sum()
        };
        for n in [59usize, 60, 100, 200, 400] {
            let k = upper_order_statistic(n, 0.95, 0.95).unwrap();
            assert!(cdf(n, 0.95, k - 1) >= 0.95, "n {n} k {k}");
            assert!(
                k == 1 || cdf(n, 0.95, k - 2) < 0.95,
                "n {n} k {k} not the smallest"
            );
            assert!(k <= n);
        }
        assert_eq!(upper_order_statistic(60, 0.95, 0.95), Some(60));
        // 200 runs: the 196th smallest, the 5th largest (the module doc's
        // figure; P(Bin(200, 0.95) ≤ 195) ≥ 0.95 > P(… ≤ 194)).
        assert_eq!(upper_order_statistic(200, 0.95, 0.95), Some(196));
        assert_eq!(upper_order_statistic(10, 0.95, 0.95), None);
        assert_eq!(upper_order_statistic(0, 0.95, 0.95), None);
        assert_eq!(upper_order_statistic(10, 1.0, 0.95), None);
    }

    /// The five roads on the Helsinki trips scenario at 50 km/h, 3 runs
    /// each to keep the test short: their order, where each stretch
    /// starts, and the engine's start reach equal to the planner's
    /// ([`super::super::mm_reach::matched_reach`], the same drive and
    /// filter: 1 % for the 25 m grid here against the engine's per-sample
    /// crossing there). Too few runs for the upper bound.
    #[test]
    fn five_roads_and_the_planners_start_reach() {
        let scn = Scenario::load(std::path::Path::new(
            "scenarios/helsinki-network-trips.toml",
        ))
        .unwrap();
        let v = 50.0 / 3.6;
        let mc = RoadRuns::new(3, 1, 500.0);
        let r = simulated_reach(&scn, HELSINKI, v, rq(20.0), &mc).unwrap();
        let names: Vec<&str> = r.drives.iter().map(|d| d.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "start",
                "first turn, sharp",
                "first turn, curve",
                "calibrated turn, sharp",
                "calibrated turn, curve"
            ]
        );
        let planner = super::super::mm_reach::matched_reach(
            &scn.located_at([HELSINKI.lat_deg, HELSINKI.lon_deg]),
            HELSINKI,
            v,
            &[crate::sim::tags::Mounting::RoadSurface],
            rq(20.0),
        )
        .unwrap();
        let start = planner[0].start_reach_m;
        // The first turn's corner is where the engine's start reach ends,
        // and its stretch starts CURVE_M later.
        let first = &r.drives[1];
        assert!(
            (first.from_m - CURVE_M - start).abs() < 0.01 * start,
            "first turn at {} m, the planner's start reach {start} m",
            first.from_m - CURVE_M
        );
        // The start road runs 500 m (to the 0.2 % of the degree-length
        // approximation the legs are laid out with): shorter than the
        // reach, so capped at the road's length.
        assert!(
            r.drives[0].capped && (r.drives[0].bound_reach_m - 500.0).abs() < 1.5,
            "{:?}",
            r.drives[0]
        );
        for d in &r.drives {
            assert!(
                d.upper_reach_m.is_none(),
                "{}: 3 runs give no upper bound",
                d.name
            );
            assert!(d.q95_reach_m >= 0.0 && d.bound_reach_m >= 0.0, "{d:?}");
        }
        // The calibrated turn comes after six 500 m legs (WARM_UP_LEG_M),
        // the first cut to the start reach if shorter.
        let warm = start.min(500.0) + 5.0 * 500.0;
        let cal = &r.drives[3];
        assert!(
            (cal.from_m - CURVE_M - warm).abs() < 0.01 * warm,
            "calibrated turn at {} m, want {warm} m",
            cal.from_m - CURVE_M
        );
    }
}
