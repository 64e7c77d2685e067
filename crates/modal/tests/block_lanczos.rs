//! The shift-invert block Lanczos eigensolver against the dense generalized eigensolver, ARPACK
//! and an analytic spectrum.

mod common;

use std::cell::Cell;

use common::{column, free_chain, mac, spring_grid};
use nlmodes_modal::eigen_options::block_size;
use nlmodes_modal::{
    csmat_to_dense, dense_generalized_eigen, eigs_shift_invert, EigenMethod, EigenOptions,
};

fn with_method(method: EigenMethod) -> EigenOptions<'static> {
    EigenOptions {
        method,
        ..Default::default()
    }
}

/// First 10 eigenpairs of a 7 x 8 x 9 (n = 504) spring-mass grid with consistent mass, clamped
/// on one face, by block Lanczos (sigma = 0) and by the dense solver.
///
/// Tolerances, as for ARPACK in `tests/arpack.rs`: eigenvalues 1e-8 relative (the convergence
/// test bounds the Ritz estimate by tol = 1e-10 of the Ritz value and eigenvalue errors are
/// quadratic in it: ~1e-13 is observed); residuals 1e-9; MAC > 1 - 1e-8 (simple eigenvalues,
/// relative gaps printed); M-orthonormality 1e-10.
#[test]
fn block_lanczos_matches_dense_on_spring_grid() {
    let (k, m) = spring_grid(7, 8, 9, 11);
    let nev = 10;
    let modes = eigs_shift_invert(&k, &m, nev, 0.0, &with_method(EigenMethod::BlockLanczos))
        .expect("block Lanczos converges");
    let (dense_values, dense_vectors) =
        dense_generalized_eigen(csmat_to_dense(&k).as_ref(), csmat_to_dense(&m).as_ref())
            .expect("dense eigen");
    assert_eq!(modes.eigenvalues.len(), nev);
    common::assert_matches_dense("block Lanczos", &modes, &dense_values, &dense_vectors, &m);
}

/// 40 eigenpairs of a 14 x 14 x 14 grid (n = 2548 free DOFs, above the dense threshold) by block
/// Lanczos and by ARPACK: eigenvalues agree to 1e-10 relative (each is within ~1e-13 of the
/// exact value on the small grid above; 1e-10 leaves room for the larger spectrum), both
/// residual sets below 1e-9, and MAC > 1 - 1e-8 (simple eigenvalues: random springs).
#[test]
fn block_lanczos_matches_arpack_for_forty_modes() {
    let (k, m) = spring_grid(14, 14, 14, 5);
    let nev = 40;
    let block = eigs_shift_invert(&k, &m, nev, 0.0, &with_method(EigenMethod::BlockLanczos))
        .expect("block Lanczos");
    let arpack =
        eigs_shift_invert(&k, &m, nev, 0.0, &with_method(EigenMethod::Arpack)).expect("ARPACK");
    let mut worst = 0.0_f64;
    for j in 0..nev {
        let (a, b) = (block.eigenvalues[j], arpack.eigenvalues[j]);
        worst = worst.max((a - b).abs() / b.abs());
        assert!((a - b).abs() <= 1e-10 * b.abs(), "mode {j}: {a} vs {b}");
        assert!(
            block.residuals[j] < 1e-9,
            "mode {j}: {}",
            block.residuals[j]
        );
        let mac_value = mac(&column(&block.vectors, j), &column(&arpack.vectors, j));
        assert!(mac_value > 1.0 - 1e-8, "mode {j}: MAC {mac_value}");
    }
    println!(
        "40 modes, n = {}: largest relative difference {worst:.1e}",
        k.rows()
    );
}

/// Free-free chain of n = 400 unit masses: singular K, spectrum 4 sin^2(j pi / (2 n)). With
/// sigma = -0.01 block Lanczos must find the rigid mode (|lambda_0| < 1e-12, as for ARPACK) and
/// the elastic eigenvalues to 1e-8 relative.
#[test]
fn block_lanczos_finds_the_rigid_mode_with_a_negative_shift() {
    let n = 400;
    let (k, m) = free_chain(n);
    let nev = 8;
    let modes = eigs_shift_invert(&k, &m, nev, -0.01, &with_method(EigenMethod::BlockLanczos))
        .expect("block Lanczos");
    assert!(
        modes.eigenvalues[0].abs() < 1e-12,
        "rigid mode {}",
        modes.eigenvalues[0]
    );
    for j in 1..nev {
        let exact = 4.0
            * (j as f64 * std::f64::consts::PI / (2.0 * n as f64))
                .sin()
                .powi(2);
        let got = modes.eigenvalues[j];
        assert!(
            (got - exact).abs() <= 1e-8 * exact,
            "mode {j}: {got} vs {exact}"
        );
    }
}

/// The progress callback is called after every block, with the running number of solves (a
/// multiple of the block size).
#[test]
fn progress_callback_counts_block_solves() {
    let (k, m) = spring_grid(6, 6, 6, 3);
    let nev = 6;
    let b = block_size(nev);
    let calls = Cell::new(0usize);
    let last = Cell::new(0usize);
    let tick = |solves: usize| {
        calls.set(calls.get() + 1);
        assert_eq!(solves % b, 0, "solves {solves} not a multiple of {b}");
        assert!(solves > last.get());
        last.set(solves);
    };
    let opts = EigenOptions {
        method: EigenMethod::BlockLanczos,
        on_iteration: Some(&tick),
        ..Default::default()
    };
    eigs_shift_invert(&k, &m, nev, 0.0, &opts).expect("block Lanczos");
    assert!(calls.get() >= 2);
    assert_eq!(last.get(), calls.get() * b);
}
