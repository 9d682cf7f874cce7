//! The `match` command's options: checked once, and the HMM's parameters
//! drawn from them and from the track itself.
//!
//! Defaults from the track: the fixes' distances to their nearest road give
//! a robust estimate of the position error, σ̂ = 1.4826 × median distance
//! (Newson and Krumm 2009, §4: the median absolute deviation scaled to a
//! Gaussian σ). The search radius is [`RADIUS_SIGMAS`] = 4 σ̂: a fix's
//! distance across its true road is Gaussian with σ ≈ σ̂, so the true road
//! lies beyond 4 σ̂ for a share 2 Φ(−4) = 6.3e-5 of the fixes (6 σ̂, the
//! earlier rule, bought 2e-9 for about twice the candidates on the FMM
//! example); at least 100 m (so plausible points up to 100 m from a road
//! are matched on a good track) and at most 300 m (beyond that the
//! candidates of a fix cover whole blocks). Within the radius the HMM also
//! drops the candidates far less likely than the fix's best
//! ([`super::HmmParams::min_emission_ratio`]). An explicit `--radius-m` is
//! the search radius as given. The HMM's
//! error model has a slowly varying drift (stationary σ, 19.4 m by default,
//! tuned for dead reckoning) and a white part (5 m): the drift's σ becomes
//! σ̂ within 5-19.4 m (a GNSS track with metres of error does not get to
//! wander 20 m onto a parallel road), and the white part what σ̂ leaves
//! over the drift's default, at least 5 m (a worse track widens the
//! emission).

use super::{Fix, HmmModel, HmmParams};
use crate::error::{Error, Result};
use crate::network::Network;

/// Which matcher to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// [`super::IncrementalMatcher`].
    Incremental,
    /// [`super::HmmMatcher`].
    Hmm,
}

/// Options of a matching run (SI units except where named).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchOptions {
    /// The matcher.
    pub method: Method,
    /// The HMM's probability model.
    pub model: HmmModel,
    /// Candidate search radius (m); `None`: from the track.
    pub radius_m: Option<f64>,
    /// σ of the white part of the fix error (m); `None`: from the track.
    pub sigma_m: Option<f64>,
    /// Highest plausible speed (km/h).
    pub max_speed_kmh: f64,
    /// Time between fixes that breaks the track (s).
    pub max_gap_s: f64,
    /// Distance between fixes that breaks the track (m).
    pub max_gap_m: f64,
}

impl Default for MatchOptions {
    fn default() -> Self {
        let p = HmmParams::default();
        Self {
            method: Method::Hmm,
            model: HmmModel::Drift,
            radius_m: None,
            sigma_m: None,
            max_speed_kmh: p.max_speed_mps * 3.6,
            max_gap_s: p.gap_s,
            max_gap_m: p.gap_m,
        }
    }
}

/// Most candidates per point under [`HmmModel::Independent`] (the drift
/// model keeps [`HmmParams::default`]'s 10): fastmm's `k`. Measured
/// (BENCHMARKS.md, seventh round): on every real trace the same roads,
/// path and scores as with 10; on the sparse tracks of
/// tests/it/matching_independent.rs the same precision and recall, on its
/// dense tracks precision 0.9915 against 0.9908; 6-12 % fewer instructions
/// per point.
pub const INDEPENDENT_MAX_CANDIDATES: usize = 8;

/// Smallest and largest search radius taken from the track (m).
pub const AUTO_RADIUS_M: [f64; 2] = [100.0, 300.0];

/// The search radius taken from the track, in σ̂ (see the module
/// documentation), before [`AUTO_RADIUS_M`]'s limits.
pub const RADIUS_SIGMAS: f64 = 4.0;

impl MatchOptions {
    /// Checks every option; the error names the command-line option.
    pub fn validate(&self) -> Result<()> {
        let check = |name: &str, v: Option<f64>, lo: f64, hi: f64| -> Result<()> {
            match v {
                Some(x) if !(x.is_finite() && x >= lo && x <= hi) => Err(Error::InvalidParameter(
                    format!("--{name} {x}: expected a number from {lo} to {hi}"),
                )),
                _ => Ok(()),
            }
        };
        check("radius-m", self.radius_m, 1.0, 1000.0)?;
        check("sigma-m", self.sigma_m, 0.1, 500.0)?;
        check("max-speed-kmh", Some(self.max_speed_kmh), 1.0, 1000.0)?;
        check("max-gap-s", Some(self.max_gap_s), 0.1, 86_400.0)?;
        check("max-gap-m", Some(self.max_gap_m), 1.0, 100_000.0)?;
        Ok(())
    }

    /// The HMM's parameters for these fixes (defaults from the track where
    /// an option is not given; see the module documentation).
    pub fn hmm_params(&self, net: &Network, fixes: &[Fix]) -> HmmParams {
        self.hmm_params_with(net, fixes, &mut Vec::new())
    }

    /// [`Self::hmm_params`] with `buf` as σ̂'s scratch (kept by a caller
    /// matching many tracks: no allocation per track).
    pub fn hmm_params_with(&self, net: &Network, fixes: &[Fix], buf: &mut Vec<f64>) -> HmmParams {
        let base = HmmParams::default();
        let sigma_hat = estimate_sigma_m_with(net, fixes, buf);
        let radius = self.radius_m.unwrap_or_else(|| match sigma_hat {
            Some(s) => (RADIUS_SIGMAS * s).clamp(AUTO_RADIUS_M[0], AUTO_RADIUS_M[1]),
            None => base.search_radius_m,
        });
        let sigma = self.sigma_m.unwrap_or_else(|| match sigma_hat {
            Some(s) => (s * s - base.drift_sigma_m * base.drift_sigma_m)
                .max(0.0)
                .sqrt()
                .max(base.sigma_m),
            None => base.sigma_m,
        });
        let drift = match sigma_hat {
            Some(s) => s.clamp(5.0, base.drift_sigma_m),
            None => base.drift_sigma_m,
        };
        HmmParams {
            search_radius_m: radius,
            sigma_m: sigma,
            drift_sigma_m: drift,
            max_speed_mps: self.max_speed_kmh / 3.6,
            gap_s: self.max_gap_s,
            gap_m: self.max_gap_m,
            model: self.model,
            max_candidates: match self.model {
                HmmModel::Drift => base.max_candidates,
                HmmModel::Independent => INDEPENDENT_MAX_CANDIDATES,
            },
            ..base
        }
    }
}

/// Robust estimate of the position error σ (m): 1.4826 × the median
/// distance from a fix to its nearest road, over the fixes within
/// [`AUTO_RADIUS_M`]'s upper end of a road (the others say nothing about
/// the error, only that the track left the map). `None` without such fixes.
pub fn estimate_sigma_m(net: &Network, fixes: &[Fix]) -> Option<f64> {
    estimate_sigma_m_with(net, fixes, &mut Vec::new())
}

/// [`estimate_sigma_m`] with `d` as its scratch (emptied first).
pub fn estimate_sigma_m_with(net: &Network, fixes: &[Fix], d: &mut Vec<f64>) -> Option<f64> {
    // A sample of at most 2,000 fixes, evenly spread, is plenty for a median.
    let step = (fixes.len() / 2000).max(1);
    d.clear();
    d.reserve(fixes.len().div_ceil(step));
    let mut previous = None;
    d.extend(
        fixes
            .iter()
            .step_by(step)
            .filter(|f| f.enu[0].is_finite() && f.enu[1].is_finite())
            .filter_map(|f| {
                let found = nearest_road_m(net, f.enu, AUTO_RADIUS_M[1], first_radius_m(previous));
                previous = found.or(previous);
                found
            }),
    );
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    Some(1.4826 * *m)
}

/// Distance (m) from `p` to its nearest road when that is at most `max_m`:
/// grid queries of growing radius (`start_m`, 4 `start_m`, ..., `max_m`),
/// the first that finds a segment giving the nearest (the query keeps every
/// segment within its radius, by the same point–segment distance, so any
/// first radius gives the same number: the least distance over all the
/// segments). Most fixes lie near a road, so this visits a few cells where
/// a nearest-neighbour search of the R-tree costs several times more
/// (callgrind).
fn nearest_road_m(net: &Network, p: [f64; 2], max_m: f64, start_m: f64) -> Option<f64> {
    let mut r = start_m.min(max_m);
    loop {
        // The grid's own nearest within `r` (one pass over the cells, the
        // distance computed once per segment): 6 % of matching alone on the
        // FMM example's 6-fix tracks went to listing the segments and
        // measuring the kept ones again.
        if let Some(d) = net.grid.nearest_within(p, r) {
            return Some(d);
        }
        if r >= max_m {
            return None;
        }
        r = (4.0 * r).min(max_m);
    }
}

/// The first radius of σ̂'s nearest-road query for a fix (m): 16 m, or
/// twice the previous fix's distance when that is more. A noisy track
/// (the FMM example's fixes lie 20-100 m from their roads) then finds its
/// road in one query instead of two or three (16 m, 64 m, 256 m); the
/// number found is the same whatever the first radius.
fn first_radius_m(previous: Option<f64>) -> f64 {
    previous.map_or(16.0, |d| (2.0 * d).max(16.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::geometry::point_segment_distance;

    /// The nearest road is the same number, bit for bit, whatever the
    /// first radius of the growing queries (the former 16 m, and the
    /// previous fix's distance's twice): on the real maps and a bundled
    /// one, inside and beyond each map (up to 60 % of its box each side),
    /// with σ̂'s cut-off (300 m) and shorter ones.
    #[test]
    fn nearest_road_is_the_same_whatever_the_first_radius() {
        let (mut some, mut none) = (0, 0);
        for (map, net) in crate::network::fixtures::query_maps() {
            for p in crate::network::fixtures::lattice(&net, 40, 0.6, [0.37, -0.21]) {
                for max_m in [300.0, 100.0, 20.0] {
                    let want = nearest_road_m(&net, p, max_m, 16.0);
                    for prev in [0.5, 3.0, 11.0, 30.0, 47.0, 90.0, 140.0, 280.0] {
                        let got = nearest_road_m(&net, p, max_m, first_radius_m(Some(prev)));
                        assert_eq!(
                            got.map(f64::to_bits),
                            want.map(f64::to_bits),
                            "{map} {p:?} {max_m} {prev}"
                        );
                    }
                    if want.is_some() {
                        some += 1;
                    } else {
                        none += 1;
                    }
                }
            }
        }
        assert!(some > 2000 && none > 2000, "{some} {none}");
    }

    /// The grid's nearest road is the R-tree's, at the same distance, up to
    /// the cut-off; beyond it, none.
    #[test]
    fn nearest_road_from_the_grid_equals_the_r_trees() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let (mut near, mut far) = (0, 0);
        // Beyond the map's box too (up to a fifth of it each side).
        for p in crate::network::fixtures::lattice(&net, 40, 0.2, [0.0, 0.0]) {
            let want = net.rtree.nearest(p).map(|(_, d)| d).filter(|d| *d <= 60.0);
            let got = nearest_road_m(&net, p, 60.0, 16.0);
            assert_eq!(got, want, "{p:?}");
            // The grid's one-pass nearest is, bit for bit, the least
            // distance over the segments its radius query lists.
            for r in [16.0, 40.0, 64.0] {
                let listed = net
                    .grid
                    .within_radius(p, r)
                    .iter()
                    .map(|&s| {
                        let sg = &net.segments[s as usize];
                        point_segment_distance(p, sg.a, sg.b)
                    })
                    .min_by(f64::total_cmp);
                assert_eq!(
                    net.grid.nearest_within(p, r).map(f64::to_bits),
                    listed.map(f64::to_bits),
                    "{p:?} {r}"
                );
            }
            if got.is_some() {
                near += 1;
            } else {
                far += 1;
            }
        }
        assert!(near > 100 && far > 100, "{near} {far}");
    }

    /// The radius taken from the track is 4 σ̂ within 100-300 m; an
    /// explicit `--radius-m` is kept as given.
    #[test]
    fn radius_from_the_track_is_four_sigma_hat_and_an_explicit_one_is_kept() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let sg = &net.segments[net.segments.len() / 2];
        // Fixes 10-40 m off one road: σ̂ well inside the limits' range.
        let fixes: Vec<Fix> = (0..9)
            .map(|i| Fix {
                t_s: f64::from(i),
                enu: [sg.a[0] + 10.0 + 4.0 * f64::from(i), sg.a[1] + 30.0],
                heading_rad: None,
            })
            .collect();
        let s = estimate_sigma_m(&net, &fixes).unwrap();
        let p = MatchOptions::default().hmm_params(&net, &fixes);
        let want = (RADIUS_SIGMAS * s).clamp(AUTO_RADIUS_M[0], AUTO_RADIUS_M[1]);
        assert_eq!(p.search_radius_m, want);
        assert!(want > AUTO_RADIUS_M[0] && want < AUTO_RADIUS_M[1], "{s}");
        let given = MatchOptions {
            radius_m: Some(77.0),
            ..MatchOptions::default()
        };
        assert_eq!(given.hmm_params(&net, &fixes).search_radius_m, 77.0);
    }
}
