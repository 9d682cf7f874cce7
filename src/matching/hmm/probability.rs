//! Scores to probabilities: the arg-max of a score vector, normalisation
//! and the soft-max used by the forward–backward smoother.

pub(super) fn argmax(v: &[f64]) -> u32 {
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
pub(super) fn normalise(v: &mut [f64]) -> bool {
    let sum: f64 = v.iter().sum();
    if !(sum > 0.0 && sum.is_finite()) {
        return false;
    }
    v.iter_mut().for_each(|x| *x /= sum);
    true
}

/// Shifts log scores so that the largest is 0 (Viterbi scores stay near
/// zero on long tracks). Only called when some score is finite.
pub(super) fn shift_max_to_zero(v: &mut [f64]) {
    let m = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    for s in v {
        *s -= m;
    }
}

/// Probabilities from log scores into `out` (all zero if none is finite).
pub(super) fn softmax_into(scores: &[f64], out: &mut Vec<f64>) {
    let m = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    out.clear();
    if !m.is_finite() {
        out.resize(scores.len(), 0.0);
        return;
    }
    out.extend(scores.iter().map(|s| (s - m).exp()));
    normalise(out);
}

#[cfg(test)]
mod tests {
    use super::*;

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
