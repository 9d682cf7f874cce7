//! Seeded random streams: one independent ChaCha8 stream per (seed, run, sensor).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Stream identifiers, one per sensor, so adding a sensor never shifts another's draws.
pub mod ids {
    /// The IMU.
    pub const IMU: u64 = 1;
    /// The odometer.
    pub const ODOMETER: u64 = 2;
    /// The differential odometer.
    pub const DIFF_ODOMETER: u64 = 3;
    /// The barometric altimeter.
    pub const BARO: u64 = 4;
    /// Initial-condition errors drawn per run.
    pub const INIT: u64 = 5;
    /// The level sensor (roll) of 3-D dead reckoning.
    pub const LEVEL: u64 = 6;
}

/// SplitMix64 finaliser: a well-mixed 64-bit hash step.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator for `sensor` in Monte Carlo run `run` of seed `seed`.
pub fn stream(seed: u64, run: u64, sensor: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(mix(mix(mix(seed) ^ run) ^ sensor))
}

/// A standard normal draw.
#[inline]
pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Standard normal 3-vector.
#[inline]
pub fn normal3(rng: &mut ChaCha8Rng) -> [f64; 3] {
    [normal(rng), normal(rng), normal(rng)]
}

/// First-order Gauss–Markov process with steady-state standard deviation
/// `sigma` and correlation time `tau` (s), sampled at interval `dt`: exact
/// discretisation x_k = e^{−dt/τ} x_{k−1} + σ √(1 − e^{−2dt/τ}) w_k.
#[derive(Debug, Clone, Copy, Default)]
pub struct GaussMarkov {
    phi: f64,
    q: f64,
    /// Current value.
    pub x: f64,
}

impl GaussMarkov {
    /// A process started from a draw of its stationary distribution
    /// (pass `rng` = None to start at zero).
    pub fn new(sigma: f64, tau: f64, dt: f64, rng: Option<&mut ChaCha8Rng>) -> Self {
        if sigma <= 0.0 || tau <= 0.0 {
            return Self::default();
        }
        let phi = (-dt / tau).exp();
        let x = rng.map(|r| sigma * normal(r)).unwrap_or(0.0);
        Self {
            phi,
            q: sigma * (1.0 - phi * phi).sqrt(),
            x,
        }
    }

    /// Advances one interval.
    #[inline]
    pub fn step(&mut self, rng: &mut ChaCha8Rng) -> f64 {
        if self.q > 0.0 {
            self.x = self.phi * self.x + self.q * normal(rng);
        }
        self.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_draws_and_streams_differ() {
        let a: Vec<f64> = (0..5)
            .map(|_| 0.0)
            .scan(stream(7, 0, 1), |r, _| Some(normal(r)))
            .collect();
        let b: Vec<f64> = (0..5)
            .map(|_| 0.0)
            .scan(stream(7, 0, 1), |r, _| Some(normal(r)))
            .collect();
        let c: Vec<f64> = (0..5)
            .map(|_| 0.0)
            .scan(stream(7, 1, 1), |r, _| Some(normal(r)))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn gauss_markov_has_its_steady_state_variance() {
        // 200k samples with τ = 100 dt: about 2000 independent samples, so the
        // sample variance is within ±10 % of σ² with overwhelming probability.
        let mut r = stream(1, 0, 9);
        let mut gm = GaussMarkov::new(2.0, 1.0, 0.01, Some(&mut r));
        let n = 200_000;
        let mut s2 = 0.0;
        for _ in 0..n {
            let x = gm.step(&mut r);
            s2 += x * x;
        }
        let var = s2 / n as f64;
        assert!((var - 4.0).abs() < 0.4, "variance {var}");
    }
}
