//! The lateral geometry of a road's lanes (issue 12, point 1): how wide a
//! lane is, how many lanes run in the direction of travel and how far each
//! lies from the road's centre line. One set of functions for the simulated
//! vehicle (which drives in a lane), the map feed (which expects it there),
//! the RFID fix models and the planner (which places tags in the lane).
//!
//! Conventions: a road's `lanes` tag counts every lane of the carriageway
//! (both directions on a two-way road); lanes of a direction are numbered
//! from the kerb (index 0, the "slow" lane) towards the centre; offsets are
//! from the digitised centre line, positive to the right of the direction
//! of travel.

use super::RoadAttributes;
use serde::{Deserialize, Serialize};

/// Which side of the road traffic keeps to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveSide {
    /// Right-hand traffic (most of the world).
    #[default]
    Right,
    /// Left-hand traffic (United Kingdom, Japan, Australia, …).
    Left,
}

impl DriveSide {
    /// Parses `right` or `left`.
    pub fn parse(s: &str) -> Option<DriveSide> {
        match s.trim() {
            "right" => Some(DriveSide::Right),
            "left" => Some(DriveSide::Left),
            _ => None,
        }
    }

    /// +1 for right-hand traffic, −1 for left-hand: the sign of the
    /// kerb side seen in the direction of travel.
    pub fn sign(self) -> f64 {
        match self {
            DriveSide::Right => 1.0,
            DriveSide::Left => -1.0,
        }
    }
}

/// Lane width (m) of a road from its OSM attributes: `width / lanes` when
/// both are given (a carriageway width over its lanes), else a default by
/// road class.
pub fn lane_width_m(a: &RoadAttributes) -> f64 {
    if let (Some(w), Some(n)) = (a.width_m, a.lanes) {
        if n > 0 && w > 0.0 {
            return (w / f64::from(n)).clamp(2.5, 5.0);
        }
    }
    if let (Some(w), None) = (a.width_m, a.lanes) {
        // A two-way road's width holds two lanes, a one-way road's one.
        let n = if a.oneway.is_oneway() { 1.0 } else { 2.0 };
        return (w / n).clamp(2.5, 5.0);
    }
    match a.highway.trim_end_matches("_link") {
        "motorway" | "trunk" => 3.75,
        "primary" | "secondary" => 3.5,
        "tertiary" | "unclassified" => 3.25,
        _ => 3.0,
    }
}

/// Lanes of the whole carriageway: the `lanes` tag, else two on a two-way
/// road and one on a one-way road (two on one-way motorways and trunk
/// roads, OpenStreetMap's documented default for them).
pub fn carriageway_lanes(a: &RoadAttributes) -> u32 {
    match a.lanes {
        Some(n) if n > 0 => n,
        _ if a.oneway.is_oneway() => match a.highway.as_str() {
            "motorway" | "trunk" => 2,
            _ => 1,
        },
        _ => 2,
    }
}

/// Lanes in one direction of travel: all of them on a one-way road, half
/// (rounded down, at least one) on a two-way road; an odd middle lane of a
/// two-way road (a turning lane) belongs to neither direction.
pub fn lanes_per_direction(a: &RoadAttributes) -> u32 {
    let n = carriageway_lanes(a);
    if a.oneway.is_oneway() {
        n
    } else {
        (n / 2).max(1)
    }
}

/// Offset (m) of the centre of lane `lane` (0 = the kerb lane; clamped to
/// the lanes of the direction) from the road's centre line, positive to the
/// right of the direction of travel. With n lanes of width w across the
/// carriageway, lane j counted from the far edge sits at (j − (n − 1)/2)·w;
/// the kerb lane of a direction is on the traffic side: right for
/// right-hand traffic, left for left-hand.
///
/// ```
/// use waymark::network::{lane_offset_m, DriveSide, Oneway, RoadAttributes};
/// let mut a = RoadAttributes::new("1", "residential", Oneway::Both);
/// // A two-way residential street: one 3 m lane each way, 1.5 m off centre.
/// assert_eq!(lane_offset_m(&a, DriveSide::Right, 0), 1.5);
/// assert_eq!(lane_offset_m(&a, DriveSide::Left, 0), -1.5);
/// // Four lanes of 3.5 m: the kerb lane 5.25 m, the inner lane 1.75 m.
/// a.lanes = Some(4);
/// a.width_m = Some(14.0);
/// assert_eq!(lane_offset_m(&a, DriveSide::Right, 0), 5.25);
/// assert_eq!(lane_offset_m(&a, DriveSide::Right, 1), 1.75);
/// // A one-way street's single lane is on the centre line.
/// a.oneway = Oneway::Forward;
/// a.lanes = None;
/// a.width_m = None;
/// assert_eq!(lane_offset_m(&a, DriveSide::Right, 0), 0.0);
/// ```
pub fn lane_offset_m(a: &RoadAttributes, side: DriveSide, lane: u32) -> f64 {
    let n = f64::from(carriageway_lanes(a));
    let i = f64::from(lane.min(lanes_per_direction(a) - 1));
    side.sign() * (0.5 * (n - 1.0) - i) * lane_width_m(a)
}

/// Mean and variance (m, m²) of the lane offset of a vehicle whose lane
/// among those of its direction is unknown and equally likely: lane i at
/// ((n − 1)/2 − i)·w for i = 0 … k − 1 has mean (n − k)/2·w and variance
/// w²(k² − 1)/12 (the discrete uniform's).
pub fn lane_offset_moments(a: &RoadAttributes, side: DriveSide) -> (f64, f64) {
    let n = f64::from(carriageway_lanes(a));
    let k = f64::from(lanes_per_direction(a));
    let w = lane_width_m(a);
    (
        side.sign() * 0.5 * (n - k) * w,
        w * w * (k * k - 1.0) / 12.0,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Oneway;

    fn road(
        highway: &str,
        lanes: Option<u32>,
        width: Option<f64>,
        oneway: Oneway,
    ) -> RoadAttributes {
        RoadAttributes {
            lanes,
            width_m: width,
            ..RoadAttributes::new("r", highway, oneway)
        }
    }

    #[test]
    fn lane_counts() {
        assert_eq!(
            lanes_per_direction(&road("residential", None, None, Oneway::Both)),
            1
        );
        assert_eq!(
            lanes_per_direction(&road("primary", Some(4), None, Oneway::Both)),
            2
        );
        assert_eq!(
            lanes_per_direction(&road("primary", Some(3), None, Oneway::Both)),
            1
        );
        assert_eq!(
            lanes_per_direction(&road("motorway", None, None, Oneway::Forward)),
            2
        );
        assert_eq!(
            lanes_per_direction(&road("primary", Some(3), None, Oneway::Forward)),
            3
        );
    }

    #[test]
    fn offsets_of_every_lane_and_their_moments() {
        // Three one-way lanes of 3.5 m: 3.5, 0, −3.5 (right-hand, kerb first).
        let a = road("primary", Some(3), Some(10.5), Oneway::Forward);
        let o: Vec<f64> = (0..3)
            .map(|i| lane_offset_m(&a, DriveSide::Right, i))
            .collect();
        assert_eq!(o, vec![3.5, 0.0, -3.5]);
        // Beyond the last lane: clamped to it.
        assert_eq!(lane_offset_m(&a, DriveSide::Right, 7), -3.5);
        let (m, v) = lane_offset_moments(&a, DriveSide::Right);
        let mean = o.iter().sum::<f64>() / 3.0;
        let var = o.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 3.0;
        assert!(
            (m - mean).abs() < 1e-12 && (v - var).abs() < 1e-12,
            "{m} {v}"
        );
        // Four two-way lanes, left-hand traffic: −5.25 and −1.75.
        let b = road("primary", Some(4), Some(14.0), Oneway::Both);
        let (m, v) = lane_offset_moments(&b, DriveSide::Left);
        assert!(
            (m + 3.5).abs() < 1e-12 && (v - 3.0625).abs() < 1e-12,
            "{m} {v}"
        );
    }
}
