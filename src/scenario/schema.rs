//! The raw scenario file (TOML) as serde reads it: field names carry their
//! units (`_m`, `_s`, `_deg`, `_dph`, `_ug`, `_kmh`, ...), optional values are
//! `Option`s, and every closed set of options is a serde enum. Unknown fields
//! and unknown option values are errors at parse time. Nothing here is
//! checked for range or converted: see [`Scenario::parse`](super::Scenario::parse), which validates.

use crate::tags::Mounting;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

mod sensors;
pub use sensors::{
    BaroSection, DiffOdometerSection, FailureSpec, ImuSection, LevelSensorSection, OdometerSection,
    RotationSpec, SlipSpec,
};

/// Fixed-length number arrays read exactly: the `toml` crate hands serde's
/// `[f64; N]` a longer array without complaint (the elements beyond `N`
/// were silently dropped: `accel_bias_ug = [1, 2, 3, 4]`, a waypoint
/// `[lat, lon, height]`), so these read the whole list and refuse any other
/// length with serde's own message ("invalid length 4, expected an array
/// of length 3"), which the parser places at the field and line.
mod exact {
    use serde::de::{Deserialize, Deserializer, Error};

    fn fixed<E: Error, const N: usize>(v: Vec<f64>) -> Result<[f64; N], E> {
        let n = v.len();
        v.try_into()
            .map_err(|_| E::invalid_length(n, &format!("an array of length {N}").as_str()))
    }

    /// `[f64; N]`.
    pub fn array<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
        fixed(Vec::<f64>::deserialize(d)?)
    }

    /// `Option<[f64; N]>` (with `#[serde(default)]`: absent is `None`).
    pub fn option<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<Option<[f64; N]>, D::Error> {
        array(d).map(Some)
    }

    /// `Vec<[f64; N]>`.
    pub fn list<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<Vec<[f64; N]>, D::Error> {
        Vec::<Vec<f64>>::deserialize(d)?
            .into_iter()
            .map(fixed)
            .collect()
    }

    /// `Option<Vec<[f64; N]>>` (with `#[serde(default)]`).
    pub fn option_list<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<Option<Vec<[f64; N]>>, D::Error> {
        list(d).map(Some)
    }
}

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
    pub mounting: Option<Mounting>,
    /// Stored minus physical position, east and north (m): a misplaced tag.
    #[serde(default, deserialize_with = "exact::option")]
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
    #[serde(default, deserialize_with = "exact::option")]
    pub attitude_sigma_arcmin: Option<[f64; 2]>,
    /// Prior σ of the initial position error, horizontal and vertical (m).
    #[serde(default, deserialize_with = "exact::option")]
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
    #[serde(deserialize_with = "exact::array")]
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
    pub adaptive: Option<Adaptive>,
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
    /// Geometry error of the map the navigator has against the world the
    /// vehicle drives in: 1σ per horizontal axis (m, ≥ 0; default
    /// 4.8 m, from Haklay 2010's
    /// ~6 m mean offset of OpenStreetMap roads from Ordnance Survey; 0: a
    /// perfect map).
    #[serde(default)]
    pub geometry_error_m: Option<f64>,
    /// Correlation length of that error (m, > 0; default 200): the length
    /// scale L of its Gaussian covariance σ² exp(−d²/2L²).
    #[serde(default)]
    pub geometry_error_correlation_m: Option<f64>,
    /// Digital elevation model(s): one GeoTIFF or a list of tiles, relative
    /// to the scenario file (WGS-84 latitude/longitude, one band of heights).
    #[serde(default)]
    pub elevation: Option<OneOrMany>,
}

/// One file or a list of files.
#[derive(Debug, Clone)]
pub enum OneOrMany {
    /// One file.
    One(PathBuf),
    /// Several files.
    Many(Vec<PathBuf>),
}

/// Read by its form, not as an untagged enum: serde's untagged error
/// ("data did not match any variant of untagged enum OneOrMany") names
/// neither the value's type nor what is expected.
impl<'de> Deserialize<'de> for OneOrMany {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Files;
        impl<'de> serde::de::Visitor<'de> for Files {
            type Value = OneOrMany;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(
                    "a GeoTIFF path (\"dem.tif\") or a list of GeoTIFF paths ([\"a.tif\", \"b.tif\"])",
                )
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<OneOrMany, E> {
                Ok(OneOrMany::One(PathBuf::from(v)))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<OneOrMany, A::Error> {
                let mut files = Vec::new();
                while let Some(f) = seq.next_element::<File>()? {
                    files.push(f.0);
                }
                Ok(OneOrMany::Many(files))
            }
        }
        /// One path of the list (its own type, for its own expectation).
        struct File(PathBuf);
        impl<'de> Deserialize<'de> for File {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct OnePath;
                impl serde::de::Visitor<'_> for OnePath {
                    type Value = File;
                    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                        f.write_str("a GeoTIFF path (\"dem.tif\")")
                    }
                    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<File, E> {
                        Ok(File(PathBuf::from(v)))
                    }
                }
                d.deserialize_str(OnePath)
            }
        }
        d.deserialize_any(Files)
    }
}

/// `[[route]]`: waypoints on the map, or a start and motion commands.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RouteSection {
    /// Waypoints, [latitude, longitude] in degrees.
    #[serde(default, deserialize_with = "exact::option_list")]
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
    pub kind: MotionKind,
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
    /// Cruise speed of the vehicles on a network plan (km/h, default 50),
    /// capped on each road by its `maxspeed` or its class's typical speed.
    #[serde(default)]
    pub speed_kmh: Option<f64>,
    /// Side of the road traffic keeps to: `"right"` (default) or `"left"`;
    /// the truth drives in a lane of its direction on that side.
    #[serde(default)]
    pub drive_side: Option<crate::network::DriveSide>,
    /// Lateral wander of the vehicle about its lane centre, 1σ (m, ≥ 0;
    /// default 0.3).
    #[serde(default)]
    pub lane_wander_m: Option<f64>,
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
            speed_kmh: None,
            drive_side: None,
            lane_wander_m: None,
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
    #[serde(default, deserialize_with = "exact::array")]
    pub initial_attitude_error_arcmin: [f64; 3],
    /// Initial velocity error, east, north, up (m/s).
    #[serde(default, deserialize_with = "exact::array")]
    pub initial_velocity_error_mps: [f64; 3],
    /// Initial position error, east, north, up (m).
    #[serde(default, deserialize_with = "exact::array")]
    pub initial_position_error_m: [f64; 3],
    /// Random initial attitude error drawn per run (integrated mode), σ of
    /// pitch/roll and of heading (arcmin), added to the fixed one.
    #[serde(default, deserialize_with = "exact::array")]
    pub initial_attitude_sigma_arcmin: [f64; 2],
    /// Random initial horizontal and vertical position error per run, σ (m).
    #[serde(default, deserialize_with = "exact::array")]
    pub initial_position_sigma_m: [f64; 2],
    /// Random initial velocity error per run, σ (m/s).
    #[serde(default)]
    pub initial_velocity_sigma_mps: f64,
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
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PlannerSection {
    /// "routes" or "network".
    #[serde(default)]
    pub coverage: Option<Coverage>,
    /// Consecutive missed reads to tolerate.
    #[serde(default)]
    pub tolerate_missed_reads: Option<u32>,
    /// Mounting types allowed.
    #[serde(default)]
    pub mountings: Option<Vec<Mounting>>,
    /// Spacing of candidate tag sites along a route (m, default 20).
    #[serde(default)]
    pub candidate_spacing_m: Option<f64>,
    /// Smallest distance between two planned tags (m, default 0).
    #[serde(default)]
    pub min_spacing_m: Option<f64>,
    /// Stretches of route distance where no tag may go: [[from_m, to_m], ...].
    #[serde(default, deserialize_with = "exact::list")]
    pub forbidden_m: Vec<[f64; 2]>,
    /// Monte Carlo runs validating a plan (default 100).
    #[serde(default)]
    pub validation_runs: Option<u64>,
    /// Installed cost per tag by mounting, e.g. { road_surface = 1.0, roadside = 0.6 }.
    #[serde(default)]
    pub cost: Option<BTreeMap<Mounting, f64>>,
    /// Refinements of the reaches from the planned filter (default 0 = none).
    #[serde(default)]
    pub refine_iterations: Option<u32>,
    /// Tags already installed (CSV as `--tags`, relative to the scenario's
    /// folder): kept, not counted as new, never skipped.
    #[serde(default)]
    pub existing_tags: Option<PathBuf>,
    /// Network coverage: where walks may turn back, "anywhere" (any
    /// junction, the default) or "dead_ends".
    #[serde(default)]
    pub u_turns: Option<UTurns>,
    /// Network coverage: the traffic the plan serves, "trips" (the
    /// default) or "any_walk".
    #[serde(default)]
    pub traffic: Option<Traffic>,
    /// `traffic = "trips"` with map matching: 2 (the default) budgets a
    /// chain at the early reach until it is calibrated and at the
    /// calibrated reach after; 1 at the single reach throughout.
    #[serde(default)]
    pub reach_levels: Option<u8>,
    /// `traffic = "trips"`: destinations CSV (`lat,lon[,weight]`, relative
    /// to the scenario's folder); default: points on the network weighted
    /// by road length.
    #[serde(default)]
    pub destinations: Option<PathBuf>,
    /// `traffic = "trips"`: hours of driving per chain of trips (default 8).
    #[serde(default)]
    pub shift_hours: Option<f64>,
    /// `traffic = "trips"`: ε, the probability a fresh chain may violate
    /// the requirement (default 0.01).
    #[serde(default)]
    pub violation_probability: Option<f64>,
    /// `traffic = "trips"`: 1 − β, the confidence of the ε statement
    /// (default 0.99).
    #[serde(default)]
    pub confidence: Option<f64>,
    /// The probability with which the horizontal error must lie within the
    /// requirement (default 0.95).
    #[serde(default)]
    pub requirement_confidence: Option<f64>,
    /// `traffic = "trips"`: chains in the planning sample (default 64).
    #[serde(default)]
    pub planning_chains: Option<u32>,
    /// `traffic = "trips"` with two reach levels: chain beginnings (the
    /// first half hour of a chain) added to the planning sample for their
    /// stretches before calibration (default: four times the first
    /// certification round's chains; 0 for none).
    #[serde(default)]
    pub cold_starts: Option<u32>,
    /// `traffic = "trips"` with two reach levels: sampled chain beginnings
    /// round 1 may test a cover leaving over budget (sampling and
    /// discarding; default: the beginnings drawn times the share of
    /// violations the first round allows, 8 at the defaults; 0 for none).
    #[serde(default)]
    pub discarded_beginnings: Option<u32>,
    /// Chains the network validation drives (default 20).
    #[serde(default)]
    pub validation_chains: Option<u32>,
}

/// The traffic a network plan serves (`planner.traffic`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Traffic {
    /// Continuous chains of shortest-path trips between destinations
    /// (`"trips"`, the default).
    #[default]
    Trips,
    /// Every walk the network allows (`"any_walk"`): the exact walk DP.
    AnyWalk,
}

impl Traffic {
    /// The name used in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Traffic::Trips => "trips",
            Traffic::AnyWalk => "any_walk",
        }
    }
}

/// One motion command's kind (`[[route]].motion[].kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionKind {
    /// Stand still.
    Stay,
    /// Speed up to `to_kmh`.
    Accelerate,
    /// Slow down to `to_kmh`.
    Decelerate,
    /// Hold speed and heading.
    Cruise,
    /// Turn by `angle_deg` on `radius_m`.
    Turn,
    /// Climb at `grade_percent`.
    Climb,
    /// Descend at `grade_percent`.
    Descend,
}

/// The external fix's adaptive noise estimation (`external_fix.adaptive`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Adaptive {
    /// The filter uses `filter_white_m` as given (the default).
    #[default]
    None,
    /// Sage–Husa estimation of the fix noise with fading factor `fading_b`.
    SageHusa,
}

/// What a tag plan must cover (`planner.coverage`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Coverage {
    /// The scenario's route (`"routes"`, the default).
    #[default]
    Routes,
    /// Every drivable road in each permitted direction (`"network"`): see
    /// `planner::network`.
    Network,
}

/// Where network-coverage walks may turn back onto the road they came
/// along (`planner.u_turns`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum UTurns {
    /// At any junction or road end (`"anywhere"`, the default): the
    /// topology's successors, the most conservative.
    #[default]
    Anywhere,
    /// Only at dead ends (`"dead_ends"`: nodes where a single road ends).
    DeadEnds,
}

impl MotionKind {
    /// The name used in files, e.g. `accelerate`.
    pub fn as_str(self) -> &'static str {
        match self {
            MotionKind::Stay => "stay",
            MotionKind::Accelerate => "accelerate",
            MotionKind::Decelerate => "decelerate",
            MotionKind::Cruise => "cruise",
            MotionKind::Turn => "turn",
            MotionKind::Climb => "climb",
            MotionKind::Descend => "descend",
        }
    }
}

impl UTurns {
    /// The name used in files: `anywhere` or `dead_ends`.
    pub fn as_str(self) -> &'static str {
        match self {
            UTurns::Anywhere => "anywhere",
            UTurns::DeadEnds => "dead_ends",
        }
    }
}

impl NavMode {
    /// The name used in files, e.g. `dead_reckoning_3d`.
    pub fn as_str(self) -> &'static str {
        match self {
            NavMode::FreeInertial => "free_inertial",
            NavMode::DeadReckoning => "dead_reckoning",
            NavMode::DeadReckoning3d => "dead_reckoning_3d",
            NavMode::Integrated => "integrated",
        }
    }
}
