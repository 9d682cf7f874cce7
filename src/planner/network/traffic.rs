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

use super::mm_reach::{CALIBRATION_TURNS, CALIBRATION_TURN_DEG};
pub use super::turns::CHORD_M;
use super::turns::{heading_samples, intrinsic_resets, point_at, walk_edge, TurnWindow, TURN_DEG};
use super::window_sets::{WindowInfo, WindowMap};
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::route::{next_leg_with, section_points, Landmarks, SectionPoint, DEFAULT_LANDMARKS};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
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
    /// Budget consumed per metre (1/R of the edge's class): by a
    /// calibrated vehicle where the chains have two levels
    /// ([`EdgeModel::with_levels`]), and by the straight walks.
    pub rate: Vec<f64>,
    /// Budget consumed per metre before a chain is calibrated (1/early
    /// reach); `rate` where the model has one level.
    pub early_rate: Vec<f64>,
    /// The least distance a chain drives before it is calibrated (m;
    /// `mm_reach::CALIBRATION_M`); infinite where the model has one level.
    pub calibration_m: f64,
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
            early_rate: rate.clone(),
            rate,
            calibration_m: f64::INFINITY,
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

impl EdgeModel {
    /// Two levels: a chain consumes `early_rate` per metre until it is
    /// calibrated ([`calibration_point`]) and `rate` after.
    pub fn with_levels(mut self, early_rate: Vec<f64>, calibration_m: f64) -> Self {
        debug_assert_eq!(early_rate.len(), self.rate.len());
        self.early_rate = early_rate;
        self.calibration_m = calibration_m;
        self
    }

    /// The one-level view of a two-level model: every metre at
    /// `early_rate` (the single reach).
    pub fn one_level(&self) -> Self {
        let mut m = self.clone();
        m.rate = self.early_rate.clone();
        m.calibration_m = f64::INFINITY;
        m
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

    /// The listed points, in the file's order (empty for points uniform in
    /// road length).
    pub(crate) fn points(&self) -> &[SectionPoint] {
        &self.points
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

/// Samples `n` chains with streams `stream`, in parallel, deterministic.
pub(crate) fn sample_chains(
    net: &Network,
    model: &EdgeModel,
    dest: &Destinations,
    shift_s: f64,
    seed: u64,
    stream: u64,
    n: usize,
) -> Result<Vec<Chain>> {
    sample_chains_in(net, model, dest, shift_s, seed, stream, 0..n)
}

/// The chains `range` of [`sample_chains`]' sequence (chain `i` is the same
/// whichever range holds it).
pub(crate) fn sample_chains_in(
    net: &Network,
    model: &EdgeModel,
    dest: &Destinations,
    shift_s: f64,
    seed: u64,
    stream: u64,
    range: std::ops::Range<usize>,
) -> Result<Vec<Chain>> {
    range
        .into_par_iter()
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(stream);
            rng.set_word_pos(i as u128 * (1u128 << 40));
            sample_chain(net, model, dest, shift_s, &mut rng)
        })
        .collect()
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
    /// Chainage of the chain's calibration point ([`calibration_point`];
    /// infinite without map matching or with one level).
    pub calibrated_at: f64,
}

/// Where a chain counts as calibrated (chainage m; infinite if it never
/// does, or the model has one level): at its
/// [`CALIBRATION_TURNS`]-th junction turn within [`CALIBRATION_TURN_DEG`]
/// of a right angle onto an edge whose turns reset, and not before
/// `model.calibration_m`. Bends along a road are not counted (their angle
/// is not kept), which can only delay the point.
pub(crate) fn calibration_point(model: &EdgeModel, chain: &Chain) -> f64 {
    if !model.calibration_m.is_finite() {
        return f64::INFINITY;
    }
    let (mut turns, mut c) = (0usize, 0.0f64);
    let mut prev: Option<&Piece> = None;
    for p in &chain.pieces {
        let e = p.edge as usize;
        if let Some(q) = prev {
            let qe = q.edge as usize;
            let joined = (q.a1 - model.length[qe]).abs() < 1e-6 && p.a0.abs() < 1e-6;
            let turn = turn_deg(model.end_heading[qe], model.start_heading[e]);
            if joined && model.turn_resets[e] && (turn - 90.0).abs() <= CALIBRATION_TURN_DEG {
                turns += 1;
                if turns >= CALIBRATION_TURNS {
                    return c.max(model.calibration_m);
                }
            }
        }
        c += p.a1 - p.a0;
        prev = Some(p);
    }
    f64::INFINITY
}

/// The budget view of a chain (resets at turns when `map_matching`,
/// [`super::turns`]). With two levels ([`EdgeModel::with_levels`]) the
/// budget grows at `early_rate` until [`calibration_point`], at `rate`
/// after.
pub(crate) fn chain_budget(model: &EdgeModel, chain: &Chain, map_matching: bool) -> ChainBudget {
    let mut out = ChainBudget::default();
    let (mut b, mut c) = (0.0, 0.0);
    out.resets.push((0.0, 0.0));
    let mut prev: Option<Piece> = None;
    let mut win = TurnWindow::default();
    let calibrated_at = if map_matching {
        calibration_point(model, chain)
    } else {
        f64::INFINITY
    };
    out.calibrated_at = calibrated_at;
    for p in &chain.pieces {
        let e = p.edge as usize;
        // The budget position of `x` along this piece: the early rate for
        // the `split` metres driven before calibration, the rate after (the
        // one-level model: `split` infinite, `b + d · early_rate`).
        let (r0, r1, b0) = (model.early_rate[e], model.rate[e], b);
        let split = (calibrated_at - c).max(0.0);
        let at = |x: f64| -> f64 {
            let d = x - p.a0;
            if d <= split {
                b0 + d * r0
            } else {
                b0 + split * r0 + (d - split) * r1
            }
        };
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
        for &(x, site) in &model.sites[e] {
            if x >= p.a0 && x < p.a1 {
                out.sites.push((at(x), site));
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
                    resets.push((at(x), c + x - p.a0));
                    false
                },
            );
        }
        let end = at(p.a1);
        out.pieces.push((p.edge, b, end));
        b = end;
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
    add_windows_before(cb, f64::INFINITY, true, out);
}

/// [`add_windows`] for the stretches that start before chainage `c_max`;
/// `hard` marks the windows as asked for by a source other than a chain
/// beginning ([`super::window_sets::WindowInfo::hard`]).
pub(crate) fn add_windows_before(cb: &ChainBudget, c_max: f64, hard: bool, out: &mut WindowMap) {
    let mut j = 0usize;
    for (ri, w) in cb.resets.windows(2).enumerate() {
        if out.full() {
            return;
        }
        let ((b0, c0), (b1, c1)) = (w[0], w[1]);
        if c0 >= c_max {
            return;
        }
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
            early: c0 < cb.calibrated_at,
            hard,
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
                let hard = e.hard || hard;
                if info.stretch_m > e.stretch_m {
                    *e = info.clone();
                }
                e.hard = hard;
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
