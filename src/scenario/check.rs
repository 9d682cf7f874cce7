//! The field checks every validation step shares: each error names the
//! scenario file and the field.

use crate::error::{Error, Result};
use std::path::Path;

pub(crate) use crate::decimal::{short_number, shorten_numbers};

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
