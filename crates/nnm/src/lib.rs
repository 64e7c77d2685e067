//! Nonlinear normal modes of linear elastic structures with frictionless unilateral contact, after
//! Laxalde, Legrand & Pierre, "Nonlinear Modal Analysis of Mechanical Systems with Frictionless
//! Contact Interfaces" (ASME IDETC 2009, DETC2009-87387), Secs. 2.3-3, Eqs. (13)-(21), Algorithm 1.
//!
//! # Equations and where they are implemented
//!
//! | paper | what | implemented in | DESIGN |
//! |---|---|---|---|
//! | Eqs. 3c, 7c, 11b | Signorini: g <= 0, lambda >= 0, lambda . g = 0 | `system::System`, `contact::apply_contact_law` | 3, 3.3 |
//! | Eq. 6 | Fourier series, here even: u(t) = sum_n u_n cos(n w t) | `fourier::cosine_series`, `point::reconstruct`, `point::velocity` | 3.1 |
//! | Eq. 9 | Rayleigh quotient: not used, see Eq. 20 | `newton` (module docs) | 3.4 |
//! | Eqs. 12a, 15, 20 | (K - (n w)^2 M) u_n + A^T lambda_n = 0, n = 0..N | `linear_model::LinearModel::harmonic_residual` (`full::FullModel`, `condensed_newton::CondensedModel`), `newton::evaluate` | 3.4 |
//! | Eq. 12b | complementarity at convergence (G <= epsilon) | `contact::powell_measure`, `augmented_lagrangian::run_algorithm1` | 3.5 |
//! | Eq. 13 | augmented-Lagrangian variables theta, kappa | `contact::Multipliers` | 3.3 |
//! | Eq. 14 | stationarity at fixed (theta, kappa): the inner solve | `newton::NewtonSolve::run`, `newton_fallback::solve_inner_robust`, `solver::InnerSolve`, `solver::Solver::solve_with_row` | 3.6 |
//! | Eq. 15 (integrand) | lambda = kappa (g + theta)_+, slope kappa or 0 | `contact::apply_contact_law` | 3.3 |
//! | Eq. 16 | theta <- theta + max(g, -theta) | `contact::violations`, `augmented_lagrangian::run_algorithm1` | 3.3, 3.5 |
//! | Eq. 17 | g = A U - g0 | `system::System::new`, `System::contact_rows`, `System::gaps` | 3.3 |
//! | Eq. 18 | time grid t_k = k T / m | `fourier::HarmonicSettings`, `fourier::Aft::synthesize`; layouts `layout::HarmonicLayout`, `layout::SignalLayout` | 2, 3.2 |
//! | Eq. 19 | frequency <-> time (AFT) | `fourier::Aft::synthesize`, `fourier::Aft::analyze` | 3.2 |
//! | Eq. 20 (Jacobian) | J_{n,n'} = D_{n+n'} + D_{abs(n-n')} from cosine moments | `fourier::Aft::cosine_moments`, `linear_model::contact_jacobian`, `linear_model::LinearModel::solve_step` | 3.6 |
//! | Eq. 20 (linear algebra) | exact condensation onto contact coordinates and master | `condensation_basis::CondensedBasis`, `condensed_newton::CondensedModel`, `modal_tail::ModalTail`; dense: `full::FullModel` | 3.7 |
//! | Eq. 21 | Powell's measure (entrywise by default) | `contact::PowellMeasure`, `contact::powell_measure`, `contact::powell_measure_of` | 3.5 |
//! | Algorithm 1 | outer loop: multiplier and penalty updates | `augmented_lagrangian::run_algorithm1`, `AlgorithmParams`, `PenaltyUpdate` | 3.5 |
//! | Sec. 2.6 | normalization e . u_1 = q | `newton::evaluate` (normalization row), `System::master`, `BackbonePoint::q` | 3.4 |
//! | Sec. 4, Fig. 3a | backbone w(q) and its branches | `trace::backbone`, `trace::Continuation`, `sweep::amplitude_sweep` | 3.8, 8 |
//! | (none) | time integration with a penalty law, independent check | `integrate::integrate_penalty`, `integrate::check_periodicity` | 5.4 |
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
//! (pseudo-arc-length continuation that follows folds), [`check_periodicity`] /
//! [`integrate_penalty`] (independent time-integration check). A solver is configured by
//! [`HarmonicSettings`] and [`SolverSettings`] (Algorithm 1's [`AlgorithmParams`], the
//! [`NewtonSettings`] and the [`Condensation`]). Tests and benchmarks also use `testing`
//! (feature `testing`): `amplitude_sweep` (given amplitude levels) and `newton_step_timing`.
//!
//! Choices that depart from a literal reading, each with its reason in the module docs:
//! * Powell's measure defaults to the entrywise maximum [`PowellMeasure::Entrywise`]; docs/DESIGN.md §3's
//!   row-maximum reading of Eq. (21) can accept orbits that violate complementarity.
//! * The penalty increase of an accepted iteration also divides theta by beta
//!   ([`PenaltyUpdate::KeepMultiplier`]); the printed update over-pushes (kept as an option).
//! * Penalties are capped (`max_penalty`); at the cap the multiplier is updated instead.
//! * Optionally (`stall_factor` > 1; default off) a point whose measure floors above epsilon is
//!   kept at its last accepted iterate when that iterate's measure is at most `stall_factor` x
//!   epsilon (reported with its measure).
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
//! The harmonic-balance engine these modules drive (system, layouts, AFT, contact law, Powell's
//! measure, Algorithm 1, the inner Newton solve and its exact condensation) is the crate
//! `nlmodes-hb`, shared with the forced response; the paths `system::`, `contact::`, `newton::`,
//! ... in the table above are its modules. Modules of this crate: `solver` (one point of the free
//! mode, `InnerSolve`), `continuation` and `trace` (backbone), `stability`, `truncation`, `point`
//! (outputs), `integrate` (time-integration cross-check), `sweep` (amplitude levels, tests only),
//! `step_timing` (benchmarks only). Design: docs/DESIGN.md (sections cited as "DESIGN §k"), §10
//! for the split.

mod continuation;
mod integrate;
mod point;
mod solver;
mod stability;
#[cfg(feature = "testing")]
mod step_timing;
#[cfg(feature = "testing")]
mod sweep;
mod trace;
mod truncation;

pub use continuation::{
    Backbone, Branch, BranchKind, ContinuationSettings, InternalResonance, Passage, SkippedLevel,
    Termination,
};
pub use integrate::{check_periodicity, integrate_penalty, MotionState, PeriodicityCheck};
/// The engine's error type: one type for the engine and the free-mode problem built on it.
pub use nlmodes_hb::HbError as NnmError;
pub use nlmodes_hb::{
    cosine_series, cosine_series_rate, powell_measure, AlgorithmParams, Condensation,
    ContactMethod, HarmonicSettings, ModalShares, Multipliers, NewtonSettings, PenaltyUpdate,
    PowellMeasure, SolverSettings, System,
};
pub use point::{reconstruct, velocity, BackbonePoint};
pub use solver::{solve_point, Solver, Start};
pub use stability::{
    analyze_backbone, boundary_backbone, boundary_history, classify, floquet,
    monodromy_by_integration, verdict_word, Bifurcation, BoundaryBackbone, BoundaryBackbonePoint,
    BoundaryHistory, BoundaryPiece, ConvergedOrbit, ConvergenceSettings, ConvergenceStop,
    ExactOrbitAtQ, FloquetAnalysis, FloquetSettings, HoleFollow, HoleFollowEnd, JacobianInTime,
    Monodromy, MonodromySettings, ShootingCheck, Stability, StabilityMethod, UnresolvedPair,
    UnstableCounts, VerdictInputs, DECOUPLED_SHARE, SALTATION_TRIVIAL_LIMIT, SHOOTING_CHECK_LIMIT,
    SHOOTING_SHIFT_LIMIT, TRIVIAL_PAIR_LIMIT, UNRESOLVED_ACCELERATION_LIMIT,
    UNRESOLVED_SHARE_LIMIT,
};
pub use trace::backbone;
pub use truncation::{truncation_estimate, TruncationEstimate};

/// What only this crate's tests and benchmarks use, outside the public API: compiled with the
/// `testing` feature, which the crate's own tests (a dev-dependency on itself) and the workspace's
/// `examples/bench_nnm.rs` enable.
#[cfg(feature = "testing")]
pub mod testing {
    pub use crate::step_timing::{newton_step_timing, StepTiming};
    pub use crate::sweep::amplitude_sweep;
}
