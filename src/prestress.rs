//! The centrifugal prestress of the clamped blade at a speed (issue 23, items 2-4; DESIGN §9,
//! docs/ROTATION.md): the static equilibrium (geometrically nonlinear or linearized, by
//! `nlmodes_fem::rotation`), the stiffness at speed K(Omega) on the free DOFs, the contact
//! nodes' radial growth and running gaps, the root stress. SI units: m, Pa, rad/s, N/m.

use anyhow::{Context, Result};
use nlmodes_fem::rotation::{
    LinearSolveError, LinearSolver, LoadStep, NewtonOptions, RotatingModel, RotorAxis,
    StaticSolution,
};
use nlmodes_fem::Isotropic;
use sprs::CsMat;

use crate::exit::bad_input;
use crate::fe_model::FeModel;
use crate::rotation_settings::RPM_TO_RAD_S;

/// The sparse Cholesky of `nlmodes_modal` (METIS ordering, numeric factorization on both
/// cores) behind the static solve's `LinearSolver`: at 93k DOFs it factors several times faster
/// than faer's default ordering. The ordering and symbolic analysis are kept and reused while
/// the pattern stays (along a Newton solve and a march over speeds: the mesh's pattern). A
/// failed pivot is reported as an indefinite tangent.
#[derive(Default)]
pub struct MetisCholesky {
    factor: Option<nlmodes_modal::SparseCholesky>,
}

impl MetisCholesky {
    /// The factorization of `a` (`what` names it in messages), reusing the ordering and symbolic
    /// analysis of the last matrix factorized when `a` has its pattern. With the same ordering
    /// and analysis the factor is the one a fresh analysis would give, bit for bit.
    pub fn factorize(
        &mut self,
        a: &CsMat<f64>,
        what: &str,
    ) -> Result<&nlmodes_modal::SparseCholesky, nlmodes_modal::ModalError> {
        match &mut self.factor {
            Some(f) if f.same_pattern(a) => f.refactorize(a, what)?,
            _ => {
                self.factor = None;
                let options = nlmodes_modal::CholeskyOptions::default();
                let f = nlmodes_modal::SparseCholesky::with_options(a, what, options)?;
                self.factor = Some(f);
            }
        }
        Ok(self.factor.as_ref().expect("factorized above"))
    }
}

impl LinearSolver for MetisCholesky {
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError> {
        let factor = self
            .factorize(a, "tangent")
            .map_err(|e| LinearSolveError(format!("Cholesky factorization failed: {e}")))?;
        let mut x = b.to_vec();
        factor
            .solve_in_place(&mut x)
            .map_err(|e| LinearSolveError(format!("Cholesky solve failed: {e}")))?;
        Ok(x)
    }
}

/// The prestressed blade at one speed.
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

/// The rotor axis of the fem crate from the case's point and direction.
pub fn fem_axis(point: [f64; 3], direction: [f64; 3]) -> Result<RotorAxis> {
    RotorAxis::new(point, direction).context("[model] rotor_axis_point / rotor_axis_direction")
}

/// Radial growth (m) of the nodes `nodes` under the global displacement `u` (3 per node): the
/// change of their distance from the axis.
pub fn radial_growth(fe: &FeModel, axis: &RotorAxis, u: &[f64], nodes: &[usize]) -> Vec<f64> {
    let radius = |x: [f64; 3]| {
        let r = axis.radial_vector(x);
        (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
    };
    nodes
        .iter()
        .map(|&n| {
            let x = fe.mesh.nodes[n];
            let y = [x[0] + u[3 * n], x[1] + u[3 * n + 1], x[2] + u[3 * n + 2]];
            radius(y) - radius(x)
        })
        .collect()
}

/// The static state at `omega` (rad/s; the case key `key` asked for it) and everything drawn
/// from it; `contact` are the contact nodes (mesh indices), `cold_gap` the gap at rest (m).
/// Bad input, naming the key and the speed: a speed at which a contact node's growth closes the
/// gap (with the node and the estimated closure speed), and one at which the static solve does
/// not converge (with the load step at which it stopped and why). `solver` solves the Newton
/// steps (`crate::rotation_mpi::FullSolver`: here, or over the ranks under mpirun).
pub fn at_speed(
    fe: &FeModel,
    material: &Isotropic,
    axis: &RotorAxis,
    (omega, key): (f64, &str),
    nonlinear: bool,
    (contact, cold_gap): (&[usize], f64),
    solver: &mut dyn LinearSolver,
) -> Result<Prestress> {
    let model = RotatingModel::new(&fe.mesh, *material, *axis, fe.dofs.clone())
        .context("the rotating model")?;
    let (solution, stiffness) = if nonlinear {
        // One nominal load step: the blade's strains are about 1e-3, Newton converges from the
        // unstressed tangent in 3-4 iterations; the cutbacks catch harder cases. The stiffness
        // at speed is the last Newton tangent.
        let options = NewtonOptions {
            load_steps: 1,
            ..NewtonOptions::default()
        };
        model
            .solve_nonlinear_with_stiffness(None, omega, &options, solver)
            .map_err(|e| not_converged(key, omega, e))?
    } else {
        let s = model
            .solve_linearized(omega, false, solver)
            .map_err(|e| not_converged(key, omega, e))?;
        let k = model
            .stiffness_at_speed(&s)
            .context("the stiffness at speed")?;
        (s, k)
    };
    let growth = radial_growth(fe, axis, &solution.displacement, contact);
    let running_gaps: Vec<f64> = growth.iter().map(|g| cold_gap - g).collect();
    check_open((omega, key), &growth, &running_gaps, contact, cold_gap)?;
    let von_mises = model.nodal_von_mises(&solution)?;
    let root_stress = root_stress(&model, &von_mises, &fe.clamp)?;
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

/// A static solve that stopped (`RotationError::StaticSolve`) is bad input naming the case key
/// and the speed; any other failure is a computation error.
pub fn not_converged(
    key: &str,
    omega: f64,
    e: nlmodes_fem::rotation::RotationError,
) -> anyhow::Error {
    let rpm = omega / RPM_TO_RAD_S;
    match e {
        nlmodes_fem::rotation::RotationError::StaticSolve { .. } => bad_input(format!(
            "{key} = {rpm:.1} rpm: the centrifugal static solve does not converge at this speed: \
             {e}; choose a lower speed (or check [material] and the clamp)"
        )),
        other => anyhow::Error::new(other).context(format!(
            "centrifugal static solve at {rpm:.1} rpm ({omega:.4} rad/s)"
        )),
    }
}

/// Bad input when a running gap is not positive, with the closure speed estimated from the
/// Omega^2 growth of the node that grows most.
fn check_open(
    (omega, key): (f64, &str),
    growth: &[f64],
    gaps: &[f64],
    contact: &[usize],
    cold_gap: f64,
) -> Result<()> {
    let Some(j) = (0..gaps.len()).min_by(|&a, &b| gaps[a].total_cmp(&gaps[b])) else {
        return Ok(());
    };
    if gaps[j] > 0.0 {
        return Ok(());
    }
    Err(bad_input(format!(
        "{key} = {:.1} rpm: the tip clearance closes statically: contact node \
         {} (mesh node {}) grows radially by {:.4e} m, more than the cold gap [model] gap = \
         {cold_gap:.4e} m; the gap closes at about {:.0} rpm (growth ~ Omega^2): choose a lower \
         speed or a larger cold gap",
        omega / RPM_TO_RAD_S,
        j + 1,
        contact[j] + 1,
        growth[j],
        closure_rpm(omega, growth[j], cold_gap).unwrap_or(f64::NAN)
    )))
}

/// The speed (rpm) at which a node growing by `growth` m at `omega` rad/s closes `cold_gap`,
/// assuming growth proportional to Omega^2 (the linear static response; the geometric
/// stiffening of the nonlinear solve makes the true closure speed slightly higher). `None`
/// for a node that does not grow.
pub fn closure_rpm(omega: f64, growth: f64, cold_gap: f64) -> Option<f64> {
    (growth > 0.0 && omega > 0.0).then(|| omega * (cold_gap / growth).sqrt() / RPM_TO_RAD_S)
}

/// The largest nodal von Mises stress over the clamped groups' nodes.
fn root_stress(
    model: &RotatingModel<'_>,
    nodal: &[f64],
    clamp: &[String],
) -> Result<Option<(usize, f64)>> {
    let mut best: Option<(usize, f64)> = None;
    for spec in clamp {
        let (group, _) = nlmodes_fem::parse_fix_spec(spec)?;
        let nodes = &model.mesh().group(&group)?.nodes;
        if let Some((n, v)) = nlmodes_fem::rotation::max_over_nodes(nodal, nodes)? {
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((n, v));
            }
        }
    }
    Ok(best)
}

/// The Newton history as text lines (`step k at .. rpm: ||r|| / ||f_c|| = ...`).
pub fn newton_history(steps: &[LoadStep]) -> Vec<String> {
    steps
        .iter()
        .map(|s| {
            let ratios: Vec<String> = s
                .iterations
                .iter()
                .map(|i| {
                    format!(
                        "{:.1e}",
                        i.residual_norm / i.load_norm.max(f64::MIN_POSITIVE)
                    )
                })
                .collect();
            format!(
                "step {} at {:.1} rpm ({} cutbacks): ||r|| / ||f_c|| = {}",
                s.step,
                s.omega / RPM_TO_RAD_S,
                s.cutbacks,
                ratios.join(", ")
            )
        })
        .collect()
}
