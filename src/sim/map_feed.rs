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
//!
//! **Map errors (issue 12).** The navigator matches against its own map, the
//! world displaced by a [`MapErrorField`]. A position p on that map is matched
//! by pulling it back to the world (q with q + offset(q) = p), matching q on
//! the world's geometry and pushing the matched point and the road's ends
//! forward again (m + offset(m)). Where the field is a local translation this
//! is exactly matching p on the displaced map; the field's gradient (~σ/L, a
//! few per cent) distorts distances and headings by that much. Because the
//! map error is correlated over L (`geometry_error_correlation_m`), fixes a
//! few metres apart share it and are not independent: the across-road
//! variance is inflated by the integrated autocorrelation of the error along
//! the path, τ = Σₖ exp(−(k·d)²/2L²) ≈ √(2π)·L/d with d = speed × interval,
//! the factor by which the variance of a mean of correlated samples exceeds
//! that of independent ones: σ² = [`ACROSS_SIGMA_M`]² + τ·σ_map².
//!
//! **Lanes (issue 12, point 1).** The truth drives in a lane, not on the
//! centre line. A navigator that knows the drive side ([`MapFeed::with_lanes`])
//! moves each matched point to the mean offset of its direction's lanes
//! ([`lane_offset_moments`]: half a lane right on a two-way street) and adds
//! the rest as noise: the lane choice's variance w²(k² − 1)/12 (zero with
//! one lane per direction), correlated over the mean distance between lane
//! changes, and the wander's σ², correlated over its 60 m; each inflated
//! like the map error, by Σ ρ^|k| = (1 + ρ)/(1 − ρ), ρ = e^(−d/L), for an
//! exponential correlation. Without the shift a 1.5–1.75 m bias would pull
//! the filter towards the centre line at 1 Hz as if it were noise.

use super::map_error::MapErrorField;
use crate::geodesy::Geodetic;
use crate::matching::{Fix, IncrementalMatcher, IncrementalParams, MatchedPoint, Matcher};
use crate::nav::integrated::along_across_covariance;
use crate::nav::NavState;
use crate::nav::{Filter, FixPosition};
use crate::network::{lane_offset_moments, Network};
use crate::scenario::LaneModel;

/// Across-road standard deviation of a matched fix (m).
pub const ACROSS_SIGMA_M: f64 = 3.0;
/// Along-road standard deviation where the geometry gives no information (m).
pub const ALONG_SIGMA_M: f64 = 1000.0;
/// Time between fixes (s).
pub const INTERVAL_S: f64 = 1.0;
/// Below this speed no fix is fed (m/s).
pub const MIN_SPEED_MPS: f64 = 1.0;

/// A match is on the wrong road when the matched road's true centre line is
/// farther than this from the truth (m): beyond a lane or two of the road,
/// short of the 15–40 m between parallel roads.
pub const WRONG_ROAD_M: f64 = 10.0;

/// What the feed did in one run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeedCounts {
    /// Fixes offered to the filter.
    pub fed: u64,
    /// Of which accepted by its gate.
    pub accepted: u64,
    /// Of which isotropic (at a road end).
    pub road_end: u64,
    /// Positions the matcher could not match.
    pub unmatched: u64,
    /// Fed fixes on the wrong road (more than 10 m, `WRONG_ROAD_M`; counted when the
    /// truth is known).
    pub wrong_road: u64,
    /// Largest across-road error of an accepted fix against the truth (m).
    pub max_across_error_m: f64,
}

/// The online map-matching feed of one run.
#[derive(Debug)]
pub struct MapFeed<'a> {
    net: &'a Network,
    matcher: IncrementalMatcher<'a>,
    out: Vec<MatchedPoint>,
    /// The navigator's map minus the world (`None`: a perfect map).
    field: Option<MapErrorField>,
    /// Map error variance per axis (m²) and correlation length (m).
    map_var: f64,
    map_corr_m: f64,
    /// The lane model the navigator assumes (`None`: the centre line).
    lanes: Option<LaneModel>,
    next_t: f64,
    /// Counts.
    pub counts: FeedCounts,
}

impl<'a> MapFeed<'a> {
    /// A feed on `net`, first fix at `t0 + INTERVAL_S`.
    /// A perfect map.
    pub fn new(net: &'a Network, t0: f64) -> Self {
        Self {
            net,
            matcher: IncrementalMatcher::new(net, IncrementalParams::default()),
            out: Vec::with_capacity(1),
            field: None,
            map_var: 0.0,
            map_corr_m: 1.0,
            lanes: None,
            next_t: t0 + INTERVAL_S,
            counts: FeedCounts::default(),
        }
    }

    /// A feed on `net` itself (the navigator's map is the world's geometry)
    /// whose fixes carry the noise model of a map with 1σ error `sigma_m`
    /// per axis correlated over `correlation_m`: what the planner's
    /// perfect-data engine predicts with, the map error's variance counted
    /// but not drawn.
    pub fn with_noise_model(net: &'a Network, t0: f64, sigma_m: f64, correlation_m: f64) -> Self {
        let mut f = Self::new(net, t0);
        f.map_var = sigma_m * sigma_m;
        f.map_corr_m = correlation_m.max(1e-3);
        f
    }

    /// A feed whose map is `net` (the world) displaced by `field`, drawn with
    /// 1σ `sigma_m` per axis and correlation length `correlation_m`.
    pub fn on_map(
        net: &'a Network,
        t0: f64,
        field: Option<MapErrorField>,
        sigma_m: f64,
        correlation_m: f64,
    ) -> Self {
        let mut f = Self::new(net, t0);
        if field.is_some() {
            f.map_var = sigma_m * sigma_m;
            f.map_corr_m = correlation_m;
        }
        f.field = field;
        f
    }

    /// The navigator expects to drive in a lane (`model`'s drive side and
    /// wander): each matched point is moved from the centre line to the
    /// mean lane offset of the road's direction, and the across-road
    /// variance gains the lane choice's and the wander's, each inflated by
    /// its correlation along the path (module doc).
    pub fn with_lanes(mut self, model: LaneModel) -> Self {
        self.lanes = Some(model);
        self
    }

    /// Called after the filter's updates at time `t`: matches the navigator's
    /// position when a fix is due and feeds the result back.
    pub fn step(&mut self, t: f64, filter: &mut Filter) {
        self.step_with_truth(t, filter, None);
    }

    /// [`Self::step`], also scoring the fix against the truth's state (wrong
    /// road, across-road error) when given.
    pub fn step_with_truth(&mut self, t: f64, filter: &mut Filter, truth: Option<&NavState>) {
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
        // The navigator's map position, pulled back to the world's geometry.
        let q = match &self.field {
            Some(f) => f.to_world([e[0], e[1]]),
            None => [e[0], e[1]],
        };
        self.out.clear();
        self.matcher.push(
            &Fix {
                t_s: t,
                enu: q,
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
        // The matched point and the road on the navigator's map.
        let (point, a, b) = match &self.field {
            Some(f) => (f.to_map(m.point), f.to_map(seg.a), f.to_map(seg.b)),
            None => (m.point, seg.a, seg.b),
        };
        // Direction of the road (clockwise from north); the sign does not
        // matter for the covariance.
        let road_heading = (b[0] - a[0]).atan2(b[1] - a[1]);
        // Across-road σ: matching and lane position, plus the map error
        // inflated by its correlation along the path (module doc).
        let d = speed * INTERVAL_S;
        let tau = if self.map_var > 0.0 {
            ((2.0 * std::f64::consts::PI).sqrt() * self.map_corr_m / d).max(1.0)
        } else {
            0.0
        };
        let mut across_var = ACROSS_SIGMA_M * ACROSS_SIGMA_M + tau * self.map_var;
        let mut point = point;
        if let Some(lm) = &self.lanes {
            let attrs =
                &net.model.roads[net.sections[seg.section as usize].road as usize].attributes;
            let (mean, lane_var) = lane_offset_moments(attrs, lm.drive_side);
            // The road's direction as travelled (the navigator's heading
            // picks the sense), and its right.
            let h = st.v[0].atan2(st.v[1]);
            let psi = if (road_heading - h).cos() >= 0.0 {
                road_heading
            } else {
                road_heading + std::f64::consts::PI
            };
            let (sn, cs) = psi.sin_cos();
            point = [point[0] + mean * cs, point[1] - mean * sn];
            // Exponentially correlated errors over L, sampled every d:
            // Σ ρ^|k| = (1 + ρ)/(1 − ρ) with ρ = e^(−d/L).
            let tau_exp = |l: f64| {
                let r = (-d.max(0.1) / l).exp();
                (1.0 + r) / (1.0 - r)
            };
            across_var += tau_exp(super::lanes::LANE_CHANGE_MEAN_M) * lane_var
                + tau_exp(super::lanes::WANDER_CORRELATION_M) * lm.wander_m * lm.wander_m;
        }
        let across = across_var.sqrt();
        let along = if at_road_end(net, seg_id, m.point) {
            self.counts.road_end += 1;
            across
        } else {
            ALONG_SIGMA_M
        };
        let cov = along_across_covariance(road_heading, along, across);
        let g = net.frame.to_geodetic([point[0], point[1], 0.0]);
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
        if let Some(tr) = truth {
            let w = net.frame.to_enu(&Geodetic {
                lat: tr.lat,
                lon: tr.lon,
                height: 0.0,
            });
            let w = [w[0], w[1]];
            if section_distance(net, seg.section, w) > WRONG_ROAD_M {
                self.counts.wrong_road += 1;
            }
            if o.accepted {
                let (sn, cs) = road_heading.sin_cos();
                // Across-road unit vector (east, north): the road's direction turned right.
                let across_err = (point[0] - w[0]) * cs - (point[1] - w[1]) * sn;
                let c = &mut self.counts.max_across_error_m;
                *c = c.max(across_err.abs());
            }
        }
    }
}

/// Distance (m) from world point `p` to a section's centre line.
fn section_distance(net: &Network, section: u32, p: [f64; 2]) -> f64 {
    let sec = &net.sections[section as usize];
    let first = sec.first_segment as usize;
    net.segments[first..first + sec.segment_count as usize]
        .iter()
        .map(|s| {
            let d = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
            let l2 = d[0] * d[0] + d[1] * d[1];
            let u = if l2 > 0.0 {
                (((p[0] - s.a[0]) * d[0] + (p[1] - s.a[1]) * d[1]) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p[0] - s.a[0] - u * d[0]).hypot(p[1] - s.a[1] - u * d[1])
        })
        .fold(f64::INFINITY, f64::min)
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
