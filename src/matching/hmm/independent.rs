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

use super::matcher::HmmMatcher;
use super::probability::{shift_max_to_zero, softmax_into};
use super::state::{Cand, Step};

impl HmmMatcher<'_> {
    /// The Viterbi recursion from the window's last step into `step` under
    /// the independent model; false when no candidate can be reached from
    /// any previous one. The route distances, their bound and the U-turn
    /// rule are the drift model's ([`Self::transition`]).
    pub(super) fn transition_independent(&mut self, step: &mut Step) -> bool {
        let (gc, bound, inv_beta, bufs) = self.route_distances(step);
        let uturn = self.params.uturn_penalty_m;
        let prev = self.window.back().expect("a previous step");
        let (np, nc) = (prev.cands.len(), step.cands.len());
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
                let charged = c.charged_from(p, d, uturn);
                let s = from - (charged - gc).abs() * inv_beta;
                if s > best {
                    best = s;
                    arg = i as u32;
                    anchor = Cand::anchor_through(p, d);
                }
            }
            if best > f64::NEG_INFINITY {
                any = true;
                best += c.emission;
            }
            c.set_anchor(anchor);
            step.score.push(best);
            step.back.push(arg);
        }
        self.trans_buf = bufs;
        if any {
            shift_max_to_zero(&mut step.score);
        }
        any
    }

    /// The independent model's confidence of the window's oldest step into
    /// `out`: the soft-max of its Viterbi scores.
    pub(super) fn front_filtered(&self, out: &mut Vec<f64>) {
        softmax_into(&self.window[0].score, out);
    }
}
