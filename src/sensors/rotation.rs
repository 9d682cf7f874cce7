//! Single-axis rotation modulation: the IMU turns about the vehicle's vertical
//! (body z) axis at a constant rate, so constant horizontal sensor errors
//! rotate in the navigation frame and average out over each revolution
//! (PAPERS.md §3.1). The navigator knows the rotation angle (an encoder).

use crate::attitude::{quat, Quat};

/// A constant-rate rotation of the IMU about body z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotationModulation {
    /// Rotation rate (rad/s, positive anticlockwise seen from above).
    pub rate: f64,
}

impl RotationModulation {
    /// The rotation q_s^b of the IMU frame s relative to the body at time `t` (s).
    #[inline]
    pub fn body_from_imu(&self, t: f64) -> Quat {
        let (s, c) = (0.5 * self.rate * t).sin_cos();
        quat(c, 0.0, 0.0, s)
    }

    /// The IMU-frame attitude q_s^n = q_b^n q_s^b for body attitude `q_nb`.
    #[inline]
    pub fn imu_attitude(&self, q_nb: &Quat, t: f64) -> Quat {
        q_nb * self.body_from_imu(t)
    }

    /// The body attitude q_b^n = q_s^n (q_s^b)* from the IMU-frame attitude.
    #[inline]
    pub fn body_attitude(&self, q_ns: &Quat, t: f64) -> Quat {
        q_ns * self.body_from_imu(t).conjugate()
    }
}
