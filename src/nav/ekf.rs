//! The error-state Kalman filter core: the state layout, the standard SINS
//! error model (Qin, "Inertial Navigation"; PSINS `etm`) as a continuous
//! system matrix F, covariance propagation with a sparse first-order
//! transition matrix Φ = I + F T, and a generic chi-square-gated measurement
//! update for 1 to 3 rows. Everything is on fixed-size arrays: no heap
//! allocation per step.
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

#![allow(clippy::needless_range_loop)] // index-heavy small-matrix algebra

use crate::attitude::{M3, V3};
use crate::geodesy::EarthState;

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

/// A square state matrix.
pub type Mat = [[f64; N]; N];

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

#[inline(always)]
fn skew(v: V3) -> M3 {
    [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]
}

#[inline(always)]
fn mm(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}

/// The continuous system matrix F of the standard SINS error model with the
/// Gauss–Markov and random-walk states, dense (for tests and for clarity);
/// the filter uses [`system_sparse`], which yields the same entries.
pub fn system_matrix(m: &ErrorModelInput, noise: &NoiseModel) -> Mat {
    let mut f = [[0.0; N]; N];
    system_sparse(m, noise, |i, j, x| f[i][j] += x);
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
    let [ve, vn, _vu] = m.v;
    let rm = e.rm_h;
    let rn = e.rn_h;
    let (sl, cl, tl) = (e.sin_lat, e.cos_lat, e.tan_lat);
    let secl = 1.0 / cl;
    let wie = crate::geodesy::EARTH_RATE;
    // Building blocks (PSINS etm / Qin).
    let maa = skew([-e.w_in[0], -e.w_in[1], -e.w_in[2]]);
    let mav: M3 = [
        [0.0, -1.0 / rm, 0.0],
        [1.0 / rn, 0.0, 0.0],
        [tl / rn, 0.0, 0.0],
    ];
    let mp1: M3 = [[0.0, 0.0, 0.0], [-wie * sl, 0.0, 0.0], [wie * cl, 0.0, 0.0]];
    let mp2: M3 = [
        [0.0, 0.0, vn / (rm * rm)],
        [0.0, 0.0, -ve / (rn * rn)],
        [ve * secl * secl / rn, 0.0, -ve * tl / (rn * rn)],
    ];
    let vx = skew(m.v);
    let wien = [
        2.0 * e.w_ie[0] + e.w_en[0],
        2.0 * e.w_ie[1] + e.w_en[1],
        2.0 * e.w_ie[2] + e.w_en[2],
    ];
    let mvv_a = mm(&vx, &mav);
    let wx = skew(wien);
    let mut mp12 = mp2;
    for i in 0..3 {
        mp12[i][0] += 2.0 * mp1[i][0];
    }
    let mvp = mm(&vx, &mp12);
    let mva = skew(m.f_n);
    let mpv: M3 = [[0.0, 1.0 / rm, 0.0], [secl / rn, 0.0, 0.0], [0.0, 0.0, 1.0]];
    let mpp: M3 = [
        [0.0, 0.0, -vn / (rm * rm)],
        [ve * secl * tl / rn, 0.0, -ve * secl / (rn * rn)],
        [0.0, 0.0, 0.0],
    ];
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
            let a = maa[i][j];
            if nz(a) {
                put(PHI + i, PHI + j, a);
            }
            let a = mav[i][j];
            if nz(a) {
                put(PHI + i, DV + j, a);
            }
            let a = mp1[i][j] + mp2[i][j];
            if nz(a) {
                put(PHI + i, DP + j, a);
            }
            put(PHI + i, EPS + j, -m.c_bn[i][j]);
            let a = mva[i][j];
            if nz(a) {
                put(DV + i, PHI + j, a);
            }
            let a = mvv_a[i][j] - wx[i][j];
            if nz(a) {
                put(DV + i, DV + j, a);
            }
            let a = mvp[i][j]
                + match (i, j) {
                    (2, 2) => g_grad,
                    (2, 0) => g_lat,
                    _ => 0.0,
                };
            if nz(a) {
                put(DV + i, DP + j, a);
            }
            put(DV + i, NABLA + j, m.c_bn[i][j]);
            let a = mpv[i][j];
            if nz(a) {
                put(DP + i, DV + j, a);
            }
            let a = mpp[i][j];
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
pub fn process_noise_diag(noise: &NoiseModel) -> [f64; N] {
    let mut q = [0.0; N];
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

/// The covariance of the error state.
#[derive(Debug, Clone)]
pub struct Covariance {
    /// P.
    pub p: Mat,
    nz: [(u8, u8, f64); 160],
    q: [f64; N],
    noise: NoiseModel,
}

impl Covariance {
    /// Starts from the diagonal standard deviations `sigma0`.
    pub fn new(sigma0: &[f64; N], noise: NoiseModel) -> Self {
        let mut p = [[0.0; N]; N];
        for i in 0..N {
            p[i][i] = sigma0[i] * sigma0[i];
        }
        Self {
            p,
            nz: [(0, 0, 0.0); 160],
            q: process_noise_diag(&noise),
            noise,
        }
    }

    /// The noise model.
    pub fn noise(&self) -> &NoiseModel {
        &self.noise
    }

    /// P ← Φ P Φ^T + Q T with Φ = I + F T (F from `m`), T the interval (s).
    pub fn propagate(&mut self, m: &ErrorModelInput, t: f64) {
        let mut n = 0usize;
        let nz = &mut self.nz;
        system_sparse(m, &self.noise, |i, j, x| {
            nz[n] = (i as u8, j as u8, x * t);
            n += 1;
        });
        let a = &self.nz[..n];
        // B = Φ P = P + A P
        let mut b = self.p;
        for &(i, k, x) in a {
            let (i, k) = (i as usize, k as usize);
            let pk = self.p[k];
            let bi = &mut b[i];
            for j in 0..N {
                bi[j] += x * pk[j];
            }
        }
        // P = B Φ^T = B + B A^T: P[r][i] += x B[r][k] for every (i, k, x).
        let mut c = b;
        for &(i, k, x) in a {
            let (i, k) = (i as usize, k as usize);
            for r in 0..N {
                c[r][i] += x * b[r][k];
            }
        }
        for i in 0..N {
            c[i][i] += self.q[i] * t;
        }
        // Symmetrize.
        for i in 0..N {
            for j in 0..i {
                let s = 0.5 * (c[i][j] + c[j][i]);
                c[i][j] = s;
                c[j][i] = s;
            }
        }
        self.p = c;
    }

    /// Innovation covariance S = H P H^T + R and P H^T for an M-row measurement.
    fn innovation<const M: usize>(
        &self,
        h: &[[f64; N]; M],
        r: &[[f64; M]; M],
    ) -> ([[f64; M]; N], [[f64; M]; M]) {
        let mut pht = [[0.0; M]; N];
        for i in 0..N {
            for m in 0..M {
                let mut s = 0.0;
                for (k, hk) in h[m].iter().enumerate() {
                    if *hk != 0.0 {
                        s += self.p[i][k] * hk;
                    }
                }
                pht[i][m] = s;
            }
        }
        let mut s = *r;
        for a in 0..M {
            for b in 0..M {
                let mut x = 0.0;
                for (k, hk) in h[a].iter().enumerate() {
                    if *hk != 0.0 {
                        x += hk * pht[k][b];
                    }
                }
                s[a][b] += x;
            }
        }
        (pht, s)
    }

    /// Normalised innovation squared of a measurement without updating.
    pub fn nis<const M: usize>(&self, z: &[f64; M], h: &[[f64; N]; M], r: &[[f64; M]; M]) -> f64 {
        let (_, s) = self.innovation(h, r);
        match chol_inv(&s) {
            Some(si) => quad(&si, z),
            None => f64::INFINITY,
        }
    }

    /// Gated update with innovation `z` (measurement predicted from the
    /// estimate minus the measurement), rows `h`, noise `r` and gate threshold
    /// `gate` on ν^T S^{-1} ν. Returns the outcome and the error-state estimate
    /// (zero when rejected).
    pub fn update<const M: usize>(
        &mut self,
        z: &[f64; M],
        h: &[[f64; N]; M],
        r: &[[f64; M]; M],
        gate: f64,
    ) -> (UpdateOutcome, [f64; N]) {
        let (pht, s) = self.innovation(h, r);
        let Some(si) = chol_inv(&s) else {
            return (
                UpdateOutcome {
                    accepted: false,
                    nis: f64::INFINITY,
                    dof: M,
                },
                [0.0; N],
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
                [0.0; N],
            );
        }
        // K = P H^T S^{-1}
        let mut k = [[0.0; M]; N];
        for i in 0..N {
            for a in 0..M {
                let mut x = 0.0;
                for b in 0..M {
                    x += pht[i][b] * si[b][a];
                }
                k[i][a] = x;
            }
        }
        let mut dx = [0.0; N];
        for i in 0..N {
            let mut x = 0.0;
            for a in 0..M {
                x += k[i][a] * z[a];
            }
            dx[i] = x;
        }
        // P ← P − K (P H^T)^T
        for i in 0..N {
            for j in 0..=i {
                let mut x = 0.0;
                for a in 0..M {
                    x += k[i][a] * pht[j][a];
                }
                let v = 0.5 * (self.p[i][j] + self.p[j][i]) - x;
                self.p[i][j] = v;
                self.p[j][i] = v;
            }
        }
        for i in 0..N {
            if self.p[i][i] < 1e-30 {
                self.p[i][i] = 1e-30;
            }
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
fn quad<const M: usize>(a: &[[f64; M]; M], x: &[f64; M]) -> f64 {
    let mut s = 0.0;
    for i in 0..M {
        for j in 0..M {
            s += x[i] * a[i][j] * x[j];
        }
    }
    s
}

/// Inverse of a small symmetric positive definite matrix by Cholesky; None if
/// it is not positive definite.
pub fn chol_inv<const M: usize>(a: &[[f64; M]; M]) -> Option<[[f64; M]; M]> {
    let mut l = [[0.0; M]; M];
    for i in 0..M {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // Inverse of L (lower triangular).
    let mut li = [[0.0; M]; M];
    for i in 0..M {
        li[i][i] = 1.0 / l[i][i];
        for j in 0..i {
            let mut s = 0.0;
            for k in j..i {
                s -= l[i][k] * li[k][j];
            }
            li[i][j] = s / l[i][i];
        }
    }
    // A^{-1} = L^{-T} L^{-1}
    let mut inv = [[0.0; M]; M];
    for i in 0..M {
        for j in 0..M {
            let mut s = 0.0;
            for k in i.max(j)..M {
                s += li[k][i] * li[k][j];
            }
            inv[i][j] = s;
        }
    }
    Some(inv)
}
