//! The sensors' sections of the scenario file (`[imu]`, `[odometer]`,
//! `[diff_odometer]`, `[baro]`, `[level_sensor]`), as serde reads them: see
//! the parent module.

use super::exact;
use serde::Deserialize;

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
    /// Class preset: fills the bias and random-walk fields the file leaves
    /// out with the class's typical figures (`super::presets`).
    #[serde(default)]
    pub grade: Option<crate::scenario::presets::ImuGrade>,
    /// Sampling rate (Hz).
    #[serde(default = "d_rate")]
    pub rate_hz: f64,
    /// Constant gyro bias (deg/h).
    #[serde(default, deserialize_with = "exact::array")]
    pub gyro_bias_dph: [f64; 3],
    /// Constant accelerometer bias (µg).
    #[serde(default, deserialize_with = "exact::array")]
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
    #[serde(default, deserialize_with = "exact::array")]
    pub gyro_scale_factor_ppm: [f64; 3],
    /// Accelerometer scale-factor errors (ppm).
    #[serde(default, deserialize_with = "exact::array")]
    pub accel_scale_factor_ppm: [f64; 3],
    /// Gyro misalignment xy, xz, yx, yz, zx, zy (arcsec).
    #[serde(default, deserialize_with = "exact::array")]
    pub gyro_misalignment_arcsec: [f64; 6],
    /// Accelerometer misalignment xy, xz, yx, yz, zx, zy (arcsec).
    #[serde(default, deserialize_with = "exact::array")]
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
#[derive(Debug, Clone, Copy, Deserialize)]
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
    /// σ of a scale-factor error drawn per run on top of
    /// `scale_factor_error` (ratio).
    #[serde(default)]
    pub scale_factor_sigma: f64,
    /// IMU-to-vehicle mounting misalignment, pitch and yaw (deg): the
    /// vehicle's forward axis is `[−yaw, 1, pitch]` in the IMU's axes.
    #[serde(default, deserialize_with = "exact::array")]
    pub misalignment_deg: [f64; 2],
    /// σ per axis of a misalignment drawn per run on top of
    /// `misalignment_deg` (deg).
    #[serde(default)]
    pub misalignment_sigma_deg: f64,
    /// Steady-state σ of a time-varying scale factor (ratio).
    #[serde(default)]
    pub scale_factor_instability: f64,
    /// Its correlation time (s).
    #[serde(default = "default_scale_factor_tau_s")]
    pub scale_factor_tau_s: f64,
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

fn default_scale_factor_tau_s() -> f64 {
    3600.0
}

impl Default for OdometerSection {
    /// As a file without `[odometer]` reads: a perfect odometer.
    fn default() -> Self {
        Self {
            scale_factor_error: 0.0,
            noise_mps: 0.0,
            pulse_m: 0.0,
            slip: None,
            failure: None,
            scale_factor_sigma: 0.0,
            misalignment_deg: [0.0; 2],
            misalignment_sigma_deg: 0.0,
            scale_factor_instability: 0.0,
            scale_factor_tau_s: default_scale_factor_tau_s(),
        }
    }
}
