//! Planar geometry on ENU coordinates shared by the indexes and the defect checks.

/// Distance (m) from point `p` to the segment `a`–`b`; a zero-length segment
/// is treated as the point `a`.
#[inline]
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    point_segment_distance_sq(p, a, b).sqrt()
}

/// Squared distance (m²) from point `p` to the segment `a`–`b`.
#[inline]
pub fn point_segment_distance_sq(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (p[0] - (a[0] + t * dx), p[1] - (a[1] + t * dy));
    ex * ex + ey * ey
}

/// Does the segment `a`–`b` touch the closed box `min`–`max`?
/// (Liang–Barsky clipping; a segment on the box's boundary counts.)
#[inline]
pub fn segment_intersects_box(a: [f64; 2], b: [f64; 2], min: [f64; 2], max: [f64; 2]) -> bool {
    let inside = |p: [f64; 2]| p[0] >= min[0] && p[0] <= max[0] && p[1] >= min[1] && p[1] <= max[1];
    if inside(a) || inside(b) {
        return true;
    }
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for axis in 0..2 {
        let (lo, hi) = (min[axis] - a[axis], max[axis] - a[axis]);
        if d[axis] == 0.0 {
            if lo > 0.0 || hi < 0.0 {
                return false;
            }
        } else {
            let (mut ta, mut tb) = (lo / d[axis], hi / d[axis]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return false;
            }
        }
    }
    true
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
