//! A rotating structure: mesh, material, rotor axis and Dirichlet conditions, with the global
//! rotation terms (3n DOFs, [`crate::assemble`]'s numbering and pattern) and the free-DOF
//! residual and tangent of the static centrifugal equilibrium.

use std::sync::OnceLock;

use rayon::prelude::*;
use sprs::{CsMat, TriMat};

use crate::dofs::DofMap;
use crate::element::{element_matrices, TabulatedRule};
use crate::error::FemError;
use crate::material::Isotropic;
use crate::mesh::Mesh;
use crate::rotation::axis::{mat_vec, Mat3, RotorAxis};
use crate::rotation::centrifugal::{
    centrifugal_load_element, coriolis_element, scalar_mass, spin_softening_element,
};
use crate::rotation::element_ref::ElementRef;
use crate::rotation::error::RotationError;
use crate::rotation::global::{assemble_global, gather, BlockPattern};
use crate::rotation::points::nonlinear_rule;
use crate::rotation::points::PointGeometry;
use crate::rotation::stress_stiffness::stress_stiffness_with_rule;
use crate::rotation::total_lagrangian::internal_force_and_tangent_with_rule;

/// A stress field for [`RotatingModel::stress_stiffness`]: S (Pa) at a quadrature point of
/// element `e` (0-based mesh index).
pub type StressField<'f> = dyn Fn(usize, &PointGeometry) -> Mat3 + Sync + 'f;

/// The free-DOF residual of the static centrifugal equilibrium and its derivative.
#[derive(Clone, Debug)]
pub struct ResidualAndTangent {
    /// r = f_int(u) - f_c(u) on the free DOFs (N).
    pub residual: Vec<f64>,
    /// The centrifugal load f_c(u) on the free DOFs (N).
    pub load: Vec<f64>,
    /// dr/du = K_T(u) - Omega^2 M_spin on the free DOFs (N/m), exactly symmetric.
    pub tangent: CsMat<f64>,
}

/// A rotating structure (SI units: m, Pa, kg/m^3, rad/s).
#[derive(Clone, Debug)]
pub struct RotatingModel<'m> {
    mesh: &'m Mesh,
    material: Isotropic,
    axis: RotorAxis,
    dofs: DofMap,
    pattern: BlockPattern,
    /// The rule of the total-Lagrangian terms and of the stress stiffness of each element
    /// ([`nonlinear_rule`]: a curved TET10's is chosen by a convergence test, done once here
    /// rather than at every assembly).
    rules: Vec<&'static TabulatedRule>,
    /// The nodal consistent mass m_ab = int rho N_a N_b dV (kg, nodes x nodes), built on the
    /// first centrifugal load ([`RotatingModel::centrifugal_load`]).
    nodal_mass: OnceLock<CsMat<f64>>,
}

impl<'m> RotatingModel<'m> {
    /// Validates the inputs (mesh, material, a DOF map of the mesh's nodes, every node in an
    /// element) and builds the matrix pattern.
    pub fn new(
        mesh: &'m Mesh,
        material: Isotropic,
        axis: RotorAxis,
        dofs: DofMap,
    ) -> Result<Self, RotationError> {
        material.validate()?;
        mesh.validate()?;
        if dofs.n_nodes() != mesh.n_nodes() {
            return Err(FemError::DimensionMismatch {
                what: "DOF map nodes",
                found: dofs.n_nodes(),
                expected: mesh.n_nodes(),
            }
            .into());
        }
        let mut used = vec![false; mesh.n_nodes()];
        for &v in &mesh.connectivity {
            used[v] = true;
        }
        if let Some(v) = used.iter().position(|&u| !u) {
            return Err(FemError::InvalidMesh(format!(
                "node {v} (0-based) belongs to no element: its rows would be empty"
            ))
            .into());
        }
        let rules = (0..mesh.n_elements())
            .into_par_iter()
            .map(|e| {
                let mut coords = [[0.0; 3]; 10];
                mesh.element_coords_into(e, &mut coords);
                nonlinear_rule(mesh.kind, &coords[..mesh.kind.nodes_per_element()])
            })
            .collect();
        Ok(RotatingModel {
            mesh,
            material,
            axis,
            dofs,
            pattern: BlockPattern::new(mesh),
            rules,
            nodal_mass: OnceLock::new(),
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh {
        self.mesh
    }
    /// The material.
    pub fn material(&self) -> &Isotropic {
        &self.material
    }
    /// The rotor axis.
    pub fn axis(&self) -> &RotorAxis {
        &self.axis
    }
    /// The DOF map (free DOFs of the static solve and of K(Omega)).
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    fn check_global(&self, u: &[f64]) -> Result<(), FemError> {
        if u.len() != self.dofs.n_global() {
            return Err(FemError::DimensionMismatch {
                what: "global displacement",
                found: u.len(),
                expected: self.dofs.n_global(),
            });
        }
        Ok(())
    }

    pub(crate) fn matrix(
        &self,
        routine: &crate::rotation::global::ElementRoutine<'_>,
    ) -> Result<CsMat<f64>, FemError> {
        let (_, m) = assemble_global(self.mesh, &self.pattern, false, true, routine)?;
        m.ok_or_else(|| FemError::InvalidMesh("no matrix assembled".to_string()))
    }

    /// Global spin-softening matrix M_spin (kg, 3n x 3n).
    pub fn spin_softening_matrix(&self) -> Result<CsMat<f64>, RotationError> {
        let (rho, axis) = (self.material.density, self.axis);
        Ok(self.matrix(&|_, el, _, m| spin_softening_element(el, rho, &axis, m))?)
    }

    /// Global Coriolis matrix G (kg/s, 3n x 3n, skew-symmetric) at speed `omega` (rad/s).
    pub fn coriolis_matrix(&self, omega: f64) -> Result<CsMat<f64>, RotationError> {
        let (rho, axis) = (self.material.density, self.axis);
        Ok(self.matrix(&|_, el, _, m| coriolis_element(el, rho, &axis, omega, m))?)
    }

    /// Global linear stiffness K_e (N/m, 3n x 3n): [`crate::assemble`]'s element matrices.
    pub fn linear_stiffness(&self) -> Result<CsMat<f64>, RotationError> {
        let mat = self.material;
        Ok(self.matrix(&|_, el, _, k| {
            let mut m = [0.0; 900];
            element_matrices(el.kind, el.coords, &mat, el.tag, k, &mut m)
        })?)
    }

    /// Global centrifugal load f_c (N, length 3n) at speed `omega` (rad/s) and global
    /// displacement `u` (m, length 3n; zeros for the reference load): for isoparametric
    /// elements f_a = Omega^2 P sum_b m_ab (X_b - p + u_b) exactly (`centrifugal` module
    /// docs), one product with the nodal mass instead of a quadrature over every element at
    /// each residual of the static solve (the quadrature, [`Self::centrifugal_load_by_quadrature`],
    /// is the check: equal to round-off).
    pub fn centrifugal_load(&self, omega: f64, u: &[f64]) -> Result<Vec<f64>, RotationError> {
        self.check_global(u)?;
        let mass = self.nodal_mass();
        let (p, proj) = (self.axis.point(), self.axis.projector());
        // Positions relative to p, so that a node far from the axis point keeps its digits.
        let arms: Vec<[f64; 3]> = (self.mesh.nodes.iter().enumerate())
            .map(|(b, x)| std::array::from_fn(|d| x[d] - p[d] + u[3 * b + d]))
            .collect();
        let mut load = vec![0.0; u.len()];
        let (indptr, indices, values) = (mass.indptr(), mass.indices(), mass.data());
        load.par_chunks_mut(3).enumerate().for_each(|(a, f)| {
            let mut w = [0.0; 3];
            for k in indptr.outer_inds_sz(a) {
                (0..3).for_each(|d| w[d] += values[k] * arms[indices[k]][d]);
            }
            let arm = mat_vec(&proj, &w);
            (0..3).for_each(|d| f[d] = omega * omega * arm[d]);
        });
        Ok(load)
    }

    /// [`Self::centrifugal_load`] by quadrature over every element (`centrifugal_load_element`):
    /// the check of the nodal-mass form.
    pub fn centrifugal_load_by_quadrature(
        &self,
        omega: f64,
        u: &[f64],
    ) -> Result<Vec<f64>, RotationError> {
        self.check_global(u)?;
        let (rho, axis, mesh) = (self.material.density, self.axis, self.mesh);
        let (v, _) = assemble_global(mesh, &self.pattern, true, false, &|e, el, f, _| {
            let mut u_e = [0.0; 30];
            gather(mesh, e, u, &mut u_e[..el.ndof()]);
            centrifugal_load_element(el, &u_e[..el.ndof()], rho, &axis, omega, f)
        })?;
        Ok(v.unwrap_or_default())
    }

    /// The nodal consistent mass (kg, nodes x nodes, CSR), assembled on first use.
    fn nodal_mass(&self) -> &CsMat<f64> {
        self.nodal_mass.get_or_init(|| {
            let (n, npe) = (self.mesh.n_nodes(), self.mesh.kind.nodes_per_element());
            let blocks: Vec<[f64; 100]> = (0..self.mesh.n_elements())
                .into_par_iter()
                .map(|e| {
                    let mut buf = [[0.0; 3]; 10];
                    scalar_mass(&self.element(e, &mut buf), self.material.density)
                })
                .collect();
            let mut tri = TriMat::with_capacity((n, n), blocks.len() * npe * npe);
            for (e, m) in blocks.iter().enumerate() {
                let nodes = self.mesh.element(e);
                for (a, &na) in nodes.iter().enumerate() {
                    for (b, &nb) in nodes.iter().enumerate() {
                        tri.add_triplet(na, nb, m[a * npe + b]);
                    }
                }
            }
            tri.to_csr()
        })
    }

    /// Global total-Lagrangian internal force (N) and tangent minus Omega^2 M_spin (N/m) at the
    /// global displacement `u` (m, length 3n) and speed `omega` (rad/s; 0 gives K_T(u)).
    pub fn internal_force_and_tangent(
        &self,
        omega: f64,
        u: &[f64],
    ) -> Result<(Vec<f64>, CsMat<f64>), RotationError> {
        match self.internal_force_with(omega, u, true)? {
            (v, Some(m)) => Ok((v, m)),
            _ => Err(FemError::InvalidMesh("nothing assembled".to_string()).into()),
        }
    }

    /// Global total-Lagrangian internal force (N) at the global displacement `u` (m, length
    /// 3n), without the tangent (a chord step's evaluation: several times cheaper).
    pub fn internal_force(&self, u: &[f64]) -> Result<Vec<f64>, RotationError> {
        Ok(self.internal_force_with(0.0, u, false)?.0)
    }

    /// The internal force and, `with_tangent`, K_T(u) - Omega^2 M_spin.
    fn internal_force_with(
        &self,
        omega: f64,
        u: &[f64],
        with_tangent: bool,
    ) -> Result<(Vec<f64>, Option<CsMat<f64>>), RotationError> {
        self.check_global(u)?;
        let (mesh, lame, rho, axis, rules) = (
            self.mesh,
            self.material.lame(),
            self.material.density,
            self.axis,
            &self.rules,
        );
        let (v, m) = assemble_global(mesh, &self.pattern, true, with_tangent, &|e, el, f, k| {
            let n = el.ndof();
            let mut u_e = [0.0; 30];
            gather(mesh, e, u, &mut u_e[..n]);
            let tangent = with_tangent.then_some(&mut *k);
            internal_force_and_tangent_with_rule(el, rules[e], &u_e[..n], lame, f, tangent)?;
            if with_tangent && omega != 0.0 {
                let mut spin = [0.0; 900];
                spin_softening_element(el, rho, &axis, &mut spin)?;
                for (kk, s) in k[..n * n].iter_mut().zip(&spin[..n * n]) {
                    *kk -= omega * omega * s;
                }
            }
            Ok(())
        })?;
        let v = v.ok_or_else(|| FemError::InvalidMesh("nothing assembled".to_string()))?;
        Ok((v, m))
    }

    /// Global stress stiffness K_sigma (N/m, 3n x 3n) of the stress field `stress`.
    pub fn stress_stiffness(&self, stress: &StressField<'_>) -> Result<CsMat<f64>, RotationError> {
        let rules = &self.rules;
        Ok(self.matrix(&|e, el, _, k| {
            stress_stiffness_with_rule(el, rules[e], |pt| stress(e, pt), k)
        })?)
    }

    /// Free-DOF residual r = f_int(u) - f_c(u), load f_c(u) and tangent K_T(u) - Omega^2 M_spin
    /// at speed `omega` (rad/s) and free displacement `u_free` (m).
    pub fn residual_and_tangent(
        &self,
        omega: f64,
        u_free: &[f64],
    ) -> Result<ResidualAndTangent, RotationError> {
        let u = self.dofs.try_expand(u_free)?;
        let (f_int, k) = self.internal_force_and_tangent(omega, &u)?;
        let (residual, load) = self.free_residual(omega, &u, &f_int)?;
        Ok(ResidualAndTangent {
            residual,
            load,
            tangent: self.dofs.try_restrict(&k)?,
        })
    }

    /// [`RotatingModel::residual_and_tangent`] without the tangent: (r, f_c) on the free DOFs
    /// (N), the same bits.
    pub fn residual(
        &self,
        omega: f64,
        u_free: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), RotationError> {
        let u = self.dofs.try_expand(u_free)?;
        let f_int = self.internal_force(&u)?;
        self.free_residual(omega, &u, &f_int)
    }

    /// (f_int - f_c(u), f_c(u)) on the free DOFs (N) from the global `u` (m) and f_int (N).
    fn free_residual(
        &self,
        omega: f64,
        u: &[f64],
        f_int: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), RotationError> {
        let load = self
            .dofs
            .try_restrict_vector(&self.centrifugal_load(omega, u)?)?;
        let f_int = self.dofs.try_restrict_vector(f_int)?;
        let residual = f_int.iter().zip(&load).map(|(a, b)| a - b).collect();
        Ok((residual, load))
    }

    /// The rule of the total-Lagrangian terms and the stress stiffness of element `e`.
    pub(crate) fn nonlinear_rule_of(&self, e: usize) -> &'static TabulatedRule {
        self.rules[e]
    }

    /// Element reference to element `e`'s coordinates in `buf`.
    pub(crate) fn element<'b>(&self, e: usize, buf: &'b mut [[f64; 3]; 10]) -> ElementRef<'b> {
        self.mesh.element_coords_into(e, buf);
        ElementRef {
            kind: self.mesh.kind,
            coords: &buf[..self.mesh.kind.nodes_per_element()],
            tag: self.mesh.element_tag(e),
        }
    }
}
