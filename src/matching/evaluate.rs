//! Scoring a matched track against ground truth: the list of roads actually
//! driven, each with the length driven on it.
//!
//! The matched length on a road is the sum, over the runs of consecutive
//! points matched to it, of the run's extent along the road (largest minus
//! smallest offset), so jitter back and forth along a road does not inflate
//! it. Then, with M the matched and T the truth roads:
//! - precision by length = matched length on roads in T / all matched length;
//! - recall by length = Σ over roads in T of min(matched, true length) /
//!   true length in all;
//! - precision by count = |M ∩ T| / |M|; recall by count = |M ∩ T| / |T|.

use super::paths::{NetworkDistances, OnSection};
use super::track::{read_text, CsvTable};
use super::MatchedPoint;
use crate::error::{Error, Result};
use crate::network::Network;
use std::collections::BTreeMap;
use std::path::Path;

/// Length (m) by road identifier.
pub type RoadLengths = BTreeMap<String, f64>;

/// Precision and recall of a matched track.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Score {
    /// Share of matched length on true roads.
    pub precision_length: f64,
    /// Share of true length covered by matches.
    pub recall_length: f64,
    /// Share of matched roads that are true roads.
    pub precision_count: f64,
    /// Share of true roads matched.
    pub recall_count: f64,
    /// Matched length (m).
    pub matched_length_m: f64,
    /// True length (m).
    pub truth_length_m: f64,
    /// Roads matched.
    pub matched_roads: usize,
    /// True roads.
    pub truth_roads: usize,
    /// Roads both matched and true.
    pub correct_roads: usize,
}

/// Matched length by road (input identifiers) of a matched track.
///
/// Within a run of consecutive points on one road, the run's extent along
/// the road counts (a run ends where the points turn back along the road by
/// more than 15 m, so driving a road there and back counts twice). Between consecutive matched points on different roads,
/// the matched route is completed by the shortest permitted path between
/// them (searched within 200 m beyond their straight distance), and each
/// piece's length counts for its road; without such a path, half the
/// straight distance counts for each of the two roads.
pub fn matched_lengths(net: &Network, points: &[MatchedPoint]) -> RoadLengths {
    let mut paths = NetworkDistances::new(net);
    let mut out = RoadLengths::new();
    let add = |r: u32, len: f64, out: &mut RoadLengths| {
        if len > 0.0 {
            *out.entry(net.roads[r as usize].attributes.id.clone())
                .or_default() += len;
        }
    };
    let mut run: Option<(u32, f64, f64)> = None;
    let mut dir = 0i8;
    let mut prev: Option<&MatchedPoint> = None;
    for p in points {
        let Some(r) = p.road else {
            if let Some((rr, lo, hi)) = run.take() {
                add(rr, hi - lo, &mut out);
            }
            prev = None;
            continue;
        };
        let o = p.road_offset_m;
        match run {
            // A reversal of more than REVERSAL_M along the road starts a new run.
            Some((rr, lo, hi)) if rr == r && !reversed(&mut dir, lo, hi, o) => {
                run = Some((r, lo.min(o), hi.max(o)));
            }
            Some((rr, lo, hi)) if rr == r => {
                add(rr, hi - lo, &mut out);
                let turn = if dir > 0 { hi } else { lo };
                run = Some((r, turn.min(o), turn.max(o)));
                dir = -dir;
            }
            _ => {
                if let Some((rr, lo, hi)) = run {
                    add(rr, hi - lo, &mut out);
                }
                run = Some((r, o, o));
                dir = 0;
                if let (Some(q), Some(qr)) = (prev, prev.and_then(|q| q.road)) {
                    let (a, b) = (on_section(net, q), on_section(net, p));
                    let straight = (p.point[0] - q.point[0]).hypot(p.point[1] - q.point[1]);
                    match paths.path(a, b, straight + 200.0, 0.0) {
                        Some(pieces) => {
                            for (sec, from, to) in pieces {
                                add(net.sections[sec as usize].road, (to - from).abs(), &mut out);
                            }
                        }
                        None => {
                            add(qr, straight / 2.0, &mut out);
                            add(r, straight / 2.0, &mut out);
                        }
                    }
                }
            }
        }
        prev = Some(p);
    }
    if let Some((rr, lo, hi)) = run {
        add(rr, hi - lo, &mut out);
    }
    out
}

/// Backward move along a road that counts as driving back (m).
const REVERSAL_M: f64 = 15.0;

/// Has a run (extent `lo..hi`, direction `dir`: 0 unknown) reversed at offset
/// `o`? Sets the direction once the run has moved `REVERSAL_M` one way.
fn reversed(dir: &mut i8, lo: f64, hi: f64, o: f64) -> bool {
    if *dir == 0 {
        if hi - lo > REVERSAL_M {
            // The direction: towards the end the run grew from its first point.
            *dir = if o >= hi - REVERSAL_M { 1 } else { -1 };
        }
        return false;
    }
    (*dir > 0 && o < hi - REVERSAL_M) || (*dir < 0 && o > lo + REVERSAL_M)
}

fn on_section(net: &Network, p: &MatchedPoint) -> OnSection {
    let seg = &net.segments[p.segment.unwrap_or(0) as usize];
    OnSection {
        section: seg.section,
        offset_m: seg.section_offset_m + (p.road_offset_m - seg.road_offset_m),
        forward: None,
    }
}

/// Scores matched lengths against true lengths.
pub fn score(matched: &RoadLengths, truth: &RoadLengths) -> Score {
    // Sums from +0: `Iterator::sum` of no `f64` is -0.0, which printed a
    // precision of "-0.0000" when no matched road was a true one.
    let total = |it: &mut dyn Iterator<Item = f64>| it.fold(0.0, |a, x| a + x);
    let matched_length_m = total(&mut matched.values().copied());
    let truth_length_m = total(&mut truth.values().copied());
    let on_truth = total(
        &mut matched
            .iter()
            .filter(|(k, _)| truth.contains_key(*k))
            .map(|(_, v)| *v),
    );
    let covered = total(
        &mut truth
            .iter()
            .map(|(k, t)| matched.get(k).map_or(0.0, |m| m.min(*t))),
    );
    let correct = matched.keys().filter(|k| truth.contains_key(*k)).count();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    Score {
        precision_length: ratio(on_truth, matched_length_m),
        recall_length: ratio(covered, truth_length_m),
        precision_count: ratio(correct as f64, matched.len() as f64),
        recall_count: ratio(correct as f64, truth.len() as f64),
        matched_length_m,
        truth_length_m,
        matched_roads: matched.len(),
        truth_roads: truth.len(),
        correct_roads: correct,
    }
}

/// Reads TRUTH.csv: a header with `road_id` and optionally `length_m` (the
/// length driven on that road; without it, the road's whole length in the
/// map). A road listed twice has its lengths added.
pub fn read_truth(path: &Path, net: &Network) -> Result<RoadLengths> {
    let text = read_text(path, "truth file")?;
    let Some(mut table) = CsvTable::open(path, &text)? else {
        return Err(Error::table(
            path,
            1,
            "empty file: expected a header row road_id[,length_m]",
        ));
    };
    let Some(cid) = table.names.iter().position(|n| n == "road_id") else {
        return Err(Error::table(
            path,
            table.header_line,
            format!("missing column road_id (header: '{}')", table.header_text),
        ));
    };
    let clen = table.names.iter().position(|n| n == "length_m");
    let by_id: BTreeMap<&str, f64> = net
        .roads
        .iter()
        .map(|r| (r.attributes.id.as_str(), r.length_m))
        .collect();
    let mut out = RoadLengths::new();
    while let Some((line, f)) = table.next_record(path)? {
        let id = &f[cid];
        let Some(&road_len) = by_id.get(id) else {
            return Err(Error::table(
                path,
                line,
                format!("road_id '{id}' is not in the map"),
            ));
        };
        let len = match clen {
            Some(c) if !f[c].is_empty() => {
                let v: f64 = f[c].parse().map_err(|_| {
                    Error::table(path, line, format!("length_m '{}' is not a number", &f[c]))
                })?;
                if !(v.is_finite() && v >= 0.0) {
                    return Err(Error::table(
                        path,
                        line,
                        format!("length_m must be a non-negative number, got {v}"),
                    ));
                }
                if v > MAX_TRUTH_LENGTH_M {
                    return Err(Error::table(
                        path,
                        line,
                        format!(
                            "length_m {v:e} is longer than the Earth's circumference \
                             (limit {MAX_TRUTH_LENGTH_M:e} m)"
                        ),
                    ));
                }
                v
            }
            _ => road_len,
        };
        *out.entry(id.to_owned()).or_default() += len;
    }
    if out.is_empty() {
        // Nothing to score against: every figure would be 0/0.
        return Err(Error::table(
            path,
            table.header_line,
            "no data rows after the header: no road to score the path against",
        ));
    }
    Ok(out)
}

/// Largest `length_m` of a TRUTH.csv row (m): the Earth's circumference.
/// Together with the file's size limit it keeps the truth's total finite
/// (a row of 1e308 m made it infinite, and the recall by length 0).
const MAX_TRUTH_LENGTH_M: f64 = 4.0e7;

#[cfg(test)]
mod tests {
    use super::*;

    fn lengths(v: &[(&str, f64)]) -> RoadLengths {
        v.iter().map(|(k, l)| (k.to_string(), *l)).collect()
    }

    #[test]
    fn precision_and_recall_by_length_and_count() {
        let truth = lengths(&[("a", 100.0), ("b", 50.0), ("c", 50.0)]);
        // 90 m on a, 60 m on b (more than its 50), 20 m on a wrong road x; c missed.
        let matched = lengths(&[("a", 90.0), ("b", 60.0), ("x", 20.0)]);
        let s = score(&matched, &truth);
        assert!((s.precision_length - 150.0 / 170.0).abs() < 1e-12);
        assert!((s.recall_length - (90.0 + 50.0) / 200.0).abs() < 1e-12);
        assert!((s.precision_count - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.recall_count - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!((s.matched_roads, s.truth_roads, s.correct_roads), (3, 3, 2));
        // Perfect and empty.
        let p = score(&truth, &truth);
        assert_eq!((p.precision_length, p.recall_length), (1.0, 1.0));
        let e = score(&RoadLengths::new(), &truth);
        assert_eq!(
            (e.precision_length, e.recall_length, e.recall_count),
            (0.0, 0.0, 0.0)
        );
    }

    #[test]
    fn reversal_detection() {
        let mut dir = 0i8;
        assert!(!reversed(&mut dir, 0.0, 10.0, 10.0));
        assert_eq!(dir, 0);
        assert!(!reversed(&mut dir, 0.0, 20.0, 20.0));
        assert_eq!(dir, 1);
        assert!(!reversed(&mut dir, 0.0, 20.0, 8.0));
        assert!(reversed(&mut dir, 0.0, 20.0, 4.0));
    }
}
