//! The crate without the `petsc` feature: the same entry points, none of which can run.

use nlmodes_fem::{DofMap, Isotropic, Mesh};
use nlmodes_modal::{CraigBampton, Modes};
use sprs::CsMat;

use crate::error::{DistributedError, Result};
use crate::launch::{launch_variable, World};

/// Never constructed without the `petsc` feature.
pub enum Session {}

/// [`DistributedError::NotBuilt`] under an MPI launcher, `None` otherwise.
pub fn start() -> Result<Option<Session>> {
    match launch_variable() {
        Some(v) => Err(DistributedError::NotBuilt {
            variable: v.to_string(),
        }),
        None => Ok(None),
    }
}

/// Always `None`: no session can run.
pub fn world() -> Option<World> {
    None
}

/// Nothing to end without a session.
pub fn abort_if_parallel(_code: i32) {}

/// As with the `petsc` feature; nothing to lead or serve without a session.
pub mod crew {
    use super::not_built;
    use crate::error::Result;

    /// Never constructed without the `petsc` feature.
    pub enum Assignment {}

    impl Assignment {
        /// Unreachable: no assignment exists.
        pub fn done(self) {
            match self {}
        }
    }

    /// Nothing to lead.
    pub fn lead() {}

    /// Nothing to end without a session.
    pub fn abort_on_panic() {}

    /// Nothing to release.
    pub fn release() {}

    /// Always [`crate::DistributedError::NotBuilt`].
    pub fn assign(_task: &[u8]) -> Result<Assignment> {
        Err(not_built())
    }

    /// Always [`crate::DistributedError::NotBuilt`].
    pub fn next_task() -> Result<Option<Vec<u8>>> {
        Err(not_built())
    }
}

/// As with the `petsc` feature.
#[derive(Clone, Copy)]
pub enum Operators<'a> {
    Assembled(&'a Isotropic),
    FromRoot(Option<(&'a CsMat<f64>, &'a CsMat<f64>)>),
}

/// As with the `petsc` feature.
pub struct ReductionInput<'a> {
    pub mesh: &'a Mesh,
    pub operators: Operators<'a>,
    pub dofs: &'a DofMap,
    pub boundary: &'a [usize],
    pub n_modes: usize,
    pub check_modes: usize,
    pub loads: &'a [Vec<f64>],
}

/// As with the `petsc` feature.
pub struct Reduction {
    pub cb: CraigBampton,
    pub full_check_hz: Option<Vec<f64>>,
}

fn not_built() -> DistributedError {
    DistributedError::NotBuilt {
        variable: launch_variable().unwrap_or("none").to_string(),
    }
}

/// Always [`DistributedError::NotBuilt`].
pub fn craig_bampton(_input: &ReductionInput) -> Result<Option<Reduction>> {
    Err(not_built())
}

/// Always [`DistributedError::NotBuilt`].
pub fn full_modes(
    _mesh: &Mesh,
    _operators: Operators,
    _dofs: &DofMap,
    _nev: usize,
    _sigma: f64,
) -> Result<Option<Modes>> {
    Err(not_built())
}

/// Always [`DistributedError::NotBuilt`].
pub fn solve_from_root(
    _mesh: &Mesh,
    _dofs: &DofMap,
    _a: Option<&CsMat<f64>>,
    _b: Option<&[f64]>,
) -> Result<Option<Vec<f64>>> {
    Err(not_built())
}
