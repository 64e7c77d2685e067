//! Guards against writing NaN or infinities: every writer of this crate calls them on its data.

use crate::OutputError;

/// Returns an error naming `what` and the index of the first non-finite value of `data`.
///
/// `what` should name the field and the file, e.g. ``"point field `u` of out/mode.vtu"``.
pub fn check_finite(what: &str, data: &[f64]) -> Result<(), OutputError> {
    match data.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(OutputError::NonFinite {
            what: what.to_string(),
            index,
            value: data[index],
        }),
    }
}

/// Single-value form of [`check_finite`] (index reported as 0).
pub fn check_finite_value(what: &str, value: f64) -> Result<(), OutputError> {
    check_finite(what, std::slice::from_ref(&value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_first_non_finite_and_names_the_field() {
        assert!(check_finite("x", &[0.0, -1.0, 1e308]).is_ok());
        let err = check_finite("point field `u` of a.vtu", &[1.0, f64::INFINITY, f64::NAN])
            .expect_err("infinity must be refused");
        match &err {
            OutputError::NonFinite { index, value, .. } => {
                assert_eq!(*index, 1);
                assert!(value.is_infinite());
            }
            other => panic!("unexpected error {other:?}"),
        }
        let msg = err.to_string();
        assert!(
            msg.contains("point field `u` of a.vtu") && msg.contains("index 1"),
            "{msg}"
        );
        assert!(check_finite_value("w", f64::NAN).is_err());
    }
}
