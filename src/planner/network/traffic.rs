//! `traffic = "trips"`: the traffic a network plan serves, as continuous
//! chains of trips between destinations (the flow view of the
//! refuelling-station location models, Kuby & Lim 2005, Capar & Kuby 2012,
//! with an error budget in place of fuel), and what a chain asks of the
//! tags.
//!
//! * **Destinations**: points on the drivable network, uniform in road
//!   length (each section drawn with probability ∝ its length, the point
//!   uniform along it), or the listed points of `planner.destinations`
//!   (snapped to the nearest road within 100 m) with their weights.
//! * **A chain**: from a destination, trips to fresh destinations, each the
//!   shortest permitted path (one-way roads honoured; at a trip end the
//!   vehicle continues in its direction when it can and turns back
//!   otherwise, exactly as `crate::route` plans a route through waypoints),
//!   at each road's planning speed, until the shift's driving time is used.
//! * **Resets** (map matching on): a turn of at least [`TURN_DEG`] and at
//!   most 180° − [`TURN_DEG`] — at a junction between two roads (the
//!   chords over the last and first [`CHORD_M`] of each) or a bend inside a
//!   road — observes the along-road error, which starts a new stretch. A
//!   turn-back — a U-turn, or a hairpin sharper than 180° − [`TURN_DEG`]
//!   onto another road ([`turns_back`]) — observes nothing. Without map
//!   matching only the chain's start is a reset.
//! * **Budget**: a metre of road of speed class c consumes `1/R_c` of the
//!   error budget; the bound stays within the requirement on a stretch
//!   while the budget consumed since the stretch's start or the last tag
//!   read is at most 1. With `k` missed reads tolerated, every window of
//!   budget 1 that starts at the stretch's start or at a tag must hold
//!   `k + 1` tags before the stretch ends.

pub use super::turns::CHORD_M;
use super::turns::{heading_samples, intrinsic_resets, point_at, walk_edge, TurnWindow, TURN_DEG};
use super::window_sets::{WindowInfo, WindowMap};
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::route::{next_leg_with, section_points, Landmarks, SectionPoint, DEFAULT_LANDMARKS};
use rand::Rng;
use std::collections::HashMap;
use std::sync::Arc;

/// Most trips in one chain (a guard against a shift far longer than the
/// network's trips).
pub const MAX_TRIPS_PER_CHAIN: usize = 200_000;

/// What the chain analysis needs of the directed edges.
#[derive(Debug, Clone)]
pub(crate) struct EdgeModel {
    /// (section, forward) → directed edge.
    pub index: HashMap<(SectionId, bool), u32>,
    /// Per directed edge: (section, forward).
    pub dir: Vec<(SectionId, bool)>,
    /// Planning speed (m/s).
    pub speed: Vec<f64>,
    /// Budget consumed per metre (1/R of the edge's class).
    pub rate: Vec<f64>,
    /// Candidate sites: (position along the directed edge m, site id),
    /// sorted.
    pub sites: Vec<Vec<(f64, u32)>>,
    /// Heading of the first and last chord (rad, clockwise from north).
    pub start_heading: Vec<f64>,
    /// Heading of the last chord.
    pub end_heading: Vec<f64>,
    /// Where a stretch starts after the edge's own turns (m): the ends of
    /// its reset zones, scanned from its start without history
    /// ([`super::turns`]).
    pub bends: Vec<Vec<f64>>,
    /// Heading samples (position m, heading rad), [`super::turns`].
    pub headings: Vec<Vec<(f32, f32)>>,
    /// Reset positions independent of the drive before the edge.
    pub intrinsic: Vec<Vec<f64>>,
    /// Edge length (m).
    pub length: Vec<f64>,
    /// Turns onto (and bends along) the edge reset the along-road error:
    /// map matching on, and its speed class's turn drive brought the bound
    /// back within the requirement.
    pub turn_resets: Vec<bool>,
    /// The class's curve distance (m; 0: turns give no credit), see
    /// [`super::turns`].
    pub curve: Vec<f64>,
    /// The nearest parallel road beside the edge in the band that matters
    /// (m), [`super::parallel`]: a warning in reasons, not in the model.
    pub parallel: Vec<Option<f32>>,
}

fn heading(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).atan2(b[1] - a[1])
}

/// Absolute heading change between two headings (degrees, 0–180).
pub fn turn_deg(h0: f64, h1: f64) -> f64 {
    let mut d = (h1 - h0).to_degrees() % 360.0;
    if d < 0.0 {
        d += 360.0;
    }
    if d > 180.0 {
        360.0 - d
    } else {
        d
    }
}

/// A turn observes the along-road error.
pub fn resets(turn: f64) -> bool {
    (TURN_DEG..=180.0 - TURN_DEG).contains(&turn)
}

/// The junction transition from directed edge `a` onto `b` turns back: a
/// U-turn onto the same road, or a hairpin onto another sharper than
/// 180° − [`TURN_DEG`] (chords at the junction). Neither observes the
/// along-road error (the hairpin's new road leaves the reversed old one at
/// less than [`TURN_DEG`], as a fork does), and a vehicle turns back at a
/// trip end, once: a walk that turns back twice in one stretch circles a
/// loop (a lens of two short roads between the same two junctions) or
/// shuttles, which no route between destinations does.
pub(crate) fn turns_back(model: &EdgeModel, a: usize, b: usize) -> bool {
    model.dir[a].0 == model.dir[b].0
        || turn_deg(model.end_heading[a], model.start_heading[b]) > 180.0 - TURN_DEG
}

/// Chord headings (rad) at the start and the end of a directed section.
pub(crate) fn end_headings(net: &Network, sec: SectionId, fwd: bool) -> (f64, f64) {
    let len = net.sections[sec as usize].length_m;
    let (from, to) = if fwd { (0.0, len) } else { (len, 0.0) };
    let pts = section_points(net, sec, from, to);
    let mut cum = vec![0.0];
    for w in pts.windows(2) {
        let l = cum[cum.len() - 1] + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        cum.push(l);
    }
    let total = cum[cum.len() - 1];
    let ch = CHORD_M.min(total);
    (
        heading(pts[0], point_at(&pts, &cum, ch)),
        heading(point_at(&pts, &cum, total - ch), pts[pts.len() - 1]),
    )
}

impl EdgeModel {
    /// The geometry of every directed edge: chord headings at its ends and
    /// its resetting bends.
    pub fn new(
        net: &Network,
        dir: Vec<(SectionId, bool)>,
        speed: Vec<f64>,
        rate: Vec<f64>,
        sites: Vec<Vec<(f64, u32)>>,
        curve: Vec<f64>,
        parallel_m: (f64, f64),
    ) -> Self {
        let turn_resets: Vec<bool> = curve.iter().map(|&w| w > 0.0).collect();
        let n = dir.len();
        let mut index = HashMap::with_capacity(n);
        let (mut sh, mut eh, mut bends, mut length) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let (mut headings, mut intrinsic) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let mut parallel = Vec::with_capacity(n);
        for (e, &(sec, fwd)) in dir.iter().enumerate() {
            index.insert((sec, fwd), e as u32);
            let len = net.sections[sec as usize].length_m;
            let (from, to) = if fwd { (0.0, len) } else { (len, 0.0) };
            let pts = section_points(net, sec, from, to);
            let mut cum = vec![0.0];
            for w in pts.windows(2) {
                let l = cum[cum.len() - 1] + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
                cum.push(l);
            }
            let total = cum[cum.len() - 1];
            let ch = CHORD_M.min(total);
            sh.push(heading(pts[0], point_at(&pts, &cum, ch)));
            eh.push(heading(
                point_at(&pts, &cum, total - ch),
                pts[pts.len() - 1],
            ));
            let scale = len / total.max(1e-9);
            let samples = heading_samples(&pts, scale);
            // The nearest parallel road in the band that matters (a warning).
            let at: Vec<([f64; 2], f32)> = samples
                .iter()
                .map(|&(x, h)| (point_at(&pts, &cum, x as f64 / scale), h))
                .collect();
            let par = super::parallel::parallel_roads(net, sec, &at, parallel_m.0, parallel_m.1);
            parallel.push(par.into_iter().flatten().reduce(f32::min));
            let mut w = TurnWindow::default();
            let flags: Vec<bool> = samples
                .iter()
                .map(|&(x, h)| w.push(x as f64, h, curve[e]))
                .collect();
            // Zone ends: a resetting sample followed by one that does not.
            let b: Vec<f64> = (0..samples.len())
                .filter(|&i| flags[i] && !flags.get(i + 1).copied().unwrap_or(false))
                .map(|i| samples[i].0 as f64)
                .collect();
            intrinsic.push(intrinsic_resets(&samples, curve[e]));
            headings.push(samples);
            bends.push(b);
            length.push(len);
        }
        Self {
            index,
            dir,
            speed,
            rate,
            sites,
            start_heading: sh,
            end_heading: eh,
            bends,
            headings,
            intrinsic,
            length,
            turn_resets,
            curve,
            parallel,
        }
    }
}

/// Where trips go.
#[derive(Debug, Clone)]
pub(crate) struct Destinations {
    /// Listed points (empty: points uniform in road length).
    points: Vec<SectionPoint>,
    /// Cumulative weights (of the points, or of the sections' lengths).
    cum: Vec<f64>,
    /// Landmark bounds guiding the trips' shortest paths (thousands per
    /// chain of trips; built once per plan).
    landmarks: Arc<Landmarks>,
}

/// Per section: both its ends lie in the largest strongly connected part of
/// the directed road graph (every point there can reach every other by
/// permitted roads). Map extracts cut roads at their edge and leave one-way
/// traps; trips run in the main part only.
pub(crate) fn main_component(net: &Network, model: &EdgeModel) -> Vec<bool> {
    use petgraph::graph::{DiGraph, NodeIndex};
    let mut g: DiGraph<(), ()> = DiGraph::with_capacity(net.nodes.len(), model.dir.len());
    for _ in 0..net.nodes.len() {
        g.add_node(());
    }
    for &(sec, fwd) in &model.dir {
        let s = &net.sections[sec as usize];
        let (a, b) = if fwd {
            (s.start, s.end)
        } else {
            (s.end, s.start)
        };
        g.add_edge(NodeIndex::new(a as usize), NodeIndex::new(b as usize), ());
    }
    let sccs = petgraph::algo::tarjan_scc(&g);
    let mut comp = vec![usize::MAX; net.nodes.len()];
    let mut best = (0usize, 0.0f64);
    for (ci, c) in sccs.iter().enumerate() {
        for n in c {
            comp[n.index()] = ci;
        }
    }
    let mut len = vec![0.0; sccs.len()];
    for s in &net.sections {
        if comp[s.start as usize] == comp[s.end as usize] && comp[s.start as usize] != usize::MAX {
            len[comp[s.start as usize]] += s.length_m;
        }
    }
    for (ci, &l) in len.iter().enumerate() {
        if l > best.1 {
            best = (ci, l);
        }
    }
    net.sections
        .iter()
        .map(|s| comp[s.start as usize] == best.0 && comp[s.end as usize] == best.0)
        .collect()
}

impl Destinations {
    /// Points uniform in road length over the sections of the main
    /// strongly connected part (`main`).
    pub fn by_length(net: &Network, model: &EdgeModel, main: &[bool]) -> Result<Self> {
        let mut cum = Vec::with_capacity(net.sections.len());
        let mut t = 0.0;
        for (si, s) in net.sections.iter().enumerate() {
            let used = main[si]
                && (model.index.contains_key(&(si as SectionId, true))
                    || model.index.contains_key(&(si as SectionId, false)));
            if used && s.length_m.is_finite() && s.length_m > 0.0 {
                t += s.length_m;
            }
            cum.push(t);
        }
        if t <= 0.0 {
            return Err(Error::InvalidParameter(
                "the map has no drivable road to place destinations on".into(),
            ));
        }
        Ok(Self {
            points: Vec::new(),
            cum,
            landmarks: Arc::new(Landmarks::build(net, DEFAULT_LANDMARKS)),
        })
    }

    /// Listed points with weights (> 0 in all).
    pub fn listed(net: &Network, points: Vec<SectionPoint>, weights: &[f64]) -> Result<Self> {
        let mut cum = Vec::with_capacity(weights.len());
        let mut t = 0.0;
        for &w in weights {
            t += w;
            cum.push(t);
        }
        // Two places to drive between: a trip from a destination to itself
        // is no trip, and a destination of weight 0 is never drawn.
        let mut places = points.iter().zip(weights).filter(|(_, &w)| w > 0.0);
        let two_places = places
            .next()
            .is_some_and(|(first, _)| places.any(|(p, _)| p != first));
        if points.len() < 2 || !(t > 0.0 && t.is_finite()) || !two_places {
            return Err(Error::InvalidParameter(
                "trips need at least two destinations with a positive weight at different \
                 places on the roads"
                    .into(),
            ));
        }
        Ok(Self {
            points,
            cum,
            landmarks: Arc::new(Landmarks::build(net, DEFAULT_LANDMARKS)),
        })
    }

    fn draw<R: Rng>(&self, net: &Network, rng: &mut R) -> SectionPoint {
        let total = self.cum[self.cum.len() - 1];
        let u = rng.random::<f64>() * total;
        let i = self
            .cum
            .partition_point(|&c| c <= u)
            .min(self.cum.len() - 1);
        if self.points.is_empty() {
            let len = net.sections[i].length_m;
            SectionPoint {
                section: i as SectionId,
                offset_m: rng.random::<f64>() * len,
            }
        } else {
            self.points[i]
        }
    }
}

/// The edges and destinations chains are drawn from.
#[derive(Debug, Clone)]
pub(crate) struct ChainModel {
    pub model: EdgeModel,
    pub dest: Destinations,
}

/// One piece of a chain: a directed edge from `a0` to `a1` along it (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Piece {
    pub edge: u32,
    pub a0: f64,
    pub a1: f64,
}

/// A chain of trips.
#[derive(Debug, Clone)]
pub(crate) struct Chain {
    /// The trip ends, in order (the first is the start).
    pub points: Vec<SectionPoint>,
    /// The pieces driven.
    pub pieces: Vec<Piece>,
    /// Length (m).
    pub length_m: f64,
    /// Driving time at the planning speeds (s).
    pub duration_s: f64,
}

/// Samples one chain of `shift_s` of driving.
pub(crate) fn sample_chain<R: Rng>(
    net: &Network,
    model: &EdgeModel,
    dest: &Destinations,
    shift_s: f64,
    rng: &mut R,
) -> Result<Chain> {
    let mut cur = dest.draw(net, rng);
    let mut chain = Chain {
        points: vec![cur],
        pieces: Vec::new(),
        length_m: 0.0,
        duration_s: 0.0,
    };
    let mut arrive: Option<bool> = None;
    let mut failures = 0usize;
    let mut trips = 0usize;
    while chain.duration_s < shift_s {
        if trips >= MAX_TRIPS_PER_CHAIN {
            break;
        }
        let next = dest.draw(net, rng);
        if next == cur {
            failures += 1;
        } else if let Some((pieces, _)) =
            next_leg_with(net, Some(&dest.landmarks), cur, next, arrive)
        {
            trips += 1;
            for (ds, from, to) in pieces {
                let Some(&e) = model.index.get(&(ds.section, ds.forward)) else {
                    continue;
                };
                let len_e = model.length[e as usize];
                let (a0, a1) = if ds.forward {
                    (from, to)
                } else {
                    (len_e - from, len_e - to)
                };
                let (a0, a1) = (a0.clamp(0.0, len_e), a1.clamp(0.0, len_e));
                let len = a1 - a0;
                if len <= 0.0 {
                    continue;
                }
                let dt = len / model.speed[e as usize];
                let left = shift_s - chain.duration_s;
                if dt >= left {
                    let cut = a0 + left * model.speed[e as usize];
                    chain.pieces.push(Piece {
                        edge: e,
                        a0,
                        a1: cut,
                    });
                    chain.length_m += cut - a0;
                    chain.duration_s = shift_s;
                    break;
                }
                chain.pieces.push(Piece { edge: e, a0, a1 });
                chain.length_m += len;
                chain.duration_s += dt;
            }
            arrive = chain.pieces.last().map(|p| model.dir[p.edge as usize].1);
            chain.points.push(next);
            cur = next;
            failures = 0;
        } else {
            failures += 1;
        }
        if failures > 200 {
            return Err(Error::InvalidParameter(format!(
                "no trip could be routed from a destination on section {} in 200 tries: the \
                 destinations are not connected by permitted roads (one-way roads, disconnected parts of the map)",
                cur.section
            )));
        }
    }
    Ok(chain)
}

/// A chain as the budget sees it.
#[derive(Debug, Clone, Default)]
pub(crate) struct ChainBudget {
    /// Resets: (budget position, chainage m), the chain's start first and
    /// its end last.
    pub resets: Vec<(f64, f64)>,
    /// Candidate sites passed: (budget position, site id), in order.
    pub sites: Vec<(f64, u32)>,
    /// Pieces: (directed edge, budget at its start, at its end).
    pub pieces: Vec<(u32, f64, f64)>,
    /// Junction transitions without a reset, node to node: (from edge, to
    /// edge).
    pub straight: Vec<(u32, u32)>,
}

/// The budget view of a chain (resets at turns when `map_matching`,
/// [`super::turns`]).
pub(crate) fn chain_budget(model: &EdgeModel, chain: &Chain, map_matching: bool) -> ChainBudget {
    let mut out = ChainBudget::default();
    let (mut b, mut c) = (0.0, 0.0);
    out.resets.push((0.0, 0.0));
    let mut prev: Option<Piece> = None;
    let mut win = TurnWindow::default();
    for p in &chain.pieces {
        let e = p.edge as usize;
        let rate = model.rate[e];
        if let Some(q) = prev {
            let qe = q.edge as usize;
            let joined = (q.a1 - model.length[qe]).abs() < 1e-6 && p.a0.abs() < 1e-6;
            let u_turn = turns_back(model, qe, e);
            if !joined || u_turn {
                // Turning back on the spot observes nothing.
                win.clear();
            }
            if joined {
                // A junction transition the straight walks may follow: not
                // a sharp resetting turn (chords at the junction).
                let sharp = map_matching
                    && model.turn_resets[e]
                    && resets(turn_deg(model.end_heading[qe], model.start_heading[e]));
                if !sharp {
                    out.straight.push((q.edge, p.edge));
                }
            }
        }
        for &(at, site) in &model.sites[e] {
            if at >= p.a0 && at < p.a1 {
                out.sites.push((b + (at - p.a0) * rate, site));
            }
        }
        if map_matching {
            let resets = &mut out.resets;
            walk_edge(
                &model.headings[e],
                &model.intrinsic[e],
                p.a0,
                p.a1,
                c,
                &mut win,
                model.curve[e],
                |x| {
                    resets.push((b + (x - p.a0) * rate, c + x - p.a0));
                    false
                },
            );
        }
        out.pieces.push((p.edge, b, b + (p.a1 - p.a0) * rate));
        b += (p.a1 - p.a0) * rate;
        c += p.a1 - p.a0;
        prev = Some(*p);
    }
    out.resets.push((b, c));
    out.resets.sort_by(|x, y| x.0.total_cmp(&y.0));
    out.sites.sort_by(|x, y| x.0.total_cmp(&y.0));
    out
}

/// Adds the windows of a chain to `out` (keyed by their sorted site ids;
/// the longest stretch kept).
pub(crate) fn add_windows(cb: &ChainBudget, out: &mut WindowMap) {
    let mut j = 0usize;
    for (ri, w) in cb.resets.windows(2).enumerate() {
        if out.full() {
            return;
        }
        let ((b0, c0), (b1, c1)) = (w[0], w[1]);
        while j < cb.sites.len() && cb.sites[j].0 < b0 {
            j += 1;
        }
        if b1 - b0 <= 1.0 {
            continue;
        }
        let mut k = j;
        while k < cb.sites.len() && cb.sites[k].0 < b1 {
            k += 1;
        }
        let sites = &cb.sites[j..k];
        let info = WindowInfo {
            stretch_m: c1 - c0,
            at_start: ri == 0,
        };
        // Left edges: the stretch's start, then every site up to b1 − 1.
        let mut lefts: Vec<(f64, bool)> = vec![(b0, true)];
        lefts.extend(
            sites
                .iter()
                .filter(|s| s.0 <= b1 - 1.0)
                .map(|s| (s.0, false)),
        );
        // The sites are in order of position (`chain_budget` sorts them), so
        // each window's sites are a run of them, found by bisection (a scan
        // of the stretch per left edge made this quadratic in a stretch's
        // sites; without map matching a stretch is a whole chain: the
        // bisection took 9 % off the Liechtenstein plan's solve).
        let mut ids: Vec<u32> = Vec::new();
        for (a, inclusive) in lefts {
            let lo = sites.partition_point(|s| if inclusive { s.0 < a } else { s.0 <= a });
            let hi = lo + sites[lo..].partition_point(|s| s.0 <= a + 1.0);
            ids.clear();
            ids.extend(sites[lo..hi].iter().map(|s| s.1));
            ids.sort_unstable();
            ids.dedup();
            if let Some(e) = out.entry(&ids) {
                if info.stretch_m > e.stretch_m {
                    *e = info.clone();
                }
            }
        }
    }
}

/// The largest budget consumed between resets and reads on a chain with the
/// worst `k` consecutive reads missed (≤ 1: the chain holds the requirement
/// under the model).
pub(crate) fn chain_use(cb: &ChainBudget, selected: &[bool], k: usize) -> f64 {
    let mut worst = 0.0f64;
    let mut j = 0usize;
    for w in cb.resets.windows(2) {
        let (b0, b1) = (w[0].0, w[1].0);
        let mut pos: Vec<f64> = vec![b0];
        while j < cb.sites.len() && cb.sites[j].0 < b0 {
            j += 1;
        }
        let mut i = j;
        while i < cb.sites.len() && cb.sites[i].0 < b1 {
            if selected[cb.sites[i].1 as usize] {
                pos.push(cb.sites[i].0);
            }
            i += 1;
        }
        pos.push(b1);
        let n = pos.len();
        for a in 0..n - 1 {
            let to = (a + k + 1).min(n - 1);
            worst = worst.max(pos[to] - pos[a]);
        }
    }
    worst
}

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
const MAX_PATHS: usize = 256;

/// Most steps (an edge entered) from one window start. Walks that end at a
/// bend close no window and so do not count towards [`MAX_PATHS`]; where
/// the reach is long (a loose requirement) or the budget does not grow
/// (rate 0), such walks fork without end and, round a ring of straight
/// transitions, never end at all. Windows a truncated start misses are
/// left to the certification rounds, as for [`MAX_PATHS`].
pub(crate) const MAX_STEPS: usize = 1 << 16;

/// What [`straight_windows`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct WalkStats {
    /// Window starts walked from.
    pub starts: usize,
    /// Starts whose walks were cut at [`MAX_STEPS`] edges entered.
    pub cut: usize,
    /// Most edges entered from one start.
    pub most_steps: usize,
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
/// from one start; the starts cut there are counted.
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
    let mut next: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(a, b) in straight {
        next[a as usize].push(b);
    }
    // A U-turn (or hairpin) at a junction a chain made counts as one
    // everywhere.
    let observed_uturn = |a: usize, b: u32| turns_back(model, a, b as usize);
    for v in &mut next {
        v.sort_unstable();
    }
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
                let mut bend = None;
                walk_edge(
                    &model.headings[ei],
                    &model.intrinsic[ei],
                    x,
                    len + 1.0,
                    c,
                    &mut win,
                    model.curve[ei],
                    |r| {
                        bend = Some(r);
                        true
                    },
                );
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
                    }
                    paths += 1;
                    continue;
                }
                if bend.is_some() {
                    continue; // a bend resets: no window from this start here
                }
                for &nx in &next[ei] {
                    if paths + stack.len() >= MAX_PATHS {
                        break;
                    }
                    let is_u = nx & UTURN_FLAG != 0 || observed_uturn(ei, nx & !UTURN_FLAG);
                    if is_u && turned >= MAX_UTURNS {
                        continue;
                    }
                    let mut w = win.clone();
                    if is_u {
                        w.clear();
                    }
                    stack.push(Step {
                        edge: nx & !UTURN_FLAG,
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

#[cfg(test)]
mod tests {
    use super::super::turns::CURVE_M;
    use super::*;
    use crate::network::{model_from_polylines, Oneway, RoadAttributes};
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
                most_steps: MAX_STEPS
            }
        );
        assert_eq!(capped.len(), 0);
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
}
