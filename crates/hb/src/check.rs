//! Range checks of parameters, one implementation for every settings type of the crate: the
//! error names the parameter, its value and what was expected.

use crate::error::HbError;

/// `value` must be finite and > 0.
pub fn positive(name: &'static str, value: f64) -> Result<(), HbError> {
    require(
        name,
        value,
        value.is_finite() && value > 0.0,
        "a finite value > 0",
    )
}

/// `value` must be finite and > 1.
pub fn greater_than_one(name: &'static str, value: f64) -> Result<(), HbError> {
    require(
        name,
        value,
        value.is_finite() && value > 1.0,
        "a finite value > 1",
    )
}

/// A count that must be at least 1.
pub fn at_least_one(name: &'static str, value: usize) -> Result<(), HbError> {
    require(name, value as f64, value >= 1, ">= 1")
}

/// Fails with [`HbError::InvalidParameter`] unless `ok`.
pub fn require(
    name: &'static str,
    value: f64,
    ok: bool,
    expected: &'static str,
) -> Result<(), HbError> {
    if ok {
        Ok(())
    } else {
        Err(HbError::InvalidParameter {
            name,
            value,
            expected,
        })
    }
}
