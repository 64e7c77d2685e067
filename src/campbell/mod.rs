//! The linear modes of the rotating blade over a speed range, for the Campbell diagram (issue
//! 23, item 5; docs/ROTATION.md, "Campbell diagram"), on the stiffness at speed of
//! [`crate::campbell::campbell_march::SpeedFamily`]: the glue between the march and the numerics of
//! `nlmodes_modal` ([`nlmodes_modal::ritz`], [`nlmodes_modal::gyroscopic`]).
//!
//! The eigenproblems (K(Omega), M) at every speed are solved by Rayleigh-Ritz on a multi-speed
//! basis ([`nlmodes_modal::RitzBasis`]): the lowest modes at three speeds of the range (first,
//! middle, last; [`BasisModes`], solved during the march with the factorization of the march's
//! analysis), M-orthonormalized. The Ritz values are exact at those speeds and upper bounds
//! everywhere; each Ritz pair's residual on the full model is reported at every speed, so the
//! accuracy is measured, not assumed. Three eigen-solves serve any number of speeds.

pub(crate) mod campbell_march;
pub(crate) mod campbell_parametric;
pub(crate) mod campbell_stage;

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_modal::{RitzBasis, RitzModes};
use sprs::CsMat;

use crate::campbell::campbell_march::{SpeedFamily, SpeedPoint};

/// The lowest modes at the basis speeds of the Ritz model ([`BasisModes::ritz_basis`]),
/// collected at those speeds of the march.
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

    /// The Ritz basis of the modes collected (every basis speed visited, in the order of the
    /// basis speeds), in the inner product of M (kg).
    pub fn ritz_basis(&self, m: &CsMat<f64>) -> Result<RitzBasis> {
        let blocks = (self.vectors.iter().zip(&self.speeds))
            .map(|(modes, omega)| {
                let modes = modes
                    .as_ref()
                    .with_context(|| format!("no modes at {omega:.3} rad/s"))?;
                Ok(modes.subcols(0, self.per_speed.min(modes.ncols())))
            })
            .collect::<Result<Vec<_>>>()?;
        RitzBasis::new(&blocks, m).context("the Ritz basis of the Campbell diagram")
    }
}

/// The frequencies (Hz, ascending) of the `n` lowest of `modes` (Ritz pairs on `ritz` at
/// `omega`, rad/s) with the Coriolis matrix G of the family's model at `omega` (kg/s,
/// docs/ROTATION.md "Physics") projected onto them, as CalculiX does for a rotating structure
/// ([`nlmodes_modal::projected_gyroscopic_frequencies`]).
pub fn coriolis_frequencies(
    family: &SpeedFamily<'_>,
    ritz: &RitzBasis,
    modes: &RitzModes,
    omega: f64,
    n: usize,
) -> Result<Vec<f64>> {
    let model = family.model();
    let g = model.dofs().try_restrict(&model.coriolis_matrix(omega)?)?;
    nlmodes_modal::projected_gyroscopic_frequencies(ritz, modes, &g, n)
        .with_context(|| format!("the Coriolis correction at {omega:.3} rad/s"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fe_model::FeModel;
    use nlmodes_fem::rotation::{RotatingModel, RotorAxis};
    use nlmodes_fem::Isotropic;

    fn beam() -> FeModel {
        crate::campbell::campbell_march::fixtures::beam([8, 1, 1])
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
            crate::rotation::rotation_mpi::FullSolver::default(),
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
        let ritz = basis_modes.ritz_basis(&family.m).unwrap();
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
}
