//! ARPACK shift-invert against the dense generalized eigensolver and
//! analytic spectra.

mod common;

use common::{column, free_chain, mac, mul, spring_grid};
use nlmodes_modal::{
    csmat_to_dense, dense_generalized_eigen, eigs_shift_invert, EigenMethod, EigenOptions,
    ModalError,
};

fn arpack_only() -> EigenOptions<'static> {
    EigenOptions {
        method: EigenMethod::Arpack,
        ..Default::default()
    }
}

/// First 10 eigenpairs of a 7 x 8 x 9 (n = 504) spring-mass grid with
/// consistent (non-diagonal) mass, clamped on one face, by ARPACK (sigma = 0)
/// and by the dense solver.
///
/// Tolerances: eigenvalues 1e-8 relative (the brief's target; both solvers
/// are backward stable and ARPACK, at its default tol = 1e-10, converges eigenvalues quadratically, so the
/// observed agreement is ~1e-13); M-orthonormality 1e-10 (Lanczos vectors
/// are M-orthogonalized with reorthogonalization, then normalized by us);
/// residuals 1e-9; MAC against the dense vectors > 1 - 1e-8 (the random
/// spring stiffnesses make the eigenvalues simple; the printed relative gaps
/// show it, and a gap g bounds the vector error by about residual / g).
#[test]
fn arpack_matches_dense_on_spring_grid() {
    let (k, m) = spring_grid(7, 8, 9, 11);
    let nev = 10;
    let modes = eigs_shift_invert(&k, &m, nev, 0.0, &arpack_only()).unwrap();
    let (dense_values, dense_vectors) =
        dense_generalized_eigen(csmat_to_dense(&k).as_ref(), csmat_to_dense(&m).as_ref()).unwrap();

    assert_eq!(modes.eigenvalues.len(), nev);
    common::assert_matches_dense("ARPACK", &modes, &dense_values, &dense_vectors, &m);
    // Residuals recomputed independently: below 1e-9, and equal to the
    // crate's to 1e-12 absolute (both are round-off-level numbers ~1e-14 whose
    // computation differs only by the rescaling of phi, i.e. in the last bits
    // of K phi - lambda M phi).
    for j in 0..nev {
        let phi = column(&modes.vectors, j);
        let kp = mul(&k, &phi);
        let mp = mul(&m, &phi);
        let lambda = modes.eigenvalues[j];
        let r: f64 = kp
            .iter()
            .zip(&mp)
            .map(|(a, b)| (a - lambda * b).powi(2))
            .sum::<f64>()
            .sqrt();
        let rel = r / (lambda.abs() * common::norm(&mp));
        assert!(rel < 1e-9, "mode {j}: independent residual {rel}");
        assert!(
            (rel - modes.residuals[j]).abs() <= 1e-12,
            "mode {j}: {rel} vs {}",
            modes.residuals[j]
        );
    }
    // Frequencies are sqrt(lambda) / (2 pi).
    let f = modes.frequencies_hz();
    assert!((f[0] - modes.eigenvalues[0].sqrt() / (2.0 * std::f64::consts::PI)).abs() < 1e-15);
}

/// Free-free chain of n = 400 unit masses and springs: K is singular, the
/// spectrum is 4 sin^2(j pi / (2 n)). A negative shift (sigma = -0.01) keeps
/// K - sigma M positive definite and ARPACK must find the zero (rigid) mode,
/// a constant vector, plus the elastic ones.
///
/// Tolerances: |lambda_0| < 1e-12 (machine epsilon times ||K|| = 4, amplified
/// by the shift-invert back-transform 1/nu + sigma with |sigma| = 1e-2:
/// ~1e-15 expected); elastic eigenvalues 1e-8 relative to the analytic
/// values (the smallest, 6e-5, is still resolved to ~1e-12 relative); the
/// rigid mode equals 1/sqrt(n) per component to 1e-8.
#[test]
fn negative_shift_finds_rigid_mode_of_free_chain() {
    let n = 400;
    let (k, m) = free_chain(n);
    let nev = 6;
    let modes = eigs_shift_invert(&k, &m, nev, -0.01, &arpack_only()).unwrap();
    for (j, &lambda) in modes.eigenvalues.iter().enumerate() {
        let exact = 4.0
            * (j as f64 * std::f64::consts::PI / (2.0 * n as f64))
                .sin()
                .powi(2);
        println!(
            "j = {j}: lambda {lambda:e}, exact {exact:e}, residual {:e}",
            modes.residuals[j]
        );
        if j == 0 {
            assert!(lambda.abs() < 1e-12, "zero mode {lambda}");
        } else {
            assert!(
                (lambda - exact).abs() <= 1e-8 * exact,
                "mode {j}: {lambda} vs {exact}"
            );
        }
        assert!(modes.residuals[j] < 1e-8, "mode {j}");
        assert!(modes.residuals[j].is_finite());
    }
    let rigid = column(&modes.vectors, 0);
    let c = 1.0 / (n as f64).sqrt();
    assert!(
        rigid.iter().all(|v| (v - c).abs() < 1e-8),
        "rigid mode is not constant"
    );
    assert!(modes.frequencies_hz().iter().all(|f| f.is_finite()));
}

/// Auto picks the dense solver for a small problem; it must agree with
/// ARPACK on the same problem (both tested above against independent
/// references; agreement to 1e-10 relative).
#[test]
fn auto_dense_path_agrees_with_arpack() {
    let (k, m) = spring_grid(4, 4, 3, 5); // n = 48
    let opts = EigenOptions {
        method: EigenMethod::Dense,
        ..Default::default()
    };
    let dense = eigs_shift_invert(&k, &m, 5, 0.0, &opts).unwrap();
    let arpack = eigs_shift_invert(&k, &m, 5, 0.0, &arpack_only()).unwrap();
    for j in 0..5 {
        let (d, a) = (dense.eigenvalues[j], arpack.eigenvalues[j]);
        assert!((d - a).abs() <= 1e-10 * d, "{d} vs {a}");
        assert!(mac(&column(&dense.vectors, j), &column(&arpack.vectors, j)) > 1.0 - 1e-8);
    }
    // n = 12 <= 2 ncv: Auto goes dense even for nev = n.
    let (k, m) = spring_grid(3, 2, 2, 5);
    let all = eigs_shift_invert(&k, &m, 12, 0.0, &EigenOptions::default()).unwrap();
    assert_eq!(all.eigenvalues.len(), 12);
    assert!(all.eigenvalues.windows(2).all(|w| w[0] <= w[1]));
}

/// The progress callback is called once per application of (K - sigma M)^-1.
#[test]
fn progress_callback_counts_solves() {
    let (k, m) = spring_grid(6, 6, 6, 2);
    let count = std::cell::Cell::new(0usize);
    let callback = |c: usize| count.set(c);
    let opts = EigenOptions {
        method: EigenMethod::Arpack,
        on_iteration: Some(&callback),
        ..Default::default()
    };
    eigs_shift_invert(&k, &m, 4, 0.0, &opts).unwrap();
    // At least one Lanczos basis of ncv = 20 vectors needs 20 solves.
    assert!(count.get() >= 20, "{}", count.get());
}

/// ARPACK keeps Fortran SAVE state: concurrent sessions must be serialized by
/// the crate and give exactly the results of a lone run (same deterministic
/// start vector, same operations: bitwise equal).
#[test]
fn concurrent_sessions_are_serialized() {
    let (k, m) = spring_grid(6, 7, 5, 3);
    let reference = eigs_shift_invert(&k, &m, 6, 0.0, &arpack_only()).unwrap();
    let results: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..3)
            .map(|_| s.spawn(|| eigs_shift_invert(&k, &m, 6, 0.0, &arpack_only()).unwrap()))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for r in results {
        assert_eq!(r.eigenvalues, reference.eigenvalues);
    }
}

#[test]
fn invalid_requests_give_errors() {
    let (k, m) = spring_grid(5, 5, 4, 1);
    let n = k.rows();
    let err = eigs_shift_invert(&k, &m, 0, 0.0, &EigenOptions::default()).unwrap_err();
    assert!(
        matches!(err, ModalError::InvalidEigenCount { nev: 0, .. }),
        "{err}"
    );
    let err = eigs_shift_invert(&k, &m, n + 1, 0.0, &EigenOptions::default()).unwrap_err();
    assert!(matches!(err, ModalError::InvalidEigenCount { .. }), "{err}");
    let err = eigs_shift_invert(&k, &m, n, 0.0, &arpack_only()).unwrap_err();
    assert!(err.to_string().contains("ARPACK needs nev < n"), "{err}");
    let err = eigs_shift_invert(&k, &m, 3, f64::NAN, &EigenOptions::default()).unwrap_err();
    assert!(matches!(err, ModalError::InvalidArgument(_)), "{err}");
    let bad_ncv = EigenOptions {
        ncv: Some(3),
        method: EigenMethod::Arpack,
        ..Default::default()
    };
    let err = eigs_shift_invert(&k, &m, 3, 0.0, &bad_ncv).unwrap_err();
    assert!(err.to_string().contains("ncv = 3"), "{err}");
    // A shift above the lowest eigenvalue makes K - sigma M indefinite.
    let modes = eigs_shift_invert(&k, &m, 2, 0.0, &arpack_only()).unwrap();
    let sigma = 0.5 * (modes.eigenvalues[0] + modes.eigenvalues[1]);
    let err = eigs_shift_invert(&k, &m, 2, sigma, &arpack_only()).unwrap_err();
    assert!(
        matches!(err, ModalError::NotPositiveDefinite { .. }),
        "{err}"
    );
    assert!(err.to_string().contains("sigma must lie below"), "{err}");
    // Too few restarts: a typed non-convergence error with counts.
    let tight = EigenOptions {
        max_iterations: 1,
        ncv: Some(5),
        method: EigenMethod::Arpack,
        ..Default::default()
    };
    let err = eigs_shift_invert(&k, &m, 4, 0.0, &tight).unwrap_err();
    match err {
        ModalError::NoConvergence {
            requested,
            converged,
            ..
        } => {
            assert_eq!(requested, 4);
            assert!(converged < 4);
        }
        other => panic!("expected NoConvergence, got {other}"),
    }
}
