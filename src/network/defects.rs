//! Network defect checks: the faults in a road map that break matching and
//! routing.
//!
//! - `zero_length_segment`: repeated or coincident consecutive vertices (removed on load);
//! - `duplicate_section`: two sections between the same nodes with the same geometry;
//! - `unconnected_close_nodes`: two topology nodes closer than the tolerance that share
//!   no section, on a common layer (a road drawn to end at another but not joined to it);
//! - `dead_end_near_road`: a dead end within the tolerance of another road it is not
//!   joined to (an undershoot or overshoot);
//! - `dead_end`: a node with one section end, other than where the extract cut a way;
//! - `unreachable_section`: a section no permitted route from the largest strongly
//!   connected component can enter.

use super::geometry::point_segment_distance;
use super::model::RoadNetwork;
use super::topology::Topology;
use super::GridIndex;
use rstar::primitives::GeomWithData;
use rstar::RTree;
use serde::Serialize;
use std::collections::BTreeMap;

/// Default tolerance for near-but-unconnected nodes (m).
pub const DEFAULT_NODE_TOLERANCE_M: f64 = 1.0;

/// One defect, located.
#[derive(Debug, Clone, Serialize)]
pub struct Defect {
    /// Kind key, as in [`DefectReport::counts`].
    pub kind: &'static str,
    /// Latitude, longitude (degrees).
    pub lat_lon: [f64; 2],
    /// Input identifiers of the roads involved.
    pub roads: Vec<String>,
    /// Human-readable detail.
    pub detail: String,
}

/// Defect counts by kind and the located defects.
#[derive(Debug, Clone, Default, Serialize)]
pub struct DefectReport {
    /// Count by kind (every kind present, zero included).
    pub counts: BTreeMap<&'static str, usize>,
    /// Every defect found.
    pub items: Vec<Defect>,
}

impl DefectReport {
    fn push(&mut self, d: Defect) {
        *self.counts.entry(d.kind).or_default() += 1;
        self.items.push(d);
    }
}

/// Runs every check. `tolerance_m` is the near-node distance (default 1 m).
pub fn check(
    net: &RoadNetwork,
    topo: &Topology,
    grid: &GridIndex,
    tolerance_m: f64,
) -> DefectReport {
    let mut r = DefectReport::default();
    for k in [
        "zero_length_segment",
        "duplicate_section",
        "unconnected_close_nodes",
        "dead_end_near_road",
        "dead_end",
        "unreachable_section",
    ] {
        r.counts.insert(k, 0);
    }
    let road_id = |section: u32| {
        net.roads[net.sections[section as usize].road as usize]
            .attributes
            .id
            .clone()
    };

    for &p in &net.report.zero_length_at {
        r.push(Defect {
            kind: "zero_length_segment",
            lat_lon: p,
            roads: Vec::new(),
            detail: "consecutive vertices at the same position".into(),
        });
    }

    // Duplicate sections: same node pair, same geometry (either direction).
    let mut by_pair: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
    for (i, s) in net.sections.iter().enumerate() {
        by_pair
            .entry((s.start.min(s.end), s.start.max(s.end)))
            .or_default()
            .push(i as u32);
    }
    for group in by_pair.values().filter(|g| g.len() > 1) {
        for (k, &a) in group.iter().enumerate() {
            for &b in &group[k + 1..] {
                if same_geometry(net, a, b) {
                    let s = &net.sections[a as usize];
                    r.push(Defect {
                        kind: "duplicate_section",
                        lat_lon: net.nodes[s.start as usize].lat_lon,
                        roads: vec![road_id(a), road_id(b)],
                        detail: format!("sections {a} and {b} have the same geometry"),
                    });
                }
            }
        }
    }

    // Layers at each node, for telling bridges over roads from missed junctions.
    let mut layers: Vec<Vec<i32>> = vec![Vec::new(); net.nodes.len()];
    for s in &net.sections {
        let l = net.roads[s.road as usize].attributes.layer;
        for n in [s.start, s.end] {
            if !layers[n as usize].contains(&l) {
                layers[n as usize].push(l);
            }
        }
    }
    let share_layer = |a: usize, b: usize| layers[a].iter().any(|l| layers[b].contains(l));

    let points: Vec<GeomWithData<[f64; 2], u32>> = net
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| GeomWithData::new(n.enu, i as u32))
        .collect();
    let tree = RTree::bulk_load(points);
    let tol2 = tolerance_m * tolerance_m;
    for (i, n) in net.nodes.iter().enumerate() {
        for other in tree.locate_within_distance(n.enu, tol2) {
            let j = other.data as usize;
            if j <= i || !share_layer(i, j) {
                continue;
            }
            let joined = topo.incidences(i as u32).iter().any(|inc| {
                let s = &net.sections[inc.section as usize];
                s.start as usize == j || s.end as usize == j
            });
            if !joined {
                let ra = topo
                    .incidences(i as u32)
                    .first()
                    .map(|x| road_id(x.section));
                let rb = topo
                    .incidences(j as u32)
                    .first()
                    .map(|x| road_id(x.section));
                let d = super::build::dist(n.enu, net.nodes[j].enu);
                r.push(Defect {
                    kind: "unconnected_close_nodes",
                    lat_lon: n.lat_lon,
                    roads: ra.into_iter().chain(rb).collect(),
                    detail: format!("nodes {d:.2} m apart are not joined"),
                });
            }
        }
    }

    // Dead ends, and dead ends that nearly touch another road.
    let mut near = Vec::new();
    for (i, n) in net.nodes.iter().enumerate() {
        if topo.degree(i as u32) != 1 || n.at_extract_edge {
            continue;
        }
        let own = topo.incidences(i as u32)[0].section;
        r.push(Defect {
            kind: "dead_end",
            lat_lon: n.lat_lon,
            roads: vec![road_id(own)],
            detail: "road ends without a junction".into(),
        });
        near.clear();
        grid.within_radius_into(n.enu, tolerance_m, &mut near);
        let hit = near.iter().find(|&&sid| {
            let seg = &net.segments[sid as usize];
            seg.section != own
                && share_layer(i, net.sections[seg.section as usize].start as usize)
                && point_segment_distance(n.enu, seg.a, seg.b) > 1e-3
        });
        if let Some(&sid) = hit {
            let seg = &net.segments[sid as usize];
            let d = point_segment_distance(n.enu, seg.a, seg.b);
            r.push(Defect {
                kind: "dead_end_near_road",
                lat_lon: n.lat_lon,
                roads: vec![road_id(own), road_id(seg.section)],
                detail: format!("dead end {d:.2} m from a road it is not joined to"),
            });
        }
    }

    for (i, s) in net.sections.iter().enumerate() {
        if !topo.reachable_from_largest(net, i as u32) {
            r.push(Defect {
                kind: "unreachable_section",
                lat_lon: net.nodes[s.start as usize].lat_lon,
                roads: vec![road_id(i as u32)],
                detail: "cannot be entered from the main network".into(),
            });
        }
    }
    r
}

fn same_geometry(net: &RoadNetwork, a: u32, b: u32) -> bool {
    let (sa, sb) = (net.section_segments(a), net.section_segments(b));
    if sa.len() != sb.len() {
        return false;
    }
    let pts = |segs: &[super::model::Segment]| -> Vec<[f64; 2]> {
        let mut v: Vec<[f64; 2]> = segs.iter().map(|s| s.a).collect();
        v.push(segs[segs.len() - 1].b);
        v
    };
    let (pa, mut pb) = (pts(sa), pts(sb));
    let close = |x: &[[f64; 2]], y: &[[f64; 2]]| {
        x.iter()
            .zip(y)
            .all(|(p, q)| super::build::dist(*p, *q) < 0.01)
    };
    if close(&pa, &pb) {
        return true;
    }
    pb.reverse();
    close(&pa, &pb)
}
