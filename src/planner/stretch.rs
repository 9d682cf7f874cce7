//! Stretch maps of the tag-free pass (issue 14): the covariance ops of the
//! route between consecutive boundaries (each the first odometer epoch
//! after a candidate site; fifth round: before, the site itself), composed into
//! one map each ([`crate::nav::riccati::Element`]), with a rigorous upper
//! bound on the bound anywhere inside the stretch, so that a run that
//! reads no tag can cross a stretch with one map application instead of
//! stepping the filter through it, and is stepped (replayed from the
//! stretch's start with its own covariance) only where its bound may cross
//! the level it is checked against.
//!
//! Why it is exact. On perfect data the state stays on the truth, so every
//! run of the route goes through the same `Φ, Q, H, R` (the differences in
//! the state are round-off, about 1e-9 relative) once its propagation
//! intervals are those of the tag-free pass: a fix brings the covariance
//! to its own sample and shifts the next interval, and the first odometer
//! epoch after the last fix brings both back to the drive's schedule
//! ([`crate::sim::covariance::PerfectData::resync_every`]). Runs therefore
//! step the filter up to the first boundary after that epoch, and from
//! there carry the covariance by the maps; a boundary being that epoch
//! for its site, a run from a fix at a boundary's site steps at most one
//! odometer interval (the paper's drive: 2.7 → 1.4 M steps for its
//! tag-free reaches, 13.6 → 11.1 counted passes in all). Map-matching feeds (restarted
//! with each run) are not restart invariant: no maps are built for them
//! ([`crate::sim::covariance::PerfectData::restart_invariant`]).
//!
//! Nodes. Runs of 8 and of 64 aligned stretches are composed into one map
//! each ([`Element::then`]) with every stretch's whole-stretch anchor
//! carried through the map of the stretches before it in the node
//! ([`Node`]), so that a run far from crossing its level crosses them by
//! one map; measured on the paper's drive: 282k map applications became
//! 88k (30.6 → 23.3 counted passes). A node is built on its second
//! request ([`LazyNode`]): built up front, the routes of a few km paid
//! about 0.2 passes for nodes no run or one run crossed.
//!
//! Restart points (seventh round). A stretch keeps, every [`SUB_SAMPLES`]
//! samples or more (at odometer epochs), the tag-free filter there and the
//! map of the stretch's ops up to it ([`Sub`]); a run that must replay a
//! stretch starts at the last restart point whose anchors (below) all hold
//! under its level from its covariance at the stretch's start, with the
//! covariance carried there by that map: the samples skipped are provably
//! under the level, where the caller's visit does nothing. Measured on the
//! paper's drive: 6.90 → 5.99 M filter steps, 9.82 → 9.23 counted passes.
//!
//! The interior bound. Updates only lower a covariance and every op is
//! monotone in the PSD order, and `(P⁻¹ + J)⁻¹ ≤ P`, so at any sample `t`
//! of a stretch starting at `e` with covariance `P`, `P_t ≤ A_t P Aᵀ_t +
//! C_t` where `(A_t, C_t, J_t)` is the map of the stretch's ops up to `t`.
//! With `M` the metric rows of the horizontal position at `e`
//! (`diag(R_N cos L, R_M)` on δλ, δL) and `G_t = M A_t = M [I 0] + D_t`:
//! `√λmax(G_t P Gᵀ_t) ≤ √λmax(M P_hor M) + √λmax(D_t P Dᵀ_t)`, and
//! `D_tᵀ D_t ≤ diag(r)` (a Gershgorin bound scaled by the tag-free
//! filter's standard deviations at the stretch's start, [`widen`]: the
//! unscaled one mixed units) gives
//! `λmax(D_t P Dᵀ_t) = λmax(P^½ D_tᵀ D_t P^½) ≤ Σ_k r_k P_kk`. The metric
//! scaling at `t` differs from `M` by at most the factor `ρ` (the largest
//! ratio of the radii, ≈ 1 + 1e-6), and `λmax(M C_t,hor M) ≤ q`. So the
//! bound at every sample of the stretch is at most
//! `√k · ρ · √((√λmax(M P_hor M) + √(Σ_k r_k P_kk))² + q)` ([`combine`];
//! the fourth round added `√q` outside the root), with `k` the bound's χ²
//! factor; all of `r`, `q`, `ρ` are taken over the stretch in the
//! recording pass.

use crate::nav::ekf::{Mat, DP, N};
type Element = crate::nav::riccati::Element<N>;
use crate::nav::Filter;
use crate::sim::lambda_max_2x2;

/// The shortest stretch (IMU samples; its end is the first odometer epoch
/// after the first candidate site at least that far from its start;
/// measured below with the site itself as the end). A cost setting only (the answers
/// are the same): on the demo's 204 tag-free reaches (test
/// `stretch_maps_give_the_stepped_reaches`), with 4 op states per anchor,
/// 0 / 300 / 1000 samples took 148k / 218k / 579k filter steps and 16.4k /
/// 8.7k / 3.1k map applications (stepping: 4.2 M steps); whole plans
/// (`plan.json`'s counted passes, demo / Monaco 20 m / Helsinki tactical):
/// 300 → 6.62 / 5.04 / 5.12, 600 → 6.42 / 5.04 / 4.96, 1000 → 6.79 /
/// 4.97 / 5.00, 2000 → 10.2 / 5.63 / 5.94.
pub(super) const MIN_SAMPLES: usize = 600;

/// Op states per anchor of the interior bound (1: the bound `A P Aᵀ + C`
/// itself at every state, tightest and dearest to test). On the demo's
/// reaches, 1 and 4 states took 102k and 218k filter steps but 320 and
/// 210 ms (anchor tests), with 300-sample stretches; whole plans with
/// 600-sample stretches, 1 / 2 / 3 / 4 / 8 states: demo 0.17 / 0.19 /
/// 0.19 / 0.13 / 0.13 s user, Monaco 20 m 1.00 / 0.74 / 0.63 / 0.56 /
/// 0.58 s (8 states: more stepping, +13 % passes on the demo).
const GROUP: usize = 4;

/// Relative margin of the interior bound below the level it must stay
/// under: the maps' covariances and the stepped ones differ by round-off
/// (≈ 1e-12 relative, measured on the demo's sites).
pub(super) const INTERIOR_MARGIN: f64 = 1e-9;

/// One anchor of a stretch's interior bound: for the samples it covers,
/// `P_t ≤ A_t P Aᵀ_t + C_t` with `M A_t = G + D_t`, `D_tᵀ D_t ≤ diag(r)`
/// and `λmax(M C_t,hor M) ≤ q`; `cm` is `M C,hor M` at the anchor itself.
#[derive(Debug, Clone)]
pub(super) struct Anchor {
    g: [[f64; N]; 2],
    cm: [f64; 3],
    r: [f64; N],
    q: f64,
}

/// The upper bound's inputs over one stretch.
#[derive(Debug, Clone)]
pub(super) struct Interior {
    /// Metres per radian of longitude and of latitude at the start.
    scale: (f64, f64),
    /// One anchor at the start for the whole stretch (cheap to test: its
    /// rows are the start's metric rows, two entries).
    whole: Anchor,
    anchors: Vec<Anchor>,
    rho: f64,
    /// The scaled Gershgorin bound's weights ([`widen`]).
    sd: [f64; N],
    /// Restart points inside the stretch ([`Sub`]), increasing.
    subs: Vec<Sub>,
}

/// A restart point inside a stretch (seventh round): the tag-free filter
/// after the ops of `sample` (an odometer epoch), the map of the
/// stretch's ops up to it, and the anchors that cover every op state up
/// to it (`anchors`: the first that many of [`Interior::anchors`]). A
/// replay whose first `anchors` anchors all hold under its level from the
/// stretch's start covariance `P` has its bound at most the level at every
/// sample up to `sample` (the anchors' bound, module docs), where the
/// caller's visit does nothing: it is started here, with the covariance
/// `prefix(P)`, rather than at the stretch's start.
#[derive(Debug, Clone)]
struct Sub {
    sample: usize,
    anchors: usize,
    filter: Filter,
    prefix: Element,
}

/// The fewest samples between restart points ([`Sub`]) of a stretch (and
/// from its start). A cost setting only (the answers are the same): on
/// the paper's drive (1,485 stretches of about 870 samples), counted
/// passes / peak RSS with none 9.82 / 307 MB, 400: 9.38 / 361 MB, 300:
/// 9.23 / 359 MB, 200: 9.17 / 412 MB, 150: 9.08 / 445 MB, 100: 9.05 /
/// 519 MB (a restart point holds a filter and a map, about 17 kB).
const SUB_SAMPLES: usize = 300;

/// The anchor's upper bound on `√λmax` of the metric horizontal
/// covariance over the samples it covers, from `p` at the stretch's start.
fn anchor_bound(a: &Anchor, p: &Mat) -> f64 {
    // G P Gᵀ over the 2×2, with P symmetric: x_r = P g_r.
    let mut x = [[0.0; N]; 2];
    for (row, xr) in x.iter_mut().enumerate() {
        for (k, &gk) in a.g[row].iter().enumerate() {
            if gk != 0.0 {
                for (l, xl) in xr.iter_mut().enumerate() {
                    *xl += gk * p[(l, k)];
                }
            }
        }
    }
    let dot = |u: &[f64; N], v: &[f64; N]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
    let gpg = [
        dot(&a.g[0], &x[0]),
        dot(&a.g[0], &x[1]),
        dot(&a.g[1], &x[1]),
    ];
    if a.q == 0.0 && a.r.iter().all(|&r| r == 0.0) {
        lambda_max_2x2(gpg[0] + a.cm[0], gpg[1] + a.cm[1], gpg[2] + a.cm[2]).sqrt()
    } else {
        let s: f64 = (0..N).map(|k| a.r[k] * p[(k, k)].max(0.0)).sum();
        combine(lambda_max_2x2(gpg[0], gpg[1], gpg[2]), s, a.q)
    }
}

/// The bound `√λmax((G + D) P (G + D)ᵀ + C)` from `y ≥ λmax(G P Gᵀ)`,
/// `x ≥ λmax(D P Dᵀ)` and `q ≥ λmax(C)`: `λmax(X + Y) ≤ λmax X + λmax Y`
/// for symmetric `X, Y`, and `√λmax` of `(G + D) P (G + D)ᵀ` is a norm of
/// `(G + D) P^½`, so at most `√y + √x` (triangle inequality).
fn combine(y: f64, x: f64, q: f64) -> f64 {
    let u = y.max(0.0).sqrt() + x.max(0.0).sqrt();
    (u * u + q.max(0.0)).sqrt()
}

/// Widens anchor `a` to cover a state with rows `g` and `M C,hor M` = `c`.
///
/// `DᵀD ≤ diag(r)` by the scaled Gershgorin bound: for any positive `s`,
/// `vᵀXv ≤ Σ_kl |X_kl| |v_k| |v_l| ≤ Σ_k v_k² Σ_l |X_kl| s_l / s_k` (from
/// `2|v_k v_l| ≤ v_k² s_l/s_k + v_l² s_k/s_l`), and `|(DᵀD)_kl| ≤
/// Σ_row |D_row,k| |D_row,l|`. With `s` the standard deviations of the
/// tag-free filter at the stretch's start (`scale`), the sum weighs each
/// state in its own units: at that covariance's diagonal `Σ_k r_k P_kk`
/// is `Σ_row (Σ_k |D_row,k| s_k)²`, the Cauchy–Schwarz bound, where the
/// unscaled sum (`s = 1`) mixed radians of latitude with metres per
/// second.
fn widen(a: &mut Anchor, g: &[[f64; N]; 2], c: &[f64; 3], scale: &[f64; N]) {
    let d0: [f64; N] = std::array::from_fn(|k| g[0][k] - a.g[0][k]);
    let d1: [f64; N] = std::array::from_fn(|k| g[1][k] - a.g[1][k]);
    let n0: f64 = d0.iter().zip(scale).map(|(x, s)| x.abs() * s).sum();
    let n1: f64 = d1.iter().zip(scale).map(|(x, s)| x.abs() * s).sum();
    for k in 0..N {
        a.r[k] = a.r[k].max((d0[k].abs() * n0 + d1[k].abs() * n1) / scale[k]);
    }
    a.q = a.q.max(lambda_max_2x2(c[0], c[1], c[2]));
}

/// The rows `M A` (east, north) and `M C,hor M` of a map.
fn metric_rows(el: &Element, (ce, re): (f64, f64)) -> ([[f64; N]; 2], [f64; 3]) {
    let g = [
        std::array::from_fn(|k| ce * el.a[(DP + 1, k)]),
        std::array::from_fn(|k| re * el.a[(DP, k)]),
    ];
    let c = &el.c;
    (
        g,
        [
            ce * ce * c[(DP + 1, DP + 1)],
            ce * re * c[(DP + 1, DP)],
            re * re * c[(DP, DP)],
        ],
    )
}

/// The stretch maps of a route.
#[derive(Debug, Clone)]
pub(super) struct Stretches {
    /// Boundary samples (increasing; the last is the route's last sample).
    pub bounds: Vec<usize>,
    /// The tag-free filter at each boundary but the last.
    pub filters: Vec<Filter>,
    /// The map of each stretch (ops of samples `bounds[m]+1 ..= bounds[m+1]`).
    pub elements: Vec<Element>,
    pub interior: Vec<Interior>,
    /// Odometer epochs (samples) that resynchronise the propagation.
    pub sync_every: usize,
    /// The bound's χ² factor (bound² per unit of the largest variance).
    pub chi2: f64,
    /// Nodes of [`NODE_SIZES`] consecutive stretches, per level.
    pub nodes: Vec<Vec<LazyNode>>,
    /// (sample, map) at each candidate site of the tag-free pass: the map
    /// of the ops of samples `bounds[m]+1 ..= sample`, the stretch `m`
    /// holding the site (`bounds[m] < sample ≤ bounds[m+1]`).
    pub prefixes: Vec<(usize, Element)>,
}

/// Stretches per node, by level: a run crosses a whole node by its
/// composed map when the node's interior bound allows (module docs).
const NODE_SIZES: [usize; 2] = [8, 64];

/// Consecutive stretches composed into one map ([`Element::then`]), with
/// each stretch's whole-stretch anchor carried to the node's start.
///
/// For stretch `j` of the node, with the map of the stretches before it
/// in the node `(A', C', J')`: its start covariance is `P_j ≤ A' P A'ᵀ +
/// C'` for `P` at the node's start, and its anchor `(G, r, q)` bounds its
/// samples by `√((√λ(G P_j Gᵀ) + √(Σ r_k P_j,kk))² + q)` ([`combine`]);
/// with `λ(X + Y) ≤ λX + λY`, `λ(G P_j Gᵀ) ≤ λ(Ĝ P Ĝᵀ) + λ(G C' Gᵀ)` and
/// `Σ r_k P_j,kk ≤ Σ_ik P_ik W_ik + Σ r_k C'_kk` with `Ĝ = G A'` and
/// `W = A'ᵀ diag(r) A'`; the two constants are kept ([`Part`]).
#[derive(Debug, Clone)]
pub(super) struct Node {
    element: Element,
    parts: Vec<Part>,
}

/// One stretch of a [`Node`] (see there).
#[derive(Debug, Clone)]
struct Part {
    g: [[f64; N]; 2],
    w: Mat,
    /// `λmax(G C' Gᵀ)`, `Σ r_k C'_kk` and the anchor's `q`.
    gc: f64,
    rc: f64,
    q: f64,
    rho: f64,
}

impl Node {
    /// Composes stretches `ms` of `st`.
    fn build(st: &Stretches, ms: std::ops::Range<usize>) -> Node {
        let mut prefix = Element::identity();
        let mut parts = Vec::with_capacity(ms.len());
        for j in ms {
            let it = &st.interior[j];
            let a = &it.whole;
            let ap = &prefix.a;
            let g: [[f64; N]; 2] = std::array::from_fn(|row| {
                std::array::from_fn(|k| (0..N).map(|l| a.g[row][l] * ap[(l, k)]).sum())
            });
            let w = Mat::from_fn(|i, k| (0..N).map(|l| a.r[l] * ap[(l, i)] * ap[(l, k)]).sum());
            let c = &prefix.c;
            let gc = |u: &[f64; N], v: &[f64; N]| {
                (0..N)
                    .map(|i| (0..N).map(|k| u[i] * c[(i, k)] * v[k]).sum::<f64>())
                    .sum::<f64>()
            };
            let lc = lambda_max_2x2(
                gc(&a.g[0], &a.g[0]),
                gc(&a.g[0], &a.g[1]),
                gc(&a.g[1], &a.g[1]),
            );
            let rc: f64 = (0..N).map(|k| a.r[k] * c[(k, k)].max(0.0)).sum();
            parts.push(Part {
                g,
                w,
                gc: lc,
                rc,
                q: a.q,
                rho: it.rho,
            });
            prefix = prefix.then(&st.elements[j]);
        }
        Node {
            element: prefix,
            parts,
        }
    }

    /// Whether the bound stays at most `level` (over `√χ²`) at every
    /// sample of the node from `p` at its start, and the parts tested.
    fn within(&self, p: &Mat, level: f64) -> (bool, usize) {
        for (n, part) in self.parts.iter().enumerate().rev() {
            let a = Anchor {
                g: part.g,
                cm: [0.0; 3],
                r: [0.0; N],
                q: 0.0,
            };
            let trw: f64 = p.component_mul(&part.w).sum().max(0.0);
            let y = anchor_bound(&a, p).powi(2);
            let ub = combine(y + part.gc, trw + part.rc, part.q);
            if part.rho * ub > level {
                return (false, self.parts.len() - n);
            }
        }
        (true, self.parts.len())
    }
}

/// Builds [`Stretches`] during a tag-free pass.
#[derive(Debug)]
pub(super) struct Recorder {
    st: Stretches,
    cur: Option<Interior>,
    /// The op states (metric rows) of the current anchor's group.
    group: Vec<([[f64; N]; 2], [f64; 3])>,
    last_ops: u64,
    min_samples: usize,
    /// The sample of the current stretch's start or last restart point.
    last_sub: usize,
}

impl Recorder {
    /// A recorder whose stretches are at least `min_samples` long (the
    /// boundaries are the first candidate sites that far apart).
    pub fn new(sync_every: usize, chi2: f64, min_samples: usize) -> Self {
        Self {
            st: Stretches {
                bounds: vec![],
                filters: vec![],
                elements: vec![],
                interior: vec![],
                sync_every,
                chi2,
                nodes: vec![],
                prefixes: vec![],
            },
            cur: None,
            group: vec![],
            last_ops: 0,
            min_samples,
            last_sub: 0,
        }
    }

    /// The odometer epochs (samples) of the recorded drive.
    pub fn sync_every(&self) -> usize {
        self.st.sync_every
    }

    /// Closes the current anchor group: anchored at its last state.
    fn close_group(&mut self) {
        let (Some(it), Some(&(g, cm))) = (self.cur.as_mut(), self.group.last()) else {
            return;
        };
        let mut a = Anchor {
            g,
            cm,
            r: [0.0; N],
            q: 0.0,
        };
        for (gt, ct) in &self.group {
            widen(&mut a, gt, ct, &it.sd);
        }
        it.anchors.push(a);
        self.group.clear();
    }

    /// After sample `i`'s ops: updates the interior bound's inputs and,
    /// when `boundary` (a candidate site here) and the stretch is long
    /// enough, or at the route's last sample (`last`), closes the stretch.
    pub fn visit(&mut self, i: usize, f: &mut Filter, boundary: bool, last: bool) {
        if let Some(it) = self.cur.as_mut() {
            let (rm, clrn) = f.metres_per_radian();
            it.rho = it.rho.max(clrn / it.scale.0).max(rm / it.scale.1);
            let scale = it.scale;
            if let Some(el) = f.element() {
                if el.ops != self.last_ops {
                    self.last_ops = el.ops;
                    if self.group.len() == GROUP {
                        self.close_group();
                    }
                    let (g, c) = metric_rows(el, scale);
                    let it = self.cur.as_mut().expect("open stretch");
                    widen(&mut it.whole, &g, &c, &it.sd);
                    self.group.push((g, c));
                }
            }
        }
        let long = self
            .st
            .bounds
            .last()
            .is_none_or(|&b| i >= b + self.min_samples);
        if !(last || (boundary && long)) {
            self.restart_point(i, f);
            return;
        }
        self.close_group();
        if let Some(it) = self.cur.take() {
            let el = f.take_element().unwrap_or_default();
            self.st.elements.push(el);
            self.st.interior.push(it);
        }
        self.st.bounds.push(i);
        if !last {
            self.st.filters.push(f.clone());
            let (rm, clrn) = f.metres_per_radian();
            // The start itself (the identity map) is the first state.
            let (g, cm) = metric_rows(&Element::identity(), (clrn, rm));
            self.group.push((g, cm));
            self.cur = Some(Interior {
                scale: (clrn, rm),
                whole: Anchor {
                    g,
                    cm,
                    r: [0.0; N],
                    q: 0.0,
                },
                anchors: vec![],
                rho: 1.0,
                subs: vec![],
                sd: std::array::from_fn(|k| {
                    let v = f.covariance()[(k, k)];
                    if v > 0.0 {
                        v.sqrt()
                    } else {
                        1.0
                    }
                }),
            });
            self.last_ops = 0;
            self.last_sub = i;
            f.track_element();
        }
    }

    /// Keeps a restart point ([`Sub`]) at sample `i` of the open stretch
    /// when it is an odometer epoch at least [`SUB_SAMPLES`] after the last.
    fn restart_point(&mut self, i: usize, f: &Filter) {
        let Some(it) = self.cur.as_mut() else {
            return;
        };
        if i % self.st.sync_every != 0 || i < self.last_sub + SUB_SAMPLES {
            return;
        }
        let Some(prefix) = f.element().cloned() else {
            return;
        };
        let mut filter = f.clone();
        filter.take_element();
        self.last_sub = i;
        // The current op state is in the open group, anchor `anchors.len()`.
        it.subs.push(Sub {
            sample: i,
            anchors: it.anchors.len() + 1,
            filter,
            prefix,
        });
    }

    /// At a candidate site's sample `i`, before [`Recorder::visit`] there:
    /// keeps the map composed since the stretch's start
    /// ([`Stretches::prefixes`]).
    pub fn site_prefix(&mut self, i: usize, f: &Filter) {
        if self.st.prefixes.last().is_some_and(|x| x.0 == i) {
            return;
        }
        let el = f.element().cloned().unwrap_or_default();
        self.st.prefixes.push((i, el));
    }

    /// The stretches (None when the route's last sample was not visited).
    pub fn finish(mut self) -> Option<Stretches> {
        if self.cur.is_some() || self.st.bounds.len() < 2 {
            return None;
        }
        let n = self.st.elements.len();
        self.st.nodes = NODE_SIZES
            .iter()
            .map(|&b| (0..n / b).map(|_| LazyNode::default()).collect())
            .collect();
        Some(self.st)
    }
}

/// A [`Node`] built on its [`NODE_BUILD_AFTER`]-th request: building one
/// costs about twice the maps it saves a run that crosses it, so a node
/// only one run reaches is not built (the short routes paid about 0.2
/// passes for nodes built up front).
#[derive(Debug, Default)]
pub(super) struct LazyNode {
    asked: std::sync::atomic::AtomicU32,
    node: std::sync::OnceLock<Node>,
}

impl Clone for LazyNode {
    fn clone(&self) -> Self {
        Self {
            asked: std::sync::atomic::AtomicU32::new(
                self.asked.load(std::sync::atomic::Ordering::Relaxed),
            ),
            node: self.node.clone(),
        }
    }
}

/// The request on which a [`LazyNode`] is built.
const NODE_BUILD_AFTER: u32 = 2;

impl Stretches {
    /// The upper bound on the bound at every sample of stretch `m` from
    /// covariance `p` at its start (see the module docs).
    /// Whether the bound stays at most `level` at every sample of stretch
    /// `m` from covariance `p` at its start, by the interior bound (the
    /// whole-stretch anchor first, then each anchor), and the anchors
    /// tested.
    pub fn interior_within(&self, m: usize, p: &Mat, level: f64) -> (bool, usize) {
        let it = &self.interior[m];
        let scale = self.chi2.sqrt() * it.rho;
        if scale * anchor_bound(&it.whole, p) <= level {
            return (true, 1);
        }
        for (n, a) in it.anchors.iter().rev().enumerate() {
            if scale * anchor_bound(a, p) > level {
                return (false, n + 2);
            }
        }
        (true, it.anchors.len() + 1)
    }

    /// Where a replay of stretch `m` from covariance `p` at its start,
    /// checked against `level`, starts: the last restart point ([`Sub`])
    /// whose anchors all hold under `level` from `p` (its filter, with the
    /// covariance carried there by its map), else the stretch's start.
    /// Every sample the replay skips has its bound at most `level` and no
    /// fix (the module docs' interior bound, anchor by anchor).
    pub fn replay_start(
        &self,
        m: usize,
        p: &Mat,
        level: f64,
        work: &super::cost::Work,
    ) -> (usize, Filter) {
        let it = &self.interior[m];
        let scale = self.chi2.sqrt() * it.rho;
        let need = it
            .subs
            .last()
            .map_or(0, |s| s.anchors)
            .min(it.anchors.len());
        let ok = it.anchors[..need]
            .iter()
            .position(|a| scale * anchor_bound(a, p) > level)
            .unwrap_or(need);
        let k = it.subs.partition_point(|s| s.anchors <= ok);
        work.add_map((ok + 1).min(need), k > 0);
        match k.checked_sub(1).map(|k| &it.subs[k]) {
            Some(sub) => {
                work.add_restart();
                let mut g = sub.filter.clone();
                g.set_covariance(sub.prefix.apply(p));
                (sub.sample, g)
            }
            None => {
                let mut g = self.filters[m].clone();
                g.set_covariance(*p);
                (self.bounds[m], g)
            }
        }
    }

    /// Drives filter `f` from sample `from` to the route's end as
    /// `step(from, f, until)` would sample by sample (it steps `f` from
    /// `from` through `until` at most, calling its caller's visit at each
    /// sample, and returns false when that visit stopped the run), but
    /// carries the covariance by the maps over each stretch that holds no
    /// fix sample (`fixes`, increasing) and whose interior bound stays
    /// under `level` (less a round-off margin): the caller's visit must do
    /// nothing at a sample whose bound is at most `level` and holds no
    /// fix. The other stretches are stepped from the tag-free filter at
    /// their start with the carried covariance; fixes and the stretches
    /// up to the first boundary after the odometer epoch that follows them
    /// are stepped with `f` itself. `f` is left somewhere along the way.
    pub fn drive(
        &self,
        from: usize,
        f: &mut Filter,
        fixes: &[usize],
        level: &std::cell::Cell<f64>,
        mut step: impl FnMut(usize, &mut Filter, usize) -> bool,
        work: &super::cost::Work,
    ) {
        let mut cost = |tested: usize, applied: bool| work.add_map(tested, applied);
        let end = *self.bounds.last().unwrap_or(&0);
        let mut cur = from;
        let mut kf = fixes.partition_point(|&x| x <= from);
        while cur < end {
            let next_fix = fixes.get(kf).copied().unwrap_or(usize::MAX);
            let Some(mut m) = self.first_after(cur) else {
                step(cur, f, usize::MAX);
                return;
            };
            let mut moved = false;
            if next_fix > self.bounds[m] {
                if !step(cur, f, self.bounds[m]) {
                    return;
                }
                let mut p = *f.covariance();
                while m + 1 < self.bounds.len() && self.bounds[m + 1] < next_fix {
                    let safe = level.get() / (1.0 + INTERIOR_MARGIN);
                    if let Some((b, node)) = self.node_at(m, &p, safe, next_fix, &mut cost, work) {
                        p = node.element.apply(&p);
                        m += b;
                        moved = true;
                        continue;
                    }
                    let (within, tested) = self.interior_within(m, &p, safe);
                    cost(tested, within);
                    if within {
                        p = self.elements[m].apply(&p);
                    } else {
                        work.add_replay();
                        let (start, mut g) = self.replay_start(m, &p, safe, work);
                        if !step(start, &mut g, self.bounds[m + 1]) {
                            return;
                        }
                        work.add_replay_through();
                        p = *g.covariance();
                    }
                    m += 1;
                    moved = true;
                }
                if m + 1 == self.bounds.len() {
                    return;
                }
                cur = self.bounds[m];
                if moved {
                    *f = self.filters[m].clone();
                    f.set_covariance(p);
                }
            }
            // The next stretch holds a fix: step through it.
            if !step(cur, f, next_fix) {
                return;
            }
            cur = next_fix;
            while kf < fixes.len() && fixes[kf] <= cur {
                kf += 1;
            }
        }
    }

    /// The largest node starting at stretch `m`, ending before the sample
    /// `next_fix`, that a run with covariance `p` there crosses with its
    /// bound at most `level` (its size and the node); the parts tested are
    /// passed to `cost` (with whether the node's map is applied).
    fn node_at(
        &self,
        m: usize,
        p: &Mat,
        level: f64,
        next_fix: usize,
        cost: &mut impl FnMut(usize, bool),
        work: &super::cost::Work,
    ) -> Option<(usize, &Node)> {
        let unit = level / self.chi2.sqrt();
        for (lv, &b) in NODE_SIZES.iter().enumerate().rev() {
            let Some(lazy) = self.nodes.get(lv).and_then(|l| l.get(m / b)) else {
                continue;
            };
            if m % b != 0 || self.bounds[m + b] >= next_fix {
                continue;
            }
            let node = match lazy.node.get() {
                Some(node) => node,
                None => {
                    let n = 1 + lazy
                        .asked
                        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if n < NODE_BUILD_AFTER {
                        continue;
                    }
                    lazy.node.get_or_init(|| {
                        work.add_built(0, b as u64);
                        Node::build(self, m..m + b)
                    })
                }
            };
            let (ok, tested) = node.within(p, unit);
            cost(tested, ok);
            if ok {
                return Some((b, node));
            }
        }
        None
    }

    /// The map from the start of the stretch holding sample `i` to `i`
    /// ([`Stretches::prefixes`]), when `i` is a candidate site's.
    pub fn prefix_at(&self, i: usize) -> Option<&Element> {
        let k = self.prefixes.partition_point(|x| x.0 < i);
        self.prefixes.get(k).filter(|x| x.0 == i).map(|x| &x.1)
    }

    /// The first stretch a run at sample `from` can be carried from by the
    /// maps: the first boundary after the first odometer epoch after
    /// `from` (None: step to the end).
    pub fn first_after(&self, from: usize) -> Option<usize> {
        let sync = (from / self.sync_every + 1) * self.sync_every;
        let m = self.bounds.partition_point(|&b| b < sync);
        (m + 1 < self.bounds.len()).then_some(m)
    }
}
