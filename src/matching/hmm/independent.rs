//! The independent-emission model ([`super::HmmModel::Independent`]):
//! Newson and Krumm's (2009) HMM. Each candidate's emission is computed once,
//! when the candidate is found (Gaussian in the fix's distance to the road
//! under the drift's prior, plus the heading's part: `Cand::emission`); the
//! Viterbi recursion over the pairs adds the transition only. No pair
//! weights are stored, no forward or backward vector is kept: the
//! confidence is the chosen road's share of the soft-max of its step's
//! Viterbi scores (a filtered max-product probability).
//!
//! Work per pair against the drift model: one look-up of the route
//! distance, the U-turn test and one subtraction; no emission (a `ln` and a
//! division), no `exp`, no forward or backward product.

use super::geometry::dist;
use super::matcher::HmmMatcher;
use super::probability::softmax_into;
use super::state::{Step, ANCHOR_M};

impl HmmMatcher<'_> {
    /// The Viterbi recursion from the window's last step into `step` under
    /// the independent model; false when no candidate can be reached from
    /// any previous one. The route distances, their bound and the U-turn
    /// rule are the drift model's ([`Self::transition`]).
    pub(super) fn transition_independent(&mut self, step: &mut Step) -> bool {
        let prev = self.window.back().expect("a previous step");
        let gc = dist(step.fix.enu, prev.fix.enu);
        let bound = self.route_bound(gc, step.fix.t_s - prev.fix.t_s);
        let backtrack = self.params.backtrack_m;
        let inv_beta = 1.0 / (self.params.beta_m + self.params.beta_per_m * gc);
        let uturn = self.params.uturn_penalty_m;
        for c in &prev.cands {
            for (n, _) in self.paths.exits(c.at).into_iter().flatten() {
                self.paths.ensure(n, bound);
            }
        }
        let prev = self.window.back().expect("a previous step");
        let (np, nc) = (prev.cands.len(), step.cands.len());
        let mut bufs = std::mem::take(&mut self.trans_buf);
        bufs.from.clear();
        bufs.from.extend(prev.cands.iter().map(|c| c.at));
        bufs.at.clear();
        bufs.at.extend(step.cands.iter().map(|c| c.at));
        self.paths.point_distance_matrix(
            &bufs.from,
            &bufs.at,
            backtrack,
            &mut bufs.scratch,
            &mut bufs.dist,
        );
        debug_assert_eq!(bufs.dist.len(), np * nc);
        step.score.clear();
        step.back.clear();
        step.pair.clear();
        step.alpha.clear();
        let mut any = false;
        for (k, c) in step.cands.iter_mut().enumerate() {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0, c.road);
            for (i, p) in prev.cands.iter().enumerate() {
                let from = prev.score[i];
                if from == f64::NEG_INFINITY {
                    continue;
                }
                let Some(d) = bufs.dist[i * nc + k] else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                // The drift model's U-turn rule, unchanged.
                let dot = |u: [f64; 2]| u[0] * c.dir[0] + u[1] * c.dir[1];
                let turned = (dot(p.dir) < -0.5 && d < uturn)
                    || (dot(p.anchor_dir) < -0.5
                        && p.anchor_m + d < 2.0 * ANCHOR_M
                        && p.anchor_road == c.road);
                let charged = if turned { d + uturn } else { d };
                let s = from - (charged - gc).abs() * inv_beta;
                if s > best {
                    best = s;
                    arg = i as u32;
                    anchor = if p.anchor_m + d > ANCHOR_M {
                        (p.dir, d, p.road)
                    } else {
                        (p.anchor_dir, p.anchor_m + d, p.anchor_road)
                    };
                }
            }
            if best > f64::NEG_INFINITY {
                any = true;
                best += c.emission;
            }
            c.anchor_dir = anchor.0;
            c.anchor_m = anchor.1;
            c.anchor_road = anchor.2;
            step.score.push(best);
            step.back.push(arg);
        }
        self.trans_buf = bufs;
        if any {
            // Renormalise so scores stay near zero on long tracks.
            let m = step.score.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for s in &mut step.score {
                *s -= m;
            }
        }
        any
    }

    /// The independent model's confidence of the window's oldest step into
    /// `out`: the soft-max of its Viterbi scores.
    pub(super) fn front_filtered(&self, out: &mut Vec<f64>) {
        softmax_into(&self.window[0].score, out);
    }
}
