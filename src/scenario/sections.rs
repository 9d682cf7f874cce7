//! The validated scenario: every value checked, every default applied and
//! every unit converted to SI (radians, seconds, metres, m/s, m/s²) once, by
//! [`Scenario::parse`](super::Scenario::parse). Readers never see the raw
//! file.

use super::schema::{Adaptive, Coverage, NavMode, Traffic, UTurns, VerticalChannel};
use crate::sensors::{
    BarometerModel, DiffOdometerModel, ImuModel, OdometerModel, RotationModulation,
};
use crate::tags::{Mounting, RfidModel};
use crate::trajectory::{Motion, Start};
use std::path::{Path, PathBuf};

/// Time constant of the baro damping loop when `navigator.vertical_tau_s` is
/// not given (s).
pub const DEFAULT_VERTICAL_TAU_S: f64 = 50.0;

/// Default candidate spacing along a route (`coverage = "routes"`, m).
pub const DEFAULT_ROUTE_SPACING_M: f64 = 20.0;

/// Default candidate spacing along every directed road of a network
/// (`coverage = "network"`, m): coarser than a route's, as the network has
/// many more roads.
pub const DEFAULT_NETWORK_SPACING_M: f64 = 50.0;

/// Installed cost of one tag of a mounting when `planner.cost` does not give
/// it: road surface 1, roadside 1, ceiling 3 (a reader in the roof is
/// expensive).
pub fn default_mounting_cost(m: Mounting) -> f64 {
    match m {
        Mounting::RoadSurface | Mounting::Roadside => 1.0,
        Mounting::Ceiling => 3.0,
    }
}

/// What a route is made of, validated and in SI units.
#[derive(Debug, Clone)]
pub enum RouteKind {
    /// Motion commands from a start.
    Motion {
        /// The start.
        start: Start,
        /// The commands.
        commands: Vec<Motion>,
    },
    /// Waypoints on the map.
    Map {
        /// The map file (resolved against the scenario's folder).
        map: PathBuf,
        /// [latitude, longitude] in degrees.
        waypoints: Vec<[f64; 2]>,
        /// Drivable-profile settings.
        profile: crate::trajectory::route::SpeedProfile,
        /// Stops: (distance along the route m, duration s).
        stops: Vec<(f64, f64)>,
        /// Height (m).
        height_m: f64,
    },
}

/// `[navigator]`, validated, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Navigator {
    /// The navigator mode.
    pub mode: NavMode,
    /// Vertical channel of the inertial navigator.
    pub vertical_channel: VerticalChannel,
    /// Time constant of the baro damping loop (s; default
    /// [`DEFAULT_VERTICAL_TAU_S`]).
    pub vertical_tau_s: f64,
    /// Initial velocity error, east, north, up (m/s).
    pub initial_velocity_error_mps: [f64; 3],
    /// Initial position error, east, north, up (m).
    pub initial_position_error_m: [f64; 3],
    /// σ of the random initial attitude error per run, pitch/roll and
    /// heading (rad).
    pub initial_attitude_sigma: [f64; 2],
    /// σ of the random initial position error per run, horizontal and
    /// vertical (m).
    pub initial_position_sigma_m: [f64; 2],
    /// σ of the random initial velocity error per run (m/s).
    pub initial_velocity_sigma_mps: f64,
}

/// `[aiding]`: which measurements an integrated navigator uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Aiding {
    /// Odometer velocity updates.
    pub odometer: bool,
    /// RFID position fixes.
    pub rfid: bool,
    /// Map matching.
    pub map_matching: bool,
    /// Barometric height.
    pub baro: bool,
    /// Non-holonomic constraints (default: on when the odometer is).
    pub non_holonomic: bool,
    /// The `[external_fix]` source.
    pub external_fix: bool,
}

/// `[filter]`, validated, every default applied (from the simulated sensor
/// models where the file leaves a prior out), in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterSettings {
    /// Covariance propagation interval (s, default 0.1).
    pub interval_s: f64,
    /// Odometer update interval (s, default 0.1).
    pub odometer_interval_s: f64,
    /// σ of the odometer's mean speed per update (m/s; default from the
    /// odometer model: white noise over the update, quantization, 1 cm/s).
    pub odometer_noise_mps: f64,
    /// σ of the non-holonomic constraints (m/s, default 0.05).
    pub nhc_noise_mps: f64,
    /// Prior σ of the gyro biases (rad/s; default: the simulated constant,
    /// turn-on and instability biases together, at least 0.001 °/h).
    pub gyro_bias_sigma: f64,
    /// Correlation time of the gyro biases (s): the IMU's when it has a bias
    /// instability, else 1e6 (a random constant).
    pub gyro_bias_tau_s: f64,
    /// Prior σ of the accelerometer biases (m/s²; default as the gyro's, at
    /// least 5 µg).
    pub accel_bias_sigma: f64,
    /// Correlation time of the accelerometer biases (s), as the gyro's.
    pub accel_bias_tau_s: f64,
    /// Prior σ of the odometer scale-factor error (default: the simulated
    /// one, at least 5e-4).
    pub odometer_scale_sigma: f64,
    /// Correlation time of the odometer scale factor (s, default 1e6).
    pub odometer_scale_tau_s: f64,
    /// Prior σ of the odometer mounting misalignments (rad, default 0.2°).
    pub odometer_misalignment_sigma: f64,
    /// Prior σ of the initial attitude errors, pitch/roll and heading (rad;
    /// default from the navigator's initial errors, at least 0.5′ and 1′).
    pub attitude_sigma: [f64; 2],
    /// Prior σ of the initial position error, horizontal and vertical (m;
    /// default from the navigator's initial errors, at least 1 m).
    pub position_sigma_m: [f64; 2],
    /// Prior σ of the initial velocity error (m/s; default from the
    /// navigator's initial errors, at least 0.05).
    pub velocity_sigma_mps: f64,
}

/// `[external_fix]`, validated: position fixes at irregular intervals whose
/// error is a random walk plus white noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExternalFix {
    /// Shortest and longest gap between fixes (s).
    pub interval_s: [f64; 2],
    /// White noise σ per axis (m).
    pub white_m: f64,
    /// Random-walk density per axis (m/√s).
    pub random_walk_m_per_rts: f64,
    /// The white noise σ the filter assumes (m; default `white_m`).
    pub filter_white_m: f64,
    /// Adaptive noise estimation.
    pub adaptive: Adaptive,
    /// Sage–Husa fading factor b (default 0.95).
    pub fading_b: f64,
}

/// Where a scenario's `[[tag]]` is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TagPlace {
    /// At stored coordinates, latitude and longitude (deg).
    LatLonDeg([f64; 2]),
    /// On the route where the vehicle is at this time (s).
    AtTime(f64),
    /// On the route at this distance (m).
    AtDistance(f64),
}

/// A scenario's `[[tag]]`, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioTag {
    /// Identifier (default `tag-N`, N its index).
    pub id: String,
    /// Where it is.
    pub place: TagPlace,
    /// Stored height (m); `None`: on-route tags take the route's height.
    pub height_m: Option<f64>,
    /// Mounting (default road surface).
    pub mounting: Mounting,
    /// Stored minus physical position, east and north (m; default 0).
    pub survey_error_m: [f64; 2],
}

/// An allowed mounting of the planner and its installed cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MountingChoice {
    /// The mounting.
    pub mounting: Mounting,
    /// Installed cost of one tag (`planner.cost`, default
    /// [`default_mounting_cost`]).
    pub cost: f64,
}

/// `[planner]`, validated, every default applied.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannerOptions {
    /// What the plan covers (default routes).
    pub coverage: Coverage,
    /// Consecutive missed reads to tolerate (default 1).
    pub tolerate_missed_reads: usize,
    /// Allowed mountings in the file's order, with their costs (default all
    /// three).
    pub mountings: Vec<MountingChoice>,
    /// Spacing of candidate tag sites (m, ≥ 1; default
    /// [`DEFAULT_ROUTE_SPACING_M`] or, with network coverage,
    /// [`DEFAULT_NETWORK_SPACING_M`]).
    pub candidate_spacing_m: f64,
    /// Smallest distance between two planned tags (m, default 0).
    pub min_spacing_m: f64,
    /// Stretches of route distance where no tag may go (m).
    pub forbidden_m: Vec<[f64; 2]>,
    /// Monte Carlo runs validating a plan (default 100).
    pub validation_runs: u64,
    /// Refinements of the reaches from the planned filter (default 0).
    pub refine_iterations: usize,
    /// Tags already installed: their CSV file, resolved against the
    /// scenario's folder.
    pub existing_tags: Option<PathBuf>,
    /// Where network walks may turn back (default anywhere).
    pub u_turns: UTurns,
    /// The traffic a network plan serves (default trips).
    pub traffic: Traffic,
    /// Reach levels of a `trips` plan with map matching: 2 (default, early
    /// then calibrated) or 1 (the single reach).
    pub reach_levels: u8,
    /// Destinations CSV of `trips` traffic, resolved against the
    /// scenario's folder (default: points weighted by road length).
    pub destinations: Option<PathBuf>,
    /// Driving per chain of trips (s, > 0; default 8 h).
    pub shift_s: f64,
    /// ε: the probability a fresh chain may violate (0 < ε < 1; default 0.01).
    pub violation_probability: f64,
    /// 1 − β: the confidence of the ε statement (0 < · < 1; default 0.99).
    pub confidence: f64,
    /// Probability with which the horizontal error must lie within the
    /// requirement (0.5 ≤ · < 1; default 0.95).
    pub requirement_confidence: f64,
    /// Chains in the planning sample of `trips` (default 64).
    pub planning_chains: usize,
    /// Chain beginnings added to the planning sample of a two-level
    /// `trips` plan for their early stretches (default: four times the
    /// first certification round's chains).
    pub cold_starts: Option<usize>,
    /// Sampled beginnings a first-round cover may leave over budget
    /// (sampling and discarding; default from the certification's size).
    pub discarded_beginnings: Option<usize>,
    /// Chains the network validation drives (default 20).
    pub validation_chains: usize,
    /// The vehicles' cruise speed on a network plan (`[vehicle] speed_kmh`,
    /// m/s; default 50 km/h).
    pub vehicle_speed_mps: f64,
}

/// Default `[map] geometry_error_m` (m, 1σ per axis): Haklay (2010, *How
/// good is volunteered geographical information?*, Environment and Planning
/// B 37(4)) found OpenStreetMap roads in London on average about 6 m from
/// Ordnance Survey's; a mean radial offset of 6 m is a per-axis σ of
/// 6 / √(π/2) = 4.8 m.
pub const DEFAULT_MAP_GEOMETRY_ERROR_M: f64 = 4.8;
/// Default `[map] geometry_error_correlation_m` (m).
pub const DEFAULT_MAP_ERROR_CORRELATION_M: f64 = 200.0;

/// `[map]` geometry error, validated: the map the navigator matches against
/// is the world displaced by a smooth random field with this σ and
/// correlation length (see `sim::map_error`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapErrorModel {
    /// 1σ per horizontal axis (m; 0: a perfect map).
    pub sigma_m: f64,
    /// Correlation length L (m) of the Gaussian covariance σ² exp(−d²/2L²).
    pub correlation_m: f64,
}

impl Default for MapErrorModel {
    fn default() -> Self {
        Self {
            sigma_m: DEFAULT_MAP_GEOMETRY_ERROR_M,
            correlation_m: DEFAULT_MAP_ERROR_CORRELATION_M,
        }
    }
}

/// Default `[vehicle] lane_wander_m` (m, 1σ): the standard deviation of
/// lateral position drivers keep in a lane, 0.2–0.3 m in driving studies
/// (SDLP; e.g. Verster & Roth 2011, Transportation Research Part F 14(3)).
pub const DEFAULT_LANE_WANDER_M: f64 = 0.3;

/// Spacing of the polyline of the truth's lane path (m): `sim::lanes`
/// moves a point of the route's smoothed centre path into its lane this
/// often. Defined here, below the simulation, because a map route's memory
/// is estimated from it when the scenario is read
/// ([`super::limits::route_truth_bytes`]).
pub const LANE_PATH_SPACING_M: f64 = 2.0;

/// `[vehicle]` lane keeping, validated: the truth drives in a lane of its
/// direction on the `drive_side` of the road, wandering about the lane's
/// centre with 1σ `wander_m` (see `sim::lanes`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneModel {
    /// Side of the road traffic keeps to.
    pub drive_side: crate::network::DriveSide,
    /// Lateral wander about the lane centre, 1σ (m; 0: on the centre).
    pub wander_m: f64,
}

impl Default for LaneModel {
    fn default() -> Self {
        Self {
            drive_side: crate::network::DriveSide::Right,
            wander_m: DEFAULT_LANE_WANDER_M,
        }
    }
}

/// A loaded, validated scenario in SI units.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The file it came from.
    pub path: PathBuf,
    /// The first route.
    pub route: RouteKind,
    /// IMU sampling interval (s).
    pub dt: f64,
    /// IMU errors.
    pub imu: ImuModel,
    /// Rotation modulation.
    pub rotation: Option<RotationModulation>,
    /// Odometer errors.
    pub odometer: OdometerModel,
    /// Differential odometer errors.
    pub diff_odometer: DiffOdometerModel,
    /// Altimeter errors.
    pub baro: BarometerModel,
    /// Initial attitude error, pitch, roll, heading (rad).
    pub initial_attitude_error: [f64; 3],
    /// Output interval (s).
    pub output_interval_s: f64,
    /// RFID reader model.
    pub rfid: RfidModel,
    /// Geometry error of the navigator's map (`[map]`; default without one).
    pub map_error: MapErrorModel,
    /// The vehicle in its lane (`[vehicle] drive_side`, `lane_wander_m`).
    pub lanes: LaneModel,
    /// `[map] elevation`: the elevation model's GeoTIFF files (resolved
    /// against the scenario's folder); empty without one (heights are then
    /// the route's constant `height_m`).
    pub elevation: Vec<PathBuf>,
    pub(super) name: String,
    pub(super) requirement_m: Option<f64>,
    pub(super) duration_cap_s: f64,
    pub(super) seed: u64,
    pub(super) navigator: Navigator,
    pub(super) aiding: Aiding,
    pub(super) filter: FilterSettings,
    pub(super) external_fix: Option<ExternalFix>,
    pub(super) tags: Vec<ScenarioTag>,
    pub(super) planner: PlannerOptions,
    pub(super) level_sensor_noise: f64,
    pub(super) gyro_bias_random: f64,
    pub(super) accel_bias_random: f64,
}

impl Scenario {
    /// The scenario placed at `lat_lon` (degrees) when its map route has no
    /// waypoints (a network plan from the map alone): the filter's prior,
    /// given in metres, is converted to angles at that latitude.
    pub fn located_at(&self, lat_lon: [f64; 2]) -> Scenario {
        let mut s = self.clone();
        if let RouteKind::Map { waypoints, .. } = &mut s.route {
            if waypoints.is_empty() {
                *waypoints = vec![lat_lon, lat_lon];
            }
        }
        s
    }

    /// The scenario file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The scenario's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The horizontal position error to hold (m), if the file gives one.
    pub fn requirement_m(&self) -> Option<f64> {
        self.requirement_m
    }

    /// The cap on the simulated time (s; infinite without `duration_s`).
    pub fn duration_cap_s(&self) -> f64 {
        self.duration_cap_s
    }

    /// The default seed (the file's `seed`, else 1); `--seed` overrides it.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The navigator.
    pub fn navigator(&self) -> &Navigator {
        &self.navigator
    }

    /// Which measurements an integrated navigator uses.
    pub fn aiding(&self) -> Aiding {
        self.aiding
    }

    /// The integrated navigator's Kalman filter settings.
    pub fn filter(&self) -> &FilterSettings {
        &self.filter
    }

    /// The external position fix source, if the file has one.
    pub fn external_fix(&self) -> Option<&ExternalFix> {
        self.external_fix.as_ref()
    }

    /// The scenario's `[[tag]]` entries.
    pub fn tags(&self) -> &[ScenarioTag] {
        &self.tags
    }

    /// The planner's options (defaults when there is no `[planner]`).
    pub fn planner(&self) -> &PlannerOptions {
        &self.planner
    }

    /// White roll noise of the level sensor (rad).
    pub fn level_sensor_noise(&self) -> f64 {
        self.level_sensor_noise
    }

    /// σ of the turn-on gyro bias drawn per run (rad/s).
    pub fn gyro_bias_random(&self) -> f64 {
        self.gyro_bias_random
    }

    /// σ of the turn-on accelerometer bias drawn per run (m/s²).
    pub fn accel_bias_random(&self) -> f64 {
        self.accel_bias_random
    }
}
