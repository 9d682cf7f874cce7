//! OpenStreetMap PBF loader (crate `osmpbf`): blobs decoded in parallel, node
//! coordinates kept in an id-sorted table, drivable ways turned into raw roads.

use super::attributes::{DrivableFilter, RoadAttributes, TagSet};
use super::build::RawRoad;
use super::model::LoadReport;
use super::osm_common::{assemble_ways, OsmWay};
use crate::error::{Error, Result};
use osmpbf::{BlobDecode, BlobReader, PrimitiveBlock};
use rayon::prelude::*;
use rustc_hash::FxHashSet;
use std::path::Path;

#[derive(Default)]
struct Partial {
    /// (id, latitude, longitude) in degrees.
    nodes: Vec<(i64, f64, f64)>,
    ways: Vec<OsmWay>,
    skipped: Vec<&'static str>,
    ways_read: usize,
}

/// Reads an OSM PBF file held in memory.
pub(crate) fn load(
    path: &Path,
    bytes: &[u8],
    filter: DrivableFilter,
) -> Result<(Vec<RawRoad>, FxHashSet<u64>, LoadReport)> {
    let bad = |e: osmpbf::Error| Error::format(path, format!("not a readable OSM PBF file: {e}"));
    let mut blobs = Vec::new();
    for blob in BlobReader::new(bytes) {
        blobs.push(blob.map_err(bad)?);
    }
    if blobs.is_empty() {
        return Err(Error::format(
            path,
            "not a readable OSM PBF file: no data blocks",
        ));
    }
    let partials: Vec<Partial> = blobs
        .par_iter()
        .map(|blob| match blob.decode().map_err(bad)? {
            BlobDecode::OsmData(block) => Ok(read_block(&block, filter)),
            BlobDecode::OsmHeader(_) | BlobDecode::Unknown(_) => Ok(Partial::default()),
        })
        .collect::<Result<_>>()?;

    let mut report = LoadReport {
        format: "osm_pbf".into(),
        ..Default::default()
    };
    let mut nodes = Vec::with_capacity(partials.iter().map(|p| p.nodes.len()).sum());
    let mut ways = Vec::new();
    for p in partials {
        nodes.extend(p.nodes);
        ways.extend(p.ways);
        report.features_read += p.ways_read;
        for s in p.skipped {
            report.skip(s);
        }
    }
    nodes.par_sort_unstable_by_key(|n| n.0);
    assemble_ways(path, &nodes, ways, report)
}

fn read_block(block: &PrimitiveBlock, filter: DrivableFilter) -> Partial {
    let mut out = Partial::default();
    for group in block.groups() {
        for n in group.dense_nodes() {
            out.nodes.push((n.id(), n.lat(), n.lon()));
        }
        for n in group.nodes() {
            out.nodes.push((n.id(), n.lat(), n.lon()));
        }
        for w in group.ways() {
            let mut tags = TagSet::default();
            for (k, v) in w.tags() {
                tags.set(k, v);
            }
            let Some(highway) = tags.highway else {
                continue;
            };
            out.ways_read += 1;
            if let Err(r) = filter.check(highway, tags.area) {
                out.skipped.push(r.key());
                continue;
            }
            let attributes: RoadAttributes = tags.attributes(w.id().to_string());
            out.ways.push(OsmWay {
                attributes,
                refs: w.refs().collect(),
            });
        }
    }
    out
}
