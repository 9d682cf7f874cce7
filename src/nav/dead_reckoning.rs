//! Odometer dead reckoning with IMU attitude: each odometer distance increment
//! is laid along the vehicle's forward axis, taken from the strapdown attitude
//! (the mean of the forward axis at the two ends of the step), and integrated
//! geodetically.

use crate::attitude::{Quat, V3};
use crate::geodesy::radii;

/// The dead-reckoned position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometerDr {
    /// Latitude (rad).
    pub lat: f64,
    /// Longitude (rad).
    pub lon: f64,
    /// Height (m).
    pub h: f64,
}

impl OdometerDr {
    /// Starts at a position.
    pub fn new(lat: f64, lon: f64, h: f64) -> Self {
        Self { lat, lon, h }
    }

    /// Advances by distance `ds` (m) travelled while the body attitude went from
    /// `q0` to `q1` (q_b^n); returns the ENU displacement (m).
    #[inline]
    pub fn step(&mut self, q0: &Quat, q1: &Quat, ds: f64) -> V3 {
        let f = (q0 * V3::y() + q1 * V3::y()) * (0.5 * ds);
        let (rm, rn) = radii(self.lat);
        self.lat += f[1] / (rm + self.h);
        self.lon += f[0] / ((rn + self.h) * self.lat.cos());
        self.h += f[2];
        f
    }
}
