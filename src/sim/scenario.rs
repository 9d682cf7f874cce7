//! The scenario file (TOML): what is simulated. Unknown fields are errors,
//! every number is checked (finite, in range), and every error names the file
//! and the field. Units are in the field names (`_m`, `_s`, `_deg`, `_dph`,
//! `_ug`, `_kmh`, ...); the conversion to SI happens here, at the edge.

use crate::error::{Error, Result};
use crate::sensors::{
    BarometerModel, DiffOdometerModel, ImuModel, OdometerFailure, OdometerModel,
    RotationModulation, WheelSlip,
};
use crate::trajectory::{Extent, Motion, Start};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Standard gravity for µg conversions (m/s²).
pub const G0: f64 = 9.806_65;
const DEG_PER_HOUR: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const ARCMIN: f64 = std::f64::consts::PI / 180.0 / 60.0;
const ARCSEC: f64 = ARCMIN / 60.0;

/// The whole scenario file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// Name of the scenario.
    pub name: String,
    /// Horizontal position error to hold (m).
    #[serde(default)]
    pub requirement_m: Option<f64>,
    /// Optional cap on the simulated time (s).
    #[serde(default)]
    pub duration_s: Option<f64>,
    /// Default seed (overridden by `--seed`).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Interval of the rows of errors.csv and of the metrics (s; default 1).
    #[serde(default)]
    pub output_interval_s: Option<f64>,
    /// The road map.
    #[serde(default)]
    pub map: Option<MapSection>,
    /// Routes (simulate drives the first).
    #[serde(default)]
    pub route: Vec<RouteSection>,
    /// The vehicle.
    #[serde(default)]
    pub vehicle: VehicleSection,
    /// The navigator.
    #[serde(default)]
    pub navigator: NavigatorSection,
    /// The IMU.
    #[serde(default)]
    pub imu: ImuSection,
    /// The odometer.
    #[serde(default)]
    pub odometer: OdometerSection,
    /// The differential odometer (3-D dead reckoning).
    #[serde(default)]
    pub diff_odometer: DiffOdometerSection,
    /// The barometric altimeter.
    #[serde(default)]
    pub baro: BaroSection,
    /// The level sensor (roll) of 3-D dead reckoning.
    #[serde(default)]
    pub level_sensor: LevelSensorSection,
    /// Which measurements an integrated navigator uses (the filter issue).
    #[serde(default)]
    pub aiding: AidingSection,
    /// RFID reader (the filter and planner issues).
    #[serde(default)]
    pub rfid: Option<RfidSection>,
    /// Planner settings (the planner issue).
    #[serde(default)]
    pub planner: Option<PlannerSection>,
    /// RFID tags along the route.
    #[serde(default)]
    pub tag: Vec<TagSpec>,
    /// Kalman filter settings of the integrated navigator.
    #[serde(default)]
    pub filter: FilterSection,
    /// An external position fix source (gravity matching and the like).
    #[serde(default)]
    pub external_fix: Option<ExternalFixSection>,
}

/// `[[tag]]`: a tag at stored coordinates, or on the route at a time or distance.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TagSpec {
    /// Identifier (default `tag-N`).
    #[serde(default)]
    pub id: Option<String>,
    /// Stored latitude (deg).
    #[serde(default)]
    pub lat: Option<f64>,
    /// Stored longitude (deg).
    #[serde(default)]
    pub lon: Option<f64>,
    /// On the route where the vehicle is at this time (s).
    #[serde(default)]
    pub at_s: Option<f64>,
    /// On the route at this distance (m).
    #[serde(default)]
    pub at_m: Option<f64>,
    /// Stored height (m); on-route tags default to the route's height there.
    #[serde(default)]
    pub height_m: Option<f64>,
    /// road_surface (default), roadside or ceiling.
    #[serde(default)]
    pub mounting: Option<String>,
    /// Stored minus physical position, east and north (m): a misplaced tag.
    #[serde(default)]
    pub survey_error_m: Option<[f64; 2]>,
}

/// `[filter]`: the integrated navigator's Kalman filter. Priors default to
/// the magnitudes of the simulated errors.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct FilterSection {
    /// Covariance propagation interval (s, default 0.1).
    #[serde(default)]
    pub interval_s: Option<f64>,
    /// Odometer update interval (s, default 0.1).
    #[serde(default)]
    pub odometer_interval_s: Option<f64>,
    /// σ of the odometer's mean speed per update (m/s; default from the odometer model).
    #[serde(default)]
    pub odometer_noise_mps: Option<f64>,
    /// σ of the non-holonomic constraints (m/s, default 0.05).
    #[serde(default)]
    pub nhc_noise_mps: Option<f64>,
    /// Prior σ of the gyro biases (deg/h).
    #[serde(default)]
    pub gyro_bias_sigma_dph: Option<f64>,
    /// Prior σ of the accelerometer biases (µg).
    #[serde(default)]
    pub accel_bias_sigma_ug: Option<f64>,
    /// Prior σ of the odometer scale-factor error.
    #[serde(default)]
    pub odometer_scale_sigma: Option<f64>,
    /// Correlation time of the odometer scale factor (s; default 1e6: a random
    /// constant, as simulated; e.g. 36000 models drift with tyre pressure).
    #[serde(default)]
    pub odometer_scale_tau_s: Option<f64>,
    /// Prior σ of the odometer mounting misalignments (deg, default 0.2).
    #[serde(default)]
    pub odometer_misalignment_sigma_deg: Option<f64>,
    /// Prior σ of the initial attitude errors, pitch/roll and heading (arcmin).
    #[serde(default)]
    pub attitude_sigma_arcmin: Option<[f64; 2]>,
    /// Prior σ of the initial position error, horizontal and vertical (m).
    #[serde(default)]
    pub position_sigma_m: Option<[f64; 2]>,
    /// Prior σ of the initial velocity error (m/s).
    #[serde(default)]
    pub velocity_sigma_mps: Option<f64>,
}

/// `[external_fix]`: position fixes at irregular intervals whose error is a
/// random walk plus white noise (PAPERS.md §4).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalFixSection {
    /// Shortest and longest gap between fixes (s); gaps are uniform in between.
    pub interval_s: [f64; 2],
    /// White noise σ per axis (m).
    pub white_m: f64,
    /// Random-walk density per axis (m/√s).
    #[serde(default)]
    pub random_walk_m_per_rts: f64,
    /// The white noise σ the filter assumes (m; default `white_m`).
    #[serde(default)]
    pub filter_white_m: Option<f64>,
    /// "none" (default) or "sage_husa".
    #[serde(default)]
    pub adaptive: Option<String>,
    /// Sage–Husa fading factor b (0 < b < 1, default 0.95).
    #[serde(default)]
    pub fading_b: Option<f64>,
}

/// `[map]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapSection {
    /// Map file, relative to the scenario file.
    pub path: PathBuf,
}

/// `[[route]]`: waypoints on the map, or a start and motion commands.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RouteSection {
    /// Waypoints, [latitude, longitude] in degrees.
    #[serde(default)]
    pub waypoints: Option<Vec<[f64; 2]>>,
    /// Cruise speed on the map route (km/h).
    #[serde(default)]
    pub speed_kmh: Option<f64>,
    /// Lateral acceleration limit on the map route (m/s², default 2).
    #[serde(default)]
    pub max_lateral_accel_mps2: Option<f64>,
    /// Acceleration limit on the map route (m/s², default 1).
    #[serde(default)]
    pub accel_mps2: Option<f64>,
    /// Braking limit on the map route (m/s², default 1.5).
    #[serde(default)]
    pub brake_mps2: Option<f64>,
    /// Stops on the map route.
    #[serde(default)]
    pub stops: Vec<StopSpec>,
    /// Height of the map route (m, default 0).
    #[serde(default)]
    pub height_m: Option<f64>,
    /// Start of a motion-command route.
    #[serde(default)]
    pub start: Option<StartSpec>,
    /// Motion commands.
    #[serde(default)]
    pub motion: Vec<MotionSpec>,
}

/// A stop on a map route.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopSpec {
    /// Where, as distance along the route (m).
    pub at_m: f64,
    /// How long (s).
    pub duration_s: f64,
}

/// `start = { ... }` of a motion-command route.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    /// Latitude (deg).
    pub lat: f64,
    /// Longitude (deg).
    pub lon: f64,
    /// Height (m).
    #[serde(default)]
    pub height_m: f64,
    /// Heading, clockwise from north (deg).
    #[serde(default)]
    pub heading_deg: f64,
    /// Pitch (deg).
    #[serde(default)]
    pub pitch_deg: f64,
    /// Roll (deg).
    #[serde(default)]
    pub roll_deg: f64,
    /// Initial speed (km/h).
    #[serde(default)]
    pub speed_kmh: f64,
}

/// One motion command.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// stay, accelerate, decelerate, cruise, turn, climb, descend.
    pub kind: String,
    /// Duration (s): stay, cruise, climb/descend hold.
    #[serde(default)]
    pub duration_s: Option<f64>,
    /// Distance (m): cruise, climb/descend hold.
    #[serde(default)]
    pub distance_m: Option<f64>,
    /// Target speed (km/h): accelerate, decelerate.
    #[serde(default)]
    pub to_kmh: Option<f64>,
    /// Acceleration magnitude (m/s²): accelerate (default 1), decelerate (default 1).
    #[serde(default)]
    pub accel_mps2: Option<f64>,
    /// Turn angle (deg, positive right).
    #[serde(default)]
    pub angle_deg: Option<f64>,
    /// Turn radius (m).
    #[serde(default)]
    pub radius_m: Option<f64>,
    /// Grade (percent, positive): climb, descend.
    #[serde(default)]
    pub grade_percent: Option<f64>,
    /// Pitch rate of the grade ramps (deg/s, default 1).
    #[serde(default)]
    pub pitch_rate_dps: Option<f64>,
}

/// `[vehicle]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSection {
    /// Vehicle width (m).
    #[serde(default = "d_width")]
    pub width_m: f64,
    /// Distance between the odometer wheels (m).
    #[serde(default = "d_track")]
    pub track_width_m: f64,
}
fn d_width() -> f64 {
    2.5
}
fn d_track() -> f64 {
    1.6
}
impl Default for VehicleSection {
    fn default() -> Self {
        Self {
            width_m: d_width(),
            track_width_m: d_track(),
        }
    }
}

/// Navigator modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum NavMode {
    /// Free strapdown inertial navigation.
    #[default]
    FreeInertial,
    /// Odometer dead reckoning with IMU attitude.
    DeadReckoning,
    /// Gyro-free 3-D dead reckoning (differential odometer, altimeter, roll).
    #[serde(rename = "dead_reckoning_3d")]
    DeadReckoning3d,
    /// Kalman filter (comes with the filter issue).
    Integrated,
}

/// How the inertial vertical channel is stabilised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum VerticalChannel {
    /// Baro-damped third-order loop.
    #[default]
    Baro,
    /// Left free (unstable).
    Free,
}

/// `[navigator]`.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct NavigatorSection {
    /// The navigator mode.
    #[serde(default)]
    pub mode: NavMode,
    /// Vertical channel of the inertial navigator.
    #[serde(default)]
    pub vertical_channel: VerticalChannel,
    /// Time constant of the baro damping loop (s, default 50).
    #[serde(default)]
    pub vertical_tau_s: Option<f64>,
    /// Initial attitude error: pitch, roll, heading (arcmin; heading clockwise).
    #[serde(default)]
    pub initial_attitude_error_arcmin: [f64; 3],
    /// Initial velocity error, east, north, up (m/s).
    #[serde(default)]
    pub initial_velocity_error_mps: [f64; 3],
    /// Initial position error, east, north, up (m).
    #[serde(default)]
    pub initial_position_error_m: [f64; 3],
    /// Random initial attitude error drawn per run (integrated mode), σ of
    /// pitch/roll and of heading (arcmin), added to the fixed one.
    #[serde(default)]
    pub initial_attitude_sigma_arcmin: [f64; 2],
    /// Random initial horizontal and vertical position error per run, σ (m).
    #[serde(default)]
    pub initial_position_sigma_m: [f64; 2],
    /// Random initial velocity error per run, σ (m/s).
    #[serde(default)]
    pub initial_velocity_sigma_mps: f64,
}

/// `rotation_modulation = { rate_dps = ... }`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationSpec {
    /// Rotation rate about the vertical (deg/s).
    pub rate_dps: f64,
}

/// `[imu]`; axes: body x right, y forward, z up.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSection {
    /// Sampling rate (Hz).
    #[serde(default = "d_rate")]
    pub rate_hz: f64,
    /// Constant gyro bias (deg/h).
    #[serde(default)]
    pub gyro_bias_dph: [f64; 3],
    /// Constant accelerometer bias (µg).
    #[serde(default)]
    pub accel_bias_ug: [f64; 3],
    /// Gyro bias instability (deg/h, Gauss–Markov σ).
    #[serde(default)]
    pub gyro_bias_instability_dph: f64,
    /// Its correlation time (s).
    #[serde(default = "d_tau")]
    pub gyro_bias_tau_s: f64,
    /// Accelerometer bias instability (µg, Gauss–Markov σ).
    #[serde(default)]
    pub accel_bias_instability_ug: f64,
    /// Its correlation time (s).
    #[serde(default = "d_tau")]
    pub accel_bias_tau_s: f64,
    /// Angle random walk (deg/√h).
    #[serde(default)]
    pub gyro_arw_dprh: f64,
    /// Velocity random walk (µg/√Hz).
    #[serde(default)]
    pub accel_vrw_ugprhz: f64,
    /// Gyro scale-factor errors (ppm).
    #[serde(default)]
    pub gyro_scale_factor_ppm: [f64; 3],
    /// Accelerometer scale-factor errors (ppm).
    #[serde(default)]
    pub accel_scale_factor_ppm: [f64; 3],
    /// Gyro misalignment xy, xz, yx, yz, zx, zy (arcsec).
    #[serde(default)]
    pub gyro_misalignment_arcsec: [f64; 6],
    /// Accelerometer misalignment xy, xz, yx, yz, zx, zy (arcsec).
    #[serde(default)]
    pub accel_misalignment_arcsec: [f64; 6],
    /// Single-axis rotation modulation about the vertical.
    #[serde(default)]
    pub rotation_modulation: Option<RotationSpec>,
    /// Turn-on gyro bias drawn per run, σ (deg/h), added to `gyro_bias_dph`.
    #[serde(default)]
    pub gyro_bias_random_dph: f64,
    /// Turn-on accelerometer bias drawn per run, σ (µg), added to `accel_bias_ug`.
    #[serde(default)]
    pub accel_bias_random_ug: f64,
}
fn d_rate() -> f64 {
    100.0
}
fn d_tau() -> f64 {
    3600.0
}
impl Default for ImuSection {
    fn default() -> Self {
        toml::from_str("").expect("defaults")
    }
}

/// `slip = { ... }`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlipSpec {
    /// Events per km.
    pub rate_per_km: f64,
    /// Length of each event (m).
    pub length_m: f64,
    /// Over-count during an event (ratio).
    pub overcount: f64,
}

/// `failure = { from_s = ... }` or `{ from_m = ... }`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailureSpec {
    /// Fails from this time (s).
    #[serde(default)]
    pub from_s: Option<f64>,
    /// Fails from this distance (m).
    #[serde(default)]
    pub from_m: Option<f64>,
}

/// `[odometer]`.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct OdometerSection {
    /// Scale-factor error (ratio).
    #[serde(default)]
    pub scale_factor_error: f64,
    /// White speed noise (m/s).
    #[serde(default)]
    pub noise_mps: f64,
    /// Distance per pulse (m; 0 = no quantization).
    #[serde(default)]
    pub pulse_m: f64,
    /// Wheel-slip events.
    #[serde(default)]
    pub slip: Option<SlipSpec>,
    /// Failure.
    #[serde(default)]
    pub failure: Option<FailureSpec>,
}

/// `[diff_odometer]`.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct DiffOdometerSection {
    /// Left wheel scale-factor error (ratio).
    #[serde(default)]
    pub scale_factor_error_left: f64,
    /// Right wheel scale-factor error (ratio).
    #[serde(default)]
    pub scale_factor_error_right: f64,
    /// Assumed minus true track width (m).
    #[serde(default)]
    pub track_width_error_m: f64,
    /// White speed noise per wheel (m/s).
    #[serde(default)]
    pub noise_mps: f64,
    /// Distance per pulse (m; 0 = no quantization).
    #[serde(default)]
    pub pulse_m: f64,
}

/// `[baro]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaroSection {
    /// Output rate (Hz).
    #[serde(default = "d_baro_rate")]
    pub rate_hz: f64,
    /// White noise (m).
    #[serde(default = "d_baro_noise")]
    pub noise_m: f64,
    /// Initial bias (m).
    #[serde(default)]
    pub initial_bias_m: f64,
    /// Drifting bias, Gauss–Markov σ (m).
    #[serde(default = "d_baro_drift")]
    pub bias_drift_m: f64,
    /// Drifting bias correlation time (s).
    #[serde(default = "d_baro_tau")]
    pub bias_tau_s: f64,
    /// Scale-factor error on height changes (ratio).
    #[serde(default)]
    pub scale_factor_error: f64,
}
fn d_baro_rate() -> f64 {
    10.0
}
fn d_baro_noise() -> f64 {
    0.5
}
fn d_baro_drift() -> f64 {
    1.0
}
fn d_baro_tau() -> f64 {
    1800.0
}
impl Default for BaroSection {
    fn default() -> Self {
        toml::from_str("").expect("defaults")
    }
}

/// `[level_sensor]`.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct LevelSensorSection {
    /// White roll noise (deg).
    #[serde(default)]
    pub noise_deg: f64,
}

/// `[aiding]`.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct AidingSection {
    /// Odometer velocity updates.
    #[serde(default)]
    pub odometer: bool,
    /// RFID position fixes.
    #[serde(default)]
    pub rfid: bool,
    /// Map matching.
    #[serde(default)]
    pub map_matching: bool,
    /// Barometric height.
    #[serde(default)]
    pub baro: bool,
    /// Non-holonomic constraints (default: on when the odometer is).
    #[serde(default)]
    pub non_holonomic: Option<bool>,
    /// The `[external_fix]` source.
    #[serde(default)]
    pub external_fix: bool,
}

/// `[rfid]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RfidSection {
    /// Probability that a passed tag is read.
    #[serde(default)]
    pub read_probability: Option<f64>,
    /// Read probability of road-surface tags (default `read_probability`).
    #[serde(default)]
    pub read_probability_road_surface: Option<f64>,
    /// Read probability of roadside tags (default `read_probability`).
    #[serde(default)]
    pub read_probability_roadside: Option<f64>,
    /// Read probability of ceiling readers (default `read_probability`).
    #[serde(default)]
    pub read_probability_ceiling: Option<f64>,
    /// Lane width D (m, default 3.75).
    #[serde(default)]
    pub lane_width_m: Option<f64>,
    /// Lateral reader-to-tag distance x of roadside tags (m, default 5.63).
    #[serde(default)]
    pub roadside_distance_m: Option<f64>,
    /// Angle θ at which a roadside tag first answers (deg, default 15).
    #[serde(default)]
    pub roadside_angle_deg: Option<f64>,
    /// Read time t0 (s, default 0.02).
    #[serde(default)]
    pub read_time_s: Option<f64>,
    /// Largest lateral distance at which a roadside tag is read (m, default 10).
    #[serde(default)]
    pub roadside_range_m: Option<f64>,
    /// σ of road-surface fixes (m, default 0.2; capped at 0.5).
    #[serde(default)]
    pub road_surface_sigma_m: Option<f64>,
    /// σ of ceiling fixes (m, default 0.1; capped at 0.3).
    #[serde(default)]
    pub ceiling_sigma_m: Option<f64>,
    /// σ of stored tag heights (m, default 0.1).
    #[serde(default)]
    pub height_sigma_m: Option<f64>,
}

/// `[planner]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannerSection {
    /// "routes" or "network".
    #[serde(default)]
    pub coverage: Option<String>,
    /// Consecutive missed reads to tolerate.
    #[serde(default)]
    pub tolerate_missed_reads: Option<u32>,
    /// Mounting types allowed.
    #[serde(default)]
    pub mountings: Option<Vec<String>>,
    /// Spacing of candidate tag sites along a route (m, default 20).
    #[serde(default)]
    pub candidate_spacing_m: Option<f64>,
    /// Smallest distance between two planned tags (m, default 0).
    #[serde(default)]
    pub min_spacing_m: Option<f64>,
    /// Stretches of route distance where no tag may go: [[from_m, to_m], ...].
    #[serde(default)]
    pub forbidden_m: Vec<[f64; 2]>,
    /// Monte Carlo runs validating a plan (default 100).
    #[serde(default)]
    pub validation_runs: Option<u64>,
    /// Installed cost per tag by mounting, e.g. { road_surface = 1.0, roadside = 0.6 }.
    #[serde(default)]
    pub cost: Option<std::collections::BTreeMap<String, f64>>,
    /// Refinements of the reaches from the planned filter (default 0 = none).
    #[serde(default)]
    pub refine_iterations: Option<u32>,
    /// Tags already installed (CSV as `--tags`, relative to the scenario's
    /// folder): kept, not counted as new, never skipped.
    #[serde(default)]
    pub existing_tags: Option<std::path::PathBuf>,
    /// Network coverage: where walks may turn back, "anywhere" (any
    /// junction, the default) or "dead_ends".
    #[serde(default)]
    pub u_turns: Option<String>,
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

/// A loaded, validated scenario in SI units.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The file it came from.
    pub path: PathBuf,
    /// The file as parsed.
    pub file: ScenarioFile,
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
    pub rfid: super::tags::RfidModel,
}

struct Check<'a> {
    path: &'a Path,
}

impl Check<'_> {
    fn err(&self, msg: impl Into<String>) -> Error {
        Error::scenario(self.path, msg)
    }
    fn finite(&self, field: &str, x: f64) -> Result<f64> {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(format!("{field} must be a finite number, got {x}")))
        }
    }
    fn finite_all(&self, field: &str, xs: &[f64]) -> Result<()> {
        for (i, x) in xs.iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), *x)?;
        }
        Ok(())
    }
    fn non_negative(&self, field: &str, x: f64) -> Result<f64> {
        if x.is_finite() && x >= 0.0 {
            Ok(x)
        } else {
            Err(self.err(format!("{field} must be zero or positive, got {x}")))
        }
    }
    fn positive(&self, field: &str, x: f64) -> Result<f64> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(format!("{field} must be positive, got {x}")))
        }
    }
    fn range(&self, field: &str, x: f64, lo: f64, hi: f64) -> Result<f64> {
        if x.is_finite() && x >= lo && x <= hi {
            Ok(x)
        } else {
            Err(self.err(format!("{field} must be between {lo} and {hi}, got {x}")))
        }
    }
}

/// One-line description of a TOML parse error with its line number.
fn toml_error(text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            format!("line {line}: {}", msg.trim())
        }
        None => msg.trim().to_string(),
    }
}

impl Scenario {
    /// Reads and validates a scenario file.
    pub fn load(path: &Path) -> Result<Scenario> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        tracing::debug!("reading scenario {}", path.display());
        Self::parse(path, &text)
    }

    /// Parses and validates scenario text; `path` names it in errors and
    /// anchors relative map paths.
    pub fn parse(path: &Path, text: &str) -> Result<Scenario> {
        let file: ScenarioFile =
            toml::from_str(text).map_err(|e| Error::scenario(path, toml_error(text, &e)))?;
        let c = Check { path };
        if let Some(r) = file.requirement_m {
            c.positive("requirement_m", r)?;
        }
        if let Some(d) = file.duration_s {
            c.positive("duration_s", d)?;
        }
        let output_interval_s = match file.output_interval_s {
            Some(x) => c.positive("output_interval_s", x)?,
            None => 1.0,
        };
        // IMU
        let s = &file.imu;
        let rate = c.range("imu.rate_hz", s.rate_hz, 1.0, 10_000.0)?;
        let dt = 1.0 / rate;
        if output_interval_s < dt {
            return Err(c.err("output_interval_s must be at least one IMU interval"));
        }
        c.finite_all("imu.gyro_bias_dph", &s.gyro_bias_dph)?;
        c.finite_all("imu.accel_bias_ug", &s.accel_bias_ug)?;
        c.non_negative("imu.gyro_bias_instability_dph", s.gyro_bias_instability_dph)?;
        c.positive("imu.gyro_bias_tau_s", s.gyro_bias_tau_s)?;
        c.non_negative("imu.accel_bias_instability_ug", s.accel_bias_instability_ug)?;
        c.positive("imu.accel_bias_tau_s", s.accel_bias_tau_s)?;
        c.non_negative("imu.gyro_arw_dprh", s.gyro_arw_dprh)?;
        c.non_negative("imu.accel_vrw_ugprhz", s.accel_vrw_ugprhz)?;
        for (f, v) in [
            ("imu.gyro_scale_factor_ppm", &s.gyro_scale_factor_ppm),
            ("imu.accel_scale_factor_ppm", &s.accel_scale_factor_ppm),
        ] {
            for (i, x) in v.iter().enumerate() {
                c.range(&format!("{f}[{i}]"), *x, -1e5, 1e5)?;
            }
        }
        for (f, v) in [
            ("imu.gyro_misalignment_arcsec", &s.gyro_misalignment_arcsec),
            (
                "imu.accel_misalignment_arcsec",
                &s.accel_misalignment_arcsec,
            ),
        ] {
            for (i, x) in v.iter().enumerate() {
                c.range(&format!("{f}[{i}]"), *x, -36_000.0, 36_000.0)?;
            }
        }
        let rotation = match s.rotation_modulation {
            Some(r) => {
                let rate = c.range(
                    "imu.rotation_modulation.rate_dps",
                    r.rate_dps,
                    -360.0,
                    360.0,
                )?;
                if rate == 0.0 {
                    return Err(c.err("imu.rotation_modulation.rate_dps must not be zero"));
                }
                Some(RotationModulation {
                    rate: rate.to_radians(),
                })
            }
            None => None,
        };
        let imu = ImuModel {
            gyro_bias: s.gyro_bias_dph.map(|x| x * DEG_PER_HOUR),
            accel_bias: s.accel_bias_ug.map(|x| x * 1e-6 * G0),
            gyro_bias_instability: s.gyro_bias_instability_dph * DEG_PER_HOUR,
            gyro_bias_tau_s: s.gyro_bias_tau_s,
            accel_bias_instability: s.accel_bias_instability_ug * 1e-6 * G0,
            accel_bias_tau_s: s.accel_bias_tau_s,
            gyro_arw: s.gyro_arw_dprh.to_radians() / 60.0,
            accel_vrw: s.accel_vrw_ugprhz * 1e-6 * G0,
            gyro_scale_factor: s.gyro_scale_factor_ppm.map(|x| x * 1e-6),
            accel_scale_factor: s.accel_scale_factor_ppm.map(|x| x * 1e-6),
            gyro_misalignment: s.gyro_misalignment_arcsec.map(|x| x * ARCSEC),
            accel_misalignment: s.accel_misalignment_arcsec.map(|x| x * ARCSEC),
        };
        // Odometer
        let o = &file.odometer;
        c.range(
            "odometer.scale_factor_error",
            o.scale_factor_error,
            -0.5,
            0.5,
        )?;
        c.non_negative("odometer.noise_mps", o.noise_mps)?;
        c.non_negative("odometer.pulse_m", o.pulse_m)?;
        let slip = match o.slip {
            Some(sl) => Some(WheelSlip {
                rate_per_km: c.non_negative("odometer.slip.rate_per_km", sl.rate_per_km)?,
                length_m: c.non_negative("odometer.slip.length_m", sl.length_m)?,
                overcount: c.range("odometer.slip.overcount", sl.overcount, -1.0, 10.0)?,
            }),
            None => None,
        };
        let failure = match o.failure {
            Some(f) => {
                if f.from_s.is_none() && f.from_m.is_none() {
                    return Err(c.err("odometer.failure needs from_s or from_m"));
                }
                if let Some(x) = f.from_s {
                    c.non_negative("odometer.failure.from_s", x)?;
                }
                if let Some(x) = f.from_m {
                    c.non_negative("odometer.failure.from_m", x)?;
                }
                Some(OdometerFailure {
                    from_s: f.from_s,
                    from_m: f.from_m,
                })
            }
            None => None,
        };
        let odometer = OdometerModel {
            scale_factor_error: o.scale_factor_error,
            noise_mps: o.noise_mps,
            pulse_m: o.pulse_m,
            slip,
            failure,
        };
        // Vehicle and differential odometer
        c.range("vehicle.width_m", file.vehicle.width_m, 0.5, 10.0)?;
        let track = c.range(
            "vehicle.track_width_m",
            file.vehicle.track_width_m,
            0.3,
            10.0,
        )?;
        let d = &file.diff_odometer;
        c.range(
            "diff_odometer.scale_factor_error_left",
            d.scale_factor_error_left,
            -0.5,
            0.5,
        )?;
        c.range(
            "diff_odometer.scale_factor_error_right",
            d.scale_factor_error_right,
            -0.5,
            0.5,
        )?;
        c.range(
            "diff_odometer.track_width_error_m",
            d.track_width_error_m,
            -0.5 * track,
            0.5 * track,
        )?;
        c.non_negative("diff_odometer.noise_mps", d.noise_mps)?;
        c.non_negative("diff_odometer.pulse_m", d.pulse_m)?;
        let diff_odometer = DiffOdometerModel {
            track_width_m: track,
            track_width_error_m: d.track_width_error_m,
            scale_factor_error_left: d.scale_factor_error_left,
            scale_factor_error_right: d.scale_factor_error_right,
            noise_mps: d.noise_mps,
            pulse_m: d.pulse_m,
        };
        // Baro
        let b = &file.baro;
        let baro = BarometerModel {
            rate_hz: c.range("baro.rate_hz", b.rate_hz, 0.01, rate)?,
            noise_m: c.non_negative("baro.noise_m", b.noise_m)?,
            initial_bias_m: c.finite("baro.initial_bias_m", b.initial_bias_m)?,
            bias_drift_m: c.non_negative("baro.bias_drift_m", b.bias_drift_m)?,
            bias_tau_s: c.positive("baro.bias_tau_s", b.bias_tau_s)?,
            scale_factor_error: c.range(
                "baro.scale_factor_error",
                b.scale_factor_error,
                -0.5,
                0.5,
            )?,
        };
        c.range(
            "level_sensor.noise_deg",
            file.level_sensor.noise_deg,
            0.0,
            10.0,
        )?;
        // Navigator
        let n = &file.navigator;
        if let Some(t) = n.vertical_tau_s {
            c.range("navigator.vertical_tau_s", t, 1.0, 1e5)?;
        }
        for (i, x) in n.initial_attitude_error_arcmin.iter().enumerate() {
            c.range(
                &format!("navigator.initial_attitude_error_arcmin[{i}]"),
                *x,
                -600.0,
                600.0,
            )?;
        }
        for (i, x) in n.initial_velocity_error_mps.iter().enumerate() {
            c.range(
                &format!("navigator.initial_velocity_error_mps[{i}]"),
                *x,
                -100.0,
                100.0,
            )?;
        }
        c.range(
            "navigator.initial_attitude_sigma_arcmin[0]",
            n.initial_attitude_sigma_arcmin[0],
            0.0,
            600.0,
        )?;
        c.range(
            "navigator.initial_attitude_sigma_arcmin[1]",
            n.initial_attitude_sigma_arcmin[1],
            0.0,
            600.0,
        )?;
        c.range(
            "navigator.initial_position_sigma_m[0]",
            n.initial_position_sigma_m[0],
            0.0,
            1e5,
        )?;
        c.range(
            "navigator.initial_position_sigma_m[1]",
            n.initial_position_sigma_m[1],
            0.0,
            1e5,
        )?;
        c.range(
            "navigator.initial_velocity_sigma_mps",
            n.initial_velocity_sigma_mps,
            0.0,
            100.0,
        )?;
        for (i, x) in n.initial_position_error_m.iter().enumerate() {
            c.range(
                &format!("navigator.initial_position_error_m[{i}]"),
                *x,
                -1e5,
                1e5,
            )?;
        }
        let mut rfid = super::tags::RfidModel {
            vehicle_width_m: file.vehicle.width_m,
            ..Default::default()
        };
        if let Some(p) = &file.rfid {
            let opt = |name: &str, x: Option<f64>, lo: f64, hi: f64, dst: &mut f64| -> Result<()> {
                if let Some(x) = x {
                    *dst = c.range(&format!("rfid.{name}"), x, lo, hi)?;
                }
                Ok(())
            };
            opt(
                "read_probability",
                p.read_probability,
                0.0,
                1.0,
                &mut rfid.read_probability,
            )?;
            for (i, (name, x)) in [
                (
                    "read_probability_road_surface",
                    p.read_probability_road_surface,
                ),
                ("read_probability_roadside", p.read_probability_roadside),
                ("read_probability_ceiling", p.read_probability_ceiling),
            ]
            .into_iter()
            .enumerate()
            {
                if let Some(x) = x {
                    rfid.read_probability_by_mounting[i] =
                        Some(c.range(&format!("rfid.{name}"), x, 0.0, 1.0)?);
                }
            }
            opt(
                "lane_width_m",
                p.lane_width_m,
                1.0,
                10.0,
                &mut rfid.lane_width_m,
            )?;
            opt(
                "roadside_distance_m",
                p.roadside_distance_m,
                0.0,
                50.0,
                &mut rfid.roadside_distance_m,
            )?;
            let mut ang = rfid.roadside_angle.to_degrees();
            opt(
                "roadside_angle_deg",
                p.roadside_angle_deg,
                0.0,
                80.0,
                &mut ang,
            )?;
            rfid.roadside_angle = ang.to_radians();
            opt(
                "read_time_s",
                p.read_time_s,
                0.0,
                1.0,
                &mut rfid.read_time_s,
            )?;
            opt(
                "roadside_range_m",
                p.roadside_range_m,
                0.5,
                100.0,
                &mut rfid.roadside_range_m,
            )?;
            opt(
                "road_surface_sigma_m",
                p.road_surface_sigma_m,
                0.0,
                0.5,
                &mut rfid.road_surface_sigma_m,
            )?;
            opt(
                "ceiling_sigma_m",
                p.ceiling_sigma_m,
                0.0,
                0.3,
                &mut rfid.ceiling_sigma_m,
            )?;
            opt(
                "height_sigma_m",
                p.height_sigma_m,
                0.0,
                100.0,
                &mut rfid.height_sigma_m,
            )?;
        }
        c.non_negative("imu.gyro_bias_random_dph", file.imu.gyro_bias_random_dph)?;
        c.non_negative("imu.accel_bias_random_ug", file.imu.accel_bias_random_ug)?;
        for (i, t) in file.tag.iter().enumerate() {
            let f = |n: &str| format!("tag[{i}].{n}");
            let placed = [
                t.lat.is_some() && t.lon.is_some(),
                t.at_s.is_some(),
                t.at_m.is_some(),
            ];
            if placed.iter().filter(|x| **x).count() != 1 || t.lat.is_some() != t.lon.is_some() {
                return Err(c.err(format!(
                    "tag[{i}] needs exactly one of lat+lon, at_s and at_m"
                )));
            }
            if let Some(x) = t.lat {
                c.range(&f("lat"), x, -89.0, 89.0)?;
            }
            if let Some(x) = t.lon {
                c.range(&f("lon"), x, -180.0, 180.0)?;
            }
            if let Some(x) = t.at_s {
                c.non_negative(&f("at_s"), x)?;
            }
            if let Some(x) = t.at_m {
                c.non_negative(&f("at_m"), x)?;
            }
            if let Some(x) = t.height_m {
                c.range(&f("height_m"), x, -1000.0, 10_000.0)?;
            }
            if let Some(m) = &t.mounting {
                if super::tags::Mounting::parse(m).is_none() {
                    return Err(c.err(format!(
                        "tag[{i}].mounting \"{m}\" is not one of road_surface, roadside, ceiling"
                    )));
                }
            }
            if let Some(e) = t.survey_error_m {
                c.finite_all(&f("survey_error_m"), &e)?;
            }
        }
        let fs = &file.filter;
        for (name, x, lo, hi) in [
            ("filter.interval_s", fs.interval_s, dt, 10.0),
            (
                "filter.odometer_interval_s",
                fs.odometer_interval_s,
                dt,
                10.0,
            ),
            (
                "filter.odometer_noise_mps",
                fs.odometer_noise_mps,
                1e-4,
                10.0,
            ),
            ("filter.nhc_noise_mps", fs.nhc_noise_mps, 1e-4, 10.0),
            (
                "filter.gyro_bias_sigma_dph",
                fs.gyro_bias_sigma_dph,
                0.0,
                1e4,
            ),
            (
                "filter.accel_bias_sigma_ug",
                fs.accel_bias_sigma_ug,
                0.0,
                1e6,
            ),
            (
                "filter.odometer_scale_sigma",
                fs.odometer_scale_sigma,
                0.0,
                0.5,
            ),
            (
                "filter.odometer_misalignment_sigma_deg",
                fs.odometer_misalignment_sigma_deg,
                0.0,
                10.0,
            ),
            (
                "filter.velocity_sigma_mps",
                fs.velocity_sigma_mps,
                0.0,
                100.0,
            ),
        ] {
            if let Some(x) = x {
                c.range(name, x, lo, hi)?;
            }
        }
        if let Some(a) = fs.attitude_sigma_arcmin {
            c.range("filter.attitude_sigma_arcmin[0]", a[0], 0.0, 600.0)?;
            c.range("filter.attitude_sigma_arcmin[1]", a[1], 0.0, 600.0)?;
        }
        if let Some(a) = fs.position_sigma_m {
            c.range("filter.position_sigma_m[0]", a[0], 0.0, 1e5)?;
            c.range("filter.position_sigma_m[1]", a[1], 0.0, 1e5)?;
        }
        if let Some(x) = &file.external_fix {
            let [a, b] = x.interval_s;
            c.range("external_fix.interval_s[0]", a, dt, 1e5)?;
            c.range("external_fix.interval_s[1]", b, a, 1e5)?;
            c.range("external_fix.white_m", x.white_m, 0.0, 1e5)?;
            c.non_negative(
                "external_fix.random_walk_m_per_rts",
                x.random_walk_m_per_rts,
            )?;
            if let Some(w) = x.filter_white_m {
                c.range("external_fix.filter_white_m", w, 1e-3, 1e5)?;
            }
            if let Some(b) = x.fading_b {
                if !(b > 0.0 && b < 1.0) {
                    return Err(c.err(format!(
                        "external_fix.fading_b must be between 0 and 1 (exclusive), got {b}"
                    )));
                }
            }
            match x.adaptive.as_deref() {
                None | Some("none") | Some("sage_husa") => {}
                Some(o) => {
                    return Err(c.err(format!(
                        "external_fix.adaptive \"{o}\" is not one of none, sage_husa"
                    )))
                }
            }
        } else if file.aiding.external_fix {
            return Err(c.err("aiding.external_fix needs an [external_fix] section"));
        }
        // Route
        let route = Self::route(&c, path, &file)?;
        Ok(Scenario {
            path: path.to_path_buf(),
            route,
            dt,
            imu,
            rotation,
            odometer,
            diff_odometer,
            baro,
            initial_attitude_error: n.initial_attitude_error_arcmin.map(|x| x * ARCMIN),
            output_interval_s,
            rfid,
            file,
        })
    }

    fn route(c: &Check, path: &Path, file: &ScenarioFile) -> Result<RouteKind> {
        let Some(r) = file.route.first() else {
            return Err(c.err("no [[route]]: give waypoints (with [map]) or start and motion"));
        };
        match (&r.waypoints, &r.start) {
            (Some(_), Some(_)) => Err(c.err(
                "route[0] has both waypoints and start; use waypoints on a map or start with motion commands",
            )),
            (None, None) => Err(c.err("route[0] needs waypoints (with [map]) or start and motion")),
            (None, Some(st)) => {
                if r.speed_kmh.is_some() || !r.stops.is_empty() {
                    return Err(c.err(
                        "route[0]: speed_kmh and stops belong to waypoint routes; motion routes set speed with accelerate",
                    ));
                }
                c.range("route[0].start.lat", st.lat, -89.0, 89.0)?;
                c.range("route[0].start.lon", st.lon, -180.0, 180.0)?;
                c.range("route[0].start.height_m", st.height_m, -1000.0, 10_000.0)?;
                c.finite("route[0].start.heading_deg", st.heading_deg)?;
                c.range("route[0].start.pitch_deg", st.pitch_deg, -45.0, 45.0)?;
                c.range("route[0].start.roll_deg", st.roll_deg, -60.0, 60.0)?;
                c.range("route[0].start.speed_kmh", st.speed_kmh, 0.0, 400.0)?;
                let start = Start {
                    lat: st.lat.to_radians(),
                    lon: st.lon.to_radians(),
                    h: st.height_m,
                    heading: st.heading_deg.to_radians(),
                    pitch: st.pitch_deg.to_radians(),
                    roll: st.roll_deg.to_radians(),
                    speed_mps: st.speed_kmh / 3.6,
                };
                let mut commands = Vec::with_capacity(r.motion.len());
                for (i, m) in r.motion.iter().enumerate() {
                    commands.push(motion(c, i, m)?);
                }
                // Compile once here so impossible motions are reported at load.
                crate::trajectory::MotionPlan::new(start, &commands, 1.0 / file.imu.rate_hz)
                    .map_err(|e| c.err(strip_invalid(e)))?;
                Ok(RouteKind::Motion { start, commands })
            }
            (Some(w), None) => {
                if !r.motion.is_empty() {
                    return Err(c.err("route[0]: motion commands need a start, not waypoints"));
                }
                let Some(map) = &file.map else {
                    return Err(c.err("route[0] has waypoints but there is no [map] path"));
                };
                if w.len() < 2 {
                    return Err(c.err("route[0].waypoints needs at least two points"));
                }
                for (i, p) in w.iter().enumerate() {
                    c.range(&format!("route[0].waypoints[{i}] latitude"), p[0], -89.0, 89.0)?;
                    c.range(&format!("route[0].waypoints[{i}] longitude"), p[1], -180.0, 180.0)?;
                }
                let speed = c.range("route[0].speed_kmh", r.speed_kmh.unwrap_or(40.0), 1.0, 300.0)?;
                let mut profile = crate::trajectory::route::SpeedProfile {
                    speed_mps: speed / 3.6,
                    ..Default::default()
                };
                if let Some(x) = r.max_lateral_accel_mps2 {
                    profile.max_lateral_accel_mps2 =
                        c.range("route[0].max_lateral_accel_mps2", x, 0.1, 8.0)?;
                }
                if let Some(x) = r.accel_mps2 {
                    profile.accel_mps2 = c.range("route[0].accel_mps2", x, 0.05, 9.81)?;
                }
                if let Some(x) = r.brake_mps2 {
                    profile.brake_mps2 = c.range("route[0].brake_mps2", x, 0.05, 9.81)?;
                }
                let mut stops = Vec::new();
                for (i, s) in r.stops.iter().enumerate() {
                    stops.push((
                        c.non_negative(&format!("route[0].stops[{i}].at_m"), s.at_m)?,
                        c.positive(&format!("route[0].stops[{i}].duration_s"), s.duration_s)?,
                    ));
                }
                let height_m = c.range("route[0].height_m", r.height_m.unwrap_or(0.0), -1000.0, 10_000.0)?;
                let base = path.parent().unwrap_or(Path::new("."));
                Ok(RouteKind::Map {
                    map: base.join(&map.path),
                    waypoints: w.clone(),
                    profile,
                    stops,
                    height_m,
                })
            }
        }
    }
}

fn strip_invalid(e: Error) -> String {
    match e {
        Error::InvalidParameter(m) => m.replacen("route.", "route[0].", 1),
        other => other.to_string(),
    }
}

fn motion(c: &Check, i: usize, m: &MotionSpec) -> Result<Motion> {
    let f = |name: &str| format!("route[0].motion[{i}].{name}");
    let need = |name: &str, x: Option<f64>| -> Result<f64> {
        x.ok_or_else(|| c.err(format!("route[0].motion[{i}] ({}) needs {name}", m.kind)))
    };
    let extent = || -> Result<Extent> {
        match (m.duration_s, m.distance_m) {
            (Some(t), None) => Ok(Extent::Duration(c.positive(&f("duration_s"), t)?)),
            (None, Some(d)) => Ok(Extent::Distance(c.positive(&f("distance_m"), d)?)),
            _ => Err(c.err(format!(
                "route[0].motion[{i}] ({}) needs exactly one of duration_s and distance_m",
                m.kind
            ))),
        }
    };
    let forbid = |names: &[(&str, bool)]| -> Result<()> {
        for (n, present) in names {
            if *present {
                return Err(c.err(format!(
                    "route[0].motion[{i}] ({}) does not take {n}",
                    m.kind
                )));
            }
        }
        Ok(())
    };
    let speed_fields = [
        ("to_kmh", m.to_kmh.is_some()),
        ("accel_mps2", m.accel_mps2.is_some()),
    ];
    let turn_fields = [
        ("angle_deg", m.angle_deg.is_some()),
        ("radius_m", m.radius_m.is_some()),
    ];
    let grade_fields = [
        ("grade_percent", m.grade_percent.is_some()),
        ("pitch_rate_dps", m.pitch_rate_dps.is_some()),
    ];
    let time_fields = [
        ("duration_s", m.duration_s.is_some()),
        ("distance_m", m.distance_m.is_some()),
    ];
    Ok(match m.kind.as_str() {
        "stay" => {
            forbid(&speed_fields)?;
            forbid(&turn_fields)?;
            forbid(&grade_fields)?;
            forbid(&[("distance_m", m.distance_m.is_some())])?;
            Motion::Stay {
                duration_s: c.positive(&f("duration_s"), need("duration_s", m.duration_s)?)?,
            }
        }
        "accelerate" | "decelerate" => {
            forbid(&turn_fields)?;
            forbid(&grade_fields)?;
            forbid(&time_fields)?;
            Motion::ChangeSpeed {
                to_mps: c.range(&f("to_kmh"), need("to_kmh", m.to_kmh)?, 0.0, 400.0)? / 3.6,
                accel_mps2: c.positive(&f("accel_mps2"), m.accel_mps2.unwrap_or(1.0))?,
                decelerate: m.kind == "decelerate",
            }
        }
        "cruise" => {
            forbid(&speed_fields)?;
            forbid(&turn_fields)?;
            forbid(&grade_fields)?;
            Motion::Cruise { extent: extent()? }
        }
        "turn" => {
            forbid(&speed_fields)?;
            forbid(&grade_fields)?;
            forbid(&time_fields)?;
            let a = c.range(&f("angle_deg"), need("angle_deg", m.angle_deg)?, -3600.0, 3600.0)?;
            if a == 0.0 {
                return Err(c.err(format!("{} must not be zero", f("angle_deg"))));
            }
            Motion::Turn {
                angle: a.to_radians(),
                radius_m: c.positive(&f("radius_m"), need("radius_m", m.radius_m)?)?,
            }
        }
        "climb" | "descend" => {
            forbid(&speed_fields)?;
            forbid(&turn_fields)?;
            let g = c.range(&f("grade_percent"), need("grade_percent", m.grade_percent)?, 0.0, 100.0)?;
            let sign = if m.kind == "climb" { 1.0 } else { -1.0 };
            Motion::Climb {
                grade: sign * g / 100.0,
                extent: extent()?,
                pitch_rate: c.positive(&f("pitch_rate_dps"), m.pitch_rate_dps.unwrap_or(1.0))?.to_radians(),
            }
        }
        other => {
            return Err(c.err(format!(
                "route[0].motion[{i}].kind \"{other}\" is not one of stay, accelerate, decelerate, cruise, turn, climb, descend"
            )))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scenario sketch of DESIGN.md parses as written (map route, all sections).
    #[test]
    fn design_sketch_parses() {
        let text = r#"
name = "tunnel-run"
requirement_m = 20.0
duration_s = 3600
[map]
path = "maps/helsinki.osm.pbf"
[[route]]
waypoints = [[60.170, 24.940], [60.175, 24.950]]
speed_kmh = 40
[vehicle]
width_m = 2.5
[navigator]
mode = "integrated"
[imu]
rate_hz = 100
gyro_bias_dph = [0.01, 0.01, 0.01]
accel_bias_ug = [50, 50, 50]
gyro_arw_dprh = 0.001
accel_vrw_ugprhz = 5
[odometer]
scale_factor_error = 0.00131
failure = { from_s = 3600 }
[aiding]
odometer = true
rfid = true
map_matching = false
baro = true
[rfid]
read_probability = 0.977
[planner]
coverage = "routes"
tolerate_missed_reads = 1
mountings = ["road_surface", "roadside", "ceiling"]
"#;
        let s = Scenario::parse(Path::new("/x/scn.toml"), text).unwrap();
        match &s.route {
            RouteKind::Map {
                map,
                waypoints,
                profile,
                ..
            } => {
                assert_eq!(map, Path::new("/x/maps/helsinki.osm.pbf"));
                assert_eq!(waypoints.len(), 2);
                assert!((profile.speed_mps - 40.0 / 3.6).abs() < 1e-12);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(s.file.navigator.mode, NavMode::Integrated);
        // Units converted at the edge: 0.01 °/h and 50 µg.
        assert!((s.imu.gyro_bias[0] - 0.01f64.to_radians() / 3600.0).abs() < 1e-20);
        assert!((s.imu.accel_bias[2] - 50e-6 * G0).abs() < 1e-15);
        assert_eq!(s.odometer.failure.unwrap().from_s, Some(3600.0));
    }

    #[test]
    fn errors_name_the_file_and_line() {
        let e = Scenario::parse(Path::new("a.toml"), "name = \"x\"\n\nbogus = 1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("a.toml: line 3:") && e.contains("bogus"),
            "{e}"
        );
        let e = Scenario::parse(
            Path::new("a.toml"),
            "name = \"x\"\n[[route]]\nstart = { lat = 95.0, lon = 0.0 }\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("route[0].start.lat"), "{e}");
    }
}
