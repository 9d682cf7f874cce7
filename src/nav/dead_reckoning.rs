//! Odometer dead reckoning with IMU attitude: each odometer distance increment
//! is laid along the vehicle's forward axis, taken from the strapdown attitude
//! (the mean of the forward axis at the two ends of the step), and integrated
//! geodetically. When the odometer fails, [`HandoverWindow`] gives the
//! velocity the inertial navigator carries on with.

use crate::attitude::{Quat, V3};
use crate::geodesy::radii;
use std::collections::VecDeque;

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
        self.shift(f);
        f
    }

    /// Moves the position by the ENU displacement `d` (m).
    #[inline]
    pub fn shift(&mut self, d: V3) {
        let (rm, rn) = radii(self.lat);
        self.lat += d[1] / (rm + self.h);
        self.lon += d[0] / ((rn + self.h) * self.lat.cos());
        self.h += d[2];
    }
}

/// The velocity handed to the inertial navigator when the odometer fails:
/// the odometer's displacement over the last `window_s` seconds, carried to
/// the present by the inertial velocity's change,
///
///   v̂(t) = v_ins(t) + (Δp_odo − Δp_ins) / W,
///
/// with Δp the dead-reckoned and the inertial displacements over the window
/// W. The inertial velocity error e = v_ins − v changes slowly (at
/// g × tilt + accelerometer bias), so (Δp_ins − Δp_odo)/W is e averaged
/// over the window and v̂ is off by the odometer's own error over W divided
/// by W — less than a pulse / W when quantized, σ √(dt/W) for white speed
/// noise σ per sample — plus e's change over half the window. The last
/// step's own speed (W = dt) was off by up to a pulse / dt: 1 m/s for 1 cm
/// pulses at 100 Hz.
#[derive(Debug, Clone)]
pub struct HandoverWindow {
    len: usize,
    dt: f64,
    steps: VecDeque<(V3, V3)>,
}

impl HandoverWindow {
    /// A window of `window_s` seconds of steps of `dt` seconds (at least one step).
    pub fn new(window_s: f64, dt: f64) -> Self {
        let len = ((window_s / dt).round() as usize).max(1);
        Self {
            len,
            dt,
            steps: VecDeque::with_capacity(len),
        }
    }

    /// Records one step: the dead-reckoned displacement `odo` (ENU, m) and the
    /// inertial velocities at the step's start and end (ENU, m/s).
    #[inline]
    pub fn push(&mut self, odo: V3, ins_v0: V3, ins_v1: V3) {
        if self.steps.len() == self.len {
            self.steps.pop_front();
        }
        self.steps
            .push_back((odo, (ins_v0 + ins_v1) * (0.5 * self.dt)));
    }

    /// The velocity now, given the inertial velocity now `ins_v` (the end of
    /// the last step recorded, or later: the inertial change carries it).
    /// With no step recorded, `ins_v` itself.
    pub fn velocity(&self, ins_v: V3) -> V3 {
        if self.steps.is_empty() {
            return ins_v;
        }
        let (odo, ins) = self
            .steps
            .iter()
            .fold((V3::zeros(), V3::zeros()), |(a, b), (o, i)| (a + o, b + i));
        ins_v + (odo - ins) / (self.steps.len() as f64 * self.dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive north whose speed is `v(t)`, its distance `s(t)`; the odometer
    /// counts whole pulses of `pulse` m (0: exact), the inertial velocity is
    /// the truth plus an error `e(t)`. Returns the handed-over velocity's
    /// north component minus the true speed at `t_end`.
    fn handover_error(
        v: impl Fn(f64) -> f64,
        s: impl Fn(f64) -> f64,
        e: impl Fn(f64) -> f64,
        pulse: f64,
        window_s: f64,
        t_end: f64,
    ) -> f64 {
        let dt = 0.01;
        let mut w = HandoverWindow::new(window_s, dt);
        let counted = |t: f64| {
            if pulse > 0.0 {
                (s(t) / pulse).floor() * pulse
            } else {
                s(t)
            }
        };
        let n = (t_end / dt).round() as usize;
        for k in 1..=n {
            let (t0, t1) = ((k - 1) as f64 * dt, k as f64 * dt);
            let odo = V3::new(0.0, counted(t1) - counted(t0), 0.0);
            let ins = |t: f64| V3::new(0.0, v(t) + e(t), 0.0);
            w.push(odo, ins(t0), ins(t1));
        }
        let ins_now = V3::new(0.0, v(t_end) + e(t_end), 0.0);
        w.velocity(ins_now)[1] - v(t_end)
    }

    #[test]
    fn a_constant_inertial_velocity_error_is_removed_whatever_the_acceleration() {
        // Exact odometer, speed 5 + 0.8 t (constant acceleration), inertial
        // velocity 0.7 m/s off: the window's mean difference is exactly the
        // error, so the velocity handed over is the true one; the trapezoid
        // is exact for a linear speed. Rounding only: 1e-9 m/s.
        let err = handover_error(
            |t| 5.0 + 0.8 * t,
            |t| 5.0 * t + 0.4 * t * t,
            |_| 0.7,
            0.0,
            2.0,
            30.0,
        );
        assert!(err.abs() < 1e-9, "{err}");
    }

    #[test]
    fn a_drifting_inertial_velocity_error_costs_half_a_window_of_its_drift() {
        // Inertial error e(t) = 0.02 t (a 2 mg tilt's g φ, say): the window
        // removes its mean over [t − W, t], e(t − W/2); what is left is
        // ė W/2 = 0.02 m/s for W = 2 s, exactly (linear e, trapezoid).
        let err = handover_error(|_| 10.0, |t| 10.0 * t, |t| 0.02 * t, 0.0, 2.0, 30.0);
        assert!((err - 0.02).abs() < 1e-9, "{err}");
    }

    #[test]
    fn quantized_distances_are_off_by_less_than_a_pulse_over_the_window() {
        // 3 cm pulses at speeds that do not divide a 10 ms step into whole
        // pulses: the last step's own speed would be off by up to p/dt =
        // 3 m/s; over W = 2 s the counted distance is off by less than one
        // pulse at each end, so the speed by less than p/W = 0.015 m/s.
        let p = 0.03;
        let mut worst: f64 = 0.0;
        for k in 0..50 {
            let v0 = 7.0 + 0.173 * k as f64;
            let err = handover_error(|_| v0, |t| v0 * t, |_| 0.0, p, 2.0, 20.0 + 0.37 * k as f64);
            worst = worst.max(err.abs());
        }
        assert!(worst < p / 2.0, "worst {worst} m/s");
        // And the window matters: one step's speed is off by pulses / dt.
        let one_step = handover_error(|_| 10.0, |t| 10.0 * t, |_| 0.0, p, 0.01, 20.005);
        assert!(one_step.abs() > 0.5, "{one_step}");
    }

    #[test]
    fn before_the_window_fills_it_uses_what_it_has_and_with_nothing_the_inertial_velocity() {
        let mut w = HandoverWindow::new(2.0, 0.01);
        let ins = V3::new(1.0, 2.0, 0.0);
        assert_eq!(w.velocity(ins), ins);
        // One step of 0.1 m north with the inertial navigator at 9.9 m/s
        // north: 10 m/s north handed over.
        w.push(
            V3::new(0.0, 0.1, 0.0),
            V3::new(0.0, 9.9, 0.0),
            V3::new(0.0, 9.9, 0.0),
        );
        let v = w.velocity(V3::new(0.0, 9.9, 0.0));
        assert!((v - V3::new(0.0, 10.0, 0.0)).norm() < 1e-12, "{v}");
    }
}
