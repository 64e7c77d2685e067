//! Below grazing the forced response is the linear modal FRF of the reduced model: checked
//! against a direct solve of (K - (hW)^2 M + i hW C) U = F (`common::linear_harmonic`) to 1e-10
//! relative, for Rayleigh, modal-ratio and a non-proportional damping matrix (the diagonal and
//! the dense path of `ModalDynamics`), a load on two harmonics with cosine and sine parts, at
//! frequencies below, at and above the resonances.

mod common;

use faer::Mat;
use nlmodes_forced::{Damping, ForcedSettings, ForcedSolver, HarmonicLoad, Load};
use nlmodes_hb::FullBasis;

fn load() -> Load {
    Load {
        harmonics: vec![
            HarmonicLoad {
                harmonic: 1,
                cos: vec![0.3, -0.1, 1.0],
                sin: vec![0.0, 0.2, 0.0],
            },
            HarmonicLoad {
                harmonic: 3,
                cos: vec![0.0, 0.0, 0.1],
                sin: vec![0.05, 0.0, 0.0],
            },
        ],
    }
}

fn check(damping: Damping) {
    let system = common::three_dof(1e3); // the gap is never reached
    let c = damping.matrix(&system).unwrap();
    let settings = ForcedSettings::new(5).unwrap();
    let load = load();
    let solver = ForcedSolver::new(&system, &c, &load, settings).unwrap();
    let w = system.linear_frequencies();
    for omega in [
        0.3 * w[0],
        w[0],
        0.5 * (w[0] + w[1]),
        w[1],
        w[2] / 3.0,
        1.7 * w[2],
    ] {
        let start = solver.linear_start(omega, 1.0).unwrap();
        let point = solver.solve(start, None).unwrap();
        let mut largest = 0.0_f64;
        let mut worst = 0.0_f64;
        for h in 1..=5 {
            let (fc, fs) = load.at(h, 3);
            let (a, b) = common::linear_harmonic(&system, &c, h as f64 * omega, &fc, &fs);
            for i in 0..3 {
                let (pa, pb) = (FullBasis::cos_index(h), FullBasis::sin_index(h));
                largest = largest.max(a[i].abs()).max(b[i].abs());
                worst = worst
                    .max((point.coefficients[(i, pa)] - a[i]).abs())
                    .max((point.coefficients[(i, pb)] - b[i]).abs());
            }
        }
        for i in 0..3 {
            worst = worst.max(point.coefficients[(i, 0)].abs());
        }
        assert!(
            worst <= 1e-10 * largest,
            "W = {omega}: error {worst:e} of {largest:e}"
        );
    }
}

#[test]
fn rayleigh_damping_gives_the_linear_frf() {
    check(Damping::Rayleigh {
        alpha: 0.02,
        beta: 0.01,
    });
}

#[test]
fn modal_ratios_give_the_linear_frf_and_the_stated_ratios() {
    let system = common::three_dof(1e3);
    let damping = Damping::ModalRatios(vec![0.01, 0.02]);
    let c = damping.matrix(&system).unwrap();
    let ratios = nlmodes_forced::modal_ratios(&system, &c);
    for (k, want) in [0.01, 0.02, 0.02].iter().enumerate() {
        assert!((ratios[k] - want).abs() < 1e-13, "mode {k}: {}", ratios[k]);
    }
    check(damping);
}

#[test]
fn a_non_proportional_matrix_gives_the_linear_frf() {
    // Dampers on DOF 0 alone: Phi^T C Phi is full, the dense path of ModalDynamics runs.
    let c = Mat::from_fn(3, 3, |i, j| if i == 0 && j == 0 { 0.2 } else { 0.0 });
    check(Damping::Matrix(c));
}
