//! One simulation run and Monte Carlo: truth → ideal IMU → sensor errors →
//! navigator (free inertial, odometer dead reckoning or gyro-free 3-D dead
//! reckoning) → navigation error (estimate minus truth) at the output interval.
//!
//! The truth is streamed sample by sample (nothing at the IMU rate is stored),
//! so a 3.6 h run at 100 Hz needs no more memory than its output rows.

use super::metrics::{summarize, Summary};
use super::scenario::{NavMode, RouteKind, Scenario, VerticalChannel};
use super::tags::{find_passes, Tag, TagPass};
use crate::attitude::{Quat, QuatExt, V3};
use crate::error::Result;
use crate::geodesy::radii;
use crate::nav::{BaroDamping, Dr3d, NavState, OdometerDr, Strapdown};
use crate::sensors::odometer::wheel_distances;
use crate::sensors::rng::{ids, normal, stream};
use crate::sensors::{Barometer, DiffOdometer, Imu, Odometer, RotationModulation};
use crate::trajectory::route::RoutePlan;
use crate::trajectory::{ideal_imu, Avp, MotionPlan};
use rayon::prelude::*;

/// Default time constant of the baro damping loop (s).
pub const DEFAULT_VERTICAL_TAU_S: f64 = 50.0;

/// Navigation error at one output time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorRow {
    /// Time (s).
    pub t_s: f64,
    /// Distance travelled (m).
    pub distance_m: f64,
    /// East error, estimate minus truth (m).
    pub east_m: f64,
    /// North error (m).
    pub north_m: f64,
    /// Up error (m).
    pub up_m: f64,
    /// Horizontal error (m).
    pub horizontal_m: f64,
    /// Filter 1σ east (m); NaN without a filter.
    pub sigma_east_m: f64,
    /// Filter 1σ north (m); NaN without a filter.
    pub sigma_north_m: f64,
    /// Filter 1σ up (m); NaN without a filter.
    pub sigma_up_m: f64,
    /// Horizontal normalised estimation error squared e^T P^{-1} e (2 dof);
    /// NaN without a filter.
    pub nees_h: f64,
}

/// What happened to one tag read in a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TagEvent {
    /// The tag.
    pub tag_id: String,
    /// Read time (s).
    pub t_s: f64,
    /// Whether the filter accepted the fix.
    pub accepted: bool,
    /// Its normalised innovation squared.
    pub nis: f64,
}

/// A pass of the vehicle by a tag in one run, and what came of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PassRecord {
    /// Time the vehicle is abeam the tag (s).
    pub t_s: f64,
    /// Distance driven then (m).
    pub distance_m: f64,
    /// The tag.
    pub tag_id: String,
    /// Its mounting.
    pub mounting: super::tags::Mounting,
    /// Whether the reader read it (false: missed, or RFID aiding off).
    pub read: bool,
    /// Time of the read (s), if read.
    pub read_t_s: Option<f64>,
    /// Whether the filter accepted the fix (None: not read, or read after the run ended).
    pub accepted: Option<bool>,
    /// The fix's normalised innovation squared, if the filter saw it.
    pub nis: Option<f64>,
}

/// The rows of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// Monte Carlo run index.
    pub run: u64,
    /// Error rows at the output interval.
    pub rows: Vec<ErrorRow>,
    /// Tag reads and the filter's verdicts (integrated mode).
    pub tag_events: Vec<TagEvent>,
    /// Every pass by a tag, read or missed, in time order (integrated mode).
    pub tag_passes: Vec<PassRecord>,
    /// Update counts (integrated mode).
    pub counts: Option<crate::nav::integrated::UpdateCounts>,
    /// What the map-matching feed did (integrated mode with `aiding.map_matching`).
    pub map_feed: Option<super::map_feed::FeedCounts>,
}

/// All runs and their summary.
#[derive(Debug, Clone)]
pub struct SimResult {
    /// Runs in index order.
    pub runs: Vec<RunResult>,
    /// Metrics.
    pub summary: Summary,
}

/// Where the truth comes from: compiled once, streamed once per run.
#[derive(Debug, Clone)]
pub enum TruthSource {
    /// Motion commands.
    Motion(MotionPlan),
    /// A road route.
    Route(Box<RoutePlan>),
}

impl TruthSource {
    /// Builds the truth source of a scenario (loads the map for a map route).
    pub fn new(scn: &Scenario) -> Result<TruthSource> {
        match &scn.route {
            RouteKind::Motion { start, commands } => Ok(TruthSource::Motion(MotionPlan::new(
                *start, commands, scn.dt,
            )?)),
            RouteKind::Map {
                map,
                waypoints,
                profile,
                stops,
                height_m,
            } => {
                let net = crate::network::Network::load(map, &Default::default())?;
                let route = crate::route::plan_route(&net, waypoints).map_err(|e| {
                    crate::error::Error::scenario(&scn.path, format!("route[0]: {e}"))
                })?;
                let plan = RoutePlan::new(&net, &route, profile, stops, *height_m, scn.dt)
                    .map_err(|e| {
                        crate::error::Error::scenario(&scn.path, format!("route[0]: {e}"))
                    })?;
                Ok(TruthSource::Route(Box::new(plan)))
            }
        }
    }

    /// The truth samples.
    pub fn samples(&self) -> Box<dyn Iterator<Item = Avp> + Send + '_> {
        match self {
            TruthSource::Motion(p) => Box::new(p.trajectory()),
            TruthSource::Route(p) => Box::new(p.trajectory()),
        }
    }

    /// Duration (s).
    pub fn duration_s(&self) -> f64 {
        match self {
            TruthSource::Motion(p) => p.duration_s,
            TruthSource::Route(p) => p.duration_s,
        }
    }
}

/// Runs `runs` Monte Carlo runs of a scenario with base seed `seed`.
pub fn simulate(scn: &Scenario, truth: &TruthSource, runs: u64, seed: u64) -> Result<SimResult> {
    simulate_with(scn, truth, &[], runs, seed, None)
}

/// Tags and their passes, found once for all runs; the road network when
/// map matching aids the navigator.
#[derive(Debug, Clone, Default)]
pub struct Prepared {
    /// All tags (scenario entries, then extra ones).
    pub tags: Vec<Tag>,
    /// Passes by tags within their read geometry, in time order.
    pub passes: Vec<TagPass>,
    /// The route's road network (with `aiding.map_matching`).
    pub network: Option<std::sync::Arc<crate::network::Network>>,
}

impl Prepared {
    /// Resolves the scenario's tags (placing on-route ones on the truth), adds
    /// `extra` (e.g. from `--tags`) and finds the passes.
    pub fn new(scn: &Scenario, truth: &TruthSource, extra: &[Tag]) -> Result<Prepared> {
        let mut tags = super::integrated::scenario_tags(scn, truth)?;
        tags.extend_from_slice(extra);
        let cap = scn.file.duration_s.unwrap_or(f64::INFINITY) + 0.5 * scn.dt;
        let passes = find_passes(truth, cap, &tags, &scn.rfid);
        let network = if scn.file.aiding.map_matching {
            match &scn.route {
                RouteKind::Map { map, .. } => Some(std::sync::Arc::new(
                    crate::network::Network::load(map, &Default::default())?,
                )),
                RouteKind::Motion { .. } => {
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
        })
    }
}

/// Monte Carlo with extra tags (`--tags`) and a progress callback called
/// after each run (from worker threads).
pub fn simulate_with(
    scn: &Scenario,
    truth: &TruthSource,
    extra_tags: &[Tag],
    runs: u64,
    seed: u64,
    progress: Option<&(dyn Fn() + Sync)>,
) -> Result<SimResult> {
    if runs == 0 {
        return Err(crate::error::Error::InvalidParameter(
            "the number of runs must be at least 1".into(),
        ));
    }
    let integrated = scn.file.navigator.mode == NavMode::Integrated;
    if integrated && scn.rotation.is_some() {
        return Err(crate::error::Error::scenario(
            &scn.path,
            "navigator.mode = \"integrated\" does not support imu.rotation_modulation",
        ));
    }
    if !integrated && scn.file.aiding.map_matching {
        return Err(crate::error::Error::scenario(
            &scn.path,
            "aiding.map_matching is used only by navigator.mode = \"integrated\"",
        ));
    }
    if !integrated && (!extra_tags.is_empty() || !scn.file.tag.is_empty()) {
        return Err(crate::error::Error::scenario(
            &scn.path,
            "tags are used only by navigator.mode = \"integrated\"",
        ));
    }
    let prep = if integrated {
        Prepared::new(scn, truth, extra_tags)?
    } else {
        Prepared::default()
    };
    tracing::info!(
        scenario = %scn.file.name,
        runs,
        seed,
        tags = prep.tags.len(),
        tag_passes = prep.passes.len(),
        "simulating"
    );
    let t0 = std::time::Instant::now();
    let results: Vec<RunResult> = (0..runs)
        .into_par_iter()
        .map(|run| {
            let r = if integrated {
                super::integrated::run_integrated(scn, truth, &prep, seed, run)
            } else {
                run_once(scn, truth, seed, run)
            };
            tracing::debug!(run, rows = r.rows.len(), "run done");
            if let Some(p) = progress {
                p();
            }
            r
        })
        .collect();
    let summary = summarize(scn, seed, &results);
    tracing::info!(
        runs,
        max_horizontal_error_m = summary.max_horizontal_error_m,
        elapsed_ms = t0.elapsed().as_secs_f64() * 1e3,
        "simulation done"
    );
    Ok(SimResult {
        runs: results,
        summary,
    })
}

/// Applies the rotation modulation (if any) to the truth attitude: the IMU
/// frame is what the inverse strapdown must see.
pub(super) fn imu_frame(avp: Avp, rot: Option<RotationModulation>) -> Avp {
    match rot {
        Some(r) => {
            let mut a = avp;
            a.state.q = r.imu_attitude(&avp.state.q, avp.t);
            a
        }
        None => avp,
    }
}

fn body_q(q_imu: &Quat, t: f64, rot: Option<RotationModulation>) -> Quat {
    match rot {
        Some(r) => r.body_attitude(q_imu, t),
        None => *q_imu,
    }
}

/// The navigator's initial state: truth plus the scenario's initial errors
/// (attitude errors on the body's pitch, roll and heading).
pub(super) fn initial_estimate(scn: &Scenario, truth_body: &NavState) -> NavState {
    let n = &scn.file.navigator;
    let (pitch, roll, yaw) = truth_body.q.to_euler();
    let [dp, dr, dh] = scn.initial_attitude_error;
    let q = Quat::from_euler(pitch + dp, roll + dr, yaw - dh);
    let (rm, rn) = radii(truth_body.lat);
    let [pe, pn, pu] = n.initial_position_error_m;
    let dv = n.initial_velocity_error_mps;
    NavState {
        q,
        v: [
            truth_body.v[0] + dv[0],
            truth_body.v[1] + dv[1],
            truth_body.v[2] + dv[2],
        ]
        .into(),
        lat: truth_body.lat + pn / (rm + truth_body.h),
        lon: truth_body.lon + pe / ((rn + truth_body.h) * truth_body.lat.cos()),
        h: truth_body.h + pu,
    }
}

/// Estimate minus truth in local metres (east, north, up).
#[inline]
fn error_enu(lat: f64, lon: f64, h: f64, truth: &NavState) -> [f64; 3] {
    let (rm, rn) = radii(truth.lat);
    [
        (lon - truth.lon) * (rn + truth.h) * truth.lat.cos(),
        (lat - truth.lat) * (rm + truth.h),
        h - truth.h,
    ]
}

type Cov3 = Option<[[f64; 3]; 3]>;

/// The truth of one run up to the scenario's duration cap, as ideal IMU
/// samples in the IMU's frame (rotation-modulated when `rot` is given), and
/// the recorder of its error rows at the output interval.
pub(super) fn start_run<'a>(
    scn: &Scenario,
    truth: &'a TruthSource,
    rot: Option<RotationModulation>,
) -> (
    impl Iterator<Item = crate::trajectory::TruthSample> + 'a,
    Recorder,
) {
    let dt = scn.dt;
    let cap = scn.file.duration_s.unwrap_or(f64::INFINITY) + 0.5 * dt;
    let body = truth.samples().take_while(move |a| a.t <= cap);
    let samples = ideal_imu(body.map(move |a| imu_frame(a, rot)), dt);
    let rec = Recorder {
        every: ((scn.output_interval_s / dt).round() as u64).max(1),
        rows: Vec::with_capacity((truth.duration_s() / scn.output_interval_s) as usize + 2),
        pending: None,
    };
    (samples, rec)
}

impl RunResult {
    /// A run with no samples.
    pub(super) fn empty(run: u64) -> Self {
        RunResult {
            run,
            rows: vec![],
            tag_events: vec![],
            tag_passes: vec![],
            counts: None,
            map_feed: None,
        }
    }
}

/// Keeps a row every `every` samples, and the last sample's row at the end.
pub(super) struct Recorder {
    pub(super) every: u64,
    pub(super) rows: Vec<ErrorRow>,
    pub(super) pending: Option<(Avp, f64, f64, f64, Cov3)>,
}

impl Recorder {
    fn row(avp: &Avp, lat: f64, lon: f64, h: f64, cov: Cov3) -> ErrorRow {
        let e = error_enu(lat, lon, h, &avp.state);
        let (se, sn, su, nees) = match cov {
            Some(c) => {
                let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
                let nees = if det > 0.0 {
                    (e[0] * e[0] * c[1][1] - 2.0 * e[0] * e[1] * c[0][1] + e[1] * e[1] * c[0][0])
                        / det
                } else {
                    f64::NAN
                };
                (c[0][0].sqrt(), c[1][1].sqrt(), c[2][2].sqrt(), nees)
            }
            None => (f64::NAN, f64::NAN, f64::NAN, f64::NAN),
        };
        ErrorRow {
            t_s: avp.t,
            distance_m: avp.distance_m,
            east_m: e[0],
            north_m: e[1],
            up_m: e[2],
            horizontal_m: e[0].hypot(e[1]),
            sigma_east_m: se,
            sigma_north_m: sn,
            sigma_up_m: su,
            nees_h: nees,
        }
    }

    #[inline]
    fn record(&mut self, k: u64, avp: &Avp, lat: f64, lon: f64, h: f64) {
        self.record_cov(k, avp, lat, lon, h, None)
    }

    #[inline]
    pub(super) fn due(&self, k: u64) -> bool {
        k % self.every == 0
    }

    #[inline]
    pub(super) fn record_cov(&mut self, k: u64, avp: &Avp, lat: f64, lon: f64, h: f64, cov: Cov3) {
        if self.due(k) {
            self.rows.push(Self::row(avp, lat, lon, h, cov));
            self.pending = None;
        } else {
            self.pending = Some((*avp, lat, lon, h, cov));
        }
    }

    pub(super) fn finish(mut self) -> Vec<ErrorRow> {
        if let Some((avp, lat, lon, h, cov)) = self.pending {
            self.rows.push(Self::row(&avp, lat, lon, h, cov));
        }
        self.rows
    }
}

/// One run with its own random streams.
pub fn run_once(scn: &Scenario, truth: &TruthSource, seed: u64, run: u64) -> RunResult {
    let dt = scn.dt;
    let rot = scn.rotation;
    let (mut samples, mut rec) = start_run(scn, truth, rot);
    let Some(first) = samples.next() else {
        return RunResult::empty(run);
    };
    // Truth body attitude at the start (undo the modulation).
    let mut truth0 = first.avp.state;
    truth0.q = body_q(&first.avp.state.q, 0.0, rot);
    let mut est0 = initial_estimate(scn, &truth0);
    let est_body_q0 = est0.q;
    if let Some(r) = rot {
        est0.q = r.imu_attitude(&est0.q, 0.0);
    }
    rec.record(0, &first.avp, est0.lat, est0.lon, est0.h);
    let mut imu = Imu::new(&scn.imu, dt, stream(seed, run, ids::IMU));
    let mut baro = Barometer::new(&scn.baro, stream(seed, run, ids::BARO));
    let mut ins = Strapdown::new(est0, dt);
    let mut damping = match scn.file.navigator.vertical_channel {
        VerticalChannel::Baro => Some(BaroDamping::new(
            scn.file
                .navigator
                .vertical_tau_s
                .unwrap_or(DEFAULT_VERTICAL_TAU_S),
        )),
        VerticalChannel::Free => None,
    };
    let mut ins_step = |ins: &mut Strapdown, s: &crate::trajectory::TruthSample| {
        let m = imu.measure(&s.imu);
        ins.step(&m);
        if let Some(d) = damping.as_mut() {
            if let Some(hb) = baro.measure(s.avp.t, s.avp.state.h) {
                d.set_reference(hb);
            }
            d.apply(ins);
        }
    };
    let mut k = 0u64;
    match scn.file.navigator.mode {
        // Integrated runs go through `run_integrated`; here (direct calls of
        // `run_once`) they run free inertial.
        NavMode::FreeInertial | NavMode::Integrated => {
            for s in samples {
                k += 1;
                ins_step(&mut ins, &s);
                rec.record(k, &s.avp, ins.state.lat, ins.state.lon, ins.state.h);
            }
        }
        NavMode::DeadReckoning => {
            let mut odo = Odometer::new(&scn.odometer, stream(seed, run, ids::ODOMETER));
            let mut dr = OdometerDr::new(est0.lat, est0.lon, est0.h);
            let mut last_distance = first.avp.distance_m;
            let mut q_prev = est_body_q0;
            let mut failed = false;
            let mut last_vel = V3::zeros();
            for s in samples {
                k += 1;
                ins_step(&mut ins, &s);
                let q_now = body_q(&ins.state.q, s.avp.t, rot);
                let d_true = s.avp.distance_m - last_distance;
                last_distance = s.avp.distance_m;
                if !failed {
                    match odo.measure(s.avp.t, s.avp.distance_m, d_true, dt) {
                        Some(ds) => {
                            let d = dr.step(&q_prev, &q_now, ds);
                            last_vel = d * (1.0 / dt);
                        }
                        None => {
                            // Odometer failed: continue inertially from the dead-
                            // reckoned position and the last odometer velocity.
                            failed = true;
                            ins.state.lat = dr.lat;
                            ins.state.lon = dr.lon;
                            ins.state.h = dr.h;
                            ins.reset_velocity(last_vel);
                        }
                    }
                }
                q_prev = q_now;
                if failed {
                    rec.record(k, &s.avp, ins.state.lat, ins.state.lon, ins.state.h);
                } else {
                    rec.record(k, &s.avp, dr.lat, dr.lon, dr.h);
                }
            }
        }
        NavMode::DeadReckoning3d => {
            let m = scn.diff_odometer;
            let mut wheels = DiffOdometer::new(&m, stream(seed, run, ids::DIFF_ODOMETER));
            let mut level = stream(seed, run, ids::LEVEL);
            let level_noise = scn.file.level_sensor.noise_deg.to_radians();
            let mut alt = Barometer::new(&scn.baro, stream(seed, run, ids::BARO));
            let (_, roll0_est, _) = est_body_q0.to_euler();
            let (_, roll0_true, _) = truth0.q.to_euler();
            let roll_bias = roll0_est - roll0_true;
            let heading0 = -est_body_q0.to_euler().2;
            let mut dr = Dr3d::new(
                est0.lat,
                est0.lon,
                est0.h,
                heading0,
                m.track_width_m + m.track_width_error_m,
            );
            let mut last_alt = alt.measure(first.avp.t, first.avp.state.h);
            let mut prev_truth = truth0;
            let (mut sl, mut sr) = (0.0, 0.0);
            for s in samples {
                k += 1;
                let mut tb = s.avp.state;
                tb.q = body_q(&s.avp.state.q, s.avp.t, rot);
                let (l, r) = wheel_distances(&prev_truth, &tb, m.track_width_m);
                prev_truth = tb;
                let (ml, mr) = wheels.measure(l, r, dt);
                sl += ml;
                sr += mr;
                if let Some(h) = alt.measure(s.avp.t, tb.h) {
                    let dh = last_alt.map_or(0.0, |h0| h - h0);
                    last_alt = Some(h);
                    let (_, roll_true, _) = tb.q.to_euler();
                    let roll = roll_true
                        + roll_bias
                        + if level_noise > 0.0 {
                            level_noise * normal(&mut level)
                        } else {
                            0.0
                        };
                    dr.step(sl, sr, dh, roll);
                    sl = 0.0;
                    sr = 0.0;
                }
                rec.record(k, &s.avp, dr.lat, dr.lon, dr.h);
            }
        }
    }
    RunResult {
        run,
        rows: rec.finish(),
        tag_events: vec![],
        tag_passes: vec![],
        counts: None,
        map_feed: None,
    }
}
