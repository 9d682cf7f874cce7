//! The perfect-data covariance engine: the integrated navigator's own
//! [`Filter`] stepped along a truth with perfect data (ideal IMU
//! increments, exact odometer distances and heights, the map-matching feed
//! where asked), so that its state stays on the truth and its covariance is
//! the predicted one: no random runs. The route budget
//! (`planner::budget`) and the network reach analysis
//! (`planner::network::reach`) both propagate and fix the filter through
//! this one engine.
//!
//! It re-exports the one definition of the horizontal 95 % bound,
//! [`bound95`] (`sim::bound`), used by the planner, the simulator's rows
//! (the report's filter bound) and the report.

use super::integrated::filter_config;
use super::map_feed::MapFeed;
use super::tags::{Mounting, RfidModel};
use crate::nav::{Filter, FilterConfig};
use crate::network::Network;
use crate::scenario::Scenario;
use crate::sensors::odometer::OdometerFailure;
use crate::trajectory::{Avp, TruthSample};

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
