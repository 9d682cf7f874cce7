//! The budget windows of a `traffic = "trips"` plan, stored flat.
//!
//! A plan on a whole map holds millions of windows of tens of site ids
//! each (Liechtenstein without map matching: 9.7 M windows). Kept as one
//! `Vec<u32>` per window, each window paid a heap allocation, its header
//! and the growth slack of the vector it was collected into, and the
//! solver's per-site index repeated that; [`WindowSets`] holds every
//! window's ids in one list with an offset per window (compressed sparse
//! rows), and [`SiteWindows`] is the same layout for the windows of each
//! site. Both keep the order in which windows are pushed, so a solver
//! reading them visits windows and sites exactly as it did with nested
//! vectors.

/// Windows of sorted site ids, one after another: window `i` is
/// `sites[start[i]..start[i + 1]]`.
///
/// ```
/// use waymark::planner::network::WindowSets;
/// let w = WindowSets::from_vecs(&[vec![0, 2], vec![], vec![1, 2, 3]]);
/// assert_eq!(w.len(), 3);
/// assert_eq!(w.get(2), &[1, 2, 3]);
/// assert!(w.get(1).is_empty());
/// assert_eq!(w.iter().map(|s| s.len()).sum::<usize>(), 5);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WindowSets {
    sites: Vec<u32>,
    start: Vec<usize>,
}

impl Default for WindowSets {
    fn default() -> Self {
        Self::new()
    }
}

impl WindowSets {
    /// No windows.
    pub fn new() -> Self {
        Self {
            sites: Vec::new(),
            start: vec![0],
        }
    }

    /// No windows, with room for `windows` windows holding `ids` ids in all.
    pub fn with_capacity(windows: usize, ids: usize) -> Self {
        let mut start = Vec::with_capacity(windows + 1);
        start.push(0);
        Self {
            sites: Vec::with_capacity(ids),
            start,
        }
    }

    /// The windows of nested vectors, in their order.
    pub fn from_vecs(windows: &[Vec<u32>]) -> Self {
        let ids = windows.iter().map(Vec::len).sum();
        let mut w = Self::with_capacity(windows.len(), ids);
        for ids in windows {
            w.push(ids);
        }
        w
    }

    /// Appends a window.
    pub fn push(&mut self, ids: &[u32]) {
        self.sites.extend_from_slice(ids);
        self.start.push(self.sites.len());
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// No window at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Site ids over all windows (with repeats).
    pub fn total_ids(&self) -> usize {
        self.sites.len()
    }

    /// Window `i`'s site ids. Panics if `i >= len()`.
    pub fn get(&self, i: usize) -> &[u32] {
        &self.sites[self.start[i]..self.start[i + 1]]
    }

    /// Every window holds at least `demand` sites of the selection `sel`
    /// (one flag per site; a site a window holds twice counts twice).
    pub fn covered_by(&self, sel: &[bool], demand: usize) -> bool {
        self.iter().all(|ids| holds(ids, sel, demand))
    }

    /// The windows holding `demand` sites of `sel`, in order.
    pub fn held_by(&self, sel: &[bool], demand: usize) -> WindowSets {
        let mut h = WindowSets::new();
        for ids in self.iter().filter(|ids| holds(ids, sel, demand)) {
            h.push(ids);
        }
        h
    }

    /// Per window, the selected sites it still lacks once the installed
    /// sites `preselected` count (`demand` less their number, at least 0).
    pub fn residual_demand(&self, demand: usize, preselected: &[bool]) -> Vec<f64> {
        self.iter()
            .map(|ids| {
                let have = ids.iter().filter(|&&s| preselected[s as usize]).count();
                demand.saturating_sub(have) as f64
            })
            .collect()
    }

    /// The windows in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.start.windows(2).map(|r| &self.sites[r[0]..r[1]])
    }
}

/// For each site, the windows holding it, in increasing window order (the
/// transpose of a [`WindowSets`]).
pub(crate) struct SiteWindows {
    windows: Vec<u32>,
    start: Vec<usize>,
}

impl SiteWindows {
    /// The transpose of `w` over `n_sites` sites (every id below `n_sites`).
    pub fn of(w: &WindowSets, n_sites: usize) -> Self {
        let mut start = vec![0usize; n_sites + 1];
        for &s in &w.sites {
            start[s as usize + 1] += 1;
        }
        for i in 0..n_sites {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut windows = vec![0u32; w.sites.len()];
        for (i, ids) in w.iter().enumerate() {
            for &s in ids {
                let f = &mut fill[s as usize];
                windows[*f] = i as u32;
                *f += 1;
            }
        }
        Self { windows, start }
    }

    /// The windows holding site `s`.
    pub fn get(&self, s: usize) -> &[u32] {
        &self.windows[self.start[s]..self.start[s + 1]]
    }

    /// Redundancy removal: in `order`, drops each selected site whose
    /// windows all keep at least `demand` selected sites without it
    /// (`count`, kept up to date, counts a site as often as a window holds
    /// it). A window may hold a site `m` times (a walk passing it again):
    /// dropping the site takes `m` from its count, so the window needs
    /// `count ≥ demand + m`; for windows of distinct sites this is
    /// `count > demand`. The site's windows come in increasing order, so a
    /// window held `m` times is a run of `m` equal entries.
    pub fn remove_redundant(
        &self,
        order: impl IntoIterator<Item = usize>,
        sel: &mut [bool],
        count: &mut [usize],
        demand: usize,
    ) {
        for s in order {
            let spare = |run: &[u32]| count[run[0] as usize] >= demand + run.len();
            if sel[s] && self.get(s).chunk_by(|a, b| a == b).all(spare) {
                sel[s] = false;
                for &w in self.get(s) {
                    count[w as usize] -= 1;
                }
            }
        }
    }
}

/// Window `ids` holds `demand` sites of `sel`.
fn holds(ids: &[u32], sel: &[bool], demand: usize) -> bool {
    ids.iter().filter(|&&s| sel[s as usize]).count() >= demand
}

/// A window of budget 1 that must hold `k + 1` tags.
#[derive(Debug, Clone, Default)]
pub(crate) struct WindowInfo {
    /// Length of the stretch it lies in (m).
    pub stretch_m: f64,
    /// The stretch starts at a chain's start (the prior).
    pub at_start: bool,
    /// The stretch starts before its chain's calibration point (budgeted at
    /// the early reach when the plan has two levels).
    pub early: bool,
    /// Some source other than a chain beginning's early stretches asks for
    /// it (a planning chain, a certification round's violator, a straight
    /// walk): a plan that leaves sampled beginnings uncovered
    /// (`super::discard`) must still hold it.
    pub hard: bool,
}

/// The distinct windows of a plan, each with the longest stretch it lies
/// in, and a limit on their site ids: a plan whose windows would pass it
/// stops adding them (then [`WindowMap::full`]) instead of running out of
/// memory.
///
/// The windows are held once, in a [`WindowSets`]; a hash table of their
/// indices finds a window already held. (A `HashMap` keyed by each
/// window's own vector, copied for the cover, cost a heap block, a key and
/// growth slack per window and the ids three to four times over: the
/// Liechtenstein plan without map matching peaked at 13.85 GB, now at
/// 5.7 GB; BENCHMARKS.md, "Trips plans on a whole map".)
pub(crate) struct WindowMap {
    sets: WindowSets,
    infos: Vec<WindowInfo>,
    table: hashbrown::HashTable<u32>,
    max_ids: usize,
    full: bool,
}

/// The hash of a window's ids (deterministic; only for finding windows).
fn hash_ids(ids: &[u32]) -> u64 {
    use std::hash::{BuildHasher, BuildHasherDefault};
    BuildHasherDefault::<rustc_hash::FxHasher>::default().hash_one(ids)
}

impl WindowMap {
    /// No windows; at most `max_ids` site ids over all windows (at most
    /// `u32::MAX - 1`: each window but the empty one holds an id, and
    /// windows are numbered by `u32`).
    pub fn new(max_ids: usize) -> Self {
        Self {
            sets: WindowSets::new(),
            infos: Vec::new(),
            table: hashbrown::HashTable::new(),
            max_ids: max_ids.min(u32::MAX as usize - 1),
            full: false,
        }
    }

    /// The entry of window `ids` (sorted, distinct), added when new; `None`
    /// when a new window would pass the limit (the map is then full).
    pub fn entry(&mut self, ids: &[u32]) -> Option<&mut WindowInfo> {
        let h = hash_ids(ids);
        let Self {
            sets, infos, table, ..
        } = self;
        if let Some(&i) = table.find(h, |&i| sets.get(i as usize) == ids) {
            return Some(&mut infos[i as usize]);
        }
        if self.full || sets.total_ids() + ids.len() > self.max_ids {
            self.full = true;
            return None;
        }
        let i = sets.len();
        sets.push(ids);
        infos.push(WindowInfo::default());
        table.insert_unique(h, i as u32, |&j| hash_ids(sets.get(j as usize)));
        Some(&mut infos[i])
    }

    /// Some window was refused by the limit.
    pub fn full(&self) -> bool {
        self.full
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.sets.len()
    }

    /// Puts the windows in the order of their ids (lexicographic, so the
    /// order does not depend on the order they were found in) and returns
    /// them with their stretches. The table is renumbered in place (a
    /// window's hash is its ids'), so it keeps finding them.
    pub fn sorted(&mut self) -> (&WindowSets, &[WindowInfo]) {
        let sets = &self.sets;
        let n = sets.len();
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_by(|&a, &b| sets.get(a as usize).cmp(sets.get(b as usize)));
        if order.iter().enumerate().any(|(r, &i)| r != i as usize) {
            let mut s = WindowSets::with_capacity(n, sets.total_ids());
            for &i in &order {
                s.push(sets.get(i as usize));
            }
            let infos: Vec<WindowInfo> = order
                .iter()
                .map(|&i| self.infos[i as usize].clone())
                .collect();
            let mut rank = vec![0u32; n];
            for (r, &i) in order.iter().enumerate() {
                rank[i as usize] = r as u32;
            }
            drop(order);
            self.sets = s;
            self.infos = infos;
            for i in self.table.iter_mut() {
                *i = rank[*i as usize];
            }
        }
        (&self.sets, &self.infos)
    }

    /// The windows in the order of their ids, with their stretches (the
    /// table dropped).
    pub fn into_sorted(mut self) -> (WindowSets, Vec<WindowInfo>) {
        self.sorted();
        (self.sets, self.infos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn the_window_map_keeps_each_distinct_window_once_in_sorted_order() {
        use std::collections::BTreeMap;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for case in 0..50 {
            // The reference: a sorted map of the windows, the longest stretch kept.
            let mut reference: BTreeMap<Vec<u32>, f64> = BTreeMap::new();
            let mut m = WindowMap::new(usize::MAX);
            for round in 0..3 {
                for _ in 0..rng.random_range(0..60) {
                    let mut v: Vec<u32> = (0..rng.random_range(0..5))
                        .map(|_| rng.random_range(0..12u32))
                        .collect();
                    v.sort_unstable();
                    v.dedup();
                    let x = rng.random_range(0.0..100.0);
                    let r = reference.entry(v.clone()).or_insert(0.0);
                    *r = r.max(x);
                    let e = m.entry(&v).unwrap();
                    e.stretch_m = e.stretch_m.max(x);
                }
                // Sorting between rounds must not lose the table's windows.
                let (sets, infos) = m.sorted();
                let got: Vec<(Vec<u32>, f64)> = sets
                    .iter()
                    .zip(infos)
                    .map(|(s, i)| (s.to_vec(), i.stretch_m))
                    .collect();
                let want: Vec<(Vec<u32>, f64)> =
                    reference.iter().map(|(k, v)| (k.clone(), *v)).collect();
                assert_eq!(got, want, "case {case}, round {round}");
                let ids = m.sorted().0.total_ids();
                assert_eq!(ids, reference.keys().map(Vec::len).sum::<usize>());
            }
        }
    }

    #[test]
    fn a_full_window_map_refuses_new_windows_and_keeps_finding_old_ones() {
        let mut m = WindowMap::new(5);
        assert!(m.entry(&[1, 2, 3]).is_some());
        assert!(m.entry(&[4, 5]).is_some());
        assert!(!m.full());
        assert!(m.entry(&[6]).is_none(), "a sixth id passes the limit");
        assert!(m.full());
        assert!(
            m.entry(&[1, 2, 3]).is_some(),
            "a window held is still found"
        );
        assert_eq!((m.len(), m.sorted().0.total_ids()), (2, 5));
    }

    #[test]
    fn flat_windows_and_their_transpose_equal_the_nested_vectors() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..200 {
            let n_sites = rng.random_range(1..40usize);
            let nested: Vec<Vec<u32>> = (0..rng.random_range(0..30))
                .map(|_| {
                    let mut v: Vec<u32> = (0..rng.random_range(0..8))
                        .map(|_| rng.random_range(0..n_sites as u32))
                        .collect();
                    v.sort_unstable();
                    v.dedup();
                    v
                })
                .collect();
            let flat = WindowSets::from_vecs(&nested);
            assert_eq!(flat.len(), nested.len());
            assert_eq!(flat.is_empty(), nested.is_empty());
            let back: Vec<Vec<u32>> = flat.iter().map(<[u32]>::to_vec).collect();
            assert_eq!(back, nested);
            for (i, v) in nested.iter().enumerate() {
                assert_eq!(flat.get(i), &v[..]);
            }
            // The transpose: the nested per-site lists built by pushing.
            let mut per_site: Vec<Vec<u32>> = vec![Vec::new(); n_sites];
            for (i, v) in nested.iter().enumerate() {
                for &s in v {
                    per_site[s as usize].push(i as u32);
                }
            }
            let t = SiteWindows::of(&flat, n_sites);
            for (s, v) in per_site.iter().enumerate() {
                assert_eq!(t.get(s), &v[..]);
            }
        }
    }
}
