//! The priority item of the covers' lazy greedies.

use std::cmp::Ordering;

/// A site with its score (and what the score was computed from), ordered
/// for a max-heap: the highest score first, ties to the lower site index
/// (deterministic). A min-heap pushes the negated score.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BestSite<T> {
    pub score: f64,
    pub site: usize,
    pub data: T,
}

impl<T> PartialEq for BestSite<T> {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}

impl<T> Eq for BestSite<T> {}

impl<T> Ord for BestSite<T> {
    fn cmp(&self, o: &Self) -> Ordering {
        self.score
            .total_cmp(&o.score)
            .then_with(|| o.site.cmp(&self.site))
    }
}

impl<T> PartialOrd for BestSite<T> {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BinaryHeap;

    #[test]
    fn the_heap_pops_the_highest_score_then_the_lowest_site() {
        let mut h = BinaryHeap::new();
        for (score, site) in [(1.0, 4), (2.0, 9), (2.0, 3), (-1.0, 0)] {
            h.push(BestSite {
                score,
                site,
                data: (),
            });
        }
        let order: Vec<usize> = std::iter::from_fn(|| h.pop().map(|b| b.site)).collect();
        assert_eq!(order, vec![3, 9, 4, 0]);
    }
}
