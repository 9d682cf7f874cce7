//! Small fixed-size rotation algebra for the navigator: 3-vectors as `[f64; 3]`,
//! unit quaternions, rotation vectors, direction cosine matrices and Euler angles.
//!
//! Frames: navigation frame n = East-North-Up; body frame b = right-forward-up.
//! A quaternion `Quat` here is q_b^n: it rotates body-frame vectors into the
//! navigation frame. Euler angles follow the PSINS convention for these frames:
//! C_b^n = R_z(yaw) R_x(pitch) R_y(roll), with yaw positive anticlockwise (seen
//! from above); the heading, clockwise from north, is −yaw.

/// A 3-vector.
pub type V3 = [f64; 3];

/// a + b.
#[inline(always)]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// a − b.
#[inline(always)]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// s a.
#[inline(always)]
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// a × b.
#[inline(always)]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// a · b.
#[inline(always)]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// |a|.
#[inline(always)]
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// A 3×3 matrix, row major.
pub type M3 = [[f64; 3]; 3];

/// M v.
#[inline(always)]
pub fn mat_vec(m: &M3, v: V3) -> V3 {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// Mᵀ v.
#[inline(always)]
pub fn mat_t_vec(m: &M3, v: V3) -> V3 {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

/// A unit quaternion [w, x, y, z], here q_b^n (body to navigation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quat(pub [f64; 4]);

impl Default for Quat {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Quat {
    /// No rotation.
    pub const IDENTITY: Quat = Quat([1.0, 0.0, 0.0, 0.0]);

    /// Hamilton product self ⊗ r.
    #[inline(always)]
    pub fn mul(&self, r: &Quat) -> Quat {
        let [a0, a1, a2, a3] = self.0;
        let [b0, b1, b2, b3] = r.0;
        Quat([
            a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3,
            a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1,
        ])
    }

    /// The conjugate (the inverse rotation for a unit quaternion).
    #[inline(always)]
    pub fn conj(&self) -> Quat {
        let [a, b, c, d] = self.0;
        Quat([a, -b, -c, -d])
    }

    /// Rotates v: q ⊗ v ⊗ q*.
    #[inline(always)]
    pub fn rotate(&self, v: V3) -> V3 {
        let [w, x, y, z] = self.0;
        let u = [x, y, z];
        // v + 2w (u × v) + 2 u × (u × v)
        let t = scale(cross(u, v), 2.0);
        add(add(v, scale(t, w)), cross(u, t))
    }

    /// Rotates v by the inverse rotation: q* ⊗ v ⊗ q.
    #[inline(always)]
    pub fn rotate_inv(&self, v: V3) -> V3 {
        self.conj().rotate(v)
    }

    /// Scaled to unit norm.
    #[inline(always)]
    pub fn normalized(&self) -> Quat {
        let [a, b, c, d] = self.0;
        let n = 1.0 / (a * a + b * b + c * c + d * d).sqrt();
        Quat([a * n, b * n, c * n, d * n])
    }

    /// The quaternion of rotation vector φ (rad).
    #[inline(always)]
    pub fn from_rotvec(phi: V3) -> Quat {
        let n2 = dot(phi, phi);
        let (c, s) = if n2 < 1e-8 {
            // Taylor series of cos(n/2) and sin(n/2)/n; error below 1e-20 here.
            let n4 = n2 * n2;
            (1.0 - n2 / 8.0 + n4 / 384.0, 0.5 - n2 / 48.0 + n4 / 3840.0)
        } else {
            let n = n2.sqrt();
            let (sh, ch) = (0.5 * n).sin_cos();
            (ch, sh / n)
        };
        Quat([c, s * phi[0], s * phi[1], s * phi[2]])
    }

    /// The rotation vector (rad) of this quaternion, angle in [0, π].
    pub fn to_rotvec(&self) -> V3 {
        let q = if self.0[0] < 0.0 {
            Quat([-self.0[0], -self.0[1], -self.0[2], -self.0[3]])
        } else {
            *self
        };
        let v = [q.0[1], q.0[2], q.0[3]];
        let s = norm(v);
        if s < 1e-12 {
            // angle ≈ 2 s; φ ≈ 2 v (1 + s²/6 ...)
            return scale(v, 2.0 / q.0[0]);
        }
        let angle = 2.0 * s.atan2(q.0[0]);
        scale(v, angle / s)
    }

    /// The direction cosine matrix C_b^n.
    pub fn to_dcm(&self) -> M3 {
        let [a, b, c, d] = self.0;
        [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a - b * b + c * c - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a - b * b - c * c + d * d,
            ],
        ]
    }

    /// From Euler angles (rad): pitch about x, roll about y, yaw about z
    /// (anticlockwise); C_b^n = R_z(yaw) R_x(pitch) R_y(roll).
    pub fn from_euler(pitch: f64, roll: f64, yaw: f64) -> Quat {
        let (sp, cp) = (0.5 * pitch).sin_cos();
        let (sr, cr) = (0.5 * roll).sin_cos();
        let (sy, cy) = (0.5 * yaw).sin_cos();
        let qz = Quat([cy, 0.0, 0.0, sy]);
        let qx = Quat([cp, sp, 0.0, 0.0]);
        let qy = Quat([cr, 0.0, sr, 0.0]);
        qz.mul(&qx).mul(&qy)
    }

    /// Euler angles (pitch, roll, yaw) in rad, the inverse of [`Quat::from_euler`].
    pub fn to_euler(&self) -> (f64, f64, f64) {
        let c = self.to_dcm();
        let pitch = c[2][1].clamp(-1.0, 1.0).asin();
        let roll = (-c[2][0]).atan2(c[2][2]);
        let yaw = (-c[0][1]).atan2(c[1][1]);
        (pitch, roll, yaw)
    }

    /// From a heading clockwise from north, pitch and roll (rad).
    pub fn from_heading_pitch_roll(heading: f64, pitch: f64, roll: f64) -> Quat {
        Quat::from_euler(pitch, roll, -heading)
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
        let f = q.rotate([0.0, 1.0, 0.0]);
        assert!((f[0] - 1.0).abs() < 1e-15 && f[1].abs() < 1e-15);
        // Pitch up 10°: forward axis has an up component sin 10°.
        let q = Quat::from_heading_pitch_roll(0.0, 10f64.to_radians(), 0.0);
        let f = q.rotate([0.0, 1.0, 0.0]);
        assert!((f[2] - 10f64.to_radians().sin()).abs() < 1e-15);
        // Roll right-wing-down 10° (positive roll about forward axis): the right axis
        // dips below the horizon.
        let q = Quat::from_heading_pitch_roll(0.0, 0.0, 10f64.to_radians());
        let r = q.rotate([1.0, 0.0, 0.0]);
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
            let v = [0.3, -1.2, 2.0];
            let a = q.rotate(v);
            let b = mat_vec(&q.to_dcm(), v);
            for i in 0..3 { prop_assert!((a[i] - b[i]).abs() < 1e-12); }
        }

        #[test]
        fn rotvec_round_trip(x in -3.0f64..3.0, y in -3.0f64..3.0, z in -3.0f64..3.0, s in 1e-9f64..1.0) {
            let phi = scale([x, y, z], s / 3.0);
            let back = Quat::from_rotvec(phi).to_rotvec();
            for i in 0..3 { prop_assert!((phi[i] - back[i]).abs() < 1e-12); }
        }
    }
}
