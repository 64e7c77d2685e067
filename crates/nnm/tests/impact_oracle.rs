//! Tests of the exact one-impact oracle (`tests/oracle/impact.rs`) against independent
//! computations: the grazing limit, an event-located nonsmooth flow and a penalty RK4 integrator,
//! Gauss-Legendre quadrature, the harmonic balance of the impulse train, finite differences of
//! the flow map for the monodromy, and the Hamiltonian +1 / energy-extremum relation. Also records
//! the numbers of the 2-DOF chain of issues 12 and 13 (docs/oracle_impact.md).

mod oracle;

use faer::linalg::solvers::Solve;
use faer::Mat;
use nlmodes_nnm::{integrate_penalty, MotionState, System};
use oracle::impact::{gauss_legendre, ImpactChain, ImpactOrbit, TimeOrigin, TransitionKind};

/// Issue 12: M = I, K = [[2, -1], [-1, 2]], stop on DOF 2 (u_2 <= g = 1).
fn chain2(master: usize) -> ImpactChain {
    ImpactChain::new(
        &[vec![1.0, 0.0], vec![0.0, 1.0]],
        &[vec![2.0, -1.0], vec![-1.0, 2.0]],
        &[0.0, 1.0],
        1.0,
        master,
    )
}

/// A general 3-DOF system: non-diagonal M, contact row not along a coordinate.
fn chain3() -> ImpactChain {
    ImpactChain::new(
        &[
            vec![2.0, 0.3, 0.0],
            vec![0.3, 1.0, 0.2],
            vec![0.0, 0.2, 1.5],
        ],
        &[
            vec![3.0, -1.0, 0.0],
            vec![-1.0, 2.5, -1.0],
            vec![0.0, -1.0, 1.2],
        ],
        &[0.2, 0.0, 1.0],
        0.5,
        2,
    )
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

fn mat_max_abs(a: &Mat<f64>) -> f64 {
    let mut m: f64 = 0.0;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            m = m.max(a[(i, j)].abs());
        }
    }
    m
}

/// Amplitude scale of an orbit: max |u| and max |v| over its turning point and impact.
fn orbit_scale(orbit: &ImpactOrbit) -> (f64, f64) {
    let u = max_abs(&orbit.turning_point).max(max_abs(&orbit.impact_displacement));
    (u, max_abs(&orbit.velocity_before_impact).max(1e-300))
}

#[test]
fn grazing_limit_is_the_linear_mode_touching_the_stop() {
    for master in 0..2 {
        let ch = chain2(master);
        let w1 = ch.grazing_omega();
        assert!((w1 - 1.0).abs() < 1e-14);
        let graze = ch.grazing_first_harmonic();
        for eps in [1e-6, 1e-8] {
            let orbit = ch.orbit_at_omega(w1 * (1.0 + eps)).expect("orbit");
            assert!(orbit.admissible, "just above grazing the orbit impacts");
            let c = ch.cosine_coefficients(&orbit, 8, TimeOrigin::Impact);
            // s = pi eps g / b1^2 = 2 pi eps here, and every deviation from the mode is s times an
            // O(1) factor (observed 3.1 eps, the q slope): bound 20 eps.
            let bound = 20.0 * eps;
            for (n, cn) in c.iter().enumerate() {
                for i in 0..2 {
                    let target = if n == 1 { graze[i] } else { 0.0 };
                    assert!(
                        (cn[i] - target).abs() <= bound,
                        "eps {eps}: u_{n}[{i}] = {} vs {target}",
                        cn[i]
                    );
                }
            }
            // Mode 1 with a . u max = g: E = w1^2 (g / b1)^2 / 2 = 1.
            assert!((orbit.energy - 1.0).abs() <= bound, "E = {}", orbit.energy);
            assert!((ch.q(&orbit, TimeOrigin::Impact) - 1.0).abs() <= bound);
        }
        // Below w1 the impact velocity would point away from the stop: no branch there.
        let below = ch.orbit_at_omega(w1 * (1.0 - 1e-6)).expect("orbit");
        assert!(!below.admissible && below.impulse_half < 0.0);
    }
}

#[test]
fn oracle_from_a_solver_system_agrees_with_its_grazing_amplitude() {
    // A contact row whose sign makes phi_1[master] b_1 < 0: the solver's q > 0 branch then
    // touches the stop half a period after cos(w t) = 1.
    for (row, master) in [(1.0, 0), (1.0, 1), (-1.0, 0), (-1.0, 1)] {
        let system = System::new(
            Mat::identity(2, 2),
            Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { -1.0 }),
            Mat::from_fn(1, 2, |_, j| row * j as f64),
            vec![0.7],
            master,
        )
        .expect("system");
        let ch = ImpactChain::from_system(&system);
        let solver_w: Vec<f64> = system.linear_frequencies();
        for (a, b) in solver_w.iter().zip(ch.linear_omegas()) {
            assert!((a - b).abs() <= 1e-12 * b);
        }
        let orbit = ch.orbit_at_omega(1.0 + 1e-9).expect("orbit");
        let q = ch.q_positive_at_grazing(&orbit);
        let graze = system.grazing_amplitude(0).expect("mode").expect("touches");
        // O(eps) from grazing (eps = 1e-9, slope ~3 g): 1e-8 relative.
        assert!(
            (q - graze).abs() <= 1e-8 * graze,
            "row {row}, master {master}: {q} vs {graze}"
        );
    }
}

#[test]
fn orbit_returns_to_itself_under_the_event_located_flow() {
    let cases = [
        (chain2(1), vec![1.001, 1.01, 1.1, 1.2, 1.3, 1.4, 1.42]),
        (chain3(), vec![1.01, 1.05, 1.1]),
    ];
    for (ch, ratios) in &cases {
        for &r in ratios {
            let orbit = ch
                .orbit_at_omega(r * ch.grazing_omega())
                .expect("orbit exists");
            assert!(orbit.admissible, "w/w1 = {r}");
            let (su, sv) = orbit_scale(&orbit);
            let zero = vec![0.0; ch.dofs()];
            let (u, v, impacts) = ch.nonsmooth_flow(&orbit.turning_point, &zero, orbit.period);
            // Exact flight + impact time to machine precision: only round-off (1e-13 relative)
            // separates the end state from the start; 1e-10 leaves margin for large amplitudes.
            for i in 0..ch.dofs() {
                assert!(
                    (u[i] - orbit.turning_point[i]).abs() <= 1e-10 * su,
                    "w/w1 = {r}: {u:?} vs {:?}, impacts {impacts:?} tau {}",
                    orbit.turning_point,
                    orbit.tau
                );
                assert!(v[i].abs() <= 1e-10 * sv, "w/w1 = {r}: v = {v:?}");
            }
            assert_eq!(impacts.len(), 1, "one impact per period, w/w1 = {r}");
            assert!((impacts[0] - orbit.tau).abs() <= 1e-12 * orbit.tau);
            // The orbit's own state function agrees with the flow at an arbitrary time.
            let t = 0.37 * orbit.period;
            let (ue, ve) = ch.state_at(&orbit, t, TimeOrigin::TurningPoint);
            let (uf, vf, _) = ch.nonsmooth_flow(&orbit.turning_point, &zero, t);
            for i in 0..ch.dofs() {
                assert!((ue[i] - uf[i]).abs() <= 1e-10 * su);
                assert!((ve[i] - vf[i]).abs() <= 1e-10 * sv);
            }
        }
    }
}

/// Max-norm state error after one period of the penalty RK4 integration from the turning point.
fn penalty_period_error(ch: &ImpactChain, orbit: &ImpactOrbit, penalty: f64) -> f64 {
    let system = System::new(
        Mat::identity(2, 2),
        Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { -1.0 }),
        Mat::from_fn(1, 2, |_, j| j as f64),
        vec![ch.gap()],
        1,
    )
    .expect("system");
    // h w_max = 0.1 (w_max ~ sqrt(penalty)): RK4 error (h w)^4 / 120 per radian is ~1e-6 of the
    // contact phase, far below the penalty model error.
    let steps = (orbit.period * penalty.sqrt() / 0.1).ceil() as usize;
    let start = MotionState {
        u: orbit.turning_point.clone(),
        v: vec![0.0; 2],
    };
    let end = integrate_penalty(&system, &[penalty], &start, orbit.period, steps).expect("rk4");
    let (su, _) = orbit_scale(orbit);
    (0..2)
        .map(|i| (end.u[i] - start.u[i]).abs().max(end.v[i].abs()))
        .fold(0.0, f64::max)
        / su
}

#[test]
fn penalty_integration_converges_to_the_exact_orbit() {
    let ch = chain2(1);
    let orbit = ch.orbit_at_omega(1.2).expect("orbit");
    let errors: Vec<f64> = [1e4, 1e6, 1e8]
        .iter()
        .map(|&kc| penalty_period_error(&ch, &orbit, kc))
        .collect();
    println!("penalty kc = 1e4, 1e6, 1e8: relative state error after T = {errors:?}");
    // The penalty contact lasts pi / sqrt(kc |b|^2) instead of 0: the state error after a period
    // is O(kc^-1/2), a factor 10 per factor 100 in kc (>= 5 required), and below 1e-2 at 1e8.
    for pair in errors.windows(2) {
        assert!(pair[1] < pair[0] / 5.0, "errors {errors:?}");
    }
    assert!(errors[2] < 1e-2, "errors {errors:?}");
}

#[test]
fn cosine_coefficients_match_quadrature_and_the_impulse_train_balance() {
    let harmonics = 12;
    let (nodes, weights) = gauss_legendre(64);
    for (ch, w) in [(chain2(0), 1.03), (chain2(1), 1.3), (chain3(), 1.05)] {
        let orbit = ch.orbit_at_omega(w * ch.grazing_omega()).expect("orbit");
        let n = ch.dofs();
        let (su, _) = orbit_scale(&orbit);
        for origin in [TimeOrigin::TurningPoint, TimeOrigin::Impact] {
            let exact = ch.cosine_coefficients(&orbit, harmonics, origin);
            // One smooth (trigonometric) piece per period between impacts: [-tau, tau] for the
            // turning-point origin, [0, T] for the impact origin. 64-point Gauss-Legendre is exact
            // to round-off for w_k tau and n pi below ~40.
            let (t0, t1) = match origin {
                TimeOrigin::TurningPoint => (-orbit.tau, orbit.tau),
                TimeOrigin::Impact => (0.0, orbit.period),
            };
            for (h, exact_h) in exact.iter().enumerate() {
                let mut quad = vec![0.0; n];
                for (x, wq) in nodes.iter().zip(&weights) {
                    let t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * x;
                    let (u, _) = ch.state_at(&orbit, t, origin);
                    let c = (h as f64 * orbit.omega * t).cos() * wq * 0.5 * (t1 - t0);
                    for i in 0..n {
                        quad[i] += u[i] * c;
                    }
                }
                let factor = if h == 0 { 1.0 } else { 2.0 } / orbit.period;
                for i in 0..n {
                    let err = (quad[i] * factor - exact_h[i]).abs();
                    assert!(err <= 1e-12 * su, "{origin:?} u_{h}[{i}] error {err:e}");
                }
            }
        }
        assert_impulse_train_balance(&ch, &orbit, harmonics);
    }
}

/// Harmonic balance of M u'' + K u = -2 s a sum_j delta(t - tau - j T) (turning-point origin):
/// (K - n^2 w^2 M) u_n = -(2 s / tau) (-1)^n a for n >= 1 and K u_0 = -(s / tau) a.
fn assert_impulse_train_balance(ch: &ImpactChain, orbit: &ImpactOrbit, harmonics: usize) {
    let n = ch.dofs();
    let (m, k, a) = (ch.mass(), ch.stiffness(), ch.contact_row());
    let coefficients = ch.cosine_coefficients(orbit, harmonics, TimeOrigin::TurningPoint);
    for (h, un) in coefficients.iter().enumerate() {
        let nw2 = (h as f64 * orbit.omega).powi(2);
        let sign = if h % 2 == 0 { 1.0 } else { -1.0 };
        let force = if h == 0 { -1.0 } else { -2.0 * sign } * orbit.impulse_half / orbit.tau;
        let scale = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (k[(i, j)].abs() + nw2 * m[(i, j)].abs()) * un[j].abs())
                    .sum::<f64>()
            })
            .fold(force.abs(), f64::max);
        for i in 0..n {
            let lhs: f64 = (0..n).map(|j| (k[(i, j)] - nw2 * m[(i, j)]) * un[j]).sum();
            assert!(
                (lhs - force * a[i]).abs() <= 1e-12 * scale,
                "harmonic {h}, row {i}: {lhs} vs {}",
                force * a[i]
            );
        }
    }
}

#[test]
fn closed_forms_of_q_and_energy_match_the_orbit_and_finite_differences() {
    for ch in [chain2(0), chain2(1), chain3()] {
        for r in [1.01, 1.03, 1.08] {
            let w = r * ch.grazing_omega();
            let orbit = ch.orbit_at_omega(w).expect("orbit");
            let (q, dq) = ch.q_impact_closed_form(w);
            let (e, de) = ch.energy_closed_form(w);
            assert!((q - ch.q(&orbit, TimeOrigin::Impact)).abs() <= 1e-12 * q.abs().max(1.0));
            assert!((q + ch.q(&orbit, TimeOrigin::TurningPoint)).abs() <= 1e-12 * q.abs().max(1.0));
            assert!((e - orbit.energy).abs() <= 1e-12 * e);
            // Energy from M and K at arbitrary times, before and after the impact.
            for t in [0.3 * orbit.tau, 1.7 * orbit.tau] {
                let (u, v) = ch.state_at(&orbit, t, TimeOrigin::TurningPoint);
                assert!((ch.energy_of_state(&u, &v) - e).abs() <= 1e-12 * e);
            }
            // Central differences, step 1e-5: truncation ~1e-10 f''', round-off ~1e-11.
            let h = 1e-5 * w;
            let fd_q =
                (ch.q_impact_closed_form(w + h).0 - ch.q_impact_closed_form(w - h).0) / (2.0 * h);
            let fd_e =
                (ch.energy_closed_form(w + h).0 - ch.energy_closed_form(w - h).0) / (2.0 * h);
            assert!(
                (fd_q - dq).abs() <= 1e-6 * (dq.abs() + q.abs()),
                "dq {dq} fd {fd_q}"
            );
            assert!(
                (fd_e - de).abs() <= 1e-6 * (de.abs() + e),
                "dE {de} fd {fd_e}"
            );
        }
    }
}

/// Central finite-difference Jacobian of the one-period nonsmooth flow map from the turning point.
fn flow_map_jacobian(ch: &ImpactChain, orbit: &ImpactOrbit, step: f64) -> Mat<f64> {
    let n = ch.dofs();
    let x0: Vec<f64> = orbit
        .turning_point
        .iter()
        .copied()
        .chain(std::iter::repeat_n(0.0, n))
        .collect();
    let flow = |x: &[f64]| {
        let (u, v, impacts) = ch.nonsmooth_flow(&x[..n], &x[n..], orbit.period);
        assert_eq!(impacts.len(), 1, "perturbed orbit keeps one impact");
        [u, v].concat()
    };
    let mut jac = Mat::zeros(2 * n, 2 * n);
    for j in 0..2 * n {
        let (mut plus, mut minus) = (x0.clone(), x0.clone());
        plus[j] += step;
        minus[j] -= step;
        let (fp, fm) = (flow(&plus), flow(&minus));
        for i in 0..2 * n {
            jac[(i, j)] = (fp[i] - fm[i]) / (2.0 * step);
        }
    }
    jac
}

#[test]
fn monodromy_matches_finite_differences_and_is_symplectic() {
    let cases = [
        (chain2(1), 1.02),
        (chain2(1), 1.1),
        (chain2(0), 1.35),
        (chain3(), 1.05),
    ];
    for (ch, r) in &cases {
        let orbit = ch.orbit_at_omega(r * ch.grazing_omega()).expect("orbit");
        let n = ch.dofs();
        let mon = ch.monodromy_at_turning_point(&orbit);
        let (su, _) = orbit_scale(&orbit);
        let fd = flow_map_jacobian(ch, &orbit, 1e-6 * su);
        let scale = mat_max_abs(&mon);
        let err = mat_max_abs(&(&fd - &mon));
        println!(
            "w/w1 = {r}, n = {n}: |FD - monodromy| / |monodromy| = {:.2e}",
            err / scale
        );
        // Step 1e-6 |u|: truncation ~1e-12 x third derivatives; round-off ~1e-16 / 1e-6 times the
        // amplification of the flow and of the impact-time error: observed 1e-8 to 8e-8 relative.
        // Bound 1e-6; a wrong saltation term gives O(1) (checked just below).
        assert!(
            err <= 1e-6 * scale,
            "w/w1 = {r}: error {err:e}, scale {scale}"
        );
        // The finite differences do see the saltation correction: the bare jump Jacobian
        // G = diag(I, R) in its place misses them by O(1).
        let bare = &half_flow(ch, &orbit) * jump_jacobian(ch) * &half_flow(ch, &orbit);
        let bare_err = mat_max_abs(&(&fd - &bare));
        println!(
            "  without the saltation correction: {:.2e}",
            bare_err / scale
        );
        assert!(bare_err > 1e-2 * scale);
        // Similar to the monodromy starting after the impact: exp(A tau) S exp(A T) = mon exp(A tau).
        let after = ch.monodromy_after_impact(&orbit);
        let half = ch.free_flow(orbit.tau);
        let conj_err = mat_max_abs(&(&half * &after - &mon * &half));
        assert!(conj_err <= 1e-12 * scale * mat_max_abs(&half).max(1.0));
        assert_symplectic_structure(ch, &orbit, &mon);
    }
}

fn half_flow(ch: &ImpactChain, orbit: &ImpactOrbit) -> Mat<f64> {
    ch.free_flow(orbit.tau)
}

/// G = diag(I, R), R = I - 2 M^-1 a a^T / (a^T M^-1 a), from M and a directly.
fn jump_jacobian(ch: &ImpactChain) -> Mat<f64> {
    let n = ch.dofs();
    let a = Mat::from_fn(n, 1, |i, _| ch.contact_row()[i]);
    let minv_a = ch.mass().partial_piv_lu().solve(&a);
    let a_minv_a: f64 = (0..n).map(|i| a[(i, 0)] * minv_a[(i, 0)]).sum();
    Mat::from_fn(2 * n, 2 * n, |i, j| {
        let identity = if i == j { 1.0 } else { 0.0 };
        if i >= n && j >= n {
            identity - 2.0 * minv_a[(i - n, 0)] * a[(j - n, 0)] / a_minv_a
        } else if i < n && j < n {
            identity
        } else {
            0.0
        }
    })
}

/// det = 1, M^T Omega M = Omega with Omega = [[0, M], [-M, 0]] (the mass enters through p = M v),
/// the flow direction is an eigenvector for +1, multipliers in reciprocal pairs, sum of the
/// nontrivial rho equals tr/2 - 1.
fn assert_symplectic_structure(ch: &ImpactChain, orbit: &ImpactOrbit, mon: &Mat<f64>) {
    let n = ch.dofs();
    let scale = mat_max_abs(mon);
    let det = mon.determinant();
    assert!(
        (det - 1.0).abs() <= 1e-12 * scale.powi(2 * n as i32),
        "det = {det}"
    );
    let mass = ch.mass();
    let omega = Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
        (true, false) => mass[(i, j - n)],
        (false, true) => -mass[(i - n, j)],
        _ => 0.0,
    });
    let defect = mat_max_abs(&(mon.transpose() * &omega * mon - &omega));
    assert!(
        defect <= 1e-11 * scale * scale * mat_max_abs(&omega),
        "symplectic defect {defect:e}"
    );
    // Flow direction f(x0) = (0, -M^-1 K u0) at the turning point: mon f = f.
    let accel = ch.turning_point_acceleration(orbit);
    let f: Vec<f64> = std::iter::repeat_n(0.0, n).chain(accel).collect();
    for i in 0..2 * n {
        let mf: f64 = (0..2 * n).map(|j| mon[(i, j)] * f[j]).sum();
        assert!((mf - f[i]).abs() <= 1e-11 * scale * max_abs(&f));
    }
    let mu = ch.multipliers(orbit);
    let near_one = mu
        .iter()
        .filter(|m| (*m - faer::c64::new(1.0, 0.0)).norm() < 1e-6)
        .count();
    assert!(near_one >= 2, "a +1 pair: {mu:?}");
    for m in &mu {
        let partner = mu
            .iter()
            .map(|p| (p * m - faer::c64::new(1.0, 0.0)).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(partner <= 1e-6, "no reciprocal partner for {m}: {mu:?}");
    }
    let trace: f64 = (0..2 * n).map(|i| mon[(i, i)]).sum();
    let rho_sum: f64 = ch
        .floquet_pairs_from_eigenvalues(orbit)
        .iter()
        .map(|r| r.re)
        .sum();
    assert!(
        (rho_sum - (0.5 * trace - 1.0)).abs() <= 1e-6 * scale,
        "rho sum {rho_sum}, tr {trace}"
    );
}

/// Prints q (both masters), energy and multipliers along the 2-DOF branch.
fn print_branch_table(ch0: &ImpactChain, ch1: &ImpactChain) {
    println!("| w | q (master 0) | q (master 1) | E | rho = (mu + 1/mu)/2 | max |mu| | stable |");
    println!("|---|---|---|---|---|---|---|");
    for i in 1..=50 {
        let w = 1.0 + 0.01 * i as f64;
        let orbit = ch0.orbit_at_omega(w).expect("orbit");
        if !orbit.admissible {
            println!(
                "| {w:.2} | - | - | - | (no admissible orbit: s = {:.3}) | - | - |",
                orbit.impulse_half
            );
            continue;
        }
        let rho = ch0.floquet_pairs(&orbit)[0].re;
        println!(
            "| {w:.2} | {:.6} | {:.6} | {:.6} | {rho:.6} | {:.6} | {} |",
            ch0.q(&orbit, TimeOrigin::Impact),
            ch1.q(&orbit, TimeOrigin::Impact),
            orbit.energy,
            ch0.max_multiplier_modulus(&orbit),
            ch0.instability(&orbit) <= 0.0
        );
    }
}

#[test]
fn two_dof_branch_fold_and_stability() {
    let (ch0, ch1) = (chain2(0), chain2(1));
    let w1 = ch0.grazing_omega();
    let w_end = ch0
        .infinite_energy_omega(1.3, 1.5)
        .expect("D(pi/w) = 0 below 1.5");
    // Master 0 (free DOF): q leaves grazing (q = g = 1) downward, folds, then stiffens.
    let fold = ch0
        .fold_near(w1 + 1e-9, 1.2)
        .expect("fold of q(w) for master 0");
    println!(
        "master 0 fold: w = {:.12}, q = {:.12}",
        fold.omega, fold.q_impact
    );
    println!("branch ends (energy -> infinity) at w = {w_end:.12}");
    for (name, ch) in [("master 0", &ch0), ("master 1", &ch1)] {
        let (q, slope) = ch.q_impact_closed_form(w1 * (1.0 + 1e-7));
        println!("{name}: at grazing q = {q:.9}, dq/dw = {slope:.9}");
    }
    println!(
        "master 0: q back to 1 (grazing value) at w = {:?}",
        ch0.omegas_at_q(1.0, 1.01, 1.2, 100)
    );
    assert!(fold.omega > w1 && fold.omega < 1.2 * w1 && fold.q_impact < 1.0);
    let q0 = |w: f64| ch0.q_impact_closed_form(w).0;
    let before: Vec<f64> = (0..=20)
        .map(|i| q0(w1 + 1e-9 + (fold.omega - w1) * i as f64 / 20.0))
        .collect();
    let after: Vec<f64> = (0..=20)
        .map(|i| q0(fold.omega + (1.2 - fold.omega) * i as f64 / 20.0))
        .collect();
    assert!((before[0] - 1.0).abs() < 1e-6, "q at grazing {}", before[0]);
    assert!(
        before.windows(2).all(|p| p[1] < p[0]),
        "q decreases to the fold: {before:?}"
    );
    assert!(
        after.windows(2).all(|p| p[1] > p[0]),
        "q increases after the fold: {after:?}"
    );
    // Master 1 (contact DOF): q decreases monotonically from 1 at grazing, through 0 at
    // w = sqrt(2) (the driving-point receptance vanishes), to -infinity at w_end: no fold.
    assert!(ch1.fold_near(w1 + 1e-9, w_end - 1e-9).is_none());
    let slopes: Vec<f64> = (1..200)
        .map(|i| {
            ch1.q_impact_closed_form(w1 + (w_end - w1) * i as f64 / 200.0)
                .1
        })
        .collect();
    assert!(slopes.iter().all(|s| *s < 0.0), "dq/dw < 0 for master 1");
    assert!(ch1.q_impact_closed_form(2f64.sqrt()).0.abs() < 1e-12);
    // Admissible exactly on (w1, w_end).
    for i in 1..100 {
        let w = w1 + (1.5 - w1) * i as f64 / 100.0;
        let orbit = ch0.orbit_at_omega(w).expect("orbit");
        assert_eq!(orbit.admissible, w < w_end, "w = {w}");
    }
    // Inverse look-up: q between the fold and grazing is reached twice, above grazing once.
    let q_mid = 0.5 * (fold.q_impact + 1.0);
    let roots = ch0.omegas_at_q(q_mid, w1 + 1e-9, 1.2, 400);
    assert_eq!(roots.len(), 2, "{roots:?}");
    assert!(roots[0] < fold.omega && roots[1] > fold.omega);
    for w in roots {
        assert!((ch0.q_impact_closed_form(w).0 - q_mid).abs() < 1e-12);
    }
    assert_two_dof_stability(&ch0, w_end);
    print_branch_table(&ch0, &ch1);
}

/// Unstable from grazing to a +1 transition at the energy minimum, stable up to a period
/// doubling, unstable (a multiplier below -1) up to the end of the branch.
fn assert_two_dof_stability(ch: &ImpactChain, w_end: f64) {
    let transitions = ch.stability_transitions(1.0 + 1e-6, w_end - 1e-6, 400);
    println!("transitions: {transitions:?}");
    assert_eq!(transitions.len(), 2, "{transitions:?}");
    let (plus_one, doubling) = (transitions[0], transitions[1]);
    assert_eq!(plus_one.kind, TransitionKind::PlusOne);
    assert!(!plus_one.stable_below);
    assert_eq!(doubling.kind, TransitionKind::PeriodDoubling);
    assert!(doubling.stable_below);
    // Conservative family: the nontrivial pair passes +1 where dE/dw = 0 (here a minimum).
    let (w_min, e_min) = ch.energy_extremum(1.0 + 1e-6, 1.2).expect("energy minimum");
    println!("energy minimum: w = {w_min:.12}, E = {e_min:.12}");
    println!(
        "+1 transition: w = {:.12}; period doubling: w = {:.12}",
        plus_one.omega, doubling.omega
    );
    assert!(
        (plus_one.omega - w_min).abs() <= 1e-9,
        "{} vs {w_min}",
        plus_one.omega
    );
    // At the period doubling rho = tr/2 - 1 = -1: a multiplier pair at -1.
    let orbit = ch.orbit_at_omega(doubling.omega).expect("orbit");
    let mu = ch.multipliers(&orbit);
    assert!(
        mu.iter()
            .filter(|m| (*m + faer::c64::new(1.0, 0.0)).norm() < 1e-4)
            .count()
            == 2,
        "{mu:?}"
    );
    for (w, stable) in [
        (1.01, false),
        (1.1, true),
        (1.3, true),
        (1.35, false),
        (1.42, false),
    ] {
        let orbit = ch.orbit_at_omega(w).expect("orbit");
        let max_mu = ch.max_multiplier_modulus(&orbit);
        assert_eq!(max_mu <= 1.0 + 1e-6, stable, "w = {w}: max |mu| = {max_mu}");
    }
}
