//! The HMM matcher's parameters and their defaults.

/// The HMM's probability model (`match --model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HmmModel {
    /// Per-survivor drift estimates: each candidate's emission under each
    /// predecessor's drift (one per pair), and the smoothed
    /// (forward–backward) confidence over the lag window. The default.
    #[default]
    Drift,
    /// Newson and Krumm's (2009) model: one emission per candidate,
    /// Gaussian in the fix's distance to the road (σ² = `drift_sigma_m`² +
    /// `sigma_m`², the heading's part added), independent of the path into
    /// it; a Viterbi over the pairs with the transition only; confidence
    /// the chosen road's filtered max-product probability (the soft-max of
    /// the decided step's Viterbi scores), no forward–backward pass. Less
    /// work per point (see the module documentation).
    Independent,
}

impl HmmModel {
    /// The model's name as `match --model` takes it.
    pub fn as_str(self) -> &'static str {
        match self {
            HmmModel::Drift => "drift",
            HmmModel::Independent => "independent",
        }
    }
}

impl std::str::FromStr for HmmModel {
    type Err = String;

    /// `drift` or `independent` (`match --model`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "drift" => Ok(HmmModel::Drift),
            "independent" => Ok(HmmModel::Independent),
            _ => Err("expected one of: drift, independent".into()),
        }
    }
}

/// Parameters of the HMM matcher.
#[derive(Debug, Clone, Copy)]
pub struct HmmParams {
    /// Candidate search radius (m): should exceed the expected position error.
    pub search_radius_m: f64,
    /// Most candidates per step.
    pub max_candidates: usize,
    /// Candidates whose emission likelihood (under the common drift, the
    /// heading's part included) is below this ratio of the fix's best are
    /// dropped. Such a candidate adds pairs but hardly information: at 1e-6
    /// it could only win if the routes into and out of it saved more than
    /// ln 1e6 ≈ 13.8 β of detour over every kept candidate's (β = 6 m
    /// between fixes 10 m apart: 83 m; 15 m at 100 m: 207 m), and
    /// otherwise its smoothed probability is of the order of 1e-6, far
    /// below the printed 1e-3 of a confidence. 0 keeps every candidate
    /// within the radius; values are taken within [0, 1] (NaN as 0), so
    /// the fix's best candidate is always kept.
    pub min_emission_ratio: f64,
    /// σ of the white part of the fix error, per axis (m): noise, lane and
    /// centreline offsets. The slowly varying part is the drift below.
    pub sigma_m: f64,
    /// β of the transition (m) between fixes close together.
    pub beta_m: f64,
    /// Growth of β with the straight distance between the fixes (m per m):
    /// β = `beta_m` + `beta_per_m` × distance. Between fixes hundreds of
    /// metres apart the route's excess over the straight line is naturally
    /// tens of metres (Newson and Krumm 2009 found β growing with the
    /// sampling interval), so a fixed β would charge the true route's bends
    /// as much as a wrong candidate's detour.
    pub beta_per_m: f64,
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
    /// Highest plausible speed (m/s): a transition may route at most this
    /// speed × the time between the fixes (plus twice the search radius)
    /// through the network. Fixes without usable times (missing, identical)
    /// are bounded by distance alone (twice the straight distance plus twice
    /// the radius and 100 m).
    pub max_speed_mps: f64,
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
    /// The probability model ([`HmmModel`]); [`HmmModel::Independent`]
    /// keeps the drift at its prior whatever `track_drift` says.
    pub model: HmmModel,
}

impl Default for HmmParams {
    fn default() -> Self {
        Self {
            // Points up to 100 m from their road are matched (a wider
            // search than the usual position error needs; the candidates
            // are ranked by emission and capped at `max_candidates`).
            search_radius_m: 100.0,
            // 10 (12 before the fifth throughput round): with the
            // emission-ratio rule below, the outputs on the real traces, the
            // long FMM track and every matching test are byte-identical to
            // 12's; 8 changed confidences on GraphHopper issue 13.
            max_candidates: 10,
            min_emission_ratio: 1e-6,
            // 2 m noise per axis plus lane and centreline offsets.
            sigma_m: 5.0,
            beta_m: 5.0,
            beta_per_m: 0.1,
            kappa_given: 3.0,
            kappa_derived: 1.0,
            min_step_m: 10.0,
            max_skip: 256,
            lag: 32,
            // Sparse fleet tracks (a fix every 30-60 s) are chained: a
            // break needs more than 3 min or 2.5 km between fixes (the
            // distance 60 s at 150 km/h covers), or no plausible route.
            gap_m: 2500.0,
            gap_s: 180.0,
            // 150 km/h.
            max_speed_mps: 150.0 / 3.6,
            backtrack_m: 15.0,
            uturn_penalty_m: 300.0,
            // √(19.4² + 5²) = 20 m: without tracking, the classic emission σ.
            drift_sigma_m: 19.4,
            // Drift diffusion 2σ²/L ≈ 1.9 m²/m: a random walk reaching 30 m
            // in about 450 m, the fast end of dead-reckoning drift (the
            // issue's design case: 30 m on routes of a few hundred metres).
            drift_correlation_m: 400.0,
            track_drift: true,
            model: HmmModel::Drift,
        }
    }
}

/// The longest route (m) a transition may take between fixes `gc_m` apart
/// in a straight line and `dt_s` apart in time: at most twice the straight
/// distance (plus twice the search radius and 100 m), and no faster than
/// `max_speed_mps` where the time is known (plus twice the radius: the fixes
/// may lie that far from the road on either side); never less than the
/// straight distance plus twice the radius and 100 m, so dense tracks
/// (where the speed bound would be tight on noise) keep their margin.
pub fn route_bound(p: &HmmParams, gc_m: f64, dt_s: f64) -> f64 {
    let r2 = 2.0 * p.search_radius_m;
    let floor = gc_m + r2 + 100.0;
    let mut cap = 2.0 * gc_m + r2 + 100.0;
    if dt_s.is_finite() && dt_s > 0.0 {
        cap = cap.min(p.max_speed_mps * dt_s + r2);
    }
    floor.max(cap)
}
