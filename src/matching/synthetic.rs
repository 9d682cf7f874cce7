//! Seeded synthetic tracks for testing and benchmarking matchers: a route
//! driven at constant speed, resampled at a fixed spacing along its polyline,
//! plus a drift (a 2-D random walk scaled so its largest excursion is a given
//! size, growing like a dead-reckoning error) and white noise.

use super::evaluate::RoadLengths;
use super::Fix;
use crate::network::Network;
use crate::route::Route;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// How a synthetic track is made.
#[derive(Debug, Clone, Copy)]
pub struct TrackModel {
    /// Spacing of the fixes along the route (m).
    pub spacing_m: f64,
    /// Speed (m/s), for the time stamps.
    pub speed_mps: f64,
    /// Largest drift excursion (m); 0 for none.
    pub drift_max_m: f64,
    /// White noise, 1σ per axis (m).
    pub noise_sigma_m: f64,
    /// Heading noise (degrees, 1σ); `None`: the fixes carry no heading.
    pub heading_sigma_deg: Option<f64>,
    /// Seed of every random draw.
    pub seed: u64,
}

/// A synthetic track and its ground truth.
#[derive(Debug, Clone)]
pub struct SyntheticTrack {
    /// The fixes (ENU, network frame).
    pub fixes: Vec<Fix>,
    /// True positions (ENU).
    pub truth_enu: Vec<[f64; 2]>,
    /// Lengths driven per road (input identifiers).
    pub truth: RoadLengths,
}

/// Lengths driven per road along a route.
pub fn route_truth(net: &Network, route: &Route) -> RoadLengths {
    let mut out = RoadLengths::new();
    for s in &route.spans {
        *out.entry(net.roads[s.road as usize].attributes.id.clone())
            .or_default() += (s.to_offset_m - s.from_offset_m).abs();
    }
    out
}

/// Drives `route` with the model.
pub fn along_route(net: &Network, route: &Route, m: &TrackModel) -> SyntheticTrack {
    let mut rng = ChaCha8Rng::seed_from_u64(m.seed);
    // Fixes every `spacing_m` from the start, and one at the very end.
    let n = (route.length_m / m.spacing_m).ceil() as usize + 1;
    let mut walk = Vec::with_capacity(n);
    let mut w = [0.0f64; 2];
    let mut largest = 0.0f64;
    for _ in 0..n {
        let a: f64 = StandardNormal.sample(&mut rng);
        let b: f64 = StandardNormal.sample(&mut rng);
        w = [w[0] + a, w[1] + b];
        largest = largest.max(w[0].hypot(w[1]));
        walk.push(w);
    }
    let scale = if largest > 0.0 {
        m.drift_max_m / largest
    } else {
        0.0
    };
    let mut fixes = Vec::with_capacity(n);
    let mut truth_enu = Vec::with_capacity(n);
    for (i, w) in walk.iter().enumerate() {
        let c = (i as f64 * m.spacing_m).min(route.length_m);
        let p = route.position_at(c);
        let e: f64 = StandardNormal.sample(&mut rng);
        let f: f64 = StandardNormal.sample(&mut rng);
        let h: f64 = StandardNormal.sample(&mut rng);
        let heading_rad = m.heading_sigma_deg.map(|s| {
            let q0 = route.position_at((c - 1.0).max(0.0));
            let q1 = route.position_at((c + 1.0).min(route.length_m));
            (q1[0] - q0[0]).atan2(q1[1] - q0[1]) + (s * h).to_radians()
        });
        fixes.push(Fix {
            t_s: c / m.speed_mps,
            enu: [
                p[0] + scale * w[0] + m.noise_sigma_m * e,
                p[1] + scale * w[1] + m.noise_sigma_m * f,
            ],
            heading_rad,
        });
        truth_enu.push(p);
    }
    SyntheticTrack {
        fixes,
        truth_enu,
        truth: route_truth(net, route),
    }
}
