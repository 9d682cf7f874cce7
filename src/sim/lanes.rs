//! The vehicle in its lane (issue 12, point 1): the truth of a map route
//! drives the centre of a lane of its direction, not the road's centre line,
//! wandering about it and changing lanes now and then on multi-lane roads.
//!
//! How the lane path is made. The route's smoothed centre path
//! ([`RoutePlan`]) is sampled every [`RESAMPLE_M`]; each sample is moved to
//! the right of the direction of travel by the lateral offset
//! l(s) = lane(s) + wander(s), and the moved points become the polyline of a
//! new route (same chainage, spans and stops) that [`RoutePlan`] makes
//! drivable again. So the lane path gets its own smoothing arcs (radius
//! R − l on the inside of a bend of radius R), its own curvature speed
//! limits and a consistent truth for the inverse strapdown: nothing is
//! shifted after the fact. Where a bend is tighter than the offset (a
//! junction corner on the inside) the moved points would run backwards; such
//! points are dropped, so the lane path cuts the corner as a vehicle does.
//!
//! - lane(s): the offset of the current lane ([`lane_offset_m`]: the road's
//!   `lanes` / `width` or its class, and `drive_side`). The first lane is
//!   drawn uniformly among those of the direction; on roads with two or more
//!   lanes per direction the vehicle changes to an adjacent lane at
//!   distances drawn from an exponential law of mean [`LANE_CHANGE_MEAN_M`];
//!   where the road changes, the lane index is kept (clamped to the new
//!   road's lanes). Every change of offset is a smooth step (a cosine ramp
//!   over [`LANE_CHANGE_M`], or [`ROAD_CHANGE_M`] at a change of road).
//! - wander(s): a first-order Gauss–Markov process in distance with 1σ
//!   `lane_wander_m` and correlation length [`WANDER_CORRELATION_M`], drawn
//!   at knots every [`WANDER_KNOT_M`] and interpolated by a Catmull–Rom
//!   spline so that the path stays smooth (its curvature adds at most a few
//!   10⁻³ /m; a white-noise process sampled every 2 m would make the
//!   vehicle weave).
//!
//! The lane path is drawn once per seed (stream [`ids::LANES`], run 0), like
//! the route itself: every Monte Carlo run drives the same truth.

use crate::error::{Error, Result};
use crate::network::{lane_offset_m, lanes_per_direction, Network};
use crate::route::{Route, RouteVertex};
use crate::scenario::LaneModel;
use crate::sensors::rng::{ids, stream, GaussMarkov};
use crate::trajectory::{RoutePlan, SpeedProfile};
use rand::Rng;

/// Spacing of the lane path's polyline (m;
/// [`crate::scenario::LANE_PATH_SPACING_M`], which the route's memory
/// estimate reads).
pub const RESAMPLE_M: f64 = crate::scenario::LANE_PATH_SPACING_M;
/// Correlation length of the lateral wander (m): drivers' lane-keeping
/// corrections have periods of several seconds, 50–100 m at town speeds.
pub const WANDER_CORRELATION_M: f64 = 60.0;
/// Spacing of the wander's knots (m).
pub const WANDER_KNOT_M: f64 = 15.0;
/// Mean distance between lane changes on a road with two or more lanes per
/// direction (m).
pub const LANE_CHANGE_MEAN_M: f64 = 2000.0;
/// Length of a lane change (m): about 4 s at 45 km/h; its peak curvature
/// for a 3.5 m change is π²·3.5/(2·50²) = 0.007 /m.
pub const LANE_CHANGE_M: f64 = 50.0;
/// Length over which the offset moves where the road (and so its lane
/// geometry) changes (m).
pub const ROAD_CHANGE_M: f64 = 30.0;

/// A smooth step of the target offset: `delta` over `length` centred at `s`.
#[derive(Debug, Clone, Copy)]
struct Step {
    s: f64,
    delta: f64,
    length: f64,
}

impl Step {
    fn at(&self, s: f64) -> f64 {
        let u = ((s - self.s) / self.length + 0.5).clamp(0.0, 1.0);
        self.delta * 0.5 * (1.0 - (std::f64::consts::PI * u).cos())
    }
}

/// The lateral offset (m, right of travel) of the truth along the centre
/// path: lane offsets with smooth steps, plus the wander.
#[derive(Debug, Clone)]
pub struct LateralProfile {
    steps: Vec<Step>,
    /// The first lane's offset plus the deltas of the steps before each
    /// (summed in order): the lane offset once those steps' ramps are over.
    finished: Vec<f64>,
    /// Half the longest step plus 1 m: a step that began more than this
    /// before `s` is over at `s`.
    reach: f64,
    knots: Vec<f64>,
}

impl LateralProfile {
    /// Draws the profile of `model` along `centre` (the smoothed path of
    /// `route` on `net`), from stream `ids::LANES` of `seed`.
    pub fn draw(
        net: &Network,
        route: &Route,
        centre: &RoutePlan,
        model: &LaneModel,
        seed: u64,
    ) -> Self {
        let mut rng = stream(seed, 0, ids::LANES);
        let total = centre.distance_m;
        let attrs = |s: f64| {
            let sp = route.span_at(centre.chainage_at(s));
            (sp.road, &net.model.roads[sp.road as usize].attributes)
        };
        let (mut road, a) = attrs(0.0);
        let mut lane = rng.random_range(0..lanes_per_direction(a));
        let start = lane_offset_m(a, model.drive_side, lane);
        let mut offset = start;
        let mut next_change = exponential(&mut rng, LANE_CHANGE_MEAN_M);
        let mut steps = Vec::new();
        let mut s = 0.0;
        while s < total {
            s = (s + RESAMPLE_M).min(total);
            let (r, a) = attrs(s);
            let k = lanes_per_direction(a);
            let mut length = LANE_CHANGE_M;
            if r != road {
                road = r;
                lane = lane.min(k - 1);
                length = ROAD_CHANGE_M;
            }
            if s >= next_change {
                next_change = s + exponential(&mut rng, LANE_CHANGE_MEAN_M);
                if k >= 2 {
                    lane = if lane == 0 {
                        1
                    } else if lane + 1 >= k || rng.random::<bool>() {
                        lane - 1
                    } else {
                        lane + 1
                    };
                    length = LANE_CHANGE_M;
                }
            }
            let target = lane_offset_m(a, model.drive_side, lane);
            if (target - offset).abs() > 1e-9 {
                steps.push(Step {
                    s,
                    delta: target - offset,
                    length,
                });
                offset = target;
            }
        }
        let n = (total / WANDER_KNOT_M).ceil() as usize + 2;
        let mut gm = GaussMarkov::new(
            model.wander_m,
            WANDER_CORRELATION_M,
            WANDER_KNOT_M,
            Some(&mut rng),
        );
        let knots = (0..n)
            .map(|i| if i == 0 { gm.x } else { gm.step(&mut rng) })
            .collect();
        let mut finished = Vec::with_capacity(steps.len() + 1);
        let mut l = start;
        finished.push(l);
        for st in &steps {
            l += st.delta;
            finished.push(l);
        }
        let reach = 0.5 * steps.iter().map(|st| st.length).fold(0.0, f64::max) + 1.0;
        Self {
            steps,
            finished,
            reach,
            knots,
        }
    }

    /// The lane offset at centre-path distance `s` without the wander (m).
    pub fn lane_at(&self, s: f64) -> f64 {
        // Steps are ordered and at most a lane change long: only those whose
        // ramp has begun count, the finished ones fully. Those over by more
        // than 1 m add exactly their delta (the ramp's cosine is -1 there),
        // so they are taken from their running sum: summing every step from
        // the route's start made a lane path quadratic in its length (a route
        // through 3,000 waypoints took 4 minutes here).
        let i0 = self.steps.partition_point(|st| st.s + self.reach < s);
        let mut l = self.finished[i0];
        for st in &self.steps[i0..] {
            if st.s - 0.5 * st.length > s {
                break;
            }
            l += st.at(s);
        }
        l
    }

    /// The wander at `s` (m): Catmull–Rom through the knots.
    pub fn wander_at(&self, s: f64) -> f64 {
        let x = (s / WANDER_KNOT_M).max(0.0);
        let j = (x.floor() as usize).min(self.knots.len().saturating_sub(2));
        let u = x - j as f64;
        let k = |i: isize| self.knots[(i.max(0) as usize).min(self.knots.len() - 1)];
        let (p0, p1, p2, p3) = (
            k(j as isize - 1),
            k(j as isize),
            k(j as isize + 1),
            k(j as isize + 2),
        );
        0.5 * (2.0 * p1
            + (-p0 + p2) * u
            + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u
            + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * u * u * u)
    }

    /// The whole lateral offset at `s` (m, right of travel).
    pub fn at(&self, s: f64) -> f64 {
        self.lane_at(s) + self.wander_at(s)
    }
}

fn exponential(rng: &mut rand_chacha::ChaCha8Rng, mean: f64) -> f64 {
    -mean * (1.0 - rng.random::<f64>()).ln()
}

/// The route the truth drives: `route`'s smoothed centre path `centre`
/// moved by `profile` (module doc), with the centre route's chainage, spans
/// and waypoints.
pub fn lane_route(
    net: &Network,
    route: &Route,
    centre: &RoutePlan,
    profile: &LateralProfile,
) -> Route {
    let total = centre.distance_m;
    let n = (total / RESAMPLE_M).ceil().max(1.0) as usize;
    let mut vertices: Vec<RouteVertex> = Vec::with_capacity(n + 1);
    let mut last: Option<[f64; 2]> = None;
    let mut last_c = 0.0f64;
    for i in 0..=n {
        let s = (i as f64 * RESAMPLE_M).min(total);
        let (p, psi) = centre.map_point(s);
        let (sn, cs) = psi.sin_cos();
        let l = profile.at(s);
        // Right of travel: (cos ψ, −sin ψ) for ψ clockwise from north.
        let q = [p[0] + l * cs, p[1] - l * sn];
        if let Some(prev) = last {
            // Keep only points that advance along the direction of travel
            // (inside a bend tighter than the offset they would run back).
            let adv = (q[0] - prev[0]) * sn + (q[1] - prev[1]) * cs;
            if adv < 0.1 && i < n {
                continue;
            }
        }
        let c = centre.chainage_at(s).max(last_c);
        last_c = c;
        let g = net.frame.to_geodetic([q[0], q[1], 0.0]);
        vertices.push(RouteVertex {
            enu: q,
            lat_lon: [g.lat_deg(), g.lon_deg()],
            chainage_m: c,
        });
        last = Some(q);
    }
    Route {
        vertices,
        spans: route.spans.clone(),
        length_m: route.length_m,
        waypoints: route.waypoints.clone(),
    }
}

/// The drivable lane path of `route` (smoothed centre path `centre`) for
/// `model`, drawn from `seed`.
#[allow(clippy::too_many_arguments)]
pub fn lane_plan(
    net: &Network,
    route: &Route,
    centre: &RoutePlan,
    model: &LaneModel,
    seed: u64,
    speed: &SpeedProfile,
    stops: &[(f64, f64)],
    height_m: f64,
    dt: f64,
) -> Result<RoutePlan> {
    let profile = LateralProfile::draw(net, route, centre, model, seed);
    let lanes = lane_route(net, route, centre, &profile);
    RoutePlan::new(net, &lanes, speed, stops, height_m, dt)
        .map_err(|e| Error::InvalidParameter(format!("the lane path: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_route_memory_allowance_covers_the_lateral_profile() {
        // The route's memory estimate (`scenario::route_truth_bytes`)
        // allows LANE_PROFILE_BYTES_PER_M for the wander's knots and the
        // lane changes' steps (each in a vector grown by doubling, with
        // its running sum), at four times their mean rate; the steps at
        // changes of road it counts per span.
        let knots = std::mem::size_of::<f64>() as f64 / WANDER_KNOT_M;
        let step = (2 * std::mem::size_of::<Step>() + std::mem::size_of::<f64>()) as f64;
        let changes = 4.0 * step / LANE_CHANGE_MEAN_M;
        assert!(knots + changes <= crate::scenario::LANE_PROFILE_BYTES_PER_M);
    }
}
