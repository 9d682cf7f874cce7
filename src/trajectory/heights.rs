//! The height profile of a road route on an elevation model
//! ([`crate::elevation::Dem`]).
//!
//! Along the route, every [`PROFILE_STEP_M`], the road's raw height is the
//! DEM's bilinear height at the road's centre line, except on tunnels and
//! bridges (OSM `tunnel=*` other than `no`, `covered=yes`, `bridge=*`; a
//! run of consecutive tunnel or bridge spans counts as one structure):
//! there it is interpolated linearly in chainage between the terrain
//! heights at the structure's two ends (the portals, the abutments), not
//! the mountain above or the valley below. A structure where the route
//! starts or ends has one end off the route: it keeps the height of the end
//! the route passes, level; a route entirely on one structure interpolates
//! between the DEM heights at the ends of its first and last roads. The
//! raw heights are then smoothed into a [`HeightProfile`] (see there for the
//! window and why).

use crate::elevation::{Dem, HeightProfile, PROFILE_HALF_WINDOW_M, PROFILE_STEP_M};
use crate::error::Result;
use crate::network::Network;
use crate::route::{Route, RouteSpan};

/// Whether a span is on a tunnel or a bridge.
fn on_structure(net: &Network, span: &RouteSpan) -> bool {
    let a = &net.model.roads[span.road as usize].attributes;
    a.tunnel || a.bridge
}

/// The DEM height at a route chainage.
fn dem_at(net: &Network, route: &Route, dem: &Dem, chainage_m: f64) -> Result<f64> {
    let p = route.position_at(chainage_m);
    let g = net.model.frame.to_geodetic([p[0], p[1], 0.0]);
    dem.height(g.lat_deg(), g.lon_deg())
}

/// The DEM height at one end of a span's road: behind the span (`ahead`
/// false) or ahead of it, in the direction of travel.
fn road_end(net: &Network, dem: &Dem, span: &RouteSpan, ahead: bool) -> Result<f64> {
    let road = &net.model.roads[span.road as usize];
    let first = &net.model.sections[road.sections[0] as usize];
    let last = &net.model.sections[road.sections[road.sections.len() - 1] as usize];
    let node = if span.section.forward == ahead {
        last.end
    } else {
        first.start
    };
    let [lat, lon] = net.model.nodes[node as usize].lat_lon;
    dem.height(lat, lon)
}

/// Tunnel and bridge runs along the route: (first span, last span).
fn structure_runs(net: &Network, route: &Route) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (i, sp) in route.spans.iter().enumerate() {
        if !on_structure(net, sp) {
            continue;
        }
        match runs.last_mut() {
            Some(r) if r.1 + 1 == i => r.1 = i,
            _ => runs.push((i, i)),
        }
    }
    runs
}

/// The smoothed height profile of `route` on `dem`; an error names the DEM
/// file when a point the route needs is outside it or on no data.
pub fn route_heights(net: &Network, route: &Route, dem: &Dem) -> Result<HeightProfile> {
    route_heights_with(net, route, dem, PROFILE_HALF_WINDOW_M)
}

/// [`route_heights`] with the smoothing's half-window (m; 0: the raw
/// heights, the DEM's and the structures' interpolation).
pub fn route_heights_with(
    net: &Network,
    route: &Route,
    dem: &Dem,
    half_window_m: f64,
) -> Result<HeightProfile> {
    let length = route.length_m.max(1e-3);
    let n = (length / PROFILE_STEP_M).ceil().max(1.0) as usize;
    let step = length / n as f64;
    let runs: Vec<(f64, f64, f64, f64)> = structure_runs(net, route)
        .into_iter()
        .map(|(i, j)| {
            let (ca, cb) = (
                route.spans[i].start_chainage_m,
                route.spans[j].end_chainage_m,
            );
            let a = (ca > 1e-6)
                .then(|| dem_at(net, route, dem, ca))
                .transpose()?;
            let b = (cb < route.length_m - 1e-6)
                .then(|| dem_at(net, route, dem, cb))
                .transpose()?;
            let (ha, hb) = match (a, b) {
                (Some(a), Some(b)) => (a, b),
                (Some(a), None) => (a, a),
                (None, Some(b)) => (b, b),
                (None, None) => (
                    road_end(net, dem, &route.spans[i], false)?,
                    road_end(net, dem, &route.spans[j], true)?,
                ),
            };
            Ok((ca, cb, ha, hb))
        })
        .collect::<Result<_>>()?;
    let mut raw = Vec::with_capacity(n + 1);
    let mut r = 0;
    for i in 0..=n {
        let c = i as f64 * step;
        while r < runs.len() && runs[r].1 < c {
            r += 1;
        }
        let h = match runs.get(r) {
            Some(&(ca, cb, ha, hb)) if c >= ca && cb > ca => ha + (hb - ha) * (c - ca) / (cb - ca),
            _ => dem_at(net, route, dem, c)?,
        };
        raw.push(h);
    }
    Ok(HeightProfile::smoothed(step, &raw, half_window_m))
}

/// Heights of a network's roads on an elevation model, for points anywhere
/// on the network (area plans): the DEM's bilinear height on ordinary
/// roads (not smoothed: a point, not a drive); on tunnels and bridges the
/// linear interpolation between the structure's ends. A structure is a
/// connected set of tunnel or bridge sections; its portals are its nodes
/// that also touch an ordinary road or end the network (dead ends, extract
/// edges), at the DEM's height; its inner nodes take the harmonic
/// interpolation (each the length-weighted mean of its neighbours, 1/length
/// weights), which along a chain of sections is linear in distance between
/// the portals, and a point on a structure section is linear between its
/// two nodes. A structure without any portal (a closed loop) follows the
/// DEM at its nodes.
#[derive(Debug, Clone)]
pub struct NetworkHeights<'a> {
    net: &'a Network,
    dem: &'a Dem,
    /// Heights of the nodes of structure sections.
    nodes: std::collections::BTreeMap<crate::network::NodeId, f64>,
}

impl<'a> NetworkHeights<'a> {
    /// Solves the structures' node heights.
    pub fn new(net: &'a Network, dem: &'a Dem) -> Result<NetworkHeights<'a>> {
        use crate::network::SectionEnd;
        use std::collections::{BTreeMap, BTreeSet};
        let m = &net.model;
        let structure = |s: u32| {
            let a = &m.roads[m.sections[s as usize].road as usize].attributes;
            a.tunnel || a.bridge
        };
        let dem_at = |n: u32| {
            let [lat, lon] = m.nodes[n as usize].lat_lon;
            dem.height(lat, lon)
        };
        // Structure nodes: portals at the DEM's height, free nodes with
        // their structure neighbours and 1/length weights (ordered maps:
        // the same sweep order, the same heights, on every run).
        let mut portals: BTreeMap<u32, f64> = BTreeMap::new();
        let mut free: BTreeMap<u32, Vec<(u32, f64)>> = BTreeMap::new();
        for (s, sec) in m.sections.iter().enumerate() {
            if !structure(s as u32) {
                continue;
            }
            for n in [sec.start, sec.end] {
                if portals.contains_key(&n) || free.contains_key(&n) {
                    continue;
                }
                let inc = net.topology.incidences(n);
                if inc.len() < 2 || inc.iter().any(|i| !structure(i.section)) {
                    portals.insert(n, dem_at(n)?);
                    continue;
                }
                let edges = inc
                    .iter()
                    .map(|i| {
                        let t = &m.sections[i.section as usize];
                        let other = match i.end {
                            SectionEnd::Start => t.end,
                            SectionEnd::End => t.start,
                        };
                        (other, 1.0 / t.length_m.max(0.01))
                    })
                    .filter(|&(o, _)| o != n)
                    .collect();
                free.insert(n, edges);
            }
        }
        // Free nodes with no portal reachable through structure sections
        // (a closed structure): the DEM's height, fixed.
        let mut linked: BTreeSet<u32> = BTreeSet::new();
        let mut stack: Vec<u32> = Vec::new();
        for (n, e) in &free {
            if e.iter().any(|(o, _)| portals.contains_key(o)) && linked.insert(*n) {
                stack.push(*n);
            }
        }
        while let Some(x) = stack.pop() {
            for &(o, _) in &free[&x] {
                if free.contains_key(&o) && linked.insert(o) {
                    stack.push(o);
                }
            }
        }
        let closed: Vec<u32> = free
            .keys()
            .copied()
            .filter(|n| !linked.contains(n))
            .collect();
        for n in closed {
            free.remove(&n);
            portals.insert(n, dem_at(n)?);
        }
        // Gauss–Seidel from the mean portal height; structures are a few
        // sections each, so this converges in a few hundred sweeps.
        let start = portals.values().sum::<f64>() / portals.len().max(1) as f64;
        let mut heights = portals;
        for n in free.keys() {
            heights.insert(*n, start);
        }
        for _ in 0..100_000 {
            let mut change = 0.0f64;
            for (n, edges) in &free {
                let (mut num, mut den) = (0.0, 0.0);
                for &(o, w) in edges {
                    num += w * heights[&o];
                    den += w;
                }
                let h = num / den;
                change = change.max((h - heights[n]).abs());
                heights.insert(*n, h);
            }
            if change < 1e-7 {
                break;
            }
        }
        Ok(NetworkHeights {
            net,
            dem,
            nodes: heights,
        })
    }

    /// The road's height (m) at `offset_m` along `section` (digitised
    /// direction), whose centre line is at `lat_lon` (degrees) there.
    pub fn at(
        &self,
        section: crate::network::SectionId,
        offset_m: f64,
        lat_lon: [f64; 2],
    ) -> Result<f64> {
        let m = &self.net.model;
        let sec = &m.sections[section as usize];
        match (self.nodes.get(&sec.start), self.nodes.get(&sec.end)) {
            (Some(&a), Some(&b))
                if {
                    let r = &m.roads[sec.road as usize].attributes;
                    r.tunnel || r.bridge
                } =>
            {
                let f = (offset_m / sec.length_m.max(1e-9)).clamp(0.0, 1.0);
                Ok(a + (b - a) * f)
            }
            _ => self.dem.height(lat_lon[0], lat_lon[1]),
        }
    }
}
