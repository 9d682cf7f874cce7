//! Odometer error models: a single (vehicle-centre) odometer with scale-factor
//! error, speed noise, pulse quantization, wheel-slip events and failure from a
//! time or a distance; and a differential odometer (left and right wheels a
//! track width apart) for gyro-free 3-D dead reckoning (PAPERS.md §2).

use super::rng::normal;
use crate::attitude::V3;
use crate::nav::NavState;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Wheel-slip events: at random distances (Poisson in distance), the wheel
/// over-counts by a fraction for a stretch of road.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelSlip {
    /// Mean number of events per km.
    pub rate_per_km: f64,
    /// Length of road each event lasts (m).
    pub length_m: f64,
    /// Fractional over-count during an event (0.1 = 10 % too much distance).
    pub overcount: f64,
}

/// When the odometer fails (it then gives no output).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometerFailure {
    /// From this time on (s).
    pub from_s: Option<f64>,
    /// From this distance on (m).
    pub from_m: Option<f64>,
}

/// Odometer error parameters.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometerModel {
    /// Scale-factor error (ratio; 0.00131 reads 0.131 % long).
    pub scale_factor_error: f64,
    /// White speed noise (m/s, per sample).
    pub noise_mps: f64,
    /// Distance per pulse (m); 0 disables quantization.
    pub pulse_m: f64,
    /// Wheel-slip events.
    pub slip: Option<WheelSlip>,
    /// Failure.
    pub failure: Option<OdometerFailure>,
    /// σ of a scale-factor error drawn per run on top of
    /// `scale_factor_error` (ratio): the calibration's uncertainty, so that
    /// a Monte Carlo covers it rather than one fixed value.
    pub scale_factor_sigma: f64,
    /// Mounting misalignment between the IMU and the vehicle, pitch and yaw
    /// (rad), in the filter's convention: the vehicle's forward axis (the
    /// odometer's, along which the non-holonomic constraints hold) is
    /// `[−yaw, 1, pitch]` in the IMU's axes (x right, y forward, z up). The
    /// IMU is mounted rotated by it, so a navigator that takes the IMU's
    /// forward axis for the vehicle's resolves the odometer's distance
    /// `yaw` to the right of the true track and `pitch` below it.
    pub misalignment: [f64; 2],
    /// σ per axis of a misalignment drawn per run on top of `misalignment`
    /// (rad).
    pub misalignment_sigma: f64,
    /// Steady-state σ of a scale-factor error that varies in time (ratio;
    /// tyre temperature, pressure and load), on top of the others: a
    /// first-order Gauss–Markov process started from its stationary
    /// distribution. 0: none.
    pub scale_factor_instability: f64,
    /// Correlation time of that process (s).
    pub scale_factor_tau_s: f64,
}

/// The odometer's mounting as one run draws it: the scale-factor error and
/// the IMU-to-vehicle misalignment (see [`OdometerModel`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunMounting {
    /// Scale-factor error of this run (ratio).
    pub scale_factor_error: f64,
    /// Misalignment of this run, pitch and yaw (rad).
    pub misalignment: [f64; 2],
}

impl RunMounting {
    /// The rotation taking vectors from the vehicle's axes to the IMU's
    /// (`C_v^s`): the rotation vector `(pitch, 0, yaw)`, which carries the
    /// vehicle's forward axis `[0, 1, 0]` to `[−sin yaw, cos yaw, 0]` (yaw
    /// alone) as [`OdometerModel::misalignment`] states it. `None` when
    /// there is no misalignment (nothing to rotate: runs without one are
    /// bit for bit what they were before the field existed).
    pub fn vehicle_to_imu(&self) -> Option<crate::attitude::Quat> {
        use crate::attitude::QuatExt;
        let [p, y] = self.misalignment;
        (p != 0.0 || y != 0.0).then(|| crate::attitude::Quat::from_rotvec(V3::new(p, 0.0, y)))
    }
}

impl OdometerModel {
    /// This run's scale factor and misalignment: the fixed values plus
    /// draws of their σ from `rng` (the run's own stream, so that no other
    /// draw moves; with σ zero the draws add exactly zero).
    pub fn draw_mounting(&self, rng: &mut ChaCha8Rng) -> RunMounting {
        let (z0, z1, z2) = (normal(rng), normal(rng), normal(rng));
        RunMounting {
            scale_factor_error: self.scale_factor_error + self.scale_factor_sigma * z0,
            misalignment: [
                self.misalignment[0] + self.misalignment_sigma * z1,
                self.misalignment[1] + self.misalignment_sigma * z2,
            ],
        }
    }
}

/// A simulated odometer: distance increments per IMU sample.
#[derive(Debug, Clone)]
pub struct Odometer {
    model: OdometerModel,
    rng: ChaCha8Rng,
    /// The time-varying scale factor's current value and its own stream
    /// (so that the other draws are those of an odometer without it).
    drift: Option<(f64, ChaCha8Rng)>,
    measured: f64,
    counted: f64,
    next_slip_m: f64,
    slip_until_m: f64,
}

fn exp_draw(rng: &mut ChaCha8Rng, mean: f64) -> f64 {
    let u: f64 = rng.random::<f64>();
    -mean * (1.0 - u).ln()
}

impl Odometer {
    /// An odometer with its own random streams: `rng` for the noise, slips
    /// and pulses, `drift_rng` for the time-varying scale factor
    /// ([`OdometerModel::scale_factor_instability`]; not drawn from without
    /// one).
    pub fn new(model: &OdometerModel, mut rng: ChaCha8Rng, mut drift_rng: ChaCha8Rng) -> Self {
        let next_slip_m = match model.slip {
            Some(s) if s.rate_per_km > 0.0 => exp_draw(&mut rng, 1000.0 / s.rate_per_km),
            _ => f64::INFINITY,
        };
        let drift = (model.scale_factor_instability > 0.0).then(|| {
            let x0 = model.scale_factor_instability * normal(&mut drift_rng);
            (x0, drift_rng)
        });
        Self {
            model: *model,
            rng,
            drift,
            measured: 0.0,
            counted: 0.0,
            next_slip_m,
            slip_until_m: f64::NEG_INFINITY,
        }
    }

    /// The scale-factor error now (ratio): the run's constant one plus the
    /// time-varying part's current value.
    pub fn scale_factor_error(&self) -> f64 {
        self.model.scale_factor_error + self.drift.as_ref().map_or(0.0, |d| d.0)
    }

    /// Whether the odometer has failed at time `t` (s) and distance `distance_m`.
    pub fn failed(&self, t: f64, distance_m: f64) -> bool {
        match self.model.failure {
            Some(f) => {
                f.from_s.is_some_and(|s| t >= s) || f.from_m.is_some_and(|m| distance_m >= m)
            }
            None => false,
        }
    }

    /// The measured distance increment (m) for a true increment `d_true` over
    /// `dt` (s), ending at time `t` and true path distance `distance_m`; None
    /// once the odometer has failed.
    #[inline]
    pub fn measure(&mut self, t: f64, distance_m: f64, d_true: f64, dt: f64) -> Option<f64> {
        let mut d = d_true * (1.0 + self.model.scale_factor_error);
        if let Some((x, rng)) = self.drift.as_mut() {
            // Exact discretisation over this step (the steps need not be
            // equal): x' = φ x + σ √(1 − φ²) w, φ = e^(−dt/τ).
            let phi = (-dt.max(0.0) / self.model.scale_factor_tau_s).exp();
            *x = phi * *x
                + self.model.scale_factor_instability * (1.0 - phi * phi).sqrt() * normal(rng);
            d += d_true * *x;
        }
        if let Some(s) = self.model.slip {
            if distance_m >= self.next_slip_m {
                self.slip_until_m = distance_m + s.length_m;
                self.next_slip_m = distance_m + exp_draw(&mut self.rng, 1000.0 / s.rate_per_km);
            }
            if distance_m < self.slip_until_m {
                d *= 1.0 + s.overcount;
            }
        }
        if self.model.noise_mps > 0.0 && d_true != 0.0 {
            d += self.model.noise_mps * dt * normal(&mut self.rng);
        }
        if self.failed(t, distance_m) {
            return None;
        }
        self.measured += d;
        if self.model.pulse_m > 0.0 {
            let c = (self.measured / self.model.pulse_m).floor() * self.model.pulse_m;
            let inc = c - self.counted;
            self.counted = c;
            Some(inc)
        } else {
            Some(d)
        }
    }
}

/// Differential odometer parameters.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DiffOdometerModel {
    /// True track width: distance between the two wheels (m).
    pub track_width_m: f64,
    /// Track width the navigator assumes, minus the true one (m).
    pub track_width_error_m: f64,
    /// Scale-factor error of the left wheel (ratio).
    pub scale_factor_error_left: f64,
    /// Scale-factor error of the right wheel (ratio).
    pub scale_factor_error_right: f64,
    /// White speed noise per wheel (m/s, per sample).
    pub noise_mps: f64,
    /// Distance per pulse (m); 0 disables quantization.
    pub pulse_m: f64,
}

/// True distances (m) travelled by the left and right wheels between two truth
/// states: the wheels sit at ∓track/2 on the body's right axis.
#[inline]
pub fn wheel_distances(s0: &NavState, s1: &NavState, track_width_m: f64) -> (f64, f64) {
    let d = crate::trajectory::local_displacement(s0, s1);
    let half = 0.5 * track_width_m;
    let r0 = s0.q * V3::new(half, 0.0, 0.0);
    let r1 = s1.q * V3::new(half, 0.0, 0.0);
    let dr = r1 - r0;
    let right = d + dr;
    let left = d - dr;
    let fwd = s1.q * V3::y();
    let sgn = |x: V3| {
        if x.dot(&fwd) < 0.0 {
            -x.norm()
        } else {
            x.norm()
        }
    };
    (sgn(left), sgn(right))
}

/// A simulated differential odometer.
#[derive(Debug, Clone)]
pub struct DiffOdometer {
    model: DiffOdometerModel,
    rng: ChaCha8Rng,
    measured: [f64; 2],
    counted: [f64; 2],
}

impl DiffOdometer {
    /// A differential odometer with its own random stream.
    pub fn new(model: &DiffOdometerModel, rng: ChaCha8Rng) -> Self {
        Self {
            model: *model,
            rng,
            measured: [0.0; 2],
            counted: [0.0; 2],
        }
    }

    /// The model.
    pub fn model(&self) -> &DiffOdometerModel {
        &self.model
    }

    /// Measured (left, right) distance increments for the true ones.
    #[inline]
    pub fn measure(&mut self, left: f64, right: f64, dt: f64) -> (f64, f64) {
        let sf = [
            self.model.scale_factor_error_left,
            self.model.scale_factor_error_right,
        ];
        let mut out = [0.0; 2];
        for (i, d_true) in [left, right].into_iter().enumerate() {
            let mut d = d_true * (1.0 + sf[i]);
            if self.model.noise_mps > 0.0 && d_true != 0.0 {
                d += self.model.noise_mps * dt * normal(&mut self.rng);
            }
            self.measured[i] += d;
            out[i] = if self.model.pulse_m > 0.0 {
                let c = (self.measured[i] / self.model.pulse_m).floor() * self.model.pulse_m;
                let inc = c - self.counted[i];
                self.counted[i] = c;
                inc
            } else {
                d
            };
        }
        (out[0], out[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::rng::stream;

    #[test]
    fn scale_factor_quantization_and_failure() {
        let model = OdometerModel {
            scale_factor_error: 0.01,
            pulse_m: 0.05,
            failure: Some(OdometerFailure {
                from_s: Some(50.0),
                from_m: None,
            }),
            ..Default::default()
        };
        let mut odo = Odometer::new(&model, stream(1, 0, 2), stream(1, 0, 12));
        let mut total = 0.0;
        for k in 1..=4999 {
            let t = k as f64 * 0.01;
            total += odo.measure(t, t, 0.01, 0.01).unwrap();
            // Quantized to whole pulses.
            assert!(((total / 0.05) - (total / 0.05).round()).abs() < 1e-9);
        }
        // 49.99 m true, 1 % long, counted down to a whole pulse (0.05 m).
        assert!((total - 49.99 * 1.01).abs() <= 0.05 + 1e-9, "{total}");
        assert!(odo.measure(50.0, 50.0, 0.01, 0.01).is_none());
    }

    #[test]
    fn slip_events_overcount_at_the_stated_rate() {
        // 2 events/km, 10 m each, 50 % over-count: over 100 km the excess is about
        // 200 × 5 m = 1000 m; Poisson count σ ≈ 14 events, so ±30 % is > 4σ.
        let model = OdometerModel {
            slip: Some(WheelSlip {
                rate_per_km: 2.0,
                length_m: 10.0,
                overcount: 0.5,
            }),
            ..Default::default()
        };
        let mut odo = Odometer::new(&model, stream(5, 0, 2), stream(5, 0, 12));
        let mut total = 0.0;
        let n = 1_000_000;
        for k in 1..=n {
            total += odo.measure(0.0, k as f64 * 0.1, 0.1, 0.01).unwrap();
        }
        let excess = total - n as f64 * 0.1;
        assert!((excess - 1000.0).abs() < 300.0, "excess {excess}");
    }

    #[test]
    fn a_run_draws_its_mounting_and_the_rotation_follows_the_filters_convention() {
        // No σ: the fixed values exactly (and no rotation without angles).
        let fixed = OdometerModel {
            scale_factor_error: 2e-3,
            misalignment: [0.01, -0.02],
            ..Default::default()
        };
        let m = fixed.draw_mounting(&mut stream(1, 0, crate::sensors::rng::ids::MOUNTING));
        assert_eq!(m.scale_factor_error, 2e-3);
        assert_eq!(m.misalignment, [0.01, -0.02]);
        assert_eq!(
            OdometerModel::default()
                .draw_mounting(&mut stream(1, 0, crate::sensors::rng::ids::MOUNTING))
                .vehicle_to_imu(),
            None
        );
        // The vehicle's forward axis in the IMU's axes is [−yaw, 1, pitch]
        // to first order (the filter's α_ψ, α_θ), exactly [−sin ψ cos θ..]
        // for one angle at a time.
        let (p, y) = (0.01f64, -0.02f64);
        let c = RunMounting {
            scale_factor_error: 0.0,
            misalignment: [0.0, y],
        }
        .vehicle_to_imu()
        .unwrap();
        let f = c * V3::y();
        assert!(
            (f - V3::new(-y.sin(), y.cos(), 0.0)).norm() < 1e-15,
            "{f:?}"
        );
        let c = RunMounting {
            scale_factor_error: 0.0,
            misalignment: [p, 0.0],
        }
        .vehicle_to_imu()
        .unwrap();
        let f = c * V3::y();
        assert!((f - V3::new(0.0, p.cos(), p.sin())).norm() < 1e-15, "{f:?}");
        // With σ: the draws are per run, their spread the σ (2,000 runs:
        // the sample σ within ±1.6 % at 1σ; ±8 % is 5σ).
        let drawn = OdometerModel {
            scale_factor_sigma: 1e-3,
            misalignment_sigma: 0.01,
            ..Default::default()
        };
        let n = 2000;
        let draws: Vec<RunMounting> = (0..n)
            .map(|run| drawn.draw_mounting(&mut stream(1, run, crate::sensors::rng::ids::MOUNTING)))
            .collect();
        let sd = |f: &dyn Fn(&RunMounting) -> f64, want: f64| {
            let v = draws.iter().map(|d| f(d).powi(2)).sum::<f64>() / n as f64;
            assert!(
                (v.sqrt() / want - 1.0).abs() < 0.08,
                "{} against {want}",
                v.sqrt()
            );
        };
        sd(&|d| d.scale_factor_error, 1e-3);
        sd(&|d| d.misalignment[0], 0.01);
        sd(&|d| d.misalignment[1], 0.01);
    }
}
