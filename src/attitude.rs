//! Rotation algebra for the navigator on `nalgebra`'s static types: 3-vectors
//! ([`V3`]), 3×3 matrices ([`M3`]), unit quaternions ([`Quat`]), and the
//! conventions nalgebra does not fix ([`QuatExt`]): rotation vectors and the
//! PSINS Euler angles.
//!
//! Frames: navigation frame n = East-North-Up; body frame b = right-forward-up.
//! A quaternion [`Quat`] here is q_b^n: it rotates body-frame vectors into the
//! navigation frame. Euler angles follow the PSINS convention for these frames:
//! C_b^n = R_z(yaw) R_x(pitch) R_y(roll), with yaw positive anticlockwise (seen
//! from above); the heading, clockwise from north, is −yaw.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// A 3-vector.
pub type V3 = Vector3<f64>;

/// A 3×3 matrix.
pub type M3 = Matrix3<f64>;

/// A unit quaternion, here q_b^n (body to navigation): `q * v` rotates a
/// body-frame vector into n, `q.inverse_transform_vector(&v)` back.
pub type Quat = UnitQuaternion<f64>;

/// The navigator's conventions on top of [`nalgebra::UnitQuaternion`]: rotation
/// vectors with a small-angle series, and PSINS Euler angles (pitch about x,
/// roll about y, yaw about z anticlockwise; C_b^n = R_z(yaw) R_x(pitch)
/// R_y(roll)), which differ from nalgebra's roll-pitch-yaw.
pub trait QuatExt: Sized {
    /// The quaternion of rotation vector φ (rad).
    fn from_rotvec(phi: V3) -> Self;
    /// The rotation vector (rad) of this quaternion, angle in [0, π].
    fn to_rotvec(&self) -> V3;
    /// From Euler angles (rad): pitch about x, roll about y, yaw about z
    /// (anticlockwise); C_b^n = R_z(yaw) R_x(pitch) R_y(roll).
    fn from_euler(pitch: f64, roll: f64, yaw: f64) -> Self;
    /// Euler angles (pitch, roll, yaw) in rad, the inverse of [`QuatExt::from_euler`].
    fn to_euler(&self) -> (f64, f64, f64);
    /// From a heading clockwise from north, pitch and roll (rad).
    fn from_heading_pitch_roll(heading: f64, pitch: f64, roll: f64) -> Self {
        Self::from_euler(pitch, roll, -heading)
    }
    /// The direction cosine matrix C_b^n.
    fn to_dcm(&self) -> M3;
    /// Scaled back to unit norm (after products have let rounding build up):
    /// one square root and one division, then four products.
    fn normalized(&self) -> Self;
}

/// A unit quaternion from its components w, x, y, z (taken as unit).
#[inline(always)]
pub fn quat(w: f64, x: f64, y: f64, z: f64) -> Quat {
    Quat::new_unchecked(Quaternion::new(w, x, y, z))
}

impl QuatExt for Quat {
    #[inline(always)]
    fn from_rotvec(phi: V3) -> Quat {
        let n2 = phi.norm_squared();
        let (c, s) = if n2 < 1e-8 {
            // Taylor series of cos(n/2) and sin(n/2)/n; error below 1e-20 here.
            let n4 = n2 * n2;
            (1.0 - n2 / 8.0 + n4 / 384.0, 0.5 - n2 / 48.0 + n4 / 3840.0)
        } else {
            let n = n2.sqrt();
            let (sh, ch) = (0.5 * n).sin_cos();
            (ch, sh / n)
        };
        quat(c, s * phi[0], s * phi[1], s * phi[2])
    }

    fn to_rotvec(&self) -> V3 {
        let (w, v) = if self.w < 0.0 {
            (-self.w, -self.imag())
        } else {
            (self.w, self.imag())
        };
        let s = v.norm();
        if s < 1e-12 {
            // angle ≈ 2 s; φ ≈ 2 v (1 + s²/6 ...)
            return v * (2.0 / w);
        }
        let angle = 2.0 * s.atan2(w);
        v * (angle / s)
    }

    fn from_euler(pitch: f64, roll: f64, yaw: f64) -> Quat {
        let (sp, cp) = (0.5 * pitch).sin_cos();
        let (sr, cr) = (0.5 * roll).sin_cos();
        let (sy, cy) = (0.5 * yaw).sin_cos();
        let qz = quat(cy, 0.0, 0.0, sy);
        let qx = quat(cp, sp, 0.0, 0.0);
        let qy = quat(cr, 0.0, sr, 0.0);
        qz * qx * qy
    }

    fn to_euler(&self) -> (f64, f64, f64) {
        let c = self.to_dcm();
        let pitch = c[(2, 1)].clamp(-1.0, 1.0).asin();
        let roll = (-c[(2, 0)]).atan2(c[(2, 2)]);
        let yaw = (-c[(0, 1)]).atan2(c[(1, 1)]);
        (pitch, roll, yaw)
    }

    #[inline(always)]
    fn to_dcm(&self) -> M3 {
        self.to_rotation_matrix().into_inner()
    }

    #[inline(always)]
    fn normalized(&self) -> Quat {
        let (w, x, y, z) = (self.w, self.i, self.j, self.k);
        let n = 1.0 / (w * w + x * x + y * y + z * z).sqrt();
        quat(w * n, x * n, y * n, z * n)
    }
}

/// Wraps an angle to (−π, π].
pub fn wrap_pi(a: f64) -> f64 {
    let mut x = a % std::f64::consts::TAU;
    if x > std::f64::consts::PI {
        x -= std::f64::consts::TAU;
    } else if x <= -std::f64::consts::PI {
        x += std::f64::consts::TAU;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn heading_convention() {
        // Heading 90° (east), level: the forward axis (body y) points east.
        let q = Quat::from_heading_pitch_roll(90f64.to_radians(), 0.0, 0.0);
        let f = q * V3::y();
        assert!((f[0] - 1.0).abs() < 1e-15 && f[1].abs() < 1e-15);
        // Pitch up 10°: forward axis has an up component sin 10°.
        let q = Quat::from_heading_pitch_roll(0.0, 10f64.to_radians(), 0.0);
        let f = q * V3::y();
        assert!((f[2] - 10f64.to_radians().sin()).abs() < 1e-15);
        // Roll right-wing-down 10° (positive roll about forward axis): the right axis
        // dips below the horizon.
        let q = Quat::from_heading_pitch_roll(0.0, 0.0, 10f64.to_radians());
        let r = q * V3::x();
        assert!(r[2] < 0.0);
    }

    proptest! {
        #[test]
        fn euler_round_trip(p in -1.5f64..1.5, r in -3.1f64..3.1, y in -3.1f64..3.1) {
            let q = Quat::from_euler(p, r, y);
            let (p2, r2, y2) = q.to_euler();
            prop_assert!((p - p2).abs() < 1e-12);
            prop_assert!(wrap_pi(r - r2).abs() < 1e-12);
            prop_assert!(wrap_pi(y - y2).abs() < 1e-12);
            // DCM and quaternion rotation agree.
            let v = V3::new(0.3, -1.2, 2.0);
            let a = q * v;
            let b = q.to_dcm() * v;
            for i in 0..3 { prop_assert!((a[i] - b[i]).abs() < 1e-12); }
        }

        #[test]
        fn rotvec_round_trip(x in -3.0f64..3.0, y in -3.0f64..3.0, z in -3.0f64..3.0, s in 1e-9f64..1.0) {
            let phi = V3::new(x, y, z) * (s / 3.0);
            let back = Quat::from_rotvec(phi).to_rotvec();
            for i in 0..3 { prop_assert!((phi[i] - back[i]).abs() < 1e-12); }
        }
    }
}
