//! Truth trajectories along a road route ([`crate::route::Route`]).
//!
//! 1. Geometry: the route polyline (in the map's ENU plane) is smoothed with a
//!    circular arc tangent to both legs at every vertex, as large as the
//!    neighbouring legs allow (each vertex may use half of an inner leg), so
//!    the heading is continuous; where the route turns back on itself
//!    (|turn| > 150°) the vehicle stops and turns on the spot.
//! 2. Speed: the drivable speed is the least of the scenario's speed, the
//!    road's `maxspeed` and the curvature limit √(a_lat/|κ|); it is zero at the
//!    start, the end, stops and turns on the spot; forward and backward passes
//!    apply the acceleration and braking limits (v² changes linearly in
//!    distance, i.e. constant acceleration between profile nodes ≤ 1 m apart).
//! 3. Time: the profile gives the distance along the path at every IMU sample
//!    in closed form (constant acceleration per node interval).
//! 4. Truth: the heading at each sample is converted from the map plane to the
//!    sample's own local level frame (the meridian convergence of the map's
//!    tangent plane, computed numerically along the path every 50 m and
//!    interpolated), and position is integrated geodetically from speed and
//!    local heading with [`PositionIntegrator`], so truth position, velocity
//!    and attitude are consistent for the inverse strapdown. The integrated
//!    path follows the map's path to within the tangent-plane distortion
//!    (relative 1e-6 of the distance from the map's origin).
//! 5. Heights: constant (`height_m`), or a terrain profile along the route's
//!    chainage ([`RoutePlan::with_heights`], from [`super::route_heights`],
//!    resampled along the plan's own path): the vertical velocity is the
//!    horizontal speed times the grade, the pitch its arctangent, and the
//!    height is integrated with the position, so it follows the profile to
//!    the integration's rounding.

use super::Avp;
use crate::attitude::{wrap_pi, Quat, QuatExt, V3};
use crate::error::{Error, Result};
use crate::geodesy::{radii, EnuFrame};
use crate::nav::strapdown::{NavState, PositionIntegrator};
use crate::network::Network;
use crate::route::Route;

/// Limits of the drivable speed profile along a road route.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedProfile {
    /// Cruise speed wanted (m/s).
    pub speed_mps: f64,
    /// Lateral acceleration limit in curves (m/s²).
    pub max_lateral_accel_mps2: f64,
    /// Acceleration limit (m/s²).
    pub accel_mps2: f64,
    /// Braking limit (m/s²).
    pub brake_mps2: f64,
}

impl Default for SpeedProfile {
    fn default() -> Self {
        Self {
            speed_mps: 40.0 / 3.6,
            max_lateral_accel_mps2: 2.0,
            accel_mps2: 1.0,
            brake_mps2: 1.5,
        }
    }
}

/// Turns sharper than this (rad) are made on the spot after a stop.
pub const PIVOT_ANGLE: f64 = 150.0 * std::f64::consts::PI / 180.0;
/// Yaw rate of a turn on the spot (rad/s).
pub const PIVOT_RATE: f64 = 0.5;
/// Largest arc radius used at a vertex (m).
pub const MAX_ARC_RADIUS_M: f64 = 5000.0;
/// Half-width of the moving averages (applied twice) smoothing a height
/// profile along a plan's own path (m): see [`RoutePlan::with_heights`].
pub const PATH_HALF_WINDOW_M: f64 = 10.0;
/// Lowest speed limit anywhere except at stops (m/s).
pub const MIN_SPEED_MPS: f64 = 0.5;
/// Longest distance between two nodes of the speed profile (m).
const NODE_SPACING_M: f64 = 1.0;
/// Longest distance between two samples of the convergence correction (m).
const CONVERGENCE_STEP_M: f64 = 50.0;

/// One element of the smoothed path, in the map's ENU plane.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Elem {
    /// Path distance at the start (m).
    s0: f64,
    /// Length (m; zero for a turn on the spot).
    len: f64,
    /// Start point (m).
    p0: [f64; 2],
    /// Heading at the start, clockwise from the map's grid north (rad).
    psi0: f64,
    /// Curvature (1/m, positive turning right); 0 for a line.
    kappa: f64,
    /// Route chainage at the start and end (m).
    c0: f64,
    c1: f64,
}

impl Elem {
    /// Position and heading at path distance `s` within this element.
    #[inline]
    fn eval(&self, s: f64) -> ([f64; 2], f64) {
        let u = (s - self.s0).clamp(0.0, self.len);
        let psi = self.psi0 + self.kappa * u;
        let ku = self.kappa * u;
        let (dx, dy) = if ku.abs() < 1e-6 {
            // Series of the arc integrals; exact for a line.
            let (s0, c0) = self.psi0.sin_cos();
            let half = 0.5 * ku;
            (u * (s0 + half * c0), u * (c0 - half * s0))
        } else {
            let (s0, c0) = self.psi0.sin_cos();
            let (s1, c1) = psi.sin_cos();
            ((c0 - c1) / self.kappa, (s1 - s0) / self.kappa)
        };
        ([self.p0[0] + dx, self.p0[1] + dy], psi)
    }
}

/// A node of the speed profile.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Node {
    s: f64,
    v: f64,
    /// Arrival time (s).
    t: f64,
    /// Standing time at the node (s).
    dwell: f64,
    /// Heading change made standing at the node (rad, map plane).
    pivot: f64,
}

/// A road route made drivable: smoothed path, speed profile and timing.
#[derive(Debug, Clone)]
pub struct RoutePlan {
    dt: f64,
    frame: EnuFrame,
    height_m: f64,
    heights: Option<crate::elevation::HeightProfile>,
    elems: Vec<Elem>,
    nodes: Vec<Node>,
    /// Convergence correction (local heading − map heading, rad) every `conv_step` m.
    conv: Vec<f64>,
    conv_step: f64,
    /// Duration (s).
    pub duration_s: f64,
    /// Length of the smoothed path (m).
    pub distance_m: f64,
    /// Number of truth samples, the initial one included.
    pub samples: u64,
}

fn pos_heading(elems: &[Elem], s: f64) -> ([f64; 2], f64) {
    let i = elems
        .partition_point(|e| e.s0 + e.len < s)
        .min(elems.len() - 1);
    elems[i].eval(s)
}

/// Local heading minus map heading at a map-plane point, by converting a 1 m
/// step along the map heading (centred on the point) to the local level frame.
fn convergence(frame: &EnuFrame, p: [f64; 2], psi: f64, height: f64) -> f64 {
    let r = crate::geodesy::WGS84_A;
    let up = |q: [f64; 2]| height - (q[0] * q[0] + q[1] * q[1]) / (2.0 * r);
    // A central difference: reversing the direction reverses the heading exactly.
    let (sn, cs) = psi.sin_cos();
    let p0 = [p[0] - 0.5 * sn, p[1] - 0.5 * cs];
    let q = [p[0] + 0.5 * sn, p[1] + 0.5 * cs];
    let a = frame.to_geodetic([p0[0], p0[1], up(p0)]);
    let b = frame.to_geodetic([q[0], q[1], up(q)]);
    let (rm, rn) = radii(a.lat);
    let de = (b.lon - a.lon) * (rn + a.height) * a.lat.cos();
    let dn = (b.lat - a.lat) * (rm + a.height);
    wrap_pi(de.atan2(dn) - psi)
}

/// Memory of a [`RoutePlan`] (bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlanBytes {
    /// Held at once while [`RoutePlan::new`] builds it.
    pub peak: u64,
    /// Kept by the plan once built.
    pub kept: u64,
}

impl RoutePlan {
    /// Upper bounds of the memory of [`RoutePlan::new`] on a route whose
    /// polyline has `vertices` points and `spans` spans, with `stops` stops
    /// and at most `turns` turns on the spot, and whose smoothed path is at
    /// most `path_m` long: the buffers `new` allocates, each at its size,
    /// and none depends on `dt` (the samples are made as they are read).
    /// Per vertex: the polyline, its legs, tangents, turns, a line and an
    /// arc (the elements) and an arc's speed limit; per metre of path a
    /// speed-profile node, and one more per hard point (the start, the end,
    /// a stop, a turn on the spot); every `CONVERGENCE_STEP_M` a
    /// convergence correction. The plan keeps its elements, nodes and
    /// corrections.
    pub fn memory_bytes(
        vertices: u64,
        turns: u64,
        spans: u64,
        stops: u64,
        path_m: f64,
    ) -> PlanBytes {
        use std::mem::size_of;
        let size = |n: u64, bytes: usize| n.saturating_mul(bytes as u64);
        let sum = |terms: &[u64]| terms.iter().fold(0u64, |a, &b| a.saturating_add(b));
        let legs = vertices.saturating_sub(1);
        let hard = sum(&[2, stops, turns]);
        let nodes = sum(&[(path_m / NODE_SPACING_M).ceil() as u64, hard]);
        let conv = sum(&[(path_m / CONVERGENCE_STEP_M).ceil() as u64, 2]);
        let kept = sum(&[
            size(legs, 2 * size_of::<Elem>()), // a line and an arc per leg
            size(nodes, size_of::<Node>()),
            size(conv, size_of::<f64>()),
        ]);
        let temporary = sum(&[
            size(vertices, size_of::<([f64; 2], f64)>()), // points
            size(legs, size_of::<(f64, f64)>()),          // legs
            size(vertices, 2 * size_of::<f64>() + size_of::<bool>()), // tangents, turns
            size(turns, size_of::<(f64, f64)>()),         // turns on the spot
            size(hard, 2 * size_of::<(f64, f64, f64)>() + size_of::<usize>()), // hard points
            size(
                legs.saturating_add(spans),
                size_of::<(std::ops::Range<usize>, f64)>(),
            ), // speed limits
        ]);
        PlanBytes {
            peak: kept.saturating_add(temporary),
            kept,
        }
    }

    /// Makes a route drivable at sampling interval `dt` (s). `stops` are
    /// (chainage m, duration s); `height_m` is the constant height driven at.
    pub fn new(
        net: &Network,
        route: &Route,
        profile: &SpeedProfile,
        stops: &[(f64, f64)],
        height_m: f64,
        dt: f64,
    ) -> Result<RoutePlan> {
        // Polyline without repeated points.
        let mut pts: Vec<([f64; 2], f64)> = Vec::with_capacity(route.vertices.len());
        for v in &route.vertices {
            if let Some(last) = pts.last() {
                if (v.enu[0] - last.0[0]).hypot(v.enu[1] - last.0[1]) < 0.01 {
                    continue;
                }
            }
            pts.push((v.enu, v.chainage_m));
        }
        if pts.len() < 2 {
            return Err(Error::InvalidParameter(
                "the route is shorter than 1 cm; nothing to drive".into(),
            ));
        }
        let m = pts.len() - 1; // legs
        let legs: Vec<(f64, f64)> = (0..m)
            .map(|j| {
                let dx = pts[j + 1].0[0] - pts[j].0[0];
                let dy = pts[j + 1].0[1] - pts[j].0[1];
                (dx.hypot(dy), dx.atan2(dy))
            })
            .collect();
        // Tangent length, turn and kind at each vertex (0 and m: none).
        let mut tang = vec![0.0; m + 1];
        let mut turn = vec![0.0; m + 1];
        let mut pivot = vec![false; m + 1];
        for j in 1..m {
            let d = wrap_pi(legs[j].1 - legs[j - 1].1);
            turn[j] = d;
            if d.abs() < 1e-9 {
                continue;
            }
            if d.abs() > PIVOT_ANGLE {
                pivot[j] = true;
                continue;
            }
            let before = if j == 1 {
                legs[0].0
            } else {
                0.5 * legs[j - 1].0
            };
            let after = if j == m - 1 {
                legs[j].0
            } else {
                0.5 * legs[j].0
            };
            let t_max = before.min(after);
            let half = (0.5 * d.abs()).tan();
            let r = (t_max / half).min(MAX_ARC_RADIUS_M);
            tang[j] = r * half;
        }
        let mut elems = Vec::with_capacity(2 * m);
        let mut s = 0.0;
        let mut pivots: Vec<(f64, f64)> = Vec::with_capacity(pivot.iter().filter(|&&p| p).count());
        for j in 0..m {
            let (len, psi) = legs[j];
            let (sn, cs) = psi.sin_cos();
            let start = [pts[j].0[0] + tang[j] * sn, pts[j].0[1] + tang[j] * cs];
            let l = (len - tang[j] - tang[j + 1]).max(0.0);
            elems.push(Elem {
                s0: s,
                len: l,
                p0: start,
                psi0: psi,
                kappa: 0.0,
                c0: pts[j].1 + tang[j],
                c1: pts[j + 1].1 - tang[j + 1],
            });
            s += l;
            let k = j + 1;
            if k < m {
                if pivot[k] {
                    pivots.push((s, turn[k]));
                } else if tang[k] > 0.0 {
                    let r = tang[k] / (0.5 * turn[k].abs()).tan();
                    let arc = r * turn[k].abs();
                    elems.push(Elem {
                        s0: s,
                        len: arc,
                        p0: [pts[k].0[0] - tang[k] * sn, pts[k].0[1] - tang[k] * cs],
                        psi0: psi,
                        kappa: turn[k].signum() / r,
                        c0: pts[k].1 - tang[k],
                        c1: pts[k].1 + tang[k],
                    });
                    s += arc;
                }
            }
        }
        let total = s;
        if total < 1.0 {
            return Err(Error::InvalidParameter(format!(
                "the route is only {total:.2} m long; nothing to drive"
            )));
        }
        // Chainage → path distance.
        let s_of_c = |c: f64| -> f64 {
            let i = elems.partition_point(|e| e.c1 < c).min(elems.len() - 1);
            let e = &elems[i];
            if e.c1 > e.c0 {
                e.s0 + e.len * ((c - e.c0) / (e.c1 - e.c0)).clamp(0.0, 1.0)
            } else {
                e.s0
            }
        };
        // Hard points: start, end, stops, pivots.
        let mut hard: Vec<(f64, f64, f64)> = Vec::with_capacity(2 + stops.len() + pivots.len());
        hard.extend([(0.0, 0.0, 0.0), (total, 0.0, 0.0)]);
        for &(c, d) in stops {
            if c > route.length_m + 1e-6 {
                return Err(Error::InvalidParameter(format!(
                    "stop at {c} m is beyond the route's end ({:.1} m)",
                    route.length_m
                )));
            }
            hard.push((s_of_c(c), d, 0.0));
        }
        for &(sp, d) in &pivots {
            hard.push((sp, d.abs() / PIVOT_RATE, d));
        }
        hard.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut merged: Vec<(f64, f64, f64)> = Vec::with_capacity(hard.len());
        for h in hard {
            match merged.last_mut() {
                Some(last) if h.0 - last.0 < 0.01 => {
                    last.1 += h.1;
                    last.2 += h.2;
                }
                _ => merged.push(h),
            }
        }
        // Profile nodes ≤ 1 m apart with exact nodes at hard points (their
        // number counted first: the buffers are allocated at their size,
        // which `RoutePlan::memory_bytes` bounds).
        let steps = |s0: f64, s1: f64| ((s1 - s0) / NODE_SPACING_M).ceil().max(1.0) as usize;
        let count = merged.len()
            + merged
                .windows(2)
                .map(|w| steps(w[0].0, w[1].0) - 1)
                .sum::<usize>();
        let mut nodes: Vec<Node> = Vec::with_capacity(count);
        let mut zero = Vec::with_capacity(merged.len());
        for w in 0..merged.len() {
            let (s0, dwell, pv) = merged[w];
            zero.push(nodes.len());
            nodes.push(Node {
                s: s0,
                v: 0.0,
                t: 0.0,
                dwell,
                pivot: pv,
            });
            if w + 1 < merged.len() {
                let s1 = merged[w + 1].0;
                let n = steps(s0, s1);
                for i in 1..n {
                    nodes.push(Node {
                        s: s0 + (s1 - s0) * i as f64 / n as f64,
                        v: f64::INFINITY,
                        t: 0.0,
                        dwell: 0.0,
                        pivot: 0.0,
                    });
                }
            }
        }
        // Speed limits.
        let vset = profile.speed_mps;
        for nd in nodes.iter_mut() {
            if nd.v > 0.0 {
                nd.v = vset;
            }
        }
        let node_range = |a: f64, b: f64| -> std::ops::Range<usize> {
            let i0 = nodes.partition_point(|n| n.s < a);
            let i1 = nodes.partition_point(|n| n.s <= b);
            i0..i1.max(i0)
        };
        let mut limits: Vec<(std::ops::Range<usize>, f64)> =
            Vec::with_capacity(elems.iter().filter(|e| e.kappa != 0.0).count() + route.spans.len());
        for e in &elems {
            if e.kappa != 0.0 {
                let v = (profile.max_lateral_accel_mps2 / e.kappa.abs())
                    .sqrt()
                    .max(MIN_SPEED_MPS);
                limits.push((node_range(e.s0 - 1.0, e.s0 + e.len + 1.0), v));
            }
        }
        for sp in &route.spans {
            if let Some(kmh) = net.model.roads[sp.road as usize].attributes.maxspeed_kmh {
                if kmh.is_finite() && kmh > 0.0 {
                    let v = (kmh / 3.6).max(MIN_SPEED_MPS);
                    limits.push((
                        node_range(s_of_c(sp.start_chainage_m), s_of_c(sp.end_chainage_m)),
                        v,
                    ));
                }
            }
        }
        for (r, v) in limits {
            for nd in &mut nodes[r] {
                nd.v = nd.v.min(v);
            }
        }
        for &z in &zero {
            nodes[z].v = 0.0;
        }
        // Acceleration (forward) and braking (backward) passes.
        for i in 1..nodes.len() {
            let ds = nodes[i].s - nodes[i - 1].s;
            let vmax = (nodes[i - 1].v.powi(2) + 2.0 * profile.accel_mps2 * ds).sqrt();
            nodes[i].v = nodes[i].v.min(vmax);
        }
        for i in (0..nodes.len() - 1).rev() {
            let ds = nodes[i + 1].s - nodes[i].s;
            let vmax = (nodes[i + 1].v.powi(2) + 2.0 * profile.brake_mps2 * ds).sqrt();
            nodes[i].v = nodes[i].v.min(vmax);
        }
        // Timing.
        let mut t = 0.0;
        for i in 0..nodes.len() {
            if i > 0 {
                let ds = nodes[i].s - nodes[i - 1].s;
                let vs = (nodes[i].v + nodes[i - 1].v).max(1e-3);
                t += 2.0 * ds / vs;
            }
            nodes[i].t = t;
            t += nodes[i].dwell;
        }
        // Arrival at the last node; its dwell (if a stop was put at the end) counts too.
        let duration = t;
        // Enough samples to arrive: the last one is at rest at the end.
        let samples = (duration / dt - 1e-9).ceil().max(0.0) as u64 + 1;
        // Convergence correction along the path.
        let frame = net.model.frame;
        let intervals = (total / CONVERGENCE_STEP_M).ceil().max(1.0);
        let conv_step = total / intervals;
        let conv = (0..=intervals as usize)
            .map(|i| {
                let (p, psi) = pos_heading(&elems, (i as f64 * conv_step).min(total));
                convergence(&frame, p, psi, height_m)
            })
            .collect();
        Ok(RoutePlan {
            dt,
            frame,
            height_m,
            heights: None,
            elems,
            nodes,
            conv,
            conv_step,
            duration_s: (samples - 1) as f64 * dt,
            distance_m: total,
            samples,
        })
    }

    /// Path distance, speed and (map-plane) heading override at time `t`,
    /// starting the node search at `*hint`.
    #[inline]
    fn at_time(&self, t: f64, hint: &mut usize) -> (f64, f64, Option<f64>) {
        let n = &self.nodes;
        let mut i = *hint;
        while i + 1 < n.len() && t >= n[i + 1].t {
            i += 1;
        }
        *hint = i;
        let nd = n[i];
        let leave = nd.t + nd.dwell;
        if t <= leave || i + 1 == n.len() {
            let pivot = if nd.pivot != 0.0 && nd.dwell > 0.0 {
                Some(nd.pivot * ((t - nd.t) / nd.dwell).clamp(0.0, 1.0))
            } else {
                None
            };
            return (
                nd.s,
                0.0,
                pivot.or(if nd.pivot != 0.0 {
                    Some(nd.pivot)
                } else {
                    None
                }),
            );
        }
        let nx = n[i + 1];
        let ds = nx.s - nd.s;
        let a = (nx.v * nx.v - nd.v * nd.v) / (2.0 * ds);
        let tau = t - leave;
        let s = (nd.s + nd.v * tau + 0.5 * a * tau * tau).min(nx.s);
        let v = (nd.v + a * tau).max(0.0);
        (s, v, None)
    }

    /// Position in the map plane (m) at path distance `s` and the map heading.
    pub fn map_point(&self, s: f64) -> ([f64; 2], f64) {
        pos_heading(&self.elems, s)
    }

    /// The route chainage (m) at path distance `s`: interpolated within the
    /// element holding `s` (a smoothing arc spans the chainage of its two
    /// tangents).
    pub fn chainage_at(&self, s: f64) -> f64 {
        let e = &self.elems[self
            .elems
            .partition_point(|e| e.s0 + e.len < s)
            .min(self.elems.len() - 1)];
        if e.len > 0.0 {
            e.c0 + (e.c1 - e.c0) * ((s - e.s0) / e.len).clamp(0.0, 1.0)
        } else {
            e.c0
        }
    }

    /// Drives the terrain's heights: `profile` (heights along the route's
    /// chainage, from [`super::route_heights`]) replaces the constant
    /// height. The plan resamples it along its own path every
    /// [`crate::elevation::PROFILE_STEP_M`] and smooths it over
    /// ±[`PATH_HALF_WINDOW_M`] (twice): a lane path's chainage advances
    /// unevenly (on the inside of a sharp corner several metres of chainage
    /// pass in a metre of path), which would otherwise show as steps of grade.
    pub fn with_heights(mut self, profile: &crate::elevation::HeightProfile) -> RoutePlan {
        let n = (self.distance_m / crate::elevation::PROFILE_STEP_M)
            .ceil()
            .max(1.0) as usize;
        let step = self.distance_m / n as f64;
        let raw: Vec<f64> = (0..=n)
            .map(|i| profile.height_at(self.chainage_at(i as f64 * step)))
            .collect();
        self.heights = Some(crate::elevation::HeightProfile::smoothed(
            step,
            &raw,
            PATH_HALF_WINDOW_M,
        ));
        self
    }

    /// The terrain height profile driven, along the plan's path distance
    /// (not the route's chainage), if any.
    pub fn heights(&self) -> Option<&crate::elevation::HeightProfile> {
        self.heights.as_ref()
    }

    /// Height (m) and grade (rise per metre of path) at path distance `s`.
    #[inline]
    fn height_grade(&self, s: f64) -> (f64, f64) {
        match &self.heights {
            None => (self.height_m, 0.0),
            Some(h) => (h.height_at(s), h.grade_at(s)),
        }
    }

    /// The truth samples, the initial one first.
    pub fn trajectory(&self) -> RouteTrajectory<'_> {
        let (p, psi) = self.elems[0].eval(0.0);
        let (h0, grade) = self.height_grade(0.0);
        let g = self.frame.to_geodetic([
            p[0],
            p[1],
            h0 - (p[0] * p[0] + p[1] * p[1]) / (2.0 * crate::geodesy::WGS84_A),
        ]);
        let heading = psi + self.conv[0];
        let state = NavState {
            q: Quat::from_heading_pitch_roll(heading, grade.atan(), 0.0),
            v: V3::zeros(),
            lat: g.lat,
            lon: g.lon,
            h: h0,
        };
        RouteTrajectory {
            plan: self,
            k: 0,
            hint: 0,
            elem: 0,
            integ: PositionIntegrator::new(&state),
            state,
            distance: 0.0,
            last_s: 0.0,
        }
    }
}

/// The truth samples of a [`RoutePlan`].
#[derive(Debug, Clone)]
pub struct RouteTrajectory<'a> {
    plan: &'a RoutePlan,
    k: u64,
    hint: usize,
    elem: usize,
    integ: PositionIntegrator,
    state: NavState,
    distance: f64,
    last_s: f64,
}

impl Iterator for RouteTrajectory<'_> {
    type Item = Avp;

    #[inline]
    fn next(&mut self) -> Option<Avp> {
        let p = self.plan;
        if self.k >= p.samples {
            return None;
        }
        let k = self.k;
        self.k += 1;
        if k == 0 {
            return Some(Avp {
                t: 0.0,
                distance_m: 0.0,
                state: self.state,
            });
        }
        let t = k as f64 * p.dt;
        let (s, v, pivot) = p.at_time(t, &mut self.hint);
        // Map heading at s: the element containing s (monotone search).
        while self.elem + 1 < p.elems.len() && s > p.elems[self.elem].s0 + p.elems[self.elem].len {
            self.elem += 1;
        }
        let e = &p.elems[self.elem];
        let mut psi = e.psi0 + e.kappa * (s - e.s0).clamp(0.0, e.len);
        if let Some(dp) = pivot {
            // Standing at a turn on the spot: heading from the incoming one.
            let before = if self.elem > 0 && (s - e.s0).abs() < 1e-9 {
                let pe = &p.elems[self.elem - 1];
                pe.psi0 + pe.kappa * pe.len
            } else {
                psi
            };
            psi = before + dp;
        }
        let ci = s / p.conv_step;
        let i0 = (ci.floor() as usize).min(p.conv.len() - 1);
        let i1 = (i0 + 1).min(p.conv.len() - 1);
        let f = ci - i0 as f64;
        let heading = psi + p.conv[i0] * (1.0 - f) + p.conv[i1] * f;
        let (sh, ch) = heading.sin_cos();
        let (_, grade) = p.height_grade(s);
        let v1 = V3::new(v * sh, v * ch, v * grade);
        let s0 = self.state;
        let (lat, lon, h) = self.integ.advance(&s0, v1, p.dt);
        self.distance += s - self.last_s;
        self.last_s = s;
        self.state = NavState {
            q: Quat::from_heading_pitch_roll(heading, grade.atan(), 0.0),
            v: v1,
            lat,
            lon,
            h,
        };
        Some(Avp {
            t,
            distance_m: self.distance,
            state: self.state,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = (self.plan.samples - self.k) as usize;
        (n, Some(n))
    }
}
