//! The stability column of `nlmodes forced` on the coarse blade against time integration of
//! the same reduced model (issue 22 item 5, issue 24's independent monodromy): an oracle that
//! shares nothing with the Floquet computation but the model.
//!
//! The penalty law makes the equation of motion
//!   M u'' + C u' + K u + A^T kc (A u - g0)_+ = F e_master cos(W t)
//! an ODE; it is integrated here by the trapezoidal rule (Newmark's average acceleration, 2000
//! steps per period, the contact set of each step solved implicitly), unconditionally stable
//! where an explicit scheme would need 1e5 steps per period (the reduced model reaches
//! w_max = 2e7 rad/s), from the state of the harmonic-balance orbit at t = 0, for `PERIODS`
//! periods. d_k = ||x((k+1)T) - x(kT)|| (relative, x = (u, v / W)):
//!
//! * where the command says stable (|mu| < 0.99), d_k never exceeds 1.5 d_0 and ends below d_0
//!   (it decays by |mu| per period: measured 0.30-0.36 over 60 periods for |mu| = 0.980-0.983,
//!   against 0.98^60 = 0.30);
//! * where it says unstable (|mu| > 1.05), d_k grows past 10 d_0 (1.05^59 = 18);
//! * where it says undetermined, its own period check found the HB orbit off the flow's periodic
//!   orbit, and so does this integration: d_0 > 1e-3.
//!
//! Points in contact get their verdict on the massless contact boundary (docs/STABILITY.md,
//! Sec. 9): the penalty contact of the Craig-Bampton contact nodes, which carry mass, rings far
//! above the N harmonics (d_0 = 1e-2..1.6e-1 here), so the massive model's flow is not the one
//! the verdict is about. For those points the oracle is the boundary model's own flow integrated
//! by RK4 (`nlmodes_boundary::rk4`: the contact problem solved at every stage, no pieces, no
//! eigenvectors) from the shot orbit's start: its monodromy must give the command's largest |mu|
//! to 1e-4 and bring the orbit back to its start to 1e-6.

use std::process::Command;

mod common;

use faer::Mat;
use nlmodes_forced::Damping;
use nlmodes_nnm::System;

const PERIODS: usize = 60;
/// Trapezoidal steps per period (3.1e-3 rad of the fundamental: its phase error per period is
/// (w dt)^2 / 12 ~ 1e-6).
const STEPS_PER_PERIOD: usize = 2000;

fn ok(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .arg("--quiet")
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success() || out.status.code() == Some(3),
        "nlmodes {args:?}:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The penalty equation integrated by the trapezoidal rule (Newmark, gamma = 1/2, beta = 1/4:
/// unconditionally stable, second order), the contact state of each step solved implicitly by a
/// semi-smooth Newton iteration on the set S of rows in contact:
///   (K_eff + kc A_S^T A_S) u_{n+1} = r_n + kc A_S^T g0_S,  K_eff = K + 2 C / dt + 4 M / dt^2.
/// The factorizations are cached per contact set (bounded: cleared past 256 sets).
struct Flow {
    m: Mat<f64>,
    c: Mat<f64>,
    k_eff: Mat<f64>,
    minv: Mat<f64>,
    k: Mat<f64>,
    rows: Mat<f64>,
    g0: Vec<f64>,
    kc: f64,
    force: Vec<f64>,
    omega: f64,
    dt: f64,
    cache: std::collections::HashMap<Vec<bool>, faer::linalg::solvers::PartialPivLu<f64>>,
}

/// (u, v, a) of the trapezoidal rule.
struct State {
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
}

fn mul(a: &Mat<f64>, x: &[f64]) -> Vec<f64> {
    (0..a.nrows())
        .map(|i| (0..a.ncols()).map(|j| a[(i, j)] * x[j]).sum())
        .collect()
}

impl Flow {
    #[allow(clippy::too_many_arguments)]
    fn new(
        minv: &Mat<f64>,
        m: &Mat<f64>,
        k: &Mat<f64>,
        c: &Mat<f64>,
        rows: Mat<f64>,
        g0: Vec<f64>,
        kc: f64,
        force: &[f64],
        omega: f64,
    ) -> Self {
        let dt = 2.0 * std::f64::consts::PI / omega / STEPS_PER_PERIOD as f64;
        let k_eff = Mat::from_fn(k.nrows(), k.ncols(), |i, j| {
            k[(i, j)] + 2.0 * c[(i, j)] / dt + 4.0 * m[(i, j)] / (dt * dt)
        });
        Self {
            m: m.clone(),
            c: c.clone(),
            k_eff,
            minv: minv.clone(),
            k: k.clone(),
            rows,
            g0,
            kc,
            force: force.to_vec(),
            omega,
            dt,
            cache: Default::default(),
        }
    }

    fn contact_force(&self, u: &[f64]) -> Vec<f64> {
        let n = u.len();
        let mut f = vec![0.0; n];
        for r in 0..self.rows.nrows() {
            let gap = (0..n).map(|j| self.rows[(r, j)] * u[j]).sum::<f64>() - self.g0[r];
            if gap > 0.0 {
                (0..n).for_each(|i| f[i] += self.rows[(r, i)] * self.kc * gap);
            }
        }
        f
    }

    /// The state at t = 0 from (u, v): a from the equation of motion.
    fn start(&self, u: Vec<f64>, v: Vec<f64>) -> State {
        let (ku, cv, fc) = (mul(&self.k, &u), mul(&self.c, &v), self.contact_force(&u));
        let rhs: Vec<f64> = (0..u.len())
            .map(|i| self.force[i] - ku[i] - cv[i] - fc[i])
            .collect();
        let a = mul(&self.minv, &rhs);
        State { u, v, a }
    }

    fn step(&mut self, s: &State, t_next: f64) -> State {
        let (n, dt) = (s.u.len(), self.dt);
        let mu: Vec<f64> = (0..n)
            .map(|i| 4.0 / (dt * dt) * s.u[i] + 4.0 / dt * s.v[i] + s.a[i])
            .collect();
        let cu: Vec<f64> = (0..n).map(|i| 2.0 / dt * s.u[i] + s.v[i]).collect();
        let (mm, cc) = (mul(&self.m, &mu), mul(&self.c, &cu));
        let cos = (self.omega * t_next).cos();
        let r: Vec<f64> = (0..n)
            .map(|i| self.force[i] * cos + mm[i] + cc[i])
            .collect();
        let mut u = s.u.clone();
        for _ in 0..30 {
            let active: Vec<bool> = (0..self.rows.nrows())
                .map(|j| (0..n).map(|q| self.rows[(j, q)] * u[q]).sum::<f64>() > self.g0[j])
                .collect();
            let mut rhs = r.clone();
            for (j, _) in active.iter().enumerate().filter(|(_, a)| **a) {
                (0..n).for_each(|i| rhs[i] += self.kc * self.rows[(j, i)] * self.g0[j]);
            }
            let next = self.solve(&active, &rhs);
            let same = (0..self.rows.nrows()).all(|j| {
                ((0..n).map(|q| self.rows[(j, q)] * next[q]).sum::<f64>() > self.g0[j]) == active[j]
            });
            u = next;
            if same {
                break;
            }
        }
        let a: Vec<f64> = (0..n)
            .map(|i| 4.0 / (dt * dt) * (u[i] - s.u[i]) - 4.0 / dt * s.v[i] - s.a[i])
            .collect();
        let v: Vec<f64> = (0..n)
            .map(|i| s.v[i] + dt / 2.0 * (s.a[i] + a[i]))
            .collect();
        State { u, v, a }
    }

    fn solve(&mut self, active: &[bool], rhs: &[f64]) -> Vec<f64> {
        if self.cache.len() > 256 {
            self.cache.clear();
        }
        if !self.cache.contains_key(active) {
            let n = rhs.len();
            let mut a = self.k_eff.clone();
            for (j, _) in active.iter().enumerate().filter(|(_, a)| **a) {
                for p in 0..n {
                    for q in 0..n {
                        a[(p, q)] += self.kc * self.rows[(j, p)] * self.rows[(j, q)];
                    }
                }
            }
            self.cache.insert(active.to_vec(), a.partial_piv_lu());
        }
        use faer::linalg::solvers::Solve;
        let b = Mat::from_fn(rhs.len(), 1, |i, _| rhs[i]);
        let x = self.cache[active].solve(&b);
        (0..rhs.len()).map(|i| x[(i, 0)]).collect()
    }

    /// (u, v) after one period from `s` (the forcing is T-periodic; t restarts at 0).
    fn period(&mut self, s: State) -> State {
        let mut s = s;
        for k in 1..=STEPS_PER_PERIOD {
            s = self.step(&s, k as f64 * self.dt);
        }
        s
    }
}

/// Highest frequency of (K + kc A^T A, M) (rad/s).
fn highest_frequency(system: &System, kc: f64) -> f64 {
    let n = system.n_dofs();
    let rows = system.contact_rows();
    let k = Mat::from_fn(n, n, |i, j| {
        system.stiffness()[(i, j)]
            + kc * (0..rows.nrows())
                .map(|r| rows[(r, i)] * rows[(r, j)])
                .sum::<f64>()
    });
    let stiff = System::new(
        system.mass().to_owned(),
        k,
        rows.to_owned(),
        system.gaps().to_vec(),
        0,
    )
    .unwrap();
    stiff
        .linear_frequencies()
        .iter()
        .copied()
        .fold(0.0, f64::max)
}

#[test]
fn stability_verdicts_of_the_blade_agree_with_time_integration() {
    let dir = tempfile::tempdir().unwrap();
    let model_dir = common::coarse_blade_model(dir.path());
    let settings = dir.path().join("forced.toml");
    // At the [forced] defaults of N's convergence (the coarse blade has 24 contact rows:
    // "retrace", the curve at N = 16 here). The RK4 below integrates the boundary model of each
    // orbit's own N: session 17 built it at N = 8 for every orbit, so an orbit solved at a
    // larger N (shot on a boundary with more dynamic modes) was compared with another model
    // (|mu| 1.13653 against 1.13857 at W = 1802.10 rad/s); with the orbit's N they agree to 1e-6.
    std::fs::write(
        &settings,
        "[forced]\nharmonics = 8\nrange = [0.95, 1.15]\nlevels = [3.0]\npenalty_factor = 10\n",
    )
    .unwrap();
    let out = dir.path().join("frf");
    ok(&[
        "forced",
        model_dir.to_str().unwrap(),
        "--settings",
        settings.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("frf.json")).unwrap()).unwrap();
    let model = nlmodes_modal::ReducedModel::read(&model_dir).unwrap();
    let system = System::new(
        model.m.clone(),
        model.k.clone(),
        model.contact_rows(),
        model.gaps(),
        model.master.dof,
    )
    .unwrap();
    let n = system.n_dofs();
    let kc = json["penalty_stiffness_n_per_m"].as_f64().unwrap();
    let curve = &json["curves"][0];
    let mut force = vec![0.0; n];
    force[json["excitation"].as_u64().unwrap() as usize] = curve["force_n"].as_f64().unwrap();
    let minv = {
        use faer::linalg::solvers::Solve;
        model
            .m
            .llt(faer::Side::Lower)
            .unwrap()
            .solve(Mat::<f64>::identity(n, n))
    };
    let c = Damping::ModalRatios(vec![0.003]).matrix(&system).unwrap();
    eprintln!(
        "w_max = {:.4e} rad/s: an explicit scheme would need ~1e5 steps per period",
        highest_frequency(&system, kc)
    );
    let orbits = curve["orbits"].as_array().unwrap();
    let mut checked = (0, 0, 0, 0);
    // Eight points spread over the curve, away from |mu| = 1.
    let picks: Vec<usize> = (0..orbits.len()).step_by(orbits.len() / 16).collect();
    for &i in &picks {
        let o = &orbits[i];
        let mu = o["largest_multiplier"].as_f64().unwrap_or(f64::NAN);
        let word = o["stability"].as_str().unwrap();
        if word != "undetermined" && (0.99..=1.05).contains(&mu) {
            continue;
        }
        let omega = o["omega"].as_f64().unwrap();
        let coeff: Vec<Vec<f64>> = serde_json::from_value(o["coefficients"].clone()).unwrap();
        if let Some(shift) = o["boundary_shift"].as_f64() {
            let load = nlmodes_forced::Load::fundamental(force.clone());
            let harmonics = o["harmonics"].as_u64().unwrap() as usize;
            let orbit = (omega, harmonics, coeff.as_slice());
            boundary_point(&system, &c, &load, kc, orbit, mu, word, shift);
            checked.3 += 1;
            continue;
        }
        let u: Vec<f64> = coeff
            .iter()
            .map(|c| nlmodes_hb::FullBasis::value_at(c, 0.0))
            .collect();
        let v: Vec<f64> = coeff
            .iter()
            .map(|c| nlmodes_hb::FullBasis::rate_at(c, omega, 0.0))
            .collect();
        let mut flow = Flow::new(
            &minv,
            &model.m,
            &model.k,
            &c,
            model.contact_rows(),
            model.gaps(),
            kc,
            &force,
            omega,
        );
        // The state (u, v / W): both in metres.
        let scaled = |s: &State| -> Vec<f64> {
            s.u.iter()
                .copied()
                .chain(s.v.iter().map(|v| v / omega))
                .collect()
        };
        let mut state = flow.start(u, v);
        let scale: f64 = scaled(&state).iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut distance = Vec::new();
        for _ in 0..PERIODS {
            let before = scaled(&state);
            state = flow.period(state);
            let after = scaled(&state);
            distance.push(
                after
                    .iter()
                    .zip(&before)
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    / scale,
            );
        }
        // The first period's change is the truncation-level mismatch of the HB start; a stable
        // orbit's changes shrink from it by |mu| per period, an unstable one's grow from it until
        // the motion leaves for another attractor.
        let first = distance[0];
        let growth = distance.iter().copied().fold(0.0, f64::max) / first;
        let last = distance[PERIODS - 1] / first;
        eprintln!(
            "W/w = {:.4}: {word} |mu| = {mu:.4}, change per period {first:.2e}, largest / first \
             {growth:.2e}, last / first {last:.2e}",
            omega / json["omega_mode_rad_s"].as_f64().unwrap()
        );
        match word {
            "stable" => {
                assert!(
                    growth < 1.5 && last < 1.0,
                    "stable by Floquet, grows in time at W = {omega}"
                );
                checked.0 += 1;
            }
            "unstable" => {
                assert!(
                    growth > 10.0,
                    "unstable by Floquet, stays in time at W = {omega}"
                );
                checked.1 += 1;
            }
            _ => {
                // Undetermined: the command's own period check found the HB orbit off the
                // flow's periodic orbit by more than 1e-3, and so does this integration.
                assert!(
                    first > 1e-3,
                    "undetermined at W = {omega}, period change {first:.2e}"
                );
                checked.2 += 1;
            }
        }
    }
    eprintln!(
        "checked {} stable, {} unstable, {} undetermined points by the massive model's flow, {} \
         on the massless boundary",
        checked.0, checked.1, checked.2, checked.3
    );
    assert!(checked.0 >= 2 && checked.3 >= 4, "{checked:?}");
    exact_curve_crowns_the_harmonic_balance(&json);
}

/// The level's exact curve on the massless boundary (`exact_curve` in frf.json, by shooting)
/// turns exactly twice, and the harmonic balance's outermost folds (its jump-down and jump-up
/// frequencies, between the small folds of its sampled problem) lie on the exact ones within
/// 5e-3 w: N = 8 harmonics of the massive model against the untruncated boundary model
/// (measured 2.6e-3..2.8e-3 at the jump-down, 1e-4..4.6e-4 at the jump-up on the meshes gmsh
/// writes from a shell and under `cargo test`; 28 folds of the harmonic balance against the
/// exact 2).
fn exact_curve_crowns_the_harmonic_balance(json: &serde_json::Value) {
    let w = json["omega_mode_rad_s"].as_f64().unwrap();
    let curve = &json["curves"][0];
    let exact = &curve["exact_curve"];
    assert_eq!(exact["end"], "complete", "{}", exact["end"]);
    let points = exact["points"].as_array().unwrap();
    let exact_folds: Vec<f64> = points
        .iter()
        .filter(|p| p["fold"].as_bool().unwrap())
        .map(|p| p["omega"].as_f64().unwrap() / w)
        .collect();
    assert_eq!(exact_folds.len(), 2, "{exact_folds:?}");
    let hb_folds: Vec<(f64, String)> = curve["folds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f[1].as_f64().unwrap() / w,
                f[2].as_str().unwrap().to_string(),
            )
        })
        .collect();
    let jump_down = hb_folds
        .iter()
        .filter(|f| f.1 == "TurnsBack")
        .map(|f| f.0)
        .fold(0.0, f64::max);
    let jump_up = hb_folds
        .iter()
        .filter(|f| f.1 == "TurnsForward")
        .map(|f| f.0)
        .fold(f64::INFINITY, f64::min);
    eprintln!(
        "jump-down W/w: harmonic balance {jump_down:.5}, exact {:.5}; jump-up: {jump_up:.5}, \
         exact {:.5}",
        exact_folds[0], exact_folds[1]
    );
    assert!((jump_down - exact_folds[0]).abs() < 5e-3);
    assert!((jump_up - exact_folds[1]).abs() < 5e-3);
    // The exact middle branch between the folds is unstable, the outer branches stable.
    let verdict_at = |i: usize| points[i]["stability"].as_str().unwrap().to_string();
    let fold_index: Vec<usize> = (0..points.len())
        .filter(|&i| points[i]["fold"].as_bool().unwrap())
        .collect();
    let middle = (fold_index[0] + fold_index[1]) / 2;
    assert_eq!(verdict_at(middle), "unstable");
    assert_eq!(verdict_at(fold_index[0] - 3), "stable");
    assert_eq!(verdict_at(fold_index[1] + 3), "stable");
}

/// The boundary of a point with its dynamic modes raised until its orbit settles (the
/// command's second opinion, `settled_stability`: 5e-3 on the master's amplitude at the load's
/// harmonic and on the largest |mu|), shot from the point's orbit at t = 0 (the multipliers do
/// not depend on the origin).
fn settled_boundary(
    system: &System,
    c: &Mat<f64>,
    load: &nlmodes_forced::Load,
    kc: f64,
    (omega, harmonics, coefficients): (f64, usize, &Mat<f64>),
) -> nlmodes_forced::BoundaryMonodromy {
    let driven = nlmodes_boundary::DrivenInputs {
        system,
        damping: c.as_ref(),
        load: (load.harmonics.iter())
            .map(|h| nlmodes_boundary::LoadHarmonic {
                harmonic: h.harmonic,
                cos: &h.cos,
                sin: &h.sin,
            })
            .collect(),
        penalty: Some(kc),
        harmonics,
        keep_all: true,
        gap_motion: Vec::new(),
    };
    nlmodes_boundary::boundary_with_converged_cutoff(&driven, coefficients, omega, 1, 5e-3)
        .expect("settled boundary")
        .expect("the command shot this orbit")
        .boundary
}

/// The command's verdict of a point in contact against RK4 on the massless boundary it used:
/// the one of the point's N (its dynamic modes are those below (N + 1) W), or where that left
/// the point undetermined the settled one.
#[allow(clippy::too_many_arguments)]
fn boundary_point(
    system: &System,
    c: &Mat<f64>,
    load: &nlmodes_forced::Load,
    kc: f64,
    (omega, harmonics, coeff): (f64, usize, &[Vec<f64>]),
    mu: f64,
    word: &str,
    shift: f64,
) {
    let inputs = nlmodes_forced::BoundaryInputs {
        system,
        damping: c.as_ref(),
        load,
        penalty: Some(kc),
        // The orbit's own N: the boundary keeps dynamic the modes below (N + 1) W.
        harmonics,
        keep_all: false,
    };
    let coefficients = Mat::from_fn(coeff.len(), coeff[0].len(), |i, k| coeff[i][k]);
    let at_cutoff = nlmodes_forced::boundary_monodromy(&inputs, &coefficients, omega)
        .expect("boundary")
        .expect("the command shot this orbit");
    // Where the state distance left the point undetermined the command took the boundary with
    // its modes raised until its orbit settles (docs/STABILITY.md Sec. 9.6): the model whose
    // |mu| it reports is that one.
    let b = match (at_cutoff.monodromy.largest() - mu).abs() <= 1e-4 {
        true => at_cutoff,
        false => settled_boundary(system, c, load, kc, (omega, harmonics, &coefficients)),
    };
    let r = b.modes;
    let period = 2.0 * std::f64::consts::PI / b.model.omega;
    let start = nlmodes_boundary::rk4::Rk4State {
        q: b.start[..r].to_vec(),
        v: b.start[r..].to_vec(),
    };
    let steps = nlmodes_boundary::rk4::rk4_steps(&b.model, period).expect("steps");
    let (end, phi) =
        nlmodes_boundary::rk4::integrate(&b.model, &start, period, steps).expect("rk4");
    let scale = start.q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let periodic = (0..r)
        .map(|i| {
            ((end.q[i] - start.q[i]) / scale)
                .abs()
                .max(((end.v[i] - start.v[i]) / (scale * b.model.omega)).abs())
        })
        .fold(0.0, f64::max);
    let rk_mu = phi
        .eigenvalues()
        .expect("eigenvalues")
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max);
    eprintln!(
        "W = {omega:.2} rad/s: {word} on the boundary (shift {shift:.1e}, {r} modes), |mu| = \
         {mu:.6}, RK4 ({steps} steps) |mu| = {rk_mu:.6}, periodic to {periodic:.1e}"
    );
    assert!(
        (rk_mu - mu).abs() <= 1e-4,
        "W = {omega}: {mu} vs RK4 {rk_mu}"
    );
    assert!(periodic <= 1e-6, "W = {omega}: {periodic}");
    if word == "undetermined" {
        // The reasons (docs/STABILITY.md Sec. 9): the shot orbit too far, |mu| within the
        // margin, or the orbit shot at the point's own W giving another verdict than the W-free
        // one (a bifurcation within the shift; session 20, `PointStability::on_boundary`, at the
        // default stability margin 1e-3).
        let margin = 1e-3;
        let fixed_differs = b.fixed_frequency_largest.is_some_and(|l| {
            b.monodromy.verdict_of(l, margin) != b.monodromy.verdict_of(mu, margin)
        });
        eprintln!(
            "  undetermined: fixed-W |mu| {:?}",
            b.fixed_frequency_largest
        );
        assert!(
            shift > nlmodes_forced::BOUNDARY_SHIFT_LIMIT
                || (mu - 1.0).abs() < 2e-3
                || fixed_differs,
            "undetermined at W = {omega} without a reason"
        );
    }
}
