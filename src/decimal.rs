//! Decimal text of a number with a fixed count of decimals: exactly the
//! characters of `format!("{x:.p$}")`, without the formatting machinery.
//!
//! MATCHED.csv writes five such numbers per row, and core's exact
//! formatting (Grisu with a Dragon fallback, through `fmt::write`) was a
//! third of `waymark match`'s instructions on long tracks. The crates for
//! fast float text (`ryu`, `dtoa`) give the shortest round-trip text, not a
//! fixed count of decimals with std's rounding, so this is written here.
//!
//! Exactness: a finite `f64` is `m · 2^e` exactly (integer `m < 2^53`).
//! For `|x| < 10^9` and at most 9 decimals, `m · 10^p < 2^83` is an exact
//! `u128`, and shifting it right by `-e` with the remainder compared with
//! half rounds the exact binary value half to even, as std does. A
//! negative number keeps its sign when it rounds to zero (`-0.000`), as
//! std's text does, and so does `-0.0`. Anything else (more decimals,
//! larger magnitudes, NaN, infinities) is handed to `format!` itself.
//!
//! Also here, for error lines: a number in scientific notation where
//! Rust's full decimal form would be long (`short_number`,
//! `shorten_numbers`).

use std::fmt::Write;

/// Most decimals the exact integer path takes.
const MAX_DECIMALS: u32 = 9;
/// Magnitudes below this take the integer path (the rounded value times
/// 10^9 then stays below 10^18 < 2^64).
const MAX_MAGNITUDE: f64 = 1e9;
/// 10^p for p up to `MAX_DECIMALS` (a look-up, not a power per number).
const POW10: [u64; MAX_DECIMALS as usize + 1] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
];

/// Appends `x` with `decimals` digits after the point, the same text as
/// `write!(s, "{x:.decimals$}")`.
///
/// ```
/// let mut s = String::new();
/// waymark::decimal::push_fixed(&mut s, 59.3293371, 7);
/// s.push(',');
/// waymark::decimal::push_fixed(&mut s, 0.125, 2); // half to even
/// s.push(',');
/// waymark::decimal::push_fixed(&mut s, -0.0001, 3); // the sign kept
/// assert_eq!(s, "59.3293371,0.12,-0.000");
/// ```
pub fn push_fixed(s: &mut String, x: f64, decimals: u32) {
    if decimals > MAX_DECIMALS || x.is_nan() || x.abs() >= MAX_MAGNITUDE {
        let _ = write!(s, "{x:.*}", decimals as usize);
        return;
    }
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1u64 << 52) - 1);
    // x = m · 2^e exactly; |x| < 10^9 < 2^30 makes e ≤ 29 − 52 < 0.
    let (m, e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1u64 << 52), biased - 1075)
    };
    let shift = (-e) as u32;
    let scaled = u128::from(m) * u128::from(POW10[decimals as usize]);
    // scaled < 2^53 · 10^9 < 2^83: beyond a shift of 84 bits it is below
    // half a unit, so it rounds to 0.
    let q = if shift > 84 {
        0
    } else {
        let q = scaled >> shift;
        let r = scaled & ((1u128 << shift) - 1);
        let half = 1u128 << (shift - 1);
        if r > half || (r == half && q & 1 == 1) {
            q + 1
        } else {
            q
        }
    } as u64;
    if bits >> 63 == 1 {
        s.push('-');
    }
    // The digits of the scaled integer once (`itoa`: two digits per step,
    // no UTF-8 check of its own output), the point put `decimals` digits
    // from the right: `q = int · 10^p + frac`, `frac < 10^p`, so the text
    // of `q` is the integer part's followed by the fraction's padded to
    // `p` digits whenever the integer part is not 0; when it is, `q` has
    // at most `p` digits and is padded with zeros after "0.".
    let mut buf = itoa::Buffer::new();
    let digits = buf.format(q);
    let p = decimals as usize;
    if p == 0 {
        s.push_str(digits);
    } else if digits.len() > p {
        let (int, frac) = digits.split_at(digits.len() - p);
        s.push_str(int);
        s.push('.');
        s.push_str(frac);
    } else {
        s.push_str("0.");
        s.push_str(&ZEROS[..p - digits.len()]);
        s.push_str(digits);
    }
}

/// Appends `x` as `write!(s, "{x}")` writes it (std's shortest text that
/// reads back as `x`, never an exponent). Whole numbers below 2^53, as the
/// times of 1 Hz tracks are, take an integer path: std writes them as
/// their integer's digits ("-0" for negative zero); the rest go to
/// `write!` itself.
///
/// ```
/// let mut s = String::new();
/// for x in [17.0, -0.0, 0.25, 1e21] {
///     waymark::decimal::push_display(&mut s, x);
///     s.push(' ');
/// }
/// assert_eq!(s, "17 -0 0.25 1000000000000000000000 ");
/// ```
pub fn push_display(s: &mut String, x: f64) {
    // 2^53: every whole f64 below it is an exact i64.
    const EXACT: f64 = 9_007_199_254_740_992.0;
    if x.abs() < EXACT && x.fract() == 0.0 {
        if x == 0.0 && x.is_sign_negative() {
            s.push('-');
        }
        s.push_str(itoa::Buffer::new().format(x as i64));
    } else {
        let _ = write!(s, "{x}");
    }
}

/// Zeros to pad a fraction with (at most `MAX_DECIMALS` of them).
const ZEROS: &str = "000000000";

/// `x` as the error line prints it: as written for ordinary numbers, in
/// scientific notation when Rust's full decimal form would be long
/// (`1e308`, not 309 digits; `1e-300`, not 300 zeros).
pub(crate) fn short_number(x: f64) -> String {
    let a = x.abs();
    if x.is_finite() && x != 0.0 && !(1e-6..1e16).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `msg` with every number of more than 24 digits replaced by
/// [`short_number`] of it. No integer Waymark reads is that long (u64::MAX
/// has 20); serde writes a float it refuses in full (`invalid type:
/// floating point `1000…000``, 309 digits for 1e308).
pub(crate) fn shorten_numbers(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len().min(256));
    let mut rest = msg;
    while let Some(start) = rest.find(|c: char| c.is_ascii_digit()) {
        out.push_str(&rest[..start]);
        let tail = &rest[start..];
        let end = tail
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(tail.len());
        let number = &tail[..end];
        let digits = number.chars().filter(char::is_ascii_digit).count();
        match number.parse::<f64>() {
            Ok(x) if digits > 24 => out.push_str(&short_number(x)),
            _ => out.push_str(number),
        }
        rest = &tail[end..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn both(x: f64, p: u32) {
        let mut got = String::new();
        push_fixed(&mut got, x, p);
        let want = format!("{x:.*}", p as usize);
        assert_eq!(got, want, "{x:e} ({:#x}) with {p} decimals", x.to_bits());
    }

    /// Exact ties (k + ½ units of the last decimal, representable in
    /// binary), zeros of both signs, the smallest subnormal, values that
    /// round up across a power of ten, the edges of the integer path and
    /// the cases handed to `format!`: the same text as std's.
    #[test]
    fn edge_cases_give_std_text() {
        for p in 0..=12u32 {
            for x in [
                0.0,
                -0.0,
                0.5,
                1.5,
                2.5,
                -2.5,
                0.125,
                0.375,
                -0.125,
                0.25,
                f64::from_bits(1),
                -f64::from_bits(1),
                9.999_999_999_5,
                99.995,
                0.000_000_000_1,
                -0.000_000_000_1,
                999_999_999.999_999_9,
                -999_999_999.999_999_9,
                1e9,
                -1e9,
                1e300,
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                179.999_999_95,
                -179.999_999_95,
            ] {
                both(x, p);
            }
            // Ties of the last decimal: (2k + 1) / 2^(j) with j ≥ 1 lands
            // on half a unit whenever 10^p · that is a half-integer.
            for j in 1..=12 {
                for k in 0..64u32 {
                    let x = f64::from(2 * k + 1) / f64::from(1u32 << j);
                    both(x, p);
                    both(-x, p);
                }
            }
        }
    }

    fn display_both(x: f64) {
        let mut got = String::new();
        push_display(&mut got, x);
        assert_eq!(got, format!("{x}"), "{x:e} ({:#x})", x.to_bits());
    }

    #[test]
    fn whole_numbers_give_std_display_text() {
        let big = 9_007_199_254_740_992.0f64;
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            59.0,
            1e15,
            -1e15,
            big - 1.0,
            -(big - 1.0),
            big,
            -big,
            big + 2.0,
            1e21,
            0.5,
            -0.5,
            1e-300,
            f64::from_bits(1),
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1_764_579_600.0,
            1_764_579_600.25,
        ] {
            display_both(x);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        /// Any bit pattern (every magnitude, NaN, subnormals) and any
        /// count of decimals up to 12: std's text.
        #[test]
        fn any_bits_give_std_text(bits in any::<u64>(), p in 0u32..=12) {
            both(f64::from_bits(bits), p);
        }

        /// Coordinates, offsets, distances and confidences as MATCHED.csv
        /// writes them: std's text.
        #[test]
        fn any_bits_give_std_display_text(bits in any::<u64>()) {
            display_both(f64::from_bits(bits));
        }

        #[test]
        fn times_give_std_display_text(t in -1e10f64..4e9, k in 0u32..4) {
            // Whole seconds, and tenths, halves and hundredths of them.
            let x = match k {
                0 => t.round(),
                1 => (t * 10.0).round() / 10.0,
                2 => (t * 2.0).round() / 2.0,
                _ => (t * 100.0).round() / 100.0,
            };
            display_both(x);
        }

        #[test]
        fn map_values_give_std_text(x in -400.0f64..400.0, y in 0.0f64..1e7, p in 0u32..=9) {
            both(x, p);
            both(y, p);
            both(x / 1e6, p);
        }
    }
}
