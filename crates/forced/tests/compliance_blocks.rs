//! The harmonic-block products of the contact compliance (`ContactCompliance::apply`,
//! `apply_transpose`) against the dense products with the same G, for both damping paths and
//! two contact rows that share modes (every block of G is full). The G J products of the
//! Newton solve: `active_jacobian.rs`'s unit test.

mod common;

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use nlmodes_forced::{Damping, Load, ModalDynamics};
use nlmodes_hb::System;

fn two_rows() -> System {
    let m = [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 1.5]];
    let k = [[3.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.2]];
    let a = [[0.2, 0.0, 1.0], [1.0, -0.4, 0.0]];
    System::new(
        Mat::from_fn(3, 3, |i, j| m[i][j]),
        Mat::from_fn(3, 3, |i, j| k[i][j]),
        Mat::from_fn(2, 3, |i, j| a[i][j]),
        vec![0.5, 0.7],
        2,
    )
    .expect("3-DOF system with two contact rows")
}

fn dense(a: faer::MatRef<'_, f64>, b: faer::MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    out
}

fn check(damping: Damping) {
    let system = two_rows();
    let c = damping.matrix(&system).unwrap();
    let nh = 5;
    let t = 2 * nh + 1;
    let dynamics =
        ModalDynamics::new(&system, &c, &Load::fundamental(vec![0.1, 0.0, 0.3]), nh).unwrap();
    for w in [0.3, 1.1, 2.6] {
        let comp = dynamics.compliance(w).unwrap();
        let l = 2 * t;
        let lambda: Vec<f64> = (0..l).map(|i| (0.7 * i as f64 + 0.2).sin()).collect();
        let g = comp.dense();
        let want = dense(g.as_ref(), Mat::from_fn(l, 1, |i, _| lambda[i]).as_ref());
        let got = comp.apply(&lambda);
        let scale = g.norm_max() * l as f64;
        for i in 0..l {
            assert!((got[i] - want[(i, 0)]).abs() <= 1e-14 * scale, "W {w}, {i}");
        }
        // G^T v on the coefficients of each row (both rows, then the second alone).
        let v: Vec<f64> = (0..l).map(|i| (0.3 * i as f64 - 0.4).cos()).collect();
        let want = dense(g.transpose(), Mat::from_fn(l, 1, |i, _| v[i]).as_ref());
        for rows in [vec![0, 1], vec![1]] {
            let got = comp.apply_transpose(&v, &rows);
            for (ar, &j) in rows.iter().enumerate() {
                for p in 0..t {
                    let (a, b) = (got[ar * t + p], want[(j * t + p, 0)]);
                    assert!((a - b).abs() <= 1e-14 * scale, "W {w}, row {j}, {p}");
                }
            }
        }
    }
}

#[test]
fn block_products_equal_the_dense_products_of_g() {
    check(Damping::Rayleigh {
        alpha: 0.02,
        beta: 0.01,
    });
    check(Damping::Matrix(Mat::from_fn(3, 3, |i, j| {
        if i == j {
            0.05 * (i + 1) as f64
        } else if i + j == 1 {
            0.01
        } else {
            0.0
        }
    })));
}

/// The two ways to the compliance give one G and one y_F: Rayleigh damping takes the diagonal
/// path (every harmonic's modal sums as one product, `ModalDynamics::diagonal_columns`), and
/// the same damping with its modal off-diagonal perturbed by 1e-10 of its largest entry takes
/// the general one (a dense LU of Z_n per harmonic). Near resonance (W = 1.1 sits between the
/// system's first two frequencies, 0.74 and 1.60 rad/s) the perturbation moves G by about
/// 1e-10 x the damping's amplification (~1e2): the two agree within 1e-7 of G's largest entry.
#[test]
fn the_diagonal_and_the_general_damping_paths_give_one_compliance() {
    let system = two_rows();
    let rayleigh = Damping::Rayleigh {
        alpha: 0.02,
        beta: 0.01,
    };
    let c = rayleigh.matrix(&system).unwrap();
    let perturbed = Mat::from_fn(3, 3, |i, j| {
        c[(i, j)] + if i != j { 1e-10 * c.norm_max() } else { 0.0 }
    });
    let nh = 6;
    let load = Load::fundamental(vec![0.1, 0.0, 0.3]);
    let diagonal = ModalDynamics::new(&system, &c, &load, nh).unwrap();
    let general = ModalDynamics::new(&system, &perturbed, &load, nh).unwrap();
    for w in [0.3, 1.1, 2.6] {
        let (a, b) = (
            diagonal.compliance(w).unwrap(),
            general.compliance(w).unwrap(),
        );
        let (ga, gb) = (a.dense(), b.dense());
        let scale = gb.norm_max();
        for i in 0..ga.nrows() {
            for j in 0..ga.ncols() {
                let d = (ga[(i, j)] - gb[(i, j)]).abs();
                assert!(d <= 1e-7 * scale, "W {w}, G[{i}, {j}]: {d:e} of {scale:e}");
            }
        }
        let y_scale = b.y_load.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(y_scale > 0.0);
        for (i, (ya, yb)) in a.y_load.iter().zip(&b.y_load).enumerate() {
            assert!((ya - yb).abs() <= 1e-7 * y_scale, "W {w}, y_F[{i}]");
        }
    }
}

/// The compliance written row by row (`compliance_rows_into`, what a Newton solve asks for:
/// the columns of the rows in contact) is the whole compliance on those columns, to the last
/// bit, on both damping paths; a move to another W leaves every row stale again on the
/// diagonal path (and reading a stale row panics rather than return G at the old W; the
/// general path writes every row at once); y_F is written whatever the rows.
#[test]
fn the_compliance_written_row_by_row_is_the_whole_compliance() {
    let system = two_rows();
    let load = Load::fundamental(vec![0.1, 0.0, 0.3]);
    let nh = 4;
    let t = 2 * nh + 1;
    for (damping, row_by_row) in [
        (
            Damping::Rayleigh {
                alpha: 0.02,
                beta: 0.01,
            },
            true,
        ),
        (
            Damping::Matrix(Mat::from_fn(3, 3, |i, j| if i == j { 0.05 } else { 0.01 })),
            false,
        ),
    ] {
        let c = damping.matrix(&system).unwrap();
        let dynamics = ModalDynamics::new(&system, &c, &load, nh).unwrap();
        let mut partial = nlmodes_forced::ContactCompliance::empty(2, t);
        for w in [0.3, 1.1, 2.6] {
            let whole = dynamics.compliance(w).unwrap();
            dynamics.compliance_rows_into(w, &[], &mut partial).unwrap();
            assert_eq!(partial.y_load, whole.y_load, "W {w}: y_F without rows");
            dynamics
                .compliance_rows_into(w, &[1], &mut partial)
                .unwrap();
            assert!(partial.written(1));
            // Forces on row 1 alone read only its columns.
            let lambda: Vec<f64> = (0..2 * t)
                .map(|i| if i >= t { (0.4 * i as f64).sin() } else { 0.0 })
                .collect();
            assert_eq!(partial.apply(&lambda), whole.apply(&lambda), "W {w}");
            dynamics
                .compliance_rows_into(w, &[0, 1], &mut partial)
                .unwrap();
            assert_eq!(partial.dense(), whole.dense(), "W {w}: both rows");
        }
        dynamics
            .compliance_rows_into(0.7, &[0], &mut partial)
            .unwrap();
        assert!(partial.written(0));
        assert_eq!(partial.written(1), !row_by_row);
        let read = std::panic::catch_unwind(|| partial.dense());
        assert_eq!(read.is_err(), row_by_row, "a stale row must not be read");
    }
}
