//! One element as the rotation terms see it: kind, node coordinates, tag.

use crate::error::FemError;
use crate::tet_kind::TetKind;

/// An element of kind `kind` with node coordinates `coords` (m, reference configuration, gmsh
/// node order) and gmsh tag `tag` (for error messages). Element DOF = 3 * local node +
/// component; element matrices are row-major `(3 npe) x (3 npe)`.
#[derive(Clone, Copy, Debug)]
pub struct ElementRef<'a> {
    /// TET4 or TET10.
    pub kind: TetKind,
    /// Reference node coordinates (m), exactly `nodes_per_element` of them.
    pub coords: &'a [[f64; 3]],
    /// gmsh element tag.
    pub tag: usize,
}

impl<'a> ElementRef<'a> {
    /// Checks that `coords` holds one point per node of `kind`.
    pub fn new(kind: TetKind, coords: &'a [[f64; 3]], tag: usize) -> Result<Self, FemError> {
        let npe = kind.nodes_per_element();
        if coords.len() != npe {
            return Err(FemError::DimensionMismatch {
                what: "element coordinates",
                found: coords.len(),
                expected: npe,
            });
        }
        Ok(ElementRef { kind, coords, tag })
    }

    /// Nodes per element.
    pub fn npe(&self) -> usize {
        self.kind.nodes_per_element()
    }

    /// Element DOFs, 3 npe.
    pub fn ndof(&self) -> usize {
        3 * self.npe()
    }

    /// Checks the length of an element vector (`what` names it in the error).
    pub fn check_vector(&self, v: &[f64], what: &'static str) -> Result<(), FemError> {
        check_len(v.len(), self.ndof(), what)
    }

    /// Checks that an output matrix buffer holds at least (3 npe)^2 entries.
    pub fn check_matrix(&self, m: &[f64], what: &'static str) -> Result<(), FemError> {
        let n = self.ndof();
        if m.len() < n * n {
            return Err(FemError::DimensionMismatch {
                what,
                found: m.len(),
                expected: n * n,
            });
        }
        Ok(())
    }
}

fn check_len(found: usize, expected: usize, what: &'static str) -> Result<(), FemError> {
    if found != expected {
        return Err(FemError::DimensionMismatch {
            what,
            found,
            expected,
        });
    }
    Ok(())
}

/// Mirrors the upper triangle of a row-major `n x n` matrix into its lower triangle, so that
/// the matrix is exactly symmetric.
pub(crate) fn mirror_upper(out: &mut [f64], n: usize) {
    for p in 0..n {
        for q in 0..p {
            out[p * n + q] = out[q * n + p];
        }
    }
}
