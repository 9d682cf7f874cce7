//! The field checks every validation step shares: each error names the
//! scenario file and the field.

use crate::error::{Error, Result};
use std::path::Path;

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

/// Builds errors that name the scenario file.
pub(super) struct Check<'a> {
    pub(super) path: &'a Path,
}

impl Check<'_> {
    pub(super) fn err(&self, msg: impl Into<String>) -> Error {
        Error::scenario(self.path, msg)
    }
    pub(super) fn finite(&self, field: &str, x: f64) -> Result<f64> {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(format!(
                "{field} must be a finite number, got {}",
                short_number(x)
            )))
        }
    }
    pub(super) fn finite_all(&self, field: &str, xs: &[f64]) -> Result<()> {
        for (i, x) in xs.iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), *x)?;
        }
        Ok(())
    }
    pub(super) fn non_negative(&self, field: &str, x: f64) -> Result<f64> {
        if x.is_finite() && x >= 0.0 {
            Ok(x)
        } else {
            Err(self.err(format!(
                "{field} must be zero or positive, got {}",
                short_number(x)
            )))
        }
    }
    pub(super) fn positive(&self, field: &str, x: f64) -> Result<f64> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(format!("{field} must be positive, got {}", short_number(x))))
        }
    }
    pub(super) fn range(&self, field: &str, x: f64, lo: f64, hi: f64) -> Result<f64> {
        if x.is_finite() && x >= lo && x <= hi {
            Ok(x)
        } else {
            Err(self.err(format!(
                "{field} must be between {} and {}, got {}",
                short_number(lo),
                short_number(hi),
                short_number(x)
            )))
        }
    }
}
