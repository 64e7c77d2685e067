//! The forced harmonic balance against exact orbits of a piecewise-linear system (issue 22).
//!
//! Penalty contact (`ContactMethod::Penalty { stiffness: kc }`) makes the equation of motion
//! M x'' + C x' + K x + kc a (a.x - g)_+ = f cos(W t) piecewise linear with a continuous vector
//! field: two linear regimes, the force continuous at the switch a.x = g. Its periodic orbits are
//! computed exactly by `pwl` (closed-form flow of each regime as a matrix exponential of the
//! state augmented by cos, sin and 1; switching instants located to 1e-15 T; shooting Newton with
//! the exact monodromy, the product of the phase-wise exponentials, the saltation matrix being
//! the identity). Against it, on a 1-DOF oscillator and on a 2-DOF chain whose curves fold
//! (hardening contact), at N = 5, 10 and 20 harmonics:
//!
//! * every point of the harmonic-balance curve lies on an exact periodic orbit: away from the
//!   folds the first-harmonic amplitude of the contact coordinate at the same W, near them the
//!   exact orbit on the hyperplane normal to the curve through the point; the error falls with N;
//! * the folds the continuation reports lie where the exact curve turns (the exact fold: a
//!   multiplier at +1, solved for directly);
//! * the stability verdicts agree with the exact monodromy farther than 1 % in W from a fold;
//! * Liouville: det(exact monodromy) = exp(-T tr(M^-1 C)) (a check of the oracle), and the
//!   product of the crate's multipliers against the same value.
//!
//! Run with `cargo test --release -p nlmodes-forced --test pwl_exact -- --nocapture` for the
//! tables (docs/VERIFICATION.md, "Forced response against exact piecewise-linear orbits").

mod pwl;

use faer::Mat;
use nlmodes_forced::{
    response_curve, Damping, FoldKind, ForcedPoint, ForcedSettings, ForcedSolver,
    FrequencyResponse, FrfSettings, FrfTermination, Load, Verdict,
};
use nlmodes_hb::{AlgorithmParams, ContactMethod, FullBasis, HarmonicSettings, System};
use pwl::{expm, Dense, Integrator, Pwl};
use std::f64::consts::PI;
use std::time::Instant;

/// A test system: the crate's description and the oracle's.
struct Case {
    name: &'static str,
    system: System,
    c: Mat<f64>,
    load: Load,
    kc: f64,
    pwl: Pwl,
    /// Index of the response coordinate (the contact DOF).
    response: usize,
    range: (f64, f64),
}

fn case(
    name: &'static str,
    m: &[Vec<f64>],
    k: &[Vec<f64>],
    damping: Damping,
    (contact, kc_factor): (usize, f64),
    force: (usize, f64),
    range: (f64, f64),
) -> Case {
    let n = m.len();
    let gap = 1.0;
    let a: Vec<f64> = (0..n).map(|i| f64::from(u8::from(i == contact))).collect();
    let system = System::new(
        Mat::from_fn(n, n, |i, j| m[i][j]),
        Mat::from_fn(n, n, |i, j| k[i][j]),
        Mat::from_fn(1, n, |_, j| a[j]),
        vec![gap],
        contact,
    )
    .expect("system");
    let c = damping.matrix(&system).expect("damping");
    let kc = kc_factor * system.contact_stiffness()[0];
    let mut f = vec![0.0; n];
    f[force.0] = force.1;
    let load = Load::fundamental(f.clone());
    let pwl = Pwl {
        n,
        m: Dense::from_fn(n, |i, j| m[i][j]),
        c: Dense::from_fn(n, |i, j| c[(i, j)]),
        k: Dense::from_fn(n, |i, j| k[i][j]),
        a,
        gap,
        kc,
        fc: f,
        fs: vec![0.0; n],
        distortion: None,
    };
    Case {
        name,
        system,
        c,
        load,
        kc,
        pwl,
        response: contact,
        range,
    }
}

/// m x'' + c x' + k x + kc (x - g)_+ = F cos(W t): m = k = g = 1, zeta = 2 %, kc = 3 k, F three
/// times the force that makes the linear resonance graze (2 zeta k g).
fn one_dof() -> Case {
    let zeta = 0.02;
    case(
        "1-DOF",
        &[vec![1.0]],
        &[vec![1.0]],
        Damping::ModalRatios(vec![zeta]),
        (0, 3.0),
        (0, 3.0 * 2.0 * zeta),
        (0.7, 1.6),
    )
}

/// 2-DOF chain, M = diag(1, 2), K = [[2, -1], [-1, 2]], Rayleigh damping with 1.5 % on both
/// modes, kc = 3 x the static stiffness seen by DOF 2, force on DOF 1.
fn two_dof() -> Case {
    let m = [vec![1.0, 0.0], vec![0.0, 2.0]];
    let k = [vec![2.0, -1.0], vec![-1.0, 2.0]];
    // Rayleigh with equal ratios zeta at w1, w2: alpha = 2 zeta w1 w2 / (w1 + w2),
    // beta = 2 zeta / (w1 + w2).
    let zeta = 0.015;
    let (l1, l2) = ((6.0 - 12f64.sqrt()) / 4.0, (6.0 + 12f64.sqrt()) / 4.0);
    let (w1, w2) = (l1.sqrt(), l2.sqrt());
    let damping = Damping::Rayleigh {
        alpha: 2.0 * zeta * w1 * w2 / (w1 + w2),
        beta: 2.0 * zeta / (w1 + w2),
    };
    // Force level: three times the one whose linear resonance grazes (linear response of DOF 2
    // to a unit force on DOF 1 at w1, by the oracle's closed form below).
    let probe = case(
        "probe",
        &m,
        &k,
        damping.clone(),
        (1, 3.0),
        (0, 1.0),
        (0.5, 2.0),
    );
    let unit = linear_amplitude(&probe.pwl, w1, 1);
    case(
        "2-DOF",
        &m,
        &k,
        damping,
        (1, 3.0),
        (0, 3.0 / unit),
        (0.7 * w1, 1.6 * w1),
    )
}

/// The 2-DOF chain (M = I, K = [[2, -1], [-1, 2]], the stop on DOF 2) at 0.3 % modal damping,
/// five times the grazing force on DOF 1: a resonance tip so narrow that the arc-length corrector
/// cannot turn it (the rising and the returning branches meet at a corner of the sampled
/// problem); the continuation passes it by a hop at fixed phase (`frf::phase_hop`).
fn light_chain() -> Case {
    let m = [vec![1.0, 0.0], vec![0.0, 1.0]];
    let k = [vec![2.0, -1.0], vec![-1.0, 2.0]];
    let damping = Damping::ModalRatios(vec![0.003, 0.003]);
    let probe = case(
        "probe",
        &m,
        &k,
        damping.clone(),
        (1, 3.0),
        (0, 1.0),
        (0.5, 2.0),
    );
    let unit = linear_amplitude(&probe.pwl, 1.0, 1);
    case(
        "light 2-DOF",
        &m,
        &k,
        damping,
        (1, 3.0),
        (0, 5.0 / unit),
        (0.9, 2.0),
    )
}

/// |X_j| of the linear response (no contact) at W: (K - W^2 M + i W C) X = fc, by the oracle's
/// own elimination.
fn linear_amplitude(sys: &Pwl, omega: f64, j: usize) -> f64 {
    let n = sys.n;
    let big = Dense::from_fn(2 * n, |p, q| {
        let (i, jj) = (p % n, q % n);
        let d = sys.k.at(i, jj) - omega * omega * sys.m.at(i, jj);
        let e = omega * sys.c.at(i, jj);
        match (p < n, q < n) {
            (true, true) | (false, false) => d,
            (true, false) => -e,
            (false, true) => e,
        }
    });
    let mut rhs = sys.fc.clone();
    rhs.extend(vec![0.0; n]);
    let x = big.solve(&rhs);
    x[j].hypot(x[n + j])
}

/// (x(0), v(0)) of a harmonic-balance point.
fn hb_state(p: &ForcedPoint) -> Vec<f64> {
    let n = p.coefficients.nrows();
    let terms = p.coefficients.ncols();
    let nh = terms / 2;
    let mut z = vec![0.0; 2 * n];
    for i in 0..n {
        z[i] = p.coefficients[(i, 0)]
            + (1..=nh)
                .map(|h| p.coefficients[(i, FullBasis::cos_index(h))])
                .sum::<f64>();
        z[n + i] = (1..=nh)
            .map(|h| h as f64 * p.omega * p.coefficients[(i, FullBasis::sin_index(h))])
            .sum::<f64>();
    }
    z
}

fn hb_amplitude(p: &ForcedPoint, j: usize) -> f64 {
    p.coefficients[(j, FullBasis::cos_index(1))].hypot(p.coefficients[(j, FullBasis::sin_index(1))])
}

fn unit(n: usize, j: usize) -> Vec<f64> {
    (0..n).map(|i| f64::from(u8::from(i == j))).collect()
}

/// First-harmonic amplitude of coordinate j of an exact orbit, and its harmonic tail beyond
/// `tail_from` relative to it (harmonics up to 4 `tail_from`).
fn exact_amplitude(sys: &Pwl, orbit: &pwl::Orbit, j: usize, tail_from: usize) -> (f64, f64) {
    let integ = Integrator::new(sys, orbit.omega, pwl::STEPS);
    let coeff = integ.fourier(&orbit.flow, &unit(2 * sys.n + 3, j), 4 * tail_from);
    let a1 = coeff[1].hypot(coeff[2]);
    let tail: f64 = (tail_from + 1..=4 * tail_from)
        .map(|h| coeff[2 * h - 1].powi(2) + coeff[2 * h].powi(2))
        .sum::<f64>()
        .sqrt();
    (a1, tail / a1)
}

/// Largest multiplier modulus of a monodromy.
fn spectral_radius(m: &Dense) -> f64 {
    m.eigenvalues().first().map_or(0.0, |z| z.0.hypot(z.1))
}

/// One harmonic-balance point against the exact orbit.
#[derive(Clone, Debug)]
struct PointCheck {
    omega: f64,
    /// Within 1 % in W of a fold (of the exact curve or of this harmonic-balance curve).
    near_fold: bool,
    /// The exact orbit reaches the contact.
    contact: bool,
    a_hb: f64,
    a_exact: f64,
    /// Away from folds: |A_HB - A_exact| / A_exact at the same W. Near them: the distance from
    /// the point to the exact curve in (z(0) / g, W / w1).
    error: f64,
    /// The exact orbit's harmonics beyond N relative to its first harmonic.
    tail: f64,
    verdict: Verdict,
    mu_hb: Option<f64>,
    mu_exact: f64,
    liouville_exact: f64,
    liouville_hb: f64,
    jump: f64,
}

#[derive(Clone, Copy, Debug)]
struct ExactFold {
    omega: f64,
    amplitude: f64,
}

struct FoldCheck {
    kind: FoldKind,
    /// `Fold::omega`, the continuation's estimate.
    w_reported: f64,
    /// The fold of the densely traced harmonic-balance curve (`dense_hb_fold`).
    w_hb: f64,
    a_hb: f64,
    exact: ExactFold,
}

struct CurveCheck {
    harmonics: usize,
    termination: FrfTermination,
    hops: usize,
    points: Vec<PointCheck>,
    folds: Vec<FoldCheck>,
    hb_seconds: f64,
    exact_seconds: f64,
}

fn hb_curve(case: &Case, harmonics: usize) -> (FrequencyResponse, ForcedSolver<'_>) {
    let settings = ForcedSettings {
        harmonics: HarmonicSettings::with_default_samples(harmonics).unwrap(),
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: case.kc },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(harmonics).unwrap()
    };
    let solver = ForcedSolver::new(&case.system, &case.c, &case.load, settings).unwrap();
    let curve = response_curve(
        &solver,
        &FrfSettings::new(case.range.0, case.range.1),
        |_| {},
    )
    .unwrap();
    (curve, solver)
}

/// The vertex of the parabola W(A) through three points (A, W): (W*, A*).
fn parabola_vertex(pts: [(f64, f64); 3]) -> (f64, f64) {
    let [(a0, w0), (a1, w1), (a2, w2)] = pts;
    let f01 = (w1 - w0) / (a1 - a0);
    let f12 = (w2 - w1) / (a2 - a1);
    let f012 = (f12 - f01) / (a2 - a0);
    let a_star = 0.5 * (a0 + a1) - f01 / (2.0 * f012);
    let w_star = w0 + f01 * (a_star - a0) + f012 * (a_star - a0) * (a_star - a1);
    (w_star, a_star)
}

/// Unit secant of the curve at point i (from its neighbours) in (z(0) / g, W / w1).
fn secant(states: &[Vec<f64>], omegas: &[f64], i: usize, scales: (f64, f64)) -> Vec<f64> {
    let (lo, hi) = (i.saturating_sub(1), (i + 1).min(states.len() - 1));
    let mut t: Vec<f64> = states[hi]
        .iter()
        .zip(&states[lo])
        .map(|(a, b)| (a - b) / scales.0)
        .collect();
    t.push((omegas[hi] - omegas[lo]) / scales.1);
    let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
    t.iter().map(|v| v / norm).collect()
}

/// The fold of the harmonic-balance curve itself, traced densely through the crate's own
/// arc-length solve (`ForcedSolver::solve` with an `ArcRow`, scaled step 1e-3 instead of the
/// continuation's 5e-3 .. 2e-2) from two points before the reported fold to two points after it;
/// the extremum of W on the dense points refined by the parabola through the three around it.
/// Returns (W*, A*), or `None` if the dense trace does not get through.
fn dense_hb_fold(
    case: &Case,
    solver: &ForcedSolver<'_>,
    curve: &FrequencyResponse,
    fold: &nlmodes_forced::Fold,
) -> Option<(f64, f64)> {
    let (g, w_ref) = (case.pwl.gap, case.system.linear_frequencies()[0]);
    let scaled = |p: &ForcedPoint| {
        let mut v: Vec<f64> = p.contact.iter().map(|y| y / g).collect();
        v.push(p.omega / w_ref);
        v
    };
    let dist = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let i = fold.point;
    let from = i.checked_sub(2).filter(|&f| f >= 1)?;
    let to = (i + 2).min(curve.points.len() - 1);
    let span: f64 = (from..to)
        .map(|k| dist(&scaled(&curve.points[k]), &scaled(&curve.points[k + 1])))
        .sum();
    let mut dense = vec![curve.points[from - 1].clone(), curve.points[from].clone()];
    let mut travelled = 0.0;
    let mut h = 1e-3;
    while travelled < span {
        let (a, b) = (
            scaled(&dense[dense.len() - 2]),
            scaled(&dense[dense.len() - 1]),
        );
        let d = dist(&b, &a);
        let t: Vec<f64> = b.iter().zip(&a).map(|(x, y)| (x - y) / d).collect();
        let last = dense.last().unwrap();
        let l = last.contact.len();
        let arc = nlmodes_forced::ArcRow {
            tangent_y: t[..l].to_vec(),
            parameter: nlmodes_forced::Parameter::Frequency,
            tangent_parameter: t[l],
            predicted: nlmodes_forced::OrbitState {
                level: 1.0,
                y: last
                    .contact
                    .iter()
                    .zip(&t)
                    .map(|(y, tk)| y + h * tk * g)
                    .collect(),
                omega: last.omega + h * t[l] * w_ref,
            },
            y_scale: g,
            parameter_scale: w_ref,
        };
        let start = nlmodes_forced::ForcedStart {
            state: arc.predicted.clone(),
            multipliers: last.multipliers.clone(),
        };
        match solver.solve(start, Some(&arc)) {
            Ok(p) if dist(&scaled(&p), &b) < 4.0 * h => {
                travelled += dist(&scaled(&p), &b);
                dense.push(p);
                h = 1e-3;
            }
            _ => {
                h *= 0.5;
                if h < 1e-6 {
                    return None;
                }
            }
        }
    }
    let w: Vec<f64> = dense.iter().map(|p| p.omega).collect();
    let sign = if fold.kind == FoldKind::TurnsBack {
        1.0
    } else {
        -1.0
    };
    let k = (1..w.len() - 1).max_by(|&x, &y| (sign * w[x]).total_cmp(&(sign * w[y])))?;
    let mut s = vec![0.0];
    for q in 1..dense.len() {
        let step = dist(&scaled(&dense[q]), &scaled(&dense[q - 1]));
        s.push(s[q - 1] + step);
    }
    // Parabola W(s) through k - 1, k, k + 1; A(s) interpolated by the parabola through the same.
    let (w_star, s_star) =
        parabola_vertex([(s[k - 1], w[k - 1]), (s[k], w[k]), (s[k + 1], w[k + 1])]);
    let a: Vec<f64> = dense
        .iter()
        .map(|p| hb_amplitude(p, case.response))
        .collect();
    let lagrange = |x: f64| {
        let (x0, x1, x2) = (s[k - 1], s[k], s[k + 1]);
        a[k - 1] * (x - x1) * (x - x2) / ((x0 - x1) * (x0 - x2))
            + a[k] * (x - x0) * (x - x2) / ((x1 - x0) * (x1 - x2))
            + a[k + 1] * (x - x0) * (x - x1) / ((x2 - x0) * (x2 - x1))
    };
    Some((w_star, lagrange(s_star)))
}

/// Newton tolerance of the oracle on |z(T) - z0|: 1e-11 g, far below every difference compared.
const ORBIT_TOL: f64 = 1e-11;

/// The folds of the exact curve, found from the folds of a harmonic-balance curve: from the point
/// nearest each, the exact curve's nearest orbit, then Newton on the fold equations; distinct
/// folds kept once.
fn exact_folds(case: &Case, curve: &FrequencyResponse) -> Vec<ExactFold> {
    let sys = &case.pwl;
    let scales = (sys.gap, case.system.linear_frequencies()[0]);
    let states: Vec<Vec<f64>> = curve.points.iter().map(hb_state).collect();
    let omegas: Vec<f64> = curve.points.iter().map(|p| p.omega).collect();
    let mut out: Vec<ExactFold> = Vec::new();
    for f in &curve.folds {
        let i = f.point;
        let t = secant(&states, &omegas, i, scales);
        let (start, _) =
            pwl::nearest_on_curve(sys, &states[i], omegas[i], &t, scales, ORBIT_TOL * sys.gap)
                .expect("exact orbit near the fold");
        let fold = pwl::fold_near(sys, &start.z0, start.omega, ORBIT_TOL * sys.gap)
            .unwrap_or_else(|| panic!("{}: no exact fold near W = {}", case.name, f.at));
        let (amplitude, _) = exact_amplitude(sys, &fold, case.response, 1);
        if !out
            .iter()
            .any(|e| (e.omega - fold.omega).abs() < 1e-8 * fold.omega)
        {
            out.push(ExactFold {
                omega: fold.omega,
                amplitude,
            });
        }
    }
    out
}

fn check_curve(
    case: &Case,
    harmonics: usize,
    (curve, solver, hb_seconds): (FrequencyResponse, ForcedSolver<'_>, f64),
    exact: &[ExactFold],
) -> CurveCheck {
    let sys = &case.pwl;
    let w_ref = case.system.linear_frequencies()[0];
    let scales = (sys.gap, w_ref);
    let started = Instant::now();
    let fold_ws: Vec<f64> = curve
        .folds
        .iter()
        .map(|f| f.at)
        .chain(exact.iter().map(|f| f.omega))
        .collect();
    let states: Vec<Vec<f64>> = curve.points.iter().map(hb_state).collect();
    let omegas: Vec<f64> = curve.points.iter().map(|p| p.omega).collect();
    let liouville = |w: f64| (-2.0 * PI / w * sys.trace_minv_c()).exp();
    let tol = ORBIT_TOL * sys.gap;
    let mut points = Vec::new();
    for (i, p) in curve.points.iter().enumerate() {
        let near_fold = fold_ws.iter().any(|wf| (p.omega - wf).abs() <= 0.01 * wf);
        let a_hb = hb_amplitude(p, case.response);
        let found = if near_fold {
            let t = secant(&states, &omegas, i, scales);
            pwl::nearest_on_curve(sys, &states[i], p.omega, &t, scales, tol)
        } else {
            pwl::periodic_at(sys, p.omega, &states[i], tol).map(|o| (o, f64::NAN))
        };
        let (orbit, distance) = found.unwrap_or_else(|| {
            panic!(
                "{} N = {harmonics}: no exact orbit from point {i} (W = {})",
                case.name, p.omega
            )
        });
        let (a_exact, tail) = exact_amplitude(sys, &orbit, case.response, harmonics);
        let mono = &orbit.flow.monodromy;
        let hb_mono = solver.monodromy(p).expect("HB monodromy");
        let hb_product: f64 = hb_mono
            .multipliers
            .iter()
            .map(|z| z[0].hypot(z[1]))
            .product();
        let st = curve.stability[i];
        points.push(PointCheck {
            omega: p.omega,
            near_fold,
            contact: !orbit.flow.events.is_empty(),
            a_hb,
            a_exact,
            error: if near_fold {
                distance
            } else {
                (a_hb - a_exact).abs() / a_exact
            },
            tail,
            verdict: st.verdict,
            mu_hb: st.largest_multiplier,
            mu_exact: spectral_radius(mono),
            liouville_exact: (mono.det() / liouville(orbit.omega) - 1.0).abs(),
            liouville_hb: (hb_product / liouville(p.omega) - 1.0).abs(),
            jump: orbit.flow.largest_jump,
        });
    }
    let folds = curve
        .folds
        .iter()
        .map(|f| {
            let dense = dense_hb_fold(case, &solver, &curve, f);
            let (w_dense, a_hb) = dense.unwrap_or((f64::NAN, f64::NAN));
            let nearest = exact
                .iter()
                .min_by(|x, y| {
                    let d = |e: &ExactFold| ((e.omega - f.at) / w_ref).abs();
                    d(x).total_cmp(&d(y))
                })
                .copied()
                .expect("an exact fold");
            FoldCheck {
                kind: f.kind,
                w_reported: f.at,
                w_hb: w_dense,
                a_hb,
                exact: nearest,
            }
        })
        .collect();
    CurveCheck {
        harmonics,
        termination: curve.termination.clone(),
        hops: curve.hops.len(),
        points,
        folds,
        hb_seconds,
        exact_seconds: started.elapsed().as_secs_f64(),
    }
}

/// Summary numbers of one curve.
struct Summary {
    far: usize,
    far_contact: usize,
    worst_far: f64,
    median_far: f64,
    worst_near: f64,
    tail: f64,
    agree: usize,
    disagree: usize,
    undetermined: usize,
    mu_diff: f64,
    liouville_exact: f64,
    liouville_hb: f64,
    jump: f64,
}

fn summary(c: &CurveCheck) -> Summary {
    let far: Vec<&PointCheck> = c.points.iter().filter(|p| !p.near_fold).collect();
    let far_contact: Vec<&PointCheck> = far.iter().copied().filter(|p| p.contact).collect();
    let mut sorted: Vec<f64> = far_contact.iter().map(|p| p.error).collect();
    sorted.sort_by(f64::total_cmp);
    let max = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0, f64::max);
    let agrees = |p: &PointCheck| match p.verdict {
        Verdict::Stable => p.mu_exact < 1.0,
        Verdict::Unstable => p.mu_exact > 1.0,
        Verdict::Undetermined => false,
    };
    let undetermined = far
        .iter()
        .filter(|p| p.verdict == Verdict::Undetermined)
        .count();
    let agree = far.iter().filter(|p| agrees(p)).count();
    Summary {
        far: far.len(),
        far_contact: far_contact.len(),
        worst_far: sorted.last().copied().unwrap_or(0.0),
        median_far: sorted.get(sorted.len() / 2).copied().unwrap_or(0.0),
        worst_near: max(&mut c.points.iter().filter(|p| p.near_fold).map(|p| p.error)),
        tail: max(&mut far_contact.iter().map(|p| p.tail)),
        agree,
        disagree: far.len() - agree - undetermined,
        undetermined,
        mu_diff: max(&mut far
            .iter()
            .filter_map(|p| p.mu_hb.map(|m| (m - p.mu_exact).abs()))),
        liouville_exact: max(&mut c.points.iter().map(|p| p.liouville_exact)),
        liouville_hb: max(&mut c.points.iter().map(|p| p.liouville_hb)),
        jump: max(&mut c.points.iter().map(|p| p.jump)),
    }
}

fn report(case: &Case, exact: &[ExactFold], checks: &[CurveCheck]) {
    let w_ref = case.system.linear_frequencies()[0];
    for f in exact {
        println!(
            "{}: exact fold at W/w1 = {:.6}, A/g = {:.5}",
            case.name,
            f.omega / w_ref,
            f.amplitude / case.pwl.gap
        );
    }
    for c in checks {
        let s = summary(c);
        println!(
            "{} N = {:2}: {} points, {:?}, {} hops; far from folds {} ({} in contact): |A_HB - A_ex| / A_ex \
             max {:.2e} median {:.2e}, exact tail beyond N max {:.2e}; near folds: distance to \
             the exact curve max {:.2e}; verdicts agree {} disagree {} undetermined {}; \
             max ||mu|_HB - |mu|_ex| {:.2e}; Liouville exact {:.1e} HB {:.1e}; jump at switches \
             {:.1e}; HB {:.2} s, exact {:.2} s",
            case.name,
            c.harmonics,
            c.points.len(),
            c.termination,
            c.hops,
            s.far,
            s.far_contact,
            s.worst_far,
            s.median_far,
            s.tail,
            s.worst_near,
            s.agree,
            s.disagree,
            s.undetermined,
            s.mu_diff,
            s.liouville_exact,
            s.liouville_hb,
            s.jump,
            c.hb_seconds,
            c.exact_seconds
        );
        for f in &c.folds {
            println!(
                "   fold {:?}: W/w1 reported {:.6}, HB (dense) {:.6}, exact {:.6} (rel {:.2e}), A/g HB {:.5} exact {:.5} (rel {:.2e})",
                f.kind,
                f.w_reported / w_ref,
                f.w_hb / w_ref,
                f.exact.omega / w_ref,
                (f.w_hb - f.exact.omega).abs() / f.exact.omega,
                f.a_hb / case.pwl.gap,
                f.exact.amplitude / case.pwl.gap,
                (f.a_hb - f.exact.amplitude).abs() / f.exact.amplitude
            );
        }
    }
    let last = checks.last().unwrap();
    println!(
        "{} N = {}: W/w1, A_HB/g, A_exact/g, error (* near a fold: distance), verdict, |mu|_HB, |mu|_exact",
        case.name, last.harmonics
    );
    let stride = (last.points.len() / 30).max(1);
    for (i, p) in last.points.iter().enumerate() {
        if i % stride != 0 {
            continue;
        }
        println!(
            "  {:8.5} {:9.6} {:9.6} {:8.1e}{} {:12} {:>8} {:8.5}",
            p.omega / w_ref,
            p.a_hb / case.pwl.gap,
            p.a_exact / case.pwl.gap,
            p.error,
            if p.near_fold { "*" } else { " " },
            format!("{:?}", p.verdict),
            p.mu_hb.map_or("-".into(), |m| format!("{m:.5}")),
            p.mu_exact
        );
    }
}

fn timed_curve(case: &Case, harmonics: usize) -> (FrequencyResponse, ForcedSolver<'_>, f64) {
    let started = Instant::now();
    let (curve, solver) = hb_curve(case, harmonics);
    (curve, solver, started.elapsed().as_secs_f64())
}

/// The curves at each N against the exact orbits; the exact folds from the finest curve's.
fn run(case: &Case, harmonics: &[usize]) -> (Vec<ExactFold>, Vec<CurveCheck>) {
    let finest = *harmonics.last().unwrap();
    let last = timed_curve(case, finest);
    let exact = exact_folds(case, &last.0);
    let mut checks: Vec<CurveCheck> = harmonics[..harmonics.len() - 1]
        .iter()
        .map(|&n| check_curve(case, n, timed_curve(case, n), &exact))
        .collect();
    checks.push(check_curve(case, finest, last, &exact));
    (exact, checks)
}

#[test]
fn oracle_self_checks() {
    // expm of a harmonic oscillator against its closed form.
    let w: f64 = 1.7;
    let t = 3.3;
    let e = expm(
        &Dense::from_fn(2, |i, j| match (i, j) {
            (0, 1) => 1.0,
            (1, 0) => -w * w,
            _ => 0.0,
        })
        .scaled(t),
    );
    let exact = [
        (w * t).cos(),
        (w * t).sin() / w,
        -w * (w * t).sin(),
        (w * t).cos(),
    ];
    let err =
        e.a.iter()
            .zip(exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
    println!("expm vs closed form: {err:.1e}");
    assert!(err < 1e-13, "expm error {err:e}");
}

/// What every curve must meet, and what the finest must meet besides.
///
/// Bounds, from the measured tables (docs/VERIFICATION.md) with a margin of about 3:
/// * every curve completes without a hop, and no stability verdict contradicts the exact
///   monodromy farther than 1 % from a fold (undetermined is allowed where the independent period
///   check cannot back the orbit, at coarse N);
/// * Liouville holds to round-off for the oracle (1e-10) and the crate's multipliers (1e-8);
/// * the amplitude error far from folds falls with N (finest below coarsest), and is below 5e-3
///   at N >= 10 (measured at most 1.6e-3 at N = 10);
/// * the finest curve: no undetermined verdict, multipliers within 2e-3 in modulus (measured
///   4.9e-4), as many folds as the exact curve has, each within 1e-3 in W and 5e-3 in amplitude
///   (measured at most 1.2e-4 and 1.1e-3).
fn assert_agrees(case: &Case, exact: &[ExactFold], checks: &[CurveCheck]) {
    let name = case.name;
    for c in checks {
        let s = summary(c);
        let n = c.harmonics;
        assert!(
            matches!(c.termination, FrfTermination::Complete) && c.hops == 0,
            "{name} N = {n}: {:?}, {} hops",
            c.termination,
            c.hops
        );
        assert_eq!(
            s.disagree, 0,
            "{name} N = {n}: verdicts contradicting the exact monodromy"
        );
        assert!(
            s.liouville_exact < 1e-10,
            "{name} N = {n}: oracle Liouville {:e}",
            s.liouville_exact
        );
        assert!(
            s.liouville_hb < 1e-8,
            "{name} N = {n}: HB Liouville {:e}",
            s.liouville_hb
        );
        if n >= 10 {
            assert!(
                s.worst_far < 5e-3,
                "{name} N = {n}: amplitude error {:e}",
                s.worst_far
            );
        }
        assert!(
            s.far_contact > 50,
            "{name} N = {n}: only {} points in contact",
            s.far_contact
        );
    }
    let (first, last) = (summary(&checks[0]), summary(checks.last().unwrap()));
    let fine = checks.last().unwrap();
    assert!(
        last.worst_far < first.worst_far && last.median_far < first.median_far,
        "{name}: the error does not fall with N ({:e} -> {:e})",
        first.worst_far,
        last.worst_far
    );
    assert_eq!(
        last.undetermined, 0,
        "{name}: undetermined verdicts at the finest N"
    );
    assert!(
        last.mu_diff < 2e-3,
        "{name}: multipliers off by {:e}",
        last.mu_diff
    );
    assert_eq!(
        fine.folds.len(),
        exact.len(),
        "{name}: folds at the finest N"
    );
    for f in &fine.folds {
        let dw = (f.w_hb - f.exact.omega).abs() / f.exact.omega;
        let da = (f.a_hb - f.exact.amplitude).abs() / f.exact.amplitude;
        assert!(
            dw < 1e-3 && da < 5e-3,
            "{name}: fold {:?} off by {dw:e} in W, {da:e} in A",
            f.kind
        );
    }
}

#[test]
fn one_dof_against_exact_orbits() {
    let case = one_dof();
    let (exact, checks) = run(&case, &[5, 10, 20]);
    report(&case, &exact, &checks);
    assert_agrees(&case, &exact, &checks);
}

#[test]
fn two_dof_against_exact_orbits() {
    let case = two_dof();
    let (exact, checks) = run(&case, &[10, 20, 40]);
    report(&case, &exact, &checks);
    assert_agrees(&case, &exact, &checks);
}

/// A lightly damped curve completes, through hops at its corners, and its points away from
/// folds lie on exact orbits: completion at N = 10 and 20, and at every point more than 1 % in W
/// from a fold of the curve, an exact periodic orbit from the point's state with the first
/// harmonic within 5e-3 (the tolerance of the other cases at N >= 10) and a verdict that does
/// not contradict the exact monodromy. Near the tip (0.3 % damping) the sampled curve zig-zags
/// and the harmonic-balance folds lie beyond the exact one, so those points are not compared.
/// Measured: N = 10, 1382 points, 42 folds (a truncation zig-zag; N = 20 has 4), 48 hops,
/// 346 compared, worst error 8.4e-4; N = 20, 827 points, 412 compared, 3.4e-4. Without the
/// phase hop the N = 10 curve stops at the tip, W / w1 = 1.1418.
#[test]
fn light_damping_chain_against_exact_orbits() {
    let case = light_chain();
    let sys = &case.pwl;
    for n in [10, 20] {
        let (curve, _) = hb_curve(&case, n);
        assert!(
            matches!(curve.termination, FrfTermination::Complete),
            "light 2-DOF N = {n}: {:?}",
            curve.termination
        );
        let folds: Vec<f64> = curve.folds.iter().map(|f| f.at).collect();
        let (mut compared, mut in_contact, mut worst) = (0, 0, 0.0_f64);
        for (i, p) in curve.points.iter().enumerate() {
            if folds.iter().any(|wf| (p.omega - wf).abs() <= 0.01 * wf) {
                continue;
            }
            let orbit = pwl::periodic_at(sys, p.omega, &hb_state(p), ORBIT_TOL * sys.gap)
                .unwrap_or_else(|| {
                    panic!("N = {n}: no exact orbit from point {i} (W = {})", p.omega)
                });
            let (a_exact, _) = exact_amplitude(sys, &orbit, case.response, n);
            let error = (hb_amplitude(p, case.response) - a_exact).abs() / a_exact;
            worst = worst.max(error);
            let mu = spectral_radius(&orbit.flow.monodromy);
            let verdict = curve.stability[i].verdict;
            assert!(
                !(verdict == Verdict::Stable && mu > 1.0 + 1e-3
                    || verdict == Verdict::Unstable && mu < 1.0 - 1e-3),
                "N = {n}: point {i} (W = {}) {verdict:?} where the exact |mu| = {mu}",
                p.omega
            );
            compared += 1;
            in_contact += usize::from(!orbit.flow.events.is_empty());
        }
        eprintln!(
            "light 2-DOF N = {n}: {} points, {} folds, {} hops, {compared} compared ({in_contact} in contact), worst amplitude error {worst:.2e}",
            curve.points.len(),
            curve.folds.len(),
            curve.hops.len()
        );
        assert!(worst < 5e-3, "N = {n}: amplitude error {worst:e}");
        assert!(
            in_contact > 50,
            "N = {n}: {in_contact} compared points in contact"
        );
    }
}

/// Amplitudes of coordinate j where a polyline of (p, A) crosses p = x (linear interpolation).
fn crossings(points: &[(f64, f64)], x: f64) -> Vec<f64> {
    points
        .windows(2)
        .filter(|w| (w[0].0 - x) * (w[1].0 - x) < 0.0)
        .map(|w| w[0].1 + (w[1].1 - w[0].1) * (x - w[0].0) / (w[1].0 - w[0].0))
        .collect()
}

/// The continuation in force level at a fixed W against two independent answers: (1) the
/// frequency sweeps at three load scales, whose crossings of W0 must be the level curve's
/// crossings of those scales (one or three of them: the S-curve's folds), and (2) the exact
/// orbit of every level-sweep point away from its folds, with the load scaled by its level.
/// Measured (N = 20, W0 = 1.12 w1, s from 0.05 to 4): 3170 points, folds at s = 2.160 (the low
/// branch reaches the stop and turns back) and 0.595 (the jump up); crossings agree to 1.2e-5
/// (the bound 1e-4 is the linear interpolation's at the fine steps), exact orbits to 4.8e-4.
#[test]
fn level_sweep_against_frequency_sweeps_and_exact_orbits() {
    let case = one_dof();
    let w1 = case.system.linear_frequencies()[0];
    let w0 = 1.12 * w1;
    let n = 20;
    let settings = ForcedSettings {
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: case.kc },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(n).unwrap()
    };
    let solver = ForcedSolver::new(&case.system, &case.c, &case.load, settings.clone()).unwrap();
    // Fine steps (2e-3 of the range at most) so that the linear interpolation between points,
    // the test's tool to meet the other curve, errs by less than 1e-4.
    let fine = |f: FrfSettings| FrfSettings {
        step: 1e-3,
        max_step: 2e-3,
        max_points: 20_000,
        stability: false,
        ..f
    };
    let sweep = fine(FrfSettings {
        sweep: nlmodes_forced::Sweep::Level { omega: w0 },
        ..FrfSettings::new(0.05, 4.0)
    });
    let curve = response_curve(&solver, &sweep, |_| {}).unwrap();
    assert!(
        matches!(curve.termination, FrfTermination::Complete),
        "{:?}",
        curve.termination
    );
    let by_level: Vec<(f64, f64)> = curve
        .points
        .iter()
        .map(|p| (p.level, hb_amplitude(p, case.response)))
        .collect();
    let mut worst_cross = 0.0_f64;
    for s in [0.5, 1.0, 1.5] {
        let load = case.load.scaled(s);
        let fs = ForcedSolver::new(&case.system, &case.c, &load, settings.clone()).unwrap();
        let frf = response_curve(
            &fs,
            &fine(FrfSettings::new(case.range.0, case.range.1)),
            |_| {},
        )
        .unwrap();
        let by_w: Vec<(f64, f64)> = frf
            .points
            .iter()
            .map(|p| (p.omega, hb_amplitude(p, case.response)))
            .collect();
        let (mut a, mut b) = (crossings(&by_w, w0), crossings(&by_level, s));
        a.sort_by(f64::total_cmp);
        b.sort_by(f64::total_cmp);
        assert_eq!(
            a.len(),
            b.len(),
            "load scale {s}: crossings {a:?} against {b:?}"
        );
        for (x, y) in a.iter().zip(&b) {
            worst_cross = worst_cross.max((x - y).abs() / x);
        }
        eprintln!(
            "load scale {s}: amplitudes at W0 by frequency sweep {a:?}, by level sweep {b:?}"
        );
    }
    let folds: Vec<f64> = curve.folds.iter().map(|f| f.at).collect();
    let mut worst_exact = 0.0_f64;
    for p in &curve.points {
        if folds.iter().any(|f| (p.level - f).abs() <= 0.01 * f) {
            continue;
        }
        let mut sys = case.pwl.clone();
        sys.fc.iter_mut().for_each(|f| *f *= p.level);
        let orbit = pwl::periodic_at(&sys, w0, &hb_state(p), ORBIT_TOL * sys.gap)
            .unwrap_or_else(|| panic!("no exact orbit at level {}", p.level));
        let (a_exact, _) = exact_amplitude(&sys, &orbit, case.response, n);
        worst_exact = worst_exact.max((hb_amplitude(p, case.response) - a_exact).abs() / a_exact);
    }
    eprintln!(
        "level sweep at W0 = 1.12 w1: {} points, folds at {folds:?}, crossings {worst_cross:.2e}, exact {worst_exact:.2e}",
        curve.points.len()
    );
    assert_eq!(folds.len(), 2, "the S-curve's two folds");
    assert!(worst_cross < 1e-4, "crossings differ by {worst_cross:e}");
    assert!(worst_exact < 5e-3, "exact orbits differ by {worst_exact:e}");
}
