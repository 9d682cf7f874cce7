//! Robust map matching: a hidden-Markov matcher in the manner of Newson and
//! Krumm (2009), online with a bounded lag window.
//!
//! - States: candidate road sections within the search radius of a fix, one
//!   per section and permitted direction of travel (its nearest point), at
//!   most `max_candidates`. Moving on in the same direction costs the
//!   distance; turning round needs a node (a junction or a dead end), never
//!   happens inside a section, and costs `uturn_penalty_m` more: a path
//!   turning straight back onto the section it left, a transition shorter
//!   than the penalty that ends facing more than 120° from where it started,
//!   or one that faces more than 120° from the direction of travel about
//!   40 m back along the best path on the same road as there (a turn-round
//!   spread over several steps, e.g. round a small triangle of roads back
//!   onto the road it left; driving round a block onto a parallel road is
//!   not one). So jitter and drift cannot make a U-turn; a real one needs
//!   strong evidence.
//! - Fix error model: fix = true position + drift + white noise. The drift
//!   (a dead-reckoning error: slowly varying, tens of metres) follows a
//!   first-order Gauss–Markov process in distance travelled (stationary σ
//!   `drift_sigma_m` per axis, correlation distance `drift_correlation_m`);
//!   the white part has σ `sigma_m` (noise, lanes, centreline offsets).
//!   Treating the whole offset as white noise (the classic emission) lets a
//!   persistent offset carry fix after fix nearer a parallel road; tracking
//!   the drift makes a wrong road pay for the change of drift it needs.
//! - Drift estimation per hypothesis (per-survivor processing, as in
//!   Viterbi decoding with unknown channel parameters): every state carries
//!   a Kalman estimate of the drift (mean, 2 × 2 covariance) along the best
//!   path into it. A state's emission is evaluated under each predecessor's
//!   drift, predicted over the distance between the fixes; the state takes
//!   the winning predecessor's estimate and updates it with its own fix. A
//!   road observes only the drift across it (the innovation is the signed
//!   distance of the fix, less the drift, from the road's line, variance
//!   nᵀPn + σ²); the drift along it stays uncertain until a turn reveals
//!   it. A wrong hypothesis's estimate lives and dies with that hypothesis,
//!   and the Gauss–Markov prediction keeps every estimate within the prior
//!   (covariance ≤ σ_drift², mean relaxing to zero where unobserved), so no
//!   estimate can run away. With `track_drift = false` the drift stays at
//!   its prior: the classic white-noise emission with σ² = σ_drift² + σ².
//! - Emission: log p = −½ ν²/S − ½ ln(S/σ²) (ν, S above; beyond a section's
//!   end the overshoot along it is charged with the drift's variance along
//!   it) + κ (cos Δθ − 1), with Δθ the angle between the heading (the
//!   fix's where given, else the displacement since the previous step) and
//!   the state's direction of travel; this is what tells parallel one-way
//!   carriageways apart.
//! - Transition: log p = −|route distance − straight distance| / β, with route
//!   distances from bounded, cached Dijkstra searches honouring one-way roads
//!   ([`super::NetworkDistances`]); no path within the bound: impossible.
//! - Dense tracks: a fix becomes a Viterbi step only once it lies at least
//!   `min_step_m` from the previous step (jitter and backward drift between
//!   steps cannot create loops or U-turns); the fixes in between are matched
//!   afterwards onto the decided path between the two steps. A short backward
//!   move along a one-way section (≤ `backtrack_m`) counts as noise, not as a
//!   drive around the block.
//! - Online: the window holds at most `lag` steps; the oldest is decided by
//!   back-tracing from the newest step's best state; its matched points are
//!   the fixes less the chosen state's drift, projected onto the road.
//!   Memory is proportional to the window (`lag` steps of at most
//!   `max_skip` fixes each, a fixed-size drift estimate per state).
//! - Breaks: a gap (time or distance between consecutive fixes), a fix with no
//!   road within the radius, or no permitted path between consecutive steps
//!   ends the chain (everything in the window is decided) and a new one starts
//!   from the last drift estimate, relaxed towards the prior over the
//!   distance since; each break is recorded, off-road fixes are reported
//!   unmatched.
//! - Confidence: the chosen road's smoothed posterior probability given
//!   every fix in the lag window (forward–backward over the window on the
//!   Viterbi's own transition and emission weights, each emission under the
//!   drift of the surviving path into its predecessor). Points are emitted
//!   `lag` steps late anyway, so the later fixes inform it at no delay.

use super::paths::{NetworkDistances, OnSection};
use super::{project, Break, BreakReason, Fix, MatchState, MatchedPoint, Matcher};
use crate::network::geometry::{norm, point_at_ratio};
use crate::network::{Network, RoadId, SectionId, SegmentId};
use std::collections::VecDeque;

/// Parameters of the HMM matcher.
#[derive(Debug, Clone, Copy)]
pub struct HmmParams {
    /// Candidate search radius (m): should exceed the expected position error.
    pub search_radius_m: f64,
    /// Most candidates per step.
    pub max_candidates: usize,
    /// σ of the white part of the fix error, per axis (m): noise, lane and
    /// centreline offsets. The slowly varying part is the drift below.
    pub sigma_m: f64,
    /// β of the transition (m).
    pub beta_m: f64,
    /// κ for a heading given with the fix.
    pub kappa_given: f64,
    /// κ for a heading derived from the displacement between steps.
    pub kappa_derived: f64,
    /// Least distance between consecutive steps (m).
    pub min_step_m: f64,
    /// Most fixes between steps (bounds memory when standing still).
    pub max_skip: usize,
    /// Steps in the lag window.
    pub lag: usize,
    /// Distance between consecutive fixes that breaks the track (m).
    pub gap_m: f64,
    /// Time between consecutive fixes that breaks the track (s).
    pub gap_s: f64,
    /// Backward move along a one-way section accepted as noise (m).
    pub backtrack_m: f64,
    /// Extra distance charged for turning round at a node straight back onto
    /// the section just left (m): a U-turn needs strong evidence.
    pub uturn_penalty_m: f64,
    /// Stationary σ of the drift, per axis (m): the prior on the offset
    /// between a fix and the true position before any road has been seen.
    pub drift_sigma_m: f64,
    /// Correlation distance of the drift's first-order Gauss–Markov model
    /// (m travelled): how far the vehicle drives before the drift has
    /// forgotten its value (e^-1 of it remains).
    pub drift_correlation_m: f64,
    /// Estimate the drift along each hypothesis (see the module
    /// documentation). `false`: the drift stays at its prior (zero mean,
    /// σ `drift_sigma_m`), i.e. the classic white-noise emission with σ
    /// √(`sigma_m`² + `drift_sigma_m`²).
    pub track_drift: bool,
}

impl Default for HmmParams {
    fn default() -> Self {
        Self {
            search_radius_m: 50.0,
            max_candidates: 12,
            // 2 m noise per axis plus lane and centreline offsets.
            sigma_m: 5.0,
            beta_m: 5.0,
            kappa_given: 3.0,
            kappa_derived: 1.0,
            min_step_m: 10.0,
            max_skip: 256,
            lag: 32,
            gap_m: 200.0,
            gap_s: 60.0,
            backtrack_m: 15.0,
            uturn_penalty_m: 300.0,
            // √(19.4² + 5²) = 20 m: without tracking, the classic emission σ.
            drift_sigma_m: 19.4,
            // Drift diffusion 2σ²/L ≈ 1.9 m²/m: a random walk reaching 30 m
            // in about 450 m, the fast end of dead-reckoning drift (the
            // issue's design case: 30 m on routes of a few hundred metres).
            drift_correlation_m: 400.0,
            track_drift: true,
        }
    }
}

/// The drift (the slowly varying offset of a fix from the true position):
/// mean and covariance, east and north (m, m²).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Drift {
    mean: [f64; 2],
    /// Covariance: east², east·north, north².
    cov: [f64; 3],
}

impl Drift {
    /// Zero mean, σ per axis.
    fn prior(sigma_m: f64) -> Self {
        let v = sigma_m * sigma_m;
        Drift {
            mean: [0.0; 2],
            cov: [v, 0.0, v],
        }
    }

    /// Prediction over `ds_m` metres travelled by the first-order
    /// Gauss–Markov model b' = φ b + w, φ = exp(−ds/L), var w = σ²(1 − φ²):
    /// the covariance never exceeds the prior's and the mean relaxes to
    /// zero where nothing is observed, so no estimate can run away.
    fn predict(&self, ds_m: f64, corr_m: f64, sigma_m: f64) -> Self {
        let phi = (-ds_m.max(0.0) / corr_m).exp();
        let (f2, q) = (phi * phi, sigma_m * sigma_m * (1.0 - phi * phi));
        Drift {
            mean: [phi * self.mean[0], phi * self.mean[1]],
            cov: [f2 * self.cov[0] + q, f2 * self.cov[1], f2 * self.cov[2] + q],
        }
    }

    /// Variance along the unit vector `u`.
    #[inline]
    fn var(&self, u: [f64; 2]) -> f64 {
        u[0] * u[0] * self.cov[0] + 2.0 * u[0] * u[1] * self.cov[1] + u[1] * u[1] * self.cov[2]
    }

    /// Kalman update with a scalar measurement of the drift along the unit
    /// vector `n`: innovation `nu`, innovation variance `s`.
    #[inline]
    fn update(&mut self, n: [f64; 2], nu: f64, s: f64) {
        let pn = [
            self.cov[0] * n[0] + self.cov[1] * n[1],
            self.cov[1] * n[0] + self.cov[2] * n[1],
        ];
        self.mean[0] += pn[0] * nu / s;
        self.mean[1] += pn[1] * nu / s;
        self.cov[0] = (self.cov[0] - pn[0] * pn[0] / s).max(0.0);
        self.cov[1] -= pn[0] * pn[1] / s;
        self.cov[2] = (self.cov[2] - pn[1] * pn[1] / s).max(0.0);
    }
}

/// The emission of a fix on a segment under a predicted drift: the
/// log-likelihood, and the across-road innovation (unit normal, innovation,
/// its variance) for the drift update.
#[derive(Debug, Clone, Copy)]
struct Emission {
    log_p: f64,
    normal: [f64; 2],
    nu: f64,
    s: f64,
}

/// Emission of the fix `raw` on segment `seg` given the predicted drift `d`
/// and the white-noise variance `r2` (m²). The fix less the drift's mean is
/// compared with the segment: across the road the innovation has variance
/// nᵀPn + r²; beyond the segment's ends the overshoot along it is charged
/// with the drift's variance along the road, uᵀPu + r². The log-likelihood
/// keeps the −½ ln(S/r²) term, so a candidate across which the drift is
/// uncertain does not gain from that uncertainty.
#[inline]
fn emission(line: &Line, raw: [f64; 2], d: &Drift, r2: f64) -> Emission {
    let u = line.u;
    let n = [-u[1], u[0]];
    let rel = [
        raw[0] - d.mean[0] - line.a[0],
        raw[1] - d.mean[1] - line.a[1],
    ];
    let along = rel[0] * u[0] + rel[1] * u[1];
    let across = rel[0] * n[0] + rel[1] * n[1];
    let over = if along < 0.0 {
        along
    } else if along > line.len {
        along - line.len
    } else {
        0.0
    };
    let s_n = d.var(n) + r2;
    let log_p = if over == 0.0 {
        -0.5 * across * across / s_n
    } else {
        -0.5 * (across * across / s_n + over * over / (d.var(u) + r2))
    } - 0.5 * (s_n / r2).ln();
    Emission {
        log_p,
        normal: n,
        nu: across,
        s: s_n,
    }
}

/// A segment as a start point, unit direction and length (ENU, m): the form
/// the emission kernel needs (the fix split into along- and across-road
/// parts against a drift covariance), which `geo` has no algorithm for; the
/// unit direction is computed once per candidate, not per transition.
#[derive(Debug, Clone, Copy)]
struct Line {
    a: [f64; 2],
    u: [f64; 2],
    len: f64,
}

impl Line {
    fn of(net: &Network, seg: SegmentId) -> Self {
        let sg = &net.segments[seg as usize];
        let (dx, dy) = (sg.b[0] - sg.a[0], sg.b[1] - sg.a[1]);
        let len = norm(dx, dy);
        let u = if len > 1e-9 {
            [dx / len, dy / len]
        } else {
            [1.0, 0.0]
        };
        Line { a: sg.a, u, len }
    }
}

#[derive(Debug, Clone, Copy)]
struct Cand {
    seg: SegmentId,
    line: Line,
    at: OnSection,
    /// Emission under the common drift (candidate ranking, chain starts).
    emission: f64,
    /// The heading part of the emission.
    heading: f64,
    /// Unit direction of travel (east, north).
    dir: [f64; 2],
    /// Direction of travel at least [`ANCHOR_M`] back along the best path
    /// into this state, and the distance from there (m).
    anchor_dir: [f64; 2],
    anchor_m: f64,
    /// The road of this state and of the state at the anchor.
    road: RoadId,
    anchor_road: RoadId,
    /// The drift estimated along the best path into this state, this
    /// step's fix included.
    drift: Drift,
}

/// Distance back along the path at which the earlier direction of travel is
/// compared with the current one to recognise U-turns (m).
const ANCHOR_M: f64 = 40.0;

#[derive(Debug)]
struct Step {
    index: u64,
    /// The fix as given.
    fix: Fix,
    cands: Vec<Cand>,
    score: Vec<f64>,
    back: Vec<u32>,
    /// Forward (filtered) probability of each candidate, normalised.
    alpha: Vec<f64>,
    /// Transition × emission weights from the previous step's candidates
    /// (rows) into this step's (columns), scaled to a largest weight of 1;
    /// empty at a chain's first step.
    pair: Vec<f64>,
    /// Fixes after this step, before the next (index, fix).
    pending: Vec<(u64, Fix)>,
}

/// The HMM matcher; see the module documentation.
#[derive(Debug)]
pub struct HmmMatcher<'a> {
    net: &'a Network,
    params: HmmParams,
    paths: NetworkDistances<'a>,
    window: VecDeque<Step>,
    index: u64,
    last_fix: Option<Fix>,
    last_step_pos: Option<[f64; 2]>,
    pending_break: Option<BreakReason>,
    last_matched: Option<(u64, f64)>,
    breaks: Vec<Break>,
    /// The drift of the newest step's best state, and where that fix was:
    /// the common estimate that places and ranks the next step's candidates
    /// and starts a new chain after a break.
    drift: Drift,
    drift_at: Option<[f64; 2]>,
    seg_buf: Vec<SegmentId>,
    near_buf: Vec<(SectionId, SegmentId, f64, f64)>,
    post_buf: Vec<f64>,
    pred_buf: Vec<Drift>,
    spare: Vec<Step>,
}

impl<'a> HmmMatcher<'a> {
    /// A matcher on `net`.
    pub fn new(net: &'a Network, params: HmmParams) -> Self {
        Self {
            net,
            params,
            paths: {
                let mut p = NetworkDistances::new(net);
                p.uturn_penalty_m = params.uturn_penalty_m;
                p
            },
            window: VecDeque::with_capacity(params.lag + 1),
            index: 0,
            last_fix: None,
            last_step_pos: None,
            pending_break: None,
            last_matched: None,
            breaks: Vec::new(),
            drift: Drift::prior(params.drift_sigma_m),
            drift_at: None,
            seg_buf: Vec::with_capacity(64),
            near_buf: Vec::with_capacity(64),
            post_buf: Vec::with_capacity(params.max_candidates),
            pred_buf: Vec::with_capacity(params.max_candidates),
            spare: Vec::new(),
        }
    }

    /// Steps currently held in the lag window.
    pub fn window_len(&self) -> usize {
        self.window.len()
    }

    /// Fixes currently held (steps and the fixes between them).
    pub fn held_fixes(&self) -> usize {
        self.window.iter().map(|s| 1 + s.pending.len()).sum()
    }

    /// The drift predicted over `ds_m` metres from `d`.
    fn predict(&self, d: &Drift, ds_m: f64) -> Drift {
        d.predict(
            ds_m,
            self.params.drift_correlation_m.max(1e-6),
            self.params.drift_sigma_m,
        )
    }

    /// The common drift predicted to the fix at `p`.
    fn common_drift(&self, p: [f64; 2]) -> Drift {
        match self.drift_at {
            Some(q) => self.predict(&self.drift, dist(p, q)),
            None => self.drift,
        }
    }

    /// Candidates of a fix into `cands`, placed and ranked with the drift `d`.
    fn candidates(
        &mut self,
        fix: &Fix,
        heading: Option<(f64, f64)>,
        d: &Drift,
        cands: &mut Vec<Cand>,
    ) {
        let net = self.net;
        cands.clear();
        self.seg_buf.clear();
        net.grid
            .within_radius_into(fix.enu, self.params.search_radius_m, &mut self.seg_buf);
        let r2 = self.params.sigma_m * self.params.sigma_m;
        let corrected = [fix.enu[0] - d.mean[0], fix.enu[1] - d.mean[1]];
        // The nearest segment of each section to the fix less the drift.
        let mut nearest = std::mem::take(&mut self.near_buf);
        nearest.clear();
        for &seg in &self.seg_buf {
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
            // One state per permitted direction of the section.
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
        self.near_buf = nearest;
        cands.sort_unstable_by(|a, b| b.emission.total_cmp(&a.emission));
        cands.truncate(self.params.max_candidates);
    }

    fn new_step(&mut self, index: u64, fix: Fix) -> Step {
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

    /// Viterbi recursion from the window's last step into `step`; false when
    /// no candidate can be reached from any previous one. Each candidate's
    /// emission is evaluated under the drift carried by each predecessor
    /// (predicted over the distance between the fixes), and the candidate
    /// takes over the winning predecessor's drift, updated with its own
    /// across-road innovation (per-survivor estimation).
    fn transition(&mut self, step: &mut Step) -> bool {
        let prev = self.window.back().expect("a previous step");
        let gc = dist(step.fix.enu, prev.fix.enu);
        let bound = gc + 2.0 * self.params.search_radius_m + 100.0;
        let backtrack = self.params.backtrack_m;
        let inv_beta = 1.0 / self.params.beta_m;
        let r2 = self.params.sigma_m * self.params.sigma_m;
        for c in &prev.cands {
            for (n, _) in self.paths.exits(c.at).into_iter().flatten() {
                self.paths.ensure(n, bound);
            }
        }
        let mut preds = std::mem::take(&mut self.pred_buf);
        preds.clear();
        let prev = self.window.back().expect("a previous step");
        preds.extend(prev.cands.iter().map(|p| self.predict(&p.drift, gc)));
        let track = self.params.track_drift;
        let mut any = false;
        step.score.clear();
        step.back.clear();
        let nc = step.cands.len();
        step.pair.clear();
        step.pair.resize(prev.cands.len() * nc, f64::NEG_INFINITY);
        for (k, c) in step.cands.iter_mut().enumerate() {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0u32;
            let mut anchor = (c.dir, 0.0, c.road);
            let mut innovation: Option<Emission> = None;
            for (i, p) in prev.cands.iter().enumerate() {
                if prev.score[i] == f64::NEG_INFINITY {
                    continue;
                }
                let Some(d) = self.paths.point_distance_cached(p.at, c.at, backtrack) else {
                    continue;
                };
                if d > bound {
                    continue;
                }
                // Facing the other way after a short drive: a U-turn (at a
                // node or round a small loop, in one transition or over a few).
                let dot = |u: [f64; 2]| u[0] * c.dir[0] + u[1] * c.dir[1];
                let turned = (dot(p.dir) < -0.5 && d < self.params.uturn_penalty_m)
                    || (dot(p.anchor_dir) < -0.5
                        && p.anchor_m + d < 2.0 * ANCHOR_M
                        && p.anchor_road == c.road);
                let charged = if turned {
                    d + self.params.uturn_penalty_m
                } else {
                    d
                };
                let e = emission(&c.line, step.fix.enu, &preds[i], r2);
                let psi = e.log_p + c.heading - (charged - gc).abs() * inv_beta;
                step.pair[i * nc + k] = psi;
                let s = prev.score[i] + psi;
                if s > best {
                    best = s;
                    arg = i as u32;
                    innovation = Some(e);
                    anchor = if p.anchor_m + d > ANCHOR_M {
                        (p.dir, d, p.road)
                    } else {
                        (p.anchor_dir, p.anchor_m + d, p.anchor_road)
                    };
                }
            }
            if let Some(e) = innovation {
                any = true;
                c.drift = preds[arg as usize];
                if track {
                    c.drift.update(e.normal, e.nu, e.s);
                }
            }
            c.anchor_dir = anchor.0;
            c.anchor_m = anchor.1;
            c.anchor_road = anchor.2;
            step.score.push(best);
            step.back.push(arg);
        }
        self.pred_buf = preds;
        if any {
            // Renormalise so scores stay near zero on long tracks.
            let m = step.score.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for s in &mut step.score {
                *s -= m;
            }
            // Forward (sum-product) recursion on the same weights.
            let m = step.pair.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for w in &mut step.pair {
                *w = (*w - m).exp();
            }
            step.alpha.clear();
            step.alpha.resize(nc, 0.0);
            for (i, a) in prev.alpha.iter().enumerate() {
                if *a > 0.0 {
                    for (x, w) in step.alpha.iter_mut().zip(&step.pair[i * nc..(i + 1) * nc]) {
                        *x += a * w;
                    }
                }
            }
            if !normalise(&mut step.alpha) {
                softmax_into(&step.score, &mut step.alpha);
            }
        }
        any
    }

    /// The smoothed posterior of the window's oldest step given every fix in
    /// the window (forward–backward over the lag window) into `out`.
    fn front_posterior(&self, out: &mut Vec<f64>) {
        let len = self.window.len();
        let mut beta = vec![1.0; self.window[len - 1].cands.len()];
        let mut next = Vec::with_capacity(self.params.max_candidates);
        for t in (1..len).rev() {
            let (st, np) = (&self.window[t], self.window[t - 1].cands.len());
            let nc = st.cands.len();
            next.clear();
            if st.pair.len() != np * nc {
                next.resize(np, 1.0);
            } else {
                next.extend((0..np).map(|i| {
                    st.pair[i * nc..(i + 1) * nc]
                        .iter()
                        .zip(&beta)
                        .map(|(w, b)| w * b)
                        .sum::<f64>()
                }));
                if !normalise(&mut next) {
                    next.iter_mut().for_each(|x| *x = 1.0);
                }
            }
            std::mem::swap(&mut beta, &mut next);
        }
        let front = &self.window[0];
        out.clear();
        out.extend(front.alpha.iter().zip(&beta).map(|(a, b)| a * b));
        if !normalise(out) {
            softmax_into(&front.score, out);
        }
    }

    /// Back-traces the window from its newest step's best state: the chosen
    /// candidate of the first `n` steps.
    fn choices(&self, n: usize, out: &mut Vec<u32>) {
        out.clear();
        let len = self.window.len();
        out.resize(len, 0);
        let last = &self.window[len - 1];
        let mut k = argmax(&last.score);
        for i in (0..len).rev() {
            out[i] = k;
            if i > 0 {
                k = self.window[i].back[k as usize];
            }
        }
        out.truncate(n);
    }

    /// Decides and emits the oldest step (given its choice and the next step's).
    fn emit_front(&mut self, choice: u32, next_choice: Option<u32>, out: &mut Vec<MatchedPoint>) {
        let mut post = std::mem::take(&mut self.post_buf);
        self.front_posterior(&mut post);
        let step = self.window.pop_front().expect("a step");
        let net = self.net;
        let c = step.cands[choice as usize];
        // The smoothed probability of the chosen road (both directions,
        // every section of it).
        let confidence = step
            .cands
            .iter()
            .zip(&post)
            .filter(|(k, _)| k.road == c.road)
            .map(|(_, p)| p)
            .sum::<f64>()
            .clamp(0.0, 1.0);
        self.post_buf = post;
        // Matched points: the fixes less the chosen state's drift, projected.
        let b = c.drift.mean;
        let corrected = |f: &Fix| Fix {
            enu: [f.enu[0] - b[0], f.enu[1] - b[1]],
            ..*f
        };
        let mut point = with_raw(
            super::matched_on(
                net,
                step.index,
                &corrected(&step.fix),
                c.seg,
                MatchState::Matched,
                confidence,
            ),
            step.fix.enu,
        );
        point.forward = c.at.forward;
        out.push(point);
        self.last_matched = Some((step.index, step.fix.t_s));
        if !step.pending.is_empty() {
            let pieces = next_choice.and_then(|nc| {
                let next = self.window.front().expect("the next step");
                let b = next.cands[nc as usize].at;
                let gc = dist(next.fix.enu, step.fix.enu);
                let bound = gc + 2.0 * self.params.search_radius_m + 100.0;
                self.paths.path(c.at, b, bound, self.params.backtrack_m)
            });
            let pieces = pieces.unwrap_or_else(|| {
                let len = net.sections[c.at.section as usize].length_m;
                vec![(c.at.section, 0.0, len)]
            });
            let mut cursor = 0usize;
            for (index, raw) in &step.pending {
                let fix = corrected(raw);
                let (k, seg) = nearest_on_pieces(net, &pieces[cursor..], fix.enu);
                cursor += k;
                let mut m =
                    super::matched_on(net, *index, &fix, seg, MatchState::Matched, confidence);
                // Keep the point inside the piece's offset range.
                let (sec, a, b) = pieces[cursor];
                clamp_to_range(net, &mut m, sec, a.min(b), a.max(b), &fix);
                out.push(with_raw(m, raw.enu));
                self.last_matched = Some((*index, fix.t_s));
            }
        }
        self.spare.push(step);
    }

    /// Decides every step in the window.
    fn flush(&mut self, out: &mut Vec<MatchedPoint>) {
        if self.window.is_empty() {
            return;
        }
        let mut ch = Vec::new();
        self.choices(self.window.len(), &mut ch);
        for i in 0..ch.len() {
            let next = ch.get(i + 1).copied();
            self.emit_front(ch[i], next, out);
        }
    }

    fn start_chain(&mut self, reason: Option<BreakReason>, index: u64, t_s: f64) {
        if let Some(r) = reason {
            self.breaks.push(Break {
                reason: r,
                before: self.last_matched,
                after: (index, t_s),
            });
        }
    }
}

/// Distance between two points (m); coordinates are metres in a local
/// frame, so the plain formula ([`norm`]) cannot overflow, and it is 5–10×
/// cheaper than `geo`'s `hypot`-based `Euclidean.distance` (measured).
#[inline]
fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    norm(a[0] - b[0], a[1] - b[1])
}

/// The point reported against the fix as given.
fn with_raw(mut m: MatchedPoint, raw: [f64; 2]) -> MatchedPoint {
    m.fix = raw;
    m.distance_m = dist(raw, m.point);
    m
}

/// Cosine between a heading and a segment's direction of travel.
fn directed_cos(net: &Network, seg: SegmentId, heading_rad: f64, forward: bool) -> f64 {
    let s = &net.segments[seg as usize];
    let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
    let len = norm(dx, dy);
    if len <= 0.0 {
        return 0.0;
    }
    let (sh, ch) = heading_rad.sin_cos();
    let c = (dx * sh + dy * ch) / len;
    if forward {
        c
    } else {
        -c
    }
}

fn argmax(v: &[f64]) -> u32 {
    let mut k = 0;
    for (i, x) in v.iter().enumerate() {
        if *x > v[k] {
            k = i;
        }
    }
    k as u32
}

/// Scales `v` to sum 1; false (and `v` untouched) when its sum is not a
/// positive finite number.
fn normalise(v: &mut [f64]) -> bool {
    let sum: f64 = v.iter().sum();
    if !(sum > 0.0 && sum.is_finite()) {
        return false;
    }
    v.iter_mut().for_each(|x| *x /= sum);
    true
}

/// Probabilities from log scores into `out` (all zero if none is finite).
fn softmax_into(scores: &[f64], out: &mut Vec<f64>) {
    let m = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    out.clear();
    if !m.is_finite() {
        out.resize(scores.len(), 0.0);
        return;
    }
    out.extend(scores.iter().map(|s| (s - m).exp()));
    normalise(out);
}

/// The nearest segment to `p` on the path pieces: (piece index, segment).
fn nearest_on_pieces(
    net: &Network,
    pieces: &[(SectionId, f64, f64)],
    p: [f64; 2],
) -> (usize, SegmentId) {
    let mut best = (0usize, 0 as SegmentId, f64::INFINITY);
    for (k, &(sec, a, b)) in pieces.iter().enumerate() {
        let (lo, hi) = (a.min(b), a.max(b));
        let section = &net.sections[sec as usize];
        for seg in section.segment_ids() {
            let s = &net.segments[seg as usize];
            if s.section_offset_m > hi || s.section_offset_m + s.length_m < lo {
                continue;
            }
            let (t, _, d) = project(net, seg, p);
            let off = s.section_offset_m + t * s.length_m;
            let d = if off < lo || off > hi {
                let off = off.clamp(lo, hi);
                let q = point_at(net, seg, off);
                dist(p, q)
            } else {
                d
            };
            if d < best.2 {
                best = (k, seg, d);
            }
        }
        if best.2.is_infinite() && k == 0 {
            best = (0, section.first_segment, f64::INFINITY);
        }
    }
    (best.0, best.1)
}

/// The point of segment `seg` at a section offset (clamped to the segment).
fn point_at(net: &Network, seg: SegmentId, section_offset: f64) -> [f64; 2] {
    let s = &net.segments[seg as usize];
    let t = if s.length_m > 0.0 {
        ((section_offset - s.section_offset_m) / s.length_m).clamp(0.0, 1.0)
    } else {
        0.0
    };
    point_at_ratio(&s.line(), t).into()
}

/// Moves a matched point into the section offset range `lo..=hi` if outside it.
fn clamp_to_range(
    net: &Network,
    m: &mut MatchedPoint,
    sec: SectionId,
    lo: f64,
    hi: f64,
    fix: &Fix,
) {
    let Some(seg) = m.segment else { return };
    let s = &net.segments[seg as usize];
    if s.section != sec {
        return;
    }
    let off = s.section_offset_m + (m.road_offset_m - s.road_offset_m);
    if off >= lo - 1e-9 && off <= hi + 1e-9 {
        return;
    }
    let off = off.clamp(lo, hi);
    let q = point_at(net, seg, off);
    m.point = q;
    m.road_offset_m = s.road_offset_m + (off - s.section_offset_m).clamp(0.0, s.length_m);
    m.distance_m = dist(fix.enu, q);
}

impl Matcher for HmmMatcher<'_> {
    fn push(&mut self, raw_fix: &Fix, out: &mut Vec<MatchedPoint>) {
        let index = self.index;
        self.index += 1;
        if !(raw_fix.enu[0].is_finite() && raw_fix.enu[1].is_finite() && raw_fix.t_s.is_finite()) {
            // Nothing to match, and nothing to let into the drift estimates;
            // what is held is decided first, so points stay in input order.
            self.flush(out);
            out.push(MatchedPoint::unmatched(index, raw_fix));
            return;
        }
        let fix = &Fix {
            heading_rad: raw_fix.heading_rad.filter(|h| h.is_finite()),
            ..*raw_fix
        };
        if let Some(last) = self.last_fix {
            let d = dist(fix.enu, last.enu);
            if (d > self.params.gap_m || fix.t_s - last.t_s > self.params.gap_s)
                && self.pending_break.is_none()
            {
                self.pending_break = Some(BreakReason::Gap);
            }
        }
        self.last_fix = Some(*fix);

        // Between steps: held until the next step decides the path.
        if self.pending_break.is_none() {
            if let Some(last) = self.window.back_mut() {
                let (dx, dy) = (fix.enu[0] - last.fix.enu[0], fix.enu[1] - last.fix.enu[1]);
                if dx * dx + dy * dy < self.params.min_step_m.powi(2)
                    && last.pending.len() < self.params.max_skip
                {
                    last.pending.push((index, *fix));
                    return;
                }
            }
        }

        let heading = match fix.heading_rad {
            Some(h) => Some((h, self.params.kappa_given)),
            None => self.last_step_pos.and_then(|q| {
                let (dx, dy) = (fix.enu[0] - q[0], fix.enu[1] - q[1]);
                (dx * dx + dy * dy >= self.params.min_step_m.powi(2) * 0.99)
                    .then(|| (dx.atan2(dy), self.params.kappa_derived))
            }),
        };
        self.last_step_pos = Some(fix.enu);
        let common = self.common_drift(fix.enu);
        let mut step = self.new_step(index, *fix);
        let mut cands = std::mem::take(&mut step.cands);
        self.candidates(fix, heading, &common, &mut cands);
        step.cands = cands;

        if step.cands.is_empty() {
            // Off road: decide everything held, report this fix unmatched.
            self.flush(out);
            if self.last_matched.is_some() {
                // Off road says more than a jump into it.
                self.pending_break = Some(BreakReason::OffRoad);
            }
            out.push(MatchedPoint::unmatched(index, raw_fix));
            self.spare.push(step);
            return;
        }

        let chained = if self.pending_break.is_none() && !self.window.is_empty() {
            if self.transition(&mut step) {
                true
            } else {
                self.pending_break = Some(BreakReason::NoPath);
                false
            }
        } else {
            false
        };
        if !chained {
            // A new chain: every state starts from the common drift (the
            // last estimate, relaxed towards the prior over the distance
            // since it was made).
            self.flush(out);
            let reason = self.pending_break.take();
            if self.last_matched.is_some() {
                self.start_chain(reason, index, fix.t_s);
            }
            step.score.clear();
            step.back.clear();
            let m = step
                .cands
                .iter()
                .map(|c| c.emission)
                .fold(f64::NEG_INFINITY, f64::max);
            let r2 = self.params.sigma_m * self.params.sigma_m;
            for c in step.cands.iter_mut() {
                c.anchor_dir = c.dir;
                c.anchor_m = 0.0;
                c.anchor_road = c.road;
                c.drift = common;
                if self.params.track_drift {
                    let e = emission(&c.line, fix.enu, &common, r2);
                    c.drift.update(e.normal, e.nu, e.s);
                }
                step.score.push(c.emission - m);
                step.back.push(0);
            }
            step.pair.clear();
            softmax_into(&step.score, &mut step.alpha);
        }
        let best = argmax(&step.score) as usize;
        self.drift = step.cands[best].drift;
        self.drift_at = Some(fix.enu);
        self.window.push_back(step);
        if self.window.len() > self.params.lag {
            let mut ch = Vec::with_capacity(2);
            self.choices(2, &mut ch);
            self.emit_front(ch[0], ch.get(1).copied(), out);
        }
    }

    fn finish(&mut self, out: &mut Vec<MatchedPoint>) {
        self.flush(out);
    }

    fn breaks(&self) -> &[Break] {
        &self.breaks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A road observes the drift across it only: the update pulls the mean
    /// and shrinks the variance across (north, for an east-west road) and
    /// leaves the drift along it (east) as uncertain as before.
    #[test]
    fn a_road_observes_the_drift_across_it_only() {
        let mut d = Drift::prior(20.0);
        let line = Line {
            a: [0.0, 0.0],
            u: [1.0, 0.0],
            len: 100.0,
        };
        // A fix 12 m north of the road, 3 m east of its start.
        let e = emission(&line, [3.0, 12.0], &d, 25.0);
        assert!((e.nu - 12.0).abs() < 1e-9 && (e.s - 425.0).abs() < 1e-9);
        d.update(e.normal, e.nu, e.s);
        // Kalman gain 400/425 on the north component.
        assert!((d.mean[1] - 12.0 * 400.0 / 425.0).abs() < 1e-9);
        assert_eq!(d.mean[0], 0.0);
        assert!((d.cov[2] - 400.0 * 25.0 / 425.0).abs() < 1e-9);
        assert_eq!(d.cov[0], 400.0);
        // With the drift removed, the same fix fits the road far better.
        let after = emission(&line, [3.0, 12.0], &d, 25.0);
        assert!(after.nu.abs() < 1.0 && after.log_p > e.log_p);
    }

    /// The Gauss–Markov prediction keeps every estimate within the prior:
    /// the mean relaxes towards zero and the variance towards σ², never
    /// beyond, however far the vehicle drives unobserved.
    #[test]
    fn prediction_stays_within_the_prior() {
        let d = Drift {
            mean: [30.0, -10.0],
            cov: [4.0, 1.0, 9.0],
        };
        let mut last = d;
        for ds in [10.0, 100.0, 1000.0, 1e6] {
            let p = d.predict(ds, 400.0, 19.4);
            assert!(p.mean[0].abs() < last.mean[0].abs());
            assert!(p.cov[0] <= 19.4 * 19.4 + 1e-9 && p.cov[2] <= 19.4 * 19.4 + 1e-9);
            assert!(p.cov[0] >= d.cov[0] && p.cov[1].abs() <= d.cov[1].abs());
            last = p;
        }
        let far = d.predict(1e6, 400.0, 19.4);
        assert!(far.mean[0].abs() < 1e-9 && (far.cov[0] - 19.4 * 19.4).abs() < 1e-6);
    }

    #[test]
    fn normalise_and_softmax_handle_degenerate_input() {
        let mut v = vec![0.0, 0.0];
        assert!(!normalise(&mut v));
        let mut out = Vec::new();
        softmax_into(&[f64::NEG_INFINITY, f64::NEG_INFINITY], &mut out);
        assert_eq!(out, vec![0.0, 0.0]);
        softmax_into(&[0.0, 0.0f64.ln_1p()], &mut out);
        assert!((out[0] - 0.5).abs() < 1e-12);
    }
}
