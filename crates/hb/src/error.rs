//! Typed errors of the harmonic-balance engine and the problems built on it (free modes in
//! `nlmodes-nnm`, forced response).
//!
//! Every message names the offending input (matrix, row, parameter) and what was expected, so that
//! the command-line program can show it as is.

use nlmodes_dense::{DenseError, SymmetryError, SYMMETRY_TOLERANCE};

/// Errors returned by `nlmodes-hb` and the crates built on it (`nlmodes-nnm` calls it `NnmError`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HbError {
    /// A matrix that must be square (or of a given size) is not.
    #[error("matrix {name} is {rows}x{cols}, expected {expected}x{expected}")]
    Shape {
        /// Which matrix (`M`, `K`, ...).
        name: &'static str,
        /// Rows found.
        rows: usize,
        /// Columns found.
        cols: usize,
        /// Expected dimension.
        expected: usize,
    },
    /// The system has no degree of freedom.
    #[error("the system has no degree of freedom (M and K are 0x0)")]
    Empty,
    /// A matrix entry is NaN or infinite.
    #[error("matrix {name} has a non-finite entry {value} at ({row}, {col})")]
    NonFinite {
        /// Which matrix.
        name: &'static str,
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The value found.
        value: f64,
    },
    /// A matrix that must be symmetric is clearly not.
    #[error(
        "matrix {name} is not symmetric: |a({row},{col}) - a({col},{row})| = {difference:e} exceeds \
         {tolerance:e} x max|a| = {scale:e}"
    )]
    NotSymmetric {
        /// Which matrix.
        name: &'static str,
        /// Row of the worst pair.
        row: usize,
        /// Column of the worst pair.
        col: usize,
        /// The absolute asymmetry found.
        difference: f64,
        /// Relative tolerance that was applied.
        tolerance: f64,
        /// Largest absolute entry of the matrix.
        scale: f64,
    },
    /// A matrix that must be symmetric positive definite is not.
    #[error("matrix {name} is not positive definite: {detail}")]
    NotPositiveDefinite {
        /// Which matrix.
        name: &'static str,
        /// What the factorization reported.
        detail: String,
    },
    /// Contact rows whose width differs from the number of degrees of freedom.
    #[error(
        "contact rows have {cols} columns, expected {expected} (the number of DOFs of M and K)"
    )]
    ContactRowsWidth {
        /// Columns found.
        cols: usize,
        /// Number of DOFs.
        expected: usize,
    },
    /// A contact row is zero or not finite.
    #[error("contact row {row} is invalid: {detail}")]
    InvalidContactRow {
        /// Index of the row.
        row: usize,
        /// What is wrong.
        detail: String,
    },
    /// Number of gaps differs from the number of contact rows.
    #[error("{gaps} initial gaps given for {rows} contact rows (one gap per row expected)")]
    GapCount {
        /// Gaps given.
        gaps: usize,
        /// Contact rows.
        rows: usize,
    },
    /// An initial gap is not finite and positive.
    #[error(
        "initial gap {index} is {value}; every initial gap g0 must be finite and > 0 (Eq. 17)"
    )]
    NonPositiveGap {
        /// Index of the contact row.
        index: usize,
        /// Value found.
        value: f64,
    },
    /// Master coordinate index out of range.
    #[error(
        "master coordinate {master} is out of range: the system has {dofs} DOFs (valid 0..{dofs})"
    )]
    MasterOutOfRange {
        /// Index given.
        master: usize,
        /// Number of DOFs.
        dofs: usize,
    },
    /// Mode index out of range.
    #[error("linear mode {mode} requested but the system has only {count} modes")]
    ModeOutOfRange {
        /// Index given.
        mode: usize,
        /// Number of modes.
        count: usize,
    },
    /// The master coordinate does not move in the requested linear mode.
    #[error(
        "the master coordinate {master} does not move in linear mode {mode} (|phi_master| = {value:e} \
         relative to max |phi|): choose another master coordinate"
    )]
    MasterNotInMode {
        /// Master coordinate.
        master: usize,
        /// Mode index.
        mode: usize,
        /// Relative master component.
        value: f64,
    },
    /// Harmonic settings that cannot work.
    #[error("harmonic settings: {detail}")]
    HarmonicSettings {
        /// What is wrong.
        detail: String,
    },
    /// An algorithm or continuation parameter out of range.
    #[error("parameter {name} = {} is invalid: expected {expected}", show_value(*.value))]
    InvalidParameter {
        /// Parameter name as in the settings file.
        name: &'static str,
        /// Value given.
        value: f64,
        /// What is expected.
        expected: &'static str,
    },
    /// A warm start whose sizes do not match the solver.
    #[error("warm start does not match the solver: {detail}")]
    WarmStart {
        /// What differs.
        detail: String,
    },
    /// Contact rows that are linearly dependent (the exact condensation needs independent rows).
    #[error(
        "contact rows are linearly dependent (numerical rank {rank} of {rows} rows): the condensed \
         Newton needs independent rows; use condensation = \"none\""
    )]
    DependentContactRows {
        /// Numerical rank found.
        rank: usize,
        /// Number of rows.
        rows: usize,
    },
    /// A dense decomposition failed.
    #[error("{what} failed: {detail}")]
    Decomposition {
        /// Which decomposition.
        what: &'static str,
        /// Details.
        detail: String,
    },
    /// The inner semi-smooth Newton solve of Eq. (20) did not converge.
    #[error(
        "Newton solve of the harmonic balance (Eq. 20) failed after {iterations} iterations: {reason} \
         (relative residual {residual:e}, tolerance {tolerance:e})"
    )]
    NewtonFailed {
        /// Iterations performed.
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
        /// Tolerance required.
        tolerance: f64,
        /// Why it stopped.
        reason: String,
    },
    /// Algorithm 1 stopped without reaching G <= epsilon.
    #[error(
        "augmented Lagrangian (Algorithm 1) did not converge at q/g0 = {q_over_g0}: {reason}; \
         last Powell measure G = {measure:e} (epsilon = {epsilon:e}), {accepted} accepted \
         iterations, {solves} inner solves, {newton_iterations} Newton iterations"
    )]
    NotConverged {
        /// Amplitude of the master coordinate (m).
        q: f64,
        /// The same amplitude in units of the reference gap g0 (how every log line gives it).
        q_over_g0: f64,
        /// Why it stopped.
        reason: String,
        /// Last Powell measure G (Eq. 21), in units of g0.
        measure: f64,
        /// Required epsilon.
        epsilon: f64,
        /// Accepted iterations i.
        accepted: usize,
        /// Inner solves performed.
        solves: usize,
        /// Newton iterations performed in total.
        newton_iterations: usize,
    },
    /// A continuation corrector whose iterate left the neighbourhood of its predictor: an
    /// iterate of Algorithm 1 farther than the leash from the predictor (q, w), in the scaled
    /// units of the parameter row (q / g_ref, w / w_lin).
    #[error(
        "the corrector left its predictor: an iterate {distance:.3e} away in scaled (q, w), \
         leash {radius:.3e}"
    )]
    LeftPredictor {
        /// Distance of the iterate from the predictor (scaled).
        distance: f64,
        /// The leash (scaled).
        radius: f64,
    },
    /// An inner solve of a problem built on the engine failed (its own words).
    #[error("{detail}")]
    InnerSolve {
        /// What the problem reported.
        detail: String,
    },
    /// A time integration step that is too large for explicit RK4 stability.
    #[error(
        "time step {step:e} s is too large for RK4: the highest frequency {omega_max:e} rad/s needs at \
         most {max_step:e} s (use at least {min_steps} steps)"
    )]
    StepTooLarge {
        /// Step requested.
        step: f64,
        /// Highest circular frequency of the penalized system.
        omega_max: f64,
        /// Largest stable step used as a limit.
        max_step: f64,
        /// Minimal number of steps.
        min_steps: usize,
    },
    /// A computation produced a NaN or infinity.
    #[error("non-finite value produced in {what}")]
    NonFiniteResult {
        /// Where.
        what: &'static str,
    },
    /// A point that cannot be analysed for stability (sizes that do not match the system).
    #[error("stability analysis: {detail}")]
    StabilityInput {
        /// What does not match.
        detail: String,
    },
}

impl HbError {
    /// The error of a failure of `nlmodes_dense` whose Cholesky factor is that of the matrix
    /// `name` (`M`, `K`, ...): `map_err(HbError::dense("M"))`.
    pub fn dense(name: &'static str) -> impl Fn(DenseError) -> Self {
        move |e| match e {
            DenseError::NotPositiveDefinite(_) => HbError::NotPositiveDefinite {
                name,
                detail: e.to_string(),
            },
            DenseError::Eigen(detail) => HbError::Decomposition {
                what: "symmetric eigen-decomposition",
                detail: format!("{detail:?}"),
            },
            DenseError::NonFinite => HbError::NonFiniteResult {
                what: "generalized eigenvalues",
            },
            DenseError::General { what, .. } | DenseError::Unchecked { what, .. } => {
                HbError::Decomposition {
                    what,
                    detail: e.to_string(),
                }
            }
        }
    }

    /// The error of the matrix `name` of order `n` that fails `nlmodes_dense::check_symmetric`.
    pub fn symmetry(name: &'static str, n: usize) -> impl Fn(SymmetryError) -> Self {
        move |e| match e {
            SymmetryError::NotSquare { rows, cols } => HbError::Shape {
                name,
                rows,
                cols,
                expected: n,
            },
            SymmetryError::NonFinite { row, col, value } => HbError::NonFinite {
                name,
                row,
                col,
                value,
            },
            SymmetryError::NotSymmetric {
                row,
                col,
                a_ij,
                a_ji,
                scale,
            } => HbError::NotSymmetric {
                name,
                row,
                col,
                difference: (a_ij - a_ji).abs(),
                tolerance: SYMMETRY_TOLERANCE,
                scale,
            },
        }
    }
}

/// A parameter value as a person reads it: plain decimal (`35`, `0.25`) unless very large or
/// very small, then in exponent form (`1e300`, `2.5e-9`), not 300 digits.
fn show_value(value: f64) -> String {
    let a = value.abs();
    if value.is_finite() && a != 0.0 && !(1e-6..1e9).contains(&a) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameter_values_are_printed_readably() {
        let msg = |value: f64| {
            HbError::InvalidParameter {
                name: "step",
                value,
                expected: "x",
            }
            .to_string()
        };
        assert_eq!(msg(0.25), "parameter step = 0.25 is invalid: expected x");
        assert_eq!(msg(35.0), "parameter step = 35 is invalid: expected x");
        assert_eq!(msg(0.0), "parameter step = 0 is invalid: expected x");
        assert_eq!(
            msg(-1e300),
            "parameter step = -1e300 is invalid: expected x"
        );
        assert_eq!(
            msg(2.5e-9),
            "parameter step = 2.5e-9 is invalid: expected x"
        );
        assert_eq!(msg(f64::NAN), "parameter step = NaN is invalid: expected x");
        assert_eq!(
            msg(f64::INFINITY),
            "parameter step = inf is invalid: expected x"
        );
    }
}
