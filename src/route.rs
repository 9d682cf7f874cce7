//! Routes through the road network: waypoints snapped to the nearest road,
//! shortest paths honouring one-way roads (Dijkstra over directed sections),
//! and chainage (distance along the route).
//!
//! Edge cases: a waypoint farther than the snap tolerance from every road is
//! an error, as is a pair of waypoints with no permitted path between them. At
//! an intermediate waypoint the route continues in the direction it arrived in
//! when it can; it turns back on itself there only when no onward route exists.

use crate::error::{Error, Result};
use crate::geodesy::Geodetic;
use crate::network::geometry::{closest_on_segment, coord, line, point_at_ratio};
use crate::network::{DirectedSection, Network, NodeId, RoadId, SectionId};
use geo::{Distance, Euclidean};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

mod landmarks;
use landmarks::Towards;
pub use landmarks::{Landmarks, DEFAULT_LANDMARKS, MAX_LANDMARK_BYTES};

/// Default distance within which a waypoint must lie from a road (m).
pub const DEFAULT_SNAP_TOLERANCE_M: f64 = 100.0;

/// A point on a section: the section and the distance from its start (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectionPoint {
    /// The section.
    pub section: SectionId,
    /// Distance from the section's start, in its digitised direction (m).
    pub offset_m: f64,
}

/// A waypoint and where it was snapped.
#[derive(Debug, Clone, Copy)]
pub struct SnappedWaypoint {
    /// The waypoint as given (latitude, longitude in degrees).
    pub input_lat_lon: [f64; 2],
    /// The point on the network.
    pub point: SectionPoint,
    /// ENU position of the snapped point (m).
    pub enu: [f64; 2],
    /// Distance from the waypoint to the road (m).
    pub distance_m: f64,
    /// Chainage of the snapped point along the route (m).
    pub chainage_m: f64,
}

/// A vertex of the route's polyline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteVertex {
    /// ENU position (m) in the network's frame.
    pub enu: [f64; 2],
    /// Latitude, longitude (degrees).
    pub lat_lon: [f64; 2],
    /// Distance from the route's start (m).
    pub chainage_m: f64,
}

/// A stretch of the route along one section, in one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteSpan {
    /// Chainage where the span starts (m).
    pub start_chainage_m: f64,
    /// Chainage where it ends (m).
    pub end_chainage_m: f64,
    /// The section and the direction of travel.
    pub section: DirectedSection,
    /// The road the section belongs to.
    pub road: RoadId,
    /// Section offset (digitised direction) at the span's start (m).
    pub from_offset_m: f64,
    /// Section offset at the span's end (m).
    pub to_offset_m: f64,
}

/// A route: a polyline with chainage, the sections it follows, and its waypoints.
#[derive(Debug, Clone)]
pub struct Route {
    /// Polyline vertices, in driving order.
    pub vertices: Vec<RouteVertex>,
    /// Section spans, in driving order.
    pub spans: Vec<RouteSpan>,
    /// Total length (m).
    pub length_m: f64,
    /// The waypoints as snapped.
    pub waypoints: Vec<SnappedWaypoint>,
}

impl Route {
    /// The span at a chainage (clamped to the route).
    pub fn span_at(&self, chainage_m: f64) -> &RouteSpan {
        let i = self
            .spans
            .partition_point(|s| s.end_chainage_m < chainage_m)
            .min(self.spans.len() - 1);
        &self.spans[i]
    }

    /// ENU position at a chainage (clamped to the route), by linear interpolation.
    pub fn position_at(&self, chainage_m: f64) -> [f64; 2] {
        let c = chainage_m.clamp(0.0, self.length_m);
        let i = self
            .vertices
            .partition_point(|v| v.chainage_m <= c)
            .clamp(1, self.vertices.len() - 1);
        let (a, b) = (&self.vertices[i - 1], &self.vertices[i]);
        let span = b.chainage_m - a.chainage_m;
        let t = if span > 0.0 {
            (c - a.chainage_m) / span
        } else {
            0.0
        };
        point_at_ratio(&line(a.enu, b.enu), t).into()
    }
}

/// Snaps a WGS-84 point to the nearest road within `tolerance_m`.
pub fn snap(
    net: &Network,
    lat_lon: [f64; 2],
    tolerance_m: f64,
) -> Result<(SectionPoint, [f64; 2], f64)> {
    let [lat, lon] = lat_lon;
    if !(lat.is_finite()
        && lon.is_finite()
        && (-90.0..=90.0).contains(&lat)
        && (-180.0..=180.0).contains(&lon))
    {
        return Err(Error::InvalidParameter(format!(
            "waypoint ({lat}, {lon}) is not a valid latitude, longitude"
        )));
    }
    let e = net.frame.to_enu(&Geodetic::from_degrees(lat, lon, 0.0));
    let p = [e[0], e[1]];
    let (seg_id, d) = net
        .rtree
        .nearest(p)
        .ok_or_else(|| Error::InvalidParameter("the road network is empty".into()))?;
    if d > tolerance_m {
        return Err(Error::InvalidParameter(format!(
            "waypoint ({lat:.6}, {lon:.6}) is {d:.0} m from the nearest road (limit {tolerance_m:.0} m)"
        )));
    }
    let seg = &net.segments[seg_id as usize];
    let (t, q) = closest_on_segment(&seg.line(), coord(p));
    Ok((
        SectionPoint {
            section: seg.section,
            offset_m: seg.section_offset_m + t * seg.length_m,
        },
        q.into(),
        d,
    ))
}

#[derive(Copy, Clone, PartialEq)]
struct HeapItem {
    cost: f64,
    node: NodeId,
}
impl Eq for HeapItem {}
impl Ord for HeapItem {
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then_with(|| o.node.cmp(&self.node))
    }
}
impl PartialOrd for HeapItem {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// One leg's result: directed pieces (section, from offset, to offset).
pub type Pieces = Vec<(DirectedSection, f64, f64)>;

/// Shortest permitted path from `from` to `to`. `start_dir` restricts the
/// direction in which `from`'s section may be left (`Some(true)`: forward).
/// Returns the pieces and the length, or `None` if `to` cannot be reached.
pub fn shortest_path(
    net: &Network,
    from: SectionPoint,
    to: SectionPoint,
    start_dir: Option<bool>,
) -> Option<(Pieces, f64)> {
    shortest_path_with(net, None, from, to, start_dir)
}

/// [`shortest_path`] guided by landmark lower bounds as well as the straight
/// line (the same length; far fewer nodes settled on a city map, so worth
/// building [`Landmarks`] when a caller routes thousands of paths on one
/// map). Between paths of exactly equal length the one returned may differ.
pub fn shortest_path_with(
    net: &Network,
    landmarks: Option<&Landmarks>,
    from: SectionPoint,
    to: SectionPoint,
    start_dir: Option<bool>,
) -> Option<(Pieces, f64)> {
    let sf = &net.sections[from.section as usize];
    let mut best: Option<(Pieces, f64)> = None;
    let dir_ok = |fwd: bool| start_dir.is_none_or(|d| d == fwd);

    // On the same section, straight along it.
    if from.section == to.section {
        if to.offset_m >= from.offset_m && sf.oneway.allows_forward() && dir_ok(true) {
            let ds = DirectedSection {
                section: from.section,
                forward: true,
            };
            best = Some((
                vec![(ds, from.offset_m, to.offset_m)],
                to.offset_m - from.offset_m,
            ));
        } else if to.offset_m <= from.offset_m && sf.oneway.allows_backward() && dir_ok(false) {
            let ds = DirectedSection {
                section: from.section,
                forward: false,
            };
            best = Some((
                vec![(ds, from.offset_m, to.offset_m)],
                from.offset_m - to.offset_m,
            ));
        }
    }

    // A* over nodes from the ends of `from`'s section: the heap holds
    // g + h with h the straight-line distance to the nearer entry of the
    // target section plus the rest from there (consistent: a section is
    // never shorter than its chord), so the search stops as soon as no
    // queued node can improve on the best arrival, with Dijkstra's result.
    SCRATCH.with(|cell| {
        let mut scratch = cell.borrow_mut();
        scratch.reset(net.nodes.len());
        a_star(net, landmarks, from, to, start_dir, best, &mut scratch)
    })
}

/// Search state reused between the queries of a thread: a chain of trips
/// routes tens of thousands of paths, and filling three node-sized arrays
/// per query cost more than the search itself on a city map. A node's
/// entries are valid when its stamp equals the current query's.
#[derive(Default)]
struct Scratch {
    stamp: Vec<u32>,
    query: u32,
    dist: Vec<f64>,
    pred: Vec<Option<DirectedSection>>,
    closed: Vec<bool>,
    heap: BinaryHeap<HeapItem>,
}

impl Scratch {
    fn reset(&mut self, nn: usize) {
        if self.stamp.len() != nn || self.query == u32::MAX {
            self.stamp = vec![0; nn];
            self.dist = vec![f64::INFINITY; nn];
            self.pred = vec![None; nn];
            self.closed = vec![false; nn];
            self.query = 0;
        }
        self.query += 1;
        self.heap.clear();
    }
    fn touch(&mut self, n: usize) {
        if self.stamp[n] != self.query {
            self.stamp[n] = self.query;
            self.dist[n] = f64::INFINITY;
            self.pred[n] = None;
            self.closed[n] = false;
        }
    }
    fn dist(&self, n: usize) -> f64 {
        if self.stamp[n] == self.query {
            self.dist[n]
        } else {
            f64::INFINITY
        }
    }
    fn pred(&self, n: usize) -> Option<DirectedSection> {
        if self.stamp[n] == self.query {
            self.pred[n]
        } else {
            None
        }
    }
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// The A* part of [`shortest_path`], with `best` the same-section answer.
fn a_star(
    net: &Network,
    landmarks: Option<&Landmarks>,
    from: SectionPoint,
    to: SectionPoint,
    start_dir: Option<bool>,
    mut best: Option<(Pieces, f64)>,
    sc: &mut Scratch,
) -> Option<(Pieces, f64)> {
    let sf = &net.sections[from.section as usize];
    let st = &net.sections[to.section as usize];
    let dir_ok = |fwd: bool| start_dir.is_none_or(|d| d == fwd);
    // Entry nodes of the target section, the remaining cost from each, and
    // the landmarks that bound the way there best from `from`'s section.
    let towards = |tn: NodeId| landmarks.map(|l| l.towards(sf.start, tn));
    let mut targets: Vec<(NodeId, bool, f64, Option<Towards>)> = Vec::with_capacity(2);
    if st.oneway.allows_forward() || to.offset_m <= 0.0 {
        targets.push((st.start, true, to.offset_m.max(0.0), towards(st.start)));
    }
    if st.oneway.allows_backward() || to.offset_m >= st.length_m {
        targets.push((
            st.end,
            false,
            (st.length_m - to.offset_m).max(0.0),
            towards(st.end),
        ));
    }
    let h = |node: NodeId| -> f64 {
        let p = net.nodes[node as usize].enu;
        targets
            .iter()
            .map(|(tn, _, rest, toward)| {
                let q = net.nodes[*tn as usize].enu;
                // sqrt of the squares: `hypot`'s overflow care is not needed
                // for map coordinates and costs several times more.
                let line = ((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1])).sqrt();
                // The larger of two consistent heuristics is consistent.
                let roads = toward.as_ref().map_or(0.0, |t| t.from(node));
                line.max(roads) + *rest
            })
            .fold(f64::INFINITY, f64::min)
    };
    // A point exactly at a node may leave by any departure there.
    let at_start = from.offset_m <= 0.0;
    let at_end = from.offset_m >= sf.length_m;
    if (sf.oneway.allows_forward() && dir_ok(true)) || at_end {
        let c = (sf.length_m - from.offset_m).max(0.0);
        if c < sc.dist(sf.end as usize) {
            sc.touch(sf.end as usize);
            sc.dist[sf.end as usize] = c;
            sc.heap.push(HeapItem {
                cost: c + h(sf.end),
                node: sf.end,
            });
        }
    }
    if (sf.oneway.allows_backward() && dir_ok(false)) || at_start {
        let c = from.offset_m.max(0.0);
        if c < sc.dist(sf.start as usize) {
            sc.touch(sf.start as usize);
            sc.dist[sf.start as usize] = c;
            sc.heap.push(HeapItem {
                cost: c + h(sf.start),
                node: sf.start,
            });
        }
    }
    let bound = |best: &Option<(Pieces, f64)>| best.as_ref().map_or(f64::INFINITY, |b| b.1);
    let mut best_target: Option<(NodeId, bool, f64)> = None;
    while let Some(HeapItem { cost: f, node }) = sc.heap.pop() {
        if sc.closed[node as usize] {
            continue;
        }
        sc.closed[node as usize] = true;
        let cost = sc.dist[node as usize];
        let current_best = best_target.map_or(bound(&best), |t| t.2);
        if f >= current_best {
            break;
        }
        for &(tn, fwd, rest, _) in &targets {
            if tn == node && cost + rest < best_target.map_or(bound(&best), |t| t.2) {
                best_target = Some((tn, fwd, cost + rest));
            }
        }
        for d in net.topology.departures(&net.model, node) {
            let s = &net.sections[d.section as usize];
            let next = if d.forward { s.end } else { s.start };
            let c = cost + s.length_m;
            if c < sc.dist(next as usize) {
                sc.touch(next as usize);
                sc.dist[next as usize] = c;
                sc.pred[next as usize] = Some(d);
                sc.heap.push(HeapItem {
                    cost: c + h(next),
                    node: next,
                });
            }
        }
    }
    if let Some((tn, fwd, total)) = best_target {
        // Walk back from the target's entry node to one of `from`'s section ends.
        let mut middle: Vec<DirectedSection> = Vec::new();
        let mut node = tn;
        while let Some(d) = sc.pred(node as usize) {
            middle.push(d);
            let s = &net.sections[d.section as usize];
            node = if d.forward { s.start } else { s.end };
        }
        middle.reverse();
        // The walk ends at the section end the path left `from`'s section by.
        let first_fwd = if sf.start == sf.end {
            (sc.dist(node as usize) - (sf.length_m - from.offset_m)).abs() < 1e-9
        } else {
            node == sf.end
        };
        let mut pieces: Pieces = Vec::with_capacity(middle.len() + 2);
        let head = DirectedSection {
            section: from.section,
            forward: first_fwd,
        };
        pieces.push((
            head,
            from.offset_m,
            if first_fwd { sf.length_m } else { 0.0 },
        ));
        for d in middle {
            let len = net.sections[d.section as usize].length_m;
            pieces.push(if d.forward {
                (d, 0.0, len)
            } else {
                (d, len, 0.0)
            });
        }
        let tail = DirectedSection {
            section: to.section,
            forward: fwd,
        };
        pieces.push((tail, if fwd { 0.0 } else { st.length_m }, to.offset_m));
        best = Some((pieces, total));
    }
    best
}

/// Plans a route through `waypoints` (latitude, longitude in degrees), each
/// snapped to the nearest road within [`DEFAULT_SNAP_TOLERANCE_M`].
pub fn plan_route(net: &Network, waypoints: &[[f64; 2]]) -> Result<Route> {
    plan_route_with(net, waypoints, DEFAULT_SNAP_TOLERANCE_M)
}

/// [`plan_route`] with a chosen snap tolerance (m).
pub fn plan_route_with(net: &Network, waypoints: &[[f64; 2]], tolerance_m: f64) -> Result<Route> {
    if waypoints.len() < 2 {
        return Err(Error::InvalidParameter(format!(
            "a route needs at least two waypoints, got {}",
            waypoints.len()
        )));
    }
    let mut snapped = Vec::with_capacity(waypoints.len());
    for (i, w) in waypoints.iter().enumerate() {
        let (point, enu, d) = snap(net, *w, tolerance_m)
            .map_err(|e| Error::InvalidParameter(format!("waypoint {}: {}", i + 1, strip(&e))))?;
        snapped.push(SnappedWaypoint {
            input_lat_lon: *w,
            point,
            enu,
            distance_m: d,
            chainage_m: 0.0,
        });
    }
    route_legs(net, snapped, "waypoint")
}

/// A route through points already on the network, leg by leg as
/// [`plan_route`] does (continuing in the arrival direction at each
/// intermediate point when it can).
pub fn plan_route_points(net: &Network, points: &[SectionPoint]) -> Result<Route> {
    if points.len() < 2 {
        return Err(Error::InvalidParameter(format!(
            "a route needs at least two points, got {}",
            points.len()
        )));
    }
    let mut snapped = Vec::with_capacity(points.len());
    for p in points {
        let sec = net.sections.get(p.section as usize).ok_or_else(|| {
            Error::InvalidParameter(format!("section {} is not in the network", p.section))
        })?;
        let off = p.offset_m.clamp(0.0, sec.length_m);
        let enu = *section_points(net, p.section, off, off)
            .first()
            .unwrap_or(&[0.0, 0.0]);
        let g = net.frame.to_geodetic([enu[0], enu[1], 0.0]);
        snapped.push(SnappedWaypoint {
            input_lat_lon: [g.lat_deg(), g.lon_deg()],
            point: SectionPoint {
                section: p.section,
                offset_m: off,
            },
            enu,
            distance_m: 0.0,
            chainage_m: 0.0,
        });
    }
    route_legs(net, snapped, "point")
}

/// A route along pieces already chosen (directed section, offsets from
/// the section's start in its digitised direction, in driving order), with
/// no waypoints: a walk planned elsewhere, driven as given.
pub fn route_from_pieces(net: &Network, pieces: &[(DirectedSection, f64, f64)]) -> Result<Route> {
    if pieces.is_empty() {
        return Err(Error::InvalidParameter(
            "a route needs at least one piece".into(),
        ));
    }
    for (d, a, b) in pieces {
        let sec = net.sections.get(d.section as usize).ok_or_else(|| {
            Error::InvalidParameter(format!("section {} is not in the network", d.section))
        })?;
        let ok = |x: f64| x.is_finite() && (-1e-6..=sec.length_m + 1e-6).contains(&x);
        if !(ok(*a) && ok(*b)) {
            return Err(Error::InvalidParameter(format!(
                "offsets {a}–{b} m are outside section {} ({} m)",
                d.section, sec.length_m
            )));
        }
    }
    let route = assemble(net, &pieces.to_vec(), Vec::new());
    if route.vertices.len() < 2 {
        return Err(Error::InvalidParameter("the pieces have no length".into()));
    }
    Ok(route)
}

/// The next leg of a route from `a` to `b` after arriving in direction
/// `arrive_dir`: on in that direction when a route exists, else turning back
/// (the rule for intermediate waypoints and trip ends).
pub fn next_leg(
    net: &Network,
    a: SectionPoint,
    b: SectionPoint,
    arrive_dir: Option<bool>,
) -> Option<(Pieces, f64)> {
    next_leg_with(net, None, a, b, arrive_dir)
}

/// [`next_leg`] guided by landmarks ([`shortest_path_with`]).
pub fn next_leg_with(
    net: &Network,
    landmarks: Option<&Landmarks>,
    a: SectionPoint,
    b: SectionPoint,
    arrive_dir: Option<bool>,
) -> Option<(Pieces, f64)> {
    shortest_path_with(net, landmarks, a, b, arrive_dir)
        .or_else(|| arrive_dir.and_then(|_| shortest_path_with(net, landmarks, a, b, None)))
}

/// Joins the legs between consecutive snapped points (`what` names them in
/// errors) into a route.
fn route_legs(net: &Network, mut snapped: Vec<SnappedWaypoint>, what: &str) -> Result<Route> {
    let mut all: Pieces = Vec::new();
    let mut arrive_dir: Option<bool> = None;
    for i in 0..snapped.len() - 1 {
        let (a, b) = (snapped[i].point, snapped[i + 1].point);
        let leg = next_leg(net, a, b, arrive_dir).ok_or_else(|| {
            Error::InvalidParameter(format!(
                "no route from {what} {} to {what} {} honouring one-way roads",
                i + 1,
                i + 2
            ))
        })?;
        arrive_dir = leg.0.last().map(|p| p.0.forward);
        snapped[i + 1].chainage_m = snapped[i].chainage_m + leg.1;
        all.extend(leg.0);
    }
    Ok(assemble(net, &all, snapped))
}

fn strip(e: &Error) -> String {
    match e {
        Error::InvalidParameter(m) => m.clone(),
        other => other.to_string(),
    }
}

/// Turns pieces into the polyline and spans.
fn assemble(net: &Network, pieces: &Pieces, waypoints: Vec<SnappedWaypoint>) -> Route {
    let mut vertices: Vec<RouteVertex> = Vec::new();
    let mut spans = Vec::with_capacity(pieces.len());
    let mut chainage = 0.0;
    for &(ds, from, to) in pieces {
        let len = (to - from).abs();
        if len <= 0.0 && pieces.len() > 1 {
            continue;
        }
        let s = &net.sections[ds.section as usize];
        spans.push(RouteSpan {
            start_chainage_m: chainage,
            end_chainage_m: chainage + len,
            section: ds,
            road: s.road,
            from_offset_m: from,
            to_offset_m: to,
        });
        for p in section_points(net, ds.section, from, to) {
            let next_chainage = match vertices.last() {
                Some(last) => {
                    let step = Euclidean.distance(coord(p), coord(last.enu));
                    if step < 1e-3 {
                        continue;
                    }
                    last.chainage_m + step
                }
                None => 0.0,
            };
            chainage_push(net, &mut vertices, p, next_chainage);
        }
        chainage += len;
    }
    let length_m = vertices.last().map_or(0.0, |v| v.chainage_m);
    Route {
        vertices,
        spans,
        length_m,
        waypoints,
    }
}

fn chainage_push(net: &Network, v: &mut Vec<RouteVertex>, enu: [f64; 2], chainage_m: f64) {
    let g = net.frame.to_geodetic([enu[0], enu[1], 0.0]);
    v.push(RouteVertex {
        enu,
        lat_lon: [g.lat_deg(), g.lon_deg()],
        chainage_m,
    });
}

/// The ENU polyline of a section between offsets `from` and `to`, in the
/// order driven (`from > to`: against the digitised direction).
pub fn section_points(net: &Network, section: SectionId, from: f64, to: f64) -> Vec<[f64; 2]> {
    let segs = net.model.section_segments(section);
    let at = |off: f64| -> [f64; 2] {
        let i = segs
            .partition_point(|s| s.section_offset_m + s.length_m < off)
            .min(segs.len() - 1);
        let s = &segs[i];
        let t = if s.length_m > 0.0 {
            ((off - s.section_offset_m) / s.length_m).clamp(0.0, 1.0)
        } else {
            0.0
        };
        point_at_ratio(&s.line(), t).into()
    };
    let (lo, hi) = (from.min(to), from.max(to));
    let mut pts = vec![at(lo)];
    for s in segs.iter().skip(1) {
        if s.section_offset_m > lo && s.section_offset_m < hi {
            pts.push(s.a);
        }
    }
    pts.push(at(hi));
    if from > to {
        pts.reverse();
    }
    pts
}
