//! Where map matching observes the along-road error: the road's heading
//! changes.
//!
//! On a matched road the map feed observes the position across the road;
//! along it, nothing. Once the road's heading has changed by an angle θ, the
//! along-road error of before is seen across the new direction with
//! sensitivity sin θ. Whether the change happens at a junction (one sharp
//! corner) or along a winding road (a hairpin, a curve of a mountain road)
//! does not matter to the filter, only that it happens within a short
//! distance: so a **reset** is any point of a drive whose heading differs by
//! [`TURN_DEG`]–(180° − [`TURN_DEG`]) from the heading somewhere within the
//! last [`CURVE_M`] driven. A U-turn on the spot (a junction U-turn, turning
//! back at a trip end) passes through no intermediate heading and observes
//! nothing; a hairpin curve does.
//!
//! Headings are those of [`CHORD_M`] chords centred every
//! [`HEADING_STEP_M`] along each directed road (smoothing the digitising
//! noise of a map), and the rule is local: whether a point resets depends on
//! the last [`CURVE_M`] of the drive only. A sharp corner therefore resets
//! the drive from the corner to [`CURVE_M`] beyond it; the stretch budgeted
//! after it starts where the reset zone ends, and the calibration
//! (`super::mm_reach`) measures the reach from there.
//!
//! The rule is written here rather than taken from a crate: it is the
//! planner's own model of its map matcher.

use std::collections::VecDeque;

/// The weakest turn that resets the along-road error (degrees): sin 45° =
/// 0.71 of the along-road error is observed.
pub const TURN_DEG: f64 = 45.0;
/// Length of the chords whose headings define a turn (m).
pub const CHORD_M: f64 = 15.0;
/// Spacing of the heading samples along a road (m).
pub const HEADING_STEP_M: f64 = 10.0;
/// The distance within which a heading change of [`TURN_DEG`] counts as a
/// turn (m): a curve of a mountain road or a roundabout's exit, not a slow
/// drift of a coast road.
pub const CURVE_M: f64 = 200.0;

/// Heading samples of a polyline (local east/north metres): (position m,
/// heading rad clockwise from north), at 0, [`HEADING_STEP_M`], … and at
/// its end, positions scaled by `scale` (section length / polyline length).
pub(crate) fn heading_samples(pts: &[[f64; 2]], scale: f64) -> Vec<(f32, f32)> {
    let mut cum = vec![0.0];
    for w in pts.windows(2) {
        cum.push(cum[cum.len() - 1] + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]));
    }
    let total = cum[cum.len() - 1];
    if pts.len() < 2 || total <= 0.0 {
        return Vec::new();
    }
    let half = 0.5 * CHORD_M.min(total);
    let n = (total / HEADING_STEP_M).ceil().max(1.0) as usize;
    (0..=n)
        .map(|i| {
            let c = (i as f64 * HEADING_STEP_M).min(total);
            let a = (c - half).clamp(0.0, total - 2.0 * half);
            let p = point_at(pts, &cum, a);
            let q = point_at(pts, &cum, a + 2.0 * half);
            ((c * scale) as f32, (q[0] - p[0]).atan2(q[1] - p[1]) as f32)
        })
        .collect()
}

/// A point at distance `c` along a polyline with cumulative distances
/// `cum` (clamped to its ends).
pub(crate) fn point_at(pts: &[[f64; 2]], cum: &[f64], c: f64) -> [f64; 2] {
    let i = cum.partition_point(|&x| x < c).clamp(1, pts.len() - 1);
    let (a, b) = (pts[i - 1], pts[i]);
    let span = cum[i] - cum[i - 1];
    let t = if span > 0.0 {
        ((c - cum[i - 1]) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// The heading samples of a drive's last [`CURVE_M`], in order: (drive
/// chainage m, heading rad).
#[derive(Debug, Clone, Default)]
pub(crate) struct TurnWindow {
    /// (chainage m, cos, sin of the heading).
    buf: VecDeque<(f64, f32, f32)>,
}

/// |cos| of the heading change at the edges of the resetting range: a turn
/// θ resets when [`TURN_DEG`] ≤ θ ≤ 180° − it,
/// i.e. when |cos θ| ≤ cos [`TURN_DEG`] (a dot
/// product of unit vectors instead of an angle difference: this test runs
/// for every sample pair of every chain).
fn reset_cos() -> f32 {
    TURN_DEG.to_radians().cos() as f32 + 1e-6
}

impl TurnWindow {
    /// Forgets the history (a U-turn on the spot, or a drive's start).
    pub fn clear(&mut self) {
        self.buf.clear();
    }

    /// Feeds the heading `h` at drive chainage `c`; returns whether the
    /// point resets: its heading differs by a turn from one within
    /// `curve_m` (≤ [`CURVE_M`]) before. A road whose class gets no reset
    /// from turns (`curve_m` = 0) feeds its headings untested, so that a
    /// sharp turn from it onto a road that does still counts.
    pub fn push(&mut self, c: f64, h: f32, curve_m: f64) -> bool {
        while self.buf.front().is_some_and(|f| f.0 < c - CURVE_M) {
            self.buf.pop_front();
        }
        let (s, co) = h.sin_cos();
        let lim = reset_cos();
        let hit = curve_m > 0.0
            && self
                .buf
                .iter()
                .rev()
                .take_while(|f| f.0 >= c - curve_m)
                .any(|&(_, c0, s0)| (c0 * co + s0 * s).abs() <= lim);
        self.buf.push_back((c, co, s));
        hit
    }
}

/// Per directed edge, the positions of its samples that reset whatever the
/// drive before the edge was: those at least [`CURVE_M`] from its start
/// whose own road turned (the history before the edge cannot reach them).
/// Positions closer to the start depend on the drive before and are tested
/// with a [`TurnWindow`].
pub(crate) fn intrinsic_resets(samples: &[(f32, f32)], curve_m: f64) -> Vec<f64> {
    let mut w = TurnWindow::default();
    let mut out = Vec::new();
    for &(x, h) in samples {
        if w.push(x as f64, h, curve_m) && x as f64 >= CURVE_M {
            out.push(x as f64);
        }
    }
    out
}

/// Walks the samples of one directed edge from `a0` to `a1` (positions m,
/// `a0` inclusive) with the drive's window `w` (`c0`: the drive's chainage
/// at `a0`), calling `on_reset(position)` for each sample that
/// resets at curve distance `curve_m` (0: none), until it returns true. Samples beyond [`CURVE_M`] from `a0` use the
/// precomputed `intrinsic` positions, except the last [`CURVE_M`], which
/// refill the window for the next edge.
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk_edge(
    samples: &[(f32, f32)],
    intrinsic: &[f64],
    a0: f64,
    a1: f64,
    c0: f64,
    w: &mut TurnWindow,
    curve_m: f64,
    mut on_reset: impl FnMut(f64) -> bool,
) {
    let lo = samples.partition_point(|s| (s.0 as f64) < a0);
    let hi = samples.partition_point(|s| (s.0 as f64) < a1);
    let head_end = a0 + CURVE_M;
    let tail_start = (a1 - CURVE_M).max(head_end);
    let mut i = lo;
    // Head: the window decides.
    while i < hi && (samples[i].0 as f64) < head_end {
        let (x, h) = (samples[i].0 as f64, samples[i].1);
        if w.push(c0 + x - a0, h, curve_m) && on_reset(x) {
            return;
        }
        i += 1;
    }
    if i >= hi {
        return;
    }
    // Middle: the edge's own resets (intrinsic positions ≥ CURVE_M from the
    // edge's start are exact once the head is past; those between a0 + CURVE_M
    // and the first CURVE_M of the edge cannot occur since a0 ≥ 0).
    if curve_m > 0.0 {
        let from = samples[i].0 as f64;
        let j0 = intrinsic.partition_point(|&x| x < from);
        for &x in &intrinsic[j0..] {
            if x >= tail_start || x >= a1 {
                break;
            }
            if on_reset(x) {
                return;
            }
        }
    }
    // Tail: refill the window (and test, for its resets).
    w.clear();
    let t0 = samples.partition_point(|s| (s.0 as f64) < tail_start - CURVE_M);
    for s in &samples[t0.max(lo)..hi] {
        let x = s.0 as f64;
        let hit = w.push(c0 + x - a0, s.1, curve_m);
        if x >= tail_start && hit && on_reset(x) {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(h_deg: &[(f64, f64)]) -> Vec<[f64; 2]> {
        let mut p = vec![[0.0, 0.0]];
        for &(h, l) in h_deg {
            let q = p[p.len() - 1];
            let r = h.to_radians();
            p.push([q[0] + l * r.sin(), q[1] + l * r.cos()]);
        }
        p
    }

    fn resets_along(pts: &[[f64; 2]]) -> Vec<f64> {
        let s = heading_samples(pts, 1.0);
        let intr = intrinsic_resets(&s, CURVE_M);
        let mut w = TurnWindow::default();
        let mut out = Vec::new();
        let end = s.last().unwrap().0 as f64 + 1.0;
        walk_edge(&s, &intr, 0.0, end, 0.0, &mut w, CURVE_M, |x| {
            out.push(x);
            false
        });
        out
    }

    #[test]
    fn a_straight_road_never_resets() {
        assert!(resets_along(&line(&[(30.0, 2000.0)])).is_empty());
    }

    #[test]
    fn a_sharp_corner_resets_from_the_corner_for_the_curve_distance() {
        let r = resets_along(&line(&[(0.0, 1000.0), (90.0, 1000.0)]));
        // The 15 m chord sees the corner from 1000 − 7.5 m on; the zone ends
        // CURVE_M after the last sample of the first leg's heading.
        let first = r[0];
        let last = *r.last().unwrap();
        assert!((first - 1000.0).abs() <= HEADING_STEP_M, "{first}");
        assert!(
            (last - (1000.0 + CURVE_M)).abs() <= HEADING_STEP_M,
            "{last}"
        );
        // Every sample in between resets (a zone, not a point).
        assert!(r.len() as f64 >= CURVE_M / HEADING_STEP_M - 1.0);
    }

    #[test]
    fn a_slow_curve_over_the_curve_distance_resets_at_its_end_only() {
        // 50° in ten corners of 5° every 20 m (200 m): the heading at the end
        // differs from one 200 m before by 45–50°.
        let mut legs = vec![(0.0, 1000.0)];
        for i in 1..=10 {
            legs.push((5.0 * i as f64, 20.0));
        }
        legs.push((50.0, 1000.0));
        let r = resets_along(&line(&legs));
        assert!(!r.is_empty());
        assert!(r.iter().all(|&x| (1150.0..=1420.0).contains(&x)), "{r:?}");
    }

    #[test]
    fn a_coast_road_drifting_slowly_does_not_reset() {
        // 90° over 2 km: 9° per 200 m.
        let legs: Vec<(f64, f64)> = (0..100).map(|i| (0.9 * i as f64, 20.0)).collect();
        assert!(resets_along(&line(&legs)).is_empty());
    }

    #[test]
    fn a_hairpin_resets_but_a_u_turn_on_the_spot_does_not() {
        let mut legs = vec![(0.0, 500.0)];
        for i in 1..=12 {
            legs.push((15.0 * i as f64, 5.0));
        }
        legs.push((180.0, 500.0));
        assert!(!resets_along(&line(&legs)).is_empty());
        // The same heading change with no intermediate heading.
        let s = heading_samples(&line(&[(0.0, 500.0)]), 1.0);
        let back = heading_samples(&line(&[(180.0, 500.0)]), 1.0);
        let mut w = TurnWindow::default();
        let mut n = 0;
        for &(x, h) in s.iter() {
            n += usize::from(w.push(x as f64, h, CURVE_M));
        }
        for &(x, h) in back.iter() {
            n += usize::from(w.push(500.0 + x as f64, h, CURVE_M));
        }
        assert_eq!(n, 0);
    }

    #[test]
    fn the_window_walk_matches_a_plain_scan() {
        // A winding road: the head/middle/tail shortcut of `walk_edge`
        // finds exactly the resets of a sample-by-sample scan, from any
        // start with an empty window.
        for amp in [40.0, 25.0, 18.0] {
            let legs: Vec<(f64, f64)> = (0..300)
                .map(|i| (amp * ((i as f64) * 0.37).sin() + 0.5 * i as f64, 17.0))
                .collect();
            let pts = line(&legs);
            let s = heading_samples(&pts, 1.0);
            let intr = intrinsic_resets(&s, CURVE_M);
            for a0 in [0.0, 35.0, 420.0, 1777.0] {
                let mut w = TurnWindow::default();
                let mut fast = Vec::new();
                walk_edge(&s, &intr, a0, 4000.0, 0.0, &mut w, CURVE_M, |x| {
                    fast.push(x);
                    false
                });
                let mut w = TurnWindow::default();
                let plain: Vec<f64> = s
                    .iter()
                    .filter(|x| x.0 as f64 >= a0 && (x.0 as f64) < 4000.0)
                    .filter(|&&(x, h)| w.push(x as f64, h, CURVE_M))
                    .map(|x| x.0 as f64)
                    .collect();
                assert_eq!(fast, plain, "from {a0}");
                assert!(amp > 20.0 || plain.len() < 300, "{amp}: {}", plain.len());
            }
        }
    }
}
