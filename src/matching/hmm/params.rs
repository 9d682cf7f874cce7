//! The HMM matcher's parameters and their defaults.

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
