//! The integrated navigator: strapdown mechanization corrected in closed loop
//! by an error-state Kalman filter ([`super::ekf`]) with odometer velocity and
//! non-holonomic constraints, position fixes (RFID tags, map matching, an
//! external fix source with random-walk error and optional Sage–Husa adaptive
//! noise) and barometric height.
//!
//! The covariance is propagated at the filter interval (0.1 s by default) with
//! the mean specific force and attitude of the IMU steps in between; before a
//! measurement is applied the covariance is brought to the current IMU epoch.
//! Measurements carry their time stamp; a position measured at `t` earlier than
//! the current epoch is compared with the navigator's position moved back by
//! v (t_now − t). Callers apply measurements in time order
//! ([`MeasurementQueue`] sorts them).
//!
//! Every update is gated by its normalised innovation squared (chi-square,
//! 99.9 % by default): a rejected measurement changes nothing and is reported
//! in the returned [`UpdateOutcome`].

use super::ekf::{
    Covariance, ErrorModelInput, Mat, NoiseModel, Rows, StateVec, UpdateOutcome, APSI, ATHETA,
    BARO, DP, DV, EPS, GATE_999, KOD, N, NABLA, PHI, RW,
};
use super::strapdown::{ImuIncrement, NavState, Strapdown};
use crate::attitude::{Quat, QuatExt, M3, V3};
use nalgebra::{Matrix1, Matrix2, Matrix3, Vector1, Vector2, Vector3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Filter settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterConfig {
    /// Covariance propagation interval (s).
    pub interval_s: f64,
    /// Noise model of the error states.
    pub noise: NoiseModel,
    /// Initial standard deviations of the error states.
    pub sigma0: [f64; N],
    /// σ of the odometer's mean forward speed over one update interval (m/s).
    pub odo_noise_mps: f64,
    /// σ of the non-holonomic constraints (lateral and vertical body velocity, m/s).
    pub nhc_noise_mps: f64,
    /// Apply the non-holonomic constraints: with each odometer update, or
    /// alone at the odometer's epochs without one. Off, the odometer
    /// observes the forward speed alone.
    pub use_nhc: bool,
    /// Consecutive rejected odometer updates that declare the odometer faulty.
    pub odo_fault_rejections: u32,
    /// Consecutive passing odometer innovations that re-enable it.
    pub odo_recover_passes: u32,
    /// Gate thresholds on the normalised innovation squared for 1, 2, 3 rows.
    pub gate: [f64; 3],
    /// Sage–Husa adaptive estimation of the external fix's white noise with
    /// fading factor b (0 < b < 1); None: fixed noise.
    pub sage_husa_b: Option<f64>,
}

impl FilterConfig {
    /// Settings with the given noise model and initial sigmas, defaults elsewhere.
    pub fn new(noise: NoiseModel, sigma0: [f64; N]) -> Self {
        Self {
            interval_s: 0.1,
            noise,
            sigma0,
            odo_noise_mps: 0.05,
            nhc_noise_mps: 0.05,
            use_nhc: true,
            odo_fault_rejections: 3,
            odo_recover_passes: 20,
            gate: GATE_999,
            sage_husa_b: None,
        }
    }
}

/// A horizontal position for [`Filter::update_position_fix`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FixPosition {
    /// Latitude and longitude (rad).
    Geodetic {
        /// Latitude (rad).
        lat: f64,
        /// Longitude (rad).
        lon: f64,
    },
    /// East and north (m) in a local frame whose origin is at `origin_lat`,
    /// `origin_lon` (rad) (flat-Earth, for fixes within a few km of the origin).
    Enu {
        /// Origin latitude (rad).
        origin_lat: f64,
        /// Origin longitude (rad).
        origin_lon: f64,
        /// East (m).
        east: f64,
        /// North (m).
        north: f64,
    },
}

/// Counts of updates by kind: (accepted, rejected).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct UpdateCounts {
    /// Odometer (with constraints) updates accepted.
    pub odometer_accepted: u64,
    /// Odometer updates rejected by the gate.
    pub odometer_rejected: u64,
    /// Epochs the odometer spent disabled as faulty.
    pub odometer_disabled_epochs: u64,
    /// Position fixes (tags, map matching) accepted.
    pub position_accepted: u64,
    /// Position fixes rejected.
    pub position_rejected: u64,
    /// Height (baro) updates accepted.
    pub height_accepted: u64,
    /// Height updates rejected.
    pub height_rejected: u64,
    /// External fixes accepted.
    pub external_accepted: u64,
    /// External fixes rejected.
    pub external_rejected: u64,
}

/// The integrated navigator.
#[derive(Debug, Clone)]
pub struct Filter {
    ins: Strapdown,
    cov: Covariance,
    cfg: FilterConfig,
    t: f64,
    gyro_bias: V3,
    accel_bias: V3,
    odo_scale: f64,
    odo_pitch: f64,
    odo_yaw: f64,
    fix_rw: Vector2<f64>,
    baro_bias: f64,
    // Accumulators for the covariance propagation.
    acc_t: f64,
    acc_n: u32,
    acc_dvn: V3,
    acc_c: M3,
    // Accumulators for the odometer: ∫ C̃_n^b v^n dt and its time.
    odo_vb: V3,
    odo_t: f64,
    odo_fault: bool,
    odo_rejects: u32,
    odo_passes: u32,
    sh_k: u32,
    sh_r: Option<Matrix2<f64>>,
    /// Update counts.
    pub counts: UpdateCounts,
}

impl Filter {
    /// A navigator starting at `state` (the estimate) at time `t0`, IMU
    /// interval `imu_dt` (s).
    pub fn new(state: NavState, t0: f64, imu_dt: f64, cfg: FilterConfig) -> Self {
        Self {
            ins: Strapdown::new(state, imu_dt),
            cov: Covariance::new(&cfg.sigma0, cfg.noise),
            cfg,
            t: t0,
            gyro_bias: V3::zeros(),
            accel_bias: V3::zeros(),
            odo_scale: 0.0,
            odo_pitch: 0.0,
            odo_yaw: 0.0,
            fix_rw: Vector2::zeros(),
            baro_bias: 0.0,
            acc_t: 0.0,
            acc_n: 0,
            acc_dvn: V3::zeros(),
            acc_c: M3::zeros(),
            odo_vb: V3::zeros(),
            odo_t: 0.0,
            odo_fault: false,
            odo_rejects: 0,
            odo_passes: 0,
            sh_k: 0,
            sh_r: None,
            counts: UpdateCounts::default(),
        }
    }

    /// Current time (s).
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The navigation solution.
    pub fn state(&self) -> &NavState {
        &self.ins.state
    }

    /// The error covariance.
    pub fn covariance(&self) -> &Mat {
        &self.cov.p
    }

    /// Replaces the error covariance (the planner's composed stretch maps
    /// carry a covariance over a stretch without stepping the filter).
    pub fn set_covariance(&mut self, p: Mat) {
        self.cov.p = p;
    }

    /// Starts (or restarts) composing the covariance ops from here on into
    /// one map ([`super::riccati::Element`]).
    pub fn track_element(&mut self) {
        self.cov.element = Some(Box::default());
    }

    /// The map composed since [`Filter::track_element`], if tracked.
    pub fn element(&self) -> Option<&super::riccati::Element<N>> {
        self.cov.element.as_deref()
    }

    /// Stops composing and returns the map, if tracked.
    pub fn take_element(&mut self) -> Option<super::riccati::Element<N>> {
        self.cov.element.take().map(|b| *b)
    }

    /// Estimated gyro and accelerometer biases (body axes; rad/s, m/s²).
    pub fn imu_biases(&self) -> (V3, V3) {
        (self.gyro_bias, self.accel_bias)
    }

    /// Estimated odometer scale-factor error, pitch and yaw misalignment (rad).
    pub fn odometer_calibration(&self) -> (f64, f64, f64) {
        (self.odo_scale, self.odo_pitch, self.odo_yaw)
    }

    /// Whether the odometer is currently disabled as faulty.
    pub fn odometer_faulty(&self) -> bool {
        self.odo_fault
    }

    /// The current adaptive (Sage–Husa) external fix noise, if any.
    pub fn adaptive_fix_noise(&self) -> Option<Matrix2<f64>> {
        self.sh_r
    }

    /// Metres per radian of latitude and of longitude at the navigator's
    /// position (`R_M + h`, `(R_N + h) cos L`): the scaling of
    /// [`Filter::position_cov_enu`].
    pub fn metres_per_radian(&self) -> (f64, f64) {
        self.m_per_rad()
    }

    fn m_per_rad(&self) -> (f64, f64) {
        let e = self.ins.earth();
        (e.rm_h, e.clrn_h)
    }

    /// Position covariance in metres (east, north, up).
    pub fn position_cov_enu_matrix(&self) -> Matrix3<f64> {
        let (rm, clrn) = self.m_per_rad();
        let s = Vector3::new(clrn, rm, 1.0);
        let idx = [DP + 1, DP, DP + 2];
        Matrix3::from_fn(|a, b| s[a] * s[b] * self.cov.p[(idx[a], idx[b])])
    }

    /// [`Filter::position_cov_enu_matrix`] as rows of an array (east, north,
    /// up; m²), the form the planner and the simulator's records take.
    pub fn position_cov_enu(&self) -> [[f64; 3]; 3] {
        self.position_cov_enu_matrix().transpose().into()
    }

    /// One IMU sample: bias compensation, mechanization, and the covariance
    /// propagation when the filter interval is complete.
    #[inline]
    pub fn step(&mut self, inc: &ImuIncrement) {
        let dt = self.ins.dt;
        let comp = ImuIncrement {
            dtheta: inc.dtheta - self.gyro_bias * dt,
            dv: inc.dv - self.accel_bias * dt,
        };
        let q0 = self.ins.state.q;
        let vb0 = q0.inverse_transform_vector(&self.ins.state.v);
        self.ins.step(&comp);
        self.t += dt;
        let c = q0.to_dcm();
        self.acc_dvn += c * comp.dv;
        self.acc_c += c;
        self.acc_n += 1;
        self.acc_t += dt;
        // Mean body velocity over the step (trapezoid), to match the distance
        // the odometer counts over the same step.
        let vb1 = self.ins.state.q.inverse_transform_vector(&self.ins.state.v);
        self.odo_vb += (vb0 + vb1) * 0.5 * dt;
        self.odo_t += dt;
        if self.acc_t >= self.cfg.interval_s - 0.5 * dt {
            self.flush();
        }
    }

    /// Brings the covariance to the current epoch.
    fn flush(&mut self) {
        if self.acc_n == 0 {
            return;
        }
        let n = self.acc_n as f64;
        let m = ErrorModelInput {
            eth: *self.ins.earth(),
            v: self.ins.state.v,
            f_n: self.acc_dvn * (1.0 / self.acc_t),
            c_bn: self.acc_c / n,
        };
        self.cov.propagate(&m, self.acc_t);
        self.acc_t = 0.0;
        self.acc_n = 0;
        self.acc_dvn = V3::zeros();
        self.acc_c = M3::zeros();
    }

    /// Feeds an error-state estimate back into the navigator and the sensor
    /// corrections (closed loop).
    fn feedback(&mut self, dx: &StateVec) {
        let s = &mut self.ins.state;
        s.q = (Quat::from_rotvec(dx.fixed_rows::<3>(PHI).into_owned()) * s.q).normalized();
        s.v -= dx.fixed_rows::<3>(DV);
        self.gyro_bias += dx.fixed_rows::<3>(EPS);
        self.accel_bias += dx.fixed_rows::<3>(NABLA);
        s.lat -= dx[DP];
        s.lon -= dx[DP + 1];
        s.h -= dx[DP + 2];
        self.odo_scale += dx[KOD];
        self.odo_pitch += dx[ATHETA];
        self.odo_yaw += dx[APSI];
        self.fix_rw += dx.fixed_rows::<2>(RW);
        self.baro_bias += dx[BARO];
    }

    /// Rows of the body-frame velocity measurement (odometer forward speed
    /// `v` along y, constraints along x and z): H for δv, φ and the odometer
    /// states. Row r of z = C̃_n^b ṽ^n − v [−α̂_ψ, 1, α̂_θ].
    pub fn odometer_rows(&self, v: f64) -> Rows<3> {
        let cnb = self.ins.state.q.conjugate().to_dcm();
        let mut h = Rows::<3>::zeros();
        h.fixed_columns_mut::<3>(DV).copy_from(&cnb);
        h.fixed_columns_mut::<3>(PHI)
            .copy_from(&-(cnb * self.ins.state.v.cross_matrix()));
        h[(0, APSI)] = -v;
        h[(1, KOD)] = -v;
        h[(2, ATHETA)] = v;
        h
    }

    /// Odometer update with the distance `distance_m` the odometer counted
    /// since the previous odometer update (which ends at the current epoch),
    /// with the non-holonomic constraints when they are on
    /// ([`FilterConfig::use_nhc`]; else the forward speed alone). A reading is compared with the
    /// navigator's mean body velocity over the same interval. Consecutive
    /// rejections disable the odometer (the constraints stay); consecutive
    /// passing innovations re-enable it.
    pub fn update_odometer(&mut self, distance_m: f64) -> UpdateOutcome {
        if self.odo_t <= 0.0 {
            return UpdateOutcome::SKIPPED;
        }
        self.flush();
        let t = self.odo_t;
        let vb = self.odo_vb * (1.0 / t);
        self.odo_vb = V3::zeros();
        self.odo_t = 0.0;
        let v = distance_m / t / (1.0 + self.odo_scale);
        let pred = V3::new(-self.odo_yaw * v, v, self.odo_pitch * v);
        let z = vb - pred;
        // The rows take the navigator's forward speed, not the odometer's: a
        // noisy (e.g. pulse-quantized) speed in H correlates H with the noise
        // and biases the scale-factor estimate (errors in variables).
        let h = self.odometer_rows(vb[1]);
        let so = self.cfg.odo_noise_mps;
        let sn = self.cfg.nhc_noise_mps;
        let r3 = Matrix3::from_diagonal(&Vector3::new(sn * sn, so * so, sn * sn));
        let mut out = UpdateOutcome::SKIPPED;
        if !self.odo_fault {
            let (o, dx) = if self.cfg.use_nhc {
                self.cov.update(&z, &h, &r3, self.cfg.gate[2])
            } else {
                // Forward speed alone: without the constraints nothing
                // holds the lateral and vertical body velocity.
                self.cov.update(
                    &Vector1::new(z[1]),
                    &h.fixed_rows::<1>(1).into_owned(),
                    &Matrix1::new(so * so),
                    self.cfg.gate[0],
                )
            };
            out = o;
            if o.accepted {
                self.feedback(&dx);
                self.counts.odometer_accepted += 1;
                self.odo_rejects = 0;
                return o;
            }
            self.counts.odometer_rejected += 1;
            self.odo_rejects += 1;
            if self.odo_rejects >= self.cfg.odo_fault_rejections {
                self.odo_fault = true;
                self.odo_passes = 0;
            }
        } else {
            self.counts.odometer_disabled_epochs += 1;
            // Test the forward speed alone for recovery.
            let nis = self.cov.nis(
                &Vector1::new(z[1]),
                &h.fixed_rows::<1>(1).into_owned(),
                &Matrix1::new(so * so),
            );
            if nis <= self.cfg.gate[0] {
                self.odo_passes += 1;
                if self.odo_passes >= self.cfg.odo_recover_passes {
                    self.odo_fault = false;
                    self.odo_rejects = 0;
                }
            } else {
                self.odo_passes = 0;
            }
        }
        if self.cfg.use_nhc {
            // Constraints alone, with the navigator's forward speed.
            let (o, dx) = self.constraints(&vb);
            if o.accepted {
                self.feedback(&dx);
            }
            if out.dof == 0 {
                out = o;
            }
        }
        out
    }

    /// Applies the constraints alone (no odometer) over the interval since the
    /// last odometer/constraint update.
    pub fn update_constraints(&mut self) -> UpdateOutcome {
        if self.odo_t <= 0.0 || !self.cfg.use_nhc {
            return UpdateOutcome::SKIPPED;
        }
        self.flush();
        let vb = self.odo_vb * (1.0 / self.odo_t);
        self.odo_vb = V3::zeros();
        self.odo_t = 0.0;
        let (o, dx) = self.constraints(&vb);
        if o.accepted {
            self.feedback(&dx);
        }
        o
    }

    /// The non-holonomic constraints (lateral and vertical body velocity,
    /// less the odometer misalignment's share) for the mean body velocity
    /// `vb`, with the navigator's forward speed in H.
    fn constraints(&mut self, vb: &V3) -> (UpdateOutcome, StateVec) {
        let sn = self.cfg.nhc_noise_mps;
        let vi = vb[1];
        let hn = self.odometer_rows(vi);
        let zn = Vector2::new(vb[0] + self.odo_yaw * vi, vb[2] - self.odo_pitch * vi);
        let mut h = Rows::<2>::zeros();
        h.set_row(0, &hn.row(0));
        h.set_row(1, &hn.row(2));
        self.cov.update(
            &zn,
            &h,
            &Matrix2::from_diagonal_element(sn * sn),
            self.cfg.gate[1],
        )
    }

    /// The navigator's position at time `t` (≤ now): moved back by v (now − t).
    fn position_at(&self, t: f64) -> (f64, f64, f64) {
        let s = &self.ins.state;
        let lag = (self.t - t).max(0.0);
        let e = self.ins.earth();
        (
            s.lat - s.v[1] * lag / e.rm_h,
            s.lon - s.v[0] * lag / e.clrn_h,
            s.h - s.v[2] * lag,
        )
    }

    /// A position fix measured at time `t`: latitude, longitude (rad), an
    /// optional height (m), the horizontal covariance (east, north; m²) and
    /// the height variance (m²). Used by RFID tags.
    pub fn update_position(
        &mut self,
        t: f64,
        lat: f64,
        lon: f64,
        h: Option<f64>,
        cov_en: Matrix2<f64>,
        var_up: f64,
    ) -> UpdateOutcome {
        self.flush();
        let (rm, clrn) = self.m_per_rad();
        let (la, lo, hh) = self.position_at(t);
        let ze = (lo - lon) * clrn;
        let zn = (la - lat) * rm;
        let (o, dx) = match h {
            Some(ht) => {
                let mut rows = Rows::<3>::zeros();
                rows[(0, DP + 1)] = clrn;
                rows[(1, DP)] = rm;
                rows[(2, DP + 2)] = 1.0;
                let mut r = Matrix3::zeros();
                r.fixed_view_mut::<2, 2>(0, 0).copy_from(&cov_en);
                r[(2, 2)] = var_up;
                self.cov
                    .update(&Vector3::new(ze, zn, hh - ht), &rows, &r, self.cfg.gate[2])
            }
            None => {
                let mut rows = Rows::<2>::zeros();
                rows[(0, DP + 1)] = clrn;
                rows[(1, DP)] = rm;
                self.cov
                    .update(&Vector2::new(ze, zn), &rows, &cov_en, self.cfg.gate[1])
            }
        };
        if o.accepted {
            self.feedback(&dx);
            self.counts.position_accepted += 1;
        } else {
            self.counts.position_rejected += 1;
        }
        o
    }

    /// A horizontal position fix with a full 2×2 covariance (east, north; m²),
    /// e.g. from map matching: tight across the road, loose along it.
    pub fn update_position_fix(
        &mut self,
        t: f64,
        position: FixPosition,
        cov_en: Matrix2<f64>,
    ) -> UpdateOutcome {
        let (lat, lon) = match position {
            FixPosition::Geodetic { lat, lon } => (lat, lon),
            FixPosition::Enu {
                origin_lat,
                origin_lon,
                east,
                north,
            } => {
                let (rm, rn) = crate::geodesy::radii(origin_lat);
                (
                    origin_lat + north / rm,
                    origin_lon + east / (rn * origin_lat.cos()),
                )
            }
        };
        self.update_position(t, lat, lon, None, cov_en, 0.0)
    }

    /// Barometric height `h` (m) at time `t` with white-noise variance `var` (m²);
    /// the barometer's bias is a state.
    pub fn update_height(&mut self, t: f64, h: f64, var: f64) -> UpdateOutcome {
        self.flush();
        let (_, _, hh) = self.position_at(t);
        let mut row = Rows::<1>::zeros();
        row[(0, DP + 2)] = 1.0;
        row[(0, BARO)] = -1.0;
        let (o, dx) = self.cov.update(
            &Vector1::new(hh + self.baro_bias - h),
            &row,
            &Matrix1::new(var),
            self.cfg.gate[0],
        );
        if o.accepted {
            self.feedback(&dx);
            self.counts.height_accepted += 1;
        } else {
            self.counts.height_rejected += 1;
        }
        o
    }

    /// An external horizontal fix (e.g. gravity matching) at time `t` whose
    /// error is a random walk (a state) plus white noise of variance `var_white`
    /// (m², per axis). With Sage–Husa on, the white-noise covariance is
    /// re-estimated at each fix with the fading weight
    /// d_k = (1 − b)/(1 − b^(k+1)).
    pub fn update_external_fix(
        &mut self,
        t: f64,
        lat: f64,
        lon: f64,
        var_white: f64,
    ) -> UpdateOutcome {
        self.flush();
        let (rm, clrn) = self.m_per_rad();
        let (la, lo, _) = self.position_at(t);
        let z = Vector2::new(
            (lo - lon) * clrn + self.fix_rw[0],
            (la - lat) * rm + self.fix_rw[1],
        );
        let mut h = Rows::<2>::zeros();
        h[(0, DP + 1)] = clrn;
        h[(0, RW)] = -1.0;
        h[(1, DP)] = rm;
        h[(1, RW + 1)] = -1.0;
        let r0 = Matrix2::from_diagonal_element(var_white);
        let r = match self.cfg.sage_husa_b {
            None => r0,
            Some(b) => {
                let prev = self.sh_r.unwrap_or(r0);
                let d = sage_husa_weight(b, self.sh_k);
                let hph = h * self.cov.p * h.transpose();
                let mut rn = prev * (1.0 - d) + (z * z.transpose() - hph) * d;
                // Keep it positive definite: floor the variances at 1 % of the
                // nominal, drop the correlation if it is not.
                let floor = 0.01 * var_white;
                for a in 0..2 {
                    if rn[(a, a)] < floor {
                        rn[(a, a)] = floor;
                    }
                }
                if rn[(0, 1)] * rn[(0, 1)] >= 0.99 * rn[(0, 0)] * rn[(1, 1)] {
                    rn[(0, 1)] = 0.0;
                    rn[(1, 0)] = 0.0;
                }
                self.sh_k += 1;
                self.sh_r = Some(rn);
                rn
            }
        };
        let (o, dx) = self.cov.update(&z, &h, &r, self.cfg.gate[1]);
        if o.accepted {
            self.feedback(&dx);
            self.counts.external_accepted += 1;
        } else {
            self.counts.external_rejected += 1;
        }
        o
    }
}

/// The east/north covariance (m²) of a fix that is `sigma_along` (m) along a
/// direction of travel with heading `heading` (rad, clockwise from north) and
/// `sigma_across` (m) across it: R = σ_a² f fᵀ + σ_c² r rᵀ with f the forward
/// and r the right unit vectors. For map-matching fixes (tight across the
/// road, loose along it) and tag fixes.
pub fn along_across_covariance(heading: f64, sigma_along: f64, sigma_across: f64) -> Matrix2<f64> {
    let (fe, fnn) = heading.sin_cos();
    let (a2, c2) = (sigma_along * sigma_along, sigma_across * sigma_across);
    let cross = (a2 - c2) * fe * fnn;
    Matrix2::new(
        a2 * fe * fe + c2 * fnn * fnn,
        cross,
        cross,
        a2 * fnn * fnn + c2 * fe * fe,
    )
}

/// The Sage–Husa fading weight d_k = (1 − b)/(1 − b^(k+1)) of the k-th
/// adaptive update (k from 0): 1 at first, tending to 1 − b.
pub fn sage_husa_weight(b: f64, k: u32) -> f64 {
    (1.0 - b) / (1.0 - b.powi(k as i32 + 1))
}

/// A time-stamped measurement waiting to be applied.
#[derive(Debug, Clone, Copy)]
struct Timed<T> {
    t: f64,
    seq: u64,
    item: T,
}

impl<T> PartialEq for Timed<T> {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl<T> Eq for Timed<T> {}
impl<T> PartialOrd for Timed<T> {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl<T> Ord for Timed<T> {
    fn cmp(&self, o: &Self) -> Ordering {
        // Reversed: the earliest (then the first pushed) on top of the max-heap.
        o.t.total_cmp(&self.t).then(o.seq.cmp(&self.seq))
    }
}

/// Measurements from sources of any rates, released in time order.
#[derive(Debug, Clone)]
pub struct MeasurementQueue<T> {
    heap: BinaryHeap<Timed<T>>,
    seq: u64,
}

impl<T> Default for MeasurementQueue<T> {
    fn default() -> Self {
        Self {
            heap: BinaryHeap::with_capacity(64),
            seq: 0,
        }
    }
}

impl<T> MeasurementQueue<T> {
    /// Queues a measurement taken at time `t`.
    pub fn push(&mut self, t: f64, item: T) {
        self.seq += 1;
        self.heap.push(Timed {
            t,
            seq: self.seq,
            item,
        });
    }

    /// The earliest measurement taken at or before `now`.
    pub fn pop_due(&mut self, now: f64) -> Option<(f64, T)> {
        if self.heap.peek().is_some_and(|x| x.t <= now) {
            self.heap.pop().map(|x| (x.t, x.item))
        } else {
            None
        }
    }

    /// Number waiting.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether none is waiting.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}
