//! The prestressed structure at one speed (issue 23, items 2-4; DESIGN §9, docs/ROTATION.md):
//! the static centrifugal equilibrium (geometrically nonlinear or linearized), the stiffness at
//! speed K(Omega) on the free DOFs, the contact nodes' radial growth and running gaps, the speed
//! at which the clearance closes, and the largest von Mises stress over the clamped groups (the
//! root stress). SI units: m, Pa, rad/s, N/m.

use sprs::CsMat;

use nlmodes_sparse::LinearSolver;

use crate::dofs::{parse_fix_spec, DofMap};
use crate::error::FemError;
use crate::material::Isotropic;
use crate::mesh::Mesh;
use crate::rotation::axis::RotorAxis;
use crate::rotation::error::RotationError;
use crate::rotation::model::RotatingModel;
use crate::rotation::prestress::max_over_nodes;
use crate::rotation::static_solve::{Kinematics, NewtonOptions, StaticSolution};

/// A clamped structure turning about an axis, with contact nodes facing a casing across a
/// uniform radial gap at rest.
#[derive(Clone, Copy, Debug)]
pub struct SpeedProblem<'a> {
    /// The mesh (m).
    pub mesh: &'a Mesh,
    /// Its DOF map, the clamp's DOFs eliminated.
    pub dofs: &'a DofMap,
    /// The Dirichlet specifications applied (`root`, `root:xy`): the root stress is the largest
    /// nodal von Mises stress over their groups.
    pub clamp: &'a [String],
    /// The material.
    pub material: Isotropic,
    /// The rotor axis.
    pub axis: RotorAxis,
    /// The contact nodes (0-based mesh indices).
    pub contact: &'a [usize],
    /// The radial gap of every contact node at rest, m.
    pub cold_gap: f64,
    /// [`Kinematics::GreenLagrange`]: the geometrically nonlinear static solve, K(Omega) its
    /// last Newton tangent; [`Kinematics::Linear`]: the linearized one, K(Omega) =
    /// K_e + K_sigma - Omega^2 M_spin ([`RotatingModel::stiffness_at_speed`]).
    pub kinematics: Kinematics,
}

/// The prestressed structure at one speed.
pub struct Prestress {
    /// Speed, rad/s.
    pub omega: f64,
    /// The converged static state (displacement in m, Newton history).
    pub solution: StaticSolution,
    /// K(Omega) on the free DOFs, N/m (exactly symmetric).
    pub stiffness: CsMat<f64>,
    /// Radial growth of each contact node, m: |P(X + u - p)| - |P(X - p)|.
    pub growth: Vec<f64>,
    /// Running gap of each contact node, m: the cold gap minus its growth.
    pub running_gaps: Vec<f64>,
    /// Nodal von Mises stress (Pa; unweighted average of the elements' values at the node).
    pub von_mises: Vec<f64>,
    /// Largest nodal von Mises stress over the clamped groups (Pa) and its mesh node (0-based).
    pub root_stress: Option<(usize, f64)>,
}

/// The static state of `problem` at `omega` (rad/s), the linear systems solved by `solver`, and
/// everything drawn from it. Errors: [`RotationError::StaticSolve`] when the static solve does
/// not converge (the load step and why), [`RotationError::ClearanceClosed`] when a contact
/// node's growth closes the gap (the node and the estimated closure speed), and the model's
/// input errors (mesh, material, clamp groups, contact nodes out of range).
pub fn prestress_at_speed(
    problem: &SpeedProblem<'_>,
    omega: f64,
    solver: &mut dyn LinearSolver,
) -> Result<Prestress, RotationError> {
    prestress_at_speed_from(problem, omega, None, solver)
}

/// [`prestress_at_speed`] with the total-Lagrangian Newton solve started from `start`, a
/// converged state of the same model at a speed at most `omega` (a Campbell march's state at
/// that speed or below it: `None` starts from rest). At the same speed the start is already
/// converged and the solve costs one assembly of the residual and tangent (no factorization);
/// the state differs from the one reached from rest by less than the Newton tolerance. Ignored
/// by the linearized prestress (one linear solve either way).
pub fn prestress_at_speed_from(
    problem: &SpeedProblem<'_>,
    omega: f64,
    start: Option<&StaticSolution>,
    solver: &mut dyn LinearSolver,
) -> Result<Prestress, RotationError> {
    let model = RotatingModel::new(
        problem.mesh,
        problem.material,
        problem.axis,
        problem.dofs.clone(),
    )?;
    let (solution, stiffness) = match problem.kinematics {
        Kinematics::GreenLagrange => {
            // One nominal load step: a blade's strains are about 1e-3, Newton converges from
            // the unstressed tangent in 3-4 iterations; the cutbacks catch harder cases. The
            // stiffness at speed is the last Newton tangent.
            let options = NewtonOptions {
                load_steps: 1,
                ..NewtonOptions::default()
            };
            model.solve_nonlinear_with_stiffness(start, omega, &options, solver)?
        }
        Kinematics::Linear => {
            let solution = model.solve_linearized(omega, false, solver)?;
            let stiffness = model.stiffness_at_speed(&solution)?;
            (solution, stiffness)
        }
    };
    let growth = radial_growth(
        problem.mesh,
        &problem.axis,
        &solution.displacement,
        problem.contact,
    )?;
    let running_gaps: Vec<f64> = growth.iter().map(|g| problem.cold_gap - g).collect();
    check_open(problem, omega, &growth, &running_gaps)?;
    let von_mises = model.nodal_von_mises(&solution)?;
    let root_stress = root_stress(&model, &von_mises, problem.clamp)?;
    Ok(Prestress {
        omega,
        solution,
        stiffness,
        growth,
        running_gaps,
        von_mises,
        root_stress,
    })
}

/// Radial growth (m) of the nodes `nodes` under the global displacement `u` (m, 3 per node):
/// the change of their distance from the axis ([`RotorAxis::radial_growth`]). Errors on a
/// displacement of another length or a node out of range.
pub fn radial_growth(
    mesh: &Mesh,
    axis: &RotorAxis,
    u: &[f64],
    nodes: &[usize],
) -> Result<Vec<f64>, FemError> {
    if u.len() != 3 * mesh.n_nodes() {
        return Err(FemError::DimensionMismatch {
            what: "global displacement",
            found: u.len(),
            expected: 3 * mesh.n_nodes(),
        });
    }
    nodes
        .iter()
        .map(|&n| {
            let x = *mesh.nodes.get(n).ok_or(FemError::DimensionMismatch {
                what: "contact node index",
                found: n,
                expected: mesh.n_nodes(),
            })?;
            Ok(axis.radial_growth(x, [u[3 * n], u[3 * n + 1], u[3 * n + 2]]))
        })
        .collect()
}

/// The speed (rad/s) at which a node growing by `growth` m at `omega` rad/s closes `cold_gap`
/// m, assuming growth proportional to Omega^2 (the linearized static response, exact for it;
/// the geometric stiffening of the nonlinear solve makes the true closure speed slightly
/// higher). `None` for a node that does not grow or a speed that is not positive.
pub fn closure_speed(omega: f64, growth: f64, cold_gap: f64) -> Option<f64> {
    (growth > 0.0 && omega > 0.0).then(|| omega * (cold_gap / growth).sqrt())
}

/// [`RotationError::ClearanceClosed`] when a running gap is not positive, for the node with the
/// smallest one, with the closure speed estimated from its Omega^2 growth.
fn check_open(
    problem: &SpeedProblem<'_>,
    omega: f64,
    growth: &[f64],
    gaps: &[f64],
) -> Result<(), RotationError> {
    let Some(j) = (0..gaps.len()).min_by(|&a, &b| gaps[a].total_cmp(&gaps[b])) else {
        return Ok(());
    };
    if gaps[j] > 0.0 {
        return Ok(());
    }
    Err(RotationError::ClearanceClosed {
        omega,
        contact: j,
        mesh_node: problem.contact[j],
        growth: growth[j],
        cold_gap: problem.cold_gap,
        closure_omega: closure_speed(omega, growth[j], problem.cold_gap),
    })
}

/// The largest of the nodal values `nodal` (the von Mises stress, Pa) over the nodes of the
/// groups of the Dirichlet specifications `clamp`, with its mesh node.
fn root_stress(
    model: &RotatingModel<'_>,
    nodal: &[f64],
    clamp: &[String],
) -> Result<Option<(usize, f64)>, FemError> {
    let mut best: Option<(usize, f64)> = None;
    for spec in clamp {
        let (group, _) = parse_fix_spec(spec)?;
        let nodes = &model.mesh().group(&group)?.nodes;
        if let Some((n, v)) = max_over_nodes(nodal, nodes)? {
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((n, v));
            }
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point of the plane of rotation moved radially by a quarter of its radius grows by
    /// exactly that (3-4-5 triangles: every value exact in binary); an axial motion does not
    /// grow it; a speed of 100 rad/s growing a node by a quarter of the gap closes it at
    /// 200 rad/s.
    #[test]
    fn growth_and_closure_speed_match_hand_values() {
        let axis = RotorAxis::new([0.0, 0.0, 1.0], [0.0, 0.0, 2.0]).unwrap();
        assert_eq!(axis.radial_growth([3.0, 4.0, 7.0], [0.75, 1.0, 0.0]), 1.25);
        assert_eq!(axis.radial_growth([3.0, 4.0, 7.0], [0.0, 0.0, 5.0]), 0.0);
        assert_eq!(closure_speed(100.0, 0.25, 1.0), Some(200.0));
        assert_eq!(closure_speed(100.0, 0.0, 1.0), None);
        assert_eq!(closure_speed(0.0, 0.25, 1.0), None);
    }
}
