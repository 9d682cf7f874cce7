//! The error-state Kalman filter core: the state layout, the standard SINS
//! error model (Qin, "Inertial Navigation"; PSINS `etm`) as a continuous
//! system matrix F, covariance propagation with a sparse first-order
//! transition matrix Φ = I + F T, and a generic chi-square-gated measurement
//! update for 1 to 3 rows. Everything is on `nalgebra` static matrices
//! ([`Mat`], [`StateVec`], [`Rows`]): no heap allocation per step.
//!
//! Error definitions (estimate minus truth unless said otherwise):
//! - φ (0..3): navigation-frame misalignment, C̃_b^n = (I − [φ×]) C_b^n;
//! - δv (3..6): ENU velocity error (m/s);
//! - δp (6..9): δL, δλ (rad), δh (m);
//! - ε (9..12): gyro bias, body axes (rad/s); ∇ (12..15): accelerometer bias (m/s²);
//! - δK (15): odometer scale-factor error (the odometer reads (1 + δK) v);
//! - α_θ, α_ψ (16, 17): odometer mounting pitch and yaw misalignment (rad; the
//!   odometer's forward axis in body axes is [−α_ψ, 1, α_θ]);
//! - N_E, N_N (18, 19): random-walk error of an external position fix (m);
//! - b_h (20): barometer bias (m).

use crate::attitude::{M3, V3};
use crate::geodesy::EarthState;
use nalgebra::{Cholesky, SMatrix, SVector};

/// Number of error states.
pub const N: usize = 21;
/// Index of φ.
pub const PHI: usize = 0;
/// Index of δv.
pub const DV: usize = 3;
/// Index of δp (δL, δλ, δh).
pub const DP: usize = 6;
/// Index of the gyro biases.
pub const EPS: usize = 9;
/// Index of the accelerometer biases.
pub const NABLA: usize = 12;
/// Index of the odometer scale-factor error.
pub const KOD: usize = 15;
/// Index of the odometer pitch misalignment.
pub const ATHETA: usize = 16;
/// Index of the odometer yaw misalignment.
pub const APSI: usize = 17;
/// Index of the external fix's random-walk error (east, north).
pub const RW: usize = 18;
/// Index of the barometer bias.
pub const BARO: usize = 20;

/// A square state matrix (covariance, system matrix).
pub type Mat = SMatrix<f64, N, N>;
/// An error-state vector.
pub type StateVec = SVector<f64, N>;
/// The M rows of a measurement matrix H.
pub type Rows<const M: usize> = SMatrix<f64, M, N>;

/// Chi-square 99.9 % quantiles for 1, 2 and 3 degrees of freedom: the gate.
pub const GATE_999: [f64; 3] = [10.828, 13.816, 16.266];

/// The result of a measurement update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateOutcome {
    /// Whether the update was applied (it passed the gate).
    pub accepted: bool,
    /// Normalised innovation squared ν^T S^{-1} ν.
    pub nis: f64,
    /// Degrees of freedom (rows of the measurement).
    pub dof: usize,
}

impl UpdateOutcome {
    /// Not attempted (e.g. the aiding is off or the sensor is disabled).
    pub const SKIPPED: UpdateOutcome = UpdateOutcome {
        accepted: false,
        nis: f64::NAN,
        dof: 0,
    };
}

/// The continuous-time error model at one epoch: the inputs F needs.
#[derive(Debug, Clone, Copy)]
pub struct ErrorModelInput {
    /// Earth state (radii, rates, gravity) at the epoch.
    pub eth: EarthState,
    /// ENU velocity (m/s).
    pub v: V3,
    /// Specific force in n (m/s²), mean over the interval.
    pub f_n: V3,
    /// C_b^n, mean over the interval.
    pub c_bn: M3,
}

/// Correlation times and driving noises of the error states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// Gyro white noise (angle random walk) density (rad/√s).
    pub gyro_arw: f64,
    /// Accelerometer white noise density (m/s/√s).
    pub accel_vrw: f64,
    /// Gyro bias steady-state σ (rad/s) and correlation time (s).
    pub gyro_bias: (f64, f64),
    /// Accelerometer bias steady-state σ (m/s²) and correlation time (s).
    pub accel_bias: (f64, f64),
    /// Odometer scale factor σ and correlation time (s).
    pub odo_scale: (f64, f64),
    /// Odometer misalignment σ (rad) and correlation time (s).
    pub odo_misalign: (f64, f64),
    /// Random-walk density of the external fix error (m/√s).
    pub fix_rw: f64,
    /// Barometer bias σ (m) and correlation time (s).
    pub baro_bias: (f64, f64),
}

/// The continuous system matrix F of the standard SINS error model with the
/// Gauss–Markov and random-walk states, dense (for tests and for clarity);
/// the filter uses [`system_sparse`], which yields the same entries.
pub fn system_matrix(m: &ErrorModelInput, noise: &NoiseModel) -> Mat {
    let mut f = Mat::zeros();
    system_sparse(m, noise, |i, j, x| f[(i, j)] += x);
    f
}

/// Calls `put(i, j, F_ij)` for every structurally non-zero entry of F.
#[inline]
pub fn system_sparse(
    m: &ErrorModelInput,
    noise: &NoiseModel,
    mut put: impl FnMut(usize, usize, f64),
) {
    let e = &m.eth;
    let (ve, vn) = (m.v[0], m.v[1]);
    let rm = e.rm_h;
    let rn = e.rn_h;
    let (sl, cl, tl) = (e.sin_lat, e.cos_lat, e.tan_lat);
    let secl = 1.0 / cl;
    let wie = crate::geodesy::EARTH_RATE;
    // Building blocks (PSINS etm / Qin).
    // (Matrix3::new takes its entries row by row.)
    let maa = (-V3::from(e.w_in)).cross_matrix();
    #[rustfmt::skip]
    let mav = M3::new(
        0.0, -1.0 / rm, 0.0,
        1.0 / rn, 0.0, 0.0,
        tl / rn, 0.0, 0.0,
    );
    #[rustfmt::skip]
    let mp1 = M3::new(
        0.0, 0.0, 0.0,
        -wie * sl, 0.0, 0.0,
        wie * cl, 0.0, 0.0,
    );
    #[rustfmt::skip]
    let mp2 = M3::new(
        0.0, 0.0, vn / (rm * rm),
        0.0, 0.0, -ve / (rn * rn),
        ve * secl * secl / rn, 0.0, -ve * tl / (rn * rn),
    );
    let vx = m.v.cross_matrix();
    let wien = V3::from(e.w_ie) * 2.0 + V3::from(e.w_en);
    let mvv_a = vx * mav;
    let wx = wien.cross_matrix();
    let mvp = vx * (mp2 + mp1 * 2.0);
    let mva = m.f_n.cross_matrix();
    #[rustfmt::skip]
    let mpv = M3::new(
        0.0, 1.0 / rm, 0.0,
        secl / rn, 0.0, 0.0,
        0.0, 0.0, 1.0,
    );
    #[rustfmt::skip]
    let mpp = M3::new(
        0.0, 0.0, -vn / (rm * rm),
        ve * secl * tl / rn, 0.0, -ve * secl / (rn * rn),
        0.0, 0.0, 0.0,
    );
    // Gravity: g_U = −γ(L, h); ∂(−γ)/∂h (≈ +2γ/R) and ∂(−γ)/∂L by central
    // differences of the normal gravity formula.
    let lat = sl.atan2(cl);
    let h = rm - crate::geodesy::meridian_radius(lat);
    let g_grad = -(crate::geodesy::normal_gravity(lat, h + 1.0)
        - crate::geodesy::normal_gravity(lat, h - 1.0))
        / 2.0;
    let g_lat = -(crate::geodesy::normal_gravity(lat + 1e-5, h)
        - crate::geodesy::normal_gravity(lat - 1e-5, h))
        / 2e-5;
    for i in 0..3 {
        for j in 0..3 {
            let nz = |x: f64| x != 0.0;
            let a = maa[(i, j)];
            if nz(a) {
                put(PHI + i, PHI + j, a);
            }
            let a = mav[(i, j)];
            if nz(a) {
                put(PHI + i, DV + j, a);
            }
            let a = mp1[(i, j)] + mp2[(i, j)];
            if nz(a) {
                put(PHI + i, DP + j, a);
            }
            put(PHI + i, EPS + j, -m.c_bn[(i, j)]);
            let a = mva[(i, j)];
            if nz(a) {
                put(DV + i, PHI + j, a);
            }
            let a = mvv_a[(i, j)] - wx[(i, j)];
            if nz(a) {
                put(DV + i, DV + j, a);
            }
            let a = mvp[(i, j)]
                + match (i, j) {
                    (2, 2) => g_grad,
                    (2, 0) => g_lat,
                    _ => 0.0,
                };
            if nz(a) {
                put(DV + i, DP + j, a);
            }
            put(DV + i, NABLA + j, m.c_bn[(i, j)]);
            let a = mpv[(i, j)];
            if nz(a) {
                put(DP + i, DV + j, a);
            }
            let a = mpp[(i, j)];
            if nz(a) {
                put(DP + i, DP + j, a);
            }
        }
    }
    for k in 0..3 {
        put(EPS + k, EPS + k, -1.0 / noise.gyro_bias.1);
        put(NABLA + k, NABLA + k, -1.0 / noise.accel_bias.1);
    }
    put(KOD, KOD, -1.0 / noise.odo_scale.1);
    put(ATHETA, ATHETA, -1.0 / noise.odo_misalign.1);
    put(APSI, APSI, -1.0 / noise.odo_misalign.1);
    put(BARO, BARO, -1.0 / noise.baro_bias.1);
}

/// Diagonal of the continuous process noise spectral density (per second).
pub fn process_noise_diag(noise: &NoiseModel) -> StateVec {
    let mut q = StateVec::zeros();
    let gm = |(s, tau): (f64, f64)| 2.0 * s * s / tau;
    for k in 0..3 {
        // C_b^n q I C_n^b = q I: isotropic white noise keeps its form in n.
        q[PHI + k] = noise.gyro_arw * noise.gyro_arw;
        q[DV + k] = noise.accel_vrw * noise.accel_vrw;
        q[EPS + k] = gm(noise.gyro_bias);
        q[NABLA + k] = gm(noise.accel_bias);
    }
    q[KOD] = gm(noise.odo_scale);
    q[ATHETA] = gm(noise.odo_misalign);
    q[APSI] = gm(noise.odo_misalign);
    q[RW] = noise.fix_rw * noise.fix_rw;
    q[RW + 1] = noise.fix_rw * noise.fix_rw;
    q[BARO] = gm(noise.baro_bias);
    q
}

/// Most entries of one row of F: 12 (the φ and δv rows; δp rows have 6,
/// the others 1).
const ROW_MAX: usize = 16;

/// The entries of A = F T grouped by row (in their order within a row).
struct ByRow<'a> {
    a: &'a [(u8, u8, f64)],
    count: [u8; N],
    by_row: [[u8; ROW_MAX]; N],
}

impl ByRow<'_> {
    /// `out` = X Φ^T = X + X A^T (X column-major, `x` its columns): column i
    /// is column i of X plus f × column k of X over the entries (i, k, f)
    /// of row i of A, in their order, accumulated in a local column.
    #[inline(always)]
    fn times_phi_t(&self, x: &[[f64; N]; N], out: &mut [[f64; N]; N]) {
        for (i, o) in out.iter_mut().enumerate() {
            let es = &self.by_row[i][..self.count[i] as usize];
            let Some((&e0, rest)) = es.split_first() else {
                *o = x[i];
                continue;
            };
            let (_, k, f) = self.a[e0 as usize];
            let (xi, xk) = (&x[i], &x[k as usize]);
            let mut col = [0.0; N];
            for r in 0..N {
                col[r] = xi[r] + f * xk[r];
            }
            for &e in rest {
                let (_, k, f) = self.a[e as usize];
                let xk = &x[k as usize];
                for r in 0..N {
                    col[r] += f * xk[r];
                }
            }
            *o = col;
        }
    }
}

/// The covariance of the error state.
#[derive(Debug, Clone)]
pub struct Covariance {
    /// P.
    pub p: Mat,
    nz: [(u8, u8, f64); 160],
    q: StateVec,
    noise: NoiseModel,
    /// When tracked, the composed map of the ops since it was started
    /// ([`super::riccati::Element`]; the planner's stretch maps).
    pub element: Option<Box<super::riccati::Element<N>>>,
}

impl Covariance {
    /// Starts from the diagonal standard deviations `sigma0`.
    pub fn new(sigma0: &[f64; N], noise: NoiseModel) -> Self {
        let s = StateVec::from(*sigma0);
        Self {
            p: Mat::from_diagonal(&s.component_mul(&s)),
            nz: [(0, 0, 0.0); 160],
            q: process_noise_diag(&noise),
            noise,
            element: None,
        }
    }

    /// The noise model.
    pub fn noise(&self) -> &NoiseModel {
        &self.noise
    }

    /// P ← Φ P Φ^T + Q T with Φ = I + F T (F from `m`), T the interval (s).
    ///
    /// Φ is sparse (about 80 off-identity entries of 441), so Φ P Φ^T is
    /// formed from its entries rather than as two dense 21×21 products. With
    /// A = F T, D = P Φ^T = P + P A^T: column i of D is column i of P plus
    /// x × column k of P for every entry (i, k, x) of A. Φ P Φ^T = Φ D is
    /// symmetric, so it equals E Φ^T = E + E A^T with E = D^T, formed the
    /// same way; then Q T is added and the result symmetrized. The entries
    /// are grouped by row of A (keeping their order within a row), so each
    /// column is built once in a fixed-size array, from its start to its end,
    /// with no matrix copies: every sum keeps its terms and their order, so
    /// the result is bit for bit that of the column-by-column form with
    /// nalgebra's `axpy` it replaces (a test keeps that form and checks it),
    /// in about a third of the instructions.
    #[allow(clippy::needless_range_loop)] // (i, j) indices of a matrix
    pub fn propagate(&mut self, m: &ErrorModelInput, t: f64) {
        let mut n = 0usize;
        let nz = &mut self.nz;
        system_sparse(m, &self.noise, |i, j, x| {
            nz[n] = (i as u8, j as u8, x * t);
            n += 1;
        });
        let a = &self.nz[..n];
        // The entries by row, in their order (indices into `a`).
        let mut count = [0u8; N];
        let mut by_row = [[0u8; ROW_MAX]; N];
        for (e, &(i, _, _)) in a.iter().enumerate() {
            let c = &mut count[i as usize];
            by_row[i as usize][*c as usize] = e as u8;
            *c += 1;
        }
        let rows = ByRow { a, count, by_row };
        // D = P Φ^T.
        let mut d = self.p.data.0;
        rows.times_phi_t(&self.p.data.0, &mut d);
        // E = D^T.
        let mut e = d;
        for (i, col) in d.iter().enumerate() {
            for (j, &v) in col.iter().enumerate() {
                e[j][i] = v;
            }
        }
        // C = E Φ^T, in P; then P = C + Q T, symmetrized.
        let c = &mut self.p.data.0;
        rows.times_phi_t(&e, c);
        for i in 0..N {
            c[i][i] += self.q[i] * t;
        }
        for j in 0..N {
            for i in 0..j {
                let s = 0.5 * (c[j][i] + c[i][j]);
                c[j][i] = s;
                c[i][j] = s;
            }
        }
        if let Some(el) = self.element.as_mut() {
            el.propagate(&self.nz[..n], &self.q, t);
        }
    }

    /// P H^T (skipping H's zero entries) and the innovation covariance
    /// S = H P H^T + R for an M-row measurement.
    fn innovation<const M: usize>(
        &self,
        h: &Rows<M>,
        r: &SMatrix<f64, M, M>,
    ) -> (SMatrix<f64, N, M>, SMatrix<f64, M, M>) {
        // Column m of P H^T = Σ_k H[m, k] × column k of P (P symmetric).
        let mut pht = SMatrix::<f64, N, M>::zeros();
        for m in 0..M {
            for k in 0..N {
                let hk = h[(m, k)];
                if hk != 0.0 {
                    pht.column_mut(m).axpy(hk, &self.p.column(k), 1.0);
                }
            }
        }
        let s = r + h * pht;
        (pht, s)
    }

    /// Normalised innovation squared of a measurement without updating.
    pub fn nis<const M: usize>(
        &self,
        z: &SVector<f64, M>,
        h: &Rows<M>,
        r: &SMatrix<f64, M, M>,
    ) -> f64 {
        let (_, s) = self.innovation(h, r);
        match Cholesky::new(s) {
            Some(c) => quad(&c.inverse(), z),
            None => f64::INFINITY,
        }
    }

    /// Gated update with innovation `z` (measurement predicted from the
    /// estimate minus the measurement), rows `h`, noise `r` and gate threshold
    /// `gate` on ν^T S^{-1} ν. Returns the outcome and the error-state estimate
    /// (zero when rejected).
    pub fn update<const M: usize>(
        &mut self,
        z: &SVector<f64, M>,
        h: &Rows<M>,
        r: &SMatrix<f64, M, M>,
        gate: f64,
    ) -> (UpdateOutcome, StateVec) {
        let (pht, s) = self.innovation(h, r);
        // S^{-1} by Cholesky; None if S is not positive definite.
        let Some(si) = Cholesky::new(s).map(|c| c.inverse()) else {
            return (
                UpdateOutcome {
                    accepted: false,
                    nis: f64::INFINITY,
                    dof: M,
                },
                StateVec::zeros(),
            );
        };
        let nis = quad(&si, z);
        if nis.is_nan() || nis > gate {
            return (
                UpdateOutcome {
                    accepted: false,
                    nis,
                    dof: M,
                },
                StateVec::zeros(),
            );
        }
        // K = P H^T S^{-1}
        let k = pht * si;
        let dx = k * z;
        // P ← P − K (P H^T)^T: symmetric, so on the lower triangle (one
        // rank-1 update per row of H: P_ij −= (P H^T)_ja K_ia for i ≥ j,
        // the operations of nalgebra's `syger(-1, K_a, (P H^T)_a, 1)` in
        // its order, on fixed-size columns) and mirrored.
        let p = &mut self.p.data.0;
        for a in 0..M {
            let ka: [f64; N] = k.column(a).into();
            let ya: [f64; N] = pht.column(a).into();
            for (j, col) in p.iter_mut().enumerate() {
                let y = ya[j];
                for i in j..N {
                    col[i] -= y * ka[i];
                }
            }
        }
        self.p.fill_upper_triangle_with_lower_triangle();
        for (i, col) in self.p.data.0.iter_mut().enumerate() {
            if col[i] < 1e-30 {
                col[i] = 1e-30;
            }
        }
        if let Some(el) = self.element.as_mut() {
            el.update(h, r);
        }
        (
            UpdateOutcome {
                accepted: true,
                nis,
                dof: M,
            },
            dx,
        )
    }
}

/// x^T A x.
fn quad<const M: usize>(a: &SMatrix<f64, M, M>, x: &SVector<f64, M>) -> f64 {
    x.dot(&(a * x))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise() -> NoiseModel {
        NoiseModel {
            gyro_arw: 0.3f64.to_radians() / 60.0,
            accel_vrw: 100e-6 * 9.8,
            gyro_bias: (10f64.to_radians() / 3600.0, 3600.0),
            accel_bias: (1e-3 * 9.8, 3600.0),
            odo_scale: (1e-3, 3600.0),
            odo_misalign: (1e-3, 3600.0),
            fix_rw: 0.01,
            baro_bias: (1.0, 600.0),
        }
    }

    /// A moving vehicle at 60° N, turning, with a tilted body.
    fn input() -> ErrorModelInput {
        let lat = 60f64.to_radians();
        ErrorModelInput {
            eth: EarthState::new(lat, 30.0, [8.0, 11.0, 0.3]),
            v: V3::new(8.0, 11.0, 0.3),
            f_n: V3::new(0.4, -0.7, 9.82),
            c_bn: *nalgebra::Rotation3::from_euler_angles(0.05, -0.02, 0.9).matrix(),
        }
    }

    /// A covariance with every entry non-zero: 30 steps of the filter's own
    /// propagation from the diagonal start, with a position fix and a
    /// measurement of every state between (which couples them all).
    fn filled() -> Covariance {
        let mut sigma = [0.0; N];
        for (i, s) in sigma.iter_mut().enumerate() {
            *s = 0.01 * (1.0 + i as f64);
        }
        let mut c = Covariance::new(&sigma, noise());
        let mut h = Rows::<2>::zeros();
        h[(0, DP)] = 6.4e6;
        h[(1, DP + 1)] = 3.2e6;
        for k in 0..30 {
            c.propagate(&input(), 0.1);
            if k % 7 == 3 {
                let r = SMatrix::<f64, 2, 2>::identity() * 0.25;
                c.update(&SVector::<f64, 2>::new(0.1, -0.1), &h, &r, f64::INFINITY);
                let all = Rows::<1>::from_fn(|_, j| 0.5 + 0.1 * ((j * 3) % 5) as f64);
                let r1 = SMatrix::<f64, 1, 1>::new(1.0);
                c.update(&SVector::<f64, 1>::new(0.2), &all, &r1, f64::INFINITY);
            }
        }
        c
    }

    /// The column-by-column form with nalgebra's `axpy` that `propagate`
    /// replaced (kept here as the reference of its bits).
    fn propagate_axpy(p: &Mat, q: &StateVec, m: &ErrorModelInput, nm: &NoiseModel, t: f64) -> Mat {
        let mut a = Vec::new();
        system_sparse(m, nm, |i, j, x| a.push((i, j, x * t)));
        let mut d = *p;
        for &(i, k, x) in &a {
            d.column_mut(i).axpy(x, &p.column(k), 1.0);
        }
        let e = d.transpose();
        let mut c = e;
        for &(i, k, x) in &a {
            c.column_mut(i).axpy(x, &e.column(k), 1.0);
        }
        for i in 0..N {
            c[(i, i)] += q[i] * t;
        }
        for j in 0..N {
            for i in 0..j {
                let s = 0.5 * (c[(i, j)] + c[(j, i)]);
                c[(i, j)] = s;
                c[(j, i)] = s;
            }
        }
        c
    }

    /// The gated update's covariance is bit for bit that of nalgebra's
    /// `syger` form it replaced, and equals the Joseph-free textbook
    /// P − K H P to round-off (relative 1e-12 of its largest entry).
    #[test]
    fn update_is_the_rank_one_form() {
        let mut c = filled();
        let p0 = c.p;
        let mut h = Rows::<3>::zeros();
        h[(0, DP + 1)] = 3.2e6;
        h[(1, DP)] = 6.4e6;
        h[(2, DP + 2)] = 1.0;
        h[(2, BARO)] = 1.0;
        let r = SMatrix::<f64, 3, 3>::from_diagonal(&nalgebra::Vector3::new(0.3, 0.2, 1.0));
        let z = SVector::<f64, 3>::new(0.5, -0.2, 1.0);
        let (o, _) = c.update(&z, &h, &r, f64::INFINITY);
        assert!(o.accepted);
        let pht = p0 * h.transpose();
        let si = Cholesky::new(r + h * pht).expect("S > 0").inverse();
        let k = pht * si;
        let mut reference = p0;
        for a in 0..3 {
            reference.syger(-1.0, &k.column(a), &pht.column(a), 1.0);
        }
        reference.fill_upper_triangle_with_lower_triangle();
        for i in 0..N {
            reference[(i, i)] = reference[(i, i)].max(1e-30);
        }
        assert_eq!(c.p, reference, "bit for bit the syger form");
        let textbook = p0 - k * h * p0;
        let diff = (c.p - textbook).amax();
        assert!(diff <= 1e-12 * p0.amax(), "{diff}");
        assert!((c.p - p0).amax() > 1e-6 * p0.amax(), "the fix moves P");
    }

    /// The propagation is bit for bit the column form it replaced, and
    /// equals the dense Φ P Φ^T + Q T to round-off: relative to the largest
    /// |entry| of each term, 1e-12 (a few hundred ulps: each entry sums
    /// about 20 products of one step, each rounded at 2^-53 ≈ 1.1e-16, so
    /// 1e-14 would be typical; an error in Φ or in the order of the
    /// products would show at 1e-4 or more, since A = F T moves P by that).
    #[test]
    fn propagation_is_the_dense_product_to_round_off() {
        let mut c = filled();
        let p0 = c.p;
        assert!(p0.iter().all(|&x| x != 0.0), "P is filled");
        let (m, t) = (input(), 0.1);
        let reference = propagate_axpy(&p0, &c.q, &m, &c.noise, t);
        c.propagate(&m, t);
        assert_eq!(c.p, reference, "bit for bit the axpy form");
        let phi = Mat::identity() + system_matrix(&m, &c.noise) * t;
        let dense = phi * p0 * phi.transpose() + Mat::from_diagonal(&(c.q * t));
        let scale = dense.amax();
        let diff = (c.p - dense).amax();
        assert!(diff <= 1e-12 * scale, "{diff} against {scale}");
        // The step is not the identity: the check above could fail.
        assert!((c.p - p0).amax() > 1e-6 * scale);
        assert_eq!(c.p, c.p.transpose(), "symmetric");
    }
}
