//! Barometric altimeter: white noise plus a slowly drifting bias (first-order
//! Gauss–Markov around an initial bias) and a scale-factor error on height
//! changes, sampled at its own rate.

use super::rng::{normal, GaussMarkov};
use rand_chacha::ChaCha8Rng;

/// Altimeter error parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarometerModel {
    /// Output rate (Hz).
    pub rate_hz: f64,
    /// White noise (m).
    pub noise_m: f64,
    /// Bias at the start (m).
    pub initial_bias_m: f64,
    /// Drifting bias: Gauss–Markov standard deviation (m).
    pub bias_drift_m: f64,
    /// Drifting bias: correlation time (s).
    pub bias_tau_s: f64,
    /// Scale-factor error on height changes from the start (ratio).
    pub scale_factor_error: f64,
}

impl Default for BarometerModel {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            noise_m: 0.5,
            initial_bias_m: 0.0,
            bias_drift_m: 1.0,
            bias_tau_s: 1800.0,
            scale_factor_error: 0.0,
        }
    }
}

/// A simulated barometric altimeter.
#[derive(Debug, Clone)]
pub struct Barometer {
    model: BarometerModel,
    rng: ChaCha8Rng,
    drift: GaussMarkov,
    period_s: f64,
    next_t: f64,
    h0: Option<f64>,
}

impl Barometer {
    /// An altimeter with its own random stream; the drift is stepped at its rate.
    pub fn new(model: &BarometerModel, rng: ChaCha8Rng) -> Self {
        let period_s = 1.0 / model.rate_hz;
        Self {
            drift: GaussMarkov::new(model.bias_drift_m, model.bias_tau_s, period_s, None),
            model: *model,
            rng,
            period_s,
            next_t: 0.0,
            h0: None,
        }
    }

    /// The reading at time `t` (s) for true height `h` (m), when a reading is due.
    #[inline]
    pub fn measure(&mut self, t: f64, h: f64) -> Option<f64> {
        if t + 1e-9 < self.next_t {
            return None;
        }
        self.next_t += self.period_s;
        let h0 = *self.h0.get_or_insert(h);
        let drift = self.drift.step(&mut self.rng);
        let noise = if self.model.noise_m > 0.0 {
            self.model.noise_m * normal(&mut self.rng)
        } else {
            0.0
        };
        Some(
            h0 + (1.0 + self.model.scale_factor_error) * (h - h0)
                + self.model.initial_bias_m
                + drift
                + noise,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::rng::stream;

    #[test]
    fn noiseless_baro_reads_scaled_height_at_its_rate() {
        let m = BarometerModel {
            rate_hz: 10.0,
            noise_m: 0.0,
            bias_drift_m: 0.0,
            initial_bias_m: 2.0,
            scale_factor_error: 0.003,
            ..Default::default()
        };
        let mut b = Barometer::new(&m, stream(1, 0, 4));
        let mut n = 0;
        for k in 0..1000 {
            let t = k as f64 * 0.01;
            if let Some(h) = b.measure(t, 100.0 + t) {
                n += 1;
                assert!((h - (100.0 + 1.003 * t + 2.0)).abs() < 1e-9);
            }
        }
        assert_eq!(n, 100);
    }
}
