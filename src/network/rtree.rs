//! An R-tree (crate `rstar`) over the network's segments, answering the same
//! queries as the Hilbert grid with the same exact predicates, plus nearest
//! segment look-ups.

use super::geometry::{point_segment_distance, point_segment_distance_sq, segment_intersects_box};
use super::model::{Segment, SegmentId};
use rstar::primitives::{GeomWithData, Line};
use rstar::{RTree, AABB};

type Entry = GeomWithData<Line<[f64; 2]>, SegmentId>;

/// Bulk-loaded R-tree of segments.
#[derive(Debug, Clone)]
pub struct SegmentTree {
    tree: RTree<Entry>,
}

impl SegmentTree {
    /// Bulk-loads the tree.
    pub fn build(segments: &[Segment]) -> Self {
        let entries = segments
            .iter()
            .enumerate()
            .map(|(i, s)| GeomWithData::new(Line::new(s.a, s.b), i as SegmentId))
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
        let env = AABB::from_corners(
            [p[0] - radius, p[1] - radius],
            [p[0] + radius, p[1] + radius],
        );
        self.tree
            .locate_in_envelope_intersecting(&env)
            .filter(|e| point_segment_distance_sq(p, e.geom().from, e.geom().to) <= radius * radius)
            .map(|e| e.data)
            .collect()
    }

    /// Segments touching the box `min`–`max`.
    pub fn in_box(&self, min: [f64; 2], max: [f64; 2]) -> Vec<SegmentId> {
        let env = AABB::from_corners(min, max);
        self.tree
            .locate_in_envelope_intersecting(&env)
            .filter(|e| segment_intersects_box(e.geom().from, e.geom().to, min, max))
            .map(|e| e.data)
            .collect()
    }

    /// The segment nearest to `p` and its distance (m); `None` on an empty tree.
    pub fn nearest(&self, p: [f64; 2]) -> Option<(SegmentId, f64)> {
        self.tree.nearest_neighbor(&p).map(|e| {
            (
                e.data,
                point_segment_distance(p, e.geom().from, e.geom().to),
            )
        })
    }

    /// Segments in order of increasing distance from `p`.
    pub fn nearest_iter(&self, p: [f64; 2]) -> impl Iterator<Item = (SegmentId, f64)> + '_ {
        self.tree
            .nearest_neighbor_iter_with_distance_2(&p)
            .map(|(e, d2)| (e.data, d2.sqrt()))
    }
}
