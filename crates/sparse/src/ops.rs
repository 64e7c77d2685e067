//! Small sparse-matrix utilities on `sprs::CsMat<f64>`: input validation,
//! matrix-vector products, the shifted matrix K - sigma M and block extraction.
//!
//! Matrices are expected in CSC with both triangles stored (what the fem crate
//! assembles). CSR input is accepted: it is converted to CSC where the storage
//! order matters.

use std::borrow::Cow;

use faer::prelude::ReborrowMut;
use faer::{Mat, MatMut, MatRef};
use rayon::prelude::*;
use sprs::CsMat;

use crate::error::{SparseError, SymmetryError};

/// Relative tolerance of the symmetry checks, |a_ij - a_ji| <= tol * max|a|: the one shared by
/// modal and nnm (`nlmodes_dense`). Finite-element assembly produces matrices symmetric to a few
/// ulps per entry (relative 1e-16 to 1e-14); 1e-10 leaves four orders of margin for round-off
/// while catching any genuine asymmetry (a wrong sign, a missing triangle, a mis-assembled entry).
pub use nlmodes_dense::SYMMETRY_TOLERANCE;

/// Dense copy of a sparse matrix (any storage order).
pub fn csmat_to_dense(a: &CsMat<f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(a.rows(), a.cols());
    for (&v, (i, j)) in a.iter() {
        out[(i, j)] += v;
    }
    out
}

/// Returns the matrix in CSC storage, borrowing when it already is.
pub fn as_csc(a: &CsMat<f64>) -> Cow<'_, CsMat<f64>> {
    if a.is_csc() {
        Cow::Borrowed(a)
    } else {
        Cow::Owned(a.to_csc())
    }
}

/// Checks that `a` is square and returns its order.
pub fn check_square(a: &CsMat<f64>, what: &str) -> Result<usize, SparseError> {
    if a.rows() != a.cols() {
        return Err(SparseError::Matrix {
            what: what.to_string(),
            source: SymmetryError::NotSquare {
                rows: a.rows(),
                cols: a.cols(),
            },
        });
    }
    Ok(a.rows())
}

/// Checks that every stored entry of `a` is finite.
pub fn check_finite(a: &CsMat<f64>, what: &str) -> Result<(), SparseError> {
    for (&value, (row, col)) in a.iter() {
        if !value.is_finite() {
            return Err(SparseError::Matrix {
                what: what.to_string(),
                source: SymmetryError::NonFinite { row, col, value },
            });
        }
    }
    Ok(())
}

/// Largest absolute value of the stored entries (0 for an empty matrix).
pub fn max_abs(a: &CsMat<f64>) -> f64 {
    a.data().iter().fold(0.0_f64, |acc, v| acc.max(v.abs()))
}

/// Checks |a_ij - a_ji| <= [`SYMMETRY_TOLERANCE`] * max|a| for every stored entry (an entry whose
/// transpose is not stored is compared with 0; the first offending entry found, in the order
/// of the outer dimension, is reported). Linear time: each column (row for CSR) j is merged
/// with row j, read from the columns after j through one cursor per column that only moves
/// forward (sprs keeps the indices of each column sorted), about a second for a million-DOF
/// stiffness where a binary search per entry took 14 s of CPU.
pub fn check_symmetric(a: &CsMat<f64>, what: &str) -> Result<(), SparseError> {
    let n = check_square(a, what)?;
    let scale = max_abs(a);
    let bound = SYMMETRY_TOLERANCE * scale;
    let (indptr, indices, data) = (a.proper_indptr(), a.indices(), a.data());
    // cursor[c]: the next entry of outer c above the diagonal (inner < c) not yet matched.
    let mut cursor: Vec<usize> = indptr[..n].to_vec();
    let mut first = None;
    // (inner, outer, value, transposed value) of a pair beyond the bound.
    let mut offend = |inner: usize, outer: usize, a_io: f64, a_oi: f64| {
        if first.is_none() && (a_io - a_oi).abs() > bound {
            first = Some((inner, outer, a_io, a_oi));
        }
    };
    for j in 0..n {
        for p in indptr[j]..indptr[j + 1] {
            let i = indices[p];
            if i <= j {
                continue;
            }
            // Entry (i, j) below the diagonal: its transpose is entry (j, i) of outer i. The
            // entries of outer i above row j skipped on the way have no transpose (theirs would
            // have been an entry of an earlier outer, which moved the cursor past them).
            let end = indptr[i + 1];
            while cursor[i] < end && indices[cursor[i]] < j {
                offend(indices[cursor[i]], i, data[cursor[i]], 0.0);
                cursor[i] += 1;
            }
            let transposed = if cursor[i] < end && indices[cursor[i]] == j {
                cursor[i] += 1;
                data[cursor[i] - 1]
            } else {
                0.0
            };
            offend(i, j, data[p], transposed);
        }
    }
    // Entries above the diagonal never reached by a cursor have no transpose.
    for c in 0..n {
        for p in cursor[c]..indptr[c + 1] {
            if indices[p] < c {
                offend(indices[p], c, data[p], 0.0);
            }
        }
    }
    match first {
        Some((inner, outer, a_ij, a_ji)) => {
            let (row, col) = if a.is_csc() {
                (inner, outer)
            } else {
                (outer, inner)
            };
            Err(SparseError::Matrix {
                what: what.to_string(),
                source: SymmetryError::NotSymmetric {
                    row,
                    col,
                    a_ij,
                    a_ji,
                    scale,
                },
            })
        }
        None => Ok(()),
    }
}

/// Square, finite and symmetric: the checks every solver entry point runs.
pub fn check_symmetric_input(a: &CsMat<f64>, what: &str) -> Result<usize, SparseError> {
    let n = check_square(a, what)?;
    check_finite(a, what)?;
    check_symmetric(a, what)?;
    Ok(n)
}

/// y = A x (overwrites `y`). Errors when the lengths do not match the matrix.
pub fn spmv(a: &CsMat<f64>, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
    for (what, expected, found) in [
        ("length of x in y = A x", a.cols(), x.len()),
        ("length of y in y = A x", a.rows(), y.len()),
    ] {
        if expected != found {
            return Err(SparseError::DimensionMismatch {
                what: what.to_string(),
                expected,
                found,
            });
        }
    }
    spmv_unchecked(a, x, y);
    Ok(())
}

/// y = A x for lengths already known to match (the eigensolvers' hot loops; lengths that do
/// not match panic: [`spmv`] checks them).
pub fn spmv_unchecked(a: &CsMat<f64>, x: &[f64], y: &mut [f64]) {
    debug_assert_eq!(x.len(), a.cols());
    debug_assert_eq!(y.len(), a.rows());
    let indptr = a.proper_indptr();
    let indices = a.indices();
    let data = a.data();
    if a.is_csc() {
        y.iter_mut().for_each(|v| *v = 0.0);
        for (j, &xj) in x.iter().enumerate() {
            if xj == 0.0 {
                continue;
            }
            for p in indptr[j]..indptr[j + 1] {
                y[indices[p]] += data[p] * xj;
            }
        }
    } else {
        for (i, yi) in y.iter_mut().enumerate() {
            let mut acc = 0.0;
            for p in indptr[i]..indptr[i + 1] {
                acc += data[p] * x[indices[p]];
            }
            *yi = acc;
        }
    }
}

/// K - sigma M on the union of the two sparsity patterns (CSC).
///
/// Errors when the matrices are not square or differ in size.
pub fn shifted(k: &CsMat<f64>, m: &CsMat<f64>, sigma: f64) -> Result<CsMat<f64>, SparseError> {
    let n = check_square(k, "K")?;
    let n_m = check_square(m, "M")?;
    if n != n_m {
        return Err(SparseError::DimensionMismatch {
            what: "order of M compared with K".to_string(),
            expected: n,
            found: n_m,
        });
    }
    if !sigma.is_finite() {
        return Err(SparseError::InvalidArgument(format!(
            "the shift sigma must be finite, got {sigma}"
        )));
    }
    let k = as_csc(k);
    let m = as_csc(m);
    let (kp, ki, kd) = (k.proper_indptr(), k.indices(), k.data());
    let (mp, mi, md) = (m.proper_indptr(), m.indices(), m.data());
    let mut indptr = Vec::with_capacity(n + 1);
    let mut indices = Vec::with_capacity(kd.len().max(md.len()));
    let mut data = Vec::with_capacity(kd.len().max(md.len()));
    indptr.push(0);
    for j in 0..n {
        let (mut p, pe) = (kp[j], kp[j + 1]);
        let (mut q, qe) = (mp[j], mp[j + 1]);
        while p < pe || q < qe {
            let rk = if p < pe { ki[p] } else { usize::MAX };
            let rm = if q < qe { mi[q] } else { usize::MAX };
            if rk == rm {
                indices.push(rk);
                data.push(kd[p] - sigma * md[q]);
                p += 1;
                q += 1;
            } else if rk < rm {
                indices.push(rk);
                data.push(kd[p]);
                p += 1;
            } else {
                indices.push(rm);
                data.push(-sigma * md[q]);
                q += 1;
            }
        }
        indptr.push(indices.len());
    }
    Ok(CsMat::new_csc((n, n), indptr, indices, data))
}

/// The block A[rows, cols] as a CSC matrix (row and column order as given).
///
/// Errors when an index is out of range or a row index is repeated.
pub fn submatrix(
    a: &CsMat<f64>,
    rows: &[usize],
    cols: &[usize],
) -> Result<CsMat<f64>, SparseError> {
    let mut seen = vec![false; a.rows()];
    for &r in rows {
        if r >= a.rows() || seen[r] {
            return Err(SparseError::InvalidArgument(format!(
                "row index {r} of a submatrix is out of range (0..{}) or repeated",
                a.rows()
            )));
        }
        seen[r] = true;
    }
    if let Some(&c) = cols.iter().find(|&&c| c >= a.cols()) {
        return Err(SparseError::InvalidArgument(format!(
            "column index {c} of a submatrix is out of range (0..{})",
            a.cols()
        )));
    }
    Ok(submatrix_unchecked(a, rows, cols))
}

/// [`submatrix`] for indices already validated (in range, rows distinct; an index out of range
/// panics).
pub fn submatrix_unchecked(a: &CsMat<f64>, rows: &[usize], cols: &[usize]) -> CsMat<f64> {
    let a = as_csc(a);
    let mut row_map = vec![usize::MAX; a.rows()];
    for (local, &global) in rows.iter().enumerate() {
        row_map[global] = local;
    }
    let monotone = rows.windows(2).all(|w| w[0] < w[1]);
    let (ap, ai, ad) = (a.proper_indptr(), a.indices(), a.data());
    let mut indptr = Vec::with_capacity(cols.len() + 1);
    let mut indices = Vec::new();
    let mut data = Vec::new();
    let mut column: Vec<(usize, f64)> = Vec::new();
    indptr.push(0);
    for &j in cols {
        column.clear();
        for p in ap[j]..ap[j + 1] {
            let local = row_map[ai[p]];
            if local != usize::MAX {
                column.push((local, ad[p]));
            }
        }
        if !monotone {
            column.sort_unstable_by_key(|&(r, _)| r);
        }
        for &(r, v) in &column {
            indices.push(r);
            data.push(v);
        }
        indptr.push(indices.len());
    }
    CsMat::new_csc((rows.len(), cols.len()), indptr, indices, data)
}

/// Maximum absolute column sum ||A||_1.
pub fn norm_one(a: &CsMat<f64>) -> f64 {
    let a = as_csc(a);
    a.outer_iterator()
        .map(|col| col.iter().map(|(_, v)| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// out = A x for a block x and a symmetric sparse A, in one pass over A: x is copied to a
/// row-major buffer so that each stored entry a_ij updates all b columns at once (A's storage,
/// CSR or CSC, is read as rows, which is the same matrix because A is symmetric).
pub fn spmm_symmetric(a: &CsMat<f64>, x: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
    let (n, b) = (x.nrows(), x.ncols());
    let mut xr = vec![0.0; n * b];
    for j in 0..b {
        for (i, v) in x.col(j).iter().enumerate() {
            xr[i * b + j] = *v;
        }
    }
    let (indptr, indices, data) = (a.proper_indptr(), a.indices(), a.data());
    let mut yr = vec![0.0; n * b];
    yr.par_chunks_mut(b).enumerate().for_each(|(i, yi)| {
        for p in indptr[i]..indptr[i + 1] {
            let (aij, xj) = (data[p], &xr[indices[p] * b..(indices[p] + 1) * b]);
            for (y, xv) in yi.iter_mut().zip(xj) {
                *y += aij * xv;
            }
        }
    });
    for j in 0..b {
        for (i, o) in out.rb_mut().col_mut(j).iter_mut().enumerate() {
            *o = yr[i * b + j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sprs::TriMat;

    /// The block product equals column-by-column spmv, for CSC and CSR storage of a symmetric
    /// matrix (exactly: each output entry sums the same products in the same row order for CSR;
    /// for CSC the order differs, so 1e-15 relative).
    #[test]
    fn block_product_matches_spmv() {
        let n = 7;
        let mut t = TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 4.0 + i as f64);
            if i + 2 < n {
                t.add_triplet(i, i + 2, -1.5 + 0.1 * i as f64);
                t.add_triplet(i + 2, i, -1.5 + 0.1 * i as f64);
            }
        }
        for a in [t.to_csc(), t.to_csr()] {
            let x = faer::Mat::<f64>::from_fn(n, 3, |i, j| (i * 3 + j) as f64 - 5.0);
            let mut y = faer::Mat::<f64>::zeros(n, 3);
            spmm_symmetric(&a, x.as_ref(), y.as_mut());
            for j in 0..3 {
                let xc: Vec<f64> = (0..n).map(|i| x[(i, j)]).collect();
                let mut yc = vec![0.0; n];
                spmv_unchecked(&a, &xc, &mut yc);
                for i in 0..n {
                    assert!((y[(i, j)] - yc[i]).abs() <= 1e-15 * yc[i].abs().max(1.0));
                }
            }
        }
    }

    fn small() -> CsMat<f64> {
        let mut t = TriMat::new((3, 3));
        for (i, j, v) in [
            (0, 0, 4.0),
            (1, 1, 5.0),
            (2, 2, 6.0),
            (0, 2, 1.0),
            (2, 0, 1.0),
        ] {
            t.add_triplet(i, j, v);
        }
        t.to_csc()
    }

    #[test]
    fn spmv_matches_hand_product_in_both_storages() {
        let a = small();
        let x = [1.0, 2.0, 3.0];
        let mut y = [0.0; 3];
        spmv(&a, &x, &mut y).unwrap();
        // [4 0 1; 0 5 0; 1 0 6] [1 2 3] = [7 10 19], exact in floating point.
        assert_eq!(y, [7.0, 10.0, 19.0]);
        let mut z = [0.0; 3];
        spmv(&a.to_csr(), &x, &mut z).unwrap();
        assert!(spmv(&a, &x[..2], &mut z).is_err());
        assert_eq!(z, y);
    }

    #[test]
    fn shifted_merges_patterns() {
        let k = small();
        let mut t = TriMat::new((3, 3));
        t.add_triplet(1, 0, 1.0);
        t.add_triplet(0, 1, 1.0);
        t.add_triplet(1, 1, 2.0);
        let m: CsMat<f64> = t.to_csc();
        let s = shifted(&k, &m, 0.5).unwrap();
        assert_eq!(s.get(0, 0), Some(&4.0));
        assert_eq!(s.get(1, 0), Some(&-0.5));
        assert_eq!(s.get(1, 1), Some(&4.0));
        assert_eq!(s.get(2, 0), Some(&1.0));
        assert_eq!(s.nnz(), 7);
    }

    #[test]
    fn asymmetry_is_detected_and_named() {
        let mut t = TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, 1.0);
        t.add_triplet(1, 0, 0.5);
        let a: CsMat<f64> = t.to_csc();
        let err = check_symmetric(&a, "test matrix").unwrap_err();
        assert!(
            err.to_string().contains("test matrix: not symmetric"),
            "{err}"
        );
    }

    /// The linear-time check finds every kind of asymmetry, in CSC and CSR storage: a value
    /// mismatch (reported with both values), an entry stored above the diagonal only, one
    /// below only, and one in the last column whose cursor is never moved; a symmetric matrix
    /// with an explicit zero pair passes.
    #[test]
    fn symmetry_check_finds_each_kind_of_asymmetry() {
        let n = 6;
        let base = |extra: &[(usize, usize, f64)]| {
            let mut t = TriMat::new((n, n));
            for i in 0..n {
                t.add_triplet(i, i, 4.0);
            }
            for (i, j, v) in [(3, 0, -1.0), (5, 1, 2.0), (4, 2, 0.0), (5, 4, 0.5)] {
                t.add_triplet(i, j, v);
                t.add_triplet(j, i, v);
            }
            for &(i, j, v) in extra {
                t.add_triplet(i, j, v);
            }
            t
        };
        for to_storage in [TriMat::to_csc, TriMat::to_csr] {
            let symmetric: CsMat<f64> = to_storage(&base(&[]));
            assert!(check_symmetric(&symmetric, "A").is_ok());
            for (extra, row, col, a_ij, a_ji) in [
                (vec![(5, 1, 1e-3)], 5, 1, 2.001, 2.0),
                (vec![(1, 3, 7.0)], 1, 3, 7.0, 0.0),
                (vec![(4, 1, 7.0)], 4, 1, 7.0, 0.0),
                (vec![(2, 5, 7.0)], 2, 5, 7.0, 0.0),
            ] {
                let a: CsMat<f64> = to_storage(&base(&extra));
                let err = check_symmetric(&a, "A").unwrap_err();
                let SparseError::Matrix {
                    source:
                        SymmetryError::NotSymmetric {
                            row: r,
                            col: c,
                            a_ij: v,
                            a_ji: w,
                            ..
                        },
                    ..
                } = err
                else {
                    panic!("{err}");
                };
                // A mismatched pair may be reported from either of its entries.
                assert!(
                    (r, c, v, w) == (row, col, a_ij, a_ji)
                        || (r, c, v, w) == (col, row, a_ji, a_ij),
                    "extra {extra:?}: ({r}, {c}, {v}, {w})"
                );
            }
        }
    }

    #[test]
    fn submatrix_keeps_given_order() {
        let a = small();
        let b = submatrix(&a, &[2, 0], &[0]).unwrap();
        assert!(submatrix(&a, &[2, 2], &[0]).is_err());
        assert!(submatrix(&a, &[0], &[3]).is_err());
        assert_eq!(b.get(0, 0), Some(&1.0));
        assert_eq!(b.get(1, 0), Some(&4.0));
    }
}
