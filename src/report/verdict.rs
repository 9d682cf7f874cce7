//! Verdicts with their rule stated. The rule is the planner's validation
//! rule ([`crate::planner::network::share_rule`]), the same for route
//! plans, area plans and simulations: the share of run time within the
//! requirement, estimated from one error sample per
//! [`THINNING_S`] per run, must have
//! its one-sided 95 % Clopper–Pearson lower bound at least the
//! requirement's confidence `p` (`planner.requirement_confidence`, default
//! 0.95). Green when it holds; amber when the share observed reaches `p`
//! but its lower bound does not (too few runs to be sure); red when the
//! share observed is below `p`. A folder whose files lack the rule's
//! figures (written by an earlier version) is amber at best, and says so.
//! Beside the verdict: the per-run maxima, the runs exceeding the
//! requirement and the one-sided 95 % upper bound (Clopper–Pearson) on
//! the chance that a run exceeds it somewhere.

use crate::planner::network::{share_rule, THINNING_S};

/// Confidence level of the stated bounds (the share's lower bound and the
/// chance that a run exceeds).
pub const CONFIDENCE: f64 = 0.95;

/// A verdict's colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// The rule holds.
    Green,
    /// The share observed reaches the confidence, its lower bound does
    /// not; or the rule's figures are missing; or the plan is predicted
    /// only (not simulated).
    Amber,
    /// The share observed is below the confidence (or the prediction
    /// exceeds the requirement).
    Red,
    /// Nothing to judge against (no requirement).
    Info,
}

impl Level {
    /// The CSS class of the verdict's badge.
    pub fn css(self) -> &'static str {
        match self {
            Level::Green => "pass",
            Level::Amber => "warn",
            Level::Red => "fail",
            Level::Info => "info",
        }
    }
}

/// The thinned samples the rule is decided on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Share {
    /// Thinned error samples (one per [`THINNING_S`] per run).
    pub samples: u64,
    /// Of which within the requirement.
    pub within: u64,
    /// The requirement's confidence `p`.
    pub confidence: f64,
}

impl Share {
    /// The one-sided 95 % Clopper–Pearson lower bound of the share within,
    /// and whether it reaches `p` (the planner's own function).
    pub fn lower_and_passed(&self, requirement_m: f64) -> (f64, bool) {
        let (lower, passed, _) = share_rule(
            self.within as usize,
            self.samples as usize,
            requirement_m,
            self.confidence,
        );
        (lower, passed)
    }

    /// The share observed.
    pub fn observed(&self) -> f64 {
        if self.samples == 0 {
            0.0
        } else {
            self.within as f64 / self.samples as f64
        }
    }
}

/// What a Monte Carlo verdict is decided on, and the figures beside it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// The requirement (m).
    pub requirement_m: f64,
    /// Runs.
    pub runs: u64,
    /// Runs whose maximum horizontal error exceeds the requirement; `None`
    /// when only known to be at least one (the overall maximum exceeds it).
    pub runs_exceeding: Option<u64>,
    /// Largest horizontal error over all runs (m).
    pub max_error_m: f64,
    /// Median over runs of each run's maximum (m), when known.
    pub median_run_max_m: Option<f64>,
    /// Share (of distance or time, every output sample) within the
    /// requirement, as the files give it.
    pub share_within: f64,
    /// The rule's thinned samples; `None` when the files lack them.
    pub share: Option<Share>,
}

/// The colour of a Monte Carlo verdict under the stated rule.
pub fn level(e: &Evidence) -> Level {
    match e.share {
        None => Level::Amber,
        Some(s) if s.samples == 0 => Level::Amber,
        Some(s) => {
            if s.lower_and_passed(e.requirement_m).1 {
                Level::Green
            } else if s.observed() >= s.confidence {
                Level::Amber
            } else {
                Level::Red
            }
        }
    }
}

/// One-sided upper confidence bound (Clopper–Pearson) on a probability
/// after `k` events in `n` trials: the `p` with P(X ≤ k | n, p) = 1 − level.
/// For `k = 0` this is the closed form 1 − (1 − level)^(1/n). `k ≥ n` gives 1.
pub fn upper_bound(k: u64, n: u64, level: f64) -> f64 {
    if n == 0 || k >= n {
        return 1.0;
    }
    let alpha = 1.0 - level;
    if k == 0 {
        return 1.0 - alpha.powf(1.0 / n as f64);
    }
    // The binomial CDF falls monotonically in p: bisect (60 halvings: ~1e-18).
    let cdf = |p: f64| -> f64 {
        // Sum of terms in log space, for large n.
        let (ln_p, ln_q) = (p.ln(), (1.0 - p).ln());
        let mut ln_c = 0.0; // ln C(n, 0)
        let mut sum = 0.0;
        for i in 0..=k {
            if i > 0 {
                ln_c += ((n - i + 1) as f64).ln() - (i as f64).ln();
            }
            sum += (ln_c + i as f64 * ln_p + (n - i) as f64 * ln_q).exp();
        }
        sum
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The rule as one paragraph for the page, with the confidence `p` the
/// verdicts used.
pub fn rule_text(confidence: f64) -> String {
    format!(
        "Rule (the planner's validation rule, the same for route plans, area plans and simulations): \
         the requirement is a bound that must hold with probability p = {confidence} \
         (planner.requirement_confidence). From every Monte Carlo run one horizontal error sample is \
         taken every {THINNING_S:.0} s (consecutive 1 Hz samples are strongly correlated; thinning keeps \
         the interval honest); green when the one-sided {:.0} % Clopper–Pearson lower bound of the share \
         of samples within the requirement is at least p; amber when the share observed reaches p but \
         its lower bound does not (too few runs to be sure: run more); red when the share observed is \
         below p. Since the requirement holds with probability p, not always, a run may exceed it \
         somewhere and the rule still hold: the runs exceeding, the per-run maxima and the one-sided \
         {:.0} % upper bound (Clopper–Pearson) on the chance that a run exceeds the requirement somewhere \
         are given beside each verdict.",
        100.0 * CONFIDENCE,
        100.0 * CONFIDENCE
    )
}

/// The rule's figures as one sentence.
pub fn share_text(e: &Evidence) -> String {
    match e.share {
        Some(s) if s.samples > 0 => {
            let (lower, passed) = s.lower_and_passed(e.requirement_m);
            format!(
                "{} of {} thinned samples within {} m ({:.2} %), lower bound {:.4} {} p = {} → {}.",
                s.within,
                s.samples,
                e.requirement_m,
                100.0 * s.observed(),
                lower,
                if passed { "≥" } else { "<" },
                s.confidence,
                if passed {
                    "rule holds"
                } else {
                    "rule does not hold"
                }
            )
        }
        Some(_) => "No thinned samples: the rule cannot be applied.".into(),
        None => {
            "The files lack the rule's thinned samples (written by an earlier Waymark version?): \
                 the rule cannot be applied; run the command again."
                .into()
        }
    }
}

/// The per-run figures as one sentence: runs exceeding, per-run maxima,
/// the share within over every output sample and the bound on the chance
/// that a run exceeds.
pub fn figures_text(e: &Evidence, share_of: &str) -> String {
    let over = 100.0 * (e.max_error_m / e.requirement_m - 1.0);
    let exceeding = match e.runs_exceeding {
        Some(k) => format!("{k} of {} run(s) exceed it somewhere", e.runs),
        None if e.max_error_m > e.requirement_m => {
            format!("at least 1 of {} run(s) exceeds it somewhere", e.runs)
        }
        None => format!("none of {} run(s) exceeds it", e.runs),
    };
    let k = e
        .runs_exceeding
        .unwrap_or(u64::from(e.max_error_m > e.requirement_m));
    let bound = upper_bound(k, e.runs, CONFIDENCE);
    format!(
        "{exceeding}; per-run maxima: largest {:.2} m ({}){}; {:.2} % of the {share_of} within {} m; \
         chance that a run exceeds the requirement somewhere ≤ {:.1} % ({:.0} % confidence).",
        e.max_error_m,
        if over > 0.0 {
            format!("{over:.0} % over the requirement")
        } else {
            format!("{:.0} % of the requirement", 100.0 * e.max_error_m / e.requirement_m)
        },
        e.median_run_max_m
            .map(|m| format!(", median {m:.2} m"))
            .unwrap_or_default(),
        100.0 * e.share_within,
        e.requirement_m,
        100.0 * bound,
        100.0 * CONFIDENCE
    )
}

/// A finite number of a JSON value, if it is one.
pub(super) fn num(v: &serde_json::Value) -> Option<f64> {
    v.as_f64().filter(|x| x.is_finite())
}

/// A verdict badge: `text` coloured by `level`.
pub(super) fn badge(level: Level, text: &str) -> String {
    format!(
        "<span class=\"verdict {}\" data-level=\"{}\">{}</span>",
        level.css(),
        match level {
            Level::Green => "green",
            Level::Amber => "amber",
            Level::Red => "red",
            Level::Info => "info",
        },
        quick_xml::escape::escape(text)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(k: Option<u64>, max: f64, share: Option<(u64, u64)>) -> Evidence {
        Evidence {
            requirement_m: 20.0,
            runs: 20,
            runs_exceeding: k,
            max_error_m: max,
            median_run_max_m: Some(9.0),
            share_within: 0.998,
            share: share.map(|(within, samples)| Share {
                samples,
                within,
                confidence: 0.95,
            }),
        }
    }

    #[test]
    fn green_only_when_the_lower_bound_reaches_the_confidence() {
        // 360 of 360 samples: lower bound 0.05^(1/360) = 0.99171 ≥ 0.95,
        // green even with a run exceeding somewhere (the demo's case:
        // 23.05 m against 20 m in 1 of 20 runs, between samples).
        assert_eq!(level(&ev(Some(1), 23.05, Some((360, 360)))), Level::Green);
        // 58 of 58: 0.05^(1/58) = 0.9497 < 0.95 — observed 100 % ≥ p but
        // not sure yet: amber. 59 of 59: 0.9505 ≥ 0.95: green.
        assert_eq!(level(&ev(Some(0), 12.0, Some((58, 58)))), Level::Amber);
        assert_eq!(level(&ev(Some(0), 12.0, Some((59, 59)))), Level::Green);
        // Observed 94 % < 95 %: red, however many samples.
        assert_eq!(level(&ev(Some(9), 40.0, Some((940, 1000)))), Level::Red);
        // No figures: the rule cannot be applied; never green.
        assert_eq!(level(&ev(Some(0), 12.0, None)), Level::Amber);
        assert_eq!(level(&ev(Some(0), 12.0, Some((0, 0)))), Level::Amber);
    }

    #[test]
    fn upper_bound_matches_closed_forms() {
        // k = 0: 1 − 0.05^(1/n); for n = 20, 0.13911 (the "rule of three"
        // 3/n = 0.15 approximates it).
        assert!((upper_bound(0, 20, 0.95) - 0.139_108).abs() < 1e-5);
        // k = n − 1: P(X ≤ n−1) = 1 − p^n = 0.05 → p = 0.95^(1/n).
        let n = 10;
        assert!((upper_bound(n - 1, n, 0.95) - 0.95f64.powf(0.1)).abs() < 1e-9);
        // k = 1, n = 20: tabulated Clopper–Pearson one-sided 95 % upper
        // limit 0.2161 (e.g. the beta quantile Beta(2, 19) at 0.95).
        assert!((upper_bound(1, 20, 0.95) - 0.2161).abs() < 5e-4);
        assert_eq!(upper_bound(3, 3, 0.95), 1.0);
        // Monotone in k.
        let b: Vec<f64> = (0..6).map(|k| upper_bound(k, 100, 0.95)).collect();
        assert!(b.windows(2).all(|w| w[0] < w[1]), "{b:?}");
    }

    #[test]
    fn figures_name_the_runs_the_maxima_and_the_rule() {
        let e = ev(Some(1), 24.06, Some((360, 360)));
        let t = figures_text(&e, "time");
        assert!(t.contains("1 of 20 run(s) exceed it"), "{t}");
        assert!(
            t.contains("largest 24.06 m (20 % over the requirement), median 9.00 m"),
            "{t}"
        );
        assert!(t.contains("99.80 % of the time within 20 m"), "{t}");
        assert!(t.contains("≤ 21.6 %"), "{t}");
        let s = share_text(&e);
        // 0.05^(1/360) = 0.991713.
        assert!(
            s.contains("360 of 360 thinned samples") && s.contains("lower bound 0.9917 ≥ p = 0.95"),
            "{s}"
        );
        assert!(share_text(&ev(Some(0), 1.0, None)).contains("cannot be applied"));
        assert!(rule_text(0.9).contains("p = 0.9 "));
    }
}
