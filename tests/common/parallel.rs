//! Parallel two-way roads of a map and U routes over them: the tracks of
//! tests/it/matching_accuracy.rs's `parallel_two_way_roads` (as
//! `common::parallel`), shared with examples/drift_vs_lean.rs (which
//! includes this file with `#[path]`).
#![allow(dead_code)]

use waymark::network::Network;
use waymark::route::{plan_route, Route};

/// A point at a fraction of a road's length (ENU).
pub fn on_road(net: &Network, road: u32, frac: f64) -> [f64; 2] {
    let r = &net.roads[road as usize];
    let off = frac * r.length_m;
    let seg = r
        .sections
        .iter()
        .flat_map(|&s| net.section_segments(s).iter())
        .find(|g| g.road_offset_m + g.length_m >= off)
        .unwrap();
    let t = ((off - seg.road_offset_m) / seg.length_m).clamp(0.0, 1.0);
    [
        seg.a[0] + t * (seg.b[0] - seg.a[0]),
        seg.a[1] + t * (seg.b[1] - seg.a[1]),
    ]
}

/// WGS-84 latitude and longitude (degrees) of an ENU point of `net`.
pub fn lat_lon(net: &Network, enu: [f64; 2]) -> [f64; 2] {
    let g = net.frame.to_geodetic([enu[0], enu[1], 0.0]);
    [g.lat_deg(), g.lon_deg()]
}

/// Pairs of nearly straight two-way roads at least 150 m long, within 10°
/// of parallel, 12-60 m apart side by side.
pub fn pairs(net: &Network) -> Vec<(u32, u32)> {
    let straight: Vec<(u32, [f64; 2], [f64; 2])> = (0..net.roads.len() as u32)
        .filter_map(|id| {
            let r = &net.roads[id as usize];
            if r.length_m < 150.0
                || r.sections.len() > 6
                || r.sections
                    .iter()
                    .any(|&s| net.sections[s as usize].oneway.is_oneway())
            {
                return None;
            }
            let (a, b) = (on_road(net, id, 0.0), on_road(net, id, 1.0));
            let chord = (b[0] - a[0]).hypot(b[1] - a[1]);
            (chord > 0.97 * r.length_m).then_some((id, a, b))
        })
        .collect();
    let mut pairs = Vec::new();
    for (i, &(s1, a1, b1)) in straight.iter().enumerate() {
        for &(s2, a2, b2) in &straight[i + 1..] {
            let (d1, d2) = (
                [b1[0] - a1[0], b1[1] - a1[1]],
                [b2[0] - a2[0], b2[1] - a2[1]],
            );
            let (l1, l2) = (d1[0].hypot(d1[1]), d2[0].hypot(d2[1]));
            let cos = (d1[0] * d2[0] + d1[1] * d2[1]) / (l1 * l2);
            if cos.abs() < 10f64.to_radians().cos() {
                continue;
            }
            let m2 = [(a2[0] + b2[0]) / 2.0, (a2[1] + b2[1]) / 2.0];
            let (rx, ry) = (m2[0] - a1[0], m2[1] - a1[1]);
            let along = (rx * d1[0] + ry * d1[1]) / l1;
            let across = (rx * d1[1] - ry * d1[0]).abs() / l1;
            if along > 0.2 * l1 && along < 0.8 * l1 && (12.0..=60.0).contains(&across) {
                pairs.push((s1, s2));
            }
        }
    }
    pairs
}

/// Each pair driven as a U (at most 8): along one road, across, back along
/// the other; routes that turn back on a road are left out.
pub fn u_routes(net: &Network, pairs: &[(u32, u32)]) -> Vec<Route> {
    let mut routes = Vec::new();
    for &(s1, s2) in pairs {
        if routes.len() == 8 {
            break;
        }
        let (a1, b1) = (on_road(net, s1, 0.03), on_road(net, s1, 0.97));
        let (a2, b2) = (on_road(net, s2, 0.03), on_road(net, s2, 0.97));
        let near = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
        let (c2, d2) = if near(b1, b2) < near(b1, a2) {
            (b2, a2)
        } else {
            (a2, b2)
        };
        let w: Vec<[f64; 2]> = [a1, b1, c2, d2].iter().map(|p| lat_lon(net, *p)).collect();
        let r = plan_route(net, &w).unwrap();
        let roads = net.roads[s1 as usize].length_m + net.roads[s2 as usize].length_m;
        // Skip routes that turn back on a road at a waypoint (a U-turn the
        // driver would not make).
        let turns_back = r.spans.iter().any(|a| {
            r.spans.iter().any(|b| {
                a.road == b.road
                    && (a.to_offset_m - a.from_offset_m) * (b.to_offset_m - b.from_offset_m) < 0.0
            })
        });
        if r.length_m < 2.0 * roads && !turns_back {
            routes.push(r);
        }
    }
    routes
}
