//! The chord steps of the static centrifugal solve (`nlmodes_fem::rotation::newton`): a march
//! over speeds with a solver that keeps its last factor (the sparse Cholesky: chord steps) lands
//! on the states of plain Newton (the LU solver keeps none: every step a Newton step), takes
//! fewer Newton steps, and returns the tangent at its converged state.
//!
//! The structure: a steel TET10 cantilever 1 m x 40 mm x 40 mm along x, clamped at x = 0,
//! turning about the z axis through the origin but offset by 0.2 m in y, so that the
//! centrifugal load rho Omega^2 (x, y, 0) both stretches it and bends it (the lateral part
//! rho Omega^2 y): the geometric stiffening makes the static state a nonlinear function of
//! Omega^2 (its first bending frequency at rest is about 200 rad/s; the march goes to 400).

use nlmodes_fem::generate::box_mesh;
use nlmodes_fem::rotation::speed_march::OVERSHOOT;
use nlmodes_fem::rotation::{
    LinearSolver, NewtonOptions, RotatingModel, RotorAxis, StaticSolution,
};
use nlmodes_fem::{fixed_dofs, DofMap, Isotropic, Mesh, TetKind};
use nlmodes_sparse::{CholeskySolver, LuSolver};

fn cantilever() -> (Mesh, DofMap) {
    let mut mesh = box_mesh([1.0, 0.04, 0.04], [10, 1, 1], TetKind::Tet10).expect("mesh");
    for x in mesh.nodes.iter_mut() {
        x[1] += 0.2;
    }
    let fixed = fixed_dofs(&mesh, &["xmin"]).expect("fixed");
    let dofs = DofMap::new(mesh.n_nodes(), &fixed).expect("dofs");
    (mesh, dofs)
}

/// The march over `speeds` (rad/s, ascending) from rest, each speed one load step from the
/// start `march_start` picks from the states before it (as the Campbell stage marches).
fn march(
    model: &RotatingModel<'_>,
    speeds: &[f64],
    solver: &mut dyn LinearSolver,
) -> Vec<(StaticSolution, sprs::CsMat<f64>)> {
    let options = NewtonOptions {
        load_steps: 1,
        ..Default::default()
    };
    let mut states: Vec<StaticSolution> = Vec::new();
    let mut out = Vec::new();
    for &omega in speeds {
        let start = model.march_start(&states, omega).expect("start");
        let start = start.as_ref();
        let (state, k) = model
            .solve_nonlinear_with_stiffness(start, omega, &options, solver)
            .expect("converged");
        states.push(state.clone());
        out.push((state, k));
    }
    out
}

fn counts(state: &StaticSolution) -> (usize, usize) {
    let it = &state.steps.last().expect("a step").iterations;
    let chord = it.iter().filter(|i| i.chord).count();
    (it.len() - 1 - chord, chord)
}

/// Same states to 1e-9 of the largest displacement (both converged to 1e-10 of the load in the
/// residual; the displacement error is that times the ratio of the stiffness to the softest
/// mode's, about 10 here: checked 1e-9 leaves room without hiding a wrong state, which would
/// differ by the chord's contraction, 1e-2 or more); the chord march uses chord steps at every
/// speed after the first and at most the Newton steps of plain Newton; its stiffness is the
/// tangent at its converged state, bit for bit.
#[test]
fn chord_steps_land_on_the_newton_states_with_fewer_newton_steps() {
    let (mesh, dofs) = cantilever();
    let material = Isotropic::new(200e9, 0.3, 7800.0).expect("material");
    let axis = RotorAxis::new([0.0; 3], [0.0, 0.0, 1.0]).expect("axis");
    let model = RotatingModel::new(&mesh, material, axis, dofs).expect("model");
    let speeds = [100.0, 200.0, 250.0, 300.0, 350.0, 400.0];
    let chord = march(&model, &speeds, &mut CholeskySolver::default());
    let plain = march(&model, &speeds, &mut LuSolver::default());
    let scale = plain
        .last()
        .map(|(s, _)| s.displacement.iter().fold(0.0_f64, |m, u| m.max(u.abs())))
        .expect("states");
    assert!(
        scale > 1e-4,
        "a deflection of {scale} m: not the nonlinear regime meant"
    );
    let (mut newton_chord, mut newton_plain) = (0, 0);
    for (i, ((a, k), (b, _))) in chord.iter().zip(&plain).enumerate() {
        let diff = a
            .displacement
            .iter()
            .zip(&b.displacement)
            .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff <= 1e-9 * scale, "{} rad/s: {diff:e} m", speeds[i]);
        let ((n_a, c_a), (n_b, c_b)) = (counts(a), counts(b));
        assert_eq!(c_b, 0, "the LU keeps no factor: plain Newton");
        if i > 0 {
            assert!(c_a > 0, "{} rad/s: no chord step ({n_a} Newton)", speeds[i]);
        }
        (newton_chord, newton_plain) = (newton_chord + n_a, newton_plain + n_b);
        assert_eq!(k, &model.stiffness_at_speed(a).expect("K(Omega)"));
    }
    assert!(
        newton_chord < newton_plain,
        "Newton steps: {newton_chord} with chord steps, {newton_plain} without"
    );
}

/// The residual of a chord step is that of a Newton step, bit for bit: `residual` assembles the
/// same element forces as `residual_and_tangent`, without the tangent.
#[test]
fn residual_without_tangent_is_the_same_bits() {
    let (mesh, dofs) = cantilever();
    let material = Isotropic::new(200e9, 0.3, 7800.0).expect("material");
    let axis = RotorAxis::new([0.0; 3], [0.0, 0.0, 1.0]).expect("axis");
    let model = RotatingModel::new(&mesh, material, axis, dofs.clone()).expect("model");
    let u: Vec<f64> = (0..dofs.n_free())
        .map(|i| 1e-3 * (0.37 * i as f64).sin())
        .collect();
    let (residual, load) = model.residual(300.0, &u).expect("residual");
    let rt = model
        .residual_and_tangent(300.0, &u)
        .expect("residual and tangent");
    assert_eq!(residual, rt.residual);
    assert_eq!(load, rt.load);
}

/// Where the state is far from polynomial in Omega^2 (the cantilever softening in its plane
/// towards 300 rad/s) the extrapolations from 100, 200 and 250 rad/s overshoot: residuals of
/// 853 (quadratic) and 806 (secant) times the load at 300 rad/s, against 0.31 for the state at
/// 250 (the quadratic one was the start that met an indefinite tangent even after ten
/// cutbacks); `march_start` falls back to the last state there, and the march converges from
/// it (the test above).
#[test]
fn the_march_start_falls_back_from_an_overshooting_extrapolation() {
    let (mesh, dofs) = cantilever();
    let material = Isotropic::new(200e9, 0.3, 7800.0).expect("material");
    let axis = RotorAxis::new([0.0; 3], [0.0, 0.0, 1.0]).expect("axis");
    let model = RotatingModel::new(&mesh, material, axis, dofs).expect("model");
    let speeds = [100.0, 200.0, 250.0];
    let states: Vec<StaticSolution> = march(&model, &speeds, &mut CholeskySolver::default())
        .into_iter()
        .map(|(s, _)| s)
        .collect();
    let omega = 300.0;
    let relative = |u: &[f64]| {
        let (r, f) = model.residual(omega, u).expect("residual");
        let n = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        n(&r) / n(&f)
    };
    let start = |count| model.extrapolated_start(&states, omega, count).unwrap();
    let (quadratic, secant) = (start(3).expect("three"), start(2).expect("two"));
    let chosen = model.march_start(&states, omega).unwrap().expect("a start");
    let (q, s, l) = (
        relative(&quadratic.displacement_free),
        relative(&secant.displacement_free),
        relative(&states[2].displacement_free),
    );
    assert!(
        q > OVERSHOOT * l && s > OVERSHOOT * l,
        "quadratic {q}, secant {s}, last state {l}: not the overshoot meant"
    );
    assert_eq!(chosen.displacement_free, states[2].displacement_free);
    assert_eq!(chosen.omega, 250.0, "a start at the last state's speed");
}
