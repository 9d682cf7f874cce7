//! The figures `waymark network inspect` prints.

use super::{DefectReport, Network};
use serde::Serialize;
use std::collections::BTreeMap;

/// Length and count of a subset of roads.
#[derive(Debug, Clone, Serialize)]
pub struct CountLength {
    /// Number of roads.
    pub count: usize,
    /// Their length (km).
    pub length_km: f64,
}

/// Component counts.
#[derive(Debug, Clone, Serialize)]
pub struct Components {
    /// Weakly connected components (ignoring one-way restrictions).
    pub weak: usize,
    /// Strongly connected components (directed travel).
    pub strong: usize,
    /// Share of road length inside the largest strongly connected component.
    pub largest_strong_length_share: f64,
}

/// Grid figures.
#[derive(Debug, Clone, Serialize)]
pub struct GridFigures {
    /// Cells per side.
    pub n: u32,
    /// Cells holding at least one segment.
    pub occupied_cells: usize,
    /// Cell size (m), east and north.
    pub cell_size_m: [f64; 2],
    /// Mean segment registrations per occupied cell.
    pub mean_segments_per_occupied_cell: f64,
}

/// Everything `network inspect` reports.
#[derive(Debug, Clone, Serialize)]
pub struct Inspection {
    /// The map file.
    pub file: String,
    /// Its format.
    pub format: String,
    /// Roads (input ways or features kept).
    pub roads: usize,
    /// Road sections between junctions.
    pub sections: usize,
    /// Straight segments.
    pub segments: usize,
    /// Topology nodes (junctions, road ends, extract-edge cuts).
    pub nodes: usize,
    /// Total road length (km).
    pub length_km: f64,
    /// Roads in tunnels.
    pub tunnels: CountLength,
    /// Roads on bridges.
    pub bridges: CountLength,
    /// Share of road length that is one-way.
    pub oneway_share: f64,
    /// Component counts.
    pub components: Components,
    /// Grid figures.
    pub grid: GridFigures,
    /// Defect counts by kind.
    pub defects: BTreeMap<&'static str, usize>,
    /// Features left out, by reason.
    pub skipped: BTreeMap<String, usize>,
    /// Ways or features read.
    pub features_read: usize,
    /// Ways cut at the extract edge (present parts kept).
    pub cut_ways: usize,
    /// Road length (km) by `highway` class.
    pub length_km_by_class: BTreeMap<String, f64>,
    /// Bounding box: min latitude, min longitude, max latitude, max longitude.
    pub bbox_deg: [f64; 4],
    /// Build and check times (ms).
    pub timings_ms: BTreeMap<&'static str, f64>,
    /// Data attribution for OpenStreetMap-derived maps.
    pub attribution: &'static str,
}

/// Gathers the figures for a loaded network and its defect report.
/// `defects_ms` is the time the defect checks took.
pub fn inspect(file: &str, net: &Network, defects: &DefectReport, defects_ms: f64) -> Inspection {
    let total_m = net.length_m();
    let road_len = |pred: &dyn Fn(&super::Road) -> bool| -> CountLength {
        let roads: Vec<_> = net.roads.iter().filter(|r| pred(r)).collect();
        CountLength {
            count: roads.len(),
            // Folded from +0.0: an empty f64 `sum` is -0.0, printed "-0".
            length_km: roads.iter().fold(0.0, |a, r| a + r.length_m) / 1e3,
        }
    };
    let oneway_m: f64 = net
        .sections
        .iter()
        .filter(|s| s.oneway.is_oneway())
        .fold(0.0, |a, s| a + s.length_m);
    let mut by_class: BTreeMap<String, f64> = BTreeMap::new();
    for r in &net.roads {
        *by_class.entry(r.attributes.highway.clone()).or_default() += r.length_m / 1e3;
    }
    let occupied = net.grid.occupied_cells();
    // WGS-84 bounding box of every node and segment end (geo's bounding
    // rectangle, x = longitude, y = latitude), reported as latitude,
    // longitude pairs.
    let ends: geo::MultiPoint<f64> = net
        .nodes
        .iter()
        .map(|n| n.lat_lon)
        .chain(net.segments.iter().flat_map(|s| [s.a_lat_lon, s.b_lat_lon]))
        .map(|[lat, lon]| geo::Point::new(lon, lat))
        .collect();
    let bbox_deg = match geo::BoundingRect::bounding_rect(&ends) {
        Some(r) => [r.min().y, r.min().x, r.max().y, r.max().x],
        None => [f64::MAX, f64::MAX, f64::MIN, f64::MIN],
    };
    let t = &net.timings;
    let timings_ms = BTreeMap::from([
        ("read", t.read_ms),
        ("load", t.load_ms),
        ("grid", t.grid_ms),
        ("rtree", t.rtree_ms),
        ("topology", t.topology_ms),
        ("defects", defects_ms),
        (
            "total",
            t.read_ms + t.load_ms + t.grid_ms.max(t.rtree_ms) + t.topology_ms + defects_ms,
        ),
    ]);
    Inspection {
        file: file.to_owned(),
        format: net.report.format.clone(),
        roads: net.roads.len(),
        sections: net.sections.len(),
        segments: net.segments.len(),
        nodes: net.nodes.len(),
        length_km: total_m / 1e3,
        tunnels: road_len(&|r| r.attributes.tunnel),
        bridges: road_len(&|r| r.attributes.bridge),
        oneway_share: if total_m > 0.0 {
            oneway_m / total_m
        } else {
            0.0
        },
        components: Components {
            weak: net.topology.weak_components,
            strong: net.topology.strong_components,
            largest_strong_length_share: net.topology.largest_scc_length_share(&net.model),
        },
        grid: GridFigures {
            n: net.grid.n(),
            occupied_cells: occupied,
            cell_size_m: net.grid.cell_size(),
            mean_segments_per_occupied_cell: if occupied > 0 {
                net.grid.registrations() as f64 / occupied as f64
            } else {
                0.0
            },
        },
        defects: defects.counts.clone(),
        skipped: net.report.skipped.clone(),
        features_read: net.report.features_read,
        cut_ways: net.report.cut_ways,
        length_km_by_class: by_class,
        bbox_deg,
        timings_ms,
        attribution: "© OpenStreetMap contributors, ODbL",
    }
}

impl Inspection {
    /// A human-readable multi-line summary.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let mut line = |l: String| {
            s.push_str(&l);
            s.push('\n');
        };
        line(format!("map        {} ({})", self.file, self.format));
        line(format!(
            "roads      {} ({} features read, {} cut at the extract edge)",
            self.roads, self.features_read, self.cut_ways
        ));
        line(format!(
            "sections   {}   segments {}   nodes {}",
            self.sections, self.segments, self.nodes
        ));
        line(format!("length     {:.2} km", self.length_km));
        line(format!(
            "tunnels    {} roads, {:.2} km   bridges {} roads, {:.2} km",
            self.tunnels.count, self.tunnels.length_km, self.bridges.count, self.bridges.length_km
        ));
        line(format!(
            "one-way    {:.1} % of length",
            100.0 * self.oneway_share
        ));
        line(format!(
            "components {} weak, {} strong (largest strong holds {:.1} % of length)",
            self.components.weak,
            self.components.strong,
            100.0 * self.components.largest_strong_length_share
        ));
        line(format!(
            "grid       N={} ({:.0} x {:.0} m cells), {} occupied, {:.1} segments per occupied cell",
            self.grid.n,
            self.grid.cell_size_m[0],
            self.grid.cell_size_m[1],
            self.grid.occupied_cells,
            self.grid.mean_segments_per_occupied_cell
        ));
        let join = |m: &mut dyn Iterator<Item = (String, String)>| {
            m.map(|(k, v)| format!("{k} {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        line(format!(
            "defects    {}",
            join(
                &mut self
                    .defects
                    .iter()
                    .map(|(k, v)| (k.to_string(), v.to_string()))
            )
        ));
        let skipped = join(&mut self.skipped.iter().map(|(k, v)| (k.clone(), v.to_string())));
        line(format!(
            "skipped    {}",
            if skipped.is_empty() {
                "none".to_owned()
            } else {
                skipped
            }
        ));
        line(format!(
            "timings    {}",
            join(
                &mut self
                    .timings_ms
                    .iter()
                    .map(|(k, v)| (k.to_string(), format!("{v:.1} ms")))
            )
        ));
        line(format!("data       {}", self.attribution));
        s
    }
}
