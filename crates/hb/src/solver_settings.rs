//! Everything a `nlmodes_nnm::Solver` is configured with beyond the harmonics: the parameters of
//! Algorithm 1 ([`AlgorithmParams`]), the inner Newton solver's ([`NewtonSettings`]) and the
//! linear algebra of its steps ([`Condensation`]).

use serde::{Deserialize, Serialize};

use crate::augmented_lagrangian::AlgorithmParams;
use crate::condensed_newton::CondensedModel;
use crate::error::HbError;
use crate::full::FullModel;
use crate::linear_model::LinearModel;
use crate::newton::NewtonSettings;
use crate::system::System;

/// Which Newton linear algebra to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Condensation {
    /// Exact condensation onto the contact coordinates and the master (docs/DESIGN.md §3.7,
    /// `condensation_basis` and `condensed_newton`).
    #[default]
    Exact,
    /// Dense Newton on all n (N + 1) + 2 unknowns (validation, small systems).
    None,
}

/// Settings of the point solver: Algorithm 1, the inner Newton solver and its linear algebra.
///
/// Serialized as one flat table (the `[algorithm]` table of a case file): the keys of
/// [`AlgorithmParams`] next to `condensation` and the `newton` sub-table, e.g.
/// `{"alpha": 4.0, "condensation": "exact", "newton": {"tolerance": 1e-10}}`. Every key has a
/// default; an unknown key is an error that names it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSettings {
    /// Algorithm 1 (augmented Lagrangian with Powell's measure) or the plain penalty.
    #[serde(flatten)]
    pub algorithm: AlgorithmParams,
    /// Inner Newton settings.
    pub newton: NewtonSettings,
    /// Exact condensation (default) or the dense uncondensed Newton.
    pub condensation: Condensation,
}

impl Condensation {
    /// The linear model of `system` for harmonics 0..=`harmonics` that this choice solves Newton
    /// steps with (`resonance_window`: [`NewtonSettings::resonance_window`]).
    pub fn linear_model<'s>(
        self,
        system: &'s System,
        resonance_window: f64,
        harmonics: usize,
    ) -> Result<Box<dyn LinearModel + 's>, HbError> {
        Ok(match self {
            Condensation::Exact => {
                Box::new(CondensedModel::new(system, resonance_window, harmonics)?)
            }
            Condensation::None => Box::new(FullModel::new(system, harmonics)),
        })
    }
}

impl SolverSettings {
    /// Checks every parameter range; the error names the parameter.
    pub fn validate(&self) -> Result<(), HbError> {
        self.algorithm.validate()?;
        self.newton.validate()
    }
}

impl From<AlgorithmParams> for SolverSettings {
    /// The given Algorithm 1 parameters with the default Newton settings and condensation.
    fn from(algorithm: AlgorithmParams) -> Self {
        Self {
            algorithm,
            ..Self::default()
        }
    }
}
