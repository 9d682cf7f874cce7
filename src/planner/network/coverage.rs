//! What a network plan predicts on each directed road piece: the largest
//! error budget consumed there by the sampled chains, by the chain
//! beginnings' stretches before calibration ([`EarlyBudgets`], two-level
//! `trips` plans) and by the straight walks
//! (`super::straight::walk_budgets`), with the plan's tags
//! all read and without any tag, as a predicted bound (the map-matching
//! reach's profile after a reset, or the straight drive's from the prior
//! without map matching), and why tags are needed there. Written as
//! `coverage.geojson` by the plan command. `any_walk` plans fill the same
//! record from the walk DP (`super::walks`), with the budget of k tags
//! missed beside it and no pass count. `budget_from` names the source of
//! the largest budget without tags.

use super::traffic::ChainBudget;
use serde::Serialize;

/// Where a piece's largest budget without tags was observed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BudgetSource {
    /// A sampled chain of trips (planning or final certification round).
    SampledChain,
    /// A chain beginning's stretch that starts before its calibration
    /// point (two-level `trips` plans, `super::cold_starts`): the early
    /// stretch of a chain not yet calibrated.
    ChainBeginning,
    /// A straight walk of the network (`traffic = "trips"`: a walk through
    /// junction transitions that do not reset, which no sampled chain need
    /// have driven).
    StraightWalk,
    /// The walk DP of an `any_walk` plan (every walk).
    AnyWalk,
}

/// One directed edge's prediction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EdgeCoverage {
    /// Directed edge index.
    pub edge: u32,
    /// Its road section and direction (digitised forward or not).
    pub section: u32,
    /// Driven in the section's digitised direction.
    pub forward: bool,
    /// Chain passes sampled over it (`trips`; `None` for `any_walk`,
    /// whose walks are every walk).
    pub passes: Option<u64>,
    /// Passes of the chain beginnings' stretches that start before their
    /// calibration point (two-level `trips` plans with beginnings; `None`
    /// otherwise), not counted in `passes`.
    pub beginning_passes: Option<u64>,
    /// Largest budget consumed since the last reset or read, tags all read
    /// (≤ 1: within the requirement under the model).
    pub budget_with_tags: f64,
    /// Largest budget consumed since the last reset, without tags.
    pub budget_without_tags: f64,
    /// Which source gave `budget_without_tags` (a tie goes to the sampled
    /// chains, then to the beginnings); `None` where no chain, beginning
    /// or walk drives here.
    pub budget_from: Option<BudgetSource>,
    /// `any_walk`: the largest budget with up to k of the plan's tags
    /// missed (the design case: ≤ 1 in a verified plan).
    pub budget_missed: Option<f64>,
    /// `any_walk`: the predicted bound with up to k tags missed (m).
    pub bound_missed_m: Option<f64>,
    /// Predicted bound there with the tags (m; `None` where no chain passed).
    pub bound_with_tags_m: Option<f64>,
    /// Predicted bound without tags (m; held at the profile's end beyond it).
    pub bound_without_tags_m: Option<f64>,
    /// Planning speed (km/h).
    pub speed_kmh: f64,
    /// Why tags are (or are not) needed here.
    pub reason: String,
}

/// The worst budget since the last event before `x`, for events sorted.
fn since(events: &[f64], x: f64) -> f64 {
    let i = events.partition_point(|&e| e < x);
    if i == 0 {
        0.0
    } else {
        x - events[i - 1]
    }
}

/// The largest budget since the last of `events` (sorted) inside the
/// piece from `b0` to `b1`: at `b1` or just before an event inside the piece.
fn worst_in(events: &[f64], b0: f64, b1: f64) -> f64 {
    let lo = events.partition_point(|&x| x <= b0);
    let hi = events.partition_point(|&x| x <= b1);
    events[lo..hi]
        .iter()
        .fold(since(events, b1), |w, &x| w.max(since(events, x)))
}

/// A chain's resets and its reads of the `selected` sites (budget
/// positions, sorted): the events after which its budget with the tags
/// read starts again.
fn read_events(cb: &ChainBudget, selected: &[bool]) -> Vec<f64> {
    let mut with: Vec<f64> = cb
        .sites
        .iter()
        .filter(|s| selected[s.1 as usize])
        .map(|s| s.0)
        .chain(cb.resets.iter().map(|r| r.0))
        .collect();
    with.sort_by(f64::total_cmp);
    with
}

/// Accumulates, per directed edge, the largest budget consumed since the
/// last reset (and read, for `selected`).
pub(crate) fn edge_budgets(
    chains: &[ChainBudget],
    selected: &[bool],
    n_edges: usize,
) -> Vec<EdgeCoverage> {
    let mut out: Vec<EdgeCoverage> = (0..n_edges)
        .map(|e| EdgeCoverage {
            edge: e as u32,
            section: 0,
            forward: true,
            passes: Some(0),
            beginning_passes: None,
            budget_with_tags: 0.0,
            budget_without_tags: 0.0,
            budget_from: None,
            budget_missed: None,
            bound_missed_m: None,
            bound_with_tags_m: None,
            bound_without_tags_m: None,
            speed_kmh: 0.0,
            reason: String::new(),
        })
        .collect();
    for cb in chains {
        let resets: Vec<f64> = cb.resets.iter().map(|r| r.0).collect();
        let with = read_events(cb, selected);
        for &(e, b0, b1) in &cb.pieces {
            let o = &mut out[e as usize];
            *o.passes.get_or_insert(0) += 1;
            o.budget_with_tags = o.budget_with_tags.max(worst_in(&with, b0, b1));
            o.budget_without_tags = o.budget_without_tags.max(worst_in(&resets, b0, b1));
            o.budget_from = Some(BudgetSource::SampledChain);
        }
    }
    out
}

/// What the coverage map keeps of the chain beginnings
/// (`super::cold_starts`): their stretches that start before their
/// calibration point, the ones the beginnings add to the planning windows.
/// Per directed edge, the passes and the largest budget without tags of
/// every beginning; the budgets themselves (cut after those stretches,
/// [`early_part`]) only of the beginnings with such a stretch over the
/// budget without tags, for their budget with the tags read once the tags
/// are chosen. A beginning within the budget before calibration needs no
/// tag there, and its budget with tags is at most its budget without
/// (≤ 1): it is not computed. Memory: two numbers per directed edge and,
/// on Gothenburg's trips plan, the early parts of 547 of 3,696 beginnings
/// (52 k pieces, 127 k site passes, 121 k resets: about 5 MB).
#[derive(Debug, Clone, Default)]
pub(crate) struct EarlyBudgets {
    /// Per directed edge: passes of the beginnings' early stretches.
    pub passes: Vec<u64>,
    /// Per directed edge: their largest budget without tags.
    pub without: Vec<f64>,
    /// The early parts of the beginnings over the budget before
    /// calibration, in the beginnings' order.
    pub over: Vec<ChainBudget>,
}

/// The part of a chain's budget up to the end of its last stretch that
/// starts before its calibration point (the whole chain if it never
/// calibrates): its resets up to that end, its site passes before it and
/// its pieces cut there. Its straight transitions are dropped (the
/// coverage does not walk from them).
pub(crate) fn early_part(cb: &ChainBudget) -> ChainBudget {
    // The first reset at or past the calibration point ends the last early
    // stretch (resets are in order of budget position and of chainage).
    let j = cb
        .resets
        .iter()
        .position(|r| r.1 >= cb.calibrated_at)
        .unwrap_or(cb.resets.len().saturating_sub(1));
    let end = cb.resets.get(j).map_or(0.0, |r| r.0);
    ChainBudget {
        resets: cb.resets[..(j + 1).min(cb.resets.len())].to_vec(),
        sites: cb.sites.iter().filter(|s| s.0 < end).copied().collect(),
        pieces: cb
            .pieces
            .iter()
            .filter(|p| p.1 < end)
            .map(|&(e, b0, b1)| (e, b0, b1.min(end)))
            .collect(),
        straight: Vec::new(),
        calibrated_at: cb.calibrated_at,
    }
}

impl EarlyBudgets {
    /// Empty, for `n_edges` directed edges.
    pub(crate) fn new(n_edges: usize) -> Self {
        EarlyBudgets {
            passes: vec![0; n_edges],
            without: vec![0.0; n_edges],
            over: Vec::new(),
        }
    }

    /// Adds a beginning's budget: its stretches that start before its
    /// calibration point, kept whole if one of them is over the budget
    /// (`over`, as `super::cold_starts` counts it).
    pub(crate) fn add(&mut self, cb: &ChainBudget, over: bool) {
        let early = early_part(cb);
        let resets: Vec<f64> = early.resets.iter().map(|r| r.0).collect();
        for &(e, b0, b1) in &early.pieces {
            let e = e as usize;
            self.passes[e] += 1;
            self.without[e] = self.without[e].max(worst_in(&resets, b0, b1));
        }
        if over {
            self.over.push(early);
        }
    }
}

/// Adds the chain beginnings' early stretches to the chains' record in
/// `out`: their passes, their largest budget without tags (a piece whose
/// largest is a beginning's, or which only beginnings drive, gets
/// `budget_from` = chain beginning; a tie goes to the sampled chains) and
/// with the `selected` tags read (the beginnings over the budget).
pub(crate) fn add_early_budgets(out: &mut [EdgeCoverage], early: &EarlyBudgets, selected: &[bool]) {
    for cb in &early.over {
        let with = read_events(cb, selected);
        for &(e, b0, b1) in &cb.pieces {
            let o = &mut out[e as usize];
            o.budget_with_tags = o.budget_with_tags.max(worst_in(&with, b0, b1));
        }
    }
    for (o, (&n, &wo)) in out.iter_mut().zip(early.passes.iter().zip(&early.without)) {
        if n == 0 {
            continue;
        }
        o.beginning_passes = Some(n);
        if wo > o.budget_without_tags || o.budget_from.is_none() {
            o.budget_from = Some(BudgetSource::ChainBeginning);
        }
        o.budget_without_tags = o.budget_without_tags.max(wo);
    }
}

/// Adds the straight walks' budgets per edge, with the tags read (`with`)
/// and without (`without`; `super::straight::walk_budgets`), to the
/// chains' in `out`: the larger of each is kept, and a piece whose largest
/// budget without tags is a walk's gets `budget_from` = straight walk.
/// A walk's budget since a read is also one since its reset (the walk
/// came from one; a walk without tags may have stopped at its cap before
/// the edge): the budget without tags is at least the one with them.
/// Edges no walk entered (budget 0 both ways) keep the chains' record.
pub(crate) fn add_walk_budgets(out: &mut [EdgeCoverage], with: &[f64], without: &[f64]) {
    for (o, (&w, &wo)) in out.iter_mut().zip(with.iter().zip(without)) {
        let wo = wo.max(w);
        if wo > o.budget_without_tags || (o.budget_from.is_none() && wo > 0.0) {
            o.budget_from = Some(BudgetSource::StraightWalk);
        }
        o.budget_without_tags = o.budget_without_tags.max(wo);
        o.budget_with_tags = o.budget_with_tags.max(w);
    }
}

/// Rounds to `d` decimals for the file (GIS tools need no more).
fn round(x: f64, d: i32) -> f64 {
    let f = 10f64.powi(d);
    (x * f).round() / f
}

/// `coverage.geojson`: a LineString per directed road piece, in driving
/// order, with its predicted bound with and without the plan's tags, its
/// speed class, the sampled passes and why tags are (or are not) needed.
/// Written a feature at a time: the whole collection as one JSON value
/// held ~0.2 GB at the end of a Gothenburg plan, its peak memory
/// (BENCHMARKS.md). The text is what `serde_json::to_string` makes of the
/// collection (keys in order: "features", then "type").
pub fn coverage_geojson(cov: &[EdgeCoverage], net: &crate::network::Network) -> String {
    let mut out: Vec<u8> = b"{\"features\":[".to_vec();
    let mut first = true;
    for c in cov {
        let Some(sec) = net.sections.get(c.section as usize) else {
            continue;
        };
        let a = &net.roads[sec.road as usize].attributes;
        let (from, to) = if c.forward {
            (0.0, sec.length_m)
        } else {
            (sec.length_m, 0.0)
        };
        let coords: Vec<[f64; 2]> = crate::route::section_points(net, c.section, from, to)
            .iter()
            .map(|p| {
                let g = net.frame.to_geodetic([p[0], p[1], 0.0]);
                [round(g.lon_deg(), 7), round(g.lat_deg(), 7)]
            })
            .collect();
        let opt = |x: Option<f64>| x.map(|v| round(v, 2));
        let feature = serde_json::json!({
            "type": "Feature",
            "geometry": { "type": "LineString", "coordinates": coords },
            "properties": {
                "road_id": a.id,
                "road_name": a.name,
                "highway": a.highway,
                "direction": if c.forward { "forward" } else { "backward" },
                "tunnel": a.tunnel,
                "length_m": round(sec.length_m, 1),
                "speed_kmh": round(c.speed_kmh, 1),
                "passes": c.passes,
                "beginning_passes": c.beginning_passes,
                "budget_with_tags": round(c.budget_with_tags, 3),
                "budget_without_tags": round(c.budget_without_tags, 3),
                "budget_from": c.budget_from,
                "bound_m": opt(c.bound_with_tags_m),
                "bound_without_tags_m": opt(c.bound_without_tags_m),
                "budget_missed": c.budget_missed.map(|b| round(b, 3)),
                "bound_missed_m": opt(c.bound_missed_m),
                "reason": c.reason,
            }
        });
        if !first {
            out.push(b',');
        }
        first = false;
        if serde_json::to_writer(&mut out, &feature).is_err() {
            return String::new();
        }
    }
    out.extend_from_slice(b"],\"type\":\"FeatureCollection\"}");
    String::from_utf8(out).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A random chain budget: pieces on edges 0..4 back to back, resets
    /// (budget position, chainage 1000 × position) and sites along it, and
    /// a calibration point anywhere (or none).
    fn random_budget(rng: &mut rand_chacha::ChaCha8Rng) -> ChainBudget {
        let mut cb = ChainBudget::default();
        let mut b = 0.0f64;
        while b < 6.0 {
            let l = rng.random_range(0.1..0.9);
            cb.pieces.push((rng.random_range(0..4u32), b, b + l));
            b += l;
        }
        cb.resets.push((0.0, 0.0));
        let mut r = 0.0f64;
        loop {
            r += [0.4, 1.3, 2.5][rng.random_range(0..3)] * rng.random_range(0.5..1.5);
            if r >= b {
                break;
            }
            cb.resets.push((r, 1000.0 * r));
        }
        cb.resets.push((b, 1000.0 * b));
        let mut x = rng.random_range(0.0..0.3);
        while x < b {
            cb.sites.push((x, rng.random_range(0..8u32)));
            x += rng.random_range(0.05..0.6);
        }
        cb.calibrated_at = if rng.random_bool(0.2) {
            f64::INFINITY
        } else {
            1000.0 * b * rng.random_range(-0.1..1.1)
        };
        cb
    }

    /// The reference on a fine grid: a point belongs to the stretch between
    /// the resets around it, early if that stretch starts before the
    /// calibration point; its budget is the distance back to the last reset
    /// (or read of a selected site, with tags) before it.
    fn by_grid(cb: &ChainBudget, selected: &[bool]) -> (Vec<u64>, Vec<f64>, Vec<f64>) {
        let (mut passes, mut without, mut with) = (vec![0u64; 4], vec![0.0; 4], vec![0.0; 4]);
        let early_at = |x: f64| {
            let i = cb.resets.iter().rposition(|r| r.0 < x).unwrap_or(0);
            cb.resets[i].1 < cb.calibrated_at
        };
        for &(e, b0, b1) in &cb.pieces {
            let e = e as usize;
            let n = 2000;
            let xs = (1..=n).map(|i| b0 + (b1 - b0) * i as f64 / n as f64);
            let mut any = false;
            for x in xs.filter(|&x| early_at(x)) {
                any = true;
                let last_reset = cb
                    .resets
                    .iter()
                    .rev()
                    .find(|r| r.0 < x)
                    .map_or(0.0, |r| r.0);
                let last_read = cb
                    .sites
                    .iter()
                    .rev()
                    .find(|s| s.0 < x && selected[s.1 as usize])
                    .map_or(0.0, |s| s.0);
                without[e] = f64::max(without[e], x - last_reset);
                with[e] = f64::max(with[e], x - last_reset.max(last_read));
            }
            // A piece that starts in an early stretch is one pass.
            if any || early_at(b0 + 1e-12) {
                passes[e] += 1;
            }
        }
        (passes, without, with)
    }

    #[test]
    fn the_beginnings_coverage_is_their_budget_up_to_the_end_of_their_early_stretches() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
        for case in 0..300 {
            let cb = random_budget(&mut rng);
            let selected: Vec<bool> = (0..8).map(|_| rng.random_bool(0.5)).collect();
            let over = cb
                .resets
                .windows(2)
                .any(|w| w[0].1 < cb.calibrated_at && w[1].0 - w[0].0 > 1.0);
            let mut early = EarlyBudgets::new(4);
            early.add(&cb, over);
            assert_eq!(early.over.len(), usize::from(over));
            // Added to an empty record: what the beginning alone gives.
            let mut out = edge_budgets(&[], &selected, 4);
            add_early_budgets(&mut out, &early, &selected);
            let (passes, without, with) = by_grid(&cb, &selected);
            let tol = 6.0 / 2000.0 + 1e-12;
            for e in 0..4 {
                let o = &out[e];
                assert_eq!(
                    o.beginning_passes.unwrap_or(0),
                    passes[e],
                    "case {case} edge {e}"
                );
                assert!(
                    (o.budget_without_tags - without[e]).abs() <= tol,
                    "case {case} edge {e}: {o:?} {without:?}"
                );
                if over {
                    assert!(
                        (o.budget_with_tags - with[e]).abs() <= tol,
                        "case {case} edge {e}: {o:?} {with:?}"
                    );
                } else {
                    // Not kept: within the budget without tags, so with them.
                    assert_eq!(o.budget_with_tags, 0.0);
                    assert!(without[e] <= 1.0 + tol);
                }
                let from = (passes[e] > 0).then_some(BudgetSource::ChainBeginning);
                assert_eq!(o.budget_from, from, "case {case} edge {e}");
            }
        }
    }

    #[test]
    fn a_tie_between_a_sampled_chain_and_a_beginning_goes_to_the_chain() {
        let cb = ChainBudget {
            resets: vec![(0.0, 0.0), (2.0, 2000.0)],
            pieces: vec![(0, 0.0, 1.5), (1, 1.5, 2.0)],
            calibrated_at: f64::INFINITY,
            ..ChainBudget::default()
        };
        let mut early = EarlyBudgets::new(2);
        early.add(&cb, true);
        let mut out = edge_budgets(std::slice::from_ref(&cb), &[], 2);
        add_early_budgets(&mut out, &early, &[]);
        assert_eq!(out[1].budget_from, Some(BudgetSource::SampledChain));
        assert_eq!((out[1].passes, out[1].beginning_passes), (Some(1), Some(1)));
        assert_eq!(out[1].budget_without_tags, 2.0);
        // Calibrated where it starts: no stretch starts before the point.
        let late = ChainBudget {
            calibrated_at: 0.0,
            ..cb.clone()
        };
        let mut early = EarlyBudgets::new(2);
        early.add(&late, false);
        assert_eq!(early.passes, vec![0, 0]);
    }
}
