//! Turns the loaders' raw roads into the network model: vertices to the local
//! ENU frame, coincident vertices merged, ways split into sections at junctions
//! (vertices shared by several ways, or visited twice by one way) and into
//! straight segments.

use super::attributes::RoadAttributes;
use super::geometry::coord;
use super::model::{LoadReport, Node, Road, RoadNetwork, Section, Segment};
use crate::error::{Error, Result};
use crate::geodesy::{EnuFrame, Geodetic};
use geo::{BoundingRect, Distance, Euclidean, MultiPoint, Point};
use rustc_hash::{FxHashMap, FxHashSet};
use std::path::Path;

/// Consecutive vertices closer than this are one point (a zero-length segment).
const COINCIDENT_M: f64 = 1e-3;

/// A vertex as a loader read it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RawVertex {
    /// Identity: the OSM node id, or the quantised coordinates for GeoJSON.
    pub key: u64,
    pub lat: f64,
    pub lon: f64,
}

/// A road as a loader read it: attributes and one or more vertex runs.
#[derive(Debug, Clone)]
pub(crate) struct RawRoad {
    pub attributes: RoadAttributes,
    /// Runs of consecutive present vertices (several when the way was cut).
    pub parts: Vec<Vec<RawVertex>>,
    pub cut: bool,
}

/// Identity key for a coordinate pair without a node id: latitude and longitude
/// quantised to 1e-7 degree (OSM's precision, about 1 cm).
pub(crate) fn coordinate_key(lat: f64, lon: f64) -> u64 {
    let la = (lat * 1e7).round() as i64 as u64 & 0xFFFF_FFFF;
    let lo = (lon * 1e7).round() as i64 as u64 & 0xFFFF_FFFF;
    (la << 32) | lo
}

/// Checks one coordinate pair; `what` (a `&str`, or `format_args!` so that
/// nothing is formatted per vertex unless it fails) names it in the error.
pub(crate) fn check_coordinate(
    path: &Path,
    what: impl std::fmt::Display,
    lat: f64,
    lon: f64,
) -> Result<()> {
    if !lat.is_finite() || !lon.is_finite() {
        return Err(Error::format(
            path,
            format!("{what}: coordinate is not a finite number (lat {lat}, lon {lon})"),
        ));
    }
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
        return Err(Error::format(
            path,
            format!("{what}: coordinate out of range (lat {lat}, lon {lon})"),
        ));
    }
    Ok(())
}

/// Vertex runs identified by their coordinates (no node ids), from
/// (longitude, latitude) pairs: every coordinate checked, runs of fewer than
/// two vertices dropped. `what` names the feature in errors.
pub(crate) fn coordinate_parts(
    path: &Path,
    what: &str,
    runs: impl IntoIterator<Item = Vec<(f64, f64)>>,
) -> Result<Vec<Vec<RawVertex>>> {
    let mut parts = Vec::new();
    for run in runs {
        let mut part = Vec::with_capacity(run.len());
        for (lon, lat) in run {
            check_coordinate(path, what, lat, lon)?;
            part.push(RawVertex {
                key: coordinate_key(lat, lon),
                lat,
                lon,
            });
        }
        if part.len() >= 2 {
            parts.push(part);
        }
    }
    Ok(parts)
}

struct Vertex {
    key: u64,
    lat: f64,
    lon: f64,
    enu: [f64; 2],
}

/// Builds the model. `edge_keys` are vertices next to nodes missing from the extract.
pub(crate) fn build(
    path: &Path,
    raw: Vec<RawRoad>,
    edge_keys: FxHashSet<u64>,
    mut report: LoadReport,
) -> Result<RoadNetwork> {
    // Bounding box in degrees, for the frame's origin.
    let (mut lat0, mut lat1, mut lon0, mut lon1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for v in raw.iter().flat_map(|r| r.parts.iter().flatten()) {
        lat0 = lat0.min(v.lat);
        lat1 = lat1.max(v.lat);
        lon0 = lon0.min(v.lon);
        lon1 = lon1.max(v.lon);
    }
    let usable = raw.iter().any(|r| r.parts.iter().any(|p| p.len() >= 2));
    if !usable {
        let detail = summary_of(&report);
        return Err(Error::EmptyNetwork {
            path: path.to_path_buf(),
            detail,
        });
    }
    let frame = EnuFrame::new(Geodetic::from_degrees(
        0.5 * (lat0 + lat1),
        0.5 * (lon0 + lon1),
        0.0,
    ));

    // Vertices in ENU; coincident consecutive vertices merged (their keys aliased).
    let mut alias: FxHashMap<u64, u64> = FxHashMap::default();
    let mut roads_v: Vec<(RoadAttributes, Vec<Vec<Vertex>>, bool)> = Vec::with_capacity(raw.len());
    for r in raw {
        let mut parts = Vec::with_capacity(r.parts.len());
        for part in r.parts {
            let mut out: Vec<Vertex> = Vec::with_capacity(part.len());
            for v in part {
                let e = frame.to_enu(&Geodetic::from_degrees(v.lat, v.lon, 0.0));
                let vert = Vertex {
                    key: v.key,
                    lat: v.lat,
                    lon: v.lon,
                    enu: [e[0], e[1]],
                };
                if let Some(prev) = out.last() {
                    let d = dist(prev.enu, vert.enu);
                    if d < COINCIDENT_M {
                        report.zero_length_segments += 1;
                        report.zero_length_at.push([vert.lat, vert.lon]);
                        if prev.key != vert.key {
                            let (a, b) = (resolve(&alias, prev.key), resolve(&alias, vert.key));
                            if a != b {
                                alias.insert(b, a);
                            }
                        }
                        continue;
                    }
                }
                out.push(vert);
            }
            if out.len() >= 2 {
                parts.push(out);
            }
        }
        if parts.is_empty() {
            report.skip("degenerate_geometry");
            continue;
        }
        roads_v.push((r.attributes, parts, r.cut));
    }
    if roads_v.is_empty() {
        let detail = summary_of(&report);
        return Err(Error::EmptyNetwork {
            path: path.to_path_buf(),
            detail,
        });
    }
    if !alias.is_empty() {
        for (_, parts, _) in roads_v.iter_mut() {
            for part in parts.iter_mut() {
                for v in part.iter_mut() {
                    v.key = resolve(&alias, v.key);
                }
                // Aliasing can make non-adjacent duplicates adjacent only through
                // merged keys; drop consecutive repeats again.
                part.dedup_by(|b, a| a.key == b.key);
            }
            parts.retain(|p| p.len() >= 2);
        }
        roads_v.retain(|(_, parts, _)| !parts.is_empty());
    }

    // Junctions: vertices used more than once, and the ends of every part.
    let mut uses: FxHashMap<u64, u32> = FxHashMap::default();
    for (_, parts, _) in &roads_v {
        for part in parts {
            for v in part {
                *uses.entry(v.key).or_default() += 1;
            }
        }
    }

    let mut roads = Vec::with_capacity(roads_v.len());
    let mut nodes: Vec<Node> = Vec::new();
    let mut node_of: FxHashMap<u64, u32> = FxHashMap::default();
    let mut sections: Vec<Section> = Vec::new();
    let mut segments: Vec<Segment> = Vec::new();

    let mut node_id = |v: &Vertex, nodes: &mut Vec<Node>| -> u32 {
        *node_of.entry(v.key).or_insert_with(|| {
            nodes.push(Node {
                enu: v.enu,
                lat_lon: [v.lat, v.lon],
                at_extract_edge: edge_keys.contains(&v.key),
            });
            (nodes.len() - 1) as u32
        })
    };

    for (attributes, parts, cut) in roads_v {
        let road_id = roads.len() as u32;
        let oneway = attributes.oneway;
        let mut road_sections = Vec::new();
        let mut road_offset = 0.0;
        for part in &parts {
            let mut start_idx = 0usize;
            let mut section_start = node_id(&part[0], &mut nodes);
            let mut first_segment = segments.len() as u32;
            let mut section_len = 0.0;
            for i in 1..part.len() {
                let (p, q) = (&part[i - 1], &part[i]);
                let len = dist(p.enu, q.enu);
                segments.push(Segment {
                    road: road_id,
                    section: sections.len() as u32,
                    a: p.enu,
                    b: q.enu,
                    a_lat_lon: [p.lat, p.lon],
                    b_lat_lon: [q.lat, q.lon],
                    length_m: len,
                    road_offset_m: road_offset,
                    section_offset_m: section_len,
                });
                road_offset += len;
                section_len += len;
                let is_last = i + 1 == part.len();
                if is_last || uses[&q.key] > 1 {
                    let end = node_id(q, &mut nodes);
                    let count = segments.len() as u32 - first_segment;
                    road_sections.push(sections.len() as u32);
                    sections.push(Section {
                        road: road_id,
                        start: section_start,
                        end,
                        first_segment,
                        segment_count: count,
                        length_m: section_len,
                        oneway,
                    });
                    section_start = end;
                    first_segment = segments.len() as u32;
                    section_len = 0.0;
                    start_idx = i;
                }
            }
            debug_assert_eq!(start_idx, part.len() - 1);
        }
        roads.push(Road {
            attributes,
            sections: road_sections,
            length_m: road_offset,
            cut_at_extract_edge: cut,
        });
    }

    let bbox = bounding_box(&segments);
    Ok(RoadNetwork {
        frame,
        roads,
        nodes,
        sections,
        segments,
        bbox,
        report,
    })
}

fn resolve(alias: &FxHashMap<u64, u64>, mut k: u64) -> u64 {
    while let Some(&n) = alias.get(&k) {
        k = n;
    }
    k
}

/// Distance (m) between two ENU points (`geo`'s Euclidean distance; off the
/// hot paths, so its `hypot` costs nothing that matters).
pub(crate) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    Euclidean.distance(coord(a), coord(b))
}

/// ENU bounding box of the segments' end points (min e, min n, max e, max n),
/// from `geo`'s bounding rectangle; an empty list gives an inverted box.
pub(crate) fn bounding_box(segments: &[Segment]) -> [f64; 4] {
    let ends: MultiPoint<f64> = segments
        .iter()
        .flat_map(|s| [s.a, s.b])
        .map(Point::from)
        .collect();
    match ends.bounding_rect() {
        Some(r) => [r.min().x, r.min().y, r.max().x, r.max().y],
        None => [f64::MAX, f64::MAX, f64::MIN, f64::MIN],
    }
}

fn summary_of(report: &LoadReport) -> String {
    let mut s = format!("{} features read", report.features_read);
    for (k, v) in &report.skipped {
        s.push_str(&format!(", {v} {k}"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::attributes::TagSet;

    fn road(id: &str, pts: &[(u64, f64, f64)]) -> RawRoad {
        RawRoad {
            attributes: TagSet::default().attributes(id.into()),
            parts: vec![pts
                .iter()
                .map(|&(key, lat, lon)| RawVertex { key, lat, lon })
                .collect()],
            cut: false,
        }
    }

    #[test]
    fn splits_at_shared_vertices() {
        // A straight road of 3 vertices crossed at its middle by a second road.
        let a = road(
            "a",
            &[(1, 60.0, 24.0), (2, 60.0, 24.001), (3, 60.0, 24.002)],
        );
        let b = road(
            "b",
            &[(4, 59.999, 24.001), (2, 60.0, 24.001), (5, 60.001, 24.001)],
        );
        let net = build(
            Path::new("t"),
            vec![a, b],
            FxHashSet::default(),
            LoadReport::default(),
        )
        .unwrap();
        assert_eq!(net.roads.len(), 2);
        assert_eq!(net.sections.len(), 4);
        assert_eq!(net.segments.len(), 4);
        assert_eq!(net.nodes.len(), 5);
        // 0.001 deg of longitude at 60 N is about 55.8 m.
        let l = net.sections[0].length_m;
        assert!((l - 55.8).abs() < 0.2, "{l}");
    }

    #[test]
    fn merges_coincident_vertices() {
        let a = road(
            "a",
            &[
                (1, 60.0, 24.0),
                (2, 60.0, 24.001),
                (9, 60.0, 24.001),
                (3, 60.0, 24.002),
            ],
        );
        let net = build(
            Path::new("t"),
            vec![a],
            FxHashSet::default(),
            LoadReport::default(),
        )
        .unwrap();
        assert_eq!(net.report.zero_length_segments, 1);
        assert_eq!(net.segments.len(), 2);
        assert_eq!(net.sections.len(), 1);
    }

    #[test]
    fn closed_way_is_a_loop_section() {
        let a = road(
            "ring",
            &[
                (1, 60.0, 24.0),
                (2, 60.0, 24.001),
                (3, 60.001, 24.001),
                (1, 60.0, 24.0),
            ],
        );
        let net = build(
            Path::new("t"),
            vec![a],
            FxHashSet::default(),
            LoadReport::default(),
        )
        .unwrap();
        assert_eq!(net.sections.len(), 1);
        assert_eq!(net.sections[0].start, net.sections[0].end);
        assert_eq!(net.nodes.len(), 1);
    }
}
