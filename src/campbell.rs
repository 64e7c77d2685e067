//! The linear modes of the rotating blade over a speed range, for the Campbell diagram (issue
//! 23, item 5; docs/ROTATION.md, "Campbell diagram"), on the stiffness at speed of
//! [`crate::campbell_march::SpeedFamily`].
//!
//! The eigenproblems (K(Omega), M) at every speed are solved by Rayleigh-Ritz on a multi-speed
//! basis ([`RitzCampbell`]): the lowest modes at three speeds of the range (first, middle,
//! last; [`BasisModes`], solved during the march with the factorization of the march's
//! analysis), M-orthonormalized. The Ritz values are exact at those speeds and upper bounds
//! everywhere; each Ritz pair's residual ||K(Omega) x - lambda M x|| / (lambda ||M x||) is
//! computed on the full model with the true K(Omega) and reported at every speed, so the
//! accuracy is measured, not assumed. Three eigen-solves serve any number of speeds.

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_modal::sparse_ops::spmm_symmetric;
use sprs::CsMat;

use crate::campbell_march::{SpeedFamily, SpeedPoint};

/// The lowest modes at the basis speeds of a [`RitzCampbell`], collected at those speeds of
/// the march.
pub struct BasisModes {
    /// The basis speeds, rad/s.
    speeds: Vec<f64>,
    per_speed: usize,
    /// The modes (n x per_speed) at each basis speed met so far.
    vectors: Vec<Option<Mat<f64>>>,
}

impl BasisModes {
    /// The modes collected so far (n x per_speed each), in the order of the basis speeds.
    pub fn modes(&self) -> impl Iterator<Item = &Mat<f64>> {
        self.vectors.iter().flatten()
    }

    /// The lowest `per_speed` modes at each of `speeds` (rad/s, speeds of the march).
    pub fn new(speeds: &[f64], per_speed: usize) -> Self {
        Self {
            speeds: speeds.to_vec(),
            per_speed,
            vectors: vec![None; speeds.len()],
        }
    }

    /// At a speed of the march: the modes of (K(Omega), M) if it is a basis speed (shift-invert
    /// at 0 on the factor of K(Omega), the march's analysis reused; over the ranks under
    /// mpirun).
    pub fn visit(&mut self, point: &mut SpeedPoint<'_>, m: &CsMat<f64>) -> Result<()> {
        let omega = point.omega;
        let Some(s) = self.speeds.iter().position(|&b| b == omega) else {
            return Ok(());
        };
        let modes = point
            .solver
            .lowest_modes(point.stiffness, m, self.per_speed, "campbell")
            .with_context(|| format!("the modes of K(Omega) at {omega:.3} rad/s"))?;
        self.vectors[s] = Some(modes.vectors);
        Ok(())
    }
}

/// The Ritz model on a multi-speed basis: Q, M-orthonormal, spanning the lowest modes at a few
/// speeds, and M Q.
pub struct RitzCampbell {
    q: Mat<f64>,
    m_q: Mat<f64>,
}

/// The modes at one speed.
pub struct SpeedModes {
    /// omega^2, rad^2/s^2, ascending.
    pub eigenvalues: Vec<f64>,
    /// Ritz coordinates (r x n), orthonormal: the M-inner product of two modes is the dot
    /// product of their coordinates.
    pub coordinates: Mat<f64>,
    /// ||K(Omega) x - lambda M x|| / (lambda ||M x||) of each mode on the full model.
    pub residuals: Vec<f64>,
}

/// y = A x for an exactly symmetric sparse A (K(Omega) and M are, by construction) and the
/// columns of a dense x, in parallel over the rows. Row r sums A[r, c] x[c] in increasing c,
/// as the sequential scatter of A's columns ([`sparse_times`]) does: the same bits.
fn symmetric_times(a: &CsMat<f64>, x: &Mat<f64>) -> Mat<f64> {
    let mut y = Mat::<f64>::zeros(a.rows(), x.ncols());
    spmm_symmetric(a, x.as_ref(), y.as_mut());
    y
}

/// y = A x for a sparse A (any, e.g. the skew Coriolis matrix) and the columns of a dense x.
fn sparse_times(a: &CsMat<f64>, x: &Mat<f64>) -> Mat<f64> {
    let mut y = Mat::<f64>::zeros(a.rows(), x.ncols());
    for j in 0..x.ncols() {
        let (xj, yj) = (x.col(j), y.col_mut(j));
        let yj = yj
            .try_as_col_major_mut()
            .expect("a column of a Mat is contiguous");
        let yj = yj.as_slice_mut();
        for (&v, (r, c)) in a.iter() {
            yj[r] += v * xj[c];
        }
    }
    y
}

impl RitzCampbell {
    /// The basis of the modes collected in `basis` (every basis speed visited), M (kg).
    pub fn new(basis: &BasisModes, m: &CsMat<f64>) -> Result<Self> {
        let d = m.rows();
        let per_speed = basis.per_speed;
        let mut v = Mat::<f64>::zeros(d, basis.speeds.len() * per_speed);
        for (s, (modes, omega)) in basis.vectors.iter().zip(&basis.speeds).enumerate() {
            let modes = modes
                .as_ref()
                .with_context(|| format!("no modes at {omega:.3} rad/s"))?;
            for j in 0..per_speed {
                for i in 0..d {
                    v[(i, s * per_speed + j)] = modes[(i, j)];
                }
            }
        }
        let (q, m_q) = m_orthonormal(&v, m);
        Ok(Self { q, m_q })
    }

    /// The lowest `n` modes of (K, M) for the stiffness `k` at one speed (N/m).
    pub fn solve(&self, k: &CsMat<f64>, n: usize) -> Result<SpeedModes> {
        let k_q = symmetric_times(k, &self.q);
        let k_r = self.q.transpose() * &k_q;
        let k_r = (&k_r + k_r.transpose()) * faer::Scale(0.5);
        let r = k_r.nrows();
        let identity = Mat::<f64>::identity(r, r);
        let (values, vectors) =
            nlmodes_modal::dense_generalized_eigen(k_r.as_ref(), identity.as_ref())?;
        let n = n.min(r);
        let coordinates = vectors.subcols(0, n).to_owned();
        let residuals = (0..n)
            .map(|j| {
                let y = coordinates.col(j);
                let kx = &k_q * y;
                let mx = &self.m_q * y;
                let res = &kx - &mx * faer::Scale(values[j]);
                res.norm_l2() / (values[j].abs() * mx.norm_l2())
            })
            .collect();
        Ok(SpeedModes {
            eigenvalues: values[..n].to_vec(),
            coordinates,
            residuals,
        })
    }
}

/// The frequencies (Hz, ascending) of the `n` lowest modes at `omega` (rad/s) with the Coriolis
/// matrix G (DESIGN §9) added by projection onto them, as CalculiX does for a rotating
/// structure: with X the mass-normalized real modes (Ritz pairs of `modes`), the quadratic
/// eigenproblem (lambda^2 I + lambda X^T G X + diag(w^2)) y = 0, solved as its 2n x 2n
/// companion matrix; lambda = +-i w_gyro. X^T G X is skew, so the shift is of second order in
/// G: it matters where two modes are close in frequency and couple through it.
pub fn coriolis_frequencies(
    family: &SpeedFamily<'_>,
    ritz: &RitzCampbell,
    modes: &SpeedModes,
    omega: f64,
    n: usize,
) -> Result<Vec<f64>> {
    let model = family.model();
    let g = model.dofs().try_restrict(&model.coriolis_matrix(omega)?)?;
    let n = n.min(modes.eigenvalues.len());
    let x = &ritz.q * modes.coordinates.subcols(0, n);
    let g_r = x.transpose() * sparse_times(&g, &x);
    gyroscopic_frequencies(&modes.eigenvalues[..n], &g_r)
}

/// The frequencies (Hz, ascending) of (lambda^2 I + lambda g + diag(w2)) y = 0 for squared
/// circular frequencies `w2` (rad^2/s^2) and a skew gyroscopic matrix `g` (1/s), from the
/// eigenvalues +-i w of the companion matrix [[0, I], [-diag(w2), -g]].
fn gyroscopic_frequencies(w2: &[f64], g: &Mat<f64>) -> Result<Vec<f64>> {
    let n = w2.len();
    let mut a = Mat::<f64>::zeros(2 * n, 2 * n);
    for i in 0..n {
        a[(i, n + i)] = 1.0;
        a[(n + i, i)] = -w2[i];
        for j in 0..n {
            a[(n + i, n + j)] = -g[(i, j)];
        }
    }
    let values = a
        .eigenvalues()
        .map_err(|e| anyhow::anyhow!("eigenvalues of the gyroscopic companion matrix: {e:?}"))?;
    let mut f: Vec<f64> = values
        .iter()
        .filter(|z| z.im > 0.0)
        .map(|z| z.im / (2.0 * std::f64::consts::PI))
        .collect();
    f.sort_by(f64::total_cmp);
    anyhow::ensure!(
        f.len() == n,
        "the gyroscopic eigenproblem gave {} oscillating pairs for {n} modes",
        f.len()
    );
    Ok(f)
}

/// An M-orthonormal basis Q of the span of the columns of `v`, and M Q: modified Gram-Schmidt
/// in the M-inner product, each vector orthogonalized twice ("twice is enough", Parlett), a
/// vector dropped when less than 1e-8 of its M-norm is left (a mode repeated between basis
/// speeds). Orthogonalizing in the full space keeps the projected matrices as accurate as the
/// vectors: forming V^T M V and inverting its square root would lose the digits of its
/// condition number (1e8 for modes barely changed between two speeds).
fn m_orthonormal(v: &Mat<f64>, m: &CsMat<f64>) -> (Mat<f64>, Mat<f64>) {
    let d = v.nrows();
    let mut q: Vec<Vec<f64>> = Vec::new();
    let mut mq: Vec<Vec<f64>> = Vec::new();
    let m_times = |x: &[f64]| {
        let y = symmetric_times(m, &Mat::from_fn(d, 1, |i, _| x[i]));
        (0..d).map(|i| y[(i, 0)]).collect::<Vec<f64>>()
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    for j in 0..v.ncols() {
        let mut x: Vec<f64> = (0..d).map(|i| v[(i, j)]).collect();
        let original = dot(&x, &m_times(&x)).sqrt();
        for _pass in 0..2 {
            for (qi, mqi) in q.iter().zip(&mq) {
                let c = dot(mqi, &x);
                x.iter_mut().zip(qi).for_each(|(a, b)| *a -= c * b);
            }
        }
        let mx = m_times(&x);
        let norm = dot(&x, &mx).sqrt();
        if norm > 1e-8 * original {
            q.push(x.iter().map(|a| a / norm).collect());
            mq.push(mx.iter().map(|a| a / norm).collect());
        }
    }
    let as_mat = |cols: &[Vec<f64>]| Mat::from_fn(d, cols.len(), |i, k| cols[k][i]);
    (as_mat(&q), as_mat(&mq))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe_model::FeModel;
    use nlmodes_fem::rotation::{RotatingModel, RotorAxis};
    use nlmodes_fem::Isotropic;

    fn beam() -> FeModel {
        crate::campbell_march::fixtures::beam([8, 1, 1])
    }

    /// The stiffness at speed of the true static state at `omega` (rad/s), N/m.
    fn true_stiffness(fe: &FeModel, axis: &RotorAxis, nonlinear: bool, omega: f64) -> CsMat<f64> {
        let material = Isotropic::new(200e9, 0.3, 7800.0).unwrap();
        let model = RotatingModel::new(&fe.mesh, material, *axis, fe.dofs.clone()).unwrap();
        let state = if nonlinear {
            let options = nlmodes_fem::rotation::NewtonOptions {
                load_steps: 1,
                ..Default::default()
            };
            model.solve_nonlinear(
                omega,
                &options,
                &mut nlmodes_sparse::CholeskySolver::default(),
            )
        } else {
            model.solve_linearized(omega, false, &mut nlmodes_sparse::CholeskySolver::default())
        };
        model.stiffness_at_speed(&state.unwrap()).unwrap()
    }

    /// The Ritz values on a basis at 0, 60 and 120 rad/s against a direct ARPACK shift-invert
    /// solve of the full (K(Omega), M) of the true static state at speeds inside and outside
    /// the basis (relative residuals 1e-9, so eigenvalues to about 1e-12: the error of a
    /// symmetric eigenvalue is of the order of the residual squared), for both prestress
    /// kinematics: equal to 1e-9 at the basis speeds, within 1e-6 between them (the Ritz error
    /// is second order in the basis' angle to the true mode, which the two neighbouring speeds
    /// pin down), never below (Rayleigh-Ritz bounds from above). K(0) is the model's K. (A dense solver is no reference here: its lowest
    /// eigenvalues of this 10-decade spectrum are good to 2e-9 only.) Speeds up to 120 rad/s
    /// raise the first frequency by 7 %: the prestress matters at the tolerances.
    #[test]
    fn ritz_campbell_matches_direct_eigenvalues_between_the_basis_speeds() {
        for nonlinear in [false, true] {
            ritz_against_direct(nonlinear);
        }
    }

    fn ritz_against_direct(nonlinear: bool) {
        let fe = beam();
        let material = Isotropic::new(200e9, 0.3, 7800.0).unwrap();
        let axis = RotorAxis::new([0.0, 0.02, 0.02], [0.0, 0.0, 1.0]).unwrap();
        let basis = [0.0, 60.0, 120.0];
        let speeds = [0.0, 30.0, 60.0, 95.0, 120.0];
        let mut basis_modes = BasisModes::new(&basis, 8);
        let family = SpeedFamily::of(
            crate::rotation_mpi::FullSolver::default(),
            &fe,
            &material,
            &axis,
            nonlinear,
            (&speeds, &[]),
            &mut |mut p| basis_modes.visit(&mut p, &fe.m),
        )
        .unwrap();
        let k0_err = (&family.at(0.0).unwrap() - &fe.k)
            .data()
            .iter()
            .fold(0.0_f64, |a, v| a.max(v.abs()));
        let k_max = fe.k.data().iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        assert!(k0_err <= 1e-12 * k_max, "K(0) differs from K by {k0_err:e}");
        let ritz = RitzCampbell::new(&basis_modes, &family.m).unwrap();
        for (omega, tol) in [
            (0.0, 1e-9),
            (30.0, 1e-6),
            (60.0, 1e-9),
            (95.0, 1e-6),
            (120.0, 1e-9),
        ] {
            let opts = nlmodes_modal::EigenOptions::default();
            let k = true_stiffness(&fe, &axis, nonlinear, omega);
            let exact = nlmodes_modal::eigs_shift_invert(&k, &family.m, 6, 0.0, &opts)
                .unwrap()
                .eigenvalues;
            let modes = ritz.solve(&family.at(omega).unwrap(), 4).unwrap();
            for (j, &exact) in exact.iter().enumerate().take(4) {
                let rel = (modes.eigenvalues[j] - exact).abs() / exact;
                println!(
                    "nonlinear {nonlinear} Omega {omega:5.1} mode {j}: Ritz {:.10e} direct {:.10e} rel {rel:.1e} residual {:.1e}",
                    modes.eigenvalues[j], exact, modes.residuals[j]
                );
                assert!(
                    rel < tol,
                    "Omega {omega}, mode {j}: relative error {rel:e} > {tol:e}"
                );
                assert!(modes.eigenvalues[j] >= exact * (1.0 - tol));
            }
        }
    }

    /// Two modes w1, w2 coupled by the skew g = [[0, c], [-c, 0]]: lambda = i w solves
    /// w^4 - (w1^2 + w2^2 + c^2) w^2 + w1^2 w2^2 = 0 (the determinant of the 2 x 2 quadratic
    /// pencil), closed form to 1e-12; with c = 0 the frequencies are unchanged.
    #[test]
    fn gyroscopic_frequencies_solve_the_two_mode_quartic() {
        let (w1, w2, c) = (100.0_f64, 130.0_f64, 25.0_f64);
        let g = Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 1) => c,
            (1, 0) => -c,
            _ => 0.0,
        });
        let f = gyroscopic_frequencies(&[w1 * w1, w2 * w2], &g).unwrap();
        let b = w1 * w1 + w2 * w2 + c * c;
        let disc = (b * b - 4.0 * w1 * w1 * w2 * w2).sqrt();
        let exact = [((b - disc) / 2.0).sqrt(), ((b + disc) / 2.0).sqrt()];
        for (fi, wi) in f.iter().zip(exact) {
            let hz = wi / (2.0 * std::f64::consts::PI);
            assert!((fi - hz).abs() < 1e-12 * hz, "{fi} vs {hz}");
        }
        assert!(
            exact[0] < w1 && exact[1] > w2,
            "the coupling splits the pair apart"
        );
        let zero = Mat::<f64>::zeros(2, 2);
        let f0 = gyroscopic_frequencies(&[w1 * w1, w2 * w2], &zero).unwrap();
        assert!((f0[0] - w1 / (2.0 * std::f64::consts::PI)).abs() < 1e-12 * w1);
    }
}
