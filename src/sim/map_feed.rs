//! Map matching as an aiding source of the integrated navigator (issue 5,
//! item 4): the navigator's own positions are matched online by the paper's
//! incremental matcher (with the navigator's heading), and each matched point
//! goes back to the filter as an anisotropic position fix:
//! - across the road: σ = [`ACROSS_SIGMA_M`] (lane position and map error);
//! - along the road: σ = [`ALONG_SIGMA_M`], i.e. no information, except at a
//!   road end (a dead end: the match is clamped to the end node), where the
//!   fix is isotropic.
//!
//! Along-road information at turns and junctions then comes from the geometry
//! itself: after a turn the new road's across-road direction is the old
//! road's along-road direction, so successive fixes on differently oriented
//! roads bound both components (and, through the filter, the odometer scale
//! factor). Fixes are fed every [`INTERVAL_S`] while the navigator moves
//! faster than [`MIN_SPEED_MPS`]; the filter's χ² gate screens wrong matches.

use crate::geodesy::Geodetic;
use crate::matching::{Fix, IncrementalMatcher, IncrementalParams, MatchedPoint, Matcher};
use crate::nav::integrated::along_across_covariance;
use crate::nav::{Filter, FixPosition};
use crate::network::Network;

/// Across-road standard deviation of a matched fix (m).
pub const ACROSS_SIGMA_M: f64 = 3.0;
/// Along-road standard deviation where the geometry gives no information (m).
pub const ALONG_SIGMA_M: f64 = 1000.0;
/// Time between fixes (s).
pub const INTERVAL_S: f64 = 1.0;
/// Below this speed no fix is fed (m/s).
pub const MIN_SPEED_MPS: f64 = 1.0;

/// What the feed did in one run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FeedCounts {
    /// Fixes offered to the filter.
    pub fed: u64,
    /// Of which accepted by its gate.
    pub accepted: u64,
    /// Of which isotropic (at a road end).
    pub road_end: u64,
    /// Positions the matcher could not match.
    pub unmatched: u64,
}

/// The online map-matching feed of one run.
#[derive(Debug)]
pub struct MapFeed<'a> {
    net: &'a Network,
    matcher: IncrementalMatcher<'a>,
    out: Vec<MatchedPoint>,
    next_t: f64,
    /// Counts.
    pub counts: FeedCounts,
}

impl<'a> MapFeed<'a> {
    /// A feed on `net`, first fix at `t0 + INTERVAL_S`.
    pub fn new(net: &'a Network, t0: f64) -> Self {
        Self {
            net,
            matcher: IncrementalMatcher::new(net, IncrementalParams::default()),
            out: Vec::with_capacity(1),
            next_t: t0 + INTERVAL_S,
            counts: FeedCounts::default(),
        }
    }

    /// Called after the filter's updates at time `t`: matches the navigator's
    /// position when a fix is due and feeds the result back.
    pub fn step(&mut self, t: f64, filter: &mut Filter) {
        if t + 1e-9 < self.next_t {
            return;
        }
        self.next_t += INTERVAL_S;
        let st = filter.state();
        let speed = st.v[0].hypot(st.v[1]);
        if speed < MIN_SPEED_MPS {
            return;
        }
        let net = self.net;
        let e = net.frame.to_enu(&Geodetic {
            lat: st.lat,
            lon: st.lon,
            height: 0.0,
        });
        self.out.clear();
        self.matcher.push(
            &Fix {
                t_s: t,
                enu: [e[0], e[1]],
                heading_rad: Some(st.v[0].atan2(st.v[1])),
            },
            &mut self.out,
        );
        let Some(m) = self.out.last() else { return };
        let Some(seg_id) = m.segment else {
            self.counts.unmatched += 1;
            return;
        };
        let seg = &net.segments[seg_id as usize];
        // Direction of the road (clockwise from north); the sign does not
        // matter for the covariance.
        let road_heading = (seg.b[0] - seg.a[0]).atan2(seg.b[1] - seg.a[1]);
        let along = if at_road_end(net, seg_id, m.point) {
            self.counts.road_end += 1;
            ACROSS_SIGMA_M
        } else {
            ALONG_SIGMA_M
        };
        let cov = along_across_covariance(road_heading, along, ACROSS_SIGMA_M);
        let g = net.frame.to_geodetic([m.point[0], m.point[1], 0.0]);
        let o = filter.update_position_fix(
            t,
            FixPosition::Geodetic {
                lat: g.lat,
                lon: g.lon,
            },
            cov,
        );
        self.counts.fed += 1;
        if o.accepted {
            self.counts.accepted += 1;
        }
    }
}

/// Is the matched point clamped to a road end (a node met by one section end only)?
fn at_road_end(net: &Network, seg_id: u32, p: [f64; 2]) -> bool {
    let seg = &net.segments[seg_id as usize];
    let sec = &net.sections[seg.section as usize];
    let near = |q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-6;
    (seg_id == sec.first_segment && near(seg.a) && net.topology.degree(sec.start) == 1)
        || (seg_id == sec.first_segment + sec.segment_count - 1
            && near(seg.b)
            && net.topology.degree(sec.end) == 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::{model_from_polylines, TagSet};

    #[test]
    fn road_ends_are_dead_ends_only() {
        // A T: a through road west-east and a dead-end stub north from its middle.
        let d = 1.0 / 111_412.0;
        let dl = 1.0 / (111_412.0 * 60f64.to_radians().cos());
        let p = |e: f64, n: f64| [60.0 + n * d, 24.0 + e * dl];
        let roads = vec![
            (
                TagSet::default().attributes("through".into()),
                vec![vec![p(0.0, 0.0), p(100.0, 0.0), p(200.0, 0.0)]],
            ),
            (
                TagSet::default().attributes("stub".into()),
                vec![vec![p(100.0, 0.0), p(100.0, 80.0)]],
            ),
        ];
        let net = Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap();
        let stub = net
            .roads
            .iter()
            .position(|r| r.attributes.id == "stub")
            .unwrap();
        let seg = net.sections[net.roads[stub].sections[0] as usize].first_segment;
        let s = net.segments[seg as usize];
        // The stub's far end is a dead end; its start is the junction.
        assert!(at_road_end(&net, seg, s.b));
        assert!(!at_road_end(&net, seg, s.a));
        // Mid-segment is no end.
        let mid = [(s.a[0] + s.b[0]) / 2.0, (s.a[1] + s.b[1]) / 2.0];
        assert!(!at_road_end(&net, seg, mid));
    }
}
