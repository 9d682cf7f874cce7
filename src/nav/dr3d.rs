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
//!
//! **Pitch over a baseline.** The paper takes sin θ = Δh / S per sampling
//! period, with an error-free altimeter. With a real one that fails: a 10 Hz
//! barometer with 0.5 m of white noise gives Δh errors of 0.7 m against
//! S = 1 m at 36 km/h, θ is mostly noise, and cos θ shortens every step (by
//! 30 % in all, measured: 318 m behind after a 1,050 m drive with perfect
//! wheels). So θ is taken over a baseline of travelled distance W instead,
//! sin θ = (h_now − h_then) / (s_now − s_then), with W set from the
//! altimeter's noise (see [`Dr3d::with_pitch_baseline`]); W = 0 is the
//! paper's per-step rule.

use crate::geodesy::radii;
use std::collections::VecDeque;

/// The 3-D dead reckoner.
#[derive(Debug, Clone, PartialEq)]
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
    /// Last roll given (rad).
    pub roll: f64,
    /// Track width assumed (m).
    pub track_width_m: f64,
    /// Travelled distance the pitch is taken over (m; 0: each step's own).
    pitch_baseline_m: f64,
    /// Distance travelled so far (m, signed: reversing counts back).
    travelled_m: f64,
    /// Path length so far (m, |S| summed): what the baseline is measured in.
    path_m: f64,
    /// (path length, travelled distance, height) at points along the last
    /// baseline, oldest first, about `pitch_baseline_m / 50` apart.
    history: VecDeque<(f64, f64, f64)>,
}

/// How many points a baseline's history holds at most (about): enough that
/// the pitch's baseline is within 2 % of the one asked for.
const HISTORY_POINTS: f64 = 50.0;

impl Dr3d {
    /// Starts at a position and heading with an assumed track width.
    pub fn new(lat: f64, lon: f64, h: f64, heading: f64, track_width_m: f64) -> Self {
        Self {
            lat,
            lon,
            h,
            heading,
            pitch: 0.0,
            roll: 0.0,
            track_width_m,
            pitch_baseline_m: 0.0,
            travelled_m: 0.0,
            path_m: 0.0,
            history: VecDeque::new(),
        }
    }

    /// Takes the pitch over the last `baseline_m` of travel (m, finite and
    /// ≥ 0; 0 is the paper's per-step rule). Until that much has been
    /// travelled the pitch comes from all the travel so far, once it is at
    /// least a fifth of the baseline, and stays at its last value before.
    ///
    /// With white altimeter noise σ (m) the pitch error over a baseline W is
    /// about √2 σ / W, and the horizontal distance is shortened on average
    /// by its square over 2, σ² / W²; [`Dr3d::baseline_for_noise`] gives the
    /// W that makes that 4 × 10⁻⁴.
    pub fn with_pitch_baseline(mut self, baseline_m: f64) -> Self {
        self.pitch_baseline_m = if baseline_m.is_finite() {
            baseline_m.max(0.0)
        } else {
            0.0
        };
        self
    }

    /// The pitch baseline (m) for an altimeter with white noise `noise_m`
    /// (1σ per sample): 50 σ, so that the horizontal distance is shortened
    /// by σ² / W² = 4 × 10⁻⁴ on average, five times less than the paper's
    /// 0.2 % odometer scale-factor error; at most 200 m, so that the pitch
    /// still follows a road's grade changes (the horizontal error of a lag of
    /// W over a change of grade Δθ is about W θ Δθ: 0.1 m for 25 m over 5°).
    pub fn baseline_for_noise(noise_m: f64) -> f64 {
        (50.0 * noise_m).clamp(0.0, 200.0)
    }

    /// One step from wheel distances (m), the altimeter's height change (m)
    /// and the level sensor's roll (rad).
    #[inline]
    pub fn step(&mut self, s_left: f64, s_right: f64, dh: f64, roll: f64) {
        let s = 0.5 * (s_left + s_right);
        if self.pitch_baseline_m == 0.0 {
            if s.abs() > 1e-6 {
                self.pitch = (dh / s).clamp(-1.0, 1.0).asin();
            }
        } else {
            self.pitch_over_baseline(s, dh);
        }
        self.roll = roll;
        let (lat, lon, dpsi) = self.moved(s_left, s_right);
        (self.lat, self.lon) = (lat, lon);
        self.heading -= dpsi;
        self.h += dh;
    }

    /// The latitude and longitude after wheel distances `s_left`,
    /// `s_right` (m) at the current pitch and roll, laid along the heading
    /// at mid-travel, and the heading's change (rad, anticlockwise).
    #[inline]
    fn moved(&self, s_left: f64, s_right: f64) -> (f64, f64, f64) {
        let s = 0.5 * (s_left + s_right);
        let cp = self.pitch.cos();
        let dpsi = (s_right - s_left) / (self.track_width_m * self.roll.cos() * cp);
        // Heading is clockwise; a larger right-wheel distance turns left.
        let mid = self.heading - 0.5 * dpsi;
        let horiz = s * cp;
        let (sh, ch) = mid.sin_cos();
        let (rm, rn) = radii(self.lat);
        let lat = self.lat + horiz * ch / (rm + self.h);
        (
            lat,
            self.lon + horiz * sh / ((rn + self.h) * lat.cos()),
            dpsi,
        )
    }

    /// Where the wheel distances `s_left`, `s_right` (m) travelled since the
    /// last step have taken the vehicle (latitude, longitude in rad, height
    /// in m), before the altimeter's next reading makes them a step: laid
    /// along the last pitch and roll and the heading at mid-travel, the
    /// height moved by S sin θ; the state is left as it is. Between the
    /// altimeter's readings (the steps) the reckoned position would
    /// otherwise stand still while the vehicle moves on: up to one altimeter
    /// period of travel behind (1.4 m at 50 km/h and 10 Hz).
    #[inline]
    pub fn position_ahead(&self, s_left: f64, s_right: f64) -> (f64, f64, f64) {
        if s_left == 0.0 && s_right == 0.0 {
            return (self.lat, self.lon, self.h);
        }
        let (lat, lon, _) = self.moved(s_left, s_right);
        (
            lat,
            lon,
            self.h + 0.5 * (s_left + s_right) * self.pitch.sin(),
        )
    }

    /// The pitch over the last `pitch_baseline_m` of travel, the step
    /// (`s`, `dh`) included.
    fn pitch_over_baseline(&mut self, s: f64, dh: f64) {
        let w = self.pitch_baseline_m;
        if self.history.is_empty() {
            self.history.push_back((0.0, 0.0, self.h));
        }
        self.path_m += s.abs();
        self.travelled_m += s;
        let h_now = self.h + dh;
        // The oldest point kept is the last one at least W back.
        while self.history.len() > 1 && self.path_m - self.history[1].0 >= w {
            self.history.pop_front();
        }
        let (path0, travelled0, h0) = self.history[0];
        let run = self.travelled_m - travelled0;
        if self.path_m - path0 >= 0.2 * w && run.abs() >= 0.2 * w {
            self.pitch = ((h_now - h0) / run).clamp(-1.0, 1.0).asin();
        }
        let last = self.history.back().map_or(f64::NEG_INFINITY, |p| p.0);
        if self.path_m - last >= w / HISTORY_POINTS {
            self.history
                .push_back((self.path_m, self.travelled_m, h_now));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A standard normal draw (Box–Muller; the sensors' own generator is a
    /// layer above this one).
    fn normal(rng: &mut ChaCha8Rng) -> f64 {
        let (u, v): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// A 1,000 m straight drive north at a constant 3 % grade (pitch
    /// 1.72°), 1 m per step, the altimeter's height change with white noise
    /// σ per sample (seeded): the horizontal distance covered (m).
    fn drive(baseline_m: f64, sigma_m: f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let pitch = 0.03f64.atan();
        let (s, climb) = (1.0, pitch.sin());
        let mut dr = Dr3d::new(0.5, 0.3, 0.0, 0.0, 1.6).with_pitch_baseline(baseline_m);
        let (lat0, mut noise0) = (dr.lat, 0.0);
        for _ in 0..1000 {
            let noise = sigma_m * normal(&mut rng);
            dr.step(s, s, climb + noise - noise0, 0.0);
            noise0 = noise;
        }
        let (rm, _) = radii(0.5);
        (dr.lat - lat0) * (rm + 15.0)
    }

    #[test]
    fn the_per_step_pitch_is_exact_without_noise() {
        // Closed form: 1000 m × cos θ = 999.550 m. Tolerance 1 mm: the
        // latitude step uses the height at the step's start (0 to 30 m on
        // a 6.4e6 m radius: 5e-6 relative, 5 mm over the drive; the test
        // takes the mean height 15 m, leaving 1e-7 relative). Over a 25 m
        // baseline the first 5 m (a fifth of it) keep pitch 0: 2.25 mm more
        // at most, 5 m × (1 − cos θ).
        let want = 1000.0 * 0.03f64.atan().cos();
        for (w, tol) in [
            (0.0, 1e-3),
            (25.0, 1e-3 + 5.0 * (1.0 - 0.03f64.atan().cos())),
        ] {
            let got = drive(w, 0.0);
            assert!((got - want).abs() < tol, "W {w}: {got} m, want {want}");
        }
    }

    #[test]
    fn a_baseline_keeps_altimeter_noise_from_shortening_the_drive() {
        // σ = 0.5 m per sample: per step (the paper's rule) the pitch is
        // mostly noise and the drive comes out far short (measured 36 %);
        // over the baseline for that noise (25 m) within 0.2 % (the bias
        // σ²/W² = 0.04 %, the noise of the pitch adds as much again).
        let want = 1000.0 * 0.03f64.atan().cos();
        let per_step = drive(0.0, 0.5);
        assert!(per_step < 0.9 * want, "per step {per_step} m");
        let w = Dr3d::baseline_for_noise(0.5);
        assert_eq!(w, 25.0);
        let over = drive(w, 0.5);
        assert!(
            (over - want).abs() < 2e-3 * want,
            "over {w} m: {over} m, want {want}"
        );
    }

    #[test]
    fn between_steps_the_position_is_where_the_wheels_have_taken_it() {
        // On a circle of radius 50 m (track 1.6 m: wheel distances
        // (50 ∓ 0.8) Δψ), level, stepped every 1 m of centre travel, and
        // asked in between after 0.3 m: the closed form is the arc's
        // chord, 2 r sin(Δψ/2) along the mid heading; position_ahead lays
        // the arc length itself along it, long by S Δψ²/24 = 3e-7 m, and
        // the step's own latitude uses the height at its start (0 here).
        // Tolerance 1e-6 m. The state is unchanged, and after the whole
        // step it agrees with the step.
        let (r, k) = (50.0, 1.6);
        let mut dr = Dr3d::new(0.5, 0.3, 0.0, 0.0, k).with_pitch_baseline(25.0);
        let wheels = |s: f64| ((r + 0.5 * k) * s / r, (r - 0.5 * k) * s / r);
        for _ in 0..10 {
            let (l, rr) = wheels(1.0);
            dr.step(l, rr, 0.0, 0.0);
        }
        let before = dr.clone();
        let (l, rr) = wheels(0.3);
        let (lat, lon, h) = dr.position_ahead(l, rr);
        assert_eq!(dr, before);
        let (rm, rn) = radii(dr.lat);
        let east = (lon - dr.lon) * rn * dr.lat.cos();
        let north = (lat - dr.lat) * rm;
        // Turning right (the left wheel goes further): heading + Δψ/2.
        let dpsi = 0.3 / r;
        let chord = 2.0 * r * (0.5 * dpsi).sin();
        let mid = dr.heading + 0.5 * dpsi;
        assert!((east - chord * mid.sin()).abs() < 1e-6, "east {east}");
        assert!((north - chord * mid.cos()).abs() < 1e-6, "north {north}");
        assert_eq!(h, 0.0);
        dr.step(l, rr, 0.0, 0.0);
        assert!((dr.lat - lat).abs() < 1e-15 && (dr.lon - lon).abs() < 1e-15);
        // Nothing travelled: where the last step left it.
        assert_eq!(dr.position_ahead(0.0, 0.0), (dr.lat, dr.lon, dr.h));
    }

    #[test]
    fn between_steps_the_height_follows_the_last_pitch() {
        // A 3 % grade taken over its baseline: 2 m of travel after a step
        // climb 2 sin θ, and lie 2 cos θ north (1e-9 m).
        let theta = 0.03f64.atan();
        let mut dr = Dr3d::new(0.5, 0.3, 0.0, 0.0, 1.6).with_pitch_baseline(25.0);
        for _ in 0..100 {
            dr.step(1.0, 1.0, theta.sin(), 0.0);
        }
        assert!((dr.pitch - theta).abs() < 1e-12);
        let (lat, _, h) = dr.position_ahead(2.0, 2.0);
        let (rm, _) = radii(dr.lat);
        assert!((h - dr.h - 2.0 * theta.sin()).abs() < 1e-9);
        assert!(((lat - dr.lat) * (rm + dr.h) - 2.0 * theta.cos()).abs() < 1e-9);
    }

    #[test]
    fn the_history_stays_small() {
        // Creeping 1 mm per step over 100 m: the baseline's history holds
        // about 50 points, not one per step.
        let mut dr = Dr3d::new(0.5, 0.3, 0.0, 0.0, 1.6).with_pitch_baseline(25.0);
        for _ in 0..100_000 {
            dr.step(0.001, 0.001, 0.0, 0.0);
        }
        assert!(dr.history.len() <= 52, "{}", dr.history.len());
    }
}
