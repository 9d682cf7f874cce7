//! The bounded one-to-many Dijkstra search behind [`super::paths`]'s
//! cache: from one topology node over permitted directed sections, up to a
//! distance bound, into a table of the reached nodes.
//!
//! Built for the many small searches of a cold match (one per predecessor
//! exit node, each settling a few dozen nodes): the departures of every node
//! are read from a compact table built at the first search (next node,
//! length, directed section code, contiguous per node) instead of through
//! the topology's incidences and the sections; the priority queue is a
//! binary heap of packed 128-bit keys (the distance's bits in an
//! order-preserving form, then the node), so popping the least
//! (distance, node) is one integer comparison per level; a node's
//! distance, predecessor and first section are one 16-byte label, so a
//! small network's dense table is the labels themselves (exchanged for a
//! spare table, all unreached, as the next search's labels). The source
//! is settled first without the heap (its first pop). Nodes are settled
//! in the same (distance, node) order as the `BinaryHeap` search this
//! replaced, with the same relaxations in the same order: the same trees,
//! bit for bit (compared with that search, kept in the tests below). Dead
//! ends, and nodes whose shortest departure leads beyond the bound, are
//! labelled but not queued: settling one would relax nothing (a dead end
//! only the section back to the settled node it was reached from).

use crate::network::{DirectedSection, Network, NodeId};
use rustc_hash::FxHashMap;

/// No predecessor (the source) or no first section.
pub(super) const NO_PRED: u32 = u32::MAX;

/// Reached nodes kept in all before the cache is emptied (about 24 bytes
/// each: some 50 MB).
pub const CACHE_ENTRIES: usize = 2_000_000;

/// A node's distance, predecessor (directed section code) and the first
/// section taken from the source.
pub(super) type Label = (f64, u32, u32);

/// Not reached.
const UNREACHED: Label = (f64::INFINITY, NO_PRED, NO_PRED);

/// One search's result: its bound and its reached nodes.
#[derive(Debug, Default)]
pub(super) struct Tree {
    pub(super) bound: f64,
    /// Distance, predecessor (directed section code) and the first section
    /// taken from the source, by node.
    pub(super) reached: Reached,
}

/// A search's reached nodes: a hash table, or, when the search reached at
/// least a quarter of the network's nodes (small networks), a table indexed
/// by node (a look-up without hashing; at most 4 entries per reached node,
/// so memory stays within a few times the hash table's).
#[derive(Debug)]
pub(super) enum Reached {
    Sparse(FxHashMap<NodeId, Label>),
    /// By node; an infinite distance: not reached.
    Dense(Vec<Label>),
}

impl Default for Reached {
    fn default() -> Self {
        Reached::Sparse(FxHashMap::default())
    }
}

impl Reached {
    #[inline]
    pub(super) fn get(&self, n: &NodeId) -> Option<&Label> {
        match self {
            Reached::Sparse(m) => m.get(n),
            Reached::Dense(v) => v.get(*n as usize).filter(|r| r.0.is_finite()),
        }
    }

    /// Entries held (for the cache's size bound).
    pub(super) fn len(&self) -> usize {
        match self {
            Reached::Sparse(m) => m.len(),
            Reached::Dense(v) => v.len(),
        }
    }

    /// Entries its memory holds.
    fn capacity(&self) -> usize {
        match self {
            Reached::Sparse(m) => m.capacity(),
            Reached::Dense(v) => v.capacity(),
        }
    }
}

/// The directed section code of a departure (section × 2, plus 1 forward).
#[inline]
pub(super) fn code(d: DirectedSection) -> u32 {
    d.section * 2 + u32::from(d.forward)
}

/// A departure from a node: the node it leads to, its length and its
/// directed section code.
#[derive(Debug, Clone, Copy)]
struct Arc {
    len: f64,
    next: NodeId,
    code: u32,
}

/// `x`'s bits mapped so that unsigned order is [`f64::total_cmp`]'s order.
#[inline(always)]
fn ordered(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

/// The inverse of [`ordered`].
#[inline(always)]
fn unordered(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// A min-heap of (distance, node) keys packed as `ordered(distance) << 32 |
/// node`: the least distance first, the least node among equal ones (what
/// the former `BinaryHeap` of reversed items popped).
#[derive(Debug, Default)]
struct KeyHeap {
    keys: Vec<u128>,
}

impl KeyHeap {
    #[inline(always)]
    fn push(&mut self, cost: f64, node: NodeId) {
        let key = u128::from(ordered(cost)) << 32 | u128::from(node);
        let mut i = self.keys.len();
        self.keys.push(key);
        let k = &mut self.keys[..];
        while i > 0 {
            let parent = (i - 1) / 2;
            if k[parent] <= key {
                break;
            }
            k[i] = k[parent];
            i = parent;
        }
        k[i] = key;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(f64, NodeId)> {
        let top = *self.keys.first()?;
        let last = self.keys.pop().expect("not empty");
        let k = &mut self.keys[..];
        let n = k.len();
        if n > 0 {
            let mut i = 0;
            loop {
                let mut c = 2 * i + 1;
                if c >= n {
                    break;
                }
                if c + 1 < n && k[c + 1] < k[c] {
                    c += 1;
                }
                if last <= k[c] {
                    break;
                }
                k[i] = k[c];
                i = c;
            }
            k[i] = last;
        }
        Some((unordered((top >> 32) as u64), top as u32))
    }
}

/// One search's tables and bound.
struct Run<'s> {
    offsets: &'s [u32],
    arcs: &'s [Arc],
    rim: &'s [f64],
    labels: &'s mut [Label],
    touched: &'s mut Vec<NodeId>,
    heap: &'s mut KeyHeap,
    bound: f64,
}

impl Run<'_> {
    /// Settles the queued nodes in (distance, node) order until the heap
    /// is empty, skipping stale entries; `from`, the source, is settled as
    /// the source again (only with a negative length can it be labelled
    /// again).
    #[inline(always)]
    fn drain(&mut self, from: NodeId) {
        while let Some((cost, node)) = self.heap.pop() {
            let here = self.labels[node as usize];
            if cost > here.0 {
                continue;
            }
            if node == from {
                self.settle::<true>(node, cost, NO_PRED);
            } else {
                self.settle::<false>(node, cost, here.2);
            }
        }
    }

    /// Settles `node` at `cost`: relaxes its departures, each node
    /// labelled with `first` as its first section (the departure's own
    /// section from the source: `SOURCE`).
    #[inline(always)]
    fn settle<const SOURCE: bool>(&mut self, node: NodeId, cost: f64, first: u32) {
        let (a, b) = (self.offsets[node as usize], self.offsets[node as usize + 1]);
        for arc in &self.arcs[a as usize..b as usize] {
            let c = cost + arc.len;
            let l = &mut self.labels[arc.next as usize];
            if c <= self.bound && c < l.0 {
                if l.0.is_infinite() {
                    self.touched.push(arc.next);
                }
                *l = (c, arc.code, if SOURCE { arc.code / 2 } else { first });
                if c + self.rim[arc.next as usize] <= self.bound {
                    self.heap.push(c, arc.next);
                }
            }
        }
    }
}

/// The search's memory, kept between searches (no search allocates once it
/// has grown), and the tables of dropped searches for reuse.
#[derive(Debug, Default)]
pub(super) struct Searcher {
    /// Departures by node: `arcs[offsets[n]..offsets[n + 1]]` (built at
    /// the first search; empty before).
    offsets: Vec<u32>,
    arcs: Vec<Arc>,
    /// By node, what its distance plus this must not exceed the bound by
    /// for settling it to relax anything: its shortest departure's length
    /// (no departure: infinite; a NaN length: −∞, always queued), or
    /// infinite for a dead end (every section to one same other node: it
    /// is reached only from that node, after it is settled, and leads only
    /// back to it). A node whose settling would relax nothing is labelled
    /// but not queued. (Floating-point addition is monotone: a departure
    /// no shorter than the shortest gives a sum no smaller.)
    rim: Vec<f64>,
    /// By node, its longest departure (NaN lengths aside; none: −∞): a
    /// reached node whose distance plus this is within a tree's bound had
    /// every departure relaxed within it ([`Self::resume`]).
    far: Vec<f64>,
    /// No departure is shorter than zero (NaN aside): nodes are settled in
    /// order of distance, what [`Self::covers`] relies on.
    monotone: bool,
    /// Labels by node (unreached outside a search).
    labels: Vec<Label>,
    touched: Vec<NodeId>,
    heap: KeyHeap,
    /// Tables of searches dropped from the cache, reused by the next
    /// searches (their entries in all at most [`CACHE_ENTRIES`]).
    spare: Vec<Reached>,
    spare_entries: usize,
}

impl Searcher {
    /// The departures table, as `Topology::departures` gives them (the
    /// same order), and unreached labels.
    fn build(&mut self, net: &Network) {
        let n = net.nodes.len();
        self.offsets.clear();
        self.arcs.clear();
        self.offsets.reserve(n + 1);
        self.offsets.push(0);
        for node in 0..n as NodeId {
            for d in net.topology.departures(&net.model, node) {
                let s = &net.sections[d.section as usize];
                self.arcs.push(Arc {
                    len: s.length_m,
                    next: if d.forward { s.end } else { s.start },
                    code: code(d),
                });
            }
            self.offsets.push(self.arcs.len() as u32);
        }
        self.rim.clear();
        self.far.clear();
        for node in 0..n as NodeId {
            // The one other end of its sections (loops aside), all of
            // them of a length that cannot shorten a path.
            let mut other = None;
            let mut leaf = true;
            for i in net.topology.incidences(node) {
                let s = &net.sections[i.section as usize];
                let o = if s.start == node { s.end } else { s.start };
                if s.length_m.is_nan()
                    || s.length_m < 0.0
                    || other.is_some_and(|p| p != o && o != node)
                {
                    leaf = false;
                    break;
                }
                if o != node {
                    other = Some(o);
                }
            }
            let out = &self.arcs[self.offsets[node as usize] as usize..];
            let out =
                &out[..(self.offsets[node as usize + 1] - self.offsets[node as usize]) as usize];
            self.far.push(
                out.iter()
                    .map(|a| a.len)
                    .filter(|l| !l.is_nan())
                    .fold(f64::NEG_INFINITY, f64::max),
            );
            self.rim.push(if leaf && other.is_some() {
                f64::INFINITY
            } else if out.iter().any(|a| a.len.is_nan()) {
                f64::NEG_INFINITY
            } else {
                out.iter().map(|a| a.len).fold(f64::INFINITY, f64::min)
            });
        }
        self.monotone = !self.arcs.iter().any(|a| a.len < 0.0);
        self.labels.clear();
        self.labels.resize(n, UNREACHED);
    }

    /// Whether the search from `tree`'s source with `bound` (larger than
    /// the tree's) would give `tree` again, bit for bit: no departure from
    /// a reached node leads to an unreached one within `bound`.
    ///
    /// Exact when departures are no shorter than zero: the search with the
    /// larger bound settles the nodes within the tree's bound in the same
    /// (distance, node) order, making the same relaxations within that
    /// bound in the same order (the others give sums beyond it, so they
    /// neither label those nodes nor win a tie there): the same labels for
    /// the tree's nodes. Any node it reaches beyond them has a predecessor
    /// chain that leaves the tree by such a departure (its sum is the
    /// node's label, within `bound`); and such a departure's node is
    /// settled (its shortest departure is within `bound` too; a dead end's
    /// departures lead back to the node it was reached from) and labels
    /// the unreached node. Otherwise (a negative length): false.
    pub(super) fn covers(&self, net: &Network, tree: &Tree, bound: f64) -> bool {
        if !self.monotone || self.offsets.len() != net.nodes.len() + 1 {
            return false;
        }
        let (offsets, arcs) = (&self.offsets[..], &self.arcs[..]);
        let out = |u: usize| &arcs[offsets[u] as usize..offsets[u + 1] as usize];
        // A departure within `bound` to an unreached node.
        let leaves = match &tree.reached {
            Reached::Dense(v) => v.iter().enumerate().any(|(u, l)| {
                l.0.is_finite()
                    && out(u)
                        .iter()
                        .any(|a| l.0 + a.len <= bound && !v[a.next as usize].0.is_finite())
            }),
            Reached::Sparse(m) => m.iter().any(|(&u, l)| {
                out(u as usize)
                    .iter()
                    .any(|a| l.0 + a.len <= bound && !m.contains_key(&a.next))
            }),
        };
        !leaves
    }

    /// Keeps a dropped search's table for the next search, within
    /// [`CACHE_ENTRIES`] entries in all.
    pub(super) fn recycle(&mut self, r: Reached) {
        let n = r.capacity();
        if self.spare_entries + n <= CACHE_ENTRIES {
            self.spare_entries += n;
            self.spare.push(r);
        }
    }

    /// The shortest distances from `from` to every node within `bound`
    /// over permitted directed sections, with each node's predecessor and
    /// the first section taken.
    pub(super) fn search(&mut self, net: &Network, from: NodeId, bound: f64) -> Tree {
        if self.offsets.len() != net.nodes.len() + 1 {
            self.build(net);
        }
        let mut run = self.run(bound);
        run.labels[from as usize].0 = 0.0;
        run.touched.push(from);
        // The source is the heap's first pop: settled without the heap.
        run.settle::<true>(from, 0.0, NO_PRED);
        run.drain(from);
        self.finish(bound)
    }

    /// The search from `from` with `bound`, larger than `tree`'s (a tree
    /// from `from`, which it consumes), continued from where `tree`'s
    /// search stopped instead of made again: the tree's labels are final,
    /// so the larger search's settling of the tree's nodes (all before any
    /// node beyond the tree's bound, in (distance, node) order) relaxes
    /// within the tree's bound nothing that would change them, and beyond
    /// it, only the departures of nodes whose longest departure leads
    /// beyond the tree's bound: those are settled again, in that order
    /// (the source first, as the search does), before the search goes on.
    /// The same tree as [`Self::search`] with `bound`, bit for bit, when no
    /// length is negative (otherwise it is searched again).
    pub(super) fn resume(&mut self, net: &Network, from: NodeId, tree: Tree, bound: f64) -> Tree {
        if !self.monotone || self.offsets.len() != net.nodes.len() + 1 {
            self.recycle(tree.reached);
            return self.search(net, from, bound);
        }
        let old = tree.bound;
        let far = &self.far[..];
        let mut source = false;
        match tree.reached {
            Reached::Dense(mut v) => {
                // The tree's table as the labels; the labels, all
                // unreached, a spare table.
                std::mem::swap(&mut self.labels, &mut v);
                for (u, l) in self.labels.iter().enumerate() {
                    if l.0.is_finite() {
                        self.touched.push(u as NodeId);
                        if l.0 + far[u] > old {
                            if u as NodeId == from {
                                source = true;
                            } else {
                                self.heap.push(l.0, u as NodeId);
                            }
                        }
                    }
                }
                self.recycle(Reached::Dense(v));
            }
            Reached::Sparse(m) => {
                for (&u, &l) in &m {
                    self.labels[u as usize] = l;
                    self.touched.push(u);
                    if l.0 + far[u as usize] > old {
                        if u == from {
                            source = true;
                        } else {
                            self.heap.push(l.0, u);
                        }
                    }
                }
                self.recycle(Reached::Sparse(m));
            }
        }
        let mut run = self.run(bound);
        if source {
            run.settle::<true>(from, 0.0, NO_PRED);
        }
        run.drain(from);
        self.finish(bound)
    }

    /// A search's working state over the searcher's tables, with `bound`.
    #[inline(always)]
    fn run(&mut self, bound: f64) -> Run<'_> {
        Run {
            offsets: &self.offsets,
            arcs: &self.arcs,
            rim: &self.rim,
            labels: &mut self.labels,
            touched: &mut self.touched,
            heap: &mut self.heap,
            bound,
        }
    }

    /// The tree of a search that labelled `touched`, with `bound`; the
    /// labels left unreached.
    fn finish(&mut self, bound: f64) -> Tree {
        let labels = &mut self.labels[..];
        let touched = &mut self.touched;
        // Every node touched was settled (within the bound): the tree, in a
        // table of exactly its size (small searches on small networks must
        // not pay for a large table each).
        let dense = 4 * touched.len() >= labels.len();
        // A spare table of the same kind (the last one kept), else a new one.
        let spare = self
            .spare
            .iter()
            .rposition(|r| matches!(r, Reached::Dense(_)) == dense)
            .map(|k| {
                let r = self.spare.swap_remove(k);
                self.spare_entries -= r.capacity();
                r
            });
        if dense {
            // The labels are the table (unreached nodes hold what the
            // table's absent entries hold), and the spare table, all
            // unreached, the next search's labels (no copy, no reset by
            // touched node).
            let mut v = match spare {
                Some(Reached::Dense(v)) => v,
                _ => Vec::with_capacity(labels.len()),
            };
            v.clear();
            v.resize(labels.len(), UNREACHED);
            std::mem::swap(&mut self.labels, &mut v);
            touched.clear();
            return Tree {
                bound,
                reached: Reached::Dense(v),
            };
        }
        let mut m = match spare {
            Some(Reached::Sparse(mut m)) => {
                m.clear();
                m.reserve(touched.len());
                m
            }
            _ => FxHashMap::with_capacity_and_hasher(touched.len(), Default::default()),
        };
        for &n in touched.iter() {
            m.insert(n, labels[n as usize]);
            labels[n as usize] = UNREACHED;
        }
        touched.clear();
        Tree {
            bound,
            reached: Reached::Sparse(m),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::LoadOptions;
    use std::cmp::Ordering;
    use std::collections::BinaryHeap;

    /// The former search's heap item: a max-heap of reversed (distance,
    /// node) order.
    #[derive(Debug, Copy, Clone, PartialEq)]
    struct Item {
        cost: f64,
        node: NodeId,
    }
    impl Eq for Item {}
    impl Ord for Item {
        fn cmp(&self, o: &Self) -> Ordering {
            o.cost
                .total_cmp(&self.cost)
                .then_with(|| o.node.cmp(&self.node))
        }
    }
    impl PartialOrd for Item {
        fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
            Some(self.cmp(o))
        }
    }

    /// The search [`Searcher::search`] replaced (`std`'s `BinaryHeap`, the
    /// topology's departures, separate distance, predecessor and
    /// first-section arrays), as it was: the label of every node it reached.
    fn reference(net: &Network, from: NodeId, bound: f64) -> Vec<Option<Label>> {
        let n = net.nodes.len();
        let mut dist = vec![f64::INFINITY; n];
        let mut pred = vec![NO_PRED; n];
        let mut first = vec![NO_PRED; n];
        let mut heap = BinaryHeap::new();
        dist[from as usize] = 0.0;
        heap.push(Item {
            cost: 0.0,
            node: from,
        });
        while let Some(Item { cost, node }) = heap.pop() {
            if cost > dist[node as usize] {
                continue;
            }
            let f = first[node as usize];
            for d in net.topology.departures(&net.model, node) {
                let s = &net.sections[d.section as usize];
                let next = if d.forward { s.end } else { s.start };
                let c = cost + s.length_m;
                if c <= bound && c < dist[next as usize] {
                    dist[next as usize] = c;
                    pred[next as usize] = code(d);
                    first[next as usize] = if node == from { d.section } else { f };
                    heap.push(Item {
                        cost: c,
                        node: next,
                    });
                }
            }
        }
        (0..n)
            .map(|i| dist[i].is_finite().then_some((dist[i], pred[i], first[i])))
            .collect()
    }

    /// The heap's keys order as `total_cmp` orders distances, and decode.
    #[test]
    fn ordered_keys_keep_the_order_of_distances() {
        let xs = [-1e300, -2.5, -0.0, 0.0, 1e-300, 0.5, 1.0, 256.0, 1e300];
        for a in xs {
            assert_eq!(unordered(ordered(a)).to_bits(), a.to_bits());
            for b in xs {
                assert_eq!(ordered(a).cmp(&ordered(b)), a.total_cmp(&b), "{a} {b}");
            }
        }
        let mut h = KeyHeap::default();
        for (i, c) in [5.0, 1.0, 3.0, 1.0, 0.0, 7.5, 3.0].into_iter().enumerate() {
            h.push(c, 10 - i as NodeId);
        }
        let got: Vec<(f64, NodeId)> = std::iter::from_fn(|| h.pop()).collect();
        let want = [
            (0.0, 6),
            (1.0, 7),
            (1.0, 9),
            (3.0, 4),
            (3.0, 8),
            (5.0, 10),
            (7.5, 5),
        ];
        assert_eq!(got, want);
    }

    /// The trees equal the former search's bit for bit (distances,
    /// predecessors, first sections, the nodes reached) on the real maps,
    /// from every node of the small ones and a sample of Helsinki's, at
    /// several bounds, one searcher reused throughout (its tables recycled,
    /// except every third tree's: searches without a spare table too).
    #[test]
    fn trees_equal_the_former_search() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let maps = [
            "tests/data/real/fmm-network.geojson",
            "tests/data/real/issue-70.osm",
            "tests/data/real/issue-13.osm",
            "maps/helsinki.osm.pbf",
        ];
        let (mut trees, mut labels) = (0, 0);
        for m in maps {
            let net = Network::load(&root.join(m), &LoadOptions::default()).unwrap();
            let n = net.nodes.len();
            let stride = (n / 150).max(1);
            let mut s = Searcher::default();
            for from in (0..n as NodeId).step_by(stride) {
                for bound in [0.0, 256.0, 1024.0, 4096.0] {
                    let want = reference(&net, from, bound);
                    let tree = s.search(&net, from, bound);
                    assert_eq!(tree.bound.to_bits(), bound.to_bits());
                    let reached = want.iter().flatten().count();
                    let dense = 4 * reached >= n;
                    assert_eq!(matches!(tree.reached, Reached::Dense(_)), dense);
                    if !dense {
                        assert_eq!(tree.reached.len(), reached);
                    }
                    for (node, w) in want.iter().enumerate() {
                        let got = tree.reached.get(&(node as NodeId)).copied();
                        let bits = |l: Option<Label>| l.map(|(d, p, f)| (d.to_bits(), p, f));
                        assert_eq!(bits(got), bits(*w), "{m} {from} {bound} {node}");
                    }
                    labels += reached;
                    trees += 1;
                    if trees % 3 != 0 {
                        s.recycle(tree.reached);
                    }
                }
            }
        }
        assert!(trees > 600 && labels > 20_000, "{trees} {labels}");
    }

    /// Whether `tree` holds exactly `want`'s labels (bits of the
    /// distances, predecessors, first sections; the nodes reached).
    fn same(tree: &Tree, want: &[Option<Label>]) -> bool {
        let bits = |l: Option<Label>| l.map(|(d, p, f)| (d.to_bits(), p, f));
        tree.reached.len() >= want.iter().flatten().count()
            && want
                .iter()
                .enumerate()
                .all(|(node, w)| bits(tree.reached.get(&(node as NodeId)).copied()) == bits(*w))
    }

    /// [`Searcher::covers`] holds exactly when the former search with the
    /// larger bound gives the same tree (so that keeping the tree is
    /// exact, and searching again is needed otherwise), on the real maps,
    /// from every node of the small ones and a sample of Helsinki's, for
    /// every pair of bounds from 0 to 8,192 m.
    #[test]
    fn covers_iff_the_larger_search_gives_the_tree() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let maps = [
            "tests/data/real/fmm-network.geojson",
            "tests/data/real/issue-70.osm",
            "tests/data/real/issue-13.osm",
            "maps/helsinki.osm.pbf",
        ];
        let bounds = [0.0, 100.0, 256.0, 512.0, 1024.0, 2048.0, 4096.0, 8192.0];
        let (mut kept, mut searched) = (0, 0);
        for m in maps {
            let net = Network::load(&root.join(m), &LoadOptions::default()).unwrap();
            let n = net.nodes.len();
            let stride = (n / 100).max(1);
            let mut s = Searcher::default();
            for from in (0..n as NodeId).step_by(stride) {
                let want: Vec<_> = bounds.iter().map(|&b| reference(&net, from, b)).collect();
                for (i, &b) in bounds.iter().enumerate() {
                    let tree = s.search(&net, from, b);
                    assert!(same(&tree, &want[i]));
                    for (k, &larger) in bounds.iter().enumerate().skip(i + 1) {
                        let covers = s.covers(&net, &tree, larger);
                        assert_eq!(covers, same(&tree, &want[k]), "{m} {from} {b} {larger}");
                        if covers {
                            kept += 1;
                        } else {
                            searched += 1;
                        }
                    }
                    s.recycle(tree.reached);
                }
            }
        }
        assert!(kept > 500 && searched > 1000, "{kept} {searched}");
    }

    /// [`Searcher::resume`] gives the former search's tree with the larger
    /// bound, bit for bit, on the real maps, from every node of the small
    /// ones and a sample of Helsinki's, for pseudo-random pairs of bounds
    /// (zero, small, powers of two, in between), resumed again and again.
    #[test]
    fn resumed_trees_equal_the_former_search() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let maps = [
            "tests/data/real/fmm-network.geojson",
            "tests/data/real/issue-70.osm",
            "tests/data/real/issue-13.osm",
            "maps/helsinki.osm.pbf",
        ];
        let mut rng = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let mut resumed = 0;
        for m in maps {
            let net = Network::load(&root.join(m), &LoadOptions::default()).unwrap();
            let n = net.nodes.len();
            let stride = (n / 100).max(1);
            let mut s = Searcher::default();
            for from in (0..n as NodeId).step_by(stride) {
                let mut bound = match next() % 3 {
                    0 => 0.0,
                    1 => 256.0,
                    _ => (next() % 500) as f64 / 3.0,
                };
                let mut tree = s.search(&net, from, bound);
                for _ in 0..4 {
                    bound = match next() % 3 {
                        0 => bound * 2.0,
                        1 => bound + (next() % 300) as f64 * 0.7,
                        _ => bound + 1e-9,
                    };
                    tree = s.resume(&net, from, tree, bound);
                    assert_eq!(tree.bound.to_bits(), bound.to_bits());
                    let want = reference(&net, from, bound);
                    assert!(same(&tree, &want), "{m} {from} {bound}");
                    let reached = want.iter().flatten().count();
                    assert_eq!(matches!(tree.reached, Reached::Dense(_)), 4 * reached >= n);
                    resumed += 1;
                }
                s.recycle(tree.reached);
            }
        }
        assert!(resumed > 800, "{resumed}");
    }
}
