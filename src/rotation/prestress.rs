//! The centrifugal prestress of the clamped blade at a speed (issue 23, items 2-4; DESIGN §9,
//! docs/ROTATION.md), from the case's settings: the physics is `nlmodes_fem::rotation`'s
//! ([`nlmodes_fem::rotation::prestress_at_speed`]: the static state, K(Omega), radial growth, running gaps, closure
//! speed, root stress); here the case's keys become its inputs, its errors become bad input
//! naming the key and the speed in rpm, and its Newton history becomes text. SI units: m, Pa,
//! rad/s, N/m.

use anyhow::{Context, Result};
use nlmodes_fem::rotation::{
    prestress_at_speed_from, Kinematics, LinearSolver, LoadStep, RotationError, RotorAxis,
    SpeedProblem, StaticSolution,
};
use nlmodes_fem::Isotropic;

use crate::exit::bad_input;
use crate::mesh::fe_model::FeModel;
use crate::rotation::rotation_settings::RPM_TO_RAD_S;

pub use nlmodes_fem::rotation::Prestress;

/// The rotor axis of the fem crate from the case's point and direction.
pub fn fem_axis(point: [f64; 3], direction: [f64; 3]) -> Result<RotorAxis> {
    RotorAxis::new(point, direction).context("[model] rotor_axis_point / rotor_axis_direction")
}

/// Radial growth (m) of the nodes `nodes` under the global displacement `u` (3 per node): the
/// change of their distance from the axis ([`RotorAxis::radial_growth`]). `nodes` are the
/// contact nodes of `fe`'s mesh and `u` one of its displacements.
pub fn radial_growth(fe: &FeModel, axis: &RotorAxis, u: &[f64], nodes: &[usize]) -> Vec<f64> {
    nodes
        .iter()
        .map(|&n| axis.radial_growth(fe.mesh.nodes[n], [u[3 * n], u[3 * n + 1], u[3 * n + 2]]))
        .collect()
}

/// The static state at `omega` (rad/s; the case key `key` asked for it) and everything drawn
/// from it; `contact` are the contact nodes (mesh indices), `cold_gap` the gap at rest (m).
/// Bad input, naming the key and the speed: a speed at which a contact node's growth closes the
/// gap (with the node and the estimated closure speed), and one at which the static solve does
/// not converge (with the load step at which it stopped and why). `solver` solves the Newton
/// steps (`crate::rotation::rotation_mpi::FullSolver`: here, or over the ranks under mpirun);
/// `start`: a converged state at a speed at most `omega` to start the nonlinear solve from
/// (`crate::rotation::static_states`; `None`: from rest; ignored by the linear prestress).
pub fn at_speed(
    fe: &FeModel,
    material: &Isotropic,
    axis: &RotorAxis,
    (omega, key): (f64, &str),
    (nonlinear, start): (bool, Option<&StaticSolution>),
    (contact, cold_gap): (&[usize], f64),
    solver: &mut dyn LinearSolver,
) -> Result<Prestress> {
    let problem = SpeedProblem {
        mesh: &fe.mesh,
        dofs: &fe.dofs,
        clamp: &fe.clamp,
        material: *material,
        axis: *axis,
        contact,
        cold_gap,
        kinematics: if nonlinear {
            Kinematics::GreenLagrange
        } else {
            Kinematics::Linear
        },
    };
    prestress_at_speed_from(&problem, omega, start, solver).map_err(|e| match e {
        RotationError::ClearanceClosed {
            omega,
            contact,
            mesh_node,
            growth,
            cold_gap,
            closure_omega,
        } => bad_input(format!(
            "{key} = {:.1} rpm: the tip clearance closes statically: contact node \
             {} (mesh node {}) grows radially by {growth:.4e} m, more than the cold gap \
             [model] gap = {cold_gap:.4e} m; the gap closes at about {:.0} rpm (growth ~ \
             Omega^2): choose a lower speed or a larger cold gap",
            omega / RPM_TO_RAD_S,
            contact + 1,
            mesh_node + 1,
            closure_omega.map_or(f64::NAN, |w| w / RPM_TO_RAD_S)
        )),
        other => not_converged(key, omega, other),
    })
}

/// A static solve that stopped (`RotationError::StaticSolve`) is bad input naming the case key
/// and the speed; any other failure is a computation error.
pub fn not_converged(key: &str, omega: f64, e: RotationError) -> anyhow::Error {
    let rpm = omega / RPM_TO_RAD_S;
    match e {
        RotationError::StaticSolve { .. } => bad_input(format!(
            "{key} = {rpm:.1} rpm: the centrifugal static solve does not converge at this speed: \
             {e}; choose a lower speed (or check [material] and the clamp)"
        )),
        other => anyhow::Error::new(other).context(format!(
            "centrifugal static solve at {rpm:.1} rpm ({omega:.4} rad/s)"
        )),
    }
}

/// The speed (rpm) at which a node growing by `growth` m at `omega` rad/s closes `cold_gap`
/// ([`nlmodes_fem::rotation::closure_speed`]: growth ~ Omega^2). `None` for a node that does not
/// grow.
pub fn closure_rpm(omega: f64, growth: f64, cold_gap: f64) -> Option<f64> {
    nlmodes_fem::rotation::closure_speed(omega, growth, cold_gap).map(|w| w / RPM_TO_RAD_S)
}

/// The Newton history as text lines (`step k at .. rpm: ||r|| / ||f_c|| = ...`, "c" marking
/// the states reached by a chord step).
pub fn newton_history(steps: &[LoadStep]) -> Vec<String> {
    steps
        .iter()
        .map(|s| {
            let ratios: Vec<String> = s
                .iterations
                .iter()
                .map(|i| {
                    format!(
                        "{:.1e}{}",
                        i.residual_norm / i.load_norm.max(f64::MIN_POSITIVE),
                        if i.chord { "c" } else { "" }
                    )
                })
                .collect();
            let chord = s.iterations.iter().filter(|i| i.chord).count();
            let newton = s.iterations.len().saturating_sub(1) - chord;
            format!(
                "step {} at {:.1} rpm ({} cutbacks; {newton} Newton + {chord} chord steps): \
                 ||r|| / ||f_c|| = {}",
                s.step,
                s.omega / RPM_TO_RAD_S,
                s.cutbacks,
                ratios.join(", ")
            )
        })
        .collect()
}
