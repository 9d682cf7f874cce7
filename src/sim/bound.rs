//! The one definition of the horizontal 95 % bound of an east–north
//! covariance ([`bound95`]) and its relatives: the bound at any
//! probability, of two uncorrelated σ, and the closed-form largest
//! eigenvalue of a 2×2 covariance. A leaf: the covariance engine, the
//! simulator's error rows, the planner and the report all use it.

/// χ²(2 dof) 95 % quantile.
pub const CHI2_2_95: f64 = 5.991_464_547_107_979;

/// The horizontal 95 % bound (m) of an east-north covariance (m²; the upper
/// left 2×2 block of `c`): `sqrt(χ²₂(0.95) · λmax)`, the radius of the circle
/// that contains the 95 % error ellipse.
///
/// Why this definition: it is a guaranteed (conservative) bound — the
/// circle contains the whole 95 % ellipse, so the probability inside it is
/// at least 95 % whatever the ellipse's shape — and it is what the planner
/// has always used, so no plan changes. The exact radius of the circle
/// holding 95 % of the 2-D Gaussian equals this bound for a circular
/// covariance and shrinks to `1.96·sqrt(λmax)` for a one-axis covariance:
/// it lies between 0.80 times this bound and this bound.
///
/// ```
/// use waymark::sim::{bound95, CHI2_2_95};
/// // A circular covariance of σ = 2 m per axis: the radius √(5.991)·2 m.
/// let c = [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 9.0]];
/// assert!((bound95(&c) - 2.0 * CHI2_2_95.sqrt()).abs() < 1e-12);
/// // An ellipse with a correlation: the largest eigenvalue of
/// // [[5, 2], [2, 2]] is 6, whatever the vertical variance.
/// let c = [[5.0, 2.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 100.0]];
/// assert!((bound95(&c) - (CHI2_2_95 * 6.0).sqrt()).abs() < 1e-12);
/// ```
pub fn bound95(c: &[[f64; 3]; 3]) -> f64 {
    (CHI2_2_95 * lambda_max_2x2(c[0][0], c[0][1], c[1][1])).sqrt()
}

/// The largest eigenvalue of the symmetric 2×2 `[[a, b], [b, d]]`, at
/// least 0 (round-off can make a covariance's slightly negative): the
/// closed form `(a + d)/2 + √(((a − d)/2)² + b²)`.
///
/// ```
/// use waymark::sim::lambda_max_2x2;
/// assert_eq!(lambda_max_2x2(5.0, 2.0, 2.0), 6.0);
/// assert_eq!(lambda_max_2x2(-1.0, 0.0, -2.0), 0.0);
/// ```
pub fn lambda_max_2x2(a: f64, b: f64, d: f64) -> f64 {
    let tr = 0.5 * (a + d);
    let disc = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    (tr + disc).max(0.0)
}

/// The horizontal bound (m) at probability `p` of an east-north covariance
/// (the upper left 2×2 block of `c`): `σ_max · sqrt(−2 ln(1 − p))`, the
/// radius of the circle that contains the error ellipse of probability `p`
/// (χ²₂'s quantile is `−2 ln(1 − p)` in closed form). Conservative in the
/// same way as [`bound95`], which it equals at `p = 0.95`.
///
/// ```
/// use waymark::sim::{bound95, bound_at};
/// let c = [[5.0, 2.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]];
/// assert!((bound_at(&c, 0.95) - bound95(&c)).abs() < 1e-9);
/// // 99 %: σ_max · 3.035.
/// assert!((bound_at(&c, 0.99) - 6f64.sqrt() * (-2.0 * 0.01f64.ln()).sqrt()).abs() < 1e-12);
/// ```
pub fn bound_at(c: &[[f64; 3]; 3], p: f64) -> f64 {
    (-2.0 * (1.0 - p).ln() * lambda_max_2x2(c[0][0], c[0][1], c[1][1])).sqrt()
}

/// [`bound95`] of a diagonal covariance given by its two 1σ (m): an
/// uncorrelated east and north (e.g. a filter's `sigma_east_m` and
/// `sigma_north_m` as `errors.csv` gives them), or a fix's along- and
/// cross-track σ. Its largest eigenvalue is the larger variance.
///
/// ```
/// use waymark::sim::{bound95, bound95_of_sigmas};
/// let c = [[9.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
/// assert_eq!(bound95_of_sigmas([3.0, 1.0]), bound95(&c));
/// ```
pub fn bound95_of_sigmas(sigma: [f64; 2]) -> f64 {
    (CHI2_2_95 * sigma[0].max(sigma[1]).powi(2)).sqrt()
}
