//! Errors of the rotation physics: the static centrifugal solve names the load step, the speed
//! and why Newton stopped.

use crate::error::FemError;

/// One Newton iteration of a load step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonIteration {
    /// 0 for the state the step starts from, then 1, 2, ...
    pub iteration: usize,
    /// Euclidean norm of the residual f_int(u) - f_c(u) on the free DOFs (N), after the
    /// iteration's correction.
    pub residual_norm: f64,
    /// Euclidean norm of the centrifugal load f_c(u) on the free DOFs at this state (N): the
    /// convergence test is residual_norm <= relative_tolerance x load_norm.
    pub load_norm: f64,
    /// Euclidean norm of the correction that led to this state (m); `None` for iteration 0.
    pub correction_norm: Option<f64>,
    /// Whether that correction was a chord step (the factor of an earlier tangent reused,
    /// `crate::rotation::newton`) rather than a Newton step.
    pub chord: bool,
}

/// Why a load step stopped without converging.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StopReason {
    /// The residual grew beyond `factor` times its value at the start of the step.
    #[error(
        "Newton diverged: residual {residual:e} N exceeds {factor:e} x the step's initial \
         residual {initial:e} N"
    )]
    Diverged {
        /// Residual norm reached (N).
        residual: f64,
        /// Residual norm at the start of the step (N).
        initial: f64,
        /// The divergence factor of the options.
        factor: f64,
    },
    /// The iteration limit was reached.
    #[error(
        "no convergence in {iterations} Newton iterations: residual {residual:e} N above the \
         tolerance {tolerance:e} N"
    )]
    MaxIterations {
        /// Iterations done.
        iterations: usize,
        /// Last residual norm (N).
        residual: f64,
        /// Absolute tolerance of the step (relative tolerance x load norm, N).
        tolerance: f64,
    },
    /// The tangent could not be factorized (singular, or indefinite for a Cholesky solver).
    #[error("singular tangent: {0}")]
    SingularTangent(String),
    /// The residual became NaN or infinite.
    #[error("the residual is not finite (NaN or infinite)")]
    NonFinite,
}

/// Errors of the rotation module.
#[derive(Debug, thiserror::Error)]
pub enum RotationError {
    /// An error of the finite-element front end (mesh, material, inverted element, sizes).
    #[error(transparent)]
    Fem(#[from] FemError),

    /// The rotor axis is invalid.
    #[error("invalid rotor axis: {0}")]
    InvalidAxis(String),

    /// A solver option is out of range.
    #[error("invalid option {name} = {value}; expected {expected}")]
    InvalidOption {
        /// The option.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The admissible range.
        expected: &'static str,
    },

    /// The static centrifugal solve stopped: a load step failed even after the allowed
    /// cutbacks of its increment.
    #[error(
        "centrifugal static solve stopped at load step {step} (Omega = {omega:.6e} rad/s, \
         target {target_omega:.6e} rad/s) after {cutbacks} cutbacks of the increment: {reason}"
    )]
    StaticSolve {
        /// 1-based number of the load step that failed (accepted steps + 1).
        step: usize,
        /// Speed of the last attempt of that step (rad/s).
        omega: f64,
        /// Speed the solve was asked for (rad/s).
        target_omega: f64,
        /// Cutbacks of the increment tried for that step.
        cutbacks: usize,
        /// Why the last attempt stopped.
        reason: StopReason,
        /// The Newton iterations of the last attempt.
        history: Vec<NewtonIteration>,
    },

    /// A contact node's radial growth at speed reaches its gap to the casing at rest: the
    /// running gap is not positive, the structure touches the casing statically.
    #[error(
        "the clearance closes statically at {omega:.6e} rad/s: contact node {contact} (0-based; \
         mesh node {mesh_node}) grows radially by {growth:.4e} m, more than the cold gap \
         {cold_gap:.4e} m"
    )]
    ClearanceClosed {
        /// The speed, rad/s.
        omega: f64,
        /// The node with the smallest running gap: its index among the contact nodes.
        contact: usize,
        /// Its mesh node (0-based).
        mesh_node: usize,
        /// Its radial growth, m.
        growth: f64,
        /// The gap at rest, m.
        cold_gap: f64,
        /// The speed at which its gap closes, rad/s, estimated from the Omega^2 law
        /// ([`crate::rotation::closure_speed`]); `None` for a node that does not grow.
        closure_omega: Option<f64>,
    },
}
