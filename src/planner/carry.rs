//! Runs of the route budget carried by the tag-free pass's stretch maps
//! (module `stretch`) where they apply, stepped elsewhere: the same
//! answers as stepping every sample (see `stretch` for why).

use super::budget::Budget;
use crate::nav::Filter;

impl Budget<'_> {
    /// The first sample after `from` where the bound of filter `f` (at
    /// sample `from`, on the truth, reading no more tags) exceeds `level`,
    /// or None if it holds to the route's end, exactly as stepping `f`
    /// says ([`Budget::run_carrying`]). `f` is left along the way.
    pub(super) fn first_above(&self, from: usize, f: &mut Filter, level: f64) -> Option<usize> {
        let mut hit = None;
        let level_c = std::cell::Cell::new(level);
        self.run_carrying(from, f, &[], &level_c, |i, f| {
            if self.bound(&f.position_cov_enu()) > level {
                hit = Some(i);
            }
            hit.is_none()
        });
        hit
    }

    /// [`Budget::run`] with `visit`, but carried by the tag-free pass's
    /// stretch maps (module `stretch`) over stretches without a fix
    /// sample (`fixes`) whose bound provably stays at most `level` there,
    /// where `visit` must do nothing (it is not called there).
    pub(super) fn run_carrying(
        &self,
        from: usize,
        f: &mut Filter,
        fixes: &[usize],
        level: &std::cell::Cell<f64>,
        mut visit: impl FnMut(usize, &mut Filter) -> bool,
    ) {
        let mut step = |from: usize, f: &mut Filter, until: usize| {
            let mut go = true;
            self.run(from, f, |i, f| {
                go = visit(i, f);
                go && i < until
            });
            go
        };
        match self.stretches() {
            Some(st) => st.drive(from, f, fixes, level, step, |a, j| self.count_map(a, j)),
            None => {
                step(from, f, usize::MAX);
            }
        }
    }
}
