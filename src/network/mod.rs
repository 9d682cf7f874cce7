//! The road network: loaders for OSM PBF, OSM XML and GeoJSON into one model,
//! the Hilbert grid index and an R-tree over its segments, the connectivity
//! topology, and defect checks.

mod attributes;
mod build;
mod defects;
mod geojson_loader;
pub(crate) mod geometry;
mod grid;
pub(crate) mod hilbert;
mod inspect;
mod lanes;
mod model;
mod osm_common;
mod osm_pbf;
mod osm_xml;
mod rtree;
mod shapefile_loader;
mod topology;

pub use attributes::{
    parse_lanes, parse_length_m, parse_oneway, parse_speed_kmh, DrivableFilter, Oneway, Rejection,
    RoadAttributes, TagSet,
};
pub use defects::{check as check_defects, Defect, DefectReport, DEFAULT_NODE_TOLERANCE_M};
pub use geometry::{point_segment_distance, segment_intersects_box};
pub use grid::{
    auto_grid_n, auto_grid_n_for, GridIndex, AUTO_CELL_M, MAX_CELLS_PER_SEGMENT, MAX_GRID_N,
};
pub use inspect::{inspect, Components, CountLength, GridFigures, Inspection};
pub use lanes::{
    carriageway_lanes, lane_offset_m, lane_offset_moments, lane_width_m, lanes_per_direction,
    DriveSide,
};
pub use model::{
    LoadReport, Node, NodeId, Road, RoadId, RoadNetwork, Section, SectionId, Segment, SegmentId,
};
pub use rtree::SegmentTree;
pub use topology::{DirectedSection, Incidence, SectionEnd, Topology};

use crate::error::{Error, Result};
use std::path::Path;
use std::time::Instant;

/// How to load a map.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoadOptions {
    /// Also load `highway=track`.
    pub include_tracks: bool,
    /// Grid size N (a power of two); `None` chooses it from the map's size.
    pub grid_n: Option<u32>,
}

/// Map file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapFormat {
    /// OpenStreetMap protocol buffers (`.osm.pbf`).
    OsmPbf,
    /// OpenStreetMap XML (`.osm`).
    OsmXml,
    /// GeoJSON FeatureCollection.
    GeoJson,
    /// ESRI shapefile (`.shp` with `.dbf` beside it), WGS-84 coordinates.
    Shapefile,
}

/// Time spent building each part (ms).
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct BuildTimings {
    /// Reading the file.
    pub read_ms: f64,
    /// Decoding and building the model (sections, segments).
    pub load_ms: f64,
    /// Building the Hilbert grid.
    pub grid_ms: f64,
    /// Building the R-tree.
    pub rtree_ms: f64,
    /// Building the topology and components.
    pub topology_ms: f64,
}

/// A loaded, indexed road network.
#[derive(Debug, Clone)]
pub struct Network {
    /// The model.
    pub model: RoadNetwork,
    /// Hilbert grid over the segments.
    pub grid: GridIndex,
    /// R-tree over the segments.
    pub rtree: SegmentTree,
    /// Connectivity.
    pub topology: Topology,
    /// Build times.
    pub timings: BuildTimings,
}

impl std::ops::Deref for Network {
    type Target = RoadNetwork;
    fn deref(&self) -> &RoadNetwork {
        &self.model
    }
}

/// Largest map file read (bytes): 1 GiB. The loader keeps the whole file
/// and the model built from it in memory (several times the file's size);
/// an endless input (`/dev/zero`, a pipe) stops here instead of filling
/// memory.
pub const MAX_MAP_BYTES: u64 = 1 << 30;

/// Reads a map file up to [`MAX_MAP_BYTES`]; content that no format starts
/// with is refused from its first bytes, before the rest is read.
fn read_map(path: &Path) -> Result<Vec<u8>> {
    const HEAD: u64 = 64 * 1024;
    let head = crate::fsio::read_head(path, HEAD)?;
    // The format follows the first non-blank byte: decided by the head
    // unless it is all blank and longer input follows.
    let decided = (head.len() as u64) < HEAD || head.iter().any(|b| !b.is_ascii_whitespace());
    if decided {
        detect_format(path, &head)?;
    }
    crate::fsio::read_limited(path, MAX_MAP_BYTES, "map")
}

/// Decides a map's format from its first bytes, then its extension.
pub fn detect_format(path: &Path, bytes: &[u8]) -> Result<MapFormat> {
    let start = bytes
        .strip_prefix(b"\xEF\xBB\xBF".as_slice())
        .unwrap_or(bytes);
    let first = start.iter().find(|b| !b.is_ascii_whitespace()).copied();
    match first {
        Some(b'{') => return Ok(MapFormat::GeoJson),
        Some(b'<') => return Ok(MapFormat::OsmXml),
        _ => {}
    }
    // Shapefile: the file code 9994 as a big-endian integer.
    if bytes.starts_with(&[0x00, 0x00, 0x27, 0x0A]) {
        return Ok(MapFormat::Shapefile);
    }
    // PBF: a 4-byte big-endian header length, then a BlobHeader whose first
    // field (tag 0x0A) is the type string "OSMHeader" or "OSMData".
    if bytes.len() >= 8 {
        let len = u32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
        if len > 0 && len < 64 * 1024 && bytes[4] == 0x0A {
            return Ok(MapFormat::OsmPbf);
        }
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if bytes.is_empty() {
        return Err(Error::format(path, "the file is empty"));
    }
    if name.ends_with(".pbf") {
        return Err(Error::format(
            path,
            "not a readable OSM PBF file: bad file header",
        ));
    }
    if name.ends_with(".geojson") || name.ends_with(".json") {
        return Err(Error::format(
            path,
            "invalid JSON: the file does not start with '{'",
        ));
    }
    if name.ends_with(".shp") {
        return Err(Error::format(
            path,
            "not a readable shapefile: bad file code",
        ));
    }
    if name.ends_with(".osm") || name.ends_with(".xml") {
        return Err(Error::format(
            path,
            "invalid OSM XML: the file does not start with '<'",
        ));
    }
    Err(Error::format(
        path,
        "unrecognised map format (expected OSM PBF, OSM XML, GeoJSON or a shapefile)",
    ))
}

/// Builds the model from a map file's bytes (no indexes).
pub fn load_model(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<RoadNetwork> {
    let filter = DrivableFilter {
        include_tracks: options.include_tracks,
    };
    let (raw, edges, report) = match detect_format(path, bytes)? {
        MapFormat::OsmPbf => osm_pbf::load(path, bytes, filter)?,
        MapFormat::OsmXml => osm_xml::load(path, bytes, filter)?,
        MapFormat::GeoJson => geojson_loader::load(path, bytes, filter)?,
        MapFormat::Shapefile => shapefile_loader::load(path, bytes, filter)?,
    };
    build::build(path, raw, edges, report)
}

/// Builds a model from polylines of (latitude, longitude) in degrees, one list
/// of parts per road; vertices at identical coordinates (to 1e-7 degree) are
/// shared, so roads meeting at a point are joined there. For programmatic and
/// synthetic networks.
pub fn model_from_polylines(
    roads: Vec<(RoadAttributes, Vec<Vec<[f64; 2]>>)>,
) -> Result<RoadNetwork> {
    let path = Path::new("<polylines>");
    let mut raw = Vec::with_capacity(roads.len());
    let mut report = LoadReport {
        format: "polylines".into(),
        ..Default::default()
    };
    for (attributes, parts) in roads {
        report.features_read += 1;
        let what = format!("road {}", attributes.id);
        let runs = parts
            .into_iter()
            .map(|part| part.into_iter().map(|[lat, lon]| (lon, lat)).collect());
        let out = build::coordinate_parts(path, &what, runs)?;
        raw.push(build::RawRoad {
            attributes,
            parts: out,
            cut: false,
        });
    }
    build::build(path, raw, Default::default(), report)
}

impl Network {
    /// Loads, indexes and topologises the map at `path`.
    pub fn load(path: &Path, options: &LoadOptions) -> Result<Network> {
        let t0 = Instant::now();
        let bytes = read_map(path)?;
        let read_ms = ms(t0);
        let t1 = Instant::now();
        let model = load_model(path, &bytes, options)?;
        let load_ms = ms(t1);
        let mut net = Network::from_model(model, options.grid_n)?;
        net.timings.read_ms = read_ms;
        net.timings.load_ms = load_ms;
        tracing::info!(
            roads = net.roads.len(),
            sections = net.sections.len(),
            segments = net.segments.len(),
            read_ms,
            load_ms,
            "loaded map {}",
            path.display()
        );
        Ok(net)
    }

    /// Indexes and topologises a model. The grid and the R-tree are built in
    /// parallel on maps of at least [`PARALLEL_INDEX_SEGMENTS`] segments.
    pub fn from_model(model: RoadNetwork, grid_n: Option<u32>) -> Result<Network> {
        let grid_job = || {
            let t = Instant::now();
            let g = GridIndex::build(&model.segments, model.bbox, grid_n);
            (g, ms(t))
        };
        let rtree_job = || {
            let t = Instant::now();
            let r = SegmentTree::build(&model.segments);
            (r, ms(t))
        };
        let ((grid, grid_ms), (rtree, rtree_ms)) =
            if model.segments.len() >= PARALLEL_INDEX_SEGMENTS {
                rayon::join(grid_job, rtree_job)
            } else {
                (grid_job(), rtree_job())
            };
        let grid = grid?;
        let t = Instant::now();
        let topology = Topology::build(&model);
        let topology_ms = ms(t);
        Ok(Network {
            model,
            grid,
            rtree,
            topology,
            timings: BuildTimings {
                grid_ms,
                rtree_ms,
                topology_ms,
                ..Default::default()
            },
        })
    }

    /// The smallest box `([x_min, y_min], [x_max, y_max])` (local ENU
    /// metres) holding every segment's end points; `None` for a map
    /// without segments.
    pub fn enu_bounds(&self) -> Option<([f64; 2], [f64; 2])> {
        let mut ends = self.segments.iter().flat_map(|sg| [sg.a, sg.b]);
        let first = ends.next()?;
        Some(ends.fold((first, first), |(lo, hi), q| {
            (
                [lo[0].min(q[0]), lo[1].min(q[1])],
                [hi[0].max(q[0]), hi[1].max(q[1])],
            )
        }))
    }

    /// Runs the defect checks with the given near-node tolerance (m).
    pub fn defects(&self, tolerance_m: f64) -> DefectReport {
        check_defects(&self.model, &self.topology, &self.grid, tolerance_m)
    }
}

/// Fewest segments for which the grid and the R-tree are built on two
/// threads: below it each takes at most about a millisecond (Stockholm's
/// 3,477 segments: grid 0.2 ms, R-tree 0.7 ms), no more than handing work to
/// another thread can cost on a busy machine.
pub const PARALLEL_INDEX_SEGMENTS: usize = 4096;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Fixtures the unit tests of the spatial queries share (the grid's and
/// the matcher's): the maps they run on and the points they query.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::Network;

    /// A bundled toy map and the three real ones of `tests/data/real`
    /// (FMM's example network, GraphHopper's issue 70 and 13 maps), with
    /// their paths.
    pub(crate) fn query_maps() -> Vec<(&'static str, Network)> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        [
            "tests/data/small.osm",
            "tests/data/real/fmm-network.geojson",
            "tests/data/real/issue-70.osm",
            "tests/data/real/issue-13.osm",
        ]
        .into_iter()
        .map(|map| {
            let net = Network::load(&root.join(map), &Default::default())
                .unwrap_or_else(|e| panic!("{map}: {e}"));
            (map, net)
        })
        .collect()
    }

    /// An `(n + 1) × (n + 1)` lattice over the map's box and `margin` of
    /// its size beyond each side (0.5: half the box), shifted by `shift`
    /// metres so that no point sits on a grid line; row by row in x, then
    /// y.
    pub(crate) fn lattice(net: &Network, n: u32, margin: f64, shift: [f64; 2]) -> Vec<[f64; 2]> {
        let ([x0, y0], [x1, y1]) = net.enu_bounds().expect("a map with segments");
        let at = |lo: f64, hi: f64, k: u32| {
            lo + (hi - lo) * (-margin + (1.0 + 2.0 * margin) * f64::from(k) / f64::from(n))
        };
        (0..=n)
            .flat_map(|i| (0..=n).map(move |j| (i, j)))
            .map(|(i, j)| [at(x0, x1, i) + shift[0], at(y0, y1, j) + shift[1]])
            .collect()
    }
}
