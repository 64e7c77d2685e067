//! The sparse Cholesky of `nlmodes-sparse` (faer + METIS), as modal uses it, against dense
//! solves and fill counts (here for the 3-D grids of modal's test fixtures).

mod common;

use common::{laplacian_3d, mul, norm, Lcg};
use faer::prelude::Solve;
use faer::{Mat, Side};
use nlmodes_sparse::error::SymmetryError;
use nlmodes_sparse::{
    csmat_to_dense, shifted, CholeskyOptions, FillOrdering, SparseCholesky, SparseError,
};
use sprs::{CsMat, TriMat};

/// The sparse solve agrees with faer's dense Cholesky solve on a 3-D
/// 7-point Laplacian + identity (n = 7*8*9 = 504).
///
/// The eigenvalues of A lie in (1, 13), so cond(A) < 13; a backward-stable
/// Cholesky solve then has relative forward error below about
/// cond * n^(1/2) * eps ~ 13 * 22 * 1.1e-16 ~ 3e-14. Tolerance 1e-12 (the
/// brief's residual level) keeps a margin of 30 while any ordering or
/// permutation mistake gives O(1) errors.
#[test]
fn solve_matches_dense_solve() {
    let a = laplacian_3d(7, 8, 9, 1.0);
    let n = a.rows();
    let chol = SparseCholesky::new(&a).unwrap();
    assert_eq!(chol.ordering(), FillOrdering::Metis);
    let b = Lcg::new(1).vector(n);
    let mut x = b.clone();
    chol.solve_in_place(&mut x).unwrap();

    let dense = csmat_to_dense(&a);
    let llt = dense.llt(Side::Lower).unwrap();
    let bm = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
    let xd = llt.solve(&bm);

    let diff: Vec<f64> = (0..n).map(|i| x[i] - xd[(i, 0)]).collect();
    let rel_diff = norm(&diff) / norm(&x);
    let r: Vec<f64> = mul(&a, &x).iter().zip(&b).map(|(ax, bi)| ax - bi).collect();
    let rel_res = norm(&r) / norm(&b);
    println!("sparse vs dense: relative difference {rel_diff:e}, residual {rel_res:e}");
    assert!(rel_diff < 1e-12, "{rel_diff}");
    assert!(rel_res < 1e-12, "{rel_res}");
}

/// `solve_many` gives, column by column, what `solve_in_place` gives (same
/// factor, same operations: identical to round-off of a different blocking,
/// 1e-14 relative).
#[test]
fn solve_many_matches_single_solves() {
    let a = laplacian_3d(6, 5, 4, 0.5);
    let n = a.rows();
    let chol = SparseCholesky::new(&a).unwrap();
    let mut rng = Lcg::new(7);
    let cols: Vec<Vec<f64>> = (0..3).map(|_| rng.vector(n)).collect();
    let mut block = Mat::<f64>::from_fn(n, 3, |i, j| cols[j][i]);
    chol.solve_many(block.as_mut()).unwrap();
    for (j, c) in cols.iter().enumerate() {
        let mut x = c.clone();
        chol.solve_in_place(&mut x).unwrap();
        let diff: Vec<f64> = (0..n).map(|i| x[i] - block[(i, j)]).collect();
        assert!(norm(&diff) <= 1e-14 * norm(&x), "column {j}");
    }
}

/// METIS nested dissection must produce less fill than the natural
/// (lexicographic) order on a 3-D grid, where the natural order's bandwidth
/// is nx*ny and nested dissection is asymptotically optimal. Printing AMD too
/// documents the orientation of METIS's permutation (DESIGN 6: the wrong
/// orientation gives far more fill than even the natural order's band).
#[test]
fn metis_beats_natural_ordering() {
    let a = laplacian_3d(16, 16, 16, 0.0);
    let nnz = |ordering| {
        SparseCholesky::with_options(
            &a,
            "3-D Laplacian",
            CholeskyOptions {
                ordering,
                ..Default::default()
            },
        )
        .unwrap()
        .nnz_l()
    };
    let metis = nnz(FillOrdering::Metis);
    let amd = nnz(FillOrdering::Amd);
    let natural = nnz(FillOrdering::Natural);
    println!("nnz(L) on a 16^3 grid: METIS {metis}, AMD {amd}, natural {natural}");
    assert!(metis < natural, "METIS {metis} vs natural {natural}");
    // Nested dissection on a 3-D grid: typically 2x less fill than the band.
    assert!(
        (metis as f64) < 0.75 * natural as f64,
        "METIS {metis} vs natural {natural}"
    );
}

/// Negating one diagonal entry makes the matrix indefinite (e_i^T A e_i < 0);
/// every principal submatrix without i is still SPD, so the first failing
/// pivot is exactly row i, which the error must name. Checked on a small grid
/// (faer's simplicial kernel) and a larger one (supernodal kernel), whose
/// pivot numbering conventions differ.
#[test]
fn indefinite_matrix_is_reported() {
    for (side, bad_row, expect_supernodal) in [(5, 37, false), (16, 2345, true)] {
        let a = laplacian_3d(side, side, side, 1.0);
        assert_eq!(
            SparseCholesky::new(&a).unwrap().is_supernodal(),
            expect_supernodal,
            "grid {side}^3 no longer exercises the intended faer kernel"
        );
        let mut t = TriMat::new((a.rows(), a.cols()));
        for (&v, (i, j)) in a.iter() {
            t.add_triplet(i, j, if i == j && i == bad_row { -v } else { v });
        }
        let bad: CsMat<f64> = t.to_csc();
        let err = SparseCholesky::new(&bad).unwrap_err();
        match &err {
            SparseError::NotPositiveDefinite { index, .. } => assert_eq!(*index, bad_row),
            other => panic!("unexpected error {other}"),
        }
        assert!(err.to_string().contains("not positive definite"), "{err}");
    }
}

#[test]
fn bad_inputs_are_rejected() {
    // Non-square.
    let mut t = TriMat::new((2, 3));
    t.add_triplet(0, 0, 1.0);
    let rect: CsMat<f64> = t.to_csc();
    assert!(matches!(
        SparseCholesky::new(&rect),
        Err(SparseError::Matrix {
            source: SymmetryError::NotSquare { rows: 2, cols: 3 },
            ..
        })
    ));
    // Asymmetric.
    let mut t = TriMat::new((2, 2));
    t.add_triplet(0, 0, 2.0);
    t.add_triplet(1, 1, 2.0);
    t.add_triplet(1, 0, 1.0);
    let asym: CsMat<f64> = t.to_csc();
    assert!(matches!(
        SparseCholesky::new(&asym),
        Err(SparseError::Matrix {
            source: SymmetryError::NotSymmetric { row: 1, col: 0, .. },
            ..
        })
    ));
    // NaN entry.
    let mut t = TriMat::new((2, 2));
    t.add_triplet(0, 0, f64::NAN);
    t.add_triplet(1, 1, 2.0);
    let nan: CsMat<f64> = t.to_csc();
    assert!(matches!(
        SparseCholesky::new(&nan),
        Err(SparseError::Matrix {
            source: SymmetryError::NonFinite { .. },
            ..
        })
    ));
    // Wrong right-hand side length.
    let a = laplacian_3d(3, 3, 3, 1.0);
    let chol = SparseCholesky::new(&a).unwrap();
    let mut short = vec![1.0; 5];
    assert!(matches!(
        chol.solve_in_place(&mut short),
        Err(SparseError::DimensionMismatch {
            expected: 27,
            found: 5,
            ..
        })
    ));
}

/// shifted(K, M, sigma) equals K - sigma M entry by entry (exact: one
/// multiply-subtract per entry, evaluated the same way in both).
#[test]
fn shifted_matches_dense_difference() {
    let k = laplacian_3d(3, 4, 2, 0.0);
    let (_, m) = common::spring_grid(3, 4, 2, 3);
    let sigma = -2.5;
    let s = csmat_to_dense(&shifted(&k, &m, sigma).unwrap());
    let kd = csmat_to_dense(&k);
    let md = csmat_to_dense(&m);
    for j in 0..k.cols() {
        for i in 0..k.rows() {
            assert_eq!(s[(i, j)], kd[(i, j)] - sigma * md[(i, j)]);
        }
    }
}

/// CSR storage of the same symmetric matrix gives the same factor and
/// solution (it is converted to CSC; identical operations, so bitwise equal).
#[test]
fn csr_input_is_accepted() {
    let a = laplacian_3d(4, 5, 6, 1.0);
    let b = Lcg::new(5).vector(a.rows());
    let mut x_csc = b.clone();
    SparseCholesky::new(&a)
        .unwrap()
        .solve_in_place(&mut x_csc)
        .unwrap();
    let mut x_csr = b;
    SparseCholesky::new(&a.to_csr())
        .unwrap()
        .solve_in_place(&mut x_csr)
        .unwrap();
    assert_eq!(x_csc, x_csr);
}

/// `refactorize` on a matrix of the same pattern (the Laplacian with another diagonal shift,
/// for both of faer's kernels) solves exactly as a fresh factorization (1e-13 relative: both
/// are the same numeric factorization on the same ordering, so they agree to round-off of the
/// solve), and a matrix of another pattern or order is refused instead of factorized wrongly.
#[test]
fn refactorization_reuses_the_analysis_and_checks_the_pattern() {
    for side in [5, 16] {
        let a = laplacian_3d(side, side, side, 1.0);
        let a2 = laplacian_3d(side, side, side, 2.5);
        let mut chol = SparseCholesky::new(&a).unwrap();
        assert!(chol.same_pattern(&a2));
        chol.refactorize(&a2, "shifted Laplacian").unwrap();
        let fresh = SparseCholesky::new(&a2).unwrap();
        let b = Lcg::new(7).vector(a.rows());
        let (mut x, mut y) = (b.clone(), b.clone());
        chol.solve_in_place(&mut x).unwrap();
        fresh.solve_in_place(&mut y).unwrap();
        let diff: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p - q).collect();
        assert!(
            norm(&diff) <= 1e-13 * norm(&y),
            "refactorized solve differs"
        );
        let r: Vec<f64> = mul(&a2, &x).iter().zip(&b).map(|(p, q)| p - q).collect();
        assert!(norm(&r) <= 1e-12 * norm(&b));
        // Another pattern (a 2-D coupling dropped) and another order.
        let mut t = TriMat::new((a.rows(), a.cols()));
        for (&v, (i, j)) in a.iter() {
            if i == j || (i as i64 - j as i64).abs() != 1 {
                t.add_triplet(i, j, v);
            }
        }
        let other: CsMat<f64> = t.to_csc();
        assert!(!chol.same_pattern(&other));
        let err = chol.refactorize(&other, "other").unwrap_err();
        assert!(err.to_string().contains("pattern"), "{err}");
        let small = laplacian_3d(side - 1, side, side, 1.0);
        assert!(chol.refactorize(&small, "small").is_err());
    }
}
