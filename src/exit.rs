//! Exit codes of `nlmodes` (documented in the README):
//!
//! | code | meaning |
//! | --- | --- |
//! | 0 | complete |
//! | 1 | failure of the computation or of the system (I/O, a solver error, a child that could not run) |
//! | 2 | bad input: a case file, mesh (or a .geo gmsh cannot mesh), reduced model, argument or output path refused (nothing computed with it) |
//! | 3 | stopped early: the backbone stopped before q_max (partial results kept, reason printed and in `backbone.json`) |
//!
//! Errors carry their class as a marker in the anyhow chain ([`BadInput`], [`StoppedEarly`]),
//! or are recognized by type (the input errors of the fem, modal and nnm crates).

use std::fmt;

/// The computation finished.
pub const COMPLETE: u8 = 0;
/// The computation failed (solver, I/O, child process).
pub const FAILURE: u8 = 1;
/// An input was refused before it was used (clap's usage errors exit 2 as well).
pub const BAD_INPUT: u8 = 2;
/// The backbone stopped before q_max; its partial results are written.
pub const STOPPED_EARLY: u8 = 3;

/// Marks an error (or a context) as bad input.
#[derive(Debug)]
pub struct BadInput(pub String);

impl fmt::Display for BadInput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// Marks an error as a computation that stopped early with partial results.
#[derive(Debug)]
pub struct StoppedEarly(pub String);

impl fmt::Display for StoppedEarly {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for StoppedEarly {}

/// An error of bad input with `message`.
pub fn bad_input(message: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(BadInput(message.into()))
}

/// The exit code of an error: the marker in its chain, else the input errors of the libraries.
pub fn code_of(e: &anyhow::Error) -> u8 {
    if e.downcast_ref::<StoppedEarly>().is_some() {
        return STOPPED_EARLY;
    }
    if e.downcast_ref::<BadInput>().is_some() || e.chain().any(is_library_input_error) {
        return BAD_INPUT;
    }
    FAILURE
}

/// Errors of the libraries that always mean a bad input file or value.
fn is_library_input_error(e: &(dyn std::error::Error + 'static)) -> bool {
    use nlmodes_fem::FemError as F;
    use nlmodes_modal::ModalError as M;
    use nlmodes_nnm::NnmError as N;
    if let Some(f) = e.downcast_ref::<F>() {
        // Every error of reading a mesh or naming its groups; not the errors of code-built input.
        return !matches!(
            f,
            F::DimensionMismatch { .. } | F::InvalidMesh(_) | F::InvalidFixedDof { .. }
        );
    }
    if let Some(m) = e.downcast_ref::<M>() {
        return matches!(
            m,
            M::ReducedModel { .. }
                | M::MatrixMarket { .. }
                | M::Json { .. }
                | M::PointOnAxis { .. }
        );
    }
    if let Some(n) = e.downcast_ref::<N>() {
        return matches!(n, N::InvalidParameter { .. } | N::HarmonicSettings { .. });
    }
    false
}
