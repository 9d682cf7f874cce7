//! What a network plan predicts on each directed road piece: the largest
//! error budget consumed there by the sampled chains and by the straight
//! walks (`super::straight::walk_budgets`), with the plan's tags
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
    /// Largest budget consumed since the last reset or read, tags all read
    /// (≤ 1: within the requirement under the model).
    pub budget_with_tags: f64,
    /// Largest budget consumed since the last reset, without tags.
    pub budget_without_tags: f64,
    /// Which source gave `budget_without_tags` (a tie goes to the sampled
    /// chains); `None` where neither a chain nor a walk drives here.
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
        let mut with: Vec<f64> = cb
            .sites
            .iter()
            .filter(|s| selected[s.1 as usize])
            .map(|s| s.0)
            .chain(resets.iter().copied())
            .collect();
        with.sort_by(f64::total_cmp);
        for &(e, b0, b1) in &cb.pieces {
            let o = &mut out[e as usize];
            *o.passes.get_or_insert(0) += 1;
            // The largest value inside [b0, b1] is at b1 or just before an
            // event inside the piece.
            let mut w = since(&with, b1);
            let lo = with.partition_point(|&x| x <= b0);
            let hi = with.partition_point(|&x| x <= b1);
            for &x in &with[lo..hi] {
                w = w.max(since(&with, x));
            }
            let mut wo = since(&resets, b1);
            let lo = resets.partition_point(|&x| x <= b0);
            let hi = resets.partition_point(|&x| x <= b1);
            for &x in &resets[lo..hi] {
                wo = wo.max(since(&resets, x));
            }
            o.budget_with_tags = o.budget_with_tags.max(w);
            o.budget_without_tags = o.budget_without_tags.max(wo);
            o.budget_from = Some(BudgetSource::SampledChain);
        }
    }
    out
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
