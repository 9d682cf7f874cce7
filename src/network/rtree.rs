//! An R-tree (crate `rstar`) over the network's segments as `geo` lines
//! (`geo-types` implements rstar's traits), answering the same queries as the
//! Hilbert grid with the same exact predicates, plus nearest segment
//! look-ups.

use super::geometry::{closest_on_segment, coord, norm_sq, point_segment_distance, rect};
use super::model::{Segment, SegmentId};
use geo::{Intersects, Line, Point};
use rstar::primitives::GeomWithData;
use rstar::{RTree, AABB};

type Entry = GeomWithData<Line<f64>, SegmentId>;

/// Bulk-loaded R-tree of segments.
#[derive(Debug, Clone)]
pub struct SegmentTree {
    tree: RTree<Entry>,
}

/// The envelope of the box `min`–`max`.
fn envelope(min: [f64; 2], max: [f64; 2]) -> AABB<Point<f64>> {
    AABB::from_corners(Point::from(min), Point::from(max))
}

impl SegmentTree {
    /// Bulk-loads the tree.
    pub fn build(segments: &[Segment]) -> Self {
        let entries = segments
            .iter()
            .enumerate()
            .map(|(i, s)| GeomWithData::new(s.line(), i as SegmentId))
            .collect();
        Self {
            tree: RTree::bulk_load(entries),
        }
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.tree.size()
    }

    /// The tree holds no segment.
    pub fn is_empty(&self) -> bool {
        self.tree.size() == 0
    }

    /// Segments within `radius` metres of `p`.
    pub fn within_radius(&self, p: [f64; 2], radius: f64) -> Vec<SegmentId> {
        let env = envelope(
            [p[0] - radius, p[1] - radius],
            [p[0] + radius, p[1] + radius],
        );
        let (pc, r2) = (coord(p), radius * radius);
        self.tree
            .locate_in_envelope_intersecting(&env)
            .filter(|e| {
                let (_, q) = closest_on_segment(e.geom(), pc);
                norm_sq(pc.x - q.x, pc.y - q.y) <= r2
            })
            .map(|e| e.data)
            .collect()
    }

    /// Segments touching the box `min`–`max`.
    pub fn in_box(&self, min: [f64; 2], max: [f64; 2]) -> Vec<SegmentId> {
        let r = rect(min, max);
        self.tree
            .locate_in_envelope_intersecting(&envelope(min, max))
            .filter(|e| r.intersects(e.geom()))
            .map(|e| e.data)
            .collect()
    }

    /// The segment nearest to `p` and its distance (m); `None` on an empty tree.
    pub fn nearest(&self, p: [f64; 2]) -> Option<(SegmentId, f64)> {
        self.tree.nearest_neighbor(&Point::from(p)).map(|e| {
            let g = e.geom();
            (
                e.data,
                point_segment_distance(p, g.start.into(), g.end.into()),
            )
        })
    }

    /// Segments in order of increasing distance from `p`.
    pub fn nearest_iter(&self, p: [f64; 2]) -> impl Iterator<Item = (SegmentId, f64)> + '_ {
        self.tree
            .nearest_neighbor_iter_with_distance_2(&Point::from(p))
            .map(|(e, d2)| (e.data, d2.sqrt()))
    }
}
