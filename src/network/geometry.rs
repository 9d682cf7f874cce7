//! Planar geometry on ENU coordinates (metres), shared by the indexes, the
//! defect checks, routes and the map matchers.
//!
//! The algorithms are the `geo` crate's planar (Euclidean) ones: closest
//! point on a segment ([`geo::LineLocatePoint`], then
//! [`geo::InterpolatePoint::point_at_ratio_between`]), segment–box
//! intersection ([`geo::Intersects`]), bounding rectangles
//! ([`geo::BoundingRect`]). The model keeps its coordinates as `[f64; 2]`
//! (east, north); [`coord`], [`line`] and [`rect`] convert.
//!
//! One small kernel stays hand-written: the length of the vector from a point
//! to its closest point, [`norm`] / [`norm_sq`]. `geo`'s `Euclidean.distance`
//! uses `f64::hypot`, which measured 5–10× slower than `sqrt(dx² + dy²)` in
//! the grid's and the matchers' inner loops (2 M point–segment pairs on
//! Monaco: 123 ms against 15 ms); coordinates are metres in a local frame,
//! so the plain formula cannot overflow.
//!
//! The segment–box test ([`segment_intersects_box`]) is `geo`'s, with exact
//! predicates; it measured 2–3× slower than the Liang–Barsky clipping it
//! replaced, and serves only the indexes' box queries (`in_box`), which no
//! matcher and no benchmark uses.

use geo::{Coord, Euclidean, InterpolatePoint, Intersects, Line, LineLocatePoint, Point, Rect};

/// An ENU point (east, north; m) as a `geo` coordinate.
#[inline]
pub fn coord(p: [f64; 2]) -> Coord<f64> {
    Coord { x: p[0], y: p[1] }
}

/// The segment `a`–`b` as a `geo` line.
#[inline]
pub fn line(a: [f64; 2], b: [f64; 2]) -> Line<f64> {
    Line::new(coord(a), coord(b))
}

/// The box with corners `min` and `max` as a `geo` rectangle.
#[inline]
pub fn rect(min: [f64; 2], max: [f64; 2]) -> Rect<f64> {
    Rect::new(coord(min), coord(max))
}

/// Length (m) of the vector (`dx`, `dy`) in the local frame (see the module
/// documentation for why this is not `geo`'s `hypot`-based distance).
#[inline]
pub fn norm(dx: f64, dy: f64) -> f64 {
    norm_sq(dx, dy).sqrt()
}

/// Squared length (m²) of the vector (`dx`, `dy`).
#[inline]
pub fn norm_sq(dx: f64, dy: f64) -> f64 {
    dx * dx + dy * dy
}

/// The point of `segment` closest to `p`: its fraction along the segment
/// (0 at the start, 1 at the end) and the point. A zero-length segment gives
/// its start; a non-finite position gives fraction 0.
#[inline]
pub fn closest_on_segment(segment: &Line<f64>, p: Coord<f64>) -> (f64, Coord<f64>) {
    let t = segment.line_locate_point(&Point(p)).unwrap_or(0.0);
    (t, point_at_ratio(segment, t))
}

/// The point at fraction `t` along `segment` (not clamped): start + t·(end − start).
#[inline]
pub fn point_at_ratio(segment: &Line<f64>, t: f64) -> Coord<f64> {
    Euclidean
        .point_at_ratio_between(segment.start_point(), segment.end_point(), t)
        .0
}

/// Distance (m) from point `p` to the segment `a`–`b`; a zero-length segment
/// is treated as the point `a`.
#[inline]
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    point_segment_distance_sq(p, a, b).sqrt()
}

/// Squared distance (m²) from point `p` to the segment `a`–`b`.
#[inline]
pub fn point_segment_distance_sq(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let p = coord(p);
    let (_, q) = closest_on_segment(&line(a, b), p);
    norm_sq(p.x - q.x, p.y - q.y)
}

/// Does the segment `a`–`b` touch the closed box `min`–`max`? (A segment on
/// the box's boundary counts; `geo`'s exact orientation predicates.)
#[inline]
pub fn segment_intersects_box(a: [f64; 2], b: [f64; 2], min: [f64; 2], max: [f64; 2]) -> bool {
    rect(min, max).intersects(&line(a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances() {
        assert_eq!(
            point_segment_distance([0.0, 1.0], [-1.0, 0.0], [1.0, 0.0]),
            1.0
        );
        assert_eq!(
            point_segment_distance([3.0, 4.0], [0.0, 0.0], [0.0, 0.0]),
            5.0
        );
        assert_eq!(
            point_segment_distance([4.0, 4.0], [0.0, 0.0], [1.0, 0.0]),
            5.0
        );
    }

    #[test]
    fn closest_points() {
        let l = line([0.0, 0.0], [4.0, 0.0]);
        assert_eq!(
            closest_on_segment(&l, coord([1.0, 3.0])),
            (0.25, coord([1.0, 0.0]))
        );
        assert_eq!(
            closest_on_segment(&l, coord([-2.0, 1.0])),
            (0.0, coord([0.0, 0.0]))
        );
        assert_eq!(
            closest_on_segment(&l, coord([9.0, -1.0])),
            (1.0, coord([4.0, 0.0]))
        );
        let dot = line([2.0, 2.0], [2.0, 2.0]);
        assert_eq!(
            closest_on_segment(&dot, coord([5.0, 6.0])),
            (0.0, coord([2.0, 2.0]))
        );
    }

    #[test]
    fn box_intersection() {
        let (lo, hi) = ([0.0, 0.0], [1.0, 1.0]);
        assert!(segment_intersects_box([-1.0, 0.5], [2.0, 0.5], lo, hi)); // crosses
        assert!(!segment_intersects_box([-1.0, 2.0], [2.0, 2.0], lo, hi)); // above
        assert!(!segment_intersects_box(
            [-1.0, 0.0],
            [0.0, -1.0],
            [0.1, 0.1],
            hi
        )); // corner miss
        assert!(segment_intersects_box([-1.0, 0.0], [1.0, 2.0], lo, hi)); // touches a corner
        assert!(segment_intersects_box([0.5, 0.5], [0.6, 0.6], lo, hi)); // inside
    }
}
