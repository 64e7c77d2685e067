//! Typed errors of the forced response. Each names the input (damping entry, load harmonic,
//! frequency range) with its value and what was expected, so the command line shows it as is.

use nlmodes_hb::HbError;

/// Errors returned by `nlmodes-forced`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ForcedError {
    /// An error of the harmonic-balance engine (system, settings, factorizations).
    #[error(transparent)]
    Engine(#[from] HbError),
    /// A damping value out of range.
    #[error("damping {what} = {value:e}: expected {expected}")]
    Damping {
        /// Which entry (`rayleigh.alpha`, `modal_ratios[2]`, `C[3][4]`).
        what: String,
        /// The value found.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// A load that cannot be applied.
    #[error("load {what}: {detail}")]
    Load {
        /// Which part (`harmonic 3`, `cos[12]`).
        what: String,
        /// What is wrong and what was expected.
        detail: String,
    },
    /// A matrix or vector of the wrong size.
    #[error("{what} is {found}, expected {expected}")]
    Shape {
        /// Which matrix or vector.
        what: String,
        /// Size found.
        found: String,
        /// Size expected.
        expected: String,
    },
    /// A continuation or solver parameter out of range.
    #[error("{name} = {value:e}: expected {expected}")]
    Parameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// The solve at one frequency failed.
    #[error("no forced orbit at w = {omega:.6e} rad/s: {reason}")]
    NotConverged {
        /// Excitation frequency (rad/s).
        omega: f64,
        /// Why (the engine's words, with the last Powell measure where known).
        reason: String,
    },
    /// The forced problem at a rotation speed could not be built (a speed sweep's family:
    /// outside its range, a running gap closed there, a model that does not assemble).
    #[error("no forced problem at the speed {speed:.6e} rad/s: {reason}")]
    Speed {
        /// The rotation speed (rad/s).
        speed: f64,
        /// Why.
        reason: String,
    },
}
