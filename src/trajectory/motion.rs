//! Trajectories from motion commands without a map, in the manner of PSINS
//! `trjsegment` and gnss-ins-sim motion files: stay, accelerate or decelerate
//! to a speed, cruise for a time or a distance, turn by an angle at a radius,
//! climb or descend at a grade.
//!
//! Each command becomes segments of whole IMU samples with constant rates of
//! speed, heading and pitch; the vehicle's velocity is along its forward axis
//! (no sideslip); position is integrated geodetically
//! ([`crate::nav::strapdown::PositionIntegrator`]). Headings are clockwise from
//! local north, so a constant heading is a rhumb line.

use super::Avp;
use crate::attitude::{Quat, QuatExt, V3};
use crate::error::{Error, Result};
use crate::nav::strapdown::{NavState, PositionIntegrator};

/// Lateral acceleration above which a turn is refused (m/s², 0.8 g).
pub const MAX_LATERAL_ACCEL: f64 = 0.8 * 9.81;
/// Longitudinal acceleration above which a speed change is refused (m/s², 1 g).
pub const MAX_LONGITUDINAL_ACCEL: f64 = 9.81;
/// Steepest grade accepted (pitch 45°).
pub const MAX_GRADE: f64 = 1.0;
/// Highest speed accepted (m/s; 400 km/h).
pub const MAX_SPEED: f64 = 400.0 / 3.6;
/// Longest trajectory accepted (s; 30 days).
pub const MAX_DURATION_S: f64 = 30.0 * 86_400.0;

/// How long a command lasts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Extent {
    /// A time (s).
    Duration(f64),
    /// A distance along the path (m).
    Distance(f64),
}

/// One motion command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Stand still for a time (s).
    Stay {
        /// Duration (s).
        duration_s: f64,
    },
    /// Change speed at a constant rate to a target (m/s); `accel_mps2` is the
    /// magnitude of the acceleration or deceleration.
    ChangeSpeed {
        /// Target speed (m/s).
        to_mps: f64,
        /// Magnitude of the acceleration (m/s²).
        accel_mps2: f64,
        /// `true` for a deceleration (the target must be below the speed).
        decelerate: bool,
    },
    /// Hold speed, heading and pitch.
    Cruise {
        /// For how long.
        extent: Extent,
    },
    /// Turn at constant speed by an angle (rad, positive to the right, i.e.
    /// clockwise seen from above) on a circle of the given radius (m).
    Turn {
        /// Angle (rad).
        angle: f64,
        /// Radius (m).
        radius_m: f64,
    },
    /// Pitch to a grade (rise over run; negative descends) at `pitch_rate`
    /// (rad/s), hold it for the extent, and pitch back to the previous grade.
    Climb {
        /// Grade (tan of the pitch angle).
        grade: f64,
        /// How long the grade is held (the pitch ramps come on top).
        extent: Extent,
        /// Pitch rate of the ramps (rad/s).
        pitch_rate: f64,
    },
}

/// Initial position, attitude and speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start {
    /// Latitude (rad).
    pub lat: f64,
    /// Longitude (rad).
    pub lon: f64,
    /// Height (m).
    pub h: f64,
    /// Heading clockwise from north (rad).
    pub heading: f64,
    /// Pitch (rad).
    pub pitch: f64,
    /// Roll (rad).
    pub roll: f64,
    /// Speed (m/s).
    pub speed_mps: f64,
}

/// A segment of whole samples with constant rates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    samples: u64,
    accel: f64,
    heading_rate: f64,
    pitch_rate: f64,
}

/// Motion commands compiled into samples at an IMU rate.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionPlan {
    start: Start,
    dt: f64,
    segments: Vec<Segment>,
    /// Samples in all, the initial one included.
    pub samples: u64,
    /// Duration (s).
    pub duration_s: f64,
    /// Path length (m).
    pub distance_m: f64,
}

fn bad(i: usize, what: &str, msg: impl std::fmt::Display) -> Error {
    Error::InvalidParameter(format!("route.motion[{i}] ({what}): {msg}"))
}

fn positive(i: usize, what: &str, field: &str, x: f64) -> Result<f64> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(bad(
            i,
            what,
            format!("{field} must be a positive number, got {x}"),
        ))
    }
}

impl MotionPlan {
    /// Compiles commands at sampling interval `dt` (s). Motions that cannot be
    /// driven (turning or climbing while stopped, a deceleration to a higher
    /// speed, lateral acceleration over 0.8 g, ...) are errors naming the command.
    pub fn new(start: Start, commands: &[Motion], dt: f64) -> Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::InvalidParameter(format!(
                "sampling interval must be positive, got {dt}"
            )));
        }
        for (name, x) in [
            ("lat", start.lat),
            ("lon", start.lon),
            ("height", start.h),
            ("heading", start.heading),
            ("pitch", start.pitch),
            ("roll", start.roll),
            ("speed", start.speed_mps),
        ] {
            if !x.is_finite() {
                return Err(Error::InvalidParameter(format!(
                    "route.start.{name} must be a finite number"
                )));
            }
        }
        if start.lat.abs() > 89f64.to_radians() {
            return Err(Error::InvalidParameter(
                "route.start.lat must be within ±89° (the ENU mechanization is singular at the poles)"
                    .into(),
            ));
        }
        if start.pitch.abs() > MAX_GRADE.atan() + 1e-12 || start.roll.abs() > 60f64.to_radians() {
            return Err(Error::InvalidParameter(
                "route.start: pitch must be within ±45° and roll within ±60°".into(),
            ));
        }
        if !(0.0..=MAX_SPEED).contains(&start.speed_mps) {
            return Err(Error::InvalidParameter(format!(
                "route.start.speed must be between 0 and {} km/h",
                MAX_SPEED * 3.6
            )));
        }
        // Capped so that no count can overflow; the total is checked below.
        let samples_for =
            |t: f64| -> u64 { ((t.min(2.0 * MAX_DURATION_S) / dt).round() as u64).max(1) };
        let mut segs = Vec::new();
        let mut v = start.speed_mps;
        let pitch = start.pitch;
        let mut distance = 0.0;
        let push = |segs: &mut Vec<Segment>, n: u64, a: f64, hr: f64, pr: f64, v0: f64| {
            segs.push(Segment {
                samples: n,
                accel: a,
                heading_rate: hr,
                pitch_rate: pr,
            });
            let t = n as f64 * dt;
            v0 * t + 0.5 * a * t * t
        };
        for (i, m) in commands.iter().enumerate() {
            match *m {
                Motion::Stay { duration_s } => {
                    let d = positive(i, "stay", "duration_s", duration_s)?;
                    if v > 0.0 {
                        return Err(bad(
                            i,
                            "stay",
                            format!(
                                "the vehicle is moving at {:.1} km/h; decelerate to 0 first",
                                v * 3.6
                            ),
                        ));
                    }
                    distance += push(&mut segs, samples_for(d), 0.0, 0.0, 0.0, v);
                }
                Motion::ChangeSpeed {
                    to_mps,
                    accel_mps2,
                    decelerate,
                } => {
                    let what = if decelerate {
                        "decelerate"
                    } else {
                        "accelerate"
                    };
                    let a = positive(i, what, "accel_mps2", accel_mps2)?;
                    if a > MAX_LONGITUDINAL_ACCEL {
                        return Err(bad(
                            i,
                            what,
                            format!("{a} m/s² is more than a vehicle can do (limit 9.81 m/s²)"),
                        ));
                    }
                    if !(to_mps.is_finite() && (0.0..=MAX_SPEED).contains(&to_mps)) {
                        return Err(bad(
                            i,
                            what,
                            format!("to_kmh must be between 0 and {}", MAX_SPEED * 3.6),
                        ));
                    }
                    if decelerate && to_mps >= v {
                        return Err(bad(
                            i,
                            what,
                            format!(
                                "cannot decelerate to {:.1} km/h from {:.1} km/h",
                                to_mps * 3.6,
                                v * 3.6
                            ),
                        ));
                    }
                    if !decelerate && to_mps <= v {
                        return Err(bad(
                            i,
                            what,
                            format!(
                                "cannot accelerate to {:.1} km/h from {:.1} km/h",
                                to_mps * 3.6,
                                v * 3.6
                            ),
                        ));
                    }
                    let n = samples_for((to_mps - v).abs() / a);
                    let acc = (to_mps - v) / (n as f64 * dt);
                    distance += push(&mut segs, n, acc, 0.0, 0.0, v);
                    v = to_mps;
                }
                Motion::Cruise { extent } => {
                    let t = match extent {
                        Extent::Duration(t) => positive(i, "cruise", "duration_s", t)?,
                        Extent::Distance(d) => {
                            let d = positive(i, "cruise", "distance_m", d)?;
                            if v <= 0.0 {
                                return Err(bad(
                                    i,
                                    "cruise",
                                    "cannot cruise a distance while stopped; accelerate first",
                                ));
                            }
                            d / v
                        }
                    };
                    distance += push(&mut segs, samples_for(t), 0.0, 0.0, 0.0, v);
                }
                Motion::Turn { angle, radius_m } => {
                    if !(angle.is_finite() && angle != 0.0) {
                        return Err(bad(i, "turn", "angle_deg must be a non-zero number"));
                    }
                    let r = positive(i, "turn", "radius_m", radius_m)?;
                    if v <= 0.0 {
                        return Err(bad(
                            i,
                            "turn",
                            "cannot turn while stopped; accelerate first",
                        ));
                    }
                    let lat_acc = v * v / r;
                    if lat_acc > MAX_LATERAL_ACCEL {
                        return Err(bad(
                            i,
                            "turn",
                            format!(
                                "a {r} m radius at {:.1} km/h needs {lat_acc:.1} m/s² lateral acceleration (limit {MAX_LATERAL_ACCEL:.2})",
                                v * 3.6
                            ),
                        ));
                    }
                    let n = samples_for(angle.abs() * r / v);
                    let rate = angle / (n as f64 * dt);
                    distance += push(&mut segs, n, 0.0, rate, 0.0, v);
                }
                Motion::Climb {
                    grade,
                    extent,
                    pitch_rate,
                } => {
                    let what = if grade >= 0.0 { "climb" } else { "descend" };
                    if !(grade.is_finite() && grade.abs() <= MAX_GRADE) {
                        return Err(bad(i, what, "grade_percent must be within ±100"));
                    }
                    let pr = positive(i, what, "pitch_rate_dps", pitch_rate)?;
                    if v <= 0.0 {
                        return Err(bad(
                            i,
                            what,
                            "cannot change grade while stopped; accelerate first",
                        ));
                    }
                    let target = grade.atan();
                    let ramp = target - pitch;
                    let hold = match extent {
                        Extent::Duration(t) => positive(i, what, "duration_s", t)?,
                        Extent::Distance(d) => positive(i, what, "distance_m", d)? / v,
                    };
                    if ramp.abs() > 0.0 {
                        let n = samples_for(ramp.abs() / pr);
                        distance += push(&mut segs, n, 0.0, 0.0, ramp / (n as f64 * dt), v);
                    }
                    distance += push(&mut segs, samples_for(hold), 0.0, 0.0, 0.0, v);
                    if ramp.abs() > 0.0 {
                        let n = samples_for(ramp.abs() / pr);
                        distance += push(&mut segs, n, 0.0, 0.0, -ramp / (n as f64 * dt), v);
                    }
                    // The ramps back leave the pitch as it was before the command.
                }
            }
        }
        let n: u64 = segs.iter().map(|s| s.samples).sum();
        if n as f64 * dt > MAX_DURATION_S {
            // "At least": each command's samples were capped at 60 days.
            return Err(Error::InvalidParameter(format!(
                "route.motion: the commands last at least {:.0} s, more than the 30 days accepted",
                n as f64 * dt
            )));
        }
        Ok(Self {
            start,
            dt,
            segments: segs,
            samples: n + 1,
            duration_s: n as f64 * dt,
            distance_m: distance,
        })
    }

    /// The sampling interval (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The truth samples, the initial one first.
    pub fn trajectory(&self) -> MotionTrajectory {
        let s = self.start;
        let state = state_of(&s, s.speed_mps, s.heading, s.pitch);
        MotionTrajectory {
            plan_segments: self.segments.clone(),
            dt: self.dt,
            roll: s.roll,
            seg: 0,
            i_in_seg: 0,
            seg_v0: s.speed_mps,
            seg_h0: s.heading,
            seg_p0: s.pitch,
            k: 0,
            distance: 0.0,
            integ: PositionIntegrator::new(&state),
            state,
            started: false,
            remaining: self.samples,
        }
    }
}

fn state_of(s: &Start, v: f64, heading: f64, pitch: f64) -> NavState {
    NavState {
        q: Quat::from_heading_pitch_roll(heading, pitch, s.roll),
        v: velocity(v, heading, pitch),
        lat: s.lat,
        lon: s.lon,
        h: s.h,
    }
}

#[inline]
fn velocity(v: f64, heading: f64, pitch: f64) -> V3 {
    let (sh, ch) = heading.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    V3::new(v * cp * sh, v * cp * ch, v * sp)
}

/// The truth samples of a [`MotionPlan`].
#[derive(Debug, Clone)]
pub struct MotionTrajectory {
    plan_segments: Vec<Segment>,
    dt: f64,
    roll: f64,
    seg: usize,
    i_in_seg: u64,
    seg_v0: f64,
    seg_h0: f64,
    seg_p0: f64,
    k: u64,
    distance: f64,
    integ: PositionIntegrator,
    state: NavState,
    started: bool,
    remaining: u64,
}

impl Iterator for MotionTrajectory {
    type Item = Avp;

    #[inline]
    fn next(&mut self) -> Option<Avp> {
        if self.remaining == 0 {
            return None;
        }
        self.remaining -= 1;
        if !self.started {
            self.started = true;
            return Some(Avp {
                t: 0.0,
                distance_m: 0.0,
                state: self.state,
            });
        }
        let mut s = self.plan_segments[self.seg];
        if self.i_in_seg == s.samples {
            // Next segment starts from the exact end values of this one.
            let t = s.samples as f64 * self.dt;
            self.seg_v0 += s.accel * t;
            self.seg_h0 += s.heading_rate * t;
            self.seg_p0 += s.pitch_rate * t;
            self.seg += 1;
            self.i_in_seg = 0;
            s = self.plan_segments[self.seg];
        }
        self.i_in_seg += 1;
        self.k += 1;
        let tau = self.i_in_seg as f64 * self.dt;
        let v = (self.seg_v0 + s.accel * tau).max(0.0);
        let heading = self.seg_h0 + s.heading_rate * tau;
        let pitch = self.seg_p0 + s.pitch_rate * tau;
        let v1 = velocity(v, heading, pitch);
        let s0 = self.state;
        let (lat, lon, h) = self.integ.advance(&s0, v1, self.dt);
        let speed0 = s0.v.norm();
        self.distance += 0.5 * (speed0 + v) * self.dt;
        self.state = NavState {
            q: Quat::from_heading_pitch_roll(heading, pitch, self.roll),
            v: v1,
            lat,
            lon,
            h,
        };
        Some(Avp {
            t: self.k as f64 * self.dt,
            distance_m: self.distance,
            state: self.state,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.remaining as usize, Some(self.remaining as usize))
    }
}
