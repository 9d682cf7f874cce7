//! A smoothed height profile along a route's chainage.
//!
//! Raw heights (bilinear DEM heights, or the linear interpolation across a
//! tunnel or bridge) are taken every [`PROFILE_STEP_M`] and smoothed with a
//! centred moving average of ±[`PROFILE_HALF_WINDOW_M`] applied twice (a
//! triangular kernel reaching ±80 m). Why: a 1″ DEM (SRTM, GLO-30) has
//! ~30 m pixels with metre-level noise and steps at buildings and trees, so
//! its heights, differenced every few metres, give grades of tens of per
//! cent that no road has; a road's vertical curves are long (50–300 m at
//! 50–100 km/h), so an 80 m window removes pixel-scale noise and keeps
//! the road's grades. The window shrinks symmetrically near the route's
//! ends, so the ends keep their heights and a height linear in chainage
//! (a straight road on a plane, a tunnel's interpolation) is unchanged.
//!
//! Grades are central differences of the smoothed heights at the nodes,
//! interpolated linearly between them (continuous, so the truth's pitch
//! and vertical velocity have no steps).

/// Spacing of the profile's nodes (m).
pub const PROFILE_STEP_M: f64 = 5.0;
/// Half-width of each of the two moving averages (m).
pub const PROFILE_HALF_WINDOW_M: f64 = 40.0;

/// Heights and grades along a route's chainage, at equally spaced nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightProfile {
    step_m: f64,
    heights: Vec<f64>,
    grades: Vec<f64>,
}

/// Centred moving average of ±`k` nodes, shrinking symmetrically at the ends.
fn moving_average(x: &[f64], k: usize) -> Vec<f64> {
    let n = x.len();
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for v in x {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + v);
    }
    (0..n)
        .map(|i| {
            let r = k.min(i).min(n - 1 - i);
            (prefix[i + r + 1] - prefix[i - r]) / (2 * r + 1) as f64
        })
        .collect()
}

impl HeightProfile {
    /// The profile of `raw` heights at chainage 0, `step_m`, 2·`step_m`, …
    /// (at least two), smoothed with moving averages of ±`half_window_m`.
    pub fn smoothed(step_m: f64, raw: &[f64], half_window_m: f64) -> HeightProfile {
        assert!(raw.len() >= 2 && step_m > 0.0, "a profile needs two nodes");
        let k = (half_window_m / step_m).round().max(0.0) as usize;
        let heights = moving_average(&moving_average(raw, k), k);
        let n = heights.len();
        let grades = (0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                (heights[b] - heights[a]) / ((b - a) as f64 * step_m)
            })
            .collect();
        HeightProfile {
            step_m,
            heights,
            grades,
        }
    }

    /// The chainage the profile reaches (m).
    pub fn length_m(&self) -> f64 {
        (self.heights.len() - 1) as f64 * self.step_m
    }

    fn locate(&self, chainage_m: f64) -> (usize, f64) {
        let x = (chainage_m / self.step_m).clamp(0.0, (self.heights.len() - 1) as f64);
        let i = (x.floor() as usize).min(self.heights.len() - 2);
        (i, x - i as f64)
    }

    /// Height (m) at a chainage (clamped to the profile).
    pub fn height_at(&self, chainage_m: f64) -> f64 {
        let (i, f) = self.locate(chainage_m);
        self.heights[i] + (self.heights[i + 1] - self.heights[i]) * f
    }

    /// Grade (dh/dchainage) at a chainage (clamped to the profile).
    pub fn grade_at(&self, chainage_m: f64) -> f64 {
        let (i, f) = self.locate(chainage_m);
        self.grades[i] + (self.grades[i + 1] - self.grades[i]) * f
    }

    /// Lowest and highest height of the profile (m).
    pub fn range_m(&self) -> (f64, f64) {
        self.heights
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &h| {
                (lo.min(h), hi.max(h))
            })
    }
}
