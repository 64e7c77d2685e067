//! Outputs of a static centrifugal state: stress (Cauchy for the nonlinear solve, D eps for the
//! linearized one), von Mises per element and per node, the largest von Mises stress over a
//! node group, and the radial displacement of nodes.

use rayon::prelude::*;

use crate::error::FemError;
use crate::geometry::{check_det_j, det3, inverse3, longest_vertex_edge, AffineJacobian};
use crate::rotation::axis::{dot, Mat3};
use crate::rotation::element_ref::ElementRef;
use crate::rotation::global::gather;
use crate::rotation::model::RotatingModel;
use crate::rotation::static_solve::{Kinematics, StaticSolution};
use crate::rotation::stress_stiffness::svk_stress;
use crate::rotation::total_lagrangian::{
    cauchy_stress, deformation_gradient, displacement_gradient, green_lagrange,
};
use crate::shape;

/// Von Mises equivalent stress sqrt(3/2 s:s), s the deviator of `sigma` (Pa).
pub fn von_mises(sigma: &Mat3) -> f64 {
    let p = (sigma[0][0] + sigma[1][1] + sigma[2][2]) / 3.0;
    let mut ss = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            let d = sigma[i][j] - if i == j { p } else { 0.0 };
            ss += d * d;
        }
    }
    (1.5 * ss).sqrt()
}

/// Physical gradients dN_a/dX (1/m) at reference point `xi` of an element.
fn gradients_at(element: &ElementRef<'_>, xi: [f64; 3]) -> Result<[[f64; 3]; 10], FemError> {
    let j = AffineJacobian::new(element.kind, element.coords).at(xi);
    let det = det3(&j);
    check_det_j(det, longest_vertex_edge(element.coords), element.tag, xi)?;
    let inv = inverse3(&j, det);
    let mut rg = [[0.0; 3]; 10];
    shape::gradients_into(element.kind, xi, &mut rg);
    let mut g = [[0.0; 3]; 10];
    for a in 0..element.npe() {
        for d in 0..3 {
            g[a][d] = rg[a][0] * inv[0][d] + rg[a][1] * inv[1][d] + rg[a][2] * inv[2][d];
        }
    }
    Ok(g)
}

impl RotatingModel<'_> {
    /// Stress (Pa) of the static state `solution` at reference point `xi` of element `e`:
    /// Cauchy sigma = F S F^T / det F for [`Kinematics::GreenLagrange`], D eps(u) for
    /// [`Kinematics::Linear`].
    pub fn stress_at(
        &self,
        solution: &StaticSolution,
        e: usize,
        xi: [f64; 3],
    ) -> Result<Mat3, FemError> {
        let mut buf = [[0.0; 3]; 10];
        let element = self.element(e, &mut buf);
        let npe = element.npe();
        let mut u_e = [0.0; 30];
        gather(self.mesh(), e, &solution.displacement, &mut u_e[..3 * npe]);
        let g = gradients_at(&element, xi)?;
        let h = displacement_gradient(&u_e[..3 * npe], &g[..npe]);
        let lame = self.material().lame();
        Ok(match solution.kinematics {
            Kinematics::GreenLagrange => cauchy_stress(
                &deformation_gradient(&h),
                &svk_stress(&green_lagrange(&h), lame),
            ),
            Kinematics::Linear => {
                let eps: Mat3 =
                    std::array::from_fn(|i| std::array::from_fn(|j| 0.5 * (h[i][j] + h[j][i])));
                svk_stress(&eps, lame)
            }
        })
    }

    /// Von Mises stress (Pa) of every element at its centroid (reference point (1/4, 1/4, 1/4)).
    pub fn element_von_mises(&self, solution: &StaticSolution) -> Result<Vec<f64>, FemError> {
        (0..self.mesh().n_elements())
            .map(|e| Ok(von_mises(&self.stress_at(solution, e, [0.25; 3])?)))
            .collect()
    }

    /// Nodal stress tensors (Pa): at every node, the average over the elements holding it of
    /// the element's stress evaluated at that node (unweighted nodal averaging).
    pub fn nodal_stress(&self, solution: &StaticSolution) -> Result<Vec<Mat3>, FemError> {
        let mesh = self.mesh();
        let mut sum = vec![[[0.0; 3]; 3]; mesh.n_nodes()];
        let mut count = vec![0usize; mesh.n_nodes()];
        let reference = shape::reference_nodes(mesh.kind);
        let npe = mesh.kind.nodes_per_element();
        // The elements' stresses at their nodes in parallel, summed per node in element order.
        let at_nodes: Vec<Mat3> = (0..mesh.n_elements() * npe)
            .into_par_iter()
            .map(|i| self.stress_at(solution, i / npe, reference[i % npe]))
            .collect::<Result<_, _>>()?;
        for e in 0..mesh.n_elements() {
            for (la, &a) in mesh.element(e).iter().enumerate() {
                let s = at_nodes[e * npe + la];
                for i in 0..3 {
                    for j in 0..3 {
                        sum[a][i][j] += s[i][j];
                    }
                }
                count[a] += 1;
            }
        }
        Ok(sum
            .into_iter()
            .zip(count)
            .map(|(s, c)| s.map(|row| row.map(|v| v / c.max(1) as f64)))
            .collect())
    }

    /// Von Mises stress (Pa) of the nodal stresses of [`RotatingModel::nodal_stress`].
    pub fn nodal_von_mises(&self, solution: &StaticSolution) -> Result<Vec<f64>, FemError> {
        Ok(self.nodal_stress(solution)?.iter().map(von_mises).collect())
    }

    /// The largest nodal von Mises stress (Pa) over the nodes of the physical group `group`
    /// (e.g. the blade root), with the node holding it; `None` for a group without nodes.
    pub fn max_von_mises_in_group(
        &self,
        solution: &StaticSolution,
        group: &str,
    ) -> Result<Option<(usize, f64)>, FemError> {
        let nodes = &self.mesh().group(group)?.nodes;
        max_over_nodes(&self.nodal_von_mises(solution)?, nodes)
    }

    /// Radial displacement (m) of each node of `nodes`: the component of its displacement u
    /// along the unit vector of P (x - p), x = X + u its deformed position (0 for a node whose
    /// deformed position is on the axis). `displacement`: global, length 3n.
    pub fn radial_displacement(
        &self,
        displacement: &[f64],
        nodes: &[usize],
    ) -> Result<Vec<f64>, FemError> {
        if displacement.len() != 3 * self.mesh().n_nodes() {
            return Err(FemError::DimensionMismatch {
                what: "global displacement",
                found: displacement.len(),
                expected: 3 * self.mesh().n_nodes(),
            });
        }
        nodes
            .iter()
            .map(|&v| {
                let x0 = self
                    .mesh()
                    .nodes
                    .get(v)
                    .ok_or_else(|| FemError::DimensionMismatch {
                        what: "node index",
                        found: v,
                        expected: self.mesh().n_nodes(),
                    })?;
                let u = [
                    displacement[3 * v],
                    displacement[3 * v + 1],
                    displacement[3 * v + 2],
                ];
                let r = self
                    .axis()
                    .radial_vector([x0[0] + u[0], x0[1] + u[1], x0[2] + u[2]]);
                let len = dot(&r, &r).sqrt();
                Ok(if len > 0.0 { dot(&u, &r) / len } else { 0.0 })
            })
            .collect()
    }
}

/// The largest value of `nodal` over the nodes `nodes` (e.g. the nodal von Mises stress over
/// the root group), with the node holding it; `None` for an empty group. Errors on a node
/// index out of range.
pub fn max_over_nodes(nodal: &[f64], nodes: &[usize]) -> Result<Option<(usize, f64)>, FemError> {
    let mut best: Option<(usize, f64)> = None;
    for &v in nodes {
        let value = *nodal.get(v).ok_or(FemError::DimensionMismatch {
            what: "node index",
            found: v,
            expected: nodal.len(),
        })?;
        if best.is_none_or(|(_, b)| value > b) {
            best = Some((v, value));
        }
    }
    Ok(best)
}
