//! One run of the integrated navigator: truth → ideal IMU → sensor errors →
//! [`Filter`] with odometer (+ constraints), barometer, RFID tag and external
//! fix measurements, queued with their time stamps and applied in time order.

use super::passes::{draw_reads, find_passes, TagPass};
use super::records::{CalibrationRow, ErrorRow, PassRecord, Recorder, RunResult, TagEvent};
use super::tags::Tag;
use super::truth::{initial_estimate, run_mounting, run_odometer, start_run, TruthSource};
use crate::attitude::QuatExt;
use crate::error::Result;
use crate::nav::ekf::{NoiseModel, APSI, ATHETA, BARO, DP, DV, EPS, KOD, N, NABLA, PHI, RW};
use crate::nav::{Filter, FilterConfig, MeasurementQueue};
use crate::scenario::{Adaptive, ExternalFix, RouteKind, Scenario, TagPlace};
use crate::sensors::rng::{ids, normal, stream};
use crate::sensors::{Barometer, Imu};
use rand::Rng;

/// Random stream of the RFID reads.
const RFID_STREAM: u64 = ids::RFID;
/// Random stream of the external fix.
const FIX_STREAM: u64 = ids::FIX;

/// Tags and their passes, found once for all runs; the road network when
/// map matching aids the navigator; the truth samples of a short drive.
#[derive(Debug, Clone, Default)]
pub struct Prepared {
    /// All tags (scenario entries, then extra ones).
    pub tags: Vec<Tag>,
    /// Passes by tags within their read geometry, in time order.
    pub passes: Vec<TagPass>,
    /// The route's road network (with `aiding.map_matching`).
    pub network: Option<std::sync::Arc<crate::network::Network>>,
    /// The truth drives in its lane (a map route): the lateral place over a
    /// tag is the truth's own.
    pub lane_truth: bool,
    /// The truth samples with their ideal IMU increments, computed once and
    /// shared by every run (`None`: each run computes them as it goes, so
    /// that a long drive is never held in memory).
    pub truth_samples: Option<std::sync::Arc<Vec<crate::trajectory::TruthSample>>>,
}

impl Prepared {
    /// Resolves the scenario's tags (placing on-route ones on the truth), adds
    /// `extra` (e.g. from `--tags`) and finds the passes.
    pub fn new(scn: &Scenario, truth: &TruthSource, extra: &[Tag]) -> Result<Prepared> {
        let mut tags = scenario_tags(scn, truth)?;
        tags.extend_from_slice(extra);
        let cap = scn.duration_cap_s() + 0.5 * scn.dt;
        let passes = find_passes(truth, cap, &tags, &scn.rfid);
        let network = if scn.aiding().map_matching {
            // The truth's network: a map route's truth carries it.
            match truth.network() {
                Some(net) => Some(std::sync::Arc::clone(net)),
                None => {
                    return Err(crate::error::Error::scenario(
                        &scn.path,
                        "aiding.map_matching needs a map route ([map] and route waypoints)",
                    ))
                }
            }
        } else {
            None
        };
        Ok(Prepared {
            tags,
            passes,
            network,
            lane_truth: truth.route().is_some(),
            truth_samples: None,
        })
    }
}

/// The scenario's `[[tag]]` entries as tags; on-route ones (`at_s`, `at_m`)
/// are placed on the truth path (stored height: the path's height there).
pub fn scenario_tags(scn: &Scenario, truth: &TruthSource) -> Result<Vec<Tag>> {
    let mut tags = Vec::with_capacity(scn.tags().len());
    let mut need: Vec<(usize, bool, f64)> = Vec::new();
    for (i, t) in scn.tags().iter().enumerate() {
        let mounting = t.mounting;
        let survey = t.survey_error_m;
        let (lat, lon) = match t.place {
            TagPlace::LatLonDeg([a, b]) => (a.to_radians(), b.to_radians()),
            TagPlace::AtTime(x) => {
                need.push((i, true, x));
                (f64::NAN, f64::NAN)
            }
            TagPlace::AtDistance(x) => {
                need.push((i, false, x));
                (f64::NAN, f64::NAN)
            }
        };
        tags.push(Tag {
            id: t.id.clone(),
            lat,
            lon,
            height_m: t.height_m,
            mounting,
            survey_error_m: survey,
            lane_width_m: None,
        });
    }
    if !need.is_empty() {
        need.sort_by(|a, b| a.2.total_cmp(&b.2));
        let mut it = need.iter().peekable();
        let mut last = None;
        for avp in truth.samples() {
            while let Some(&&(i, by_time, x)) = it.peek() {
                let v = if by_time { avp.t } else { avp.distance_m };
                if v + 1e-9 < x {
                    break;
                }
                place(&mut tags[i], &avp.state);
                it.next();
            }
            if it.peek().is_none() {
                break;
            }
            last = Some(avp);
        }
        if let Some(&(i, by_time, x)) = it.next() {
            let _ = last;
            return Err(crate::error::Error::scenario(
                &scn.path,
                format!(
                    "tag[{i}].{} = {} is beyond the end of the route",
                    if by_time { "at_s" } else { "at_m" },
                    crate::scenario::short_number(x)
                ),
            ));
        }
    }
    Ok(tags)
}

fn place(tag: &mut Tag, s: &crate::nav::NavState) {
    let (rm, rn) = crate::geodesy::radii(s.lat);
    tag.lat = s.lat + tag.survey_error_m[1] / rm;
    tag.lon = s.lon + tag.survey_error_m[0] / (rn * s.lat.cos());
    if tag.height_m.is_none() {
        tag.height_m = Some(s.h);
    }
}

/// The filter settings of a scenario: priors and noise from the simulated
/// sensor models unless `[filter]` says otherwise.
pub fn filter_config(scn: &Scenario) -> FilterConfig {
    let f = scn.filter();
    let odo_sigma = f.odometer_scale_sigma;
    let mis_sigma = f.odometer_misalignment_sigma;
    let b = &scn.baro;
    let baro_sigma = (b.initial_bias_m.powi(2) + b.bias_drift_m.powi(2))
        .sqrt()
        .max(0.1);
    let (fix_rw, sage) = match (scn.external_fix(), scn.aiding().external_fix) {
        (Some(x), true) => (
            x.random_walk_m_per_rts.max(1e-3),
            if x.adaptive == Adaptive::SageHusa {
                Some(x.fading_b)
            } else {
                None
            },
        ),
        _ => (1e-3, None),
    };
    let noise = NoiseModel {
        gyro_arw: scn.imu.gyro_arw.max(0.0005f64.to_radians() / 60.0),
        accel_vrw: scn.imu.accel_vrw.max(1e-6 * crate::units::G0),
        // Constant (turn-on) biases are random constants: a Gauss–Markov
        // process with a correlation time much longer than the run.
        gyro_bias: (f.gyro_bias_sigma, f.gyro_bias_tau_s),
        accel_bias: (f.accel_bias_sigma, f.accel_bias_tau_s),
        odo_scale: (odo_sigma, f.odometer_scale_tau_s),
        odo_misalign: (mis_sigma, 1e6),
        fix_rw,
        baro_bias: (baro_sigma, b.bias_tau_s),
    };
    let [sa_level, sa_head] = f.attitude_sigma;
    let [sp_h, sp_v] = f.position_sigma_m;
    let sv = f.velocity_sigma_mps;
    let mut s0 = [0.0; N];
    s0[PHI] = sa_level;
    s0[PHI + 1] = sa_level;
    s0[PHI + 2] = sa_head;
    for k in 0..3 {
        s0[DV + k] = sv;
        s0[EPS + k] = noise.gyro_bias.0;
        s0[NABLA + k] = noise.accel_bias.0;
    }
    let (rm, rn) = match &scn.route {
        RouteKind::Motion { start, .. } => {
            let (a, b) = crate::geodesy::radii(start.lat);
            (a, b * start.lat.cos())
        }
        RouteKind::Map { waypoints, .. } => {
            let lat = waypoints[0][0].to_radians();
            let (a, b) = crate::geodesy::radii(lat);
            (a, b * lat.cos())
        }
    };
    s0[DP] = sp_h / rm;
    s0[DP + 1] = sp_h / rn;
    s0[DP + 2] = sp_v;
    s0[KOD] = odo_sigma;
    s0[ATHETA] = mis_sigma;
    s0[APSI] = mis_sigma;
    s0[RW] = 0.01;
    s0[RW + 1] = 0.01;
    s0[BARO] = baro_sigma;
    let mut cfg = FilterConfig::new(noise, s0);
    cfg.interval_s = f.interval_s;
    cfg.odo_noise_mps = f.odometer_noise_mps;
    cfg.nhc_noise_mps = f.nhc_noise_mps;
    cfg.use_nhc = scn.aiding().non_holonomic;
    cfg.sage_husa_b = sage;
    cfg
}

#[derive(Debug, Clone, Copy)]
enum Meas {
    Odometer(f64),
    Constraints,
    Height(f64),
    Tag(usize),
    Fix(f64, f64),
}

/// A run's truth samples: shared by the runs (computed once) or generated
/// for this run; an enum rather than a boxed iterator so that the loop
/// reads each sample without a call and a copy through a vtable (the
/// copies were ≈ 2 % of the demo's profile).
enum RunSamples<'a, G> {
    Shared(std::slice::Iter<'a, crate::trajectory::TruthSample>),
    Generated(G),
}

impl<G: Iterator<Item = crate::trajectory::TruthSample>> Iterator for RunSamples<'_, G> {
    type Item = crate::trajectory::TruthSample;

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        match self {
            Self::Shared(it) => it.next().copied(),
            Self::Generated(g) => g.next(),
        }
    }
}

/// One integrated run.
pub fn run_integrated(
    scn: &Scenario,
    truth: &TruthSource,
    prep: &Prepared,
    seed: u64,
    run: u64,
) -> RunResult {
    let (generated, rec) = start_run(scn, truth, None);
    match IntegratedRun::start(scn, prep, seed, run, generated, rec) {
        Some(mut r) => {
            while let Some(s) = r.samples.next() {
                r.step(&s);
            }
            r.finish()
        }
        None => RunResult::empty(run),
    }
}

/// An integrated run of [`run_integrated`] at its first truth sample
/// `first`, with its recorder `rec` (both from `start_run`), to be stepped
/// through the rest of the same samples by the caller
/// ([`IntegratedRun::step_all`], [`IntegratedRun::end`]): row for row the
/// same run. `prep` shares no truth samples (the caller does).
pub(super) fn staged_run<'a>(
    scn: &'a Scenario,
    prep: &'a Prepared,
    seed: u64,
    run: u64,
    first: crate::trajectory::TruthSample,
    rec: Recorder,
) -> Option<IntegratedRun<'a, std::iter::Once<crate::trajectory::TruthSample>>> {
    debug_assert!(prep.truth_samples.is_none());
    IntegratedRun::start(scn, prep, seed, run, std::iter::once(first), rec)
}

/// The state of one integrated run between two truth samples: its
/// navigator, sensors, random streams, measurement queue and records.
pub(super) struct IntegratedRun<'a, G> {
    scn: &'a Scenario,
    prep: &'a Prepared,
    run: u64,
    samples: RunSamples<'a, G>,
    rec: Recorder,
    aid: crate::scenario::Aiding,
    use_nhc: bool,
    mount: crate::sensors::RunMounting,
    filter: Filter,
    imu: Imu,
    baro: Barometer,
    odo: crate::sensors::Odometer,
    keep_calibration: bool,
    calibration_rows: Vec<CalibrationRow>,
    odo_every: u64,
    odo_acc: f64,
    last_distance: f64,
    reads: Vec<super::passes::TagRead>,
    next_read: usize,
    tag_events: Vec<TagEvent>,
    /// What the filter made of each read (accepted, NIS).
    read_outcome: Vec<Option<(bool, f64)>>,
    /// The distance driven at each pass (interpolated between samples).
    pass_distance: Vec<f64>,
    prev_t: f64,
    prev_d: f64,
    fix_rng: rand_chacha::ChaCha8Rng,
    xf: Option<ExternalFix>,
    next_fix: f64,
    last_fix_t: f64,
    fix_rw: [f64; 2],
    queue: MeasurementQueue<Meas>,
    map_feed: Option<super::map_feed::MapFeed<'a>>,
    /// Samples stepped so far.
    k: u64,
    /// The truth has ended and the last sample's row is recorded.
    ended: bool,
}

/// Gap to the next external fix (s).
fn fix_gap(rng: &mut rand_chacha::ChaCha8Rng, x: &ExternalFix) -> f64 {
    let [a, b] = x.interval_s;
    a + (b - a) * rng.random::<f64>()
}

impl<'a, G: Iterator<Item = crate::trajectory::TruthSample>> IntegratedRun<'a, G> {
    /// The run at its first truth sample (`None` without samples): the
    /// navigator's initial estimate and filter, the run's sensors and its
    /// first row.
    fn start(
        scn: &'a Scenario,
        prep: &'a Prepared,
        seed: u64,
        run: u64,
        generated: G,
        mut rec: Recorder,
    ) -> Option<Self> {
        let dt = scn.dt;
        let mut samples = match prep.truth_samples.as_deref() {
            Some(v) => RunSamples::Shared(v.iter()),
            None => RunSamples::Generated(generated),
        };
        let first = samples.next()?;
        let aid = scn.aiding();
        let cfg = filter_config(scn);
        let use_nhc = cfg.use_nhc;
        let mount = run_mounting(scn, seed, run);
        let mut est0 = initial_estimate(scn, &first.avp.state, &mount);
        let mut init = stream(seed, run, ids::INIT);
        {
            // Random initial errors drawn per run (the prior the filter assumes).
            let n = scn.navigator();
            let [sl, sh] = n.initial_attitude_sigma;
            let phi = [
                sl * normal(&mut init),
                sl * normal(&mut init),
                sh * normal(&mut init),
            ];
            est0.q = (crate::attitude::Quat::from_rotvec(phi.into()) * est0.q).normalized();
            let sv = n.initial_velocity_sigma_mps;
            for k in 0..3 {
                est0.v[k] += sv * normal(&mut init);
            }
            let [ph, pv] = n.initial_position_sigma_m;
            let (rm, rn) = crate::geodesy::radii(est0.lat);
            est0.lat += ph * normal(&mut init) / (rm + est0.h);
            est0.lon += ph * normal(&mut init) / ((rn + est0.h) * est0.lat.cos());
            est0.h += pv * normal(&mut init);
        }
        let filter = Filter::new(est0, first.avp.t, dt, cfg);
        let p = filter.position_cov_enu();
        rec.record_cov(0, &first.avp, est0.lat, est0.lon, est0.h, Some(p));
        // Per-run turn-on biases.
        let mut imu_model = scn.imu;
        let gr = scn.gyro_bias_random();
        let ar = scn.accel_bias_random();
        for k in 0..3 {
            imu_model.gyro_bias[k] += gr * normal(&mut init);
            imu_model.accel_bias[k] += ar * normal(&mut init);
        }
        let mut imu = Imu::new(&imu_model, dt, stream(seed, run, ids::IMU));
        imu.mount(&mount);
        let baro = Barometer::new(&scn.baro, stream(seed, run, ids::BARO));
        let odo = run_odometer(scn, &mount, seed, run);
        // Run 0 keeps its calibration at every error row (calibration.csv);
        // the others only their end state, which keeps a run's memory small.
        let keep_calibration = aid.odometer && run == 0;
        let odo_every = ((scn.filter().odometer_interval_s / dt).round() as u64).max(1);
        let mut rfid_rng = stream(seed, run, RFID_STREAM);
        let reads = if aid.rfid {
            // A map route's truth drives in its lane: the lateral place over a
            // tag is its own (issue 12, point 1).
            let rfid = crate::tags::RfidModel {
                lateral_from_truth: prep.lane_truth,
                ..scn.rfid
            };
            draw_reads(&prep.passes, &prep.tags, &rfid, &mut rfid_rng)
        } else {
            vec![]
        };
        // External fix source.
        let mut fix_rng = stream(seed, run, FIX_STREAM);
        let xf = scn.external_fix().copied().filter(|_| aid.external_fix);
        let next_fix = xf
            .as_ref()
            .map_or(f64::INFINITY, |x| first.avp.t + fix_gap(&mut fix_rng, x));
        let map_feed = prep
            .network
            .as_deref()
            .filter(|_| aid.map_matching)
            .map(|net| {
                let me = scn.map_error;
                let field =
                    super::map_error::MapErrorField::draw(seed, run, me.sigma_m, me.correlation_m);
                super::map_feed::MapFeed::on_map(
                    net,
                    first.avp.t,
                    field,
                    me.sigma_m,
                    me.correlation_m,
                )
                .with_lanes(scn.lanes)
            });
        let mut r = IntegratedRun {
            scn,
            prep,
            run,
            samples,
            rec,
            aid,
            use_nhc,
            mount,
            filter,
            imu,
            baro,
            odo,
            keep_calibration,
            calibration_rows: Vec::new(),
            odo_every,
            odo_acc: 0.0,
            last_distance: first.avp.distance_m,
            read_outcome: vec![None; reads.len()],
            tag_events: Vec::with_capacity(reads.len()),
            reads,
            next_read: 0,
            pass_distance: Vec::with_capacity(prep.passes.len()),
            prev_t: first.avp.t,
            prev_d: first.avp.distance_m,
            fix_rng,
            xf,
            next_fix,
            last_fix_t: first.avp.t,
            fix_rw: [0.0; 2],
            queue: MeasurementQueue::default(),
            map_feed,
            k: 0,
            ended: false,
        };
        if r.keep_calibration {
            let states = r.calibration_now();
            r.calibration_rows.push(CalibrationRow {
                t_s: first.avp.t,
                distance_m: first.avp.distance_m,
                states,
            });
        }
        Some(r)
    }

    /// The odometer's calibration now: (truth, estimate, filter σ) of the
    /// scale factor, pitch and yaw misalignment.
    fn calibration_now(&self) -> [[f64; 3]; 3] {
        let (k, pitch, yaw) = self.filter.odometer_calibration();
        let p = self.filter.covariance();
        let sd = |i: usize| p[(i, i)].max(0.0).sqrt();
        [
            [self.odo.scale_factor_error(), k, sd(KOD)],
            [self.mount.misalignment[0], pitch, sd(ATHETA)],
            [self.mount.misalignment[1], yaw, sd(APSI)],
        ]
    }

    /// One truth sample: the IMU, the sensors due, their updates in time
    /// order, the map feed and the row.
    #[inline]
    fn step(&mut self, s: &crate::trajectory::TruthSample) {
        let scn = self.scn;
        let prep = self.prep;
        let dt = scn.dt;
        self.k += 1;
        let k = self.k;
        let t = s.avp.t;
        while let Some(p) = prep.passes.get(self.pass_distance.len()) {
            if p.t_abeam > t {
                break;
            }
            let w = if t > self.prev_t {
                ((p.t_abeam - self.prev_t) / (t - self.prev_t)).clamp(0.0, 1.0)
            } else {
                1.0
            };
            self.pass_distance
                .push(self.prev_d + w * (s.avp.distance_m - self.prev_d));
        }
        (self.prev_t, self.prev_d) = (t, s.avp.distance_m);
        let m = self.imu.measure(&s.imu);
        let filter = &mut self.filter;
        filter.step(&m);
        // Sensors due at this epoch.
        let d_true = s.avp.distance_m - self.last_distance;
        self.last_distance = s.avp.distance_m;
        // A failed odometer reads nothing: zero distance.
        self.odo_acc += self
            .odo
            .measure(t, s.avp.distance_m, d_true, dt)
            .unwrap_or(0.0);
        let queue = &mut self.queue;
        if k % self.odo_every == 0 {
            if self.aid.odometer {
                queue.push(t, Meas::Odometer(self.odo_acc));
            } else if self.use_nhc {
                queue.push(t, Meas::Constraints);
            }
            self.odo_acc = 0.0;
        }
        if self.aid.baro {
            if let Some(h) = self.baro.measure(t, s.avp.state.h) {
                queue.push(t, Meas::Height(h));
            }
        }
        let reads = &self.reads;
        while self.next_read < reads.len() && reads[self.next_read].t <= t {
            queue.push(reads[self.next_read].t, Meas::Tag(self.next_read));
            self.next_read += 1;
        }
        if let Some(x) = &self.xf {
            if t >= self.next_fix {
                let gap_s = t - self.last_fix_t;
                self.last_fix_t = t;
                self.next_fix = t + fix_gap(&mut self.fix_rng, x);
                let (rm, rn) = crate::geodesy::radii(s.avp.state.lat);
                for r in self.fix_rw.iter_mut() {
                    *r += x.random_walk_m_per_rts * gap_s.sqrt() * normal(&mut self.fix_rng);
                }
                let we = x.white_m * normal(&mut self.fix_rng);
                let wn = x.white_m * normal(&mut self.fix_rng);
                let lat = s.avp.state.lat + (self.fix_rw[1] + wn) / rm;
                let lon = s.avp.state.lon + (self.fix_rw[0] + we) / (rn * s.avp.state.lat.cos());
                queue.push(t, Meas::Fix(lat, lon));
            }
        }
        while let Some((tm, meas)) = queue.pop_due(t) {
            match meas {
                Meas::Odometer(ds) => {
                    filter.update_odometer(ds);
                }
                Meas::Constraints => {
                    filter.update_constraints();
                }
                Meas::Height(h) => {
                    let var = scn.baro.noise_m.powi(2).max(0.01);
                    filter.update_height(tm, h, var);
                }
                Meas::Tag(i) => {
                    let r = &reads[i];
                    let tag = &prep.tags[r.tag];
                    let cov = scn
                        .rfid
                        .with_lane_width(tag.lane_width_m)
                        .fix_covariance(r.mounting, filter.state());
                    let o = filter.update_position(
                        tm,
                        r.lat,
                        r.lon,
                        r.height_m,
                        cov,
                        scn.rfid.fix_height_var(),
                    );
                    self.read_outcome[i] = Some((o.accepted, o.nis));
                    self.tag_events.push(TagEvent {
                        tag_id: tag.id.clone(),
                        t_s: tm,
                        accepted: o.accepted,
                        nis: o.nis,
                    });
                }
                Meas::Fix(lat, lon) => {
                    let x = self.xf.as_ref().expect("fix source");
                    let w = x.filter_white_m.max(1e-3);
                    filter.update_external_fix(tm, lat, lon, w * w);
                }
            }
        }
        if let Some(feed) = self.map_feed.as_mut() {
            feed.step_with_truth(t, filter, Some(&s.avp.state));
        }
        let st = filter.state();
        if self.rec.due(k) {
            let cov = Some(filter.position_cov_enu());
            self.rec.record_cov(k, &s.avp, st.lat, st.lon, st.h, cov);
            if self.keep_calibration {
                let states = self.calibration_now();
                self.calibration_rows.push(CalibrationRow {
                    t_s: s.avp.t,
                    distance_m: s.avp.distance_m,
                    states,
                });
            }
        } else {
            self.rec.pending = Some((s.avp, st.lat, st.lon, st.h, None));
        }
    }

    /// Steps the run through `samples`, the truth's next ones.
    pub(super) fn step_all(&mut self, samples: &[crate::trajectory::TruthSample]) {
        for s in samples {
            self.step(s);
        }
    }

    /// The rows recorded so far.
    pub(super) fn rows(&self) -> &[ErrorRow] {
        &self.rec.rows
    }

    /// The truth has ended: the last sample's row, with the filter's
    /// covariance, and its calibration.
    pub(super) fn end(&mut self) {
        if self.ended {
            return;
        }
        self.ended = true;
        if self.rec.pending.is_some() {
            let cov = self.filter.position_cov_enu();
            let states = self.keep_calibration.then(|| self.calibration_now());
            if let Some(p) = self.rec.pending.as_mut() {
                p.4 = Some(cov);
                if let Some(states) = states {
                    self.calibration_rows.push(CalibrationRow {
                        t_s: p.0.t,
                        distance_m: p.0.distance_m,
                        states,
                    });
                }
            }
        }
        self.rec.flush();
    }

    /// The run's result, at the end of its truth.
    fn finish(mut self) -> RunResult {
        self.end();
        let prep = self.prep;
        let mut read_of_pass: Vec<Option<usize>> = vec![None; prep.passes.len()];
        for (i, r) in self.reads.iter().enumerate() {
            read_of_pass[r.pass] = Some(i);
        }
        let tag_passes = prep
            .passes
            .iter()
            .zip(&self.pass_distance)
            .zip(&read_of_pass)
            .map(|((p, &d), r)| {
                let outcome = r.and_then(|i| self.read_outcome[i]);
                PassRecord {
                    t_s: p.t_abeam,
                    distance_m: d,
                    tag_id: prep.tags[p.tag].id.clone(),
                    mounting: prep.tags[p.tag].mounting,
                    read: r.is_some(),
                    read_t_s: r.map(|i| self.reads[i].t),
                    accepted: outcome.map(|o| o.0),
                    nis: outcome.map(|o| o.1),
                }
            })
            .collect();
        let calibration = self.aid.odometer.then(|| self.calibration_now());
        RunResult {
            run: self.run,
            rows: std::mem::take(&mut self.rec.rows),
            tag_events: std::mem::take(&mut self.tag_events),
            tag_passes,
            counts: Some(self.filter.counts),
            map_feed: self.map_feed.take().map(|f| f.counts),
            calibration,
            calibration_rows: std::mem::take(&mut self.calibration_rows),
        }
    }

    /// The rows so far as a run's result, without the rest.
    pub(super) fn into_rows_so_far(self) -> RunResult {
        RunResult {
            rows: self.rec.rows,
            ..RunResult::empty(self.run)
        }
    }
}
