//! The Coriolis (gyroscopic) correction of a rotating structure's frequencies by projection
//! onto its real modes, as CalculiX reports it (docs/ROTATION.md, "Campbell diagram"): with X
//! the mass-normalized real modes of (K(Omega), M) (X^T M X = I, X^T K X = diag(w^2)) and G the
//! skew Coriolis matrix (kg/s; docs/ROTATION.md, "Physics": G^ab = 2 Omega int rho N_a N_b dV
//! [a]x), the modal equations q'' + X^T G X q' + diag(w^2) q = 0 give, for q = y e^(lambda t),
//!
//! ```text
//! (lambda^2 I + lambda g + diag(w^2)) y = 0,   g = X^T G X (1/s, skew),
//! ```
//!
//! solved as the 2n x 2n companion matrix [[0, I], [-diag(w^2), -g]]: lambda = +-i w_gyro
//! (undamped and gyroscopic with K > 0, the system is stable: every lambda is imaginary). g is
//! skew, so the shift of a frequency is of second order in g, of order (g_ij)^2 / (w_i^2 -
//! w_j^2): it matters where two modes close in frequency couple through G.

use faer::{Mat, MatRef};
use nlmodes_dense::eigenvalues_checked;
use sprs::CsMat;

use crate::error::ModalError;
use crate::ritz::{RitzBasis, RitzModes};

/// The frequencies (Hz, ascending) of (lambda^2 I + lambda g + diag(w2)) y = 0 (module docs)
/// for squared circular frequencies `w2` (rad^2/s^2, each finite and > 0) and a gyroscopic
/// matrix `g` (n x n, 1/s, skew for a Coriolis matrix: not checked), from the eigenvalues
/// +-i w of the companion matrix: the n of positive imaginary part.
pub fn gyroscopic_frequencies(w2: &[f64], g: MatRef<'_, f64>) -> Result<Vec<f64>, ModalError> {
    check_gyroscopic_input(w2, g)?;
    let n = w2.len();
    let mut a = Mat::<f64>::zeros(2 * n, 2 * n);
    for i in 0..n {
        a[(i, n + i)] = 1.0;
        a[(n + i, i)] = -w2[i];
        for j in 0..n {
            a[(n + i, n + j)] = -g[(i, j)];
        }
    }
    let what = "the gyroscopic companion matrix";
    let values = eigenvalues_checked(a.as_ref(), what).map_err(|e| ModalError::DenseEigen {
        what: e.to_string(),
    })?;
    let mut f: Vec<f64> = values
        .iter()
        .filter(|z| z.im > 0.0)
        .map(|z| z.im / (2.0 * std::f64::consts::PI))
        .collect();
    f.sort_by(f64::total_cmp);
    if f.len() != n {
        return Err(ModalError::DenseEigen {
            what: format!("{what} ({} oscillating pairs for {n} modes)", f.len()),
        });
    }
    Ok(f)
}

/// `w2` positive and finite, `g` n x n and finite.
fn check_gyroscopic_input(w2: &[f64], g: MatRef<'_, f64>) -> Result<(), ModalError> {
    let n = w2.len();
    for (what, found) in [("rows", g.nrows()), ("columns", g.ncols())] {
        if found != n {
            return Err(ModalError::DimensionMismatch {
                what: format!("{what} of the gyroscopic matrix against the number of modes"),
                expected: n,
                found,
            });
        }
    }
    if let Some((k, v)) = w2
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && **v > 0.0))
    {
        return Err(ModalError::InvalidArgument(format!(
            "squared circular frequency {k} of the gyroscopic problem is {v:e} rad^2/s^2; \
             expected finite and > 0 (a mode at or past divergence has no oscillation)"
        )));
    }
    for j in 0..n {
        for i in 0..n {
            if !g[(i, j)].is_finite() {
                return Err(ModalError::NotFinite {
                    what: "the gyroscopic matrix".to_string(),
                    row: i,
                    col: j,
                    value: g[(i, j)],
                });
            }
        }
    }
    Ok(())
}

/// The frequencies (Hz, ascending) of the lowest `n` of `modes` (Ritz pairs of one stiffness
/// on `basis`) with the Coriolis matrix `g` (kg/s, sparse, on the basis' DOFs) projected onto
/// them: g_r = X^T G X with X = Q Y the mass-normalized shapes ([`gyroscopic_frequencies`]).
pub fn projected_gyroscopic_frequencies(
    basis: &RitzBasis,
    modes: &RitzModes,
    g: &CsMat<f64>,
    n: usize,
) -> Result<Vec<f64>, ModalError> {
    let n = n.min(modes.eigenvalues.len());
    let x = basis.shapes(modes, n);
    let mut g_x = Mat::<f64>::zeros(g.rows(), n);
    let mut y = vec![0.0; g.rows()];
    for j in 0..n {
        let xj: Vec<f64> = x.col(j).iter().copied().collect();
        nlmodes_sparse::ops::spmv(g, &xj, &mut y)?;
        for (i, v) in y.iter().enumerate() {
            g_x[(i, j)] = *v;
        }
    }
    let g_r = x.transpose() * &g_x;
    gyroscopic_frequencies(&modes.eigenvalues[..n], g_r.as_ref())
}

#[cfg(test)]
mod tests {
    use super::*;
    use sprs::TriMat;
    use std::f64::consts::PI;

    /// A point mass m on an isotropic spring k in the plane normal to the spin axis, in the
    /// frame turning at Omega: M = m I, K(Omega) = (k - m Omega^2) I (spin softening),
    /// G = 2 m Omega [[0, -1], [1, 0]]. Its whirl frequencies seen in the turning frame are
    /// exactly w0 - Omega (forward whirl) and w0 + Omega (backward), w0 = sqrt(k / m): the
    /// determinant (w0^2 - Omega^2 - w^2)^2 - 4 Omega^2 w^2 = 0. Through the Ritz model of the
    /// full (sparse) matrices, to 1e-12.
    #[test]
    fn a_point_mass_on_an_isotropic_spring_whirls_at_w0_plus_minus_omega() {
        let (m, k) = (2.5_f64, 4.0e4_f64);
        let w0 = (k / m).sqrt();
        for omega in [0.0, 10.0, 60.0, 0.9 * w0] {
            let diag = |v: f64| {
                let mut t = TriMat::new((2, 2));
                t.add_triplet(0, 0, v);
                t.add_triplet(1, 1, v);
                t.to_csc()
            };
            let (mass, stiffness) = (diag(m), diag(k - m * omega * omega));
            let mut g = TriMat::new((2, 2));
            g.add_triplet(0, 1, -2.0 * m * omega);
            g.add_triplet(1, 0, 2.0 * m * omega);
            let identity = Mat::<f64>::identity(2, 2);
            let basis = RitzBasis::new(&[identity.as_ref()], &mass).unwrap();
            let modes = basis.solve(&stiffness, 2).unwrap();
            let f = projected_gyroscopic_frequencies(&basis, &modes, &g.to_csc(), 2).unwrap();
            let exact = [(w0 - omega) / (2.0 * PI), (w0 + omega) / (2.0 * PI)];
            for (got, want) in f.iter().zip(exact) {
                assert!(
                    (got - want).abs() < 1e-12 * w0,
                    "Omega {omega}: {got} vs {want}"
                );
            }
        }
    }

    /// Two modes w1, w2 coupled by the skew g = [[0, c], [-c, 0]]: lambda = i w solves
    /// w^4 - (w1^2 + w2^2 + c^2) w^2 + w1^2 w2^2 = 0 (the determinant of the 2 x 2 quadratic
    /// pencil), closed form to 1e-12; the coupling splits the pair apart; with c = 0 the
    /// frequencies are unchanged.
    #[test]
    fn two_modes_coupled_by_a_gyroscopic_term_solve_the_quartic() {
        let (w1, w2, c) = (100.0_f64, 130.0_f64, 25.0_f64);
        let g = Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 1) => c,
            (1, 0) => -c,
            _ => 0.0,
        });
        let f = gyroscopic_frequencies(&[w1 * w1, w2 * w2], g.as_ref()).unwrap();
        let b = w1 * w1 + w2 * w2 + c * c;
        let disc = (b * b - 4.0 * w1 * w1 * w2 * w2).sqrt();
        let exact = [((b - disc) / 2.0).sqrt(), ((b + disc) / 2.0).sqrt()];
        for (fi, wi) in f.iter().zip(exact) {
            let hz = wi / (2.0 * PI);
            assert!((fi - hz).abs() < 1e-12 * hz, "{fi} vs {hz}");
        }
        assert!(exact[0] < w1 && exact[1] > w2);
        let zero = Mat::<f64>::zeros(2, 2);
        let f0 = gyroscopic_frequencies(&[w1 * w1, w2 * w2], zero.as_ref()).unwrap();
        assert!((f0[0] - w1 / (2.0 * PI)).abs() < 1e-12 * w1);
        assert!((f0[1] - w2 / (2.0 * PI)).abs() < 1e-12 * w2);
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let g = Mat::<f64>::zeros(2, 2);
        assert!(matches!(
            gyroscopic_frequencies(&[1.0, -4.0], g.as_ref()),
            Err(ModalError::InvalidArgument(_))
        ));
        assert!(matches!(
            gyroscopic_frequencies(&[1.0, 4.0, 9.0], g.as_ref()),
            Err(ModalError::DimensionMismatch { .. })
        ));
        let nan = Mat::from_fn(2, 2, |i, j| if i == j { 0.0 } else { f64::NAN });
        assert!(matches!(
            gyroscopic_frequencies(&[1.0, 4.0], nan.as_ref()),
            Err(ModalError::NotFinite { .. })
        ));
    }
}
