//! The walk DP as the separation oracle of a trips plan's straight walks
//! where their paths fork past [`super::straight::MAX_PATHS`].
//!
//! Where a speed class's turns give no credit (its curve distance is 0),
//! every junction continues a straight walk, so the walks from one start
//! fork without end and their enumeration stops at the paths' limit. There
//! the straight walks are any walks with at most one turn-back, and the
//! any-walk planner's exact test ([`super::cover::check_with_witnesses`],
//! a dynamic programme over node and tag passes) finds every one the tags
//! do not hold, with a witness walk just over the budget. The plan adds
//! each witness's sites as a window and solves again until the test finds
//! none (lazy constraint generation, `super::trips`).
//!
//! The DP's graph ([`WalkOracle::new`]) holds the directed roads within one
//! budget (along straight transitions, forward or backward) of a road of a
//! class without credit: every budget window of a straight walk that
//! touches such a road lies in it, walks entering from other roads
//! included, with the budget they bring. Each road is an edge from a node
//! at its start to one at its end, its length the budget it consumes
//! ([`SCALE_M`] per budget of 1, so one reach serves all classes), split
//! where the road's own bends reset: a walk ends at the first reset from a
//! start on the road scanned without history (`super::turns::walk_edge`)
//! and starts again at each reset zone's end. Junction transitions that do
//! not reset join a road's end to the next road's start (length
//! [`LINK_M`]). The graph is held twice: a turn-back
//! ([`super::traffic::turns_back`], or a flagged U-turn) leads from the
//! first copy into the second, which has none, so a walk makes at most one
//! ([`super::straight::MAX_UTURNS`]).
//!
//! Against the enumerated walks this is conservative: walks start anywhere
//! (not only on roads the chains drove), and a walk's heading history
//! before a road is ignored, so its resets there come no earlier than with
//! it (with more headings in the curve window a point resets at least as
//! often). Tag passes count with multiplicity, as along a chain
//! ([`super::traffic::chain_use`]): a walk passing one tag twice (with a
//! turn-back between) counts two passes, where a window of distinct sites
//! counts one.

use super::cover::{check_with_witnesses, CoverEdge, CoverProblem, CoverSite};
use super::straight::UTURN_FLAG;
use super::traffic::{turns_back, EdgeModel};
use super::turns::{walk_edge, TurnWindow};
use super::window_sets::{WindowMap, WindowSets};
use crate::error::Result;
use std::collections::HashSet;

/// The DP's metres per budget of 1.
pub(crate) const SCALE_M: f64 = 1000.0;

/// Length of a junction transition in the DP (its metres, positive as the
/// DP needs): a walk through 10,000 junctions gains 10⁻³ m of 1,000.
pub(crate) const LINK_M: f64 = 1e-7;

/// Most witness walks taken from one check.
pub(crate) const MAX_WITNESSES: usize = 20_000;

/// The straight walks near the roads without turn credit, as a walk DP.
pub(crate) struct WalkOracle {
    problem: CoverProblem,
    /// Per DP site, the plan's site.
    site_of: Vec<u32>,
    /// Per DP edge, metres of road per DP metre (0 for a transition).
    metres_per: Vec<f64>,
    /// Directed roads in the DP's graph.
    pub roads: usize,
    /// Of which in a class without turn credit.
    pub no_credit: usize,
}

/// Budget distances along straight transitions from (`forward`) or to the
/// roads `seed`: for each road the least budget driven between a seed road
/// and it (from the seed's end to the road's start, or from the road's end
/// to the seed's start), roads beyond `limit` left at infinity.
fn budget_distance(
    model: &EdgeModel,
    next: &[Vec<(u32, bool)>],
    seed: &[bool],
    forward: bool,
    limit: f64,
) -> Vec<f64> {
    use std::cmp::Reverse;
    let n = next.len();
    let budget = |e: usize| model.length[e] * model.rate[e];
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (a, v) in next.iter().enumerate() {
        for &(b, _) in v {
            if forward {
                adj[a].push(b);
            } else {
                adj[b as usize].push(a as u32);
            }
        }
    }
    let mut dist = vec![f64::INFINITY; n];
    let mut heap = std::collections::BinaryHeap::new();
    // Ordered by the bits of non-negative floats (they order as values).
    for e in (0..n).filter(|&e| seed[e]) {
        for &b in &adj[e] {
            if dist[b as usize] > 0.0 {
                dist[b as usize] = 0.0;
                heap.push(Reverse((0u64, b)));
            }
        }
    }
    while let Some(Reverse((d, e))) = heap.pop() {
        let d = f64::from_bits(d);
        if d > dist[e as usize] || seed[e as usize] {
            continue;
        }
        let nd = d + budget(e as usize);
        if nd >= limit {
            continue;
        }
        for &b in &adj[e as usize] {
            if nd < dist[b as usize] {
                dist[b as usize] = nd;
                heap.push(Reverse((nd.to_bits(), b)));
            }
        }
    }
    dist
}

/// The stretches of road `e` a walk drives without a reset, from its start
/// and from each of its reset zones' ends: (from m, to m, reaches the
/// road's end).
fn pieces(model: &EdgeModel, e: usize) -> Vec<(f64, f64, bool)> {
    let len = model.length[e];
    let mut starts = vec![0.0];
    if model.turn_resets[e] {
        starts.extend(model.bends[e].iter().copied().filter(|&x| x < len));
    }
    starts
        .into_iter()
        .map(|x| {
            let mut stop = None;
            walk_edge(
                &model.headings[e],
                &model.intrinsic[e],
                x,
                len + 1.0,
                0.0,
                &mut TurnWindow::default(),
                model.curve[e],
                |r| {
                    stop = Some(r);
                    true
                },
            );
            match stop {
                Some(r) if r < len => (x, r.max(x), false),
                _ => (x, len, true),
            }
        })
        .filter(|p| p.1 > p.0 || p.2)
        .collect()
}

impl WalkOracle {
    /// The DP over the straight transitions `straight` near the roads
    /// whose class gets no turn credit (`model.curve` 0) with the plan's
    /// `n_sites` sites and `k` missed reads tolerated; `None` when no road
    /// lacks credit.
    pub fn new(
        model: &EdgeModel,
        straight: &HashSet<(u32, u32)>,
        n_sites: usize,
        k: usize,
    ) -> Option<Self> {
        let n = model.dir.len();
        let seed: Vec<bool> = (0..n)
            .map(|e| model.curve[e] <= 0.0 && model.rate[e] > 0.0 && model.length[e] > 0.0)
            .collect();
        let no_credit = seed.iter().filter(|&&s| s).count();
        if no_credit == 0 {
            return None;
        }
        let mut next: Vec<Vec<(u32, bool)>> = vec![Vec::new(); n];
        let mut pairs: Vec<(u32, u32)> = straight.iter().copied().collect();
        pairs.sort_unstable();
        for (a, nx) in pairs {
            let b = nx & !UTURN_FLAG;
            let u = nx & UTURN_FLAG != 0 || turns_back(model, a as usize, b as usize);
            next[a as usize].push((b, u));
        }
        let fwd = budget_distance(model, &next, &seed, true, 1.0);
        let back = budget_distance(model, &next, &seed, false, 1.0);
        let inside: Vec<bool> = (0..n)
            .map(|e| {
                model.length[e] > 0.0
                    && model.rate[e] > 0.0
                    && (seed[e] || fwd[e] < 1.0 || back[e] < 1.0)
            })
            .collect();
        // Nodes: 0 a source (no edge enters it), then per road in the
        // graph its start and end in each copy, then a sink per piece that
        // ends at a reset.
        let mut start_node = vec![u32::MAX; n];
        let mut nodes = 1usize;
        for e in (0..n).filter(|&e| inside[e]) {
            start_node[e] = nodes as u32;
            nodes += 4;
        }
        let node = |e: usize, end: bool, copy: usize| start_node[e] + 2 * copy as u32 + end as u32;
        let mut edges = Vec::new();
        let mut metres_per = Vec::new();
        let mut sites = Vec::new();
        let mut site_of = Vec::new();
        for e in (0..n).filter(|&e| inside[e]) {
            let scale = model.rate[e] * SCALE_M;
            for (from, to, to_end) in pieces(model, e) {
                for copy in 0..2 {
                    // A walk starting at a bend starts in the first copy.
                    if from > 0.0 && copy == 1 {
                        continue;
                    }
                    let tail = if from > 0.0 { 0 } else { node(e, false, copy) };
                    let head = if to_end {
                        node(e, true, copy)
                    } else {
                        nodes += 1;
                        (nodes - 1) as u32
                    };
                    let id = edges.len() as u32;
                    let length_m = ((to - from) * scale).max(LINK_M);
                    edges.push(CoverEdge {
                        tail,
                        head,
                        length_m,
                    });
                    metres_per.push(1.0 / scale);
                    for &(at, s) in &model.sites[e] {
                        if at >= from && at <= to {
                            sites.push(CoverSite {
                                edge: id,
                                at_m: (at - from) * scale,
                                cost: 1.0,
                                existing: false,
                            });
                            site_of.push(s);
                        }
                    }
                }
            }
        }
        for a in (0..n).filter(|&e| inside[e]) {
            for &(b, u) in &next[a] {
                if !inside[b as usize] {
                    continue;
                }
                let links: &[(usize, usize)] = if u { &[(0, 1)] } else { &[(0, 0), (1, 1)] };
                for &(ca, cb) in links {
                    edges.push(CoverEdge {
                        tail: node(a, true, ca),
                        head: node(b as usize, false, cb),
                        length_m: LINK_M,
                    });
                    metres_per.push(0.0);
                }
            }
        }
        debug_assert!(site_of.iter().all(|&s| (s as usize) < n_sites));
        let problem = CoverProblem::new(nodes, edges, sites, SCALE_M, k).ok()?;
        Some(Self {
            problem,
            site_of,
            metres_per,
            roads: inside.iter().filter(|&&i| i).count(),
            no_credit,
        })
    }

    /// The walks the selection `sel` (the plan's sites) does not hold: the
    /// number of violations the DP finds, and per violation (at most
    /// [`MAX_WITNESSES`]) the window of its witness walk (just over the
    /// budget): the plan's sites on it, sorted and distinct, with the
    /// walk's length in metres of road. No violation: the tags hold every
    /// walk. (A witness the DP cannot rebuild, by rounding, gives no
    /// window, so violations may outnumber windows.)
    pub fn unheld(&self, sel: &[bool]) -> (usize, Vec<(Vec<u32>, f64)>) {
        let dp_sel: Vec<bool> = self.site_of.iter().map(|&s| sel[s as usize]).collect();
        let (res, walks) = check_with_witnesses(&self.problem, &dp_sel, MAX_WITNESSES);
        let windows = walks
            .iter()
            .map(|w| {
                let mut ids: Vec<u32> = w.sites.iter().map(|&s| self.site_of[s as usize]).collect();
                ids.sort_unstable();
                ids.dedup();
                let m = w
                    .pieces
                    .iter()
                    .map(|&(e, a, b)| (b - a) * self.metres_per[e as usize])
                    .sum();
                (ids, m)
            })
            .collect();
        (res.violations.len(), windows)
    }

    /// The selection holds every walk in the DP's graph.
    pub fn holds(&self, sel: &[bool]) -> bool {
        let dp_sel: Vec<bool> = self.site_of.iter().map(|&s| sel[s as usize]).collect();
        super::cover::check(&self.problem, &dp_sel).feasible()
    }
}

/// Most solves the oracle asks for after one solve of a trips plan: each
/// follows the windows of the walks its selection left unheld.
pub(crate) const MAX_PASSES: usize = 40;

/// Most greedy repairs between two solves, each adding tags for the
/// witnesses' windows and checked again.
pub(crate) const MAX_REPAIRS: usize = 1000;

/// What the oracle did over a trips plan (`super::trips`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct HeldWalks {
    /// Directed roads in the DP's graph.
    pub roads: usize,
    /// Of which in a class without turn credit.
    pub no_credit: usize,
    /// DP checks run (of solves' selections and of their repairs).
    pub checks: usize,
    /// Solves after the first that the oracle asked for.
    pub passes: usize,
    /// Windows added.
    pub windows: usize,
    /// Violations the last check of the reported selection found (0: the
    /// tags hold every walk in the DP's graph).
    pub violations: usize,
}

/// The lazy loop of a trips plan's solve (`super::trips`): while the DP
/// finds walks the solve's selection (`sel_of`) leaves unheld, their
/// witnesses' windows join the planning set `wmap` and `repair` (a greedy
/// keeping the selection) adds tags for them, checked again, until the DP
/// finds none; then `solve` solves all the windows again (it may drop
/// tags). Ends when a solve's selection holds every walk, a check adds no
/// window, or after [`MAX_PASSES`] solves; `held` counts what it did and
/// the violations of the last check, which is of the returned solve's
/// selection.
pub(crate) fn hold_walks<S>(
    o: &WalkOracle,
    wmap: &mut WindowMap,
    held: &mut HeldWalks,
    first: S,
    sel_of: impl Fn(&S) -> &Vec<bool>,
    repair: impl Fn(&WindowSets, &[bool]) -> Option<Vec<bool>>,
    mut solve: impl FnMut(&mut WindowMap, &S) -> Result<S>,
) -> Result<S> {
    (held.roads, held.no_credit) = (o.roads, o.no_credit);
    let mut s = first;
    for pass in 0..=MAX_PASSES {
        let (v, mut ws) = o.unheld(sel_of(&s));
        held.checks += 1;
        held.violations = v;
        if v == 0 || pass == MAX_PASSES {
            break;
        }
        let before = wmap.len();
        let mut cur = sel_of(&s).clone();
        for _ in 0..MAX_REPAIRS {
            let mut new = WindowSets::new();
            for (ids, m) in &ws {
                if let Some(w) = wmap.entry(ids) {
                    w.hard = true;
                    w.stretch_m = w.stretch_m.max(*m);
                }
                new.push(ids);
            }
            // Too few sites in a window: the solve says where.
            let Some(c) = repair(&new, &cur) else { break };
            cur = c;
            let (v, w) = o.unheld(&cur);
            held.checks += 1;
            if v == 0 || wmap.full() {
                break;
            }
            ws = w;
        }
        if wmap.len() == before {
            break;
        }
        held.passes += 1;
        held.windows += wmap.len() - before;
        s = solve(wmap, &s)?;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::super::straight::{geometric_straight, straight_windows, MAX_PATHS};
    use super::super::trips::multicover;
    use super::super::window_sets::SiteWindows;
    use super::*;
    use crate::network::{model_from_polylines, Network, Oneway, RoadAttributes, SectionId};

    /// A triangle lattice of one-way straight roads northward (as in
    /// `straight`'s tests): junction `j` of row `i` lies 100 m × `i` north
    /// and 20 m × (2`j` − `i`) east; from each junction of rows 0 to
    /// `rows` − 1 a road leads to each of the two nearest junctions of the
    /// next row.
    fn lattice(rows: usize) -> Network {
        let (la, lo) = (60.17f64, 24.94f64);
        let m_lat = 111_320.0;
        let m_lon = 111_320.0 * la.to_radians().cos();
        let at = |i: usize, j: usize| {
            let (n, e) = (100.0 * i as f64, 20.0 * (2.0 * j as f64 - i as f64));
            [la + n / m_lat, lo + e / m_lon]
        };
        let mut roads = Vec::new();
        for i in 0..rows {
            for j in 0..=i {
                for (side, to) in [("w", j), ("e", j + 1)] {
                    let attributes = RoadAttributes {
                        maxspeed_kmh: Some(20.0),
                        ..RoadAttributes::new(
                            format!("{i}/{j}{side}"),
                            "residential",
                            Oneway::Forward,
                        )
                    };
                    roads.push((attributes, vec![vec![at(i, j), at(i + 1, to)]]));
                }
            }
        }
        Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap()
    }

    /// Every direction of every section, one reach `reach_m`, no turn
    /// credit (curve distance 0: every junction continues a straight
    /// walk), a candidate site every `spacing_m` on the roads leaving rows
    /// `first_row` and up.
    fn no_credit_model(net: &Network, reach_m: f64, spacing_m: f64, first_row: usize) -> EdgeModel {
        let dir: Vec<(SectionId, bool)> = (0..net.sections.len() as SectionId)
            .map(|s| (s, true))
            .collect();
        let n = dir.len();
        let mut id = 0u32;
        let sites = dir
            .iter()
            .map(|&(sec, _)| {
                let len = net.sections[sec as usize].length_m;
                let name = &net.roads[net.sections[sec as usize].road as usize]
                    .attributes
                    .id;
                let row: usize = name.split('/').next().unwrap().parse().unwrap();
                let k = if row >= first_row {
                    (len / spacing_m).ceil() as usize
                } else {
                    0
                };
                (0..k)
                    .map(|i| {
                        id += 1;
                        ((i as f64 + 0.5) * len / k as f64, id - 1)
                    })
                    .collect()
            })
            .collect();
        EdgeModel::new(
            net,
            dir,
            vec![5.6; n],
            vec![1.0 / reach_m; n],
            sites,
            vec![0.0; n],
            (0.0, 0.0),
        )
    }

    /// Every straight walk of the lattice (no turn-back: one-way roads)
    /// from the start and every site of the roads `from`, followed without a limit
    /// until its budget reaches 1: the windows (sites, distinct) that
    /// `sel` leaves with fewer than `demand` tags.
    fn unheld_by_enumeration(
        model: &EdgeModel,
        straight: &HashSet<(u32, u32)>,
        from: &[bool],
        sel: &[bool],
        demand: usize,
    ) -> usize {
        let n = model.dir.len();
        let mut next: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &(a, b) in straight {
            next[a as usize].push(b & !UTURN_FLAG);
        }
        let mut bad = 0;
        for e in (0..n).filter(|&e| from[e]) {
            let mut starts = vec![(0.0, true)];
            starts.extend(model.sites[e].iter().map(|s| (s.0, false)));
            for (x0, inclusive) in starts {
                // (edge, from m, budget metres left, tags passed)
                let mut stack = vec![(e, x0, 1.0 / model.rate[e], 0usize, true)];
                while let Some((ed, x, left, tags, first)) = stack.pop() {
                    let len = model.length[ed];
                    let end = (x + left).min(len);
                    let mut t = tags;
                    for &(at, s) in &model.sites[ed] {
                        let after = if first && !inclusive { at > x } else { at >= x };
                        if after && at <= end && sel[s as usize] {
                            t += 1;
                        }
                    }
                    if x + left <= len {
                        bad += usize::from(t < demand);
                        continue;
                    }
                    for &b in &next[ed] {
                        stack.push((b as usize, 0.0, left - (len - x), t, false));
                    }
                }
            }
        }
        bad
    }

    #[test]
    fn the_walk_dp_finds_the_walks_a_capped_enumeration_misses_and_the_lazy_loop_holds_them_all() {
        // The one-way lattice of 17 rows 100 m apart with a 1 km reach and
        // no turn credit: a walk from rows 0–6 forks at every junction and
        // reaches its budget 10 rows on, after 2^9 = 512 > MAX_PATHS paths.
        // A site every 50 m from row 4 on (so that no tag on the first
        // roads holds every path at once), one missed read tolerated. The
        // straight walks start on the roads leaving row 0 (those the
        // chains drove): their paths from one start that are followed all
        // leave it on one side, and the extreme path on the other side
        // shares no road with them.
        let (rows, k) = (17, 1);
        let demand = k + 1;
        let net = lattice(rows);
        let model = no_credit_model(&net, 1000.0, 50.0, 4);
        let n_sites = model.sites.iter().map(Vec::len).sum::<usize>();
        let straight = geometric_straight(&net, &model);
        let row_of = |e: usize| -> usize {
            let sec = &net.sections[model.dir[e].0 as usize];
            let id = &net.roads[sec.road as usize].attributes.id;
            id.split('/').next().unwrap().parse().unwrap()
        };
        let used: Vec<bool> = (0..model.dir.len()).map(|e| row_of(e) == 0).collect();
        let all = vec![true; model.dir.len()];
        let mut wmap = WindowMap::new(usize::MAX);
        let stats = straight_windows(&model, &straight, &used, &mut wmap);
        assert!(stats.forked > 0, "{stats:?}");
        let pre = vec![false; n_sites];
        let cost = vec![1.0; n_sites];
        let solve = |wmap: &mut WindowMap| -> Vec<bool> {
            let (ws, _) = wmap.sorted();
            let site_w = SiteWindows::of(ws, n_sites);
            multicover(ws, &site_w, demand, &cost, &pre).expect("enough sites")
        };
        let mut sel = solve(&mut wmap);
        assert!(wmap.sorted().0.covered_by(&sel, demand));
        // The paths past MAX_PATHS were not followed: walks from row 0 the
        // selection leaves unheld, which the unlimited enumeration finds
        // and the DP too (it checks walks from anywhere).
        let o = WalkOracle::new(&model, &straight, n_sites, k).expect("no credit anywhere");
        assert_eq!(o.no_credit, model.dir.len());
        assert_eq!(o.roads, model.dir.len());
        let (v, ws) = o.unheld(&sel);
        let missed = unheld_by_enumeration(&model, &straight, &used, &sel, demand);
        assert!(
            v > 0 && !ws.is_empty(),
            "{v} violations, {missed} by enumeration"
        );
        assert!(
            missed > 0,
            "the capped windows' cover holds every walk: no test"
        );
        for (ids, m) in &ws {
            let tags = ids.iter().filter(|&&s| sel[s as usize]).count();
            assert!(tags < demand, "a witness the selection holds: {ids:?}");
            assert!((1000.0..1001.0).contains(m), "witness of {m} m");
        }
        // The lazy loop of the plans (`hold_walks`): the witnesses' windows,
        // greedy repairs, a solve, until a solve's selection holds them all.
        let mut held = HeldWalks::default();
        let windows_before = wmap.len();
        let repair = |new: &WindowSets, cur: &[bool]| {
            let site_w = SiteWindows::of(new, n_sites);
            multicover(new, &site_w, demand, &cost, cur).ok()
        };
        let first = sel.clone();
        sel = hold_walks(
            &o,
            &mut wmap,
            &mut held,
            first,
            |s: &Vec<bool>| s,
            repair,
            |w: &mut WindowMap, _: &Vec<bool>| Ok(solve(w)),
        )
        .expect("no limit");
        assert_eq!(held.violations, 0, "{held:?}");
        assert!(held.passes >= 1 && held.passes < MAX_PASSES, "{held:?}");
        assert_eq!(held.windows, wmap.len() - windows_before, "{held:?}");
        assert!(wmap.sorted().0.covered_by(&sel, demand));
        assert!(o.holds(&sel));
        assert_eq!(
            unheld_by_enumeration(&model, &straight, &all, &sel, demand),
            0,
            "the DP holds every walk but an unlimited enumeration finds one unheld"
        );
        const { assert!(MAX_PATHS < 512) };
    }
}
