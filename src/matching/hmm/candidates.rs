//! Candidates of a fix: the nearest point of each section within the search
//! radius, one state per permitted direction, ranked by emission.

use super::drift::{emission, emission_log_p_with, Drift, Line};
use super::geometry::directed_cos_sc;
use super::matcher::HmmMatcher;
use super::state::{Cand, Step};
use crate::matching::paths::OnSection;
use crate::matching::{project, Fix};
use crate::network::{Network, SectionId, SegmentId};

/// Does a drift have the prior's isotropic covariance (the same variance
/// across every road, so the emission's log term repeats:
/// [`super::drift::LnCache`])?
#[inline]
fn isotropic(d: &Drift) -> bool {
    d.cov[1] == 0.0 && d.cov[0] == d.cov[2]
}

/// The candidates' ranking: emission (with the heading's part) down, ties
/// by the key's code (the order found) up. A total order: a sorted list of
/// keys is the same whatever the algorithm.
#[inline]
fn key_order(a: &(f64, u32), b: &(f64, u32)) -> std::cmp::Ordering {
    b.0.total_cmp(&a.0).then(a.1.cmp(&b.1))
}

/// Keys sorted whole by insertion on packed integers, from `PACKED_FROM`
/// to `INSERTION_KEYS` of them: fewer instructions than the standard
/// sort (after a selection when more than `k`) at the FMM example's 9-16
/// keys per fix, more below (its fixed cost) and above (measured).
const PACKED_FROM: usize = 9;
const INSERTION_KEYS: usize = 16;

/// A key as one integer whose ascending order is [`key_order`]: the
/// emission's bits mapped as [`f64::total_cmp`] orders them, inverted (so
/// the largest comes first), above the code.
#[inline]
fn pack_key((em, code): (f64, u32)) -> u128 {
    let l = em.to_bits() as i64;
    let l = l ^ ((((l >> 63) as u64) >> 1) as i64);
    let ascending = (l as u64) ^ (1 << 63);
    (u128::from(!ascending) << 32) | u128::from(code)
}

/// [`pack_key`]'s inverse (the emission's bits restored exactly).
#[inline]
fn unpack_key(p: u128) -> (f64, u32) {
    let l = (!((p >> 32) as u64) ^ (1 << 63)) as i64;
    let bits = l ^ ((((l >> 63) as u64) >> 1) as i64);
    (f64::from_bits(bits as u64), p as u32)
}

/// The best `k` (at least 1, at most `keys.len()`) of `keys`, in
/// [`key_order`]: a few sorted whole by insertion on [`pack_key`]'s
/// integers, more selected first, then sorted (the same list either way,
/// the order being total).
#[inline]
fn best_keys(keys: &mut Vec<(f64, u32)>, k: usize) {
    if (PACKED_FROM..=INSERTION_KEYS).contains(&keys.len()) {
        let mut packed = [0u128; INSERTION_KEYS];
        let n = keys.len();
        for (i, &key) in keys.iter().enumerate() {
            let x = pack_key(key);
            let mut j = i;
            while j > 0 && x < packed[j - 1] {
                packed[j] = packed[j - 1];
                j -= 1;
            }
            packed[j] = x;
        }
        for (key, &p) in keys.iter_mut().zip(&packed[..n]) {
            *key = unpack_key(p);
        }
        keys.truncate(k);
        return;
    }
    if keys.len() > k {
        keys.select_nth_unstable_by(k - 1, key_order);
        keys.truncate(k);
    }
    keys.sort_unstable_by(key_order);
}

/// A section not in the nearest list.
const NOT_LISTED: u32 = u32::MAX;

/// The nearest segment of each section: (section, segment, distance, t),
/// in the order the sections are first found; a nearer segment of a
/// section found later replaces the earlier one in place. `slot` holds each
/// listed section's index (a look-up instead of a scan of the list).
#[inline]
fn note_nearest(
    nearest: &mut Vec<(SectionId, SegmentId, f64, f64)>,
    slot: &mut [u32],
    net: &Network,
    seg: SegmentId,
    t: f64,
    dist: f64,
) {
    let section = net.segments[seg as usize].section;
    let at = &mut slot[section as usize];
    if *at == NOT_LISTED {
        *at = nearest.len() as u32;
        nearest.push((section, seg, dist, t));
    } else {
        let n = &mut nearest[*at as usize];
        if dist < n.2 {
            *n = (section, seg, dist, t);
        }
    }
}

/// A section's heading terms, κ (cos − 1), forward and backward: 0
/// without a heading. The backward cosine is the forward one negated, as
/// [`directed_cos_sc`] gives it (its 0 for a zero-length segment and a
/// negated 0 give the same term), so the cosine is taken once.
#[inline]
fn heading_terms(net: &Network, seg: SegmentId, heading: Option<((f64, f64), f64)>) -> (f64, f64) {
    match heading {
        Some((sc, kappa)) => {
            let c = directed_cos_sc(net, seg, sc, true);
            (kappa * (c - 1.0), kappa * (-c - 1.0))
        }
        None => (0.0, 0.0),
    }
}

impl HmmMatcher<'_> {
    /// Candidates of a fix into `cands`, placed and ranked with the drift `d`.
    ///
    /// Ranked on small keys, built once: each section's nearest segment
    /// gives its emission and, per permitted direction, a key (emission
    /// with the heading's part, the candidate's place in the order found);
    /// only the best `max_candidates` keys become [`Cand`]s. Without a
    /// drift mean (the independent model, and a chain's start) the radius
    /// query hands over the closest point and the distance it computed.
    /// The same candidates, in the same order, with the same numbers as
    /// building every candidate first (tested against that below).
    #[inline(never)]
    pub(super) fn candidates(
        &mut self,
        fix: &Fix,
        heading: Option<(f64, f64)>,
        d: &Drift,
        cands: &mut Vec<Cand>,
    ) {
        let net = self.net;
        cands.clear();
        let r2 = self.params.sigma_m * self.params.sigma_m;
        let corrected = [fix.enu[0] - d.mean[0], fix.enu[1] - d.mean[1]];
        // The nearest segment of each section to the fix less the drift.
        let mut nearest = std::mem::take(&mut self.near_buf);
        nearest.clear();
        let mut slot = std::mem::take(&mut self.near_slot);
        if slot.len() != net.sections.len() {
            slot.clear();
            slot.resize(net.sections.len(), NOT_LISTED);
        }
        if corrected[0].to_bits() == fix.enu[0].to_bits()
            && corrected[1].to_bits() == fix.enu[1].to_bits()
        {
            net.grid
                .for_each_within(fix.enu, self.params.search_radius_m, |seg, t, dist| {
                    note_nearest(&mut nearest, &mut slot, net, seg, t, dist);
                });
        } else {
            self.seg_buf.clear();
            net.grid
                .within_radius_into(fix.enu, self.params.search_radius_m, &mut self.seg_buf);
            for &seg in &self.seg_buf {
                let (t, _, dist) = project(net, seg, corrected);
                note_nearest(&mut nearest, &mut slot, net, seg, t, dist);
            }
        }
        for n in &nearest {
            slot[n.0 as usize] = NOT_LISTED;
        }
        // The heading's unit vector once per fix.
        let heading = heading.map(|(h, kappa)| (h.sin_cos(), kappa));
        let iso = isotropic(d);
        // Keys: (emission, 2 × index in `nearest` + 1 for the backward
        // direction), which orders ties as building every candidate in
        // turn (sections in the order found, forward first) did.
        let mut keys = std::mem::take(&mut self.key_buf);
        keys.clear();
        let mut lines = std::mem::take(&mut self.near_lines);
        lines.clear();
        self.rank_drift = *d;
        for (j, &(section, seg, _, _)) in nearest.iter().enumerate() {
            let line = Line::of(net, seg);
            let base = if iso {
                let cache = &mut self.ln_cache;
                emission_log_p_with(&line, fix.enu, d, r2, |x| cache.ln(x))
            } else {
                emission(&line, fix.enu, d, r2).log_p
            };
            let oneway = net.sections[section as usize].oneway;
            let (hf, hb) = heading_terms(net, seg, heading);
            // One state per permitted direction of the section.
            if oneway.allows_forward() {
                keys.push((base + hf, 2 * j as u32));
            }
            if oneway.allows_backward() {
                keys.push((base + hb, 2 * j as u32 + 1));
            }
            lines.push((line, hf, hb, base));
        }
        // The best `max_candidates` by emission, ties in the order found (a
        // total order, so the selection does not depend on the sorting
        // algorithm).
        let k = self.params.max_candidates.min(keys.len());
        if k > 0 {
            best_keys(&mut keys, k);
            // Far less likely than the best: dropped (`min_emission_ratio`).
            // The ratio is taken within [0, 1] (NaN as 0), so the best is
            // always kept and a ratio out of range never empties the set.
            let ratio = self.params.min_emission_ratio;
            let ratio = if ratio.is_nan() {
                0.0
            } else {
                ratio.clamp(0.0, 1.0)
            };
            let floor = keys[0].0 + self.ln_cache.ln(ratio);
            let kept = keys.partition_point(|k| k.0 >= floor);
            keys.truncate(kept);
            for &(em, code) in &keys {
                let j = (code >> 1) as usize;
                let (section, seg, _, t) = nearest[j];
                let (line, hf, hb, _) = lines[j];
                let forward = code & 1 == 0;
                let s = &net.segments[seg as usize];
                let sign = if forward { 1.0 } else { -1.0 };
                cands.push(Cand {
                    seg,
                    line,
                    at: OnSection {
                        section,
                        offset_m: s.section_offset_m + t * s.length_m,
                        forward: Some(forward),
                    },
                    emission: em,
                    heading: if forward { hf } else { hb },
                    dir: [sign * line.u[0], sign * line.u[1]],
                    anchor_dir: [0.0; 2],
                    anchor_m: 0.0,
                    road: s.road,
                    anchor_road: s.road,
                    drift: *d,
                });
            }
        }
        self.near_buf = nearest;
        self.key_buf = keys;
        self.near_slot = slot;
        self.near_lines = lines;
    }

    pub(super) fn new_step(&mut self, index: u64, fix: Fix) -> Step {
        match self.spare.pop() {
            Some(mut s) => {
                s.index = index;
                s.fix = fix;
                s.cands.clear();
                s.score.clear();
                s.back.clear();
                s.alpha.clear();
                s.pair.clear();
                s.pending.clear();
                s
            }
            None => Step {
                index,
                fix,
                cands: Vec::with_capacity(self.params.max_candidates),
                score: Vec::with_capacity(self.params.max_candidates),
                back: Vec::with_capacity(self.params.max_candidates),
                alpha: Vec::with_capacity(self.params.max_candidates),
                pair: Vec::with_capacity(self.params.max_candidates * self.params.max_candidates),
                pending: Vec::new(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{HmmMatcher, HmmParams};
    use super::*;

    /// The candidates as built before ranking on keys: every section's
    /// nearest segment projected again, every candidate built in full, the
    /// best selected and copied (the former code, kept as the reference).
    fn candidates_reference(
        m: &mut HmmMatcher,
        fix: &Fix,
        heading: Option<(f64, f64)>,
        d: &Drift,
    ) -> Vec<Cand> {
        use crate::matching::hmm::geometry::directed_cos;
        let net = m.net;
        let mut cands = Vec::new();
        let seg_buf = net.grid.within_radius(fix.enu, m.params.search_radius_m);
        let r2 = m.params.sigma_m * m.params.sigma_m;
        let corrected = [fix.enu[0] - d.mean[0], fix.enu[1] - d.mean[1]];
        let mut nearest: Vec<(SectionId, SegmentId, f64, f64)> = Vec::new();
        for &seg in &seg_buf {
            let (t, _, dist) = project(net, seg, corrected);
            let section = net.segments[seg as usize].section;
            match nearest.iter_mut().find(|n| n.0 == section) {
                Some(n) => {
                    if dist < n.2 {
                        *n = (section, seg, dist, t);
                    }
                }
                None => nearest.push((section, seg, dist, t)),
            }
        }
        for &(section, seg, _, t) in &nearest {
            let s = &net.segments[seg as usize];
            let line = Line::of(net, seg);
            let base = emission(&line, fix.enu, d, r2).log_p;
            let offset_m = s.section_offset_m + t * s.length_m;
            let oneway = net.sections[section as usize].oneway;
            for forward in [true, false] {
                if !(if forward {
                    oneway.allows_forward()
                } else {
                    oneway.allows_backward()
                }) {
                    continue;
                }
                let h = match heading {
                    Some((h, kappa)) => kappa * (directed_cos(net, seg, h, forward) - 1.0),
                    None => 0.0,
                };
                let sign = if forward { 1.0 } else { -1.0 };
                cands.push(Cand {
                    seg,
                    line,
                    at: OnSection {
                        section,
                        offset_m,
                        forward: Some(forward),
                    },
                    emission: base + h,
                    heading: h,
                    dir: [sign * line.u[0], sign * line.u[1]],
                    anchor_dir: [0.0; 2],
                    anchor_m: 0.0,
                    road: s.road,
                    anchor_road: s.road,
                    drift: *d,
                });
            }
        }
        let order = |a: &(f64, u32), b: &(f64, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
        let mut keys: Vec<(f64, u32)> = cands
            .iter()
            .enumerate()
            .map(|(i, c)| (c.emission, i as u32))
            .collect();
        let k = m.params.max_candidates.min(keys.len());
        if k == 0 {
            return Vec::new();
        }
        if keys.len() > k {
            keys.select_nth_unstable_by(k - 1, order);
            keys.truncate(k);
        }
        keys.sort_unstable_by(order);
        let ratio = m.params.min_emission_ratio;
        let ratio = if ratio.is_nan() {
            0.0
        } else {
            ratio.clamp(0.0, 1.0)
        };
        let floor = keys[0].0 + ratio.ln();
        let kept = keys.partition_point(|k| k.0 >= floor);
        keys.truncate(kept);
        keys.iter().map(|&(_, i)| cands[i as usize]).collect()
    }

    /// Ranking on keys and building the kept candidates only (with the
    /// radius query's own projection, the heading's `sin_cos` once per fix
    /// and the cached logarithms) gives the reference's candidates, in the
    /// same order, every number bit for bit (compared by their `Debug`
    /// text, which tells every two `f64` apart): on the real maps and a
    /// bundled one, fixes on a lattice over and beyond each map (up to
    /// half its box each side) and on and beside up to 200 nodes of each
    /// (junctions: several sections' nearest point is the same node, and
    /// keys of different sections tie, so their order is the order found),
    /// with and without a heading, under the
    /// prior (the independent model, a chain's start) and under drifts
    /// with a mean and an anisotropic covariance (the drift model), with
    /// both models' candidate caps and several radii and ratios.
    #[test]
    fn ranking_on_keys_gives_the_reference_candidates() {
        let (mut fixes, mut found, mut capped, mut tied) = (0usize, 0usize, 0usize, 0usize);
        for (map, net) in crate::network::fixtures::query_maps() {
            // A lattice over and beyond the map (up to half its box each
            // side), and every node (where several sections' nearest point
            // is the same node) with a point 0.7 m off it.
            let mut points = crate::network::fixtures::lattice(&net, 24, 0.5, [0.13, -0.29]);
            for node in net.nodes.iter().step_by(net.nodes.len().div_ceil(200)) {
                points.push(node.enu);
                points.push([node.enu[0] + 0.7, node.enu[1] - 0.7]);
            }
            let drifts = [
                Drift::prior(19.4),
                Drift::prior(7.3),
                Drift {
                    mean: [4.5, -2.25],
                    cov: [30.0, 6.5, 120.0],
                },
                Drift {
                    mean: [0.0, 0.0],
                    cov: [50.0, -3.0, 20.0],
                },
            ];
            for (pi, (radius, max_c, ratio)) in [
                (279.0, 8, 1e-6),
                (100.0, 10, 1e-6),
                (50.0, 8, 0.0),
                (300.0, 1000, 0.5),
            ]
            .into_iter()
            .enumerate()
            {
                let params = HmmParams {
                    search_radius_m: radius,
                    max_candidates: max_c,
                    min_emission_ratio: ratio,
                    sigma_m: 4.0 + pi as f64,
                    ..HmmParams::default()
                };
                let mut fast = HmmMatcher::new(&net, params);
                let mut slow = HmmMatcher::new(&net, params);
                let mut got = Vec::new();
                for (n, &p) in points.iter().enumerate() {
                    let fix = Fix {
                        t_s: 0.0,
                        enu: p,
                        heading_rad: None,
                    };
                    let d = &drifts[n % drifts.len()];
                    let heading = match n % 3 {
                        0 => None,
                        1 => Some((0.1 * n as f64, 2.0)),
                        _ => Some((-0.37 * n as f64, 0.5)),
                    };
                    fast.candidates(&fix, heading, d, &mut got);
                    let want = candidates_reference(&mut slow, &fix, heading, d);
                    assert_eq!(format!("{got:?}"), format!("{want:?}"), "{map} {p:?} {pi}");
                    fixes += 1;
                    found += usize::from(!got.is_empty());
                    capped += usize::from(got.len() == max_c);
                    // Equal keys of different sections: their order is the
                    // order the sections were found in.
                    tied += usize::from(got.windows(2).any(|w| {
                        w[0].emission.to_bits() == w[1].emission.to_bits()
                            && w[0].at.section != w[1].at.section
                    }));
                }
            }
        }
        println!("{fixes} fixes, {found} with candidates, {capped} capped, {tied} with tied keys");
        assert!(
            fixes >= 10_000 && found > 2000 && fixes - found > 1000 && capped > 50 && tied > 50,
            "{fixes} {found} {capped} {tied}"
        );
    }

    /// The best `k` keys by insertion (a few) or selection (more) are the
    /// best `k` of the whole list sorted, in order: random lists of 1-40
    /// keys from a few values (many ties, broken by the code), with −0,
    /// +0, infinities and NaNs of both signs, every `k`.
    #[test]
    fn best_keys_are_the_sorted_lists_head() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
        let values = [
            -3.5,
            -1.0,
            -0.0,
            0.0,
            2.25,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        let mut checked = 0;
        for _ in 0..4000 {
            let n = rng.random_range(1..=40usize);
            let mut keys: Vec<(f64, u32)> = (0..n)
                .map(|_| values[rng.random_range(0..values.len())])
                .zip(0u32..)
                .collect();
            // Codes in no order, as a fix's two directions and sections
            // interleave after pruning.
            for i in (1..n).rev() {
                let j = rng.random_range(0..=i);
                let c = keys[i].1;
                keys[i].1 = keys[j].1;
                keys[j].1 = c;
            }
            let mut sorted = keys.clone();
            sorted.sort_by(key_order);
            for k in 1..=n {
                let mut got = keys.clone();
                best_keys(&mut got, k);
                let bits =
                    |v: &[(f64, u32)]| v.iter().map(|x| (x.0.to_bits(), x.1)).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&sorted[..k]), "{keys:?} {k}");
                checked += 1;
            }
        }
        assert!(checked > 50_000, "{checked}");
    }

    /// The emission-ratio rule drops exactly the candidates below the
    /// fix's best × `min_emission_ratio`, keeping the others in the same
    /// order; with 0 every candidate within the radius (up to the cap) is
    /// kept, and on this map some of those lie below the floor.
    #[test]
    fn candidates_far_less_likely_than_the_best_are_dropped() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let params = |ratio: f64| HmmParams {
            search_radius_m: 300.0,
            max_candidates: 1000,
            min_emission_ratio: ratio,
            ..HmmParams::default()
        };
        let (mut all, mut kept) = (Vec::new(), Vec::new());
        let mut below = 0;
        for sg in net.segments.iter().step_by(7) {
            let fix = Fix {
                t_s: 0.0,
                enu: [(sg.a[0] + sg.b[0]) / 2.0 + 3.0, (sg.a[1] + sg.b[1]) / 2.0],
                heading_rad: None,
            };
            let d = Drift::prior(HmmParams::default().drift_sigma_m);
            HmmMatcher::new(&net, params(0.0)).candidates(&fix, None, &d, &mut all);
            HmmMatcher::new(&net, params(1e-6)).candidates(&fix, None, &d, &mut kept);
            let floor = all[0].emission + 1e-6f64.ln();
            let want: Vec<_> = all.iter().filter(|c| c.emission >= floor).collect();
            below += all.len() - want.len();
            assert_eq!(want.len(), kept.len());
            for (a, b) in want.iter().zip(&kept) {
                assert_eq!(
                    (a.seg, a.at.forward, a.emission),
                    (b.seg, b.at.forward, b.emission)
                );
            }
        }
        assert!(
            below > 0,
            "no candidate below the floor: the test shows nothing"
        );
    }
    /// A ratio out of range never empties a fix's candidates: NaN and
    /// negative ratios keep every candidate within the radius, ratios
    /// above 1 keep the best (and its ties) only.
    #[test]
    fn an_out_of_range_emission_ratio_keeps_the_best() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/small.osm");
        let net = Network::load(&path, &Default::default()).unwrap();
        let sg = &net.segments[net.segments.len() / 2];
        let fix = Fix {
            t_s: 0.0,
            enu: [(sg.a[0] + sg.b[0]) / 2.0 + 3.0, (sg.a[1] + sg.b[1]) / 2.0],
            heading_rad: None,
        };
        let d = Drift::prior(HmmParams::default().drift_sigma_m);
        let run = |ratio: f64| {
            let params = HmmParams {
                search_radius_m: 300.0,
                max_candidates: 1000,
                min_emission_ratio: ratio,
                ..HmmParams::default()
            };
            let mut out = Vec::new();
            HmmMatcher::new(&net, params).candidates(&fix, None, &d, &mut out);
            out
        };
        let all = run(0.0);
        assert!(all.len() > 1, "{}", all.len());
        for ratio in [f64::NAN, -1.0] {
            assert_eq!(run(ratio).len(), all.len(), "{ratio}");
        }
        let best = run(2.0);
        assert!(!best.is_empty() && best.len() < all.len(), "{}", best.len());
        assert_eq!(best[0].emission, all[0].emission);
    }
}
