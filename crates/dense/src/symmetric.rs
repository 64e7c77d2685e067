//! Symmetric dense matrices: the one symmetry tolerance of the workspace, the check every
//! symmetric input passes (square, finite, symmetric to that tolerance), the symmetrization that
//! follows it, and the measures they use.

use faer::{Mat, MatRef};

/// Relative tolerance of the symmetry checks of both crates: a matrix is accepted as symmetric
/// when max |a_ij - a_ji| <= 1e-10 max |a| (and then symmetrized).
///
/// The matrices checked are symmetric by construction: finite-element assembly (asymmetry of a
/// few ulps per entry, relative 1e-16 to 1e-14), Craig-Bampton products T^T K T (1.3e-12 for K_r
/// and 1.7e-16 for M_r on the default blade, 93 138 DOFs, measured), reduced-model files (written
/// symmetrized) and analytic chains (exact). 1e-10 leaves two orders of magnitude over the worst
/// measured round-off while catching any genuine asymmetry (a wrong sign, a missing triangle, a
/// mis-assembled entry). It was modal's value and, through the reduced-model reader, already the
/// bound every matrix of the `nlmodes` pipeline met before `nnm` saw it; `nnm` alone used 1e-9.
pub const SYMMETRY_TOLERANCE: f64 = 1e-10;

/// Why a matrix is not accepted as symmetric ([`check_symmetric`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SymmetryError {
    /// The matrix is not square.
    #[error("{rows}x{cols}, not square")]
    NotSquare { rows: usize, cols: usize },
    /// An entry is NaN or infinite (the first in column-major order).
    #[error("non-finite entry {value} at ({row}, {col})")]
    NonFinite { row: usize, col: usize, value: f64 },
    /// The largest asymmetry |a_ij - a_ji| (row > col) exceeds [`SYMMETRY_TOLERANCE`] x max|a|.
    #[error(
        "not symmetric: a({row},{col}) = {a_ij:e}, a({col},{row}) = {a_ji:e}, beyond \
         {tolerance:e} x max|a| = {scale:e}",
        tolerance = SYMMETRY_TOLERANCE
    )]
    NotSymmetric {
        row: usize,
        col: usize,
        a_ij: f64,
        a_ji: f64,
        /// max |a|.
        scale: f64,
    },
}

/// Checks that `a` is square, finite and symmetric to [`SYMMETRY_TOLERANCE`] relative to its
/// largest entry; the worst pair is reported. Returns its order.
pub fn check_symmetric(a: MatRef<'_, f64>) -> Result<usize, SymmetryError> {
    if a.nrows() != a.ncols() {
        return Err(SymmetryError::NotSquare {
            rows: a.nrows(),
            cols: a.ncols(),
        });
    }
    let n = a.nrows();
    let mut scale = 0.0_f64;
    for j in 0..n {
        for i in 0..n {
            let value = a[(i, j)];
            if !value.is_finite() {
                return Err(SymmetryError::NonFinite {
                    row: i,
                    col: j,
                    value,
                });
            }
            scale = scale.max(value.abs());
        }
    }
    let mut worst = (0.0_f64, 0, 0);
    for j in 0..n {
        for i in (j + 1)..n {
            let d = (a[(i, j)] - a[(j, i)]).abs();
            if d > worst.0 {
                worst = (d, i, j);
            }
        }
    }
    if worst.0 > SYMMETRY_TOLERANCE * scale {
        let (_, row, col) = worst;
        return Err(SymmetryError::NotSymmetric {
            row,
            col,
            a_ij: a[(row, col)],
            a_ji: a[(col, row)],
            scale,
        });
    }
    Ok(n)
}

/// Largest absolute entry of a dense matrix (0 when empty).
pub fn max_abs(a: MatRef<'_, f64>) -> f64 {
    let mut m = 0.0_f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            m = m.max(a[(i, j)].abs());
        }
    }
    m
}

/// Replaces A by (A + A^T) / 2 (its leading square block if A is not square).
pub fn symmetrize(a: &mut Mat<f64>) {
    let n = a.nrows().min(a.ncols());
    for j in 0..n {
        for i in 0..j {
            let avg = 0.5 * (a[(i, j)] + a[(j, i)]);
            a[(i, j)] = avg;
            a[(j, i)] = avg;
        }
    }
}

/// max |A - A^T| / max |A| (0 for a zero matrix): the relative asymmetry
/// (of the leading square block if A is not square).
pub fn relative_asymmetry(a: MatRef<'_, f64>) -> f64 {
    let scale = max_abs(a);
    if scale == 0.0 {
        return 0.0;
    }
    let mut worst = 0.0_f64;
    for j in 0..a.nrows().min(a.ncols()) {
        for i in 0..j {
            worst = worst.max((a[(i, j)] - a[(j, i)]).abs());
        }
    }
    worst / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_pair_is_reported_and_round_off_passes() {
        let mut a = Mat::from_fn(3, 3, |i, j| (i + j) as f64 + 1.0);
        a[(1, 0)] += 1e-12;
        assert_eq!(check_symmetric(a.as_ref()), Ok(3));
        a[(2, 0)] += 1e-3;
        a[(2, 1)] += 2e-3;
        let err = check_symmetric(a.as_ref()).unwrap_err();
        assert!(
            matches!(err, SymmetryError::NotSymmetric { row: 2, col: 1, .. }),
            "{err}"
        );
        a[(0, 2)] = f64::NAN;
        assert!(matches!(
            check_symmetric(a.as_ref()),
            Err(SymmetryError::NonFinite { row: 0, col: 2, .. })
        ));
        let wide = Mat::<f64>::zeros(2, 3);
        assert!(matches!(
            check_symmetric(wide.as_ref()),
            Err(SymmetryError::NotSquare { rows: 2, cols: 3 })
        ));
    }
}
