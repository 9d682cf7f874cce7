//! The straight walks of `traffic = "trips"`: every walk through junction
//! transitions that do not reset the along-road error (at most
//! [`MAX_UTURNS`] turn-backs per stretch), beside the sampled chains
//! ([`super::traffic`]). They give the planner its windows
//! ([`straight_windows`]) and the coverage map the budgets they consume
//! ([`walk_budgets`]).

use super::traffic::{resets, turn_deg, turns_back, EdgeModel};
use super::turns::{walk_edge, TurnWindow};
use super::window_sets::WindowMap;
use crate::network::Network;

/// Marks a junction U-turn transition in the straight set (the edge index
/// never reaches it: checked at build).
pub(crate) const UTURN_FLAG: u32 = 1 << 31;

/// Most junction turn-backs ([`turns_back`]: U-turns, and hairpins onto
/// another road) in one stretch: a trip end with the next destination
/// behind makes one; two in a row on the same straight run
/// happen in long shifts but are left to the certification rounds (two per
/// stretch cost Monaco 350 tags instead of 272 without changing its rounds).
pub const MAX_UTURNS: u8 = 1;

/// Most paths followed from one window start (a guard against forks).
pub(crate) const MAX_PATHS: usize = 256;

/// Most steps (an edge entered) from one window start. Walks that end at a
/// bend close no window and so do not count towards [`MAX_PATHS`]; where
/// the reach is long (a loose requirement) or the budget does not grow
/// (rate 0), such walks fork without end and, round a ring of straight
/// transitions, never end at all. Windows a truncated start misses are
/// left to the certification rounds, as for [`MAX_PATHS`].
pub(crate) const MAX_STEPS: usize = 1 << 16;

/// The first reset on directed edge `ei` at or after `x` (m), for a walk
/// with heading history `win` that has driven `c` m since its start: the
/// end of the first resetting zone ([`walk_edge`]), or `None`.
fn first_reset(model: &EdgeModel, ei: usize, x: f64, c: f64, win: &mut TurnWindow) -> Option<f64> {
    let mut bend = None;
    walk_edge(
        &model.headings[ei],
        &model.intrinsic[ei],
        x,
        model.length[ei] + 1.0,
        c,
        win,
        model.curve[ei],
        |r| {
            bend = Some(r);
            true
        },
    );
    bend
}

/// The walk's continuations from the end of edge `ei` through the
/// non-resetting transitions `next` (flagged U-turns included): (edge,
/// whether it turns back, the heading history to carry). A turn-back
/// ([`turns_back`]) clears the history and is skipped once `turned` has
/// reached [`MAX_UTURNS`].
fn continuations<'a>(
    model: &'a EdgeModel,
    next: &'a [u32],
    ei: usize,
    turned: u8,
    win: &'a TurnWindow,
) -> impl Iterator<Item = (u32, bool, TurnWindow)> + 'a {
    next.iter().filter_map(move |&nx| {
        let to = nx & !UTURN_FLAG;
        let is_u = nx & UTURN_FLAG != 0 || turns_back(model, ei, to as usize);
        if is_u && turned >= MAX_UTURNS {
            return None;
        }
        let mut w = win.clone();
        if is_u {
            w.clear();
        }
        Some((to, is_u, w))
    })
}

/// The transitions `straight` from each of the `n` directed edges, in
/// order (flagged U-turns last): walks take them in this order whatever
/// the set's, and a U-turn (or hairpin) at a junction a chain made counts
/// as one everywhere (`continuations`).
fn successors(n: usize, straight: &std::collections::HashSet<(u32, u32)>) -> Vec<Vec<u32>> {
    let mut next: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(a, b) in straight {
        next[a as usize].push(b);
    }
    for v in &mut next {
        v.sort_unstable();
    }
    next
}

/// What [`straight_windows`] or [`walk_budgets`] did. Where walks stopped
/// at a limit, the windows (or budgets) of the walks not followed are
/// missing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct WalkStats {
    /// Window starts walked from.
    pub starts: usize,
    /// Starts whose walks were cut at [`MAX_STEPS`] edges entered.
    pub cut: usize,
    /// Starts whose walks stopped forking at [`MAX_PATHS`] paths (the
    /// windows of the paths not followed are missing).
    pub forked: usize,
    /// Most edges entered from one start.
    pub most_steps: usize,
}

impl WalkStats {
    /// The counts of two sets of starts together.
    fn merge(self, o: Self) -> Self {
        Self {
            starts: self.starts + o.starts,
            cut: self.cut + o.cut,
            forked: self.forked + o.forked,
            most_steps: self.most_steps.max(o.most_steps),
        }
    }
}

/// A straight walk's state at an edge.
struct Step {
    edge: u32,
    /// Position along the edge (m).
    x: f64,
    /// Budget used so far.
    u: f64,
    /// Sites passed.
    ids: Vec<u32>,
    /// Junction U-turns made.
    turned: u8,
    /// The walk's headings of the last `CURVE_M`.
    win: TurnWindow,
    /// The walk's chainage at `x` (m).
    c: f64,
}

/// Windows of every straight walk the traffic makes possible: from each
/// edge start and each candidate site of the edges `used`, forward along
/// the junction transitions without a reset in `straight`, stopping at
/// bends that reset; each walk reaching a budget of 1 gives the window of
/// the sites it passes within it. A stretch that traffic enters at any of
/// its junctions (or starts on) is then covered even where no sampled chain
/// drove exactly that combination. At most [`MAX_STEPS`] edges are entered
/// and [`MAX_PATHS`] paths followed from one start; the starts cut at
/// either limit are counted.
pub(crate) fn straight_windows(
    model: &EdgeModel,
    straight: &std::collections::HashSet<(u32, u32)>,
    used: &[bool],
    out: &mut WindowMap,
) -> WalkStats {
    straight_windows_within(model, straight, used, out, MAX_STEPS)
}

/// [`straight_windows`] with at most `max_steps` edges entered per start.
fn straight_windows_within(
    model: &EdgeModel,
    straight: &std::collections::HashSet<(u32, u32)>,
    used: &[bool],
    out: &mut WindowMap,
    max_steps: usize,
) -> WalkStats {
    let mut stats = WalkStats::default();
    let n = model.dir.len();
    let next = successors(n, straight);
    for (e, _) in used.iter().enumerate().filter(|x| *x.1) {
        if out.full() {
            return stats;
        }
        let mut starts: Vec<(f64, bool)> = vec![(0.0, true)];
        starts.extend(model.sites[e].iter().map(|s| (s.0, false)));
        starts.extend(
            model.bends[e]
                .iter()
                .filter(|_| model.turn_resets[e])
                .map(|&x| (x, true)),
        );
        for (x0, inclusive) in starts {
            let mut paths = 0usize;
            let mut steps = 0usize;
            let mut forked = false;
            // Stack of (edge, position along it, budget so far, sites so far,
            // a U-turn made, the headings of the last CURVE_M, chainage).
            let mut stack: Vec<Step> = vec![Step {
                edge: e as u32,
                x: x0,
                u: 0.0,
                ids: Vec::new(),
                turned: 0,
                win: TurnWindow::default(),
                c: 0.0,
            }];
            stats.starts += 1;
            while let Some(st) = stack.pop() {
                if steps == max_steps {
                    stats.cut += 1;
                    break;
                }
                steps += 1;
                let Step {
                    edge: ed,
                    x,
                    u,
                    mut ids,
                    turned,
                    mut win,
                    c,
                } = st;
                let ei = ed as usize;
                let rate = model.rate[ei];
                let len = model.length[ei];
                // The first reset on this edge from x, with the walk's history.
                let bend = first_reset(model, ei, x, c, &mut win);
                let stop = bend.unwrap_or(len);
                // Where the budget reaches 1 on this edge, if it does.
                let reach_at = if rate > 0.0 {
                    x + (1.0 - u) / rate
                } else {
                    f64::INFINITY
                };
                let end = reach_at.min(stop);
                for &(at, site) in &model.sites[ei] {
                    let first = ed as usize == e && x == x0;
                    let after = if first && !inclusive { at > x } else { at >= x };
                    if after && at <= end {
                        ids.push(site);
                    }
                }
                if reach_at <= stop {
                    ids.sort_unstable();
                    ids.dedup();
                    let m = if rate > 0.0 { 1.0 / rate } else { 0.0 };
                    if let Some(w) = out.entry(&ids) {
                        if w.stretch_m < m {
                            w.stretch_m = m;
                        }
                        w.hard = true;
                    }
                    paths += 1;
                    continue;
                }
                if bend.is_some() {
                    continue; // a bend resets: no window from this start here
                }
                for (to, is_u, w) in continuations(model, &next[ei], ei, turned, &win) {
                    if paths + stack.len() >= MAX_PATHS {
                        forked = true;
                        break;
                    }
                    stack.push(Step {
                        edge: to,
                        x: 0.0,
                        u: u + (len - x) * rate,
                        ids: ids.clone(),
                        turned: turned + u8::from(is_u),
                        win: w,
                        c: c + len - x,
                    });
                }
            }
            stats.most_steps = stats.most_steps.max(steps);
            stats.forked += usize::from(forked);
        }
    }
    stats
}

/// Every junction transition that does not reset (map matching on): onto
/// a road continuing within [`TURN_DEG`] of straight on (or sharper than
/// 180° − [`TURN_DEG`]), or onto an edge whose speed class gets no reset
/// from turns; a U-turn onto the same road only where it ends (a dead end,
/// where trips turn back). Walks count every turn-back ([`turns_back`],
/// flagged or not) towards [`MAX_UTURNS`].
pub(crate) fn geometric_straight(
    net: &Network,
    model: &EdgeModel,
) -> std::collections::HashSet<(u32, u32)> {
    let mut out = std::collections::HashSet::new();
    for (e, &(sec, fwd)) in model.dir.iter().enumerate() {
        let s = &net.sections[sec as usize];
        let v = if fwd { s.end } else { s.start };
        let dead_end = net.topology.degree(v) <= 1;
        for d in net.topology.departures(&net.model, v) {
            let Some(&e2) = model.index.get(&(d.section, d.forward)) else {
                continue;
            };
            if d.section == sec && !dead_end {
                // A U-turn at a junction: trips make it right after a trip end
                // when the next destination lies behind (the route planner's
                // shortest path); at most one per stretch (see
                // `straight_windows`).
                out.insert((e as u32, e2 | UTURN_FLAG));
                continue;
            }
            let turn = turn_deg(model.end_heading[e], model.start_heading[e2 as usize]);
            if !(model.turn_resets[e2 as usize] && resets(turn)) {
                out.insert((e as u32, e2));
            }
        }
    }
    out
}

/// Budget at which a coverage walk ([`walk_budgets`]) stops: past the
/// requirement's 1 with room to show by how much, and the forks it
/// follows stay bounded.
pub const WALK_BUDGET_CAP: f64 = 1.5;

/// A coverage walk's state at an edge, shared by the walks from its start
/// that reached it ([`walk_from`]).
struct Reach {
    edge: u32,
    /// Position along the edge (m).
    x: f64,
    /// Budget used so far.
    u: f64,
    /// Junction turn-backs made.
    turned: u8,
    /// The walk's headings of the last `CURVE_M`.
    win: TurnWindow,
    /// The walk's chainage at `x` (m).
    c: f64,
    /// The walks at this state: bit 0 the walk without the tags, bit 1
    /// the walk with them.
    walks: u8,
}

/// Per directed edge, the largest budget the straight walks consume there
/// (for the coverage map), without the tags and with the sites `read`
/// (`read[site]`): the walks of [`straight_windows`], from each start of
/// the edges `used` (an edge's start and its resetting bends) and, with
/// the tags, from every site read (on any edge: the tags lie on the walks
/// of the windows they cover) along the transitions `straight`, each
/// stopping at a bend that resets, at a site read (with the tags: the
/// budget since the last read is the one with the tags), or on the edge
/// where its budget reaches `cap` (its value at that edge's end is kept,
/// so budgets above `cap` are walks' true budgets but not always their
/// largest). Walks follow the same limits as the windows' (at most
/// [`MAX_UTURNS`] turn-backs per stretch, [`MAX_PATHS`] walks and
/// [`MAX_STEPS`] edges entered per start, counted for each of the two
/// walks). Starts run in parallel; the result does not depend on their
/// order. Edges no walk enters get 0. Returns (without, with, the walks'
/// stats: starts stopped at a limit have budgets that may be understated;
/// a start counts once for its two walks).
pub(crate) fn walk_budgets(
    model: &EdgeModel,
    straight: &std::collections::HashSet<(u32, u32)>,
    used: &[bool],
    read: &[bool],
    cap: f64,
) -> (Vec<f64>, Vec<f64>, WalkStats) {
    use rayon::prelude::*;
    use std::sync::atomic::AtomicU64;
    let n = model.dir.len();
    let next = successors(n, straight);
    let is_read = |site: u32| read[site as usize];
    let used = |e: usize| used.get(e) == Some(&true);
    let edges: Vec<usize> = (0..n)
        .filter(|&e| used(e) || model.sites[e].iter().any(|s| is_read(s.1)))
        .collect();
    // One array per walk for all threads, the budgets' bits (`keep_max`):
    // an array per thread or block of starts left the allocator holding
    // freed arrays (peak memory, BENCHMARKS.md).
    let out: [Vec<AtomicU64>; 2] =
        std::array::from_fn(|_| (0..n).map(|_| AtomicU64::new(0)).collect());
    let stats = edges
        .par_iter()
        .map(|&e| {
            let mut stats = WalkStats::default();
            if used(e) {
                stats = stats.merge(walk_from(model, &next, e, 0.0, false, &is_read, cap, &out));
                if model.turn_resets[e] {
                    for &x in &model.bends[e] {
                        let one = walk_from(model, &next, e, x, false, &is_read, cap, &out);
                        stats = stats.merge(one);
                    }
                }
            }
            for s in model.sites[e].iter().filter(|s| is_read(s.1)) {
                stats = stats.merge(walk_from(model, &next, e, s.0, true, &is_read, cap, &out));
            }
            stats
        })
        .reduce(WalkStats::default, WalkStats::merge);
    let [without, with] = out.map(|v| {
        v.into_iter()
            .map(|a| f64::from_bits(a.into_inner()))
            .collect()
    });
    (without, with, stats)
}

/// Raises `slot` to budget `u`: the bits of non-negative floats order as
/// their values, so the largest stays whatever the order of the updates
/// (what `f64::max` from 0 keeps; NaN and budgets ≤ 0 change nothing).
fn keep_max(slot: &std::sync::atomic::AtomicU64, u: f64) {
    if u > 0.0 {
        slot.fetch_max(u.to_bits(), std::sync::atomic::Ordering::Relaxed);
    }
}

/// The coverage walks from one start ([`walk_budgets`]): the walk without
/// the tags (not from a site read, `at_read`) and the one with them,
/// followed together while they share their states. Up to its first read
/// the walk with the tags is the walk without them; each keeps its own
/// counts for the limits, and a state is followed for the walks that
/// reached it (the order of the states is each walk's alone). Returns the
/// start's stats: cut if a walk was cut at [`MAX_STEPS`], forked if one
/// stopped forking at [`MAX_PATHS`], the most edges either walk entered.
#[allow(clippy::too_many_arguments)]
fn walk_from(
    model: &EdgeModel,
    next: &[Vec<u32>],
    e: usize,
    x0: f64,
    at_read: bool,
    is_read: &impl Fn(u32) -> bool,
    cap: f64,
    out: &[Vec<std::sync::atomic::AtomicU64>; 2],
) -> WalkStats {
    let (mut cut, mut forked) = (false, false);
    let mut live: u8 = if at_read { 2 } else { 3 };
    // Per walk: windows closed, edges entered, states on the stack.
    let (mut paths, mut steps, mut queued) = ([0usize; 2], [0usize; 2], [1usize; 2]);
    let mut stack: Vec<Reach> = vec![Reach {
        edge: e as u32,
        x: x0,
        u: 0.0,
        turned: 0,
        win: TurnWindow::default(),
        c: 0.0,
        walks: live,
    }];
    let bits = |w: u8| (0..2).filter(move |k| w >> k & 1 == 1);
    while let Some(st) = stack.pop() {
        let Reach {
            edge: ed,
            x,
            u,
            turned,
            mut win,
            c,
            walks,
        } = st;
        for k in bits(walks) {
            queued[k] -= 1;
        }
        let mut walks = walks & live;
        for k in bits(walks) {
            if steps[k] == MAX_STEPS {
                live &= !(1 << k);
                walks &= !(1 << k);
                cut = true;
            } else {
                steps[k] += 1;
            }
        }
        if walks == 0 {
            continue;
        }
        let ei = ed as usize;
        let rate = model.rate[ei];
        let len = model.length[ei];
        let bend = first_reset(model, ei, x, c, &mut win);
        // A walk ends at a bend or, with the tags, at the next site read,
        // whichever comes first (a read at the start itself opened it).
        let stop_without = bend.into_iter().fold(len, f64::min);
        let stop_with = if walks & 2 != 0 {
            let first = ei == e && x == x0;
            let read_at = model.sites[ei]
                .iter()
                .filter(|s| if first && at_read { s.0 > x } else { s.0 >= x })
                .find(|s| is_read(s.1))
                .map(|s| s.0);
            read_at.into_iter().fold(stop_without, f64::min)
        } else {
            stop_without
        };
        // The walks going on, and their budget (the same for both: they go
        // on only from an edge neither stopped on).
        let (mut going, mut u_next) = (0u8, 0.0);
        for k in bits(walks) {
            let stop = if k == 0 { stop_without } else { stop_with };
            let u_end = u + (stop - x).max(0.0) * rate;
            keep_max(&out[k][ei], u_end);
            if u_end >= cap {
                paths[k] += 1;
                continue;
            }
            if stop < len {
                continue;
            }
            debug_assert!(going == 0 || u_next == u_end);
            going |= 1 << k;
            u_next = u_end;
        }
        for (to, is_u, w) in continuations(model, &next[ei], ei, turned, &win) {
            for k in bits(going) {
                if paths[k] + queued[k] >= MAX_PATHS {
                    going &= !(1 << k);
                    forked = true;
                }
            }
            if going == 0 {
                break;
            }
            for k in bits(going) {
                queued[k] += 1;
            }
            stack.push(Reach {
                edge: to,
                x: 0.0,
                u: u_next,
                turned: turned + u8::from(is_u),
                win: w,
                c: c + len - x,
                walks: going,
            });
        }
    }
    WalkStats {
        starts: 1,
        cut: usize::from(cut),
        forked: usize::from(forked),
        most_steps: steps[0].max(steps[1]),
    }
}

#[cfg(test)]
mod tests {
    use super::super::turns::CURVE_M;
    use super::*;
    use crate::network::{model_from_polylines, Oneway, RoadAttributes, SectionId};
    use std::collections::BTreeMap;

    /// A two-way (or one-way) primary road `id`, 50 km/h.
    fn primary(id: String, oneway: Oneway) -> RoadAttributes {
        RoadAttributes {
            maxspeed_kmh: Some(50.0),
            ..RoadAttributes::new(id, "primary", oneway)
        }
    }

    /// Points `[north m, east m]` from (60.17° N, 24.94° E) as (lat, lon).
    fn local(pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let la = 60.17f64;
        let m_lon = 111_320.0 * la.to_radians().cos();
        pts.iter()
            .map(|p| [la + p[0] / 111_320.0, 24.94 + p[1] / m_lon])
            .collect()
    }

    /// A triangle lattice of straight roads northward: junction `j` of row
    /// `i` (`j` = 0..=`i`) lies 100 m × `i` north and 20 m × (2`j` − `i`)
    /// east; from each junction of rows 0 to `rows` − 1 a road leads to
    /// each of the two nearest junctions of the next row (11.3° either side
    /// of north, so every continuation turns 22.6°: straight on). Road ids
    /// are "`i`/`j`w" and "`i`/`j`e" (the row and junction they leave).
    fn lattice(rows: usize, oneway: Oneway) -> Network {
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
                    let attributes = primary(format!("{i}/{j}{side}"), oneway);
                    roads.push((attributes, vec![vec![at(i, j), at(i + 1, to)]]));
                }
            }
        }
        Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap()
    }

    /// Every permitted direction of every section, one reach `reach_m` for
    /// all, map matching's turn resets on (curve distance [`CURVE_M`]) and
    /// candidate sites every `spacing_m` (none: `None`).
    fn edge_model(net: &Network, reach_m: f64, spacing_m: Option<f64>) -> EdgeModel {
        let mut dir = Vec::new();
        for (si, s) in net.sections.iter().enumerate() {
            for fwd in [true, false] {
                let allowed = if fwd {
                    s.oneway.allows_forward()
                } else {
                    s.oneway.allows_backward()
                };
                if allowed {
                    dir.push((si as SectionId, fwd));
                }
            }
        }
        let n = dir.len();
        let mut id = 0u32;
        let sites = dir
            .iter()
            .map(|&(sec, _)| {
                let len = net.sections[sec as usize].length_m;
                let k = spacing_m.map_or(0, |sp| (len / sp).ceil() as usize);
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
            vec![13.9; n],
            vec![1.0 / reach_m; n],
            sites,
            vec![CURVE_M; n],
            (0.0, 0.0),
        )
    }

    /// The windows of a map: site ids → longest stretch (m).
    fn windows(m: &mut WindowMap) -> BTreeMap<Vec<u32>, f64> {
        let (sets, infos) = m.sorted();
        sets.iter()
            .zip(infos)
            .map(|(s, i)| (s.to_vec(), i.stretch_m))
            .collect()
    }

    #[test]
    fn straight_walks_forking_without_a_window_stop_at_max_steps_per_start() {
        // One-way roads north, 17 rows: a walk from a road leaving row i
        // forks at every junction up to row 17, where no road goes on, and
        // never reaches the 5 km reach (the lattice is 1.7 km long): no
        // window closes, so MAX_PATHS never counts, and it enters
        // 1 + 2 + … + 2^(16 − i) = 2^(17 − i) − 1 roads.
        let rows = 17;
        let net = lattice(rows, Oneway::Forward);
        let model = edge_model(&net, 5000.0, None);
        assert_eq!(model.dir.len(), rows * (rows + 1));
        let straight = geometric_straight(&net, &model);
        // Every junction of rows 1–16 continues both incoming roads onto
        // both outgoing ones.
        assert_eq!(straight.len(), 4 * (rows - 1) * rows / 2);
        // Walks from the roads leaving row 0 (2 of them: 2^17 − 1 roads
        // entered each) and row 1 (4: 2^16 − 1 each): with MAX_STEPS = 2^16
        // the first pass the limit, the others stay just within it.
        let row_of = |e: usize| -> usize {
            let sec = &net.sections[model.dir[e].0 as usize];
            let id = &net.roads[sec.road as usize].attributes.id;
            id.split('/').next().unwrap().parse().unwrap()
        };
        let used: Vec<bool> = (0..model.dir.len()).map(|e| row_of(e) <= 1).collect();
        assert_eq!(used.iter().filter(|&&u| u).count(), 6);
        let per_start = [(2usize, (1usize << 17) - 1), (4, (1 << 16) - 1)];
        let want_cut: usize = per_start
            .iter()
            .filter(|s| s.1 > MAX_STEPS)
            .map(|s| s.0)
            .sum();
        assert!(
            want_cut > 0,
            "MAX_STEPS = {MAX_STEPS} cuts no walk of this lattice (2^17 − 1 roads at most): the \
             guard is gone, or the lattice needs more rows"
        );

        // Unbounded (the reference: it ends, the lattice has no cycle).
        let mut all = WindowMap::new(usize::MAX);
        let free = straight_windows_within(&model, &straight, &used, &mut all, usize::MAX);
        assert_eq!(
            free,
            WalkStats {
                starts: 6,
                cut: 0,
                forked: 0,
                most_steps: (1 << 17) - 1
            }
        );
        assert_eq!(all.len(), 0, "no walk reaches the 5 km reach");

        // With the guard: the starts on row 0 stop at MAX_STEPS roads and
        // are counted, those on row 1 are not cut.
        let mut capped = WindowMap::new(usize::MAX);
        let stats = straight_windows(&model, &straight, &used, &mut capped);
        assert_eq!(
            stats,
            WalkStats {
                starts: 6,
                cut: want_cut,
                forked: 0,
                most_steps: MAX_STEPS
            }
        );
        assert_eq!(capped.len(), 0);
    }

    #[test]
    fn walks_forking_past_max_paths_before_their_window_closes_are_counted() {
        // The one-way lattice of 17 rows 100 m apart with a 1 km reach: a
        // walk from a road leaving row i ≤ 6 forks at every junction and
        // reaches its budget 10 rows on, after 2^9 = 512 > MAX_PATHS
        // paths; from rows 8 and up every path runs off the lattice
        // first, closing no window. A site every 50 m: a path's window is
        // the sites it passes.
        let rows = 17;
        let net = lattice(rows, Oneway::Forward);
        let model = edge_model(&net, 1000.0, Some(50.0));
        let straight = geometric_straight(&net, &model);
        let row_of = |e: usize| -> usize {
            let sec = &net.sections[model.dir[e].0 as usize];
            let id = &net.roads[sec.road as usize].attributes.id;
            id.split('/').next().unwrap().parse().unwrap()
        };
        let only =
            |r: usize| -> Vec<bool> { (0..model.dir.len()).map(|e| row_of(e) == r).collect() };
        let mut w = WindowMap::new(usize::MAX);
        let low = straight_windows(&model, &straight, &only(0), &mut w);
        assert_eq!(low.cut, 0);
        assert!(low.starts > 0);
        assert_eq!(low.forked, low.starts, "{low:?}");
        assert!(w.len() >= MAX_PATHS, "{} windows", w.len());
        let mut w = WindowMap::new(usize::MAX);
        let high = straight_windows(&model, &straight, &only(rows - 2), &mut w);
        assert!(high.starts > 0);
        assert_eq!(high.forked, 0, "{high:?}");
        assert_eq!(w.len(), 0);
    }

    #[test]
    fn the_step_limit_cuts_no_walk_of_an_ordinary_network() {
        // Two-way roads (walks also turn back sharply onto the other road
        // of a junction, and make one U-turn), a site every 25 m, a reach
        // of 300 m: the windows close within the paths' limit, far from
        // MAX_STEPS, and are those of the unbounded enumeration.
        let net = lattice(4, Oneway::Both);
        let model = edge_model(&net, 300.0, Some(25.0));
        let straight = geometric_straight(&net, &model);
        assert!(straight.iter().any(|&(_, b)| b & UTURN_FLAG != 0));
        let used = vec![true; model.dir.len()];
        let mut capped = WindowMap::new(usize::MAX);
        let stats = straight_windows(&model, &straight, &used, &mut capped);
        let mut all = WindowMap::new(usize::MAX);
        let free = straight_windows_within(&model, &straight, &used, &mut all, usize::MAX);
        assert_eq!(stats, free);
        assert_eq!(stats.cut, 0);
        assert_eq!(stats.forked, 0);
        // 20 roads × 2 directions × (1 + 5 sites) starts.
        assert_eq!(stats.starts, 240);
        assert!(stats.most_steps < MAX_STEPS, "{stats:?}");
        let w = windows(&mut capped);
        assert!(w.len() > 100, "{} windows", w.len());
        assert_eq!(w, windows(&mut all));
    }

    #[test]
    fn a_walk_turns_back_once_per_stretch_even_round_a_lens() {
        // A 500 m road north ("in") to junction J1, a lens of two bowed
        // 31 m roads ("A" east, "B" west) from J1 to J2 30 m north, and a
        // 500 m road on north ("out"). Every continuation through the
        // lens is straight on (15°), and each end of the lens turns back
        // 150° onto its other side: a hairpin that neither resets nor
        // turns on the same road. A walk may make one such turn-back per
        // stretch (as a U-turn); circling the lens, A → B → A → …, until
        // the 300 m reach is used is no vehicle's path.
        let two = Oneway::Both;
        let roads = vec![
            (
                primary("in".into(), two),
                vec![local(&[[-500.0, 0.0], [0.0, 0.0]])],
            ),
            (
                primary("A".into(), two),
                vec![local(&[[0.0, 0.0], [15.0, 4.0], [30.0, 0.0]])],
            ),
            (
                primary("B".into(), two),
                vec![local(&[[0.0, 0.0], [15.0, -4.0], [30.0, 0.0]])],
            ),
            (
                primary("out".into(), two),
                vec![local(&[[30.0, 0.0], [530.0, 0.0]])],
            ),
        ];
        let net = Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap();
        let model = edge_model(&net, 300.0, Some(25.0));
        let road = |e: usize| -> &str {
            let sec = &net.sections[model.dir[e].0 as usize];
            &net.roads[sec.road as usize].attributes.id
        };
        let edge = |id: &str, fwd: bool| -> usize {
            (0..model.dir.len())
                .find(|&e| road(e) == id && model.dir[e].1 == fwd)
                .unwrap()
        };
        // The hairpins at J2 (A onto B backwards) and J1 (B backwards onto
        // A) turn back and are straight transitions; on through the lens
        // is neither.
        let straight = geometric_straight(&net, &model);
        let (a, b_back) = (edge("A", true), edge("B", false));
        for (x, y) in [(a, b_back), (b_back, a)] {
            assert!(turns_back(&model, x, y), "{} → {}", road(x), road(y));
            assert!(straight.contains(&(x as u32, y as u32)));
        }
        assert!(!turns_back(&model, edge("in", true), a));
        assert!(!turns_back(&model, a, edge("out", true)));

        let used = vec![true; model.dir.len()];
        let mut map = WindowMap::new(usize::MAX);
        straight_windows(&model, &straight, &used, &mut map);
        let w = windows(&mut map);
        let lens: std::collections::HashSet<u32> = (0..model.dir.len())
            .filter(|&e| matches!(road(e), "A" | "B"))
            .flat_map(|e| model.sites[e].iter().map(|s| s.1))
            .collect();
        let on = |id: &str| -> std::collections::HashSet<u32> {
            let mut s = std::collections::HashSet::new();
            for fwd in [true, false] {
                s.extend(model.sites[edge(id, fwd)].iter().map(|x| x.1));
            }
            s
        };
        // No window holds only lens sites: every walk left the lens within
        // one turn-back.
        for ids in w.keys() {
            assert!(
                !ids.iter().all(|i| lens.contains(i)),
                "a window of lens sites only, {ids:?}: a walk circled the lens"
            );
        }
        // The single turn-back is still walked: from A round the hairpin
        // onto B and back down "in".
        let (sa, sb, sin) = (on("A"), on("B"), on("in"));
        assert!(
            w.keys().any(|ids| ids.iter().any(|i| sa.contains(i))
                && ids.iter().any(|i| sb.contains(i))
                && ids.iter().any(|i| sin.contains(i))),
            "no window of a walk A → B → in"
        );
    }

    /// A coverage walk's state at an edge ([`separate_walk_budgets`]).
    struct OneReach {
        edge: u32,
        /// Position along the edge (m).
        x: f64,
        /// Budget used so far.
        u: f64,
        /// Junction turn-backs made.
        turned: u8,
        /// The walk's headings of the last `CURVE_M`.
        win: TurnWindow,
        /// The walk's chainage at `x` (m).
        c: f64,
    }

    /// The coverage budgets of one walk per start as [`walk_budgets`] had
    /// them before it followed both in one pass (the reference): without
    /// the tags (`read` = `None`) or with them.
    fn separate_walk_budgets(
        model: &EdgeModel,
        straight: &std::collections::HashSet<(u32, u32)>,
        used: &[bool],
        read: Option<&[bool]>,
        cap: f64,
    ) -> Vec<f64> {
        use rayon::prelude::*;
        let n = model.dir.len();
        let mut next: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &(a, b) in straight {
            next[a as usize].push(b);
        }
        for v in &mut next {
            v.sort_unstable();
        }
        let is_read = |site: u32| read.is_some_and(|r| r[site as usize]);
        let used = |e: usize| used.get(e) == Some(&true);
        let edges: Vec<usize> = (0..n)
            .filter(|&e| used(e) || model.sites[e].iter().any(|s| is_read(s.1)))
            .collect();
        let merge = |mut a: Vec<f64>, b: Vec<f64>| {
            for (x, y) in a.iter_mut().zip(b) {
                *x = x.max(y);
            }
            a
        };
        // A few blocks of starts per thread, each with one array of the
        // edges (one per rayon split held ~0.3 GB more on Gothenburg).
        let block = edges
            .len()
            .div_ceil(8 * rayon::current_num_threads())
            .max(1);
        edges
            .par_chunks(block)
            .map(|chunk| {
                let mut out = vec![0.0; n];
                for &e in chunk {
                    // (position, the start is a site read there).
                    let mut starts: Vec<(f64, bool)> = Vec::new();
                    if used(e) {
                        starts.push((0.0, false));
                        starts.extend(
                            model.bends[e]
                                .iter()
                                .filter(|_| model.turn_resets[e])
                                .map(|&x| (x, false)),
                        );
                    }
                    starts.extend(
                        model.sites[e]
                            .iter()
                            .filter(|s| is_read(s.1))
                            .map(|s| (s.0, true)),
                    );
                    for (x0, at_read) in starts {
                        separate_walk_from(model, &next, e, x0, at_read, &is_read, cap, &mut out);
                    }
                }
                out
            })
            .reduce(|| vec![0.0; n], merge)
    }

    /// The coverage walks from one start ([`separate_walk_budgets`]).
    #[allow(clippy::too_many_arguments)]
    fn separate_walk_from(
        model: &EdgeModel,
        next: &[Vec<u32>],
        e: usize,
        x0: f64,
        at_read: bool,
        is_read: &impl Fn(u32) -> bool,
        cap: f64,
        out: &mut [f64],
    ) {
        let mut paths = 0usize;
        let mut steps = 0usize;
        let mut stack: Vec<OneReach> = vec![OneReach {
            edge: e as u32,
            x: x0,
            u: 0.0,
            turned: 0,
            win: TurnWindow::default(),
            c: 0.0,
        }];
        while let Some(st) = stack.pop() {
            if steps == MAX_STEPS {
                break;
            }
            steps += 1;
            let OneReach {
                edge: ed,
                x,
                u,
                turned,
                mut win,
                c,
            } = st;
            let ei = ed as usize;
            let rate = model.rate[ei];
            let len = model.length[ei];
            let bend = first_reset(model, ei, x, c, &mut win);
            // The walk ends at a bend or at the next site read, whichever
            // comes first (a read at the start itself opened it).
            let first = ei == e && x == x0;
            let read_at = model.sites[ei]
                .iter()
                .filter(|s| if first && at_read { s.0 > x } else { s.0 >= x })
                .find(|s| is_read(s.1))
                .map(|s| s.0);
            let stop = bend.into_iter().chain(read_at).fold(len, f64::min);
            let u_end = u + (stop - x).max(0.0) * rate;
            out[ei] = out[ei].max(u_end);
            if u_end >= cap {
                paths += 1;
                continue;
            }
            if stop < len {
                continue;
            }
            for (to, is_u, w) in continuations(model, &next[ei], ei, turned, &win) {
                if paths + stack.len() >= MAX_PATHS {
                    break;
                }
                stack.push(OneReach {
                    edge: to,
                    x: 0.0,
                    u: u_end,
                    turned: turned + u8::from(is_u),
                    win: w,
                    c: c + len - x,
                });
            }
        }
    }

    /// Asserts that [`walk_budgets`] gives, bit for bit, the budgets of the
    /// two separate walks per start ([`separate_walk_budgets`]: without the
    /// tags, then with `read`); returns how many edges the walks without
    /// and with the tags reached, and the wall times (s) of the one pass
    /// and of the two separate walks.
    fn same_as_separate_walks(
        model: &EdgeModel,
        straight: &std::collections::HashSet<(u32, u32)>,
        used: &[bool],
        read: &[bool],
        cap: f64,
    ) -> (usize, usize, f64, f64) {
        let t = std::time::Instant::now();
        let (without, with, _) = walk_budgets(model, straight, used, read, cap);
        let one = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let want_without = separate_walk_budgets(model, straight, used, None, cap);
        let want_with = separate_walk_budgets(model, straight, used, Some(read), cap);
        let two = t.elapsed().as_secs_f64();
        for (name, got, want) in [
            ("without", &without, &want_without),
            ("with", &with, &want_with),
        ] {
            assert_eq!(got.len(), want.len());
            if let Some(e) = (0..got.len()).find(|&e| got[e].to_bits() != want[e].to_bits()) {
                panic!(
                    "budget {name} the tags on edge {e}: {} in one pass, {} walked separately \
                     (cap {cap})",
                    got[e], want[e]
                );
            }
        }
        let reached = |v: &[f64]| v.iter().filter(|&&u| u > 0.0).count();
        (reached(&without), reached(&with), one, two)
    }

    /// Every `m`-th element (from a hash of the index, offset `k`) of `n`.
    fn every(n: usize, m: usize, k: usize) -> Vec<bool> {
        (0..n)
            .map(|i| {
                ((i as u64 + k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) % m as u64 == 0
            })
            .collect()
    }

    #[test]
    fn walk_budgets_in_one_pass_equal_the_two_walks_on_small_networks() {
        // Forks past MAX_STEPS (one-way lattice, a 5 km reach, 17 rows):
        // the walk without the tags is cut, the walk with them stops at
        // reads (each counts its own edges entered).
        let net = lattice(17, Oneway::Forward);
        let model = edge_model(&net, 5000.0, Some(100.0));
        let straight = geometric_straight(&net, &model);
        let sites = model.sites.iter().map(Vec::len).sum::<usize>();
        let used: Vec<bool> = (0..model.dir.len()).map(|e| e < 6).collect();
        for (m, k) in [(1, 0), (2, 0), (5, 1), (40, 3), (usize::MAX, 0)] {
            let read = every(sites, m, k);
            same_as_separate_walks(&model, &straight, &used, &read, WALK_BUDGET_CAP);
        }
        // Two-way lattices (U-turns, turn-backs), a short reach (windows
        // close) and a long one (forks up to MAX_PATHS), several caps.
        for (rows, reach, spacing) in [(4, 300.0, 25.0), (6, 2000.0, 50.0), (8, 600.0, 30.0)] {
            let net = lattice(rows, Oneway::Both);
            let model = edge_model(&net, reach, Some(spacing));
            let straight = geometric_straight(&net, &model);
            let sites = model.sites.iter().map(Vec::len).sum::<usize>();
            let n = model.dir.len();
            for (used, m) in [(vec![true; n], 7), (every(n, 3, 1), 2), (every(n, 2, 0), 1)] {
                for cap in [0.5, 1.0, WALK_BUDGET_CAP, 4.0] {
                    for read in [every(sites, m, 0), vec![false; sites]] {
                        let (a, b, ..) =
                            same_as_separate_walks(&model, &straight, &used, &read, cap);
                        assert!(a > 0 && b > 0, "{rows} rows: no walk");
                    }
                }
            }
        }
    }

    #[test]
    fn walk_budgets_count_the_starts_whose_walks_stopped_at_a_limit() {
        // The one-way lattice of 17 rows 100 m apart, a site every 50 m,
        // none read (the walks with and without the tags are the same, so
        // a start counts once).
        let rows = 17;
        let net = lattice(rows, Oneway::Forward);
        let row_of = |model: &EdgeModel, e: usize| -> usize {
            let sec = &net.sections[model.dir[e].0 as usize];
            let id = &net.roads[sec.road as usize].attributes.id;
            id.split('/').next().unwrap().parse().unwrap()
        };
        let only = |model: &EdgeModel, r: usize| -> Vec<bool> {
            (0..model.dir.len())
                .map(|e| row_of(model, e) == r)
                .collect()
        };
        // A 1 km reach and a cap of 1: from row 0 the walks reach the cap 10
        // rows on, after 2^9 = 512 > MAX_PATHS paths, and every start stops
        // forking; from row 15 they run off the lattice first.
        let model = edge_model(&net, 1000.0, Some(50.0));
        let straight = geometric_straight(&net, &model);
        let sites = model.sites.iter().map(Vec::len).sum::<usize>();
        let none = vec![false; sites];
        let starts = only(&model, 0).iter().filter(|&&u| u).count();
        assert!(starts > 0);
        let (.., low) = walk_budgets(&model, &straight, &only(&model, 0), &none, 1.0);
        assert_eq!(
            (low.starts, low.cut, low.forked),
            (starts, 0, starts),
            "{low:?}"
        );
        let (.., high) = walk_budgets(&model, &straight, &only(&model, rows - 2), &none, 1.0);
        assert_eq!((high.cut, high.forked), (0, 0), "{high:?}");
        // A 5 km reach: no walk reaches the cap on the 1.7 km lattice; from
        // row 0 each enters 2^17 − 1 roads, past MAX_STEPS = 2^16, and is
        // cut; from row 1, 2^16 − 1, just within it.
        let model = edge_model(&net, 5000.0, Some(50.0));
        let straight = geometric_straight(&net, &model);
        let (.., far) = walk_budgets(&model, &straight, &only(&model, 0), &none, 1.0);
        assert_eq!(
            (far.starts, far.cut, far.forked),
            (starts, starts, 0),
            "{far:?}"
        );
        let (.., near) = walk_budgets(&model, &straight, &only(&model, 1), &none, 1.0);
        assert_eq!((near.cut, near.forked), (0, 0), "{near:?}");
    }

    #[test]
    fn walk_budgets_in_one_pass_equal_the_two_walks_on_real_maps() {
        // Helsinki and Gothenburg, every direction of every road, a site
        // every 40 m; walks from two thirds of the edges, reads at 1 % and
        // 10 % of the sites, the plans' cap and a reach of 500 m and 2 km.
        use crate::network::LoadOptions;
        for map in ["maps/helsinki.osm.pbf", "maps/gothenburg-roads.geojson"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(map);
            let net = Network::load(&path, &LoadOptions::default()).unwrap();
            for reach in [500.0, 2000.0] {
                let model = edge_model(&net, reach, Some(40.0));
                let straight = geometric_straight(&net, &model);
                let sites = model.sites.iter().map(Vec::len).sum::<usize>();
                let used = every(model.dir.len(), 3, 2)
                    .iter()
                    .map(|&x| !x)
                    .collect::<Vec<_>>();
                for m in [100, 10] {
                    let read = every(sites, m, 5);
                    let (a, b, one, two) =
                        same_as_separate_walks(&model, &straight, &used, &read, WALK_BUDGET_CAP);
                    eprintln!(
                        "{map}, reach {reach} m, a read per {m} sites: {} edges, {a} reached \
                         without the tags, {b} with; one pass {one:.2} s, two walks {two:.2} s",
                        model.dir.len()
                    );
                    assert!(a > model.dir.len() / 2 && b > model.dir.len() / 2);
                }
            }
        }
    }

    #[test]
    fn walk_budgets_follow_straight_walks_past_the_reach_and_stop_at_reads() {
        // Two one-way 200 m roads straight north, "in" then "out", a 300 m
        // reach, two sites on each road (at 50 and 150 m).
        let one = Oneway::Forward;
        let roads = vec![
            (
                primary("in".into(), one),
                vec![local(&[[0.0, 0.0], [200.0, 0.0]])],
            ),
            (
                primary("out".into(), one),
                vec![local(&[[200.0, 0.0], [400.0, 0.0]])],
            ),
        ];
        let net = Network::from_model(model_from_polylines(roads).unwrap(), None).unwrap();
        let model = edge_model(&net, 300.0, Some(150.0));
        assert_eq!(model.dir.len(), 2);
        let edge = |id: &str| -> usize {
            (0..2)
                .find(|&e| {
                    let sec = &net.sections[model.dir[e].0 as usize];
                    net.roads[sec.road as usize].attributes.id == id
                })
                .unwrap()
        };
        let (a, b) = (edge("in"), edge("out"));
        let straight = geometric_straight(&net, &model);
        assert!(straight.contains(&(a as u32, b as u32)));
        // (The roads measure 200.2 m on the ellipsoid: 2e-3 of budget.)
        let close = |x: f64, y: f64| (x - y).abs() < 2e-3;
        // Only "in" driven: the walk from its start goes on into "out",
        // 400 m, a budget of 4/3 at the end (over the reach, under the cap).
        let mut used = vec![false; 2];
        used[a] = true;
        let (without, with, stops) =
            walk_budgets(&model, &straight, &used, &[false; 4], WALK_BUDGET_CAP);
        assert_eq!(
            (stops.cut, stops.forked),
            (0, 0),
            "two roads: no limit reached"
        );
        assert_eq!(with, without, "no site read: the same walks");
        assert!(close(without[a], 2.0 / 3.0), "{without:?}");
        assert!(close(without[b], 4.0 / 3.0), "{without:?}");
        // With a cap of 1 the walk stops at the end of "out", where it
        // passed 1 (the value at that edge's end is kept).
        let capped = walk_budgets(&model, &straight, &used, &[false; 4], 1.0).0;
        assert!(close(capped[b], 4.0 / 3.0), "{capped:?}");
        // The site at 150 m of "out" read: the walk from the start of "in"
        // ends there (350 m); the walk from the read (on a road not driven,
        // still a start) adds 50 m.
        let out_site = model.sites[b][1];
        assert!((out_site.0 - 150.0).abs() < 0.5, "{out_site:?}");
        let mut read = vec![false; 4];
        read[out_site.1 as usize] = true;
        let (w2, with, _) = walk_budgets(&model, &straight, &used, &read, WALK_BUDGET_CAP);
        assert_eq!(w2, without, "the walks without the tags ignore reads");
        assert!(close(with[a], 2.0 / 3.0), "{with:?}");
        assert!(close(with[b], 3.5 / 3.0), "{with:?}");
        // The site read on "in" (at 150 m): 150 m before it, then 250 m
        // after it (50 m of "in" and all of "out").
        let mut read = vec![false; 4];
        read[model.sites[a][1].1 as usize] = true;
        let with = walk_budgets(&model, &straight, &used, &read, WALK_BUDGET_CAP).1;
        assert!(close(with[a], 0.5), "{with:?}");
        assert!(close(with[b], 2.5 / 3.0), "{with:?}");
        // Nothing driven, nothing walked.
        let none = walk_budgets(&model, &straight, &[false; 2], &[false; 4], WALK_BUDGET_CAP);
        assert_eq!(none, (vec![0.0; 2], vec![0.0; 2], WalkStats::default()));
        // Each case as the two separate walks had it.
        for r in 0..16u32 {
            let read: Vec<bool> = (0..4).map(|i| r >> i & 1 == 1).collect();
            for cap in [1.0, WALK_BUDGET_CAP] {
                same_as_separate_walks(&model, &straight, &used, &read, cap);
            }
        }
    }
}
