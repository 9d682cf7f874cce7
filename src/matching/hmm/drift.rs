//! The drift model: a first-order Gauss–Markov offset per hypothesis, its
//! Kalman update from a road, and the emission of a fix under it.

use crate::network::geometry::norm;
use crate::network::{Network, SegmentId};

/// The drift (the slowly varying offset of a fix from the true position):
/// mean and covariance, east and north (m, m²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Drift {
    pub(super) mean: [f64; 2],
    /// Covariance: east², east·north, north².
    pub(super) cov: [f64; 3],
}

impl Drift {
    /// Zero mean, σ per axis.
    pub(super) fn prior(sigma_m: f64) -> Self {
        let v = sigma_m * sigma_m;
        Drift {
            mean: [0.0; 2],
            cov: [v, 0.0, v],
        }
    }

    /// Prediction over `ds_m` metres travelled by the first-order
    /// Gauss–Markov model b' = φ b + w, φ = exp(−ds/L), var w = σ²(1 − φ²):
    /// the covariance never exceeds the prior's and the mean relaxes to
    /// zero where nothing is observed, so no estimate can run away.
    pub(super) fn predict(&self, ds_m: f64, corr_m: f64, sigma_m: f64) -> Self {
        self.predict_by(Self::decay(ds_m, corr_m), sigma_m)
    }

    /// The factor φ of [`Self::predict`] over `ds_m` metres (one `exp` for
    /// all the estimates predicted over the same distance).
    pub(super) fn decay(ds_m: f64, corr_m: f64) -> f64 {
        (-ds_m.max(0.0) / corr_m).exp()
    }

    /// [`Self::predict`] given its factor φ ([`Self::decay`]): the same values.
    #[inline]
    pub(super) fn predict_by(&self, phi: f64, sigma_m: f64) -> Self {
        let (f2, q) = (phi * phi, sigma_m * sigma_m * (1.0 - phi * phi));
        Drift {
            mean: [phi * self.mean[0], phi * self.mean[1]],
            cov: [f2 * self.cov[0] + q, f2 * self.cov[1], f2 * self.cov[2] + q],
        }
    }

    /// Equal bit for bit (so every function of it gives the same number).
    #[inline]
    pub(super) fn same_bits(&self, o: &Drift) -> bool {
        let eq = |x: f64, y: f64| x.to_bits() == y.to_bits();
        eq(self.mean[0], o.mean[0])
            && eq(self.mean[1], o.mean[1])
            && eq(self.cov[0], o.cov[0])
            && eq(self.cov[1], o.cov[1])
            && eq(self.cov[2], o.cov[2])
    }

    /// Variance along the unit vector `u` (the form [`Self::var_along`]
    /// and [`Self::var_across`] take from a line's products).
    #[cfg(test)]
    pub(super) fn var(&self, u: [f64; 2]) -> f64 {
        u[0] * u[0] * self.cov[0] + 2.0 * u[0] * u[1] * self.cov[1] + u[1] * u[1] * self.cov[2]
    }

    /// Variance along a unit vector `u` ([`Self::var`]) from its
    /// products `q` = [`products`]`(u)`: `u₀u₀·P₀₀ + 2u₀u₁·P₀₁ + u₁u₁·P₁₁`,
    /// the same operations on the same numbers, so the same bits.
    #[inline(always)]
    pub(super) fn var_along(&self, [p, r, q]: [f64; 3]) -> f64 {
        p * self.cov[0] + r * self.cov[1] + q * self.cov[2]
    }

    /// Variance across a unit vector `u` ([`Self::var`] of its normal
    /// `n = (−u₁, u₀)`) from its products `q` = [`products`]`(u)`:
    /// `n₀n₀ = u₁u₁` and `n₁n₁ = u₀u₀` exactly, and `2n₀n₁ = −(2u₁)u₀ =
    /// −(2u₀)u₁` exactly (a product by 2 and a sign change round nothing),
    /// so the same bits. The emission needs both variances of a line at
    /// times: its products are taken once.
    #[inline(always)]
    pub(super) fn var_across(&self, [p, r, q]: [f64; 3]) -> f64 {
        q * self.cov[0] - r * self.cov[1] + p * self.cov[2]
    }

    /// Kalman update with a scalar measurement of the drift along the unit
    /// vector `n`: innovation `nu`, innovation variance `s`.
    #[inline]
    pub(super) fn update(&mut self, n: [f64; 2], nu: f64, s: f64) {
        let pn = [
            self.cov[0] * n[0] + self.cov[1] * n[1],
            self.cov[1] * n[0] + self.cov[2] * n[1],
        ];
        self.mean[0] += pn[0] * nu / s;
        self.mean[1] += pn[1] * nu / s;
        self.cov[0] = (self.cov[0] - pn[0] * pn[0] / s).max(0.0);
        self.cov[1] -= pn[0] * pn[1] / s;
        self.cov[2] = (self.cov[2] - pn[1] * pn[1] / s).max(0.0);
    }
}

/// The emission of a fix on a segment under a predicted drift: the
/// log-likelihood, and the across-road innovation (unit normal, innovation,
/// its variance) for the drift update.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Emission {
    pub(super) log_p: f64,
    pub(super) normal: [f64; 2],
    pub(super) nu: f64,
    pub(super) s: f64,
}

/// Emission of the fix `raw` on segment `seg` given the predicted drift `d`
/// and the white-noise variance `r2` (m²). The fix less the drift's mean is
/// compared with the segment: across the road the innovation has variance
/// nᵀPn + r²; beyond the segment's ends the overshoot along it is charged
/// with the drift's variance along the road, uᵀPu + r². The log-likelihood
/// keeps the −½ ln(S/r²) term, so a candidate across which the drift is
/// uncertain does not gain from that uncertainty.
#[inline]
pub(super) fn emission(line: &Line, raw: [f64; 2], d: &Drift, r2: f64) -> Emission {
    emission_with(line, raw, d, r2, f64::ln)
}

/// [`emission`], its `ln` taken by `ln` (e.g. a cache of exact
/// logarithms: [`LnCache`]); the same numbers when `ln` is `f64::ln`.
#[inline]
pub(super) fn emission_with(
    line: &Line,
    raw: [f64; 2],
    d: &Drift,
    r2: f64,
    ln: impl FnOnce(f64) -> f64,
) -> Emission {
    let (quad, normal, nu, s) = emission_parts(line, raw, d, r2);
    Emission {
        log_p: quad - 0.5 * ln(s / r2),
        normal,
        nu,
        s,
    }
}

/// [`emission`]'s log-likelihood alone, its `ln` taken by `ln` (e.g. a
/// cache of exact logarithms: [`LnCache`]); the same
/// number when `ln` is `f64::ln`.
#[inline]
pub(super) fn emission_log_p_with(
    line: &Line,
    raw: [f64; 2],
    d: &Drift,
    r2: f64,
    ln: impl FnOnce(f64) -> f64,
) -> f64 {
    let (quad, _, _, s) = emission_parts(line, raw, d, r2);
    quad - 0.5 * ln(s / r2)
}

/// [`emission`]'s across-road innovation alone (for the drift update):
/// the unit normal, the innovation and its variance S, by the same
/// operations as [`emission`], so the same bits; no logarithm.
#[inline]
pub(super) fn innovation(line: &Line, raw: [f64; 2], d: &Drift, r2: f64) -> ([f64; 2], f64, f64) {
    let (_, n, across, _, s_n) = across_parts(line, raw, d, r2);
    (n, across, s_n)
}

/// The fix less the drift's mean relative to the line's start, the unit
/// normal, the innovation across the road, the direction's products and
/// the innovation's variance S ([`emission_parts`], [`innovation`]).
#[inline(always)]
fn across_parts(
    line: &Line,
    raw: [f64; 2],
    d: &Drift,
    r2: f64,
) -> ([f64; 2], [f64; 2], f64, [f64; 3], f64) {
    let u = line.u;
    let n = [-u[1], u[0]];
    let rel = [
        raw[0] - d.mean[0] - line.a[0],
        raw[1] - d.mean[1] - line.a[1],
    ];
    let across = rel[0] * n[0] + rel[1] * n[1];
    let q = products(u);
    let s_n = d.var_across(q) + r2;
    (rel, n, across, q, s_n)
}

/// [`emission`] but its log term: the quadratic part of the
/// log-likelihood, the unit normal, the innovation and its variance S.
#[inline(always)]
fn emission_parts(line: &Line, raw: [f64; 2], d: &Drift, r2: f64) -> (f64, [f64; 2], f64, f64) {
    let u = line.u;
    let (rel, n, across, q, s_n) = across_parts(line, raw, d, r2);
    let along = rel[0] * u[0] + rel[1] * u[1];
    let over = if along < 0.0 {
        along
    } else if along > line.len {
        along - line.len
    } else {
        0.0
    };
    let quad = if over == 0.0 {
        -0.5 * across * across / s_n
    } else {
        -0.5 * (across * across / s_n + over * over / (d.var_along(q) + r2))
    };
    (quad, n, across, s_n)
}

/// The products `u₀u₀`, `(2u₀)u₁`, `u₁u₁` of a unit vector `u`
/// ([`Drift::var_along`], [`Drift::var_across`]).
#[inline(always)]
pub(super) fn products(u: [f64; 2]) -> [f64; 3] {
    [u[0] * u[0], 2.0 * u[0] * u[1], u[1] * u[1]]
}

/// [`LnCache`]'s slots (a power of 2).
const LN_SLOTS: usize = 32;

/// Natural logarithms already taken, by their argument's bits
/// (direct-mapped on the low bits): `ln(x)` is exactly `x.ln()`. Under the
/// isotropic prior (the independent model's drift, always) the emission's
/// `−½ ln(S/r²)` has the same argument for every candidate of a track up
/// to the last bits of S (each road's direction rounds it a little
/// differently), so a handful of entries answer nearly every candidate
/// where `ln` took ~60 instructions each (callgrind, FMM example). The
/// drift model's emissions repeat fewer arguments (~135 distinct of ~340
/// emissions on FMM's example), more than 8 slots held apart: 32 slots
/// take its `ln` calls from ~300 to ~270 per run of that track.
#[derive(Debug, Clone)]
pub(super) struct LnCache {
    keys: [u64; LN_SLOTS],
    vals: [f64; LN_SLOTS],
}

impl Default for LnCache {
    fn default() -> Self {
        // Every slot holds ln(1) = 0, exact (1.0 maps to slot 0; the other
        // slots' key never matches an argument that maps to them).
        Self {
            keys: [1.0f64.to_bits(); LN_SLOTS],
            vals: [0.0; LN_SLOTS],
        }
    }
}

impl LnCache {
    /// `x.ln()`, exactly.
    #[inline]
    pub(super) fn ln(&mut self, x: f64) -> f64 {
        let bits = x.to_bits();
        let slot = (bits & (LN_SLOTS as u64 - 1)) as usize;
        if self.keys[slot] == bits {
            return self.vals[slot];
        }
        let v = x.ln();
        self.keys[slot] = bits;
        self.vals[slot] = v;
        v
    }
}

/// A segment as a start point, unit direction and length (ENU, m): the form
/// the emission kernel needs (the fix split into along- and across-road
/// parts against a drift covariance), which `geo` has no algorithm for; the
/// unit direction is computed once per candidate, not per transition.
#[derive(Debug, Clone, Copy)]
pub(super) struct Line {
    pub(super) a: [f64; 2],
    pub(super) u: [f64; 2],
    pub(super) len: f64,
}

impl Line {
    pub(super) fn of(net: &Network, seg: SegmentId) -> Self {
        let sg = &net.segments[seg as usize];
        let (dx, dy) = (sg.b[0] - sg.a[0], sg.b[1] - sg.a[1]);
        let len = norm(dx, dy);
        let u = if len > 1e-9 {
            [dx / len, dy / len]
        } else {
            [1.0, 0.0]
        };
        Line::new(sg.a, u, len)
    }

    /// The line from `a` along the unit vector `u` over `len` metres.
    #[inline]
    pub(super) fn new(a: [f64; 2], u: [f64; 2], len: f64) -> Self {
        Line { a, u, len }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A road observes the drift across it only: the update pulls the mean
    /// and shrinks the variance across (north, for an east-west road) and
    /// leaves the drift along it (east) as uncertain as before.
    #[test]
    fn a_road_observes_the_drift_across_it_only() {
        let mut d = Drift::prior(20.0);
        let line = Line::new([0.0, 0.0], [1.0, 0.0], 100.0);
        // A fix 12 m north of the road, 3 m east of its start.
        let e = emission(&line, [3.0, 12.0], &d, 25.0);
        assert!((e.nu - 12.0).abs() < 1e-9 && (e.s - 425.0).abs() < 1e-9);
        d.update(e.normal, e.nu, e.s);
        // Kalman gain 400/425 on the north component.
        assert!((d.mean[1] - 12.0 * 400.0 / 425.0).abs() < 1e-9);
        assert_eq!(d.mean[0], 0.0);
        assert!((d.cov[2] - 400.0 * 25.0 / 425.0).abs() < 1e-9);
        assert_eq!(d.cov[0], 400.0);
        // With the drift removed, the same fix fits the road far better.
        let after = emission(&line, [3.0, 12.0], &d, 25.0);
        assert!(after.nu.abs() < 1.0 && after.log_p > e.log_p);
    }

    /// The Gauss–Markov prediction keeps every estimate within the prior:
    /// the mean relaxes towards zero and the variance towards σ², never
    /// beyond, however far the vehicle drives unobserved.
    #[test]
    fn prediction_stays_within_the_prior() {
        let d = Drift {
            mean: [30.0, -10.0],
            cov: [4.0, 1.0, 9.0],
        };
        let mut last = d;
        for ds in [10.0, 100.0, 1000.0, 1e6] {
            let p = d.predict(ds, 400.0, 19.4);
            assert!(p.mean[0].abs() < last.mean[0].abs());
            assert!(p.cov[0] <= 19.4 * 19.4 + 1e-9 && p.cov[2] <= 19.4 * 19.4 + 1e-9);
            assert!(p.cov[0] >= d.cov[0] && p.cov[1].abs() <= d.cov[1].abs());
            last = p;
        }
        let far = d.predict(1e6, 400.0, 19.4);
        assert!(far.mean[0].abs() < 1e-9 && (far.cov[0] - 19.4 * 19.4).abs() < 1e-6);
    }

    /// [`innovation`] is [`emission`]'s normal, innovation and variance bit
    /// for bit: seeded lines (zero-length ones among them), fixes before,
    /// along and beyond them, drifts with and without a mean, isotropic
    /// and not.
    #[test]
    fn the_innovation_alone_is_the_emissions() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
        for j in 0..20_000 {
            let (dx, dy): (f64, f64) =
                (rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
            let len = if j % 7 == 0 { 0.0 } else { dx.hypot(dy) };
            let u = if len > 1e-9 {
                [dx / len, dy / len]
            } else {
                [1.0, 0.0]
            };
            let line = Line::new(
                [rng.random_range(-1e3..1e3), rng.random_range(-1e3..1e3)],
                u,
                len,
            );
            let raw = [
                line.a[0] + rng.random_range(-80.0..80.0),
                line.a[1] + rng.random_range(-80.0..80.0),
            ];
            let v: f64 = rng.random_range(0.0..400.0);
            let w: f64 = rng.random_range(0.0..400.0);
            let d = match j % 3 {
                0 => Drift::prior(rng.random_range(1.0..30.0)),
                1 => Drift {
                    mean: [rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0)],
                    cov: [v, rng.random_range(-1.0..1.0) * (v * w).sqrt(), w],
                },
                _ => Drift {
                    mean: [rng.random_range(-20.0..20.0), 0.0],
                    cov: [v, 0.0, v],
                },
            };
            let r2 = rng.random_range(1.0..100.0);
            let e = emission(&line, raw, &d, r2);
            let (n, nu, s) = innovation(&line, raw, &d, r2);
            let bits = |x: [f64; 4]| x.map(f64::to_bits);
            assert_eq!(
                bits([n[0], n[1], nu, s]),
                bits([e.normal[0], e.normal[1], e.nu, e.s]),
                "{line:?} {raw:?} {d:?} {r2}"
            );
        }
    }

    /// The variances along and across a unit vector from its products equal
    /// [`Drift::var`] of its direction and normal bit for bit, on seeded
    /// random directions (axes and diagonals among them) and covariances
    /// (negative, zero and tiny cross terms).
    #[test]
    fn variances_from_a_lines_products_equal_the_quadratic_form() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let mut dirs: Vec<[f64; 2]> = vec![[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
        let h = std::f64::consts::FRAC_1_SQRT_2;
        dirs.extend([[h, h], [-h, h], [h, -h], [-h, -h]]);
        for _ in 0..20_000 {
            let (dx, dy): (f64, f64) = (rng.random_range(-1e3..1e3), rng.random_range(-1e3..1e3));
            let len = dx.hypot(dy);
            dirs.push([dx / len, dy / len]);
        }
        for (j, u) in dirs.iter().enumerate() {
            let q = products(*u);
            let v: f64 = rng.random_range(0.0..900.0);
            let w: f64 = rng.random_range(0.0..900.0);
            let c = match j % 4 {
                0 => 0.0,
                1 => rng.random_range(-1e-12..1e-12),
                _ => rng.random_range(-1.0..1.0) * (v * w).sqrt(),
            };
            let d = Drift {
                mean: [0.0; 2],
                cov: [v, c, w],
            };
            let n = [-u[1], u[0]];
            assert_eq!(d.var_along(q).to_bits(), d.var(*u).to_bits(), "{u:?} {d:?}");
            assert_eq!(d.var_across(q).to_bits(), d.var(n).to_bits(), "{u:?} {d:?}");
        }
    }
}
