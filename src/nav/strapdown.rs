//! Strapdown inertial mechanization on WGS-84 in the local-level ENU frame, at
//! the IMU rate: quaternion attitude with two-sample (previous-sample) coning
//! correction, velocity with two-sample sculling and rotation corrections,
//! Earth rate, transport rate, normal gravity with height and Coriolis, and
//! geodetic position by the trapezoid rule. Earth-related terms are evaluated
//! at the mid-point of each step, extrapolated from the previous step's
//! acceleration (as PSINS `insupdate` does).
//!
//! The loop allocates nothing and works on `nalgebra` static vectors and unit
//! quaternions; see
//! `benches/nav.rs` for its throughput.

use crate::attitude::{Quat, QuatExt, V3};
use crate::geodesy::EarthState;

/// IMU output over one sampling interval: angle increment ∫ω dt (rad) and
/// velocity increment ∫f dt (m/s), both in the IMU (body) frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ImuIncrement {
    /// Angle increment (rad).
    pub dtheta: V3,
    /// Velocity increment (m/s).
    pub dv: V3,
}

/// Attitude, velocity and position of a navigator or of the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavState {
    /// Attitude q_b^n (body to ENU).
    pub q: Quat,
    /// Velocity, ENU (m/s).
    pub v: V3,
    /// Latitude (rad).
    pub lat: f64,
    /// Longitude (rad).
    pub lon: f64,
    /// Height above the ellipsoid (m).
    pub h: f64,
}

/// The rotation vector of one step from the current and previous angle
/// increments: φ = Δθ_k + (1/12) Δθ_{k−1} × Δθ_k (two-sample coning).
#[inline(always)]
pub(crate) fn coning(prev: V3, cur: V3) -> V3 {
    cur + prev.cross(&cur) * (1.0 / 12.0)
}

/// The body-frame velocity increment with rotation and two-sample sculling
/// corrections: Δv + ½ Δθ × Δv + (1/12)(Δθ_{k−1} × Δv + Δv_{k−1} × Δθ).
#[inline(always)]
pub(crate) fn sculling(prev: &ImuIncrement, cur: &ImuIncrement) -> V3 {
    let rot = cur.dtheta.cross(&cur.dv) * 0.5;
    let scul = (prev.dtheta.cross(&cur.dv) + prev.dv.cross(&cur.dtheta)) * (1.0 / 12.0);
    cur.dv + rot + scul
}

/// The Earth state at the mid-point of the coming step, extrapolated from the
/// state at its start, the previous step's ENU acceleration and the previous
/// Earth state's position rates. Shared by the forward mechanization and the
/// inverse (truth to IMU) so that the two are exact inverses.
#[inline(always)]
pub(crate) fn mid_step_earth(
    s: &NavState,
    acc_n: V3,
    prev_eth: &EarthState,
    dt: f64,
) -> EarthState {
    let half = 0.5 * dt;
    let v_mid = s.v + acc_n * half;
    let pr = prev_eth.position_rate(v_mid.into());
    EarthState::new(s.lat + pr[0] * half, s.h + pr[2] * half, v_mid.into())
}

/// Integrates geodetic position over one step from the velocities at its two
/// ends, with the same mid-step Earth state as the mechanization (trapezoid
/// rule). Truth generators use it so that truth and navigator integrate
/// position alike; it returns the new (lat, lon, h) and the mid-step Earth state
/// to pass as `prev_eth` next time.
#[derive(Debug, Clone, Copy)]
pub struct PositionIntegrator {
    acc_n: V3,
    eth: EarthState,
}

impl PositionIntegrator {
    /// Starts at state `s`.
    pub fn new(s: &NavState) -> Self {
        Self {
            acc_n: V3::zeros(),
            eth: EarthState::new(s.lat, s.h, s.v.into()),
        }
    }

    /// Position at the end of a step of `dt` from `s0` whose end velocity is `v1`.
    #[inline]
    pub fn advance(&mut self, s0: &NavState, v1: V3, dt: f64) -> (f64, f64, f64) {
        let eth = mid_step_earth(s0, self.acc_n, &self.eth, dt);
        let pr = eth.position_rate(((s0.v + v1) * 0.5).into());
        self.acc_n = (v1 - s0.v) * (1.0 / dt);
        self.eth = eth;
        (s0.lat + pr[0] * dt, s0.lon + pr[1] * dt, s0.h + pr[2] * dt)
    }
}

/// The strapdown navigator.
#[derive(Debug, Clone)]
pub struct Strapdown {
    /// The current solution.
    pub state: NavState,
    /// Sampling interval (s).
    pub dt: f64,
    prev: ImuIncrement,
    acc_n: V3,
    eth: EarthState,
}

impl Strapdown {
    /// A navigator starting from `state`, with IMU sampling interval `dt` (s).
    pub fn new(state: NavState, dt: f64) -> Self {
        Self {
            eth: EarthState::new(state.lat, state.h, state.v.into()),
            state,
            dt,
            prev: ImuIncrement::default(),
            acc_n: V3::zeros(),
        }
    }

    /// The Earth state used in the last step.
    pub fn earth(&self) -> &EarthState {
        &self.eth
    }

    /// The ENU acceleration of the last step (m/s²).
    pub fn acceleration(&self) -> V3 {
        self.acc_n
    }

    /// Replaces velocity (and forgets the acceleration used for extrapolation),
    /// e.g. when another sensor resets it.
    pub fn reset_velocity(&mut self, v: V3) {
        self.state.v = v;
        self.acc_n = V3::zeros();
    }

    /// One mechanization step with the increments of one IMU sample.
    #[inline]
    pub fn step(&mut self, inc: &ImuIncrement) {
        let dt = self.dt;
        let s = &mut self.state;
        let eth = mid_step_earth(s, self.acc_n, &self.eth, dt);
        let wdt = V3::from(eth.w_in) * dt;
        // Velocity: specific force rotated into n (at the start attitude, with the
        // half-step rotation of the n frame), plus gravity less Coriolis.
        let dvn0 = s.q * sculling(&self.prev, inc);
        let dvn = dvn0 - wdt.cross(&dvn0) * 0.5;
        let v_new = s.v + dvn + V3::from(eth.g_cc) * dt;
        self.acc_n = (v_new - s.v) * (1.0 / dt);
        // Position: trapezoid rule with the mid-step radii.
        let pr = eth.position_rate(((s.v + v_new) * 0.5).into());
        s.lat += pr[0] * dt;
        s.lon += pr[1] * dt;
        s.h += pr[2] * dt;
        s.v = v_new;
        // Attitude: body rotation φ, then the navigation frame's rotation ω_in dt.
        let phi = coning(self.prev.dtheta, inc.dtheta);
        s.q = (Quat::from_rotvec(-wdt) * (s.q * Quat::from_rotvec(phi))).normalized();
        self.eth = eth;
        self.prev = *inc;
    }
}

/// Turns consecutive truth states into the IMU increments that make the
/// forward mechanization ([`Strapdown::step`]) reproduce them: the inverse
/// strapdown. It is generic: any reference path sampled at the IMU rate (motion
/// commands, a road route, a recorded trajectory) becomes ideal IMU data.
#[derive(Debug, Clone)]
pub struct InverseStrapdown {
    dt: f64,
    last: Option<NavState>,
    prev: ImuIncrement,
    acc_n: V3,
    eth: EarthState,
}

impl InverseStrapdown {
    /// An inverse for sampling interval `dt` (s).
    pub fn new(dt: f64) -> Self {
        Self {
            dt,
            last: None,
            prev: ImuIncrement::default(),
            acc_n: V3::zeros(),
            eth: EarthState::default(),
        }
    }

    /// Feeds the next truth state; returns the increments of the interval that
    /// ends at it (None for the first state).
    pub fn push(&mut self, s1: &NavState) -> Option<ImuIncrement> {
        let Some(s0) = self.last.replace(*s1) else {
            self.eth = EarthState::new(s1.lat, s1.h, s1.v.into());
            return None;
        };
        let dt = self.dt;
        let eth = mid_step_earth(&s0, self.acc_n, &self.eth, dt);
        let wdt = V3::from(eth.w_in) * dt;
        // Attitude: q1 = q(−ω_in dt) q0 q(φ)  ⇒  q(φ) = q0* q(ω_in dt) q1.
        let qphi = s0.q.conjugate() * Quat::from_rotvec(wdt) * s1.q;
        let phi = qphi.to_rotvec();
        // Solve Δθ + (1/12) Δθ_prev × Δθ = φ (contraction: |Δθ_prev|/12 ≪ 1).
        let mut dtheta = phi;
        for _ in 0..4 {
            dtheta = phi - self.prev.dtheta.cross(&dtheta) * (1.0 / 12.0);
        }
        // Velocity: Δv^n = v1 − v0 − g_cc dt = (I − ½[ω_in dt ×]) C Δv_sf^b.
        let dvn = s1.v - s0.v - V3::from(eth.g_cc) * dt;
        let mut dvn0 = dvn;
        for _ in 0..3 {
            dvn0 = dvn + wdt.cross(&dvn0) * 0.5;
        }
        let dvb = s0.q.inverse_transform_vector(&dvn0);
        // Solve Δv + ½Δθ×Δv + (1/12)(Δθ_prev×Δv + Δv_prev×Δθ) = Δv_sf^b.
        let known = dvb - self.prev.dv.cross(&dtheta) * (1.0 / 12.0);
        let a = dtheta * 0.5 + self.prev.dtheta * (1.0 / 12.0);
        let mut dv = known;
        for _ in 0..5 {
            dv = known - a.cross(&dv);
        }
        let inc = ImuIncrement { dtheta, dv };
        self.acc_n = (s1.v - s0.v) * (1.0 / dt);
        self.eth = eth;
        self.prev = inc;
        Some(inc)
    }
}
