//! What the two OSM loaders share: resolving way node references against the
//! node table, keeping the present parts of ways cut at the extract edge.

use super::attributes::RoadAttributes;
use super::build::{check_coordinate, RawRoad, RawVertex};
use super::model::LoadReport;
use crate::error::Result;
use rustc_hash::FxHashSet;
use std::path::Path;

/// A drivable way with its node references.
pub(crate) struct OsmWay {
    pub attributes: RoadAttributes,
    pub refs: Vec<i64>,
}

/// Resolves node references; `nodes` must be sorted by id.
///
/// A way whose nodes are partly missing (cut at the extract edge) keeps each
/// run of two or more present nodes as a part; the vertices next to a gap are
/// returned as extract-edge keys. A way with no such run is skipped
/// (`nodes_missing`).
pub(crate) fn assemble_ways(
    path: &Path,
    nodes: &[(i64, f64, f64)],
    ways: Vec<OsmWay>,
    mut report: LoadReport,
) -> Result<(Vec<RawRoad>, FxHashSet<u64>, LoadReport)> {
    let mut edge_keys = FxHashSet::default();
    let mut roads = Vec::with_capacity(ways.len());
    for way in ways {
        let mut parts: Vec<Vec<RawVertex>> = Vec::new();
        let mut current: Vec<RawVertex> = Vec::new();
        let mut cut = false;
        for &r in &way.refs {
            match nodes.binary_search_by_key(&r, |n| n.0) {
                Ok(i) => {
                    let (_, lat, lon) = nodes[i];
                    check_coordinate(path, format_args!("node {r}"), lat, lon)?;
                    current.push(RawVertex {
                        key: r as u64,
                        lat,
                        lon,
                    });
                }
                Err(_) => {
                    if let Some(last) = current.last() {
                        edge_keys.insert(last.key);
                    }
                    cut = true;
                    if current.len() >= 2 {
                        parts.push(std::mem::take(&mut current));
                    } else {
                        current.clear();
                    }
                }
            }
        }
        if cut {
            // The first vertex after a gap is also at the edge.
            for p in parts.iter().chain(std::iter::once(&current)) {
                if let Some(first) = p.first() {
                    if way.refs.first() != Some(&(first.key as i64)) {
                        edge_keys.insert(first.key);
                    }
                }
            }
        }
        if current.len() >= 2 {
            parts.push(current);
        }
        if parts.is_empty() {
            report.skip("nodes_missing");
            continue;
        }
        if cut {
            report.cut_ways += 1;
        }
        roads.push(RawRoad {
            attributes: way.attributes,
            parts,
            cut,
        });
    }
    Ok((roads, edge_keys, report))
}
