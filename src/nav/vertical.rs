//! Barometric damping of the inertial vertical channel: a third-order loop
//! (all three poles at −1/τ) that pulls height, vertical velocity and an
//! accelerometer-error estimate toward the altimeter. Without it the inertial
//! vertical channel diverges exponentially (time constant √(R/2g) ≈ 570 s).

use super::strapdown::Strapdown;

/// The damping loop.
#[derive(Debug, Clone, Copy)]
pub struct BaroDamping {
    k1: f64,
    k2: f64,
    k3: f64,
    accel_correction: f64,
    reference: Option<f64>,
}

impl BaroDamping {
    /// A loop with time constant `tau_s` (s).
    pub fn new(tau_s: f64) -> Self {
        Self {
            k1: 3.0 / tau_s,
            k2: 3.0 / (tau_s * tau_s),
            k3: 1.0 / (tau_s * tau_s * tau_s),
            accel_correction: 0.0,
            reference: None,
        }
    }

    /// Records a new altimeter reading (m).
    pub fn set_reference(&mut self, h: f64) {
        self.reference = Some(h);
    }

    /// Applies one step of the loop to the navigator after its mechanization step.
    #[inline]
    pub fn apply(&mut self, nav: &mut Strapdown) {
        let dt = nav.dt;
        let Some(href) = self.reference else { return };
        let e = nav.state.h - href;
        self.accel_correction += self.k3 * e * dt;
        nav.state.h -= self.k1 * e * dt;
        nav.state.v[2] -= (self.k2 * e + self.accel_correction) * dt;
    }
}
