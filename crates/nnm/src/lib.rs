//! Nonlinear normal modes of linear elastic structures with frictionless unilateral contact, after
//! Laxalde, Legrand & Pierre, "Nonlinear Modal Analysis of Mechanical Systems with Frictionless
//! Contact Interfaces" (ASME IDETC 2009, DETC2009-87387), Secs. 2.3-3, Eqs. (13)-(21), Algorithm 1.
//!
//! The crate knows nothing of meshes: a [`System`] is any SPD pair (M, K) with contact rows A and
//! initial gaps g0 (Eq. 17). A nonlinear mode at master amplitude q is a periodic orbit
//! u(t) = sum_{n=0..N} u_n cos(n w t) solving the harmonic balance of M u'' + K u + A^T lambda = 0
//! with Signorini conditions on the time samples (Eq. 20 as DESIGN 3 reads it, see [`newton`'s
//! docs](crate#modules)), computed by Algorithm 1 (augmented Lagrangian with Powell's measure,
//! [`AlgorithmParams`]) around a semi-smooth Newton solver, with an exact condensation onto the
//! contact coordinates. [`backbone`] traces w(q) by pseudo-arc-length continuation.
//!
//! Modules: `system` (inputs), `fourier` (AFT), `contact` (sampled law, Powell's measure),
//! `newton` (inner solve), `condensation`/`condensed` (exact condensation), `full` (uncondensed
//! validation model), `augmented_lagrangian` (Algorithm 1), `solver` (one point), `continuation`
//! (backbone), `point` (outputs), `integrate` (time-integration cross-check).

mod augmented_lagrangian;
mod condensation;
mod condensed;
mod contact;
mod dense;
mod error;
mod fourier;
mod full;
mod integrate;
mod newton;
mod point;
mod solver;
mod system;
mod continuation;

pub use augmented_lagrangian::{AlgorithmParams, Condensation, ContactMethod, PenaltyUpdate};
pub use contact::{powell_measure, Multipliers, PowellMeasure};
pub use continuation::{
    amplitude_sweep, backbone, Backbone, ContinuationSettings, SkippedLevel, Termination,
};
pub use error::NnmError;
pub use fourier::{cosine_series, cosine_series_rate, HarmonicSettings};
pub use integrate::{check_periodicity, integrate_penalty, MotionState, PeriodicityCheck};
pub use newton::NewtonSettings;
pub use point::{reconstruct, velocity, BackbonePoint};
pub use solver::{solve_point, Solver, Start};
pub use system::System;
