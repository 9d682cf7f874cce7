//! Candidates of a fix: the nearest point of each section within the search
//! radius, one state per permitted direction, ranked by emission.

use super::drift::{emission, Drift, Line};
use super::geometry::directed_cos;
use super::matcher::HmmMatcher;
use super::state::{Cand, Step};
use crate::matching::paths::OnSection;
use crate::matching::{project, Fix};

impl HmmMatcher<'_> {
    /// Candidates of a fix into `cands`, placed and ranked with the drift `d`.
    pub(super) fn candidates(
        &mut self,
        fix: &Fix,
        heading: Option<(f64, f64)>,
        d: &Drift,
        cands: &mut Vec<Cand>,
    ) {
        let net = self.net;
        cands.clear();
        self.seg_buf.clear();
        net.grid
            .within_radius_into(fix.enu, self.params.search_radius_m, &mut self.seg_buf);
        let r2 = self.params.sigma_m * self.params.sigma_m;
        let corrected = [fix.enu[0] - d.mean[0], fix.enu[1] - d.mean[1]];
        // The nearest segment of each section to the fix less the drift.
        let mut nearest = std::mem::take(&mut self.near_buf);
        nearest.clear();
        for &seg in &self.seg_buf {
            let (t, _, dist) = project(net, seg, corrected);
            let section = net.segments[seg as usize].section;
            match nearest.iter_mut().find(|n| n.0 == section) {
                Some(n) => {
                    if dist < n.2 {
                        *n = (section, seg, dist, t);
                    }
                }
                None => nearest.push((section, seg, dist, t)),
            }
        }
        for &(section, seg, _, t) in &nearest {
            let s = &net.segments[seg as usize];
            let line = Line::of(net, seg);
            let base = emission(&line, fix.enu, d, r2).log_p;
            let offset_m = s.section_offset_m + t * s.length_m;
            let oneway = net.sections[section as usize].oneway;
            // One state per permitted direction of the section.
            for forward in [true, false] {
                if !(if forward {
                    oneway.allows_forward()
                } else {
                    oneway.allows_backward()
                }) {
                    continue;
                }
                let h = match heading {
                    Some((h, kappa)) => kappa * (directed_cos(net, seg, h, forward) - 1.0),
                    None => 0.0,
                };
                let sign = if forward { 1.0 } else { -1.0 };
                cands.push(Cand {
                    seg,
                    line,
                    at: OnSection {
                        section,
                        offset_m,
                        forward: Some(forward),
                    },
                    emission: base + h,
                    heading: h,
                    dir: [sign * line.u[0], sign * line.u[1]],
                    anchor_dir: [0.0; 2],
                    anchor_m: 0.0,
                    road: s.road,
                    anchor_road: s.road,
                    drift: *d,
                });
            }
        }
        self.near_buf = nearest;
        // The best `max_candidates` by emission, ties in the order found (a
        // total order, so the selection does not depend on the sorting
        // algorithm); sorted as keys, the candidates moved once.
        let order = |a: &(f64, u32), b: &(f64, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
        let mut keys = std::mem::take(&mut self.key_buf);
        keys.clear();
        keys.extend(
            cands
                .iter()
                .enumerate()
                .map(|(i, c)| (c.emission, i as u32)),
        );
        let k = self.params.max_candidates.min(keys.len());
        if k == 0 {
            cands.clear();
        } else {
            if keys.len() > k {
                keys.select_nth_unstable_by(k - 1, order);
                keys.truncate(k);
            }
            keys.sort_unstable_by(order);
            // Far less likely than the best: dropped (`min_emission_ratio`).
            // The ratio is taken within [0, 1] (NaN as 0), so the best is
            // always kept and a ratio out of range never empties the set.
            let ratio = self.params.min_emission_ratio;
            let ratio = if ratio.is_nan() {
                0.0
            } else {
                ratio.clamp(0.0, 1.0)
            };
            let floor = keys[0].0 + ratio.ln();
            let kept = keys.partition_point(|k| k.0 >= floor);
            keys.truncate(kept);
            let mut sorted = std::mem::take(&mut self.cand_buf);
            sorted.clear();
            sorted.extend(keys.iter().map(|&(_, i)| cands[i as usize]));
            std::mem::swap(cands, &mut sorted);
            self.cand_buf = sorted;
        }
        self.key_buf = keys;
    }

    pub(super) fn new_step(&mut self, index: u64, fix: Fix) -> Step {
        match self.spare.pop() {
            Some(mut s) => {
                s.index = index;
                s.fix = fix;
                s.cands.clear();
                s.score.clear();
                s.back.clear();
                s.alpha.clear();
                s.pair.clear();
                s.pending.clear();
                s
            }
            None => Step {
                index,
                fix,
                cands: Vec::with_capacity(self.params.max_candidates),
                score: Vec::with_capacity(self.params.max_candidates),
                back: Vec::with_capacity(self.params.max_candidates),
                alpha: Vec::with_capacity(self.params.max_candidates),
                pair: Vec::with_capacity(self.params.max_candidates * self.params.max_candidates),
                pending: Vec::new(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{HmmMatcher, HmmParams};
    use super::*;
    use crate::network::Network;

    /// The emission-ratio rule drops exactly the candidates below the
    /// fix's best × `min_emission_ratio`, keeping the others in the same
    /// order; with 0 every candidate within the radius (up to the cap) is
    /// kept, and on this map some of those lie below the floor.
    #[test]
    fn candidates_far_less_likely_than_the_best_are_dropped() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let params = |ratio: f64| HmmParams {
            search_radius_m: 300.0,
            max_candidates: 1000,
            min_emission_ratio: ratio,
            ..HmmParams::default()
        };
        let (mut all, mut kept) = (Vec::new(), Vec::new());
        let mut below = 0;
        for sg in net.segments.iter().step_by(7) {
            let fix = Fix {
                t_s: 0.0,
                enu: [(sg.a[0] + sg.b[0]) / 2.0 + 3.0, (sg.a[1] + sg.b[1]) / 2.0],
                heading_rad: None,
            };
            let d = Drift::prior(HmmParams::default().drift_sigma_m);
            HmmMatcher::new(&net, params(0.0)).candidates(&fix, None, &d, &mut all);
            HmmMatcher::new(&net, params(1e-6)).candidates(&fix, None, &d, &mut kept);
            let floor = all[0].emission + 1e-6f64.ln();
            let want: Vec<_> = all.iter().filter(|c| c.emission >= floor).collect();
            below += all.len() - want.len();
            assert_eq!(want.len(), kept.len());
            for (a, b) in want.iter().zip(&kept) {
                assert_eq!(
                    (a.seg, a.at.forward, a.emission),
                    (b.seg, b.at.forward, b.emission)
                );
            }
        }
        assert!(
            below > 0,
            "no candidate below the floor: the test shows nothing"
        );
    }
    /// A ratio out of range never empties a fix's candidates: NaN and
    /// negative ratios keep every candidate within the radius, ratios
    /// above 1 keep the best (and its ties) only.
    #[test]
    fn an_out_of_range_emission_ratio_keeps_the_best() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let sg = &net.segments[net.segments.len() / 2];
        let fix = Fix {
            t_s: 0.0,
            enu: [(sg.a[0] + sg.b[0]) / 2.0 + 3.0, (sg.a[1] + sg.b[1]) / 2.0],
            heading_rad: None,
        };
        let d = Drift::prior(HmmParams::default().drift_sigma_m);
        let run = |ratio: f64| {
            let params = HmmParams {
                search_radius_m: 300.0,
                max_candidates: 1000,
                min_emission_ratio: ratio,
                ..HmmParams::default()
            };
            let mut out = Vec::new();
            HmmMatcher::new(&net, params).candidates(&fix, None, &d, &mut out);
            out
        };
        let all = run(0.0);
        assert!(all.len() > 1, "{}", all.len());
        for ratio in [f64::NAN, -1.0] {
            assert_eq!(run(ratio).len(), all.len(), "{ratio}");
        }
        let best = run(2.0);
        assert!(!best.is_empty() && best.len() < all.len(), "{}", best.len());
        assert_eq!(best[0].emission, all[0].emission);
    }
}
