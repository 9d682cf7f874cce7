//! The navigator's map against the world (issue 12, point 2): the map the
//! navigator matches against is the world the truth drives in displaced by a
//! smooth, spatially correlated 2-D offset field, drawn per run from the seed.
//!
//! Each axis of the field is a sum of [`FEATURES`] random Fourier features
//! (Rahimi & Recht 2007): f(x) = σ √(2/M) Σ cos(ωᵢ·x + bᵢ) with
//! ωᵢ ~ N(0, I/L²) and bᵢ ~ U(0, 2π). Its covariance over draws is
//! σ² exp(−|x − y|²/2L²) (the Gaussian kernel with length scale L =
//! `geometry_error_correlation_m`), and every realisation is smooth
//! everywhere, so it is continuous across junctions: roads that meet still
//! meet on the erroneous map. Its gradient is of order σ/L (a few per cent
//! for OpenStreetMap-like values), so nearby roads move nearly together.

use crate::sensors::rng::{normal, stream};
use rand::Rng;

/// Features per axis.
pub const FEATURES: usize = 64;
/// Random stream of the map error (after the RFID and external-fix streams).
pub const MAP_ERROR_STREAM: u64 = crate::sensors::rng::ids::MAP_ERROR;

/// One realisation of the offset field (map minus world, east and north, m).
#[derive(Debug, Clone)]
pub struct MapErrorField {
    /// Per axis: (ω east, ω north, phase) of each feature.
    axes: [Vec<[f64; 3]>; 2],
    /// σ √(2/M).
    amp: f64,
}

impl MapErrorField {
    /// The field of run `run` of seed `seed`, with 1σ `sigma_m` per axis and
    /// correlation length `correlation_m`; `None` when `sigma_m` is 0.
    pub fn draw(seed: u64, run: u64, sigma_m: f64, correlation_m: f64) -> Option<Self> {
        if sigma_m <= 0.0 {
            return None;
        }
        let mut rng = stream(seed, run, MAP_ERROR_STREAM);
        let mut axis = || -> Vec<[f64; 3]> {
            (0..FEATURES)
                .map(|_| {
                    let we = normal(&mut rng) / correlation_m;
                    let wn = normal(&mut rng) / correlation_m;
                    let b = rng.random::<f64>() * std::f64::consts::TAU;
                    [we, wn, b]
                })
                .collect()
        };
        let axes = [axis(), axis()];
        Some(Self {
            axes,
            amp: sigma_m * (2.0 / FEATURES as f64).sqrt(),
        })
    }

    /// The offset (map minus world, east and north, m) at world point `p`.
    pub fn offset(&self, p: [f64; 2]) -> [f64; 2] {
        let f = |ax: &[[f64; 3]]| {
            self.amp
                * ax.iter()
                    .map(|w| (w[0] * p[0] + w[1] * p[1] + w[2]).cos())
                    .sum::<f64>()
        };
        [f(&self.axes[0]), f(&self.axes[1])]
    }

    /// World point → its place on the navigator's map.
    pub fn to_map(&self, p: [f64; 2]) -> [f64; 2] {
        let o = self.offset(p);
        [p[0] + o[0], p[1] + o[1]]
    }

    /// Navigator's-map point → the world point it stands for: the solution q
    /// of q + offset(q) = p by fixed-point iteration (a contraction, since
    /// the field's gradient is small: σ/L of a few per cent; six steps reach
    /// millimetres).
    pub fn to_world(&self, p: [f64; 2]) -> [f64; 2] {
        let mut q = p;
        for _ in 0..6 {
            let o = self.offset(q);
            q = [p[0] - o[0], p[1] - o[1]];
        }
        q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_sigma_is_a_perfect_map() {
        assert!(MapErrorField::draw(1, 0, 0.0, 200.0).is_none());
    }

    #[test]
    fn seeded_and_per_run() {
        let a = MapErrorField::draw(3, 0, 5.0, 200.0).unwrap();
        let b = MapErrorField::draw(3, 0, 5.0, 200.0).unwrap();
        let c = MapErrorField::draw(3, 1, 5.0, 200.0).unwrap();
        let p = [123.0, -456.0];
        assert_eq!(a.offset(p), b.offset(p));
        assert_ne!(a.offset(p), c.offset(p));
    }

    /// Over 2000 draws the field's variance at a point is σ² and its
    /// correlation at distance L is e^{−1/2} = 0.607, at 2L e^{−2} = 0.135.
    /// Tolerances: the sample variance of 2000 Gaussian draws has relative
    /// standard error √(2/2000) = 3.2 % (we allow 12 %, ~4σ); a sample
    /// correlation's standard error is (1 − ρ²)/√n ≤ 0.022 (we allow 0.08).
    #[test]
    fn variance_and_correlation_match_the_gaussian_kernel() {
        let (sigma, l, n) = (5.0, 200.0, 2000u64);
        let p = [1000.0, 2000.0];
        let mut s = [0.0f64; 4];
        let (mut c1, mut c2) = (0.0, 0.0);
        for run in 0..n {
            let f = MapErrorField::draw(11, run, sigma, l).unwrap();
            let a = f.offset(p);
            let b = f.offset([p[0] + l, p[1]]);
            let c = f.offset([p[0], p[1] + 2.0 * l]);
            s[0] += a[0] * a[0];
            s[1] += a[1] * a[1];
            s[2] += b[0] * b[0];
            s[3] += c[1] * c[1];
            c1 += a[0] * b[0];
            c2 += a[1] * c[1];
        }
        let nf = n as f64;
        for v in s {
            assert!((v / nf / (sigma * sigma) - 1.0).abs() < 0.12, "{}", v / nf);
        }
        let r1 = c1 / (s[0] * s[2]).sqrt();
        let r2 = c2 / (s[1] * s[3]).sqrt();
        assert!((r1 - (-0.5f64).exp()).abs() < 0.08, "ρ(L) {r1}");
        assert!((r2 - (-2.0f64).exp()).abs() < 0.08, "ρ(2L) {r2}");
    }

    /// Continuous (no jumps, e.g. at junctions): over 1 m the offset changes
    /// by at most a few centimetres (gradient ~σ/L = 0.025); and `to_world`
    /// inverts `to_map`.
    #[test]
    fn smooth_and_invertible() {
        let f = MapErrorField::draw(5, 0, 5.0, 200.0).unwrap();
        let mut worst = 0.0f64;
        for i in 0..2000 {
            let p = [i as f64 * 1.7 - 1500.0, i as f64 * 0.9 - 800.0];
            let a = f.offset(p);
            let b = f.offset([p[0] + 0.7, p[1] + 0.7]);
            worst = worst.max((a[0] - b[0]).hypot(a[1] - b[1]));
            let w = f.to_world(f.to_map(p));
            assert!((w[0] - p[0]).hypot(w[1] - p[1]) < 1e-3, "{p:?} {w:?}");
        }
        assert!(worst < 0.15, "{worst} m over 1 m");
    }
}
