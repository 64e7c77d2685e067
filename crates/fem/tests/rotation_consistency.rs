//! Consistency of the rotation terms (issue 23): the load against its spin matrix, the
//! total-Lagrangian tangent against finite differences, the stress stiffness against a closed
//! form, every term at Omega = 0 against today's model (`assemble`), symmetry of K(Omega) and
//! skew-symmetry of G, and the typed errors of a failed static solve.

// Index loops mirror the index notation of the formulas (u[3 a + d], k[i * n + j]).
#![allow(clippy::needless_range_loop)]

mod common;

use common::{curve_mid_edge_nodes, straight_tet10, Lcg};
use nlmodes_fem::element::element_matrices;
use nlmodes_fem::generate::box_mesh;
use nlmodes_fem::rotation::{
    centrifugal_load_element, centrifugal_load_from_spin_matrix,
    internal_force_and_tangent_element, spin_softening_element, ElementRef, Kinematics,
    NewtonOptions, RotatingModel, RotationError, RotorAxis, StopReason,
};
use nlmodes_fem::{assemble, fixed_dofs, DofMap, Isotropic, Mesh, TetKind};
use nlmodes_sparse::CholeskySolver;
use sprs::CsMat;

fn steel() -> Isotropic {
    Isotropic::new(2.0e11, 0.3, 7800.0).expect("valid")
}

fn axis() -> RotorAxis {
    RotorAxis::new([0.01, -0.02, 0.005], [0.3, -0.2, 1.0]).expect("valid")
}

/// A random positively oriented element of size ~`h` (m) near `centre`: TET4, or TET10 whose
/// mid-edge nodes are moved by up to `curve` x h (0 = straight).
fn random_element(
    rng: &mut Lcg,
    kind: TetKind,
    centre: [f64; 3],
    h: f64,
    curve: f64,
) -> Vec<[f64; 3]> {
    let reference = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    loop {
        let v: [[f64; 3]; 4] = std::array::from_fn(|i| {
            std::array::from_fn(|d| centre[d] + h * (reference[i][d] + 0.3 * rng.next()))
        });
        let e = |i: usize| [v[i][0] - v[0][0], v[i][1] - v[0][1], v[i][2] - v[0][2]];
        let (a, b, c) = (e(1), e(2), e(3));
        let vol6 = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]);
        if vol6 < 0.3 * h * h * h {
            continue;
        }
        return match kind {
            TetKind::Tet4 => v.to_vec(),
            TetKind::Tet10 => {
                let mut c = straight_tet10(&v);
                for node in c.iter_mut().skip(4) {
                    let dir = rng.unit();
                    for d in 0..3 {
                        node[d] += curve * h * dir[d];
                    }
                }
                c
            }
        };
    }
}

/// The element families of the element-level checks: TET4, straight TET10, curved TET10.
fn families() -> [(TetKind, f64, &'static str); 3] {
    [
        (TetKind::Tet4, 0.0, "TET4"),
        (TetKind::Tet10, 0.0, "TET10"),
        (TetKind::Tet10, 0.04, "curved TET10"),
    ]
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn centrifugal_load_equals_omega_squared_spin_matrix_times_position() {
    // Isoparametric elements: x = sum N_b x_b, so int rho N_a P (x - p) = sum_b m_ab P (x_b - p)
    // exactly; the load is integrated with the degree-7 rule, M_spin with the exact cubic
    // mass weights: two independent exact computations, equal to round-off (sums of <= 64
    // terms: 1e-12 relative is far above round-off and far below any wrong term).
    let mut rng = Lcg(17);
    let (mat, axis, omega) = (steel(), axis(), 1500.0);
    for (kind, curve, name) in families() {
        let mut worst: f64 = 0.0;
        for trial in 0..5 {
            let coords = random_element(&mut rng, kind, [0.4, 0.1, -0.2], 0.02, curve);
            let el = ElementRef::new(kind, &coords, trial).expect("element");
            for scale in [0.0, 2e-3] {
                let u: Vec<f64> = (0..el.ndof()).map(|_| scale * rng.next()).collect();
                let mut f = vec![0.0; el.ndof()];
                centrifugal_load_element(&el, &u, mat.density, &axis, omega, &mut f).expect("load");
                let g = centrifugal_load_from_spin_matrix(&el, &u, mat.density, &axis, omega)
                    .expect("spin");
                let err = f
                    .iter()
                    .zip(&g)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(
                    err <= 1e-12 * max_abs(&g),
                    "{name} trial {trial} u scale {scale}: {err:e} vs {:e}",
                    max_abs(&g)
                );
                assert!(max_abs(&g) > 0.0);
                worst = worst.max(err / max_abs(&g));
            }
        }
        println!("{name}: load vs Omega^2 M_spin (x - p), worst relative {worst:.1e}");
    }
}

/// Central-difference derivative of `f` at `u` in direction `d` with step `h`.
fn central_difference(f: impl Fn(&[f64]) -> Vec<f64>, u: &[f64], d: &[f64], h: f64) -> Vec<f64> {
    let shifted = |s: f64| -> Vec<f64> { u.iter().zip(d).map(|(a, b)| a + s * h * b).collect() };
    let (fp, fm) = (f(&shifted(1.0)), f(&shifted(-1.0)));
    fp.iter()
        .zip(&fm)
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect()
}

fn mat_vec(k: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|i| (0..n).map(|j| k[i * n + j] * x[j]).sum())
        .collect()
}

#[test]
fn element_tangent_matches_finite_differences_of_internal_force_minus_load() {
    // r(u) = f_int(u) - f_c(u); dr/du = K_T(u) - Omega^2 M_spin. f_int is a cubic polynomial
    // of u, f_c linear, so the central difference with step h |d| = 1e-6 h_el has truncation
    // error (h |d|)^2 / 6 |D^3 f| ~ 1e-12 relative and round-off eps |f| / (h |d|) ~ 1e-11
    // relative (|u| ~ 3 % of h_el): the 1e-8 bound has three orders of margin and catches
    // any wrong term, the smallest one being Omega^2 M_spin at ~1e-4 of K here.
    let mut rng = Lcg(2024);
    let (mat, axis, omega) = (steel(), axis(), 2.0e4);
    let lame = mat.lame();
    let h_el = 0.02;
    for (kind, curve, name) in families() {
        let mut worst: f64 = 0.0;
        for trial in 0..6 {
            let coords = random_element(&mut rng, kind, [0.3, -0.1, 0.2], h_el, curve);
            let el = ElementRef::new(kind, &coords, trial).expect("element");
            let n = el.ndof();
            let residual = |u: &[f64]| -> Vec<f64> {
                let mut f = vec![0.0; n];
                let mut load = vec![0.0; n];
                internal_force_and_tangent_element(&el, u, lame, &mut f, None).expect("force");
                centrifugal_load_element(&el, u, mat.density, &axis, omega, &mut load)
                    .expect("load");
                f.iter().zip(&load).map(|(a, b)| a - b).collect()
            };
            let u: Vec<f64> = (0..n).map(|_| 0.03 * h_el * rng.next()).collect();
            let mut f = vec![0.0; n];
            let mut k = vec![0.0; n * n];
            internal_force_and_tangent_element(&el, &u, lame, &mut f, Some(&mut k))
                .expect("tangent");
            let mut spin = vec![0.0; n * n];
            spin_softening_element(&el, mat.density, &axis, &mut spin).expect("spin");
            let t: Vec<f64> = k
                .iter()
                .zip(&spin)
                .map(|(a, s)| a - omega * omega * s)
                .collect();
            let spin_share = max_abs(&spin) * omega * omega / max_abs(&k);
            assert!(
                spin_share > 1e-6,
                "{name}: spin term too small to be tested ({spin_share:e})"
            );
            for _ in 0..3 {
                let d: Vec<f64> = (0..n).map(|_| rng.next()).collect();
                let fd = central_difference(residual, &u, &d, 1e-6 * h_el);
                let td = mat_vec(&t, &d);
                let err = fd
                    .iter()
                    .zip(&td)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(
                    err <= 1e-8 * max_abs(&td),
                    "{name} trial {trial}: |FD - T d| = {err:e}, |T d| = {:e}",
                    max_abs(&td)
                );
                worst = worst.max(err / max_abs(&td));
            }
        }
        println!("{name}: tangent vs central differences, worst relative {worst:.1e}");
    }
}

#[test]
fn element_tangent_at_zero_displacement_is_the_linear_stiffness() {
    // At u = 0: F = I, S = 0, so the tangent is the linear stiffness and the internal force is
    // zero. Both integrate exactly (affine) or with the same ladder rule (curved): equal to
    // round-off, 1e-12 relative.
    let mut rng = Lcg(5);
    let mat = steel();
    for (kind, curve, name) in families() {
        let mut worst: f64 = 0.0;
        for trial in 0..5 {
            let coords = random_element(&mut rng, kind, [0.0, 0.5, 0.1], 0.01, curve);
            let el = ElementRef::new(kind, &coords, trial).expect("element");
            let n = el.ndof();
            let (mut f, mut k) = (vec![1.0; n], vec![0.0; n * n]);
            internal_force_and_tangent_element(
                &el,
                &vec![0.0; n],
                mat.lame(),
                &mut f,
                Some(&mut k),
            )
            .expect("tangent");
            let (mut ke, mut me) = (vec![0.0; n * n], vec![0.0; n * n]);
            element_matrices(kind, &coords, &mat, trial, &mut ke, &mut me).expect("linear");
            let err = k
                .iter()
                .zip(&ke)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err <= 1e-12 * max_abs(&ke), "{name} trial {trial}: {err:e}");
            assert_eq!(max_abs(&f), 0.0, "{name}: internal force at u = 0");
            worst = worst.max(err / max_abs(&ke));
        }
        println!("{name}: tangent at u = 0 vs linear stiffness, worst relative {worst:.1e}");
    }
}

#[test]
fn stress_stiffness_of_uniaxial_stress_matches_the_closed_form() {
    // Uniform S = sigma e_x e_x on the box [0, L] x [0, b] x [0, c] and the transverse field
    // v = (x / L)^2 e_y (quadratic, exactly represented by TET10): v^T K_sigma v =
    // int sigma (dv/dx)^2 dV = sigma b c int_0^L 4 x^2 / L^4 dx = 4 sigma b c / (3 L). The
    // integrand is a polynomial integrated exactly: equal to round-off (1e-12 relative).
    let (l, b, c, sigma) = (0.5, 0.04, 0.03, 3.0e7);
    let mesh = box_mesh([l, b, c], [4, 2, 2], TetKind::Tet10).expect("mesh");
    let model = RotatingModel::new(
        &mesh,
        steel(),
        axis(),
        DofMap::new(mesh.n_nodes(), &[]).expect("dofs"),
    )
    .expect("model");
    let s = [[sigma, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
    let k = model.stress_stiffness(&|_, _| s).expect("K_sigma");
    let mut v = vec![0.0; 3 * mesh.n_nodes()];
    for (i, x) in mesh.nodes.iter().enumerate() {
        v[3 * i + 1] = (x[0] / l).powi(2);
    }
    let kv = common::mul(&k, &v);
    let energy = common::dot(&v, &kv);
    let exact = 4.0 * sigma * b * c / (3.0 * l);
    println!("uniform stress: v^T K_sigma v {energy:.15e}, closed form {exact:.15e}");
    assert!(
        (energy - exact).abs() <= 1e-12 * exact,
        "{energy} vs {exact}"
    );
    // The element routine with a point-dependent field S = sigma (x / L) e_x e_x: v^T K v =
    // sigma b c int_0^L (x / L) 4 x^2 / L^4 dx = sigma b c / L (cubic integrand, exact).
    let k_lin = model
        .stress_stiffness(&|e, pt| {
            let nodes = mesh.element(e);
            let x: f64 = (0..10)
                .map(|a| pt.values[a] * mesh.nodes[nodes[a]][0])
                .sum();
            [[sigma * x / l, 0.0, 0.0], [0.0; 3], [0.0; 3]]
        })
        .expect("K_sigma");
    let energy = common::dot(&v, &common::mul(&k_lin, &v));
    let exact = sigma * b * c / l;
    println!("linear stress: v^T K_sigma v {energy:.15e}, closed form {exact:.15e}");
    assert!(
        (energy - exact).abs() <= 1e-12 * exact,
        "{energy} vs {exact}"
    );
}

/// A small curved TET10 beam clamped at x = 0, far from the axis point.
fn clamped_curved_beam() -> Mesh {
    let mut mesh = box_mesh([0.3, 0.05, 0.04], [3, 2, 1], TetKind::Tet10).expect("mesh");
    curve_mid_edge_nodes(&mut mesh, 0.02, 9);
    for x in mesh.nodes.iter_mut() {
        x[0] += 0.2;
    }
    mesh
}

fn max_abs_diff(a: &CsMat<f64>, b: &CsMat<f64>) -> f64 {
    let d = a - b;
    d.data().iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn every_term_at_rest_equals_todays_model() {
    // Omega = 0: the static solves return u = 0 at iteration 0 (the load and the residual are
    // exactly zero), and every stiffness (K_e, the tangent at u = 0, K(0) of both kinematics)
    // equals `assemble`'s K restricted, to round-off (1e-12 of max |K|: element values differ
    // in the last bits through the quadrature rule, sums of <= 30 elements); M_spin is `assemble`'s
    // M with its 3x3 blocks m_ab I replaced by m_ab P (same exact mass code: 1e-15 relative).
    let mesh = clamped_curved_beam();
    let mat = steel();
    let axis = axis();
    let dofs = DofMap::new(
        mesh.n_nodes(),
        &fixed_dofs(&mesh, &["xmin"]).expect("fixed"),
    )
    .expect("dofs");
    let model = RotatingModel::new(&mesh, mat, axis, dofs.clone()).expect("model");
    let (k_ref, m_ref) = assemble(&mesh, &mat).expect("assemble");
    let k_ref_free = dofs.restrict(&k_ref);
    let scale = common::max_abs(&k_ref_free);
    let mut solver = CholeskySolver::default();
    let nonlinear = model
        .solve_nonlinear(0.0, &NewtonOptions::default(), &mut solver)
        .expect("solve");
    assert!(nonlinear.displacement.iter().all(|&u| u == 0.0));
    assert!(nonlinear.steps.iter().all(|s| s.iterations.len() == 1));
    let linear = model
        .solve_linearized(0.0, true, &mut solver)
        .expect("solve");
    assert!(linear.displacement.iter().all(|&u| u == 0.0));
    let candidates = [
        (
            "K_e",
            dofs.restrict(&model.linear_stiffness().expect("K_e")),
        ),
        (
            "K(0) nonlinear",
            model.stiffness_at_speed(&nonlinear).expect("K"),
        ),
        ("K(0) linear", model.stiffness_at_speed(&linear).expect("K")),
    ];
    for (name, k) in &candidates {
        let err = max_abs_diff(k, &k_ref_free);
        println!(
            "{name} vs assemble's K: max difference / max |K| = {:.1e}",
            err / scale
        );
        assert!(err <= 1e-12 * scale, "{name}: {err:e} vs max |K| {scale:e}");
    }
    assert_eq!(nonlinear.kinematics, Kinematics::GreenLagrange);
    let spin = model.spin_softening_matrix().expect("M_spin");
    let p = axis.projector();
    let mut worst: f64 = 0.0;
    for (&v, (r, c)) in spin.iter() {
        let m_ab = *m_ref.get(3 * (r / 3), 3 * (c / 3)).expect("same pattern");
        worst = worst.max((v - m_ab * p[r % 3][c % 3]).abs());
    }
    println!(
        "M_spin vs m_ab P from assemble's M: {:.1e} relative",
        worst / common::max_abs(&m_ref)
    );
    assert!(worst <= 1e-15 * common::max_abs(&m_ref), "{worst:e}");
    assert_eq!(spin.nnz(), m_ref.nnz());
}

#[test]
fn stiffness_at_speed_is_exactly_symmetric_and_coriolis_skew_symmetric() {
    // The element matrices are mirrored and scattered in element order: exact symmetry
    // (a_ij == a_ji bitwise), not a tolerance; likewise G = -G^T exactly.
    let mesh = clamped_curved_beam();
    let dofs = DofMap::new(
        mesh.n_nodes(),
        &fixed_dofs(&mesh, &["xmin"]).expect("fixed"),
    )
    .expect("dofs");
    let model = RotatingModel::new(&mesh, steel(), axis(), dofs).expect("model");
    let mut solver = CholeskySolver::default();
    let omega = 3000.0;
    let sol = model
        .solve_nonlinear(omega, &NewtonOptions::default(), &mut solver)
        .expect("solve");
    assert!(sol.displacement.iter().any(|&u| u != 0.0));
    for k in [
        model.stiffness_at_speed(&sol).expect("K"),
        model
            .stiffness_at_speed(
                &model
                    .solve_linearized(omega, false, &mut solver)
                    .expect("lin"),
            )
            .expect("K"),
    ] {
        let kt = k.transpose_view().to_csc();
        assert_eq!(k.data(), kt.data(), "K(Omega) not exactly symmetric");
    }
    let g = model.coriolis_matrix(omega).expect("G");
    let gt = g.transpose_view().to_csc();
    assert!(g.data().iter().zip(gt.data()).all(|(a, b)| *a == -*b));
    assert!(common::max_abs(&g) > 0.0);
}

#[test]
fn global_residual_tangent_matches_finite_differences() {
    // The assembled, restricted r(u) = f_int(u) - f_c(u) against T = K_T(u) - Omega^2 M_spin
    // along random directions at a strongly loaded state (Omega = 1500 rad/s: root stress
    // ~1.8e9 Pa, strain ~1e-2, max |u| = 4 cm; Omega is 0.65 x the lowest bending frequency at
    // rest, so the tangent stays positive definite from the first iteration on), perturbed by
    // 30 % at random. Step h = 1e-6 max |u|: measured error 4.8e-5, 4.8e-7, 4.8e-9, 5.6e-11,
    // 7.2e-10 relative for h = 1e-3 ... 1e-7 max |u| (truncation h^2 of the cubic f_int, then
    // round-off 1 / h), so 1e-8 leaves a factor 100 and catches any wrong term.
    let mesh = clamped_curved_beam();
    let dofs = DofMap::new(
        mesh.n_nodes(),
        &fixed_dofs(&mesh, &["xmin"]).expect("fixed"),
    )
    .expect("dofs");
    let model = RotatingModel::new(&mesh, steel(), axis(), dofs).expect("model");
    let omega = 1500.0;
    let sol = model
        .solve_nonlinear(
            omega,
            &NewtonOptions::default(),
            &mut CholeskySolver::default(),
        )
        .expect("solve");
    let mut rng = Lcg(77);
    let u: Vec<f64> = sol
        .displacement_free
        .iter()
        .map(|&x| x * (1.0 + 0.3 * rng.next()))
        .collect();
    let rt = model.residual_and_tangent(omega, &u).expect("r");
    let scale = max_abs(&u);
    for _ in 0..3 {
        let d: Vec<f64> = (0..u.len()).map(|_| rng.next()).collect();
        let fd = central_difference(
            |v| model.residual_and_tangent(omega, v).expect("r").residual,
            &u,
            &d,
            1e-6 * scale,
        );
        let td = common::mul(&rt.tangent, &d);
        let err = fd
            .iter()
            .zip(&td)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "global r(u) central differences vs tangent: {:.1e} relative",
            err / max_abs(&td)
        );
        assert!(err <= 1e-8 * max_abs(&td), "{err:e} vs {:e}", max_abs(&td));
    }
}

#[test]
fn failed_static_solve_names_the_step_the_speed_and_the_reason() {
    let mesh = clamped_curved_beam();
    // No constraint: the tangent is singular (rigid-body modes), Cholesky fails at step 1 with
    // every cutback: the last attempt is at Omega^2 = 1000^2 / 4 / 2^10, Omega = 15.625 rad/s.
    let free = RotatingModel::new(
        &mesh,
        steel(),
        axis(),
        DofMap::new(mesh.n_nodes(), &[]).expect("dofs"),
    )
    .expect("model");
    let err = free
        .solve_nonlinear(
            1000.0,
            &NewtonOptions::default(),
            &mut CholeskySolver::default(),
        )
        .expect_err("singular");
    match &err {
        RotationError::StaticSolve {
            step: 1,
            omega,
            target_omega,
            cutbacks: 10,
            reason: StopReason::SingularTangent(_),
            history,
        } => {
            assert!((omega - 15.625).abs() < 1e-12, "{omega}");
            assert_eq!(*target_omega, 1000.0);
            assert_eq!(history.len(), 1);
        }
        other => panic!("unexpected {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("load step 1 (Omega = 1.562500e1 rad/s, target 1.000000e3 rad/s)")
            && msg.contains("after 10 cutbacks")
            && msg.contains("singular"),
        "{msg}"
    );
    // One Newton iteration allowed, no cutback: the iteration limit, with the history.
    let dofs = DofMap::new(
        mesh.n_nodes(),
        &fixed_dofs(&mesh, &["xmin"]).expect("fixed"),
    )
    .expect("dofs");
    let model = RotatingModel::new(&mesh, steel(), axis(), dofs).expect("model");
    let options = NewtonOptions {
        load_steps: 2,
        max_iterations: 1,
        max_cutbacks: 0,
        ..NewtonOptions::default()
    };
    let err = model
        .solve_nonlinear(1500.0, &options, &mut CholeskySolver::default())
        .expect_err("limit");
    match &err {
        RotationError::StaticSolve {
            step: 1,
            cutbacks: 0,
            reason: StopReason::MaxIterations { iterations: 1, .. },
            history,
            ..
        } => {
            assert_eq!(history.len(), 2);
            assert!(history[1].correction_norm.is_some_and(|c| c > 0.0));
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(
        err.to_string()
            .contains("no convergence in 1 Newton iterations"),
        "{err}"
    );
}

/// Marching in speed (`solve_nonlinear_from`, as the Campbell diagram does) reaches the state a
/// solve from rest reaches: the equilibrium at a speed does not depend on the path (St
/// Venant-Kirchhoff is hyperelastic and the load conservative for this static problem). Both
/// converge to ||r|| <= 1e-10 ||f_c||, so the displacements agree to about 1e-10 relative;
/// tolerance 1e-8. A start above the target speed, or of another length, is refused.
#[test]
fn marching_in_speed_reaches_the_state_solved_from_rest() {
    let mesh = clamped_curved_beam();
    let dofs = DofMap::new(
        mesh.n_nodes(),
        &fixed_dofs(&mesh, &["xmin"]).expect("fixed"),
    )
    .expect("dofs");
    let model = RotatingModel::new(&mesh, steel(), axis(), dofs).expect("model");
    let options = NewtonOptions {
        load_steps: 1,
        ..NewtonOptions::default()
    };
    let mut solver = CholeskySolver::default();
    let direct = model
        .solve_nonlinear(3000.0, &NewtonOptions::default(), &mut solver)
        .expect("from rest");
    let mut state = None;
    for omega in [1000.0, 2000.0, 3000.0] {
        let next = model
            .solve_nonlinear_from(state.as_ref(), omega, &options, &mut solver)
            .expect("march");
        state = Some(next);
    }
    let marched = state.expect("three speeds");
    let diff: Vec<f64> = marched
        .displacement
        .iter()
        .zip(&direct.displacement)
        .map(|(a, b)| a - b)
        .collect();
    let rel = max_abs(&diff) / max_abs(&direct.displacement);
    assert!(rel < 1e-8, "marched state differs by {rel:e}");
    // Continuing from 3000 rad/s to a lower speed is not a march.
    assert!(model
        .solve_nonlinear_from(Some(&marched), 2000.0, &options, &mut solver)
        .is_err());
}

#[test]
fn global_centrifugal_load_from_the_nodal_mass_equals_the_quadrature() {
    // The static solve's load is Omega^2 P M_nodal (X - p + u) (one sparse product); the
    // element quadrature of the following load is its check. Both integrate the same
    // polynomials exactly, so they agree to round-off of the sums (1e-13 of the largest
    // entry), on a curved TET10 beam far from the axis point and on its TET4 twin, at rest
    // and displaced.
    for kind in [TetKind::Tet10, TetKind::Tet4] {
        let mut mesh = box_mesh([0.3, 0.05, 0.04], [3, 2, 1], kind).expect("mesh");
        if kind == TetKind::Tet10 {
            curve_mid_edge_nodes(&mut mesh, 0.02, 9);
        }
        mesh.nodes.iter_mut().for_each(|x| x[0] += 0.2);
        let dofs = DofMap::new(mesh.n_nodes(), &[]).expect("dofs");
        let model = RotatingModel::new(&mesh, steel(), axis(), dofs).expect("model");
        let n = 3 * mesh.n_nodes();
        let displaced: Vec<f64> = (0..n).map(|i| 1e-3 * (0.37 * i as f64).sin()).collect();
        for u in [vec![0.0; n], displaced] {
            let fast = model.centrifugal_load(900.0, &u).expect("nodal mass");
            let slow = model
                .centrifugal_load_by_quadrature(900.0, &u)
                .expect("quadrature");
            let scale = max_abs(&slow);
            assert!(scale > 0.0);
            let worst = fast
                .iter()
                .zip(&slow)
                .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(worst <= 1e-13 * scale, "{kind:?}: {worst:e} of {scale:e}");
        }
    }
}
