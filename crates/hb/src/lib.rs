//! The harmonic-balance engine of nlmodes: what free motion (the nonlinear modes of
//! `nlmodes-nnm`) and forced motion share, after Laxalde, Legrand & Pierre, "Nonlinear Modal
//! Analysis of Mechanical Systems with Frictionless Contact Interfaces" (ASME IDETC 2009,
//! DETC2009-87387), Secs. 2.3-3, Eqs. (13)-(21), Algorithm 1. Design: docs/DESIGN.md (sections
//! cited as "DESIGN §k"), §10 for the split between this engine and the problems built on it.
//!
//! The engine knows nothing of meshes nor of the problem it serves: a [`System`] is any SPD pair
//! (M, K) with contact rows A and initial gaps g0 (Eq. 17); a problem (a free mode at fixed
//! amplitude, a forced orbit at fixed frequency) supplies its own rows and drives Algorithm 1
//! through [`augmented_lagrangian::InnerSolves`].
//!
//! | paper | what | module |
//! |---|---|---|
//! | Eqs. 3c, 7c, 11b | Signorini: g <= 0, lambda >= 0, lambda . g = 0 | [`system`], [`contact`] |
//! | Eq. 6 | Fourier series u(t) = sum_n u_n cos(n w t) (time-symmetric orbits) | [`fourier`], [`layout`] |
//! | Eqs. 12a, 15, 20 | (K - (n w)^2 M) u_n + A^T lambda_n = 0 | [`linear_model`] ([`full`], [`condensed_newton`]), [`newton`] |
//! | Eq. 13 | augmented-Lagrangian variables theta, kappa | [`contact::Multipliers`] |
//! | Eq. 14 | the inner solve at fixed (theta, kappa) | [`newton`], [`newton_fallback`] |
//! | Eq. 15 | lambda = kappa (g + theta)_+ | [`contact::apply_contact_law`] |
//! | Eq. 16 | theta <- theta + max(g, -theta) | [`contact::violations`], [`augmented_lagrangian`] |
//! | Eq. 17 | g = A U - g0 | [`system::System`] |
//! | Eqs. 18-19 | time grid and frequency <-> time (AFT) | [`fourier::Aft`] |
//! | Eq. 20 | the semi-smooth Newton step, exact condensation onto the contact coordinates | [`linear_model`], [`condensation_basis`], [`condensed_newton`], [`modal_tail`] |
//! | Eq. 21 | Powell's measure | [`contact::powell_measure`] |
//! | Algorithm 1 | multiplier and penalty updates | [`augmented_lagrangian::run_algorithm1`] |
//!
//! Modules: `system` (inputs), `layout` (harmonic layouts), `fourier` (AFT), `contact` (sampled
//! law, Powell's measure), `linear_model` (the linear part as the Newton solver sees it), `newton`
//! (inner solve), `newton_fallback` (smoothing path), `condensation_basis` and `condensed_newton`
//! (the exact condensation), `modal_tail` (series for the high modes), `full` (uncondensed
//! validation model), `floquet` (multipliers from the sampled slopes), `augmented_lagrangian`
//! (Algorithm 1), `solver_settings`, `check` (parameter checks), `error`. Dense linear algebra is
//! `nlmodes-dense`'s; the massless contact boundary, shot and continued exactly beside the
//! harmonic balance, is `nlmodes-boundary`'s (built on this engine).

pub mod augmented_lagrangian;
pub mod check;
pub mod condensation_basis;
pub mod condensed_newton;
pub mod contact;
pub mod error;
pub mod floquet;
pub mod fourier;
pub mod full;
pub mod full_basis;
mod harmonic_block;
pub mod layout;
pub mod linear_model;
pub mod modal_tail;
pub mod newton;
pub mod newton_fallback;
pub mod penalty_integral;
pub mod solver_settings;
pub mod system;

pub use augmented_lagrangian::{AlgorithmParams, ContactMethod, PenaltyUpdate};
pub use contact::{powell_measure, Multipliers, PowellMeasure};
pub use error::HbError;
pub use fourier::{cosine_series, cosine_series_rate, HarmonicSettings};
pub use full_basis::FullBasis;
pub use newton::NewtonSettings;
pub use solver_settings::{Condensation, SolverSettings};
pub use system::{ModalShares, System};
