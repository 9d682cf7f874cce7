//! What the walk DP of `traffic = "any_walk"` says beyond feasibility: the
//! budget each directed road consumes on the worst walk through it (with
//! the plan's tags all read, with k of them missed, and without tags), for
//! `coverage.geojson`; and the DP's worst walks themselves, which the
//! validation drives with their tags missed on purpose.
//!
//! Budgets are in units of the reach: 1 is the error budget the plan must
//! hold, the instance's metres divided by its reference reach.

use super::cover::{CoverEdge, CoverProblem, Dp};
use super::instance::Built;
use crate::network::{DirectedSection, Network};
use serde::Serialize;

impl<'a> Dp<'a> {
    /// The whole graph's fixed point for a selection.
    fn solved(p: &'a CoverProblem, selected: &[bool]) -> Self {
        let mut dp = Self::new(p, selected);
        let all: Vec<u32> = (0..p.nodes as u32).collect();
        dp.solve(None, &all, false);
        dp
    }

    /// The longest walk ending at node `v` with at most `j` passes (capped
    /// at R + 1).
    fn node_value(&self, v: u32, j: usize) -> f64 {
        self.at(v, j).min(self.cap)
    }
}

/// Per physical directed edge: the largest budget consumed on it by any
/// walk, with the plan's tags all read, with up to k of them missed, and
/// without tags (capped just above 1: a tag-free loop never ends).
#[derive(Debug, Clone, Default)]
pub(crate) struct WalkBudgets {
    pub all_read: Vec<f64>,
    pub missed: Vec<f64>,
    pub without: Vec<f64>,
}

/// [`WalkBudgets`] of a selection on the first `physical` edges.
pub(crate) fn walk_budgets(p: &CoverProblem, selected: &[bool], physical: usize) -> WalkBudgets {
    let r = p.reach_m.max(f64::MIN_POSITIVE);
    let with = Dp::solved(p, selected);
    let none = vec![false; selected.len()];
    let bare = Dp::solved(p, &none);
    let per = |dp: &Dp, j: usize| -> Vec<f64> {
        (0..physical as u32)
            .map(|e| dp.edge_max(e, j).0 / r)
            .collect()
    };
    WalkBudgets {
        all_read: per(&with, 0),
        missed: per(&with, p.k),
        without: per(&bare, 0),
    }
}

/// Per physical edge: the longest tag-free walk through it, in units of
/// the reach (each side of the edge capped just above 1, so a value above
/// 1 reads "more than the reach"): the longest walk ending at its tail plus
/// its length plus the longest walk starting at its head (a walk ending at
/// the head on the reversed graph); and whether a side hit its cap (the
/// value is then a lower bound).
pub(crate) fn through_budgets(p: &CoverProblem, physical: usize) -> Vec<(f64, bool)> {
    let r = p.reach_m.max(f64::MIN_POSITIVE);
    let none = vec![false; p.sites.len()];
    let fwd = Dp::solved(p, &none);
    let reversed: Vec<CoverEdge> = p
        .edges
        .iter()
        .map(|e| CoverEdge {
            tail: e.head,
            head: e.tail,
            length_m: e.length_m,
        })
        .collect();
    let Ok(rp) = CoverProblem::new(p.nodes, reversed, Vec::new(), p.reach_m, p.k) else {
        return vec![(f64::INFINITY, true); physical];
    };
    let rev = Dp::solved(&rp, &[]);
    p.edges[..physical]
        .iter()
        .map(|e| {
            let (a, b) = (fwd.node_value(e.tail, 0), rev.node_value(e.head, 0));
            let capped = a.max(b) >= p.reach_m + 1.0 - 1e-9;
            ((a + e.length_m + b) / r, capped)
        })
        .collect()
}

/// One of the walk DP's worst walks: the longest walks with at most k of
/// the plan's tags on them, ending on different roads.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignWalk {
    /// Budget consumed at its end (at most 1 in a verified plan).
    pub budget: f64,
    /// Length of the walk (m), without its lead-in.
    pub length_m: f64,
    /// Driven before the walk so that it starts as the model's walk does:
    /// just after a read, or through the turn that reset the error (m).
    pub lead_in_m: f64,
    /// The plan's tags on the walk (at most k), missed on purpose when the
    /// validation drives it.
    pub missed_tags: Vec<String>,
    /// Roads driven, in order (names, else ids; repeats merged).
    pub roads: Vec<String>,
    /// Start of the walk proper (latitude, longitude in degrees).
    pub start_lat_lon: [f64; 2],
    /// Its end.
    pub end_lat_lon: [f64; 2],
    /// Route pieces, lead-in included: directed section and offsets from
    /// the section's start in its digitised direction (from > to when
    /// driven against it).
    #[serde(skip)]
    pub pieces: Vec<(DirectedSection, f64, f64)>,
}

/// Worst walks an `any_walk` plan keeps for its validation.
pub const DESIGN_WALKS: usize = 10;

/// Lead-in before a walk that starts at a site (m of the same edge).
const LEAD_IN_M: f64 = 150.0;

/// Up to `n` of the DP's worst walks of a verified selection (at most k
/// passes each), ending on distinct directed edges and sharing at most
/// half their roads with a walk kept before, longest first; `tag_of_site` names a selected site's tag.
pub(super) fn worst_walks(
    net: &Network,
    built: &Built,
    selected: &[bool],
    n: usize,
    tag_of_site: impl Fn(u32) -> Option<String>,
) -> Vec<DesignWalk> {
    let p = &built.problem;
    let physical = built.physical_edges;
    let dp = Dp::solved(p, selected);
    let mut ends: Vec<(f64, f64, u32)> = (0..physical as u32)
        .map(|e| {
            let (v, at) = dp.edge_max(e, p.k);
            (v, at, e)
        })
        .filter(|x| x.0 > 0.0)
        .collect();
    ends.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.2.cmp(&b.2)));
    let mut used = vec![false; physical];
    let mut out = Vec::new();
    for (v, at, e) in ends {
        if out.len() >= n {
            break;
        }
        if used[e as usize] {
            continue;
        }
        // A hair shorter than the fixed point's value, so that rounding in
        // the backtrack cannot lose it.
        let need = (v - 1e-6).max(0.0);
        let Some(w) = dp.witness(None, e, at, need) else {
            continue;
        };
        // Distinct walks: most of its roads not driven by a walk kept.
        let own: Vec<u32> = w
            .pieces
            .iter()
            .map(|x| x.0)
            .filter(|&pe| (pe as usize) < physical)
            .collect();
        let seen = own.iter().filter(|&&pe| used[pe as usize]).count();
        if 2 * seen > own.len() {
            continue;
        }
        for &pe in &own {
            used[pe as usize] = true;
        }
        let to_route = |e: u32, a: f64, b: f64| -> (DirectedSection, f64, f64) {
            let (sec, fwd) = built.edge_dir[e as usize];
            let s = built.edge_scale[e as usize];
            let len = net.sections[sec as usize].length_m;
            let (a, b) = ((a / s).clamp(0.0, len), (b / s).clamp(0.0, len));
            let d = DirectedSection {
                section: sec,
                forward: fwd,
            };
            if fwd {
                (d, a, b)
            } else {
                (d, len - a, len - b)
            }
        };
        let mut pieces: Vec<(DirectedSection, f64, f64)> = w
            .pieces
            .iter()
            .filter(|x| (x.0 as usize) < physical && x.2 > x.1)
            .map(|&(pe, a, b)| to_route(pe, a, b))
            .collect();
        let Some(&(first_e, first_a, _)) = w.pieces.iter().find(|x| (x.0 as usize) < physical)
        else {
            continue;
        };
        let length_m: f64 = pieces.iter().map(|x| (x.2 - x.1).abs()).sum();
        let at_point = |d: DirectedSection, off: f64| -> [f64; 2] {
            let q = crate::route::section_points(net, d.section, off, off);
            let q = q.first().copied().unwrap_or([0.0, 0.0]);
            let g = net.frame.to_geodetic([q[0], q[1], 0.0]);
            [g.lat_deg(), g.lon_deg()]
        };
        let start_lat_lon = pieces.first().map_or([0.0; 2], |x| at_point(x.0, x.1));
        let end_lat_lon = pieces.last().map_or([0.0; 2], |x| at_point(x.0, x.2));
        // The lead-in: back along the same edge past the read that starts
        // the walk, or the road before the turn that reset the error.
        let scale = built.edge_scale[first_e as usize];
        let lead = if first_a > 1e-6 {
            let back = (first_a / scale).min(LEAD_IN_M) * scale;
            vec![to_route(first_e, first_a - back, first_a)]
        } else {
            predecessor(net, built, first_e)
                .map(|pe| {
                    let l = p.edges[pe as usize].length_m;
                    let s = built.edge_scale[pe as usize];
                    vec![to_route(pe, (l - 2.0 * LEAD_IN_M * s).max(0.0), l)]
                })
                .unwrap_or_default()
        };
        let lead_in_m: f64 = lead.iter().map(|x| (x.2 - x.1).abs()).sum();
        pieces.splice(0..0, lead);
        let mut roads: Vec<String> = Vec::new();
        for x in &pieces {
            let a = &net.roads[net.sections[x.0.section as usize].road as usize].attributes;
            let name = a.name.clone().unwrap_or_else(|| format!("road {}", a.id));
            if roads.last() != Some(&name) {
                roads.push(name);
            }
        }
        let mut missed_tags: Vec<String> = w
            .sites
            .iter()
            .filter(|&&s| selected[s as usize])
            .filter_map(|&s| tag_of_site(s))
            .collect();
        missed_tags.dedup();
        out.push(DesignWalk {
            budget: v / p.reach_m,
            length_m,
            lead_in_m,
            missed_tags,
            roads,
            start_lat_lon,
            end_lat_lon,
            pieces,
        });
    }
    out
}

/// A drivable directed road edge arriving where edge `e` departs (not its
/// own reverse): the road a walk starting at `e`'s start came from.
fn predecessor(net: &Network, built: &Built, e: u32) -> Option<u32> {
    let (sec, fwd) = built.edge_dir[e as usize];
    let from = net.topology.arrival_node(
        net,
        DirectedSection {
            section: sec,
            forward: !fwd,
        },
    );
    (0..built.physical_edges as u32).find(|&pe| {
        let (ps, pf) = built.edge_dir[pe as usize];
        ps != sec
            && net.topology.arrival_node(
                net,
                DirectedSection {
                    section: ps,
                    forward: pf,
                },
            ) == from
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::network::cover::CoverSite;

    /// A one-way line 0 → 1 → 2 → 3 of three 400 m edges, a candidate in
    /// the middle of each, reach 1000 m.
    fn line(k: usize) -> CoverProblem {
        let edges = (0..3)
            .map(|i| CoverEdge {
                tail: i,
                head: i + 1,
                length_m: 400.0,
            })
            .collect();
        let sites = (0..3)
            .map(|i| CoverSite {
                edge: i,
                at_m: 200.0,
                cost: 1.0,
                existing: false,
            })
            .collect();
        CoverProblem::new(4, edges, sites, 1000.0, k).unwrap()
    }

    #[test]
    fn budgets_on_a_line_match_hand_computed_walks() {
        // The middle tag selected, k = 0. Longest walks ending on each edge
        // (m): all read 400 | 600 (just before the tag) | 200 + 400; none
        // read 400 | 800 | 1200, capped at R + 1 m (the DP's cap: values
        // above the reach only say "more than the reach").
        let p = line(0);
        let b = walk_budgets(&p, &[false, true, false], 3);
        let close = |a: &[f64], w: [f64; 3]| a.iter().zip(w).all(|(x, y)| (x - y).abs() < 1e-9);
        assert!(close(&b.all_read, [0.4, 0.6, 0.6]), "{:?}", b.all_read);
        assert!(close(&b.without, [0.4, 0.8, 1.001]), "{:?}", b.without);
        // k = 0: missing none is the design case.
        assert!(close(&b.missed, [0.4, 0.6, 0.6]), "{:?}", b.missed);
        // With k = 1 the selected tag may be missed: the longest walk is
        // the whole line.
        let p1 = line(1);
        let b1 = walk_budgets(&p1, &[false, true, false], 3);
        assert!(close(&b1.missed, [0.4, 0.8, 1.001]), "{:?}", b1.missed);
        assert!(close(&b1.all_read, [0.4, 0.6, 0.6]), "{:?}", b1.all_read);
        // Through each edge the whole line is the longest tag-free walk.
        for (t, capped) in through_budgets(&p, 3) {
            assert!((t - 1.2).abs() < 1e-9 && !capped, "{t}");
        }
    }

    #[test]
    fn through_budgets_of_a_tag_free_loop_are_capped() {
        // A 300 m one-way loop: walks around it never end.
        let edges = (0..3)
            .map(|i| CoverEdge {
                tail: i,
                head: (i + 1) % 3,
                length_m: 100.0,
            })
            .collect();
        let p = CoverProblem::new(3, edges, Vec::new(), 1000.0, 1).unwrap();
        for (t, capped) in through_budgets(&p, 3) {
            assert!(capped && t > 2.0, "{t}");
        }
        let b = walk_budgets(&p, &[], 3);
        assert!(b.without.iter().all(|&x| x > 1.0));
    }
}
