//! Landmark lower bounds on road distance, for A* (the "ALT" method:
//! A*, landmarks and the triangle inequality; Goldberg & Harrelson, 2005).
//!
//! For a landmark `L` and any nodes `v`, `t`, the triangle inequality of
//! shortest-path distances `d` on the directed road graph gives
//!
//! `d(v, t) ≥ d(v, L) − d(t, L)`  and  `d(v, t) ≥ d(L, t) − d(L, v)`,
//!
//! so with both distances to and from a few landmarks stored per node, the
//! largest of these differences is a lower bound on `d(v, t)` that, unlike
//! the straight line, knows about rivers, one-way systems and motorways
//! without exits. As a difference of exact distances it is a consistent
//! heuristic (`h(u) ≤ len(u→w) + h(w)`), so A* with it settles each node
//! once and returns a shortest path; it settles far fewer nodes than with
//! the straight line alone (BENCHMARKS.md, "Routing with landmarks").
//!
//! Edge cases: a node a landmark cannot reach, or that cannot reach it,
//! stores ∞. A difference `∞ − finite` is a true statement (`v` cannot reach
//! `t` at all) and makes the bound ∞, which A* reads as "no path from here";
//! `finite − ∞` and `∞ − ∞` say nothing and are skipped.
//!
//! Landmarks are chosen by the "farthest" rule: the first is the node of the
//! largest strongly connected part farthest from its centroid, each next one
//! the node of that part farthest by road (to and back) from those chosen.
//! Deterministic: no randomness, ties to the lowest node id.

use super::HeapItem;
use crate::network::{Network, NodeId};
use std::collections::BinaryHeap;

/// Landmarks a trip sampler builds: 16 stores 256 bytes per node and is
/// the usual choice in the literature for road networks of city to country
/// size; more gives tighter bounds at more work per settled node.
pub const DEFAULT_LANDMARKS: usize = 16;

/// Most bytes the distances may take (256 MiB): 16 landmarks up to 1 M
/// nodes (a country's roads), fewer beyond, none past 16 M nodes (A* then
/// runs on the straight line alone, as without landmarks).
pub const MAX_LANDMARK_BYTES: usize = 1 << 28;

/// Distances to and from a few landmarks, per node.
#[derive(Debug, Clone)]
pub struct Landmarks {
    count: usize,
    /// `d(v → L_l)` at `v * count + l` (m; ∞ when `v` cannot reach `L_l`).
    to: Vec<f64>,
    /// `d(L_l → v)` at `v * count + l`.
    from: Vec<f64>,
    /// The landmark nodes, in the order chosen.
    nodes: Vec<NodeId>,
}

/// The directed node graph as offsets and (head, length) arcs.
struct Arcs {
    offsets: Vec<usize>,
    arcs: Vec<(NodeId, f64)>,
}

impl Arcs {
    /// Forward arcs (the departures A* follows) or their reverse.
    fn of(net: &Network, reverse: bool) -> Self {
        let nn = net.nodes.len();
        let mut pairs: Vec<(NodeId, NodeId, f64)> = Vec::new();
        for node in 0..nn as NodeId {
            for d in net.topology.departures(&net.model, node) {
                let s = &net.sections[d.section as usize];
                let next = if d.forward { s.end } else { s.start };
                if reverse {
                    pairs.push((next, node, s.length_m));
                } else {
                    pairs.push((node, next, s.length_m));
                }
            }
        }
        let mut offsets = vec![0usize; nn + 1];
        for &(a, _, _) in &pairs {
            offsets[a as usize + 1] += 1;
        }
        for i in 1..=nn {
            offsets[i] += offsets[i - 1];
        }
        let mut fill = offsets.clone();
        let mut arcs = vec![(0 as NodeId, 0.0); pairs.len()];
        for &(a, b, len) in &pairs {
            arcs[fill[a as usize]] = (b, len);
            fill[a as usize] += 1;
        }
        Self { offsets, arcs }
    }

    /// Distances from `source` over these arcs (Dijkstra).
    fn distances(&self, source: NodeId) -> Vec<f64> {
        let nn = self.offsets.len() - 1;
        let mut dist = vec![f64::INFINITY; nn];
        let mut heap = BinaryHeap::new();
        dist[source as usize] = 0.0;
        heap.push(HeapItem {
            cost: 0.0,
            node: source,
        });
        while let Some(HeapItem { cost, node }) = heap.pop() {
            if cost > dist[node as usize] {
                continue;
            }
            let n = node as usize;
            for &(next, len) in &self.arcs[self.offsets[n]..self.offsets[n + 1]] {
                let c = cost + len;
                if c < dist[next as usize] {
                    dist[next as usize] = c;
                    heap.push(HeapItem {
                        cost: c,
                        node: next,
                    });
                }
            }
        }
        dist
    }
}

impl Landmarks {
    /// Chooses up to `count` landmarks in the network's largest strongly
    /// connected part (fewer when their distances would pass
    /// [`MAX_LANDMARK_BYTES`]) and stores the distances to and from each
    /// (two Dijkstra searches over the whole map per landmark).
    pub fn build(net: &Network, count: usize) -> Self {
        let nn = net.nodes.len();
        let main: Vec<NodeId> = (0..nn as NodeId)
            .filter(|&n| net.topology.scc_of(n) == net.topology.largest_scc)
            .collect();
        let per_landmark = 2 * std::mem::size_of::<f64>() * nn.max(1);
        let count = count.min(main.len()).min(MAX_LANDMARK_BYTES / per_landmark);
        let forward = Arcs::of(net, false);
        let backward = Arcs::of(net, true);
        let mut to = vec![f64::INFINITY; nn * count];
        let mut from = vec![f64::INFINITY; nn * count];
        let mut nodes = Vec::with_capacity(count);
        // Round trip to the nearest landmark chosen so far, per main node.
        let mut nearest = vec![f64::INFINITY; main.len()];
        for l in 0..count {
            let pick = if l == 0 {
                let n = main.len() as f64;
                let (cx, cy) = main.iter().fold((0.0, 0.0), |(x, y), &v| {
                    let p = net.nodes[v as usize].enu;
                    (x + p[0] / n, y + p[1] / n)
                });
                farthest(main.iter().map(|&v| {
                    let p = net.nodes[v as usize].enu;
                    (v, (p[0] - cx).hypot(p[1] - cy))
                }))
            } else {
                farthest(main.iter().copied().zip(nearest.iter().copied()))
            };
            let Some(pick) = pick else { break };
            nodes.push(pick);
            let d_from = forward.distances(pick);
            let d_to = backward.distances(pick);
            for v in 0..nn {
                from[v * count + l] = d_from[v];
                to[v * count + l] = d_to[v];
            }
            for (k, &v) in main.iter().enumerate() {
                nearest[k] = nearest[k].min(d_from[v as usize] + d_to[v as usize]);
            }
        }
        Self {
            count,
            to,
            from,
            nodes,
        }
    }

    /// The landmark nodes, in the order chosen.
    pub fn nodes(&self) -> &[NodeId] {
        &self.nodes
    }

    /// A lower bound on the road distance from `v` to `t` (m; ∞ when `v`
    /// provably cannot reach `t`; 0 with no landmark).
    #[inline]
    pub fn lower_bound(&self, v: NodeId, t: NodeId) -> f64 {
        (0..self.count).fold(0.0, |b, l| b.max(self.bound_by(l, v, t)))
    }

    /// The bound of landmark `l` alone.
    #[inline]
    fn bound_by(&self, l: usize, v: NodeId, t: NodeId) -> f64 {
        let k = self.count;
        let (v, t) = (v as usize * k + l, t as usize * k + l);
        let mut b = 0.0f64;
        let (vt, tt) = (self.to[v], self.to[t]);
        if tt.is_finite() {
            b = b.max(vt - tt);
        }
        let (lv, lt) = (self.from[v], self.from[t]);
        if lv.is_finite() {
            b = b.max(lt - lv);
        }
        b
    }

    /// The bound towards `t` from the [`ACTIVE`] landmarks that bound the
    /// distance from `s` to `t` best (the usual refinement: a landmark
    /// behind the target helps little, and reading all of them at every
    /// settled node costs more than the few extra nodes it saves). Still a
    /// lower bound and consistent: the largest of some of the landmarks'.
    pub(super) fn towards(&self, s: NodeId, t: NodeId) -> Towards<'_> {
        let mut picks = [usize::MAX; ACTIVE];
        let mut vals = [f64::NEG_INFINITY; ACTIVE];
        for l in 0..self.count {
            let b = self.bound_by(l, s, t);
            // Insertion into the sorted best few (ties keep the lower index).
            if let Some(i) = (0..ACTIVE).find(|&i| b > vals[i]) {
                for j in (i + 1..ACTIVE).rev() {
                    picks[j] = picks[j - 1];
                    vals[j] = vals[j - 1];
                }
                picks[i] = l;
                vals[i] = b;
            }
        }
        let n = picks.iter().take_while(|&&p| p != usize::MAX).count();
        Towards {
            lm: self,
            t,
            picks,
            n,
        }
    }
}

/// Landmarks read per settled node by [`Landmarks::towards`].
const ACTIVE: usize = 4;

/// A target and the landmarks chosen for it ([`Landmarks::towards`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Towards<'a> {
    lm: &'a Landmarks,
    t: NodeId,
    picks: [usize; ACTIVE],
    n: usize,
}

impl Towards<'_> {
    /// A lower bound on the road distance from `v` to the target (m).
    #[inline]
    pub(super) fn from(&self, v: NodeId) -> f64 {
        self.picks[..self.n]
            .iter()
            .fold(0.0, |b, &l| b.max(self.lm.bound_by(l, v, self.t)))
    }
}

/// The node with the largest finite value, ties to the lowest id.
fn farthest(values: impl Iterator<Item = (NodeId, f64)>) -> Option<NodeId> {
    let mut best: Option<(NodeId, f64)> = None;
    for (v, d) in values {
        if d.is_finite() && best.is_none_or(|(bv, bd)| d > bd || (d == bd && v < bv)) {
            best = Some((v, d));
        }
    }
    best.map(|b| b.0)
}
