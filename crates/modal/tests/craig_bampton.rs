//! Craig-Bampton reduction checked against the full model.

mod common;

use faer::linalg::solvers::Solve;

use common::{column, far_face, mac, norm, spring_grid, Lcg};
use nlmodes_modal::{
    craig_bampton, craig_bampton_with_check, craig_bampton_with_loads, eigs_shift_invert,
    reduced_eigen, EigenMethod, EigenOptions, ModalError, SparseCholesky,
};
use sprs::{CsMat, TriMat};

/// Slender 40 x 3 x 3 spring-mass grid (n = 360, a "beam"), clamped on the
/// face i = 0; boundary = 6 of the 9 DOFs of the free end face, deliberately
/// not in ascending order.
fn structure() -> (CsMat<f64>, CsMat<f64>, Vec<usize>) {
    let (nx, ny, nz) = (40, 3, 3);
    let (k, m) = spring_grid(nx, ny, nz, 21);
    let face = far_face(nx, ny, nz);
    let boundary = vec![face[4], face[0], face[8], face[2], face[6], face[3]];
    (k, m, boundary)
}

fn arpack() -> EigenOptions<'static> {
    EigenOptions {
        method: EigenMethod::Arpack,
        ..Default::default()
    }
}

/// Rayleigh-Ritz properties and convergence of the reduced eigenvalues.
///
/// * Every reduced eigenvalue is >= the full one of the same rank (Ritz
///   values of a subspace, Cauchy interlacing), to round-off: 1e-10 relative
///   (dense eigen of a model of at most 360 DOFs, errors ~1e-13).
/// * The bases for 5, 10, 20, 40 modes are nested (same constraint modes,
///   more fixed-interface modes), so each of the first 6 eigenvalue errors
///   is non-increasing as modes are added (slack 1e-12 relative for round-off).
/// * With every interior mode kept, T is square and invertible, so the
///   reduced spectrum is the full one: 1e-9 relative (round-off of two
///   different dense/sparse eigensolvers on matrices of condition ~1e4).
/// * With 40 modes the first 6 eigenvalues are within 1e-3 relative (0.05 %
///   in frequency): an engineering requirement for the reduced blade model,
///   not a convergence-rate bound; this lattice has a bounded, dense
///   spectrum, so CB converges only about like 1/n_modes here (printed).
/// * Recovered full-model shapes with 40 modes have MAC > 0.999 with the full modes.
#[test]
fn reduced_frequencies_converge_from_above() {
    let (k, m, boundary) = structure();
    let n_check = 6;
    let n_interior = k.rows() - boundary.len();
    let full = eigs_shift_invert(&k, &m, n_check, 0.0, &arpack()).unwrap();
    let mut previous: Option<Vec<f64>> = None;
    for n_modes in [5, 10, 20, 40, n_interior] {
        let opts = if n_modes == n_interior {
            EigenOptions::default()
        } else {
            arpack()
        };
        let cb = craig_bampton(&k, &m, &boundary, n_modes, &opts).unwrap();
        let (values, vectors) = reduced_eigen(&cb).unwrap();
        let errors: Vec<f64> = (0..n_check)
            .map(|j| (values[j] - full.eigenvalues[j]) / full.eigenvalues[j])
            .collect();
        println!("{n_modes} modes: relative errors {errors:?}");
        for (j, e) in errors.iter().enumerate() {
            assert!(
                *e >= -1e-10,
                "{n_modes} modes, mode {j}: below the full value ({e})"
            );
        }
        if let Some(prev) = &previous {
            for j in 0..n_check {
                assert!(
                    errors[j] <= prev[j] + 1e-12,
                    "{n_modes} modes, mode {j}: error grew from {} to {}",
                    prev[j],
                    errors[j]
                );
            }
        }
        if n_modes == 40 {
            for (j, e) in errors.iter().enumerate() {
                assert!(*e < 1e-3, "mode {j}: relative error {e}");
                let u = cb.recover(&column(&vectors, j)).unwrap();
                let mac_value = mac(&u, &column(&full.vectors, j));
                println!("mode {j}: MAC {mac_value}");
                assert!(mac_value > 0.999, "mode {j}: MAC {mac_value}");
            }
        }
        if n_modes == n_interior {
            for (j, e) in errors.iter().enumerate() {
                assert!(
                    e.abs() < 1e-9,
                    "complete basis, mode {j}: relative error {e}"
                );
            }
        }
        previous = Some(errors);
    }
}

/// Structure of K_r and M_r: the boundary-modal coupling block of K_r is
/// zero and its modal block is diag(lambda); the modal block of M_r is I.
/// Exact in exact arithmetic; numerically each entry is a sum of ~n terms of
/// size ||K|| |Psi| |Phi|, so round-off ~1e-13 relative to max|K_r|;
/// tolerance 1e-10. The asymmetry measured before symmetrization is
/// round-off too (< 1e-12).
#[test]
fn reduced_matrices_have_craig_bampton_structure() {
    let (k, m, boundary) = structure();
    let n_modes = 12;
    let cb = craig_bampton(&k, &m, &boundary, n_modes, &arpack()).unwrap();
    let n_b = boundary.len();
    assert_eq!(cb.n_reduced(), n_b + n_modes);
    assert_eq!(cb.boundary, boundary);
    assert_eq!(cb.interior.len(), k.rows() - n_b);
    let scale = (0..cb.n_reduced())
        .flat_map(|i| (0..cb.n_reduced()).map(move |j| (i, j)))
        .map(|(i, j)| cb.k_r[(i, j)].abs())
        .fold(0.0, f64::max);
    for i in 0..n_b {
        for j in 0..n_modes {
            assert!(
                cb.k_r[(i, n_b + j)].abs() < 1e-10 * scale,
                "K_r[{i}, {}]",
                n_b + j
            );
        }
    }
    for i in 0..n_modes {
        for j in 0..n_modes {
            let expected_k = if i == j {
                cb.fixed_interface_eigenvalues[i]
            } else {
                0.0
            };
            let expected_m = if i == j { 1.0 } else { 0.0 };
            assert!((cb.k_r[(n_b + i, n_b + j)] - expected_k).abs() < 1e-10 * scale);
            assert!((cb.m_r[(n_b + i, n_b + j)] - expected_m).abs() < 1e-10);
        }
    }
    println!(
        "asymmetry K_r {:e}, M_r {:e}",
        cb.asymmetry_k, cb.asymmetry_m
    );
    assert!(cb.asymmetry_k < 1e-12 && cb.asymmetry_m < 1e-12);
    // The fixed-interface eigenvalues are those of (K_ii, M_ii) computed independently.
    let k_ii = nlmodes_modal::sparse_ops::submatrix(&k, &cb.interior, &cb.interior).unwrap();
    let m_ii = nlmodes_modal::sparse_ops::submatrix(&m, &cb.interior, &cb.interior).unwrap();
    let direct = eigs_shift_invert(&k_ii, &m_ii, n_modes, 0.0, &arpack()).unwrap();
    for (a, b) in direct
        .eigenvalues
        .iter()
        .zip(&cb.fixed_interface_eigenvalues)
    {
        assert!((a - b).abs() <= 1e-10 * a, "{a} vs {b}");
    }
}

/// A static load on boundary DOFs only: the constraint modes span the exact
/// static response, so the reduced solution equals the full one. Both are
/// backward-stable Cholesky solves of matrices with condition ~1e3, so the
/// agreement is ~1e-13; tolerance 1e-10 (the brief's).
#[test]
fn static_boundary_load_is_exact() {
    let (k, m, boundary) = structure();
    let cb = craig_bampton(&k, &m, &boundary, 8, &arpack()).unwrap();
    let n_b = boundary.len();
    let loads = Lcg::new(9).vector(n_b);
    let mut f = vec![0.0; k.rows()];
    for (&dof, &value) in boundary.iter().zip(&loads) {
        f[dof] = value;
    }
    let mut u_full = f.clone();
    SparseCholesky::new(&k)
        .unwrap()
        .solve_in_place(&mut u_full)
        .unwrap();

    let mut f_r = vec![0.0; cb.n_reduced()];
    f_r[..n_b].copy_from_slice(&loads);
    let k_r_llt = cb.k_r.llt(faer::Side::Lower).unwrap();
    let rhs = faer::Mat::<f64>::from_fn(cb.n_reduced(), 1, |i, _| f_r[i]);
    let q = faer::prelude::Solve::solve(&k_r_llt, &rhs);
    let q: Vec<f64> = (0..cb.n_reduced()).map(|i| q[(i, 0)]).collect();
    let u_red = cb.recover(&q).unwrap();
    let diff: Vec<f64> = u_full.iter().zip(&u_red).map(|(a, b)| a - b).collect();
    let rel = norm(&diff) / norm(&u_full);
    println!("static boundary load: relative difference {rel:e}");
    assert!(rel < 1e-10, "{rel}");
    // The modal amplitudes of a static boundary load vanish (K_r block diagonal).
    assert!(q[n_b..].iter().all(|v| v.abs() < 1e-10 * norm(&q)));
}

/// `recovery_basis` is T: its columns reproduce `recover` on unit vectors.
#[test]
fn recovery_basis_matches_recover() {
    let (k, m, boundary) = structure();
    let cb = craig_bampton(&k, &m, &boundary, 4, &arpack()).unwrap();
    let t = cb.recovery_basis();
    assert_eq!((t.nrows(), t.ncols()), (k.rows(), cb.n_reduced()));
    for j in 0..cb.n_reduced() {
        let mut e = vec![0.0; cb.n_reduced()];
        e[j] = 1.0;
        assert_eq!(cb.recover(&e).unwrap(), column(&t, j));
    }
    assert!(matches!(
        cb.recover(&[1.0]),
        Err(ModalError::DimensionMismatch { found: 1, .. })
    ));
}

/// Guyan reduction (no modes) is allowed and equals the static condensation.
#[test]
fn zero_modes_gives_guyan_reduction() {
    let (k, m, boundary) = structure();
    let cb = craig_bampton(&k, &m, &boundary, 0, &EigenOptions::default()).unwrap();
    assert_eq!(cb.n_reduced(), boundary.len());
    assert!(cb.fixed_interface_eigenvalues.is_empty());
}

#[test]
fn invalid_inputs_give_errors() {
    let (k, m, boundary) = structure();
    let n = k.rows();
    let opts = EigenOptions::default();
    let err = craig_bampton(&k, &m, &[], 3, &opts).unwrap_err();
    assert!(err.to_string().contains("empty"), "{err}");
    let err = craig_bampton(&k, &m, &[3, n], 3, &opts).unwrap_err();
    assert!(
        err.to_string().contains(&format!("boundary DOF {n}")),
        "{err}"
    );
    let err = craig_bampton(&k, &m, &[3, 7, 3], 3, &opts).unwrap_err();
    assert!(err.to_string().contains("appears twice"), "{err}");
    let err = craig_bampton(&k, &m, &boundary, n - boundary.len() + 1, &opts).unwrap_err();
    assert!(err.to_string().contains("interior DOFs"), "{err}");
    let all: Vec<usize> = (0..n).collect();
    let err = craig_bampton(&k, &m, &all, 0, &opts).unwrap_err();
    assert!(err.to_string().contains("nothing to reduce"), "{err}");

    // A negative stiffness on interior DOF 40 makes K_ii indefinite; the
    // error names it in the input numbering.
    let mut t = TriMat::new((n, n));
    for (&v, (i, j)) in k.iter() {
        t.add_triplet(i, j, if i == j && i == 40 { -v } else { v });
    }
    let bad: CsMat<f64> = t.to_csc();
    let err = craig_bampton(&bad, &m, &boundary, 3, &opts).unwrap_err();
    match &err {
        ModalError::NotPositiveDefinite { index, .. } => assert_eq!(*index, 40),
        other => panic!("unexpected error {other}"),
    }
    assert!(err.to_string().contains("K_ii"), "{err}");
}

/// The full-model check reuses the factor of K_ii bordered by the Schur complement of the
/// boundary (`BorderedSolve`): its eigenvalues equal those of a separate factorization of the
/// whole K to the eigensolvers' accuracy (tol 1e-10 on the Ritz estimates gives eigenvalue errors
/// of order 1e-14 relative, docs of `EigenOptions::tol`; 1e-11 leaves room for the different
/// round-off of the two factorizations), and its shapes agree (MAC > 1 - 1e-9).
#[test]
fn full_model_check_from_the_interior_factor_matches_a_separate_factorization() {
    let (k, m, boundary) = structure();
    let n_check = 6;
    let reference = eigs_shift_invert(&k, &m, n_check, 0.0, &arpack()).unwrap();
    for opts in [arpack(), EigenOptions::default()] {
        let (cb, full) = craig_bampton_with_check(&k, &m, &boundary, 10, n_check, &opts).unwrap();
        let full = full.expect("check modes requested");
        assert_eq!(cb.n_reduced(), boundary.len() + 10);
        for i in 0..n_check {
            let (a, b) = (full.eigenvalues[i], reference.eigenvalues[i]);
            assert!((a - b).abs() <= 1e-11 * b.abs(), "mode {i}: {a} vs {b}");
            let mac_value = mac(&column(&full.vectors, i), &column(&reference.vectors, i));
            assert!(mac_value > 1.0 - 1e-9, "mode {i}: MAC {mac_value}");
        }
    }
    let (_, none) = craig_bampton_with_check(&k, &m, &boundary, 10, 0, &arpack()).unwrap();
    assert!(none.is_none());
}

/// Static correction (issue 22): a load on every DOF of the grid (random, boundary included)
/// reaches the reduced model as T^T f; with its correction vector in the basis the reduced static
/// response, recovered, equals the full model's K^-1 f to round-off (1e-8 relative: solves of
/// condition ~1e4 matrices), at 5 or 20 modes alike; without it the error is that of the modal
/// truncation of the interior response (above 1e-4 here), so the check can fail.
#[test]
fn static_correction_makes_the_reduced_static_response_exact() {
    let (k, m, boundary) = structure();
    let n = k.rows();
    let mut rng = Lcg::new(7);
    let f: Vec<f64> = (0..n).map(|_| rng.next_f64() - 0.5).collect();
    let full = {
        let chol = SparseCholesky::new(&k).unwrap();
        let mut u = faer::Mat::from_fn(n, 1, |i, _| f[i]);
        chol.solve_many(u.as_mut()).unwrap();
        (0..n).map(|i| u[(i, 0)]).collect::<Vec<f64>>()
    };
    let error = |loads: &[Vec<f64>], modes: usize| {
        let (cb, _) =
            craig_bampton_with_loads(&k, &m, &boundary, modes, 0, loads, &arpack()).unwrap();
        let t = cb.recovery_basis();
        let nr = cb.n_reduced();
        let fr = faer::Mat::from_fn(nr, 1, |j, _| (0..n).map(|i| t[(i, j)] * f[i]).sum::<f64>());
        let qr = cb.k_r.partial_piv_lu().solve(&fr);
        let u = cb
            .recover(&(0..nr).map(|j| qr[(j, 0)]).collect::<Vec<f64>>())
            .unwrap();
        let diff: Vec<f64> = u.iter().zip(&full).map(|(a, b)| a - b).collect();
        (norm(&diff) / norm(&full), nr)
    };
    for modes in [5, 20] {
        let (with, nr) = error(std::slice::from_ref(&f), modes);
        let (without, nr0) = error(&[], modes);
        println!("{modes} modes: static error {with:.1e} with the correction ({nr} coordinates), {without:.1e} without ({nr0})");
        assert_eq!(nr, nr0 + 1);
        assert!(with < 1e-8, "{with:e}");
        assert!(without > 1e-4, "{without:e}");
    }
}
