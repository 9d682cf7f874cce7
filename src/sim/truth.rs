//! Where the truth comes from (motion commands or a road route on a loaded
//! map, compiled once and streamed once per run), and the start of a run:
//! the truth's ideal IMU samples, the recorder of its rows and the
//! navigator's initial estimate.

use super::records::Recorder;
use crate::attitude::{Quat, QuatExt};
use crate::error::Result;
use crate::geodesy::radii;
use crate::nav::NavState;
use crate::network::Network;
use crate::route::Route;
use crate::scenario::{RouteKind, Scenario};
use crate::sensors::rng::{ids, stream};
use crate::sensors::{Odometer, OdometerModel, RotationModulation, RunMounting};
use crate::trajectory::motion::MAX_DURATION_S;
use crate::trajectory::route::RoutePlan;
use crate::trajectory::{ideal_imu, Avp, MotionPlan};
use std::sync::Arc;

/// Where the truth comes from: compiled once, streamed once per run.
#[derive(Debug, Clone)]
pub enum TruthSource {
    /// Motion commands.
    Motion(MotionPlan),
    /// A road route on a loaded map.
    Route(Box<RouteTruth>),
}

/// A road route's truth with the map and the route it was planned on, so
/// that every user (map matching, the planner's road context, the route
/// budget) shares the one loaded network instead of loading it again.
#[derive(Debug, Clone)]
pub struct RouteTruth {
    /// The compiled drive along the route.
    pub plan: RoutePlan,
    /// The route (polyline and section spans) on `network`.
    pub route: Route,
    /// The road network, loaded once.
    pub network: Arc<Network>,
}

impl TruthSource {
    /// Builds the truth source of a scenario (loads the map for a map route,
    /// once).
    pub fn new(scn: &Scenario) -> Result<TruthSource> {
        match &scn.route {
            RouteKind::Map { waypoints, .. } if waypoints.is_empty() => {
                Err(crate::error::Error::scenario(
                    &scn.path,
                    "no [[route]]: this scenario plans a network (planner.coverage = \"network\"); \
                     simulating needs a [[route]] with waypoints",
                ))
            }
            RouteKind::Map { map, .. } => {
                let net = Arc::new(Network::load(map, &Default::default())?);
                Self::on_network(scn, net)
            }
            RouteKind::Motion { .. } => Self::motion(scn),
        }
    }

    fn motion(scn: &Scenario) -> Result<TruthSource> {
        match &scn.route {
            RouteKind::Motion { start, commands } => Ok(TruthSource::Motion(MotionPlan::new(
                *start, commands, scn.dt,
            )?)),
            RouteKind::Map { .. } => unreachable!("a map route is built on its network"),
        }
    }

    /// Builds the truth source of a scenario whose map is already loaded
    /// (`network` is the scenario's map; unused for motion commands).
    pub fn on_network(scn: &Scenario, network: Arc<Network>) -> Result<TruthSource> {
        match &scn.route {
            RouteKind::Motion { .. } => Self::motion(scn),
            RouteKind::Map {
                waypoints,
                profile,
                stops,
                height_m,
                ..
            } => {
                if waypoints.is_empty() {
                    return Err(crate::error::Error::scenario(
                        &scn.path,
                        "no [[route]]: this scenario plans a network (planner.coverage = \"network\"); \
                         simulating needs a [[route]] with waypoints",
                    ));
                }
                // Numbers of the file (a stop's `at_m = 1e308`) printed short.
                let err = |e: crate::error::Error| {
                    crate::error::Error::scenario(
                        &scn.path,
                        crate::scenario::shorten_numbers(&format!("route[0]: {e}")),
                    )
                };
                let route = crate::route::plan_route(&network, waypoints).map_err(err)?;
                check_route_length(scn, route.length_m, profile.speed_mps)?;
                crate::scenario::check_route_memory(scn, &route)?;
                let mut centre =
                    RoutePlan::new(&network, &route, profile, stops, *height_m, scn.dt)
                        .map_err(err)?;
                // Terrain heights (`[map] elevation`): one profile along the
                // route's chainage, which the centre and lane paths share.
                let heights = if scn.elevation.is_empty() {
                    None
                } else {
                    let dem = crate::elevation::Dem::open(&scn.elevation)?;
                    let h = crate::trajectory::route_heights(&network, &route, &dem)?;
                    centre = centre.with_heights(&h);
                    Some(h)
                };
                // The truth drives in its lane (issue 12): the centre path
                // moved to a lane of its direction, with wander and lane changes.
                let plan = super::lanes::lane_plan(
                    &network,
                    &route,
                    &centre,
                    &scn.lanes,
                    scn.seed(),
                    profile,
                    stops,
                    *height_m,
                    scn.dt,
                )
                .map_err(err)?;
                let plan = match heights {
                    Some(h) => plan.with_heights(&h),
                    None => plan,
                };
                Ok(Self::from_route(network, route, plan))
            }
        }
    }

    /// The truth of a route already planned and compiled on `network`.
    pub fn from_route(network: Arc<Network>, route: Route, plan: RoutePlan) -> TruthSource {
        TruthSource::Route(Box::new(RouteTruth {
            plan,
            route,
            network,
        }))
    }

    /// The loaded road network of a map route.
    pub fn network(&self) -> Option<&Arc<Network>> {
        match self {
            TruthSource::Route(r) => Some(&r.network),
            TruthSource::Motion(_) => None,
        }
    }

    /// The planned route of a map route.
    pub fn route(&self) -> Option<&Route> {
        match self {
            TruthSource::Route(r) => Some(&r.route),
            TruthSource::Motion(_) => None,
        }
    }

    /// The route chainage (m, along the centre-line route) where a map
    /// route's truth is at path distance `distance_m`: the truth drives its
    /// lane, whose length differs from the centre line's at every bend, so
    /// a uniform scale maps distances only roughly. `None` for motion
    /// commands.
    pub fn chainage_at(&self, distance_m: f64) -> Option<f64> {
        match self {
            TruthSource::Route(r) => Some(r.plan.chainage_at(distance_m)),
            TruthSource::Motion(_) => None,
        }
    }

    /// The truth samples.
    pub fn samples(&self) -> Box<dyn Iterator<Item = Avp> + Send + '_> {
        match self {
            TruthSource::Motion(p) => Box::new(p.trajectory()),
            TruthSource::Route(p) => Box::new(p.plan.trajectory()),
        }
    }

    /// Duration (s).
    pub fn duration_s(&self) -> f64 {
        match self {
            TruthSource::Motion(p) => p.duration_s,
            TruthSource::Route(p) => p.plan.duration_s,
        }
    }
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

pub(super) fn body_q(q_imu: &Quat, t: f64, rot: Option<RotationModulation>) -> Quat {
    match rot {
        Some(r) => r.body_attitude(q_imu, t),
        None => *q_imu,
    }
}

/// This run's odometer scale factor and IMU-to-vehicle misalignment
/// ([`crate::sensors::OdometerModel::draw_mounting`]), from the run's own
/// stream.
pub(super) fn run_mounting(scn: &Scenario, seed: u64, run: u64) -> RunMounting {
    scn.odometer
        .draw_mounting(&mut stream(seed, run, ids::MOUNTING))
}

/// This run's odometer: the scenario's with the run's scale factor
/// (`mount`), on its own streams.
pub(super) fn run_odometer(scn: &Scenario, mount: &RunMounting, seed: u64, run: u64) -> Odometer {
    let model = OdometerModel {
        scale_factor_error: mount.scale_factor_error,
        ..scn.odometer
    };
    Odometer::new(
        &model,
        stream(seed, run, ids::ODOMETER),
        stream(seed, run, ids::ODOMETER_SCALE),
    )
}

/// The navigator's initial state: truth plus the scenario's initial errors
/// (attitude errors on the body's pitch, roll and heading). Alignment finds
/// the IMU's attitude: with a mounting misalignment (`mount`) that is the
/// vehicle's rotated by it, and the navigator takes the IMU's axes for the
/// vehicle's.
pub(super) fn initial_estimate(
    scn: &Scenario,
    truth_body: &NavState,
    mount: &RunMounting,
) -> NavState {
    let n = scn.navigator();
    let (pitch, roll, yaw) = truth_body.q.to_euler();
    let [dp, dr, dh] = scn.initial_attitude_error;
    let q = Quat::from_euler(pitch + dp, roll + dr, yaw - dh);
    let (rm, rn) = radii(truth_body.lat);
    let [pe, pn, pu] = n.initial_position_error_m;
    let dv = n.initial_velocity_error_mps;
    let q = match mount.vehicle_to_imu() {
        Some(c) => q * c.inverse(),
        None => q,
    };
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
    let cap = scn.duration_cap_s() + 0.5 * dt;
    let body = truth.samples().take_while(move |a| a.t <= cap);
    let samples = ideal_imu(body.map(move |a| imu_frame(a, rot)), dt);
    let rec = Recorder {
        every: ((scn.output_interval_s / dt).round() as u64).max(1),
        rows: Vec::with_capacity(
            (truth.duration_s().min(scn.duration_cap_s()) / scn.output_interval_s) as usize + 2,
        ),
        pending: None,
    };
    (samples, rec)
}

/// Checks a map route's routed length (m), before its trajectory is
/// sampled (every 2 m) and its lane path made: its drive at the cruise
/// speed `speed_mps` (a lower bound of the drive's duration) against
/// [`super::MAX_SIMULATED_S`] (`trajectory::motion::MAX_DURATION_S`, read here: `limits` imports this file). The route is built whole whatever `duration_s`,
/// so the cap does not lift this limit. (Scenario validation checks the
/// waypoints' great-circle distances before the map is loaded.)
fn check_route_length(scn: &Scenario, length_m: f64, speed_mps: f64) -> Result<()> {
    let drive_s = length_m / speed_mps;
    if !(drive_s.is_finite() && drive_s <= MAX_DURATION_S) {
        return Err(crate::error::Error::scenario(
            &scn.path,
            format!(
                "route[0]: the route through its waypoints is {:.0} km long, a drive of at least \
                 {:.1} days at speed_kmh = {:.1}, above the limit of 30 days ({MAX_DURATION_S:.0} s; \
                 duration_s does not shorten the route, which is built whole): use fewer or \
                 closer waypoints",
                length_m / 1000.0,
                drive_s / 86_400.0,
                speed_mps * 3.6,
            ),
        ));
    }
    Ok(())
}
