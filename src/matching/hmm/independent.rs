//! The independent-emission model ([`super::HmmModel::Independent`]):
//! Newson and Krumm's (2009) HMM. Each candidate's emission is computed once,
//! when the candidate is found (Gaussian in the fix's distance to the road
//! under the drift's prior, plus the heading's part: `Cand::emission`); the
//! Viterbi recursion over the pairs adds the transition only. No pair
//! weights are stored, no forward or backward vector is kept: the
//! confidence is the chosen road's share of the soft-max of its step's
//! Viterbi scores (a filtered max-product probability).
//!
//! Work per pair against the drift model: one look-up of the route
//! distance, the U-turn test and one subtraction; no emission (a `ln` and a
//! division), no `exp`, no forward or backward product.

use super::geometry::dist;
use super::matcher::HmmMatcher;
use super::probability::{max_product, shift_max_to_zero, softmax_into};
use super::state::{Cand, Step};

impl HmmMatcher<'_> {
    /// The Viterbi recursion from the window's last step into `step` under
    /// the independent model; false when no candidate can be reached from
    /// any previous one. The route distances, their bound and the U-turn
    /// rule are the drift model's ([`Self::transition`]), but a pair's
    /// route distance is looked up only when the recursion needs it
    /// ([`max_product`]: predecessors in decreasing score, each one's
    /// search made and looked up once), and no predecessor × candidate
    /// matrix is built: the same scores, back-pointers and anchors as the
    /// full recursion (checked in the tests below).
    #[inline(never)]
    pub(super) fn transition_independent(&mut self, step: &mut Step) -> bool {
        let prev = self.window.back().expect("a previous step");
        let gc = dist(step.fix.enu, prev.fix.enu);
        let bound = self.route_bound(gc, step.fix.t_s - prev.fix.t_s);
        let inv_beta = 1.0 / (self.params.beta_m + self.params.beta_per_m * gc);
        let (uturn, backtrack) = (self.params.uturn_penalty_m, self.params.backtrack_m);
        let paths = &mut self.paths;
        let (order, entries) = self.trans_buf.scratch.pair_buffers();
        entries.clear();
        entries.extend(step.cands.iter().map(|c| paths.directed_entry(c.at)));
        let cands = &step.cands;
        // The winners' route distances in `alpha` (emptied below: no
        // forward vector in this model).
        let bufs = (&mut step.score, &mut step.back, &mut step.alpha);
        max_product(&prev.score, cands.len(), order, bufs, |i, offers| {
            let p = &prev.cands[i];
            let (xn, xc) = paths.directed_exit(p.at);
            let src = paths.source(xn, bound);
            for (k, (c, &en)) in cands.iter().zip(entries.iter()).enumerate() {
                if !offers.open(k) {
                    continue;
                }
                let d = src.directed_distance(p.at, xc, c.at, en, backtrack);
                // (A NaN distance would give a NaN score, which never wins.)
                if let Some(d) = d.filter(|&d| d <= bound) {
                    // The drift model's U-turn rule, unchanged.
                    let charged = c.charged_from(p, d, uturn);
                    offers.offer(k, (charged - gc).abs() * inv_beta, d);
                }
            }
        });
        step.pair.clear();
        let mut any = false;
        for (k, c) in step.cands.iter_mut().enumerate() {
            let s = &mut step.score[k];
            if *s > f64::NEG_INFINITY {
                any = true;
                *s += c.emission;
                let p = &prev.cands[step.back[k] as usize];
                c.set_anchor(Cand::anchor_through(p, step.alpha[k]));
            } else {
                c.set_anchor((c.dir, 0.0, c.road));
            }
        }
        step.alpha.clear();
        if any {
            shift_max_to_zero(&mut step.score);
        }
        #[cfg(test)]
        check::against_full(self, step);
        any
    }

    /// The independent model's confidence of the window's oldest step into
    /// `out`: the soft-max of its Viterbi scores.
    pub(super) fn front_filtered(&self, out: &mut Vec<f64>) {
        softmax_into(&self.window[0].score, out);
    }
}

/// The full recursion (every predecessor × candidate pair, from the route
/// distance matrix: the code [`HmmMatcher::transition_independent`]
/// replaced), run beside the pruned one on a copy of each step while a test
/// asks for it, and compared bit for bit.
#[cfg(test)]
pub(super) mod check {
    use super::super::matcher::HmmMatcher;
    use super::super::state::{Cand, Step};
    use std::cell::Cell;

    /// What the comparisons covered.
    #[derive(Debug, Default, Clone, Copy)]
    pub(crate) struct Stats {
        /// Steps compared.
        pub(crate) steps: usize,
        /// Pairs of a finite-score predecessor and a candidate; of them,
        /// those with a route within the bound.
        pub(crate) pairs: usize,
        pub(crate) reached: usize,
        /// Candidates no predecessor reaches.
        pub(crate) unreachable: usize,
        /// Candidates whose best score two predecessors share.
        pub(crate) tied_best: usize,
        /// Steps where two finite predecessors' scores are equal.
        pub(crate) tied_from: usize,
    }

    thread_local! {
        /// `Some` while a test compares the two recursions.
        pub(crate) static STATS: Cell<Option<Stats>> = const { Cell::new(None) };
    }

    /// Compares `step` (after the pruned recursion) with the full
    /// recursion's result on a copy of it.
    pub(super) fn against_full(m: &mut HmmMatcher, step: &Step) {
        let Some(mut st) = STATS.get() else {
            return;
        };
        let mut full = Step {
            index: step.index,
            fix: step.fix,
            cands: step.cands.clone(),
            score: Vec::new(),
            back: Vec::new(),
            alpha: Vec::new(),
            pair: Vec::new(),
            pending: Vec::new(),
        };
        let mut s = Vec::new();
        full_recursion(m, &mut full, &mut s);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&step.score), bits(&full.score), "scores");
        assert_eq!(step.back, full.back, "back-pointers");
        for (a, b) in step.cands.iter().zip(&full.cands) {
            assert_eq!(bits(&a.anchor_dir), bits(&b.anchor_dir), "anchor direction");
            assert_eq!(
                a.anchor_m.to_bits(),
                b.anchor_m.to_bits(),
                "anchor distance"
            );
            assert_eq!(a.anchor_road, b.anchor_road, "anchor road");
        }
        let prev = &m.window.back().expect("a previous step").score;
        let nc = step.cands.len();
        st.steps += 1;
        for (i, f) in prev.iter().enumerate() {
            if *f > f64::NEG_INFINITY {
                st.pairs += nc;
                st.reached += s[i * nc..(i + 1) * nc].iter().flatten().count();
                if prev[..i].contains(f) {
                    st.tied_from += 1;
                }
            }
        }
        for k in 0..nc {
            let col = (0..prev.len()).filter_map(|i| s[i * nc + k]);
            let max = col.clone().fold(f64::NEG_INFINITY, f64::max);
            st.unreachable += usize::from(max == f64::NEG_INFINITY);
            st.tied_best += usize::from(col.filter(|x| *x == max).count() > 1);
        }
        STATS.set(Some(st));
    }

    /// The recursion as it was: every pair from the route distance matrix
    /// (each pair's score into `pairs`, predecessor-major; `None`: no
    /// route within the bound or a predecessor out of the chain).
    fn full_recursion(m: &mut HmmMatcher, step: &mut Step, pairs: &mut Vec<Option<f64>>) {
        let (gc, bound, inv_beta, bufs) = m.route_distances(step);
        let uturn = m.params.uturn_penalty_m;
        let prev = m.window.back().expect("a previous step");
        let nc = step.cands.len();
        pairs.clear();
        pairs.resize(prev.cands.len() * nc, None);
        step.score.clear();
        step.back.clear();
        let mut any = false;
        for (k, c) in step.cands.iter_mut().enumerate() {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0, c.road);
            for (i, p) in prev.cands.iter().enumerate() {
                let from = prev.score[i];
                if from == f64::NEG_INFINITY {
                    continue;
                }
                let Some(d) = bufs.dist[i * nc + k] else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                let charged = c.charged_from(p, d, uturn);
                let s = from - (charged - gc).abs() * inv_beta;
                pairs[i * nc + k] = Some(s);
                if s > best {
                    best = s;
                    arg = i as u32;
                    anchor = Cand::anchor_through(p, d);
                }
            }
            if best > f64::NEG_INFINITY {
                any = true;
                best += c.emission;
            }
            c.set_anchor(anchor);
            step.score.push(best);
            step.back.push(arg);
        }
        m.trans_buf = bufs;
        if any {
            super::shift_max_to_zero(&mut step.score);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::check::{Stats, STATS};
    use crate::matching::inputs::read_track_file;
    use crate::matching::options::MatchOptions;
    use crate::matching::track::FileMatcher;
    use crate::matching::{match_track, Fix, HmmMatcher, HmmModel};
    use crate::network::{LoadOptions, Network};
    use rand::{Rng, SeedableRng};
    use std::path::Path;

    fn load(rel: &str) -> Network {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
        Network::load(&p, &LoadOptions::default()).unwrap()
    }

    fn independent(radius_m: Option<f64>) -> MatchOptions {
        MatchOptions {
            model: HmmModel::Independent,
            radius_m,
            ..MatchOptions::default()
        }
    }

    /// Seeded random drives on `net`: from a random node along random
    /// departures, a fix every ~`spacing_m` on the straight line between
    /// the nodes, with Gaussian-ish noise of a few metres and, on some,
    /// repeated fixes (equal scores: ties).
    fn walks(net: &Network, n: usize, spacing_m: f64, seed: u64) -> Vec<Vec<Fix>> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::new();
        while out.len() < n {
            let mut node = rng.random_range(0..net.nodes.len()) as u32;
            let mut fixes: Vec<Fix> = Vec::new();
            let mut t = 0.0;
            for _ in 0..40 {
                let deps: Vec<_> = net.topology.departures(&net.model, node).collect();
                if deps.is_empty() {
                    break;
                }
                let d = deps[rng.random_range(0..deps.len())];
                let s = &net.sections[d.section as usize];
                let next = if d.forward { s.end } else { s.start };
                let (a, b) = (net.nodes[node as usize].enu, net.nodes[next as usize].enu);
                let len = (b[0] - a[0]).hypot(b[1] - a[1]);
                let steps = (len / spacing_m).ceil().max(1.0) as usize;
                for j in 0..steps {
                    let u = j as f64 / steps as f64;
                    let noise = |r: &mut rand_chacha::ChaCha8Rng| {
                        (r.random::<f64>() + r.random::<f64>() + r.random::<f64>() - 1.5) * 6.0
                    };
                    let fix = Fix {
                        t_s: t,
                        enu: [
                            a[0] + u * (b[0] - a[0]) + noise(&mut rng),
                            a[1] + u * (b[1] - a[1]) + noise(&mut rng),
                        ],
                        heading_rad: None,
                    };
                    t += spacing_m / 10.0;
                    fixes.push(fix);
                    if rng.random::<f64>() < 0.1 {
                        fixes.push(Fix { t_s: t, ..fix });
                        t += 1.0;
                    }
                }
                node = next;
            }
            if fixes.len() >= 5 {
                out.push(fixes);
            }
        }
        out
    }

    /// The pruned recursion equals the full one (scores bit for bit,
    /// back-pointers, anchors) at every step of the real traces (each
    /// with the radius from σ̂ and fastmm's 100 m and 80 m) and of seeded
    /// random drives on the bundled Helsinki map and the FMM example's
    /// map, fixes 10 m to 300 m apart; the steps cover ties, predecessors
    /// out of reach and unreachable candidates.
    #[test]
    fn pruned_recursion_equals_the_full_one() {
        STATS.set(Some(Stats::default()));
        let d = "tests/data/real";
        let fmm = load(&format!("{d}/fmm-network.geojson"));
        let i13 = load(&format!("{d}/issue-13.osm"));
        let i70 = load(&format!("{d}/issue-70.osm"));
        let cases = [
            (&fmm, "fmm-trips.geojson"),
            (&i70, "issue-70.gpx"),
            (&i13, "issue-13.gpx"),
            (&i13, "issue-127.gpx"),
        ];
        for (net, track) in cases {
            let (rows, _) =
                read_track_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join(d).join(track))
                    .unwrap();
            for radius in [None, Some(100.0), Some(80.0)] {
                let (points, _) = FileMatcher::new(net).match_rows(&rows, &independent(radius));
                assert_eq!(points.len(), rows.len(), "{track}");
            }
        }
        let real = STATS.get().unwrap();
        let helsinki = load("maps/helsinki.osm.pbf");
        for (net, spacing, seed) in [
            (&helsinki, 10.0, 1),
            (&helsinki, 40.0, 2),
            (&helsinki, 300.0, 3),
            (&fmm, 15.0, 4),
            (&fmm, 80.0, 5),
        ] {
            for fixes in walks(net, 6, spacing, seed) {
                let params = independent(None).hmm_params(net, &fixes);
                let mut m = HmmMatcher::new(net, params);
                let points = match_track(&mut m, &fixes);
                assert_eq!(points.len(), fixes.len());
            }
        }
        let all = STATS.get().unwrap();
        STATS.set(None);
        println!("real traces: {real:?}\nall: {all:?}");
        assert!(real.steps > 100, "{real:?}");
        assert!(all.steps > real.steps + 1000, "{all:?}");
        assert!(all.reached < all.pairs, "{all:?}");
        assert!(
            all.unreachable > 0 && all.tied_from > 0 && all.tied_best > 0,
            "{all:?}"
        );
    }
}
