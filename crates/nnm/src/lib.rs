//! Nonlinear normal modes of linear elastic structures with frictionless unilateral contact, after
//! Laxalde, Legrand & Pierre, "Nonlinear Modal Analysis of Mechanical Systems with Frictionless
//! Contact Interfaces" (ASME IDETC 2009, DETC2009-87387), Secs. 2.3-3, Eqs. (13)-(21), Algorithm 1.
//!
//! The crate knows nothing of meshes: a [`System`] is any SPD pair (M, K) with contact rows A and
//! initial gaps g0 (Eq. 17). A nonlinear mode at master amplitude q is a periodic orbit
//! u(t) = sum_{n=0..N} u_n cos(n w t) solving the harmonic balance of M u'' + K u + A^T lambda = 0
//! with the Signorini conditions on m time samples per period (Eqs. 18-20; the harmonic balance of
//! the equations of motion rather than the paper's Rayleigh-quotient scaling, see the `newton`
//! module docs), computed by Algorithm 1 (augmented Lagrangian with Powell's measure,
//! [`AlgorithmParams`]) around a semi-smooth Newton solver, with an exact condensation onto the
//! contact coordinates and the master.
//!
//! Entry points: [`Solver::solve_point`] / [`solve_point`] (one amplitude), [`backbone`]
//! (pseudo-arc-length continuation that follows folds), [`amplitude_sweep`] (given amplitude
//! levels), [`check_periodicity`] / [`integrate_penalty`] (independent time-integration check).
//!
//! Choices that depart from a literal reading, each with its reason in the module docs:
//! * Powell's measure defaults to the entrywise maximum [`PowellMeasure::Entrywise`]; DESIGN 3's
//!   row-maximum reading of Eq. (21) can accept orbits that violate complementarity.
//! * The penalty increase of an accepted iteration also divides theta by beta
//!   ([`PenaltyUpdate::KeepMultiplier`]); the printed update over-pushes (kept as an option).
//! * Penalties are capped (`max_penalty`); at the cap the multiplier is updated instead.
//! * The inner Newton has fallbacks (secant slopes at contact switches, a smoothing path, penalty
//!   and multiplier homotopies) and a per-point iteration budget; failures are typed errors that
//!   carry the last Powell measure and the iteration counts.
//!
//! Limits met on dense, many-contact models: internal resonances (n w crossing another mode) make
//! the backbone turn into resonance tongues, and a sample entering contact can make the branch of
//! the sampled problem turn sharply (a non-smooth fold). [`backbone`] follows smooth folds and
//! hops over corners at fixed q when it can; otherwise it stops and returns the points computed so
//! far with a [`Termination`] that says why.
//!
//! Modules: `system` (inputs), `fourier` (AFT), `contact` (sampled law, Powell's measure),
//! `newton` (inner solve), `newton_fallback` (smoothing path), `condensation`/`condensed` (exact condensation), `full` (uncondensed
//! validation model), `augmented_lagrangian` (Algorithm 1), `solver` (one point), `continuation`
//! (backbone), `sweep` (amplitude levels), `point` (outputs), `integrate` (time-integration cross-check), `dense` (faer
//! helpers), `error`.

mod augmented_lagrangian;
mod condensation;
mod condensed;
mod contact;
mod continuation;
mod dense;
mod error;
mod fourier;
mod full;
mod integrate;
mod modal_tail;
mod newton;
mod newton_fallback;
mod point;
mod solver;
mod stability;
mod step_timing;
mod sweep;
mod system;

pub use augmented_lagrangian::{AlgorithmParams, Condensation, ContactMethod, PenaltyUpdate};
pub use contact::{powell_measure, Multipliers, PowellMeasure};
pub use continuation::{
    backbone, Backbone, ContinuationSettings, InternalResonance, SkippedLevel, Termination,
};
pub use error::NnmError;
pub use fourier::{cosine_series, cosine_series_rate, HarmonicSettings};
pub use integrate::{check_periodicity, integrate_penalty, MotionState, PeriodicityCheck};
pub use newton::NewtonSettings;
pub use point::{reconstruct, velocity, BackbonePoint};
pub use solver::{solve_point, Solver, Start};
pub use stability::{
    classify, floquet, monodromy_by_integration, Bifurcation, FloquetAnalysis, FloquetSettings,
    JacobianInTime, Monodromy, MonodromySettings, Stability, UnstableCounts,
};
pub use step_timing::{newton_step_timing, StepTiming};
pub use sweep::amplitude_sweep;
pub use system::{ModalShares, System};
