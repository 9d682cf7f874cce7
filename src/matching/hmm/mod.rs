//! Robust map matching: a hidden-Markov matcher in the manner of Newson and
//! Krumm (2009), online with a bounded lag window.
//!
//! - States: candidate road sections within the search radius of a fix, one
//!   per section and permitted direction of travel (its nearest point), at
//!   most `max_candidates`, none less than `min_emission_ratio` as likely
//!   as the fix's best. Moving on in the same direction costs the
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
//!   ([`super::NetworkDistances`]); β = `beta_m` + `beta_per_m` × the
//!   straight distance (sparse tracks' true routes bend more between
//!   points). The bound ([`route_bound`]): at most twice the straight
//!   distance and no faster than `max_speed_mps` over the time between the
//!   fixes (each plus twice the radius), never below the straight distance
//!   plus twice the radius and 100 m; no path within it: impossible. So
//!   sparse tracks (a fix every 30-60 s) are routed, not split.
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
//! - Breaks: a gap (more than `gap_s` or `gap_m` between consecutive
//!   fixes; a fix without a time is chained by distance alone), a fix with no
//!   road within the radius, or no permitted path between consecutive steps
//!   ends the chain (everything in the window is decided) and a new one starts
//!   from the last drift estimate, relaxed towards the prior over the
//!   distance since; each break is recorded, off-road fixes are reported
//!   unmatched.
//! - Confidence: the chosen road's smoothed posterior probability given
//!   every fix in the lag window (forward–backward over the window on the
//!   Viterbi's own transition and emission weights, each emission under the
//!   drift of the surviving path into its predecessor). Points are emitted
//!   `lag` steps late anyway, so the later fixes inform it at no delay. The
//!   oldest step's backward vector is kept incrementally (`smoother`), not
//!   recomputed over the whole window for every step.
//! - A leaner model, [`HmmModel::Independent`] (`match --model
//!   independent`; module `independent`): Newson and Krumm's own, each
//!   candidate's emission computed once (under the drift's prior: Gaussian
//!   in its distance to the road, σ² = `drift_sigma_m`² + `sigma_m`²) and
//!   the Viterbi over the pairs adding the transition only (same route
//!   distances, bound and U-turn rule); no forward or backward vector, the
//!   confidence the chosen road's share of the soft-max of its step's
//!   Viterbi scores. It decides what the drift model decides with
//!   `track_drift = false` (tests/it/matching_independent.rs).

mod candidates;
mod drift;
mod geometry;
mod independent;
mod matcher;
mod params;
mod probability;
mod smoother;
mod state;
mod transitions;

pub use matcher::HmmMatcher;
pub use params::{route_bound, HmmModel, HmmParams};
