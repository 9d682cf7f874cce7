//! The perfect-data covariance engine: the integrated navigator's own
//! [`Filter`] stepped along a truth with perfect data (ideal IMU
//! increments, exact odometer distances and heights, the map-matching feed
//! where asked), so that its state stays on the truth and its covariance is
//! the predicted one: no random runs. The route budget
//! (`planner::budget`) and the network reach analysis
//! (`planner::network::reach`) both propagate and fix the filter through
//! this one engine.
//!
//! It also holds the one definition of the horizontal 95 % bound,
//! [`bound95`], used by the planner, the simulator's rows (the report's
//! filter bound) and the report.

use super::integrated::filter_config;
use super::map_feed::MapFeed;
use super::tags::{Mounting, RfidModel};
use crate::nav::{Filter, FilterConfig};
use crate::network::Network;
use crate::scenario::Scenario;
use crate::sensors::odometer::OdometerFailure;
use crate::trajectory::{Avp, TruthSample};

/// χ²(2 dof) 95 % quantile.
pub const CHI2_2_95: f64 = 5.991_464_547_107_979;

/// The horizontal 95 % bound (m) of an east-north covariance (m²; the upper
/// left 2×2 block of `c`): `sqrt(χ²₂(0.95) · λmax)`, the radius of the circle
/// that contains the 95 % error ellipse.
///
/// Why this definition: it is a guaranteed (conservative) bound — the
/// circle contains the whole 95 % ellipse, so the probability inside it is
/// at least 95 % whatever the ellipse's shape — and it is what the planner
/// has always used, so no plan changes. The exact radius of the circle
/// holding 95 % of the 2-D Gaussian equals this bound for a circular
/// covariance and shrinks to `1.96·sqrt(λmax)` for a one-axis covariance:
/// it lies between 0.80 times this bound and this bound.
///
/// ```
/// use waymark::sim::{bound95, CHI2_2_95};
/// // A circular covariance of σ = 2 m per axis: the radius √(5.991)·2 m.
/// let c = [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 9.0]];
/// assert!((bound95(&c) - 2.0 * CHI2_2_95.sqrt()).abs() < 1e-12);
/// // An ellipse with a correlation: the largest eigenvalue of
/// // [[5, 2], [2, 2]] is 6, whatever the vertical variance.
/// let c = [[5.0, 2.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 100.0]];
/// assert!((bound95(&c) - (CHI2_2_95 * 6.0).sqrt()).abs() < 1e-12);
/// ```
pub fn bound95(c: &[[f64; 3]; 3]) -> f64 {
    (CHI2_2_95 * lambda_max_2x2(c[0][0], c[0][1], c[1][1])).sqrt()
}

/// The largest eigenvalue of the symmetric 2×2 `[[a, b], [b, d]]`, at
/// least 0 (round-off can make a covariance's slightly negative): the
/// closed form `(a + d)/2 + √(((a − d)/2)² + b²)`.
///
/// ```
/// use waymark::sim::lambda_max_2x2;
/// assert_eq!(lambda_max_2x2(5.0, 2.0, 2.0), 6.0);
/// assert_eq!(lambda_max_2x2(-1.0, 0.0, -2.0), 0.0);
/// ```
pub fn lambda_max_2x2(a: f64, b: f64, d: f64) -> f64 {
    let tr = 0.5 * (a + d);
    let disc = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    (tr + disc).max(0.0)
}

/// The horizontal bound (m) at probability `p` of an east-north covariance
/// (the upper left 2×2 block of `c`): `σ_max · sqrt(−2 ln(1 − p))`, the
/// radius of the circle that contains the error ellipse of probability `p`
/// (χ²₂'s quantile is `−2 ln(1 − p)` in closed form). Conservative in the
/// same way as [`bound95`], which it equals at `p = 0.95`.
///
/// ```
/// use waymark::sim::{bound95, bound_at};
/// let c = [[5.0, 2.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]];
/// assert!((bound_at(&c, 0.95) - bound95(&c)).abs() < 1e-9);
/// // 99 %: σ_max · 3.035.
/// assert!((bound_at(&c, 0.99) - 6f64.sqrt() * (-2.0 * 0.01f64.ln()).sqrt()).abs() < 1e-12);
/// ```
pub fn bound_at(c: &[[f64; 3]; 3], p: f64) -> f64 {
    (-2.0 * (1.0 - p).ln() * lambda_max_2x2(c[0][0], c[0][1], c[1][1])).sqrt()
}

/// [`bound95`] of a diagonal covariance given by its two 1σ (m): an
/// uncorrelated east and north (e.g. a filter's `sigma_east_m` and
/// `sigma_north_m` as `errors.csv` gives them), or a fix's along- and
/// cross-track σ. Its largest eigenvalue is the larger variance.
///
/// ```
/// use waymark::sim::{bound95, bound95_of_sigmas};
/// let c = [[9.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
/// assert_eq!(bound95_of_sigmas([3.0, 1.0]), bound95(&c));
/// ```
pub fn bound95_of_sigmas(sigma: [f64; 2]) -> f64 {
    (CHI2_2_95 * sigma[0].max(sigma[1]).powi(2)).sqrt()
}

/// The filter settings and the perfect measurements of a scenario.
#[derive(Debug, Clone)]
pub struct PerfectData<'a> {
    dt: f64,
    cfg: FilterConfig,
    aid_odometer: bool,
    aid_baro: bool,
    odo_every: usize,
    baro_every: usize,
    baro_var: f64,
    failure: Option<OdometerFailure>,
    network: Option<&'a Network>,
    rfid: RfidModel,
    map_error: crate::scenario::MapErrorModel,
    lanes: crate::scenario::LaneModel,
}

impl<'a> PerfectData<'a> {
    /// The scenario's filter and aiding on perfect data, with the
    /// scenario's odometer failure (fault injection) and no map matching.
    pub fn new(scn: &Scenario) -> Self {
        let dt = scn.dt;
        Self {
            dt,
            cfg: filter_config(scn),
            aid_odometer: scn.aiding().odometer,
            aid_baro: scn.aiding().baro,
            odo_every: ((scn.filter().odometer_interval_s / dt).round() as usize).max(1),
            baro_every: (1.0 / dt).round().max(1.0) as usize,
            baro_var: scn.baro.noise_m.powi(2).max(0.01),
            failure: scn.odometer.failure,
            network: None,
            rfid: scn.rfid,
            map_error: scn.map_error,
            lanes: scn.lanes,
        }
    }

    /// With the map-matching feed on `network` (when given).
    pub fn with_map_feed(mut self, network: Option<&'a Network>) -> Self {
        self.network = network;
        self
    }

    /// Without the scenario's odometer failure (a drive that is not the
    /// scenario's route, where its failure time and distance mean nothing).
    pub fn without_faults(mut self) -> Self {
        self.failure = None;
        self
    }

    /// Whether a propagation started at a truth sample goes through the
    /// very same updates as one started earlier and carried on through
    /// that sample: true without a map-matching feed (which restarts with
    /// each propagation). Odometer readings are: a propagation resumed at
    /// a sample ([`PerfectData::resume`]) counts the distance from the
    /// drive's last odometer epoch, the interval the filter's own odometer
    /// accumulators cover. The constraints, the barometer and the fixes
    /// are on the drive's own schedule.
    pub fn restart_invariant(&self) -> bool {
        self.network.is_none()
    }

    /// The odometer interval (IMU samples) when every odometer epoch of the
    /// drive (`i % interval == 0`) brings the covariance to that epoch and
    /// restarts the propagation's accumulators (an odometer or constraint
    /// update does, and one happens at every such epoch): then two
    /// propagations of the same drive that differ only in the fixes they
    /// read (a fix brings the covariance to its own sample, which shifts
    /// the propagation intervals after it) go through the same ops again
    /// from the first odometer epoch after the last fix. None otherwise.
    pub fn resync_every(&self) -> Option<usize> {
        let flushes = self.cfg.use_nhc || (self.aid_odometer && self.failure.is_none());
        flushes.then_some(self.odo_every)
    }

    /// A filter on the truth `avp` with the scenario's prior.
    pub fn filter_at(&self, avp: &Avp) -> Filter {
        Filter::new(avp.state, avp.t, self.dt, self.cfg)
    }

    /// [`PerfectData::start`] for a filter at drive sample `i` (distance
    /// `distance_m`) that has been stepped along the drive up to there: the
    /// first odometer reading counts the distance since the drive's last
    /// odometer epoch (`epoch_distance_m`, at sample `i − i mod interval`),
    /// which is the interval the filter's own odometer accumulators cover,
    /// so that a resumed propagation reads what one carried on from the
    /// drive's start reads.
    pub fn resume(
        &self,
        filter: &Filter,
        distance_m: f64,
        epoch_distance_m: f64,
    ) -> Propagation<'_, 'a> {
        let mut p = self.start(filter, distance_m);
        p.odo_acc = distance_m - epoch_distance_m;
        p
    }

    /// The odometer interval (IMU samples).
    pub fn odometer_every(&self) -> usize {
        self.odo_every
    }

    /// Starts propagating `filter`, which is at a truth sample at distance
    /// `distance_m` (the map-matching feed starts there).
    pub fn start(&self, filter: &Filter, distance_m: f64) -> Propagation<'_, 'a> {
        Propagation {
            data: self,
            // The truth drives on the map's geometry; the fixes carry the
            // scenario's map-error noise model (issue 12) and its lanes'
            // (the lane choice and wander as noise, as the simulator's
            // navigator feeds them), so the predicted covariance is the
            // navigator's on an erroneous map, driving in its lane.
            feed: self.network.map(|n| {
                MapFeed::with_noise_model(
                    n,
                    filter.time(),
                    self.map_error.sigma_m,
                    self.map_error.correlation_m,
                )
                .with_lanes(self.lanes)
            }),
            odo_acc: 0.0,
            last_d: distance_m,
        }
    }

    /// The fix a tag of `mounting` gives at truth `avp` (lane width
    /// `lane_width_m` where known), applied to `f` with the mounting's
    /// covariance at the speed there.
    pub fn apply_fix(
        &self,
        avp: &Avp,
        f: &mut Filter,
        mounting: Mounting,
        lane_width_m: Option<f64>,
    ) {
        let a = avp;
        let cov = self
            .rfid
            .with_lane_width(lane_width_m)
            .fix_covariance(mounting, &a.state);
        f.update_position(
            a.t,
            a.state.lat,
            a.state.lon,
            Some(a.state.h),
            cov,
            self.rfid.fix_height_var(),
        );
    }
}

/// A filter being stepped along the truth: the odometer distance since the
/// last odometer update and the map-matching feed.
#[derive(Debug)]
pub struct Propagation<'d, 'a> {
    data: &'d PerfectData<'a>,
    feed: Option<MapFeed<'a>>,
    odo_acc: f64,
    last_d: f64,
}

impl Propagation<'_, '_> {
    /// Steps `filter` to truth sample `s` (index `i` from the drive's first
    /// sample): the IMU increment, then the odometer (or the constraints),
    /// barometer and map-matching updates due there, as in the navigator.
    pub fn step(&mut self, i: usize, s: &TruthSample, filter: &mut Filter) {
        let d = self.data;
        filter.step(&s.imu);
        self.odo_acc += s.avp.distance_m - self.last_d;
        self.last_d = s.avp.distance_m;
        if i % d.odo_every == 0 {
            // A failed odometer (fault injection) is modelled as the
            // filter ends up treating it: disabled, constraints only.
            let failed = d.failure.is_some_and(|f| {
                f.from_s.is_some_and(|x| s.avp.t >= x)
                    || f.from_m.is_some_and(|x| s.avp.distance_m >= x)
            });
            if d.aid_odometer && !failed {
                filter.update_odometer(self.odo_acc);
            } else if d.cfg.use_nhc {
                filter.update_constraints();
            }
            self.odo_acc = 0.0;
        }
        if d.aid_baro && i % d.baro_every == 0 {
            filter.update_height(s.avp.t, s.avp.state.h, d.baro_var);
        }
        if let Some(f) = self.feed.as_mut() {
            f.step(s.avp.t, filter);
        }
    }
}
