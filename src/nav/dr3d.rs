//! Gyro-free 3-D dead reckoning (PAPERS.md §2): heading from the difference of
//! the left and right wheel distances, pitch from the altimeter's height change
//! over the distance travelled, roll from a level sensor.
//!
//! Per step with wheel distances S_L, S_R, height change Δh and roll γ:
//! S = (S_L + S_R)/2; sin θ = Δh / S; the body yaw increment is (S_R − S_L)/K,
//! which in the level plane is Δψ = (S_R − S_L)/(K cos γ cos θ) (from the Euler
//! rate equations for C_b^n = R_z(ψ) R_x(θ) R_y(γ) with θ̇ ≈ 0; this is the
//! paper's projected track width K'); the position moves by
//! S cos θ (sin H, cos H) horizontally, with the heading H clockwise from north
//! taken at mid-step, and by Δh vertically.

use crate::geodesy::radii;

/// The 3-D dead reckoner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dr3d {
    /// Latitude (rad).
    pub lat: f64,
    /// Longitude (rad).
    pub lon: f64,
    /// Height (m).
    pub h: f64,
    /// Heading clockwise from north (rad).
    pub heading: f64,
    /// Last computed pitch (rad).
    pub pitch: f64,
    /// Track width assumed (m).
    pub track_width_m: f64,
}

impl Dr3d {
    /// Starts at a position and heading with an assumed track width.
    pub fn new(lat: f64, lon: f64, h: f64, heading: f64, track_width_m: f64) -> Self {
        Self {
            lat,
            lon,
            h,
            heading,
            pitch: 0.0,
            track_width_m,
        }
    }

    /// One step from wheel distances (m), the altimeter's height change (m)
    /// and the level sensor's roll (rad).
    #[inline]
    pub fn step(&mut self, s_left: f64, s_right: f64, dh: f64, roll: f64) {
        let s = 0.5 * (s_left + s_right);
        if s.abs() > 1e-6 {
            self.pitch = (dh / s).clamp(-1.0, 1.0).asin();
        }
        let cp = self.pitch.cos();
        let dpsi = (s_right - s_left) / (self.track_width_m * roll.cos() * cp);
        // Heading is clockwise; a larger right-wheel distance turns left.
        let mid = self.heading - 0.5 * dpsi;
        self.heading -= dpsi;
        let horiz = s * cp;
        let (sh, ch) = mid.sin_cos();
        let (rm, rn) = radii(self.lat);
        self.lat += horiz * ch / (rm + self.h);
        self.lon += horiz * sh / ((rn + self.h) * self.lat.cos());
        self.h += dh;
    }
}
