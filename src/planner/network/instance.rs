//! The covering instance of a network: directed edges (section,
//! direction), candidate sites along them, installed tags snapped to their
//! best-fitting edge, U-turn connectors; and the geometry to report sites
//! and walks on the roads.

use super::cover::{CoverEdge, CoverProblem, CoverSite, Walk};
use super::settings::{UTurns, EXISTING_SNAP_M};
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::planner::settings::{lane_width_m, PlannerSettings};
use crate::sim::tags::Mounting;
use std::collections::{BTreeMap, BTreeSet};

/// Length of a junction connector when U-turns are restricted (m).
const CONNECTOR_M: f64 = 1e-3;

/// The instance built from a network.
pub(super) struct Built {
    pub(super) problem: CoverProblem,
    /// Per directed edge: section, forward.
    pub(super) edge_dir: Vec<(SectionId, bool)>,
    /// Per site: mounting, installed tag index.
    pub(super) site_mounting: Vec<Mounting>,
    pub(super) site_existing: Vec<Option<usize>>,
    /// Speed (m/s) per directed edge.
    pub(super) edge_speed: Vec<f64>,
    pub(super) existing_off: usize,
    pub(super) directed_length_m: f64,
    /// Directed road edges (connectors come after them).
    pub(super) physical_edges: usize,
    /// Budget metres per metre of each edge (R_ref / R of its speed class).
    pub(super) edge_scale: Vec<f64>,
}

/// The key of a speed class: its speed in (km/h)/100, an integer.
pub(super) fn speed_key(v_mps: f64) -> u64 {
    (v_mps * 3.6 * 100.0).round() as u64
}

/// Speed class keys, mountings, and their (speed m/s, mounting) pairs.
pub(super) type ClassesInUse = (BTreeSet<u64>, Vec<Mounting>, Vec<(f64, Mounting)>);

/// The speed classes (keys) and mountings in use on a built instance, and
/// their pairs (speed m/s, mounting); an error when no site can take any
/// mounting.
pub(super) fn classes_in_use(built: &Built) -> Result<ClassesInUse> {
    let speeds: BTreeSet<u64> = built.edge_speed.iter().map(|&v| speed_key(v)).collect();
    let names: BTreeSet<&'static str> = built.site_mounting.iter().map(|m| m.as_str()).collect();
    let mountings: Vec<Mounting> = names.iter().filter_map(|m| Mounting::parse(m)).collect();
    let classes: Vec<(f64, Mounting)> = speeds
        .iter()
        .flat_map(|&s| mountings.iter().map(move |&m| (s as f64 / 360.0, m)))
        .collect();
    if classes.is_empty() {
        return Err(Error::InvalidParameter(
            "no candidate site: none of planner.mountings is allowed on any road (ceiling only in tunnels)"
                .into(),
        ));
    }
    Ok((speeds, mountings, classes))
}

/// Typical speed of a road class where the map gives no `maxspeed` (km/h):
/// urban figures, the slower end of common national defaults (slower is
/// the worse case for the error budget).
pub fn class_speed_kmh(highway: &str) -> Option<f64> {
    Some(match highway {
        "motorway" => 100.0,
        "trunk" => 80.0,
        "primary" => 60.0,
        "secondary" | "motorway_link" => 50.0,
        "tertiary" | "unclassified" | "trunk_link" | "primary_link" | "road" => 40.0,
        "secondary_link" | "tertiary_link" | "residential" => 30.0,
        "service" | "track" => 20.0,
        "living_street" => 10.0,
        _ => return None,
    })
}

/// The planning speed of a road (m/s): the vehicles' speed capped by the
/// road's `maxspeed`, else by its class's typical speed, in 5 km/h classes.
pub(super) fn road_speed(scn_speed: f64, maxspeed_kmh: Option<f64>, highway: &str) -> f64 {
    edge_speed(scn_speed, maxspeed_kmh.or_else(|| class_speed_kmh(highway)))
}

pub(super) fn edge_speed(scn_speed: f64, maxspeed_kmh: Option<f64>) -> f64 {
    let v = maxspeed_kmh.map_or(scn_speed, |m| (m / 3.6).min(scn_speed));
    // 5 km/h classes, rounded down (slower is the worse case); a speed
    // below 5 km/h is its own class (at least 1 km/h).
    let kmh = (v * 3.6 / 5.0).floor() * 5.0;
    let kmh = if kmh < 5.0 { (v * 3.6).max(1.0) } else { kmh };
    kmh / 3.6
}

/// Whether the transition from one directed section to the next resets the
/// along-road error (a turn map matching observes).
pub(super) type ResetTest<'a> = dyn Fn((SectionId, bool), (SectionId, bool)) -> bool + 'a;

pub(super) fn build(
    net: &Network,
    settings: &PlannerSettings,
    scn_speed: f64,
    spacing: f64,
    reach_m: f64,
    u_turns: UTurns,
    resets: Option<&ResetTest<'_>>,
) -> Result<Built> {
    let mut edges = Vec::new();
    let mut edge_dir = Vec::new();
    let mut edge_speed_v = Vec::new();
    let mut sites = Vec::new();
    let mut site_mounting = Vec::new();
    let mut site_existing = Vec::new();
    let mut dir_index: BTreeMap<(SectionId, bool), u32> = BTreeMap::new();
    let mut directed_length_m = 0.0;
    for (si, s) in net.sections.iter().enumerate() {
        if s.length_m.is_nan() || s.length_m <= 0.0 {
            continue;
        }
        let a = &net.roads[s.road as usize].attributes;
        for fwd in [true, false] {
            let allowed = if fwd {
                s.oneway.allows_forward()
            } else {
                s.oneway.allows_backward()
            };
            if !allowed {
                continue;
            }
            let (tail, head) = if fwd {
                (s.start, s.end)
            } else {
                (s.end, s.start)
            };
            let e = edges.len() as u32;
            edges.push(CoverEdge {
                tail,
                head,
                length_m: s.length_m,
            });
            dir_index.insert((si as SectionId, fwd), e);
            edge_dir.push((si as SectionId, fwd));
            edge_speed_v.push(road_speed(scn_speed, a.maxspeed_kmh, &a.highway));
            directed_length_m += s.length_m;
            if let Some(o) = settings.mountings.iter().find(|o| o.allowed_on(a.tunnel)) {
                let n = (s.length_m / spacing).ceil().max(1.0) as usize;
                for i in 0..n {
                    sites.push(CoverSite {
                        edge: e,
                        at_m: (i as f64 + 0.5) * s.length_m / n as f64,
                        cost: o.cost,
                        existing: false,
                    });
                    site_mounting.push(o.mounting);
                    site_existing.push(None);
                }
            }
        }
    }
    if edges.is_empty() {
        return Err(Error::InvalidParameter(
            "the map has no drivable road section to cover".into(),
        ));
    }
    // Installed tags: the best-fitting directed edge within 15 m.
    let mut existing_off = 0;
    for (ti, t) in settings.existing_tags.iter().enumerate() {
        let p = net.frame.to_enu(&crate::geodesy::Geodetic {
            lat: t.lat,
            lon: t.lon,
            height: 0.0,
        });
        let p2 = [p[0], p[1]];
        // Among the segments within 15 m, the one the tag fits best as a
        // lane-centre point: its lateral offset closest to half a lane (two-way
        // roads) or to the centreline (one-way), projection inside the
        // segment preferred. The side gives the direction served.
        let mut best: Option<(f64, u32, f64, f64)> = None; // (score, segment, offset, cross)
        for (seg_id, d) in net.rtree.nearest_iter(p2) {
            if d > EXISTING_SNAP_M {
                break;
            }
            let seg = &net.segments[seg_id as usize];
            let (dx, dy) = (seg.b[0] - seg.a[0], seg.b[1] - seg.a[1]);
            let l2 = (dx * dx + dy * dy).max(1e-12);
            let raw = ((p2[0] - seg.a[0]) * dx + (p2[1] - seg.a[1]) * dy) / l2;
            let tpar = raw.clamp(0.0, 1.0);
            let cross = (dx * (p2[1] - seg.a[1]) - dy * (p2[0] - seg.a[0])) / l2.sqrt();
            let sec = &net.sections[seg.section as usize];
            let expected = if sec.oneway.is_oneway() {
                0.0
            } else {
                0.5 * lane_width_m(&net.roads[sec.road as usize].attributes)
            };
            let outside = (raw - tpar).abs() * l2.sqrt();
            let score = (cross.abs() - expected).abs() + outside;
            if best.is_none_or(|b| score < b.0 - 1e-9) {
                best = Some((
                    score,
                    seg_id,
                    seg.section_offset_m + tpar * seg.length_m,
                    cross,
                ));
            }
        }
        let Some((_, seg_id, off, cross)) = best else {
            existing_off += 1;
            continue;
        };
        let seg = &net.segments[seg_id as usize];
        // Right of the digitised direction (or on it): forward; left: backward.
        let prefer_fwd = cross <= 0.0;
        let sec = seg.section;
        let pick = [prefer_fwd, !prefer_fwd]
            .into_iter()
            .find_map(|f| dir_index.get(&(sec, f)).map(|&e| (e, f)));
        let Some((e, fwd)) = pick else {
            existing_off += 1;
            continue;
        };
        let len = edges[e as usize].length_m;
        sites.push(CoverSite {
            edge: e,
            at_m: if fwd { off } else { len - off },
            cost: 0.0,
            existing: true,
        });
        site_mounting.push(t.mounting);
        site_existing.push(Some(ti));
    }
    // U-turns only at dead ends: every directed edge gets its own end
    // nodes, joined by connectors (1 mm, no sites) for each permitted
    // transition; the walk model is unchanged and walks gain at most 1 mm per
    // junction (conservative).
    // With map matching (`resets` given) every directed edge gets its own
    // end nodes too, and a transition that resets the along-road error (a
    // turn map matching observes) has no connector: a walk ends there, and
    // the next one starts on the road turned into.
    let physical = edges.len();
    let nodes = match (u_turns, resets) {
        (UTurns::Anywhere, None) => net.nodes.len(),
        _ => {
            for e in 0..physical {
                let (sec, fwd) = edge_dir[e];
                let v = edges[e].head;
                for d in net.topology.departures(net, v) {
                    let Some(&e2) = dir_index.get(&(d.section, d.forward)) else {
                        continue;
                    };
                    let u_turn = d.section == sec && d.forward != fwd;
                    if u_turn && u_turns == UTurns::DeadEnds && net.topology.degree(v) > 1 {
                        continue;
                    }
                    if resets.is_some_and(|r| r((sec, fwd), (d.section, d.forward))) {
                        continue;
                    }
                    edges.push(CoverEdge {
                        tail: 2 * e as u32 + 1,
                        head: 2 * e2,
                        length_m: CONNECTOR_M,
                    });
                }
            }
            for (e, ed) in edges.iter_mut().enumerate().take(physical) {
                ed.tail = 2 * e as u32;
                ed.head = 2 * e as u32 + 1;
            }
            2 * physical
        }
    };
    let problem =
        CoverProblem::new(nodes, edges, sites, reach_m, settings.tolerate_missed_reads)
            .map_err(|m| Error::InvalidParameter(format!("network coverage instance: {m}")))?;
    Ok(Built {
        problem,
        edge_dir,
        site_mounting,
        site_existing,
        edge_speed: edge_speed_v,
        existing_off,
        directed_length_m,
        physical_edges: physical,
        edge_scale: vec![1.0; physical],
    })
}

/// A point of a section at `offset` from its start: centreline
/// (lat, lon in degrees), ENU, the road offset and the digitised heading
/// (ENU unit vector).
pub(super) fn section_point(
    net: &Network,
    sec: SectionId,
    offset: f64,
) -> ([f64; 2], [f64; 2], f64, [f64; 2]) {
    let segs = net.section_segments(sec);
    let i = segs
        .partition_point(|g| g.section_offset_m + g.length_m < offset)
        .min(segs.len() - 1);
    let g = &segs[i];
    let t = if g.length_m > 0.0 {
        ((offset - g.section_offset_m) / g.length_m).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let ll = [
        g.a_lat_lon[0] + t * (g.b_lat_lon[0] - g.a_lat_lon[0]),
        g.a_lat_lon[1] + t * (g.b_lat_lon[1] - g.a_lat_lon[1]),
    ];
    let enu = [
        g.a[0] + t * (g.b[0] - g.a[0]),
        g.a[1] + t * (g.b[1] - g.a[1]),
    ];
    let (dx, dy) = (g.b[0] - g.a[0], g.b[1] - g.a[1]);
    let n = dx.hypot(dy).max(1e-12);
    (ll, enu, g.road_offset_m + t * g.length_m, [dx / n, dy / n])
}

/// Names the roads of a walk for an infeasibility report.
pub(super) fn describe_walk(net: &Network, built: &Built, w: &Walk) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut seen = BTreeSet::new();
    let mut pieces: Vec<&(u32, f64, f64)> = w.pieces.iter().collect();
    pieces.sort_by(|a, b| (b.2 - b.1).total_cmp(&(a.2 - a.1)));
    for &&(e, a, b) in pieces
        .iter()
        .filter(|p| (p.0 as usize) < built.physical_edges)
        .take(3)
    {
        let (sec, fwd) = built.edge_dir[e as usize];
        if !seen.insert((sec, fwd)) {
            continue;
        }
        let f = built.edge_scale[e as usize];
        let (a, b) = (a / f, b / f);
        let s = &net.sections[sec as usize];
        let len = s.length_m;
        let (sa, sb) = if fwd { (a, b) } else { (len - b, len - a) };
        let (_, _, ra, _) = section_point(net, sec, sa);
        let (_, _, rb, _) = section_point(net, sec, sb);
        let at = &net.roads[s.road as usize].attributes;
        parts.push(format!(
            "road {}{} ({} its digitised direction, chainage {:.0}–{:.0} m{})",
            at.id,
            at.name
                .as_ref()
                .map(|n| format!(" \"{n}\""))
                .unwrap_or_default(),
            if fwd { "along" } else { "against" },
            ra.min(rb),
            ra.max(rb),
            if at.tunnel { ", tunnel" } else { "" }
        ));
    }
    parts.join(", ")
}
