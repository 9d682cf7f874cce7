//! The greedy for walk coverage: rounds of greedy set multicover over the
//! witnesses of the current violations (the exact walk dynamic programme of
//! [`super::cover`]), then reverse deletion of redundant tags, each removal
//! tested exactly by that programme restricted to the ball of radius
//! `R + 1` around the tag ([`LocalChecker`]; a violation created by removing
//! a tag lies on a walk of length just over `R` through it).

use super::cover::{check_with_witnesses, passes, CoverProblem, Dp, Solved, Walk};
use std::collections::BinaryHeap;

/// Greedy set multicover over the witnesses of the current violations, in
/// rounds until [`check`](super::cover::check) passes, then reverse deletion of redundant tags
/// (exact local test). Every added site serves at least one witness, so the
/// rounds end.
pub fn greedy(p: &CoverProblem) -> Solved {
    greedy_with_stats(p).0
}

/// What the greedy did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GreedyStats {
    /// Multicover rounds (exact checks).
    pub rounds: usize,
    /// Sites added by the multicover.
    pub added: usize,
    /// Of them, removed again by reverse deletion.
    pub removed: usize,
}

/// [`greedy`] with its statistics.
pub fn greedy_with_stats(p: &CoverProblem) -> (Solved, GreedyStats) {
    greedy_from(p, p.existing_selection(), &mut |_| {})
}

/// [`greedy_with_stats`] from `selected` (installed sites included; reverse
/// deletion tries only the sites added), handing every round's witnesses to `witness`.
pub(crate) fn greedy_from(
    p: &CoverProblem,
    mut selected: Vec<bool>,
    witness: &mut dyn FnMut(&Walk),
) -> (Solved, GreedyStats) {
    let mut stats = GreedyStats::default();
    let need_all = p.k + 1;
    let mut order: Vec<u32> = Vec::new();
    loop {
        stats.rounds += 1;
        let (res, walks) = check_with_witnesses(p, &selected, usize::MAX);
        if res.feasible() {
            break;
        }
        // Remaining need of each witness; site → witnesses (with multiplicity).
        let mut need: Vec<usize> = walks
            .iter()
            .map(|w| need_all.saturating_sub(passes(w, &selected)))
            .collect();
        let mut by_site: Vec<Vec<u32>> = vec![Vec::new(); p.sites.len()];
        for (wi, w) in walks.iter().enumerate() {
            if need[wi] == 0 {
                continue;
            }
            let free = w.sites.iter().filter(|&&s| !selected[s as usize]).count();
            if free < need[wi] {
                // Every unselected pass would not be enough.
                return (Solved::Infeasible(w.clone()), stats);
            }
            for &s in &w.sites {
                if !selected[s as usize] {
                    by_site[s as usize].push(wi as u32);
                }
            }
        }
        if walks.is_empty() {
            // Rounding left no witness: should not happen; stop safely.
            let w = Walk {
                pieces: vec![(res.violations[0].edge, 0.0, res.violations[0].at_m)],
                sites: vec![],
            };
            return (Solved::Infeasible(w), stats);
        }
        let score = |s: usize, need: &[usize]| -> f64 {
            let hits: usize = by_site[s].iter().filter(|&&w| need[w as usize] > 0).count();
            hits as f64 / p.sites[s].cost.max(1e-6)
        };
        let mut heap: BinaryHeap<(u64, std::cmp::Reverse<u32>)> = BinaryHeap::new();
        for s in 0..p.sites.len() {
            if !selected[s] && !by_site[s].is_empty() {
                heap.push((score(s, &need).to_bits(), std::cmp::Reverse(s as u32)));
            }
        }
        while let Some((sc, std::cmp::Reverse(s))) = heap.pop() {
            let s = s as usize;
            if selected[s] {
                continue;
            }
            let now = score(s, &need);
            if now <= 0.0 {
                continue;
            }
            if now.to_bits() < sc {
                heap.push((now.to_bits(), std::cmp::Reverse(s as u32)));
                continue;
            }
            selected[s] = true;
            order.push(s as u32);
            for &w in &by_site[s] {
                need[w as usize] = need[w as usize].saturating_sub(1);
            }
        }
        walks.iter().for_each(&mut *witness);
    }
    // Reverse deletion: most expensive first, then latest added first.
    let mut cands = order.clone();
    cands.reverse();
    cands.sort_by(|&a, &b| {
        p.sites[b as usize]
            .cost
            .total_cmp(&p.sites[a as usize].cost)
    });
    stats.added = order.len();
    let mut local = LocalChecker::new(p, &selected);
    for s in cands {
        if local.try_remove(s) {
            selected[s as usize] = false;
            stats.removed += 1;
        }
    }
    (Solved::Feasible(selected), stats)
}

/// Exact feasibility tests restricted to the ball around a site, for
/// removing sites from a feasible selection one at a time.
pub struct LocalChecker<'a> {
    p: &'a CoverProblem,
    dp: Dp<'a>,
    dist: Vec<f64>,
    mask: Vec<bool>,
}

impl<'a> LocalChecker<'a> {
    /// A checker for a feasible selection of an instance.
    pub fn new(p: &'a CoverProblem, selected: &[bool]) -> Self {
        Self {
            p,
            dp: Dp::new(p, selected),
            dist: vec![f64::INFINITY; p.nodes],
            mask: vec![false; p.edges.len()],
        }
    }

    /// Nodes within `lim` of `from` (reached at distance `d0`) along edges
    /// (`forward`) or against them.
    fn ball(&mut self, from: u32, d0: f64, lim: f64, forward: bool) -> Vec<u32> {
        let p = self.p;
        let mut touched: Vec<u32> = Vec::new();
        let mut heap: BinaryHeap<(std::cmp::Reverse<u64>, u32)> = BinaryHeap::new();
        if d0 <= lim {
            self.dist[from as usize] = d0;
            touched.push(from);
            heap.push((std::cmp::Reverse(d0.to_bits()), from));
        }
        while let Some((std::cmp::Reverse(db), v)) = heap.pop() {
            let d = f64::from_bits(db);
            if d > self.dist[v as usize] {
                continue;
            }
            let adj = if forward {
                &p.out_edges[v as usize]
            } else {
                &p.in_edges[v as usize]
            };
            for &e in adj {
                let ed = &p.edges[e as usize];
                let w = if forward { ed.head } else { ed.tail };
                let nd = d + ed.length_m;
                if nd < self.dist[w as usize] && nd <= lim {
                    if self.dist[w as usize].is_infinite() {
                        touched.push(w);
                    }
                    self.dist[w as usize] = nd;
                    heap.push((std::cmp::Reverse(nd.to_bits()), w));
                }
            }
        }
        for &v in &touched {
            self.dist[v as usize] = f64::INFINITY;
        }
        touched
    }

    /// Removes selected site `s` if the selection stays feasible; returns
    /// whether it did. Exact: a violation created by the removal lies on a
    /// walk of length just over R through the site, whose parts before and
    /// after the site are walks of at most R + 1 to and from it; the
    /// dynamic programme over the edges entering the backward ball and
    /// leaving the forward ball sees every such walk, and only real walks.
    pub fn try_remove(&mut self, s: u32) -> bool {
        let p = self.p;
        let site = p.sites[s as usize];
        let pe = &mut self.dp.pos[site.edge as usize];
        let Some(ix) = pe.iter().position(|&x| x == site.at_m) else {
            return false;
        };
        pe.remove(ix);
        let e0 = p.edges[site.edge as usize];
        // Quick exact rejection: a self-loop or a two-edge cycle through the
        // site's edge left without tags carries walks of any length.
        if self.dp.pos[site.edge as usize].is_empty() {
            let bare_cycle = e0.tail == e0.head
                || p.out_edges[e0.head as usize].iter().any(|&b| {
                    p.edges[b as usize].head == e0.tail && self.dp.pos[b as usize].is_empty()
                });
            if bare_cycle {
                self.dp.pos[site.edge as usize].insert(ix, site.at_m);
                return false;
            }
        }
        let lim = p.reach_m + 1.0;
        // The violating walk's part after the site is a forward walk from
        // it, the part before a backward walk to it, each at most R + 1
        // long: Dijkstra forward from the head and backward from the tail.
        let fwd = self.ball(e0.head, e0.length_m - site.at_m, lim, true);
        let bwd = self.ball(e0.tail, site.at_m, lim, false);
        // Edges leaving the forward ball, entering the backward ball, and
        // the site's edge.
        let mut edges: Vec<u32> = vec![site.edge];
        for &v in &fwd {
            edges.extend_from_slice(&p.out_edges[v as usize]);
        }
        for &v in &bwd {
            edges.extend_from_slice(&p.in_edges[v as usize]);
        }
        edges.sort_unstable();
        edges.dedup();
        for &e in &edges {
            self.mask[e as usize] = true;
        }
        let mut nodes: Vec<u32> = edges
            .iter()
            .flat_map(|&e| [p.edges[e as usize].tail, p.edges[e as usize].head])
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        let ok = !self.dp.solve(Some(&self.mask), &nodes, true)
            && self.dp.violations(Some(&self.mask), &edges).is_empty();
        self.dp.reset(&nodes);
        for &e in &edges {
            self.mask[e as usize] = false;
        }
        if !ok {
            let pe = &mut self.dp.pos[site.edge as usize];
            let at = pe.partition_point(|&x| x < site.at_m);
            pe.insert(at, site.at_m);
        }
        ok
    }
}
