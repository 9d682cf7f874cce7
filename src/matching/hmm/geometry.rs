//! Geometry of the matched points: distances, headings against segments,
//! and placing the fixes between steps on the decided path.

use crate::matching::{project, Fix, MatchedPoint};
use crate::network::geometry::{norm, point_at_ratio};
use crate::network::{Network, SectionId, SegmentId};

/// Distance between two points (m); coordinates are metres in a local
/// frame, so the plain formula ([`norm`]) cannot overflow, and it is 5–10×
/// cheaper than `geo`'s `hypot`-based `Euclidean.distance` (measured).
#[inline]
pub(super) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    norm(a[0] - b[0], a[1] - b[1])
}

/// The point reported against the fix as given.
pub(super) fn with_raw(mut m: MatchedPoint, raw: [f64; 2]) -> MatchedPoint {
    m.fix = raw;
    m.distance_m = dist(raw, m.point);
    m
}

/// Cosine between a heading and a segment's direction of travel.
#[cfg(test)]
pub(super) fn directed_cos(net: &Network, seg: SegmentId, heading_rad: f64, forward: bool) -> f64 {
    directed_cos_sc(net, seg, heading_rad.sin_cos(), forward)
}

/// [`directed_cos`] given the heading's `sin_cos()` (taken once per fix,
/// not once per candidate): the same number.
#[inline]
pub(super) fn directed_cos_sc(
    net: &Network,
    seg: SegmentId,
    (sh, ch): (f64, f64),
    forward: bool,
) -> f64 {
    let s = &net.segments[seg as usize];
    let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
    let len = norm(dx, dy);
    if len <= 0.0 {
        return 0.0;
    }
    let c = (dx * sh + dy * ch) / len;
    if forward {
        c
    } else {
        -c
    }
}

/// The nearest segment to `p` on the path pieces: (piece index, segment).
#[inline]
pub(super) fn nearest_on_pieces(
    net: &Network,
    pieces: &[(SectionId, f64, f64)],
    p: [f64; 2],
) -> (usize, SegmentId) {
    let mut best = (0usize, 0 as SegmentId, f64::INFINITY);
    for (k, &(sec, a, b)) in pieces.iter().enumerate() {
        let (lo, hi) = (a.min(b), a.max(b));
        let section = &net.sections[sec as usize];
        for seg in section.segment_ids() {
            let s = &net.segments[seg as usize];
            if s.section_offset_m > hi || s.section_offset_m + s.length_m < lo {
                continue;
            }
            let (t, _, d) = project(net, seg, p);
            let off = s.section_offset_m + t * s.length_m;
            let d = if off < lo || off > hi {
                let off = off.clamp(lo, hi);
                let q = point_at(net, seg, off);
                dist(p, q)
            } else {
                d
            };
            if d < best.2 {
                best = (k, seg, d);
            }
        }
        if best.2.is_infinite() && k == 0 {
            best = (0, section.first_segment, f64::INFINITY);
        }
    }
    (best.0, best.1)
}

/// The point of segment `seg` at a section offset (clamped to the segment).
pub(super) fn point_at(net: &Network, seg: SegmentId, section_offset: f64) -> [f64; 2] {
    let s = &net.segments[seg as usize];
    let t = if s.length_m > 0.0 {
        ((section_offset - s.section_offset_m) / s.length_m).clamp(0.0, 1.0)
    } else {
        0.0
    };
    point_at_ratio(&s.line(), t).into()
}

/// Moves a matched point into the section offset range `lo..=hi` if outside it.
#[inline]
pub(super) fn clamp_to_range(
    net: &Network,
    m: &mut MatchedPoint,
    sec: SectionId,
    lo: f64,
    hi: f64,
    fix: &Fix,
) {
    let Some(seg) = m.segment else { return };
    let s = &net.segments[seg as usize];
    if s.section != sec {
        return;
    }
    let off = s.section_offset_m + (m.road_offset_m - s.road_offset_m);
    if off >= lo - 1e-9 && off <= hi + 1e-9 {
        return;
    }
    let off = off.clamp(lo, hi);
    let q = point_at(net, seg, off);
    m.point = q;
    m.road_offset_m = s.road_offset_m + (off - s.section_offset_m).clamp(0.0, s.length_m);
    m.distance_m = dist(fix.enu, q);
}
