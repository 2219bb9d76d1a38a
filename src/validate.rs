//! The crate's one family of setting checks: each returns [`Error::InvalidSetting`] naming the
//! field or `--flag` and what is required of it, with the value given.

use crate::error::{Error, Result};

/// `value` is a finite number ≥ 0, or an error naming it (`name`: a field or a `--flag`).
pub fn ensure_non_negative(name: &str, value: f64) -> Result<()> {
    require(
        value.is_finite() && value >= 0.0,
        name,
        format!("must be a finite number ≥ 0, got {value}"),
    )
}

/// `value` is a finite number > 0, or an error naming it.
pub fn ensure_positive(name: &str, value: f64) -> Result<()> {
    require(
        value.is_finite() && value > 0.0,
        name,
        format!("must be a finite number > 0, got {value}"),
    )
}

/// An iteration count is at least 1, or an error naming it.
pub fn ensure_iterations(name: &str, iterations: usize) -> Result<()> {
    require(iterations > 0, name, "must be at least 1, got 0".into())
}

/// `value` is ≥ 1, where ∞ is allowed (it switches a feature off), or an error naming it.
pub fn ensure_factor_or_infinite(name: &str, value: f64) -> Result<()> {
    require(
        value >= 1.0,
        name,
        format!("must be a number ≥ 1, got {value}"),
    )
}

/// `value` is > 0, where ∞ is allowed (it switches a feature off), or an error naming it.
pub fn ensure_positive_or_infinite(name: &str, value: f64) -> Result<()> {
    require(
        value > 0.0,
        name,
        format!("must be a number > 0, got {value}"),
    )
}

/// A count is at most `max`, or an error naming it.
pub fn ensure_at_most(name: &str, value: usize, max: usize) -> Result<()> {
    require(
        value <= max,
        name,
        format!("must be at most {max}, got {value}"),
    )
}

/// `Ok` when `ok`, else [`Error::InvalidSetting`] for `name`.
fn require(ok: bool, name: &str, requirement: String) -> Result<()> {
    match ok {
        true => Ok(()),
        false => Err(Error::InvalidSetting {
            name: name.to_string(),
            requirement,
        }),
    }
}

/// `value` lies strictly between 0 and 1 (a relative tolerance), or an error naming it.
pub fn ensure_open_unit(name: &str, value: f64) -> Result<()> {
    require(
        value > 0.0 && value < 1.0,
        name,
        format!("must be in (0, 1), got {value}"),
    )
}
