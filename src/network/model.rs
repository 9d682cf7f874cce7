//! The road network model: roads (input ways), topology nodes, road sections
//! between junctions, and straight segments, in WGS-84 and in a local ENU frame.

use super::attributes::{Oneway, RoadAttributes};
use crate::geodesy::EnuFrame;
use serde::Serialize;
use std::collections::BTreeMap;

/// Index of a road in [`RoadNetwork::roads`].
pub type RoadId = u32;
/// Index of a topology node in [`RoadNetwork::nodes`].
pub type NodeId = u32;
/// Index of a section in [`RoadNetwork::sections`].
pub type SectionId = u32;
/// Index of a segment in [`RoadNetwork::segments`].
pub type SegmentId = u32;

/// One input road: an OSM way or a GeoJSON (Multi)LineString feature.
#[derive(Debug, Clone)]
pub struct Road {
    /// The attributes read from the input.
    pub attributes: RoadAttributes,
    /// The road's sections in digitised order.
    pub sections: Vec<SectionId>,
    /// Total length of the road's present geometry (m).
    pub length_m: f64,
    /// Some of the way's nodes were missing from the extract.
    pub cut_at_extract_edge: bool,
}

/// A topology node: a junction, a road end, or a point where a road was cut.
#[derive(Debug, Clone, Copy)]
pub struct Node {
    /// ENU position (m) in the network's frame: east, north.
    pub enu: [f64; 2],
    /// WGS-84 latitude, longitude (degrees).
    pub lat_lon: [f64; 2],
    /// The node lies next to nodes missing from the extract (the way was cut here).
    pub at_extract_edge: bool,
}

/// A road section: the part of one road between two topology nodes, with no
/// junction inside it.
#[derive(Debug, Clone, Copy)]
pub struct Section {
    /// The road it belongs to.
    pub road: RoadId,
    /// Node at the section's start (in the road's digitised direction).
    pub start: NodeId,
    /// Node at the section's end.
    pub end: NodeId,
    /// First segment; the section's segments are contiguous.
    pub first_segment: SegmentId,
    /// Number of segments (at least one).
    pub segment_count: u32,
    /// Length (m).
    pub length_m: f64,
    /// Permitted travel direction.
    pub oneway: Oneway,
}

impl Section {
    /// The section's segment ids, start to end.
    pub fn segment_ids(&self) -> std::ops::Range<SegmentId> {
        self.first_segment..self.first_segment + self.segment_count
    }
}

/// A straight segment between two consecutive vertices of a road.
#[derive(Debug, Clone, Copy)]
pub struct Segment {
    /// The road it belongs to.
    pub road: RoadId,
    /// The section it belongs to.
    pub section: SectionId,
    /// Start point in ENU (m).
    pub a: [f64; 2],
    /// End point in ENU (m).
    pub b: [f64; 2],
    /// Start point, WGS-84 latitude and longitude (degrees).
    pub a_lat_lon: [f64; 2],
    /// End point, WGS-84 latitude and longitude (degrees).
    pub b_lat_lon: [f64; 2],
    /// Length in the ENU plane (m).
    pub length_m: f64,
    /// Distance from the road's start to this segment's start along the road (m).
    pub road_offset_m: f64,
    /// Distance from the section's start to this segment's start (m).
    pub section_offset_m: f64,
}

impl Segment {
    /// The segment in ENU (m) as a `geo` line, `a` to `b`.
    #[inline]
    pub fn line(&self) -> geo::Line<f64> {
        super::geometry::line(self.a, self.b)
    }
}

/// What a loader read and what it left out.
#[derive(Debug, Clone, Default, Serialize)]
pub struct LoadReport {
    /// The input format: `osm_pbf`, `osm_xml` or `geojson`.
    pub format: String,
    /// Ways or features read from the file.
    pub features_read: usize,
    /// Features left out, counted by reason.
    pub skipped: BTreeMap<String, usize>,
    /// Ways cut at the extract edge: nodes missing, present parts kept.
    pub cut_ways: usize,
    /// Zero-length segments (repeated or coincident vertices) removed.
    pub zero_length_segments: usize,
    /// Where the zero-length segments were (latitude, longitude in degrees).
    #[serde(skip)]
    pub zero_length_at: Vec<[f64; 2]>,
}

impl LoadReport {
    pub(crate) fn skip(&mut self, reason: &str) {
        *self.skipped.entry(reason.to_owned()).or_default() += 1;
    }
}

/// The road network model, as loaded; see [`super::Network`] for the indexed network.
#[derive(Debug, Clone)]
pub struct RoadNetwork {
    /// The local ENU frame, centred on the map's bounding box.
    pub frame: EnuFrame,
    /// Input roads.
    pub roads: Vec<Road>,
    /// Topology nodes.
    pub nodes: Vec<Node>,
    /// Road sections.
    pub sections: Vec<Section>,
    /// Straight segments.
    pub segments: Vec<Segment>,
    /// ENU bounding box of all segments: min east, min north, max east, max north.
    pub bbox: [f64; 4],
    /// What the loader read and skipped.
    pub report: LoadReport,
}

impl RoadNetwork {
    /// [`Self::bbox`] as a `geo` rectangle (east = x, north = y); `None` for
    /// a network without segments.
    pub fn bounding_rect(&self) -> Option<geo::Rect<f64>> {
        let [e0, n0, e1, n1] = self.bbox;
        (e0 <= e1 && n0 <= n1).then(|| geo::Rect::new([e0, n0], [e1, n1]))
    }

    /// Total length of all sections (m).
    pub fn length_m(&self) -> f64 {
        self.sections.iter().map(|s| s.length_m).sum()
    }

    /// The segments of a section.
    pub fn section_segments(&self, section: SectionId) -> &[Segment] {
        let s = &self.sections[section as usize];
        &self.segments[s.first_segment as usize..(s.first_segment + s.segment_count) as usize]
    }

    /// Attributes of the road a section belongs to.
    pub fn section_road(&self, section: SectionId) -> &Road {
        &self.roads[self.sections[section as usize].road as usize]
    }
}
