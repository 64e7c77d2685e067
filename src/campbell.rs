//! The linear modes of the rotating blade over a speed range, for the Campbell diagram (issue
//! 23, item 5; docs/ROTATION.md, "Campbell diagram").
//!
//! The prestress of the diagram is linear (ANSYS' and Nastran's default for Campbell
//! diagrams): the static displacement u(Omega) = Omega^2 u_1 with K_e u_1 = f_c(X; 1 rad/s), so
//! that the stiffness at speed is exactly a polynomial in Omega^2,
//! K(Omega) = K_e + Omega^2 K_1, K_1 = K_sigma(u_1) - M_spin ([`SpeedFamily`]). The stage
//! compares it with the geometrically nonlinear prestress at the operating speed.
//!
//! The eigenproblems (K(Omega), M) at every speed are solved by Rayleigh-Ritz on a multi-speed
//! basis ([`RitzCampbell`]): the lowest modes at three speeds of the range (first, middle,
//! last), M-orthonormalized. The Ritz values are exact at those speeds and upper bounds
//! everywhere; each Ritz pair's residual ||K(Omega) x - lambda M x|| / (lambda ||M x||) is
//! computed on the full model and reported at every speed, so the accuracy is measured, not
//! assumed. Three factorizations serve any number of speeds.

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_fem::rotation::{RotatingModel, RotorAxis};
use nlmodes_fem::Isotropic;
use sprs::CsMat;

use crate::fe_model::FeModel;
use crate::prestress::MetisCholesky;

/// K(Omega) = K_e + Omega^2 K_1 on the free DOFs (N/m), and M (kg).
pub struct SpeedFamily {
    pub k_e: CsMat<f64>,
    pub k_1: CsMat<f64>,
    pub m: CsMat<f64>,
}

impl SpeedFamily {
    /// The family of the clamped model `fe` turning about `axis`.
    pub fn of(fe: &FeModel, material: &Isotropic, axis: &RotorAxis) -> Result<Self> {
        let model = RotatingModel::new(&fe.mesh, *material, *axis, fe.dofs.clone())
            .context("the rotating model")?;
        let k_e = model.linear_operator(0.0)?;
        // The linear static state at 1 rad/s without spin softening in the operator: exactly
        // Omega^2 times it at Omega (the load is Omega^2 M_spin (X - p)).
        let unit = model
            .solve_linearized(1.0, false, &mut MetisCholesky)
            .context("the linear centrifugal static solve")?;
        let k_at_one = model.stiffness_at_speed(&unit)?;
        let k_1 = &k_at_one - &k_e;
        Ok(Self {
            k_e,
            k_1,
            m: fe.m.clone(),
        })
    }

    /// K(Omega), N/m.
    pub fn at(&self, omega: f64) -> CsMat<f64> {
        let w2 = omega * omega;
        &self.k_e + &self.k_1.map(|v| w2 * v)
    }
}

/// The Ritz model on a multi-speed basis: V T, with V the stacked modes and T making the basis
/// M-orthonormal; the projected K_e and K_1 and the full-model products kept for residuals.
pub struct RitzCampbell {
    /// T^T V^T K_e V T and T^T V^T K_1 V T (r x r); the projected M is the identity.
    ke_r: Mat<f64>,
    k1_r: Mat<f64>,
    /// K_e V T, K_1 V T, M V T (d x r).
    ke_v: Mat<f64>,
    k1_v: Mat<f64>,
    m_v: Mat<f64>,
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

/// y = A x for a sparse A and the columns of a dense x.
fn sparse_times(a: &CsMat<f64>, x: &Mat<f64>) -> Mat<f64> {
    let mut y = Mat::<f64>::zeros(a.rows(), x.ncols());
    for j in 0..x.ncols() {
        for (&v, (r, c)) in a.iter() {
            y[(r, j)] += v * x[(c, j)];
        }
    }
    y
}

impl RitzCampbell {
    /// The basis of the lowest `per_speed` modes at each of `speeds` (rad/s).
    pub fn new(family: &SpeedFamily, speeds: &[f64], per_speed: usize) -> Result<Self> {
        let d = family.k_e.rows();
        let mut v = Mat::<f64>::zeros(d, speeds.len() * per_speed);
        for (s, &omega) in speeds.iter().enumerate() {
            let k = family.at(omega);
            let factor = nlmodes_modal::SparseCholesky::new(&k)
                .with_context(|| format!("factorizing K(Omega) at {omega:.3} rad/s"))?;
            let modes = crate::ui::with_solve_spinner("campbell", |opts| {
                nlmodes_modal::eigs_shift_invert_factored(
                    &k, &family.m, 0.0, &factor, per_speed, opts,
                )
            })
            .with_context(|| format!("the modes at {omega:.3} rad/s"))?;
            for j in 0..per_speed {
                for i in 0..d {
                    v[(i, s * per_speed + j)] = modes.vectors[(i, j)];
                }
            }
        }
        let (vt, m_v) = m_orthonormal(&v, &family.m);
        let ke_v = sparse_times(&family.k_e, &vt);
        let k1_v = sparse_times(&family.k_1, &vt);
        let sym = |a: Mat<f64>| {
            let at = a.transpose().to_owned();
            (&a + &at) * faer::Scale(0.5)
        };
        Ok(Self {
            ke_r: sym(vt.transpose() * &ke_v),
            k1_r: sym(vt.transpose() * &k1_v),
            ke_v,
            k1_v,
            m_v,
        })
    }

    /// The lowest `n` modes at `omega` (rad/s).
    pub fn solve(&self, omega: f64, n: usize) -> Result<SpeedModes> {
        let w2 = omega * omega;
        let r = self.ke_r.nrows();
        let k = &self.ke_r + &self.k1_r * faer::Scale(w2);
        let identity = Mat::<f64>::identity(r, r);
        let (values, vectors) =
            nlmodes_modal::dense_generalized_eigen(k.as_ref(), identity.as_ref())?;
        let n = n.min(r);
        let coordinates = vectors.subcols(0, n).to_owned();
        let residuals = (0..n)
            .map(|j| {
                let y = coordinates.col(j);
                let kx = &self.ke_v * y + &self.k1_v * y * faer::Scale(w2);
                let mx = &self.m_v * y;
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
        let mut y = vec![0.0; d];
        for (&a, (r, c)) in m.iter() {
            y[r] += a * x[c];
        }
        y
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
    use nlmodes_fem::{assemble, fixed_dofs, DofMap, TetKind};

    /// A clamped TET10 beam, 1 m x 4 cm x 4 cm (steel), 8 cells along.
    fn beam() -> FeModel {
        let mesh = nlmodes_fem::generate::box_mesh([1.0, 0.04, 0.04], [8, 1, 1], TetKind::Tet10)
            .expect("mesh");
        let material = Isotropic::new(200e9, 0.3, 7800.0).expect("material");
        let clamp = vec!["xmin".to_string()];
        let fixed = fixed_dofs(&mesh, &clamp).expect("fixed");
        let dofs = DofMap::new(mesh.n_nodes(), &fixed).expect("dofs");
        let (k, m) = assemble(&mesh, &material).expect("assembly");
        let (k, m) = (
            dofs.try_restrict(&k).unwrap(),
            dofs.try_restrict(&m).unwrap(),
        );
        FeModel {
            mesh,
            dofs,
            k,
            m,
            clamp,
        }
    }

    /// The Ritz values on a basis at 0, 60 and 120 rad/s against a direct ARPACK shift-invert
    /// solve of the full (K(Omega), M) at speeds inside and outside the basis (relative
    /// residuals 1e-9, so eigenvalues to about 1e-12: the error of a symmetric eigenvalue is
    /// of the order of the residual squared): equal to 1e-9 at the basis speeds, within 1e-6
    /// between them (the Ritz error is second order in the basis' angle to the true mode,
    /// which the two neighbouring speeds pin down), never below (Rayleigh-Ritz bounds from
    /// above). K(0) is the model's K. (A dense solver is no reference here: its lowest
    /// eigenvalues of this 10-decade spectrum are good to 2e-9 only.)
    #[test]
    fn ritz_campbell_matches_direct_eigenvalues_between_the_basis_speeds() {
        let fe = beam();
        let material = Isotropic::new(200e9, 0.3, 7800.0).unwrap();
        let axis = RotorAxis::new([0.0, 0.02, 0.02], [0.0, 0.0, 1.0]).unwrap();
        let family = SpeedFamily::of(&fe, &material, &axis).unwrap();
        let k0_err = (&family.at(0.0) - &fe.k)
            .data()
            .iter()
            .fold(0.0_f64, |a, v| a.max(v.abs()));
        let k_max = fe.k.data().iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        assert!(k0_err <= 1e-12 * k_max, "K(0) differs from K by {k0_err:e}");
        let ritz = RitzCampbell::new(&family, &[0.0, 60.0, 120.0], 8).unwrap();
        for (omega, tol) in [
            (0.0, 1e-9),
            (30.0, 1e-6),
            (60.0, 1e-9),
            (95.0, 1e-6),
            (120.0, 1e-9),
        ] {
            let opts = nlmodes_modal::EigenOptions::default();
            let exact =
                nlmodes_modal::eigs_shift_invert(&family.at(omega), &family.m, 6, 0.0, &opts)
                    .unwrap()
                    .eigenvalues;
            let modes = ritz.solve(omega, 4).unwrap();
            for (j, &exact) in exact.iter().enumerate().take(4) {
                let rel = (modes.eigenvalues[j] - exact).abs() / exact;
                println!(
                    "Omega {omega:5.1} mode {j}: Ritz {:.10e} direct {:.10e} rel {rel:.1e} residual {:.1e}",
                    modes.eigenvalues[j], exact, modes.residuals[j]
                );
                assert!(
                    rel < tol,
                    "Omega {omega}, mode {j}: relative error {rel:e} > {tol:e}"
                );
                // Rayleigh-Ritz from above: never below the exact value (to round-off).
                assert!(modes.eigenvalues[j] >= exact * (1.0 - 1e-9));
            }
        }
    }
}
