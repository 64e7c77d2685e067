//! Small systems and independent references shared by the forced-response tests.
#![allow(dead_code)]

use faer::Mat;
use nlmodes_hb::{FullBasis, System};

/// The 3-DOF system with a non-diagonal mass matrix of the nnm tests (`three_dof_stop`): one
/// contact row 0.2 x0 + x2 with gap `gap`, master x2.
pub fn three_dof(gap: f64) -> System {
    let m = [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 1.5]];
    let k = [[3.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.2]];
    let a = [0.2, 0.0, 1.0];
    System::new(
        Mat::from_fn(3, 3, |i, j| m[i][j]),
        Mat::from_fn(3, 3, |i, j| k[i][j]),
        Mat::from_fn(1, 3, |_, j| a[j]),
        vec![gap],
        2,
    )
    .expect("3-DOF system")
}

/// Complex amplitude U = a - i b of the linear response to f = f_c cos + f_s sin at the
/// frequency `nw` (rad/s): (K - nw^2 M + i nw C) U = f_c - i f_s, solved as a real 2n x 2n system
/// by Gaussian elimination with partial pivoting (independent of the crate's modal path).
/// Returns (a, b).
pub fn linear_harmonic(
    system: &System,
    c: &Mat<f64>,
    nw: f64,
    fc: &[f64],
    fs: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let n = system.n_dofs();
    let (m, k) = (system.mass(), system.stiffness());
    let mut a = vec![vec![0.0; 2 * n + 1]; 2 * n];
    for i in 0..n {
        for j in 0..n {
            let d = k[(i, j)] - nw * nw * m[(i, j)];
            let e = nw * c[(i, j)];
            a[i][j] = d;
            a[i][n + j] = -e;
            a[n + i][j] = e;
            a[n + i][n + j] = d;
        }
        a[i][2 * n] = fc[i];
        a[n + i][2 * n] = -fs[i];
    }
    let x = gauss(a);
    (x[..n].to_vec(), x[n..].iter().map(|v| -v).collect())
}

fn gauss(mut a: Vec<Vec<f64>>) -> Vec<f64> {
    let n = a.len();
    for col in 0..n {
        let p = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap();
        a.swap(col, p);
        let pivot = a[col].clone();
        for row in a.iter_mut().skip(col + 1) {
            let f = row[col] / pivot[col];
            row.iter_mut()
                .zip(&pivot)
                .skip(col)
                .for_each(|(v, p)| *v -= f * p);
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|cc| a[r][cc] * x[cc]).sum();
        x[r] = (a[r][n] - s) / a[r][r];
    }
    x
}

/// The gap of [`tip_chain`].
pub const TIP_CHAIN_GAP: f64 = 1.0;

/// A 2-DOF blade-like chain: a body (m = 1) on a root spring (k = 1) and a light tip (m = 0.05)
/// on a stiff spring (k = 10) whose own mode lies near 15 w1, the contact on the tip (gap
/// `TIP_CHAIN_GAP`, master the tip); with `padded` a stiff coordinate coupled to nothing
/// (k = 1e6), as FE models have (tests/casing_cutoff.rs, tests/forced_settled_stability.rs).
pub fn tip_chain(padded: bool) -> System {
    let n = if padded { 3 } else { 2 };
    let m = [1.0, 0.05, 1.0];
    let k = [[11.0, -10.0, 0.0], [-10.0, 10.0, 0.0], [0.0, 0.0, 1e6]];
    System::new(
        Mat::from_fn(n, n, |i, j| if i == j { m[i] } else { 0.0 }),
        Mat::from_fn(n, n, |i, j| k[i][j]),
        Mat::from_fn(1, n, |_, j| if j == 1 { 1.0 } else { 0.0 }),
        vec![TIP_CHAIN_GAP],
        1,
    )
    .expect("tip chain")
}

/// The penalty of [`tip_chain`]'s tests: 10 x the chain's static contact stiffness.
pub fn tip_chain_kc() -> f64 {
    10.0 * tip_chain(false).contact_stiffness()[0]
}

/// 2 % modal damping of `s`.
pub fn tip_chain_damping(s: &System) -> Mat<f64> {
    nlmodes_forced::Damping::ModalRatios(vec![0.02])
        .matrix(s)
        .expect("modal damping")
}

/// Forced settings at N = `harmonics` with `samples` time samples under the penalty law of
/// stiffness `kc` (N/m), the other keys at their defaults.
pub fn penalty_settings(
    harmonics: usize,
    samples: usize,
    kc: f64,
) -> nlmodes_forced::ForcedSettings {
    nlmodes_forced::ForcedSettings {
        harmonics: nlmodes_hb::HarmonicSettings::new(harmonics, samples).expect("N and m"),
        algorithm: nlmodes_hb::AlgorithmParams {
            method: nlmodes_hb::ContactMethod::Penalty { stiffness: kc },
            ..nlmodes_hb::AlgorithmParams::default()
        },
        ..nlmodes_forced::ForcedSettings::new(harmonics).expect("N")
    }
}

/// (x, v)(0) of a harmonic-balance orbit (`coefficients`: n x (2N + 1)) at W (rad/s): the
/// start the oracle's shooting (`pwl::periodic_at`) takes from a point.
pub fn state_at_zero(coefficients: &Mat<f64>, w: f64) -> Vec<f64> {
    let n = coefficients.nrows();
    let series = |i: usize| {
        (0..coefficients.ncols())
            .map(|q| coefficients[(i, q)])
            .collect::<Vec<f64>>()
    };
    let mut z: Vec<f64> = (0..n)
        .map(|i| FullBasis::value_at(&series(i), 0.0))
        .collect();
    z.extend((0..n).map(|i| FullBasis::rate_at(&series(i), w, 0.0)));
    z
}
