//! The speed sweep (`speed_sweep`) against independent solutions, on the 3-DOF system of the
//! other tests turning with a stiffness K(Omega) = K0 + S Omega^2 M: every frequency then
//! follows the Southwell law w_k(Omega)^2 = w_k0^2 + S Omega^2 exactly (the modes do not change
//! with the speed), so the Campbell curve of mode 1 crosses the engine order e at
//! Omega_c = w_10 / sqrt(e^2 - S) in closed form.
//!
//! - Without contact: every point is the direct linear solve of (K(Omega) - W^2 M + i W C) U = F
//!   at its own speed and W = e Omega (`common::linear_harmonic`), and the sweep peaks where the
//!   modal sum's closed form peaks, within the half-power half-width of the crossing
//!   (the shift damping explains).
//! - With contact, S = 0 (a structure that does not change with the speed): the speed sweep at
//!   e is the frequency sweep at W = e Omega of the same structure (`response_curve`, a second
//!   continuation): the same folds and the same peak.
//! - N converged (`SpeedHarmonics::Retrace`): on a stiff stop whose sweep at N = 10 is not
//!   converged, the retraced sweep's peak against the exact curve of the penalty equation
//!   (`pwl`, exact switches, independent of the crate).

mod common;
mod pwl;

use faer::Mat;
use nlmodes_forced::{
    response_curve, speed_sweep, Damping, FoldKind, ForcedError, ForcedSettings, ForcedSolver,
    FrfSettings, FrfTermination, HarmonicCheck, Load, SpeedFamily, SpeedHarmonics, SpeedProblem,
    SpeedSweep, SpeedSweepSettings,
};
use nlmodes_hb::{AlgorithmParams, ContactMethod, FullBasis, HarmonicSettings, System};

/// The 3-DOF system (`common::three_dof`) turning: K(Omega) = K0 + S Omega^2 M, modal damping
/// `zeta` on every mode at every speed, a force `force` (N) on the master x2.
#[derive(Clone, Copy)]
struct Turning {
    s: f64,
    gap: f64,
    zeta: f64,
    force: f64,
}

impl Turning {
    fn system(&self, speed: f64) -> System {
        let rest = common::three_dof(self.gap);
        let (m, k0) = (rest.mass(), rest.stiffness());
        let k = Mat::from_fn(3, 3, |i, j| k0[(i, j)] + self.s * speed * speed * m[(i, j)]);
        let rows = rest.contact_rows().to_owned();
        System::new(m.to_owned(), k, rows, vec![self.gap], 2).unwrap()
    }

    fn with_force(&self, force: f64) -> Turning {
        Turning { force, ..*self }
    }

    /// w_1 at rest (rad/s).
    fn w10(&self) -> f64 {
        self.system(0.0).linear_frequencies()[0]
    }
}

impl SpeedFamily for Turning {
    fn at(&self, speed: f64) -> Result<SpeedProblem, ForcedError> {
        let system = self.system(speed);
        let damping = Damping::ModalRatios(vec![self.zeta]).matrix(&system)?;
        Ok(SpeedProblem {
            system,
            damping,
            load: Load::fundamental(vec![0.0, 0.0, self.force]),
        })
    }
}

/// First-harmonic amplitude of x2.
fn master(c: &Mat<f64>) -> f64 {
    c[(2, FullBasis::cos_index(1))].hypot(c[(2, FullBasis::sin_index(1))])
}

/// The closed form of the master's amplitude at speed `speed` and W = e Omega: the modal sum
/// |sum_k phi_2k (phi_k . f) / (w_k^2 - W^2 + 2 i zeta w_k W)| with w_k^2 = w_k0^2 + S Omega^2
/// and the modes at rest (mass-normalized).
fn modal_amplitude(t: &Turning, e: f64, speed: f64) -> f64 {
    let rest = t.system(0.0);
    let (modes, lambda) = (rest.modes(), rest.eigenvalues());
    let w = e * speed;
    let (mut re, mut im) = (0.0, 0.0);
    for k in 0..3 {
        let wk = (lambda[k] + t.s * speed * speed).sqrt();
        let gain = modes[(2, k)] * modes[(2, k)] * t.force;
        let (a, b) = (wk * wk - w * w, 2.0 * t.zeta * wk * w);
        let d = a * a + b * b;
        re += gain * a / d;
        im -= gain * b / d;
    }
    re.hypot(im)
}

/// The speed of the closed form's largest amplitude in [a, b] (golden section, to 1e-12).
fn modal_peak(t: &Turning, e: f64, (mut a, mut b): (f64, f64)) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    while b - a > 1e-12 * b {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if modal_amplitude(t, e, x1) > modal_amplitude(t, e, x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    0.5 * (a + b)
}

/// The largest of three-point parabolas through the sweep's top point and its neighbours:
/// (speed, amplitude).
fn interpolated_peak(speeds: &[f64], amps: &[f64]) -> (f64, f64) {
    let k = (1..amps.len() - 1)
        .max_by(|&a, &b| amps[a].total_cmp(&amps[b]))
        .unwrap();
    let (x, y) = (&speeds[k - 1..=k + 1], &amps[k - 1..=k + 1]);
    let d1 = (y[1] - y[0]) / (x[1] - x[0]);
    let d2 = (y[2] - y[1]) / (x[2] - x[1]);
    let c = (d2 - d1) / (x[2] - x[0]);
    let slope = d1 + c * (x[1] - x[0]);
    let at = x[1] - slope / (2.0 * c);
    (at, y[1] + slope * (at - x[1]) + c * (at - x[1]).powi(2))
}

/// Without contact, S = 1.2 (a rotating cantilever's flap mode), e = 2, 1 % damping: every
/// point is the direct linear solve at its speed to 1e-9 (relative to the largest amplitude;
/// the forced solver's linear FRF is exact to 1e-10, `linear_limit.rs`); the peak (the
/// parabola through the sweep's top three points) lies within 2e-4 half-power half-widths of
/// the closed form's peak (measured 1.5e-5), and the closed form's peak within the half-power
/// half-width zeta Omega_c e^2 / (e^2 - S) of the crossing (measured 0.024 of it: the shift
/// damping explains).
#[test]
fn linear_sweep_peaks_at_the_campbell_crossing() {
    let t = Turning {
        s: 1.2,
        gap: 1.0,
        zeta: 0.01,
        force: 0.0,
    };
    let e = 2.0_f64;
    let crossing = t.w10() / (e * e - t.s).sqrt();
    // Peak master amplitude about 0.5 of the gap: out of contact, but large in the scaled space.
    let t = Turning {
        force: 0.5 / modal_amplitude(&t.with_force(1.0), e, crossing),
        ..t
    };
    let settings = SpeedSweepSettings::new(
        2,
        0,
        (0.8 * crossing, 1.2 * crossing),
        t.w10() / e,
        ForcedSettings::new(3).unwrap(),
    );
    let sweep = speed_sweep(&t, &settings, |_| {}).unwrap();
    assert_eq!(sweep.termination, FrfTermination::Complete);
    assert!(sweep.folds.is_empty());
    let mut worst = 0.0_f64;
    for p in &sweep.points {
        assert!(!p.point.touches());
        let problem = t.at(p.speed).unwrap();
        let w = e * p.speed;
        let (a, b) = common::linear_harmonic(
            &problem.system,
            &problem.damping,
            w,
            &[0.0, 0.0, t.force],
            &[0.0; 3],
        );
        for i in 0..3 {
            worst = worst
                .max((p.point.coefficients[(i, FullBasis::cos_index(1))] - a[i]).abs())
                .max((p.point.coefficients[(i, FullBasis::sin_index(1))] - b[i]).abs());
        }
        assert!(
            (p.point.omega - w).abs() <= 1e-9 * w,
            "W {} at {}",
            p.point.omega,
            p.speed
        );
    }
    assert!(
        worst < 1e-9 * 0.5,
        "largest difference to the direct solve {worst:e}"
    );
    let speeds: Vec<f64> = sweep.points.iter().map(|p| p.speed).collect();
    let amps: Vec<f64> = sweep
        .points
        .iter()
        .map(|p| master(&p.point.coefficients))
        .collect();
    let (peak, _) = interpolated_peak(&speeds, &amps);
    let closed = modal_peak(&t, e, (0.95 * crossing, 1.05 * crossing));
    let half_width = t.zeta * crossing * e * e / (e * e - t.s);
    println!(
        "{} points; crossing {crossing:.6} rad/s, closed-form peak {closed:.6} ({:+.3e} half-widths), \
         sweep peak {peak:.6} ({:+.3e} half-widths from the closed form)",
        sweep.points.len(),
        (closed - crossing) / half_width,
        (peak - closed) / half_width
    );
    assert!((closed - crossing).abs() < half_width);
    assert!((peak - closed).abs() < 2e-4 * half_width);
}

/// With contact (the penalty law, kc = 10 x the static contact stiffness, N = 12, 2 %
/// damping, the crowning test's force), S = 0: the speed sweep at e = 3 is the frequency sweep
/// at W = 3 Omega of the same structure. Its folds (a `TurnsBack` at the peak, a `TurnsForward`
/// below it) at W / 3 within 1e-5 (relative) of the frequency sweep's, and its largest master
/// amplitude within 1e-5 of the frequency sweep's (measured: 7e-9 and 8e-7 at the folds,
/// 3e-7 at the peak; the speed sweep's fold is the parabola through three points, the frequency
/// sweep's the Hermite interpolant of exact tangents, and the two curves sample the peak at
/// different points: a fold misplaced by one step would be off by 1e-3 or more); the middle
/// branch between the folds has unstable points.
#[test]
fn speed_independent_structure_gives_the_frequency_sweep() {
    let t = Turning {
        s: 0.0,
        gap: 0.5,
        zeta: 0.02,
        force: 0.08,
    };
    let e = 3.0;
    let system = t.system(0.0);
    let w1 = system.linear_frequencies()[0];
    let settings = ForcedSettings {
        harmonics: HarmonicSettings::new(12, 128).unwrap(),
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty {
                stiffness: 10.0 * system.contact_stiffness()[0],
            },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(12).unwrap()
    };
    let range = (0.8 * w1 / e, 1.6 * w1 / e);
    let sweep_settings = SpeedSweepSettings::new(3, 0, range, w1 / e, settings.clone());
    let sweep = speed_sweep(&t, &sweep_settings, |_| {}).unwrap();
    assert_eq!(sweep.termination, FrfTermination::Complete);
    let problem = t.at(0.0).unwrap();
    let solver =
        ForcedSolver::new(&problem.system, &problem.damping, &problem.load, settings).unwrap();
    let frf = FrfSettings {
        max_harmonics: Some(12),
        stability: false,
        ..FrfSettings::new(e * range.0, e * range.1)
    };
    let curve = response_curve(&solver, &frf, |_| {}).unwrap();
    assert_eq!(curve.termination, FrfTermination::Complete);
    let kinds = |k: Vec<FoldKind>| k;
    assert_eq!(
        kinds(sweep.folds.iter().map(|f| f.kind).collect()),
        kinds(curve.folds.iter().map(|f| f.kind).collect())
    );
    assert!(sweep.folds.iter().any(|f| f.kind == FoldKind::TurnsBack));
    for (a, b) in sweep.folds.iter().zip(&curve.folds) {
        let (speed, w) = (a.speed, b.at);
        println!(
            "fold {:?}: speed sweep W = {:.9}, frequency sweep {w:.9} ({:.2e})",
            a.kind,
            e * speed,
            (e * speed - w) / w
        );
        assert!((e * speed - w).abs() < 1e-5 * w, "{} vs {w}", e * speed);
    }
    let top = |v: Vec<f64>| v.into_iter().fold(0.0, f64::max);
    let (q_speed, q_freq) = (
        top(sweep
            .points
            .iter()
            .map(|p| master(&p.point.coefficients))
            .collect()),
        top(curve
            .points
            .iter()
            .map(|p| master(&p.coefficients))
            .collect()),
    );
    println!(
        "{} / {} points, peak q {q_speed:.9} / {q_freq:.9} ({:.2e})",
        sweep.points.len(),
        curve.points.len(),
        (q_speed - q_freq) / q_freq
    );
    assert!((q_speed - q_freq).abs() < 1e-5 * q_freq);
    let unstable = sweep
        .points
        .iter()
        .filter(|p| {
            p.stability
                .is_some_and(|s| s.verdict == nlmodes_forced::Verdict::Unstable)
        })
        .count();
    assert!(
        unstable > 0,
        "the middle branch between the folds is unstable"
    );
}

/// The 1-DOF oscillator of tests/forced_oracle_cli.rs (m = 1 kg, k = 1 N/m, 1 %, a stop at
/// gap 1 m with kc = 100 N/m, 0.1 N on the mass), the same at every speed, excited at W = Omega
/// (engine order 1): its speed sweep is its frequency response, whose exact curve `pwl` traces.
struct Stop;

const STOP_FORCE: f64 = 0.1;
const STOP_KC: f64 = 100.0;
const STOP_ZETA: f64 = 0.01;

impl SpeedFamily for Stop {
    fn at(&self, _speed: f64) -> Result<SpeedProblem, ForcedError> {
        let one = |v: f64| Mat::from_fn(1, 1, |_, _| v);
        let system = System::new(one(1.0), one(1.0), one(1.0), vec![1.0], 0).unwrap();
        let damping = Damping::ModalRatios(vec![STOP_ZETA]).matrix(&system)?;
        Ok(SpeedProblem {
            system,
            damping,
            load: Load::fundamental(vec![STOP_FORCE]),
        })
    }
}

/// The stop's sweep over W / w1 = 0.8 .. 2.2 from N = 10 under `policy`.
fn stop_sweep(policy: SpeedHarmonics) -> SpeedSweep {
    stop_sweep_at(10, 0, policy)
}

/// The stop's sweep over W / w1 = 0.8 .. 2.2 from N = `n` under `policy`, N up to `top`
/// (`max_harmonics`, 0: 4N).
fn stop_sweep_at(n: usize, top: usize, policy: SpeedHarmonics) -> SpeedSweep {
    let settings = ForcedSettings {
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: STOP_KC },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(n).unwrap()
    };
    let mut s = SpeedSweepSettings::new(1, 0, (0.8, 2.2), 1.0, settings);
    s.harmonic_policy = policy;
    s.max_harmonics = top;
    s.stability = false;
    speed_sweep(&Stop, &s, |_| {}).unwrap()
}

/// The exact curve of the stop (`pwl`: the penalty equation with exact switches, shooting,
/// arc length through the folds; W = Omega here).
fn stop_exact() -> pwl::trace::ExactCurve {
    let w1 = 1.0;
    let sys = pwl::Pwl {
        n: 1,
        m: pwl::Dense::from_fn(1, |_, _| 1.0),
        c: pwl::Dense::from_fn(1, |_, _| 2.0 * STOP_ZETA * w1),
        k: pwl::Dense::from_fn(1, |_, _| 1.0),
        a: vec![1.0],
        gap: 1.0,
        kc: STOP_KC,
        fc: vec![STOP_FORCE],
        fs: vec![0.0],
        distortion: None,
    };
    pwl::trace::ExactCurve::trace(sys, vec![1.0], (0.8, 2.25), (1.0, w1), 1e-10)
        .expect("the exact curve")
}

/// N raised around the points that move (DESIGN §10.10, `raised_segments`): the stop's sweep
/// at N = 5 with `max_harmonics = 10` is traced again at 10 (the largest N of a whole trace)
/// and cannot be traced again at 20, so the points its check at 20 finds moving are raised to
/// 20 with their neighbours along the sweep until two in a row are converged, and checked at
/// 40. Against two independent answers: the exact curve of the penalty equation (`pwl`) and
/// the whole sweep traced at N = 20 (a continuation of its own, `Fixed`): the raised peak lies
/// within the tolerance (1e-3) of both, the points not raised keep N = 10, and the sweep says
/// it is converged. About 5 s.
#[test]
fn a_sweep_raised_around_its_moving_points_matches_the_trace_at_2n() {
    let raised = stop_sweep_at(5, 10, SpeedHarmonics::Retrace);
    let traced = stop_sweep_at(20, 20, SpeedHarmonics::Fixed);
    let traced_at: Vec<usize> = raised.retraces.iter().map(|t| t.harmonics).collect();
    assert_eq!(traced_at, vec![5, 10], "{:?}", raised.retraces);
    assert!(!raised.retraces[1].converged(), "{:?}", raised.retraces);
    let segments = raised
        .raised
        .as_ref()
        .expect("N raised around the moving points");
    println!(
        "raised {} points in {} rounds",
        segments.raised.len(),
        segments.rounds.len()
    );
    assert!(!segments.raised.is_empty());
    for (i, p) in raised.points.iter().enumerate() {
        let n = p.point.harmonics;
        match segments.raised.contains(&i) {
            true => assert_eq!(n, 20, "point {i}"),
            false => assert_eq!(n, 10, "point {i}"),
        }
    }
    let (_, q_exact, _) = stop_exact().peak_before(2.2).expect("the exact peak");
    let (q_raised, q_traced) = (sweep_peak(&raised), sweep_peak(&traced));
    let q5 = sweep_peak(&stop_sweep_at(5, 10, SpeedHarmonics::Check));
    let off = |q: f64| (q - q_exact).abs() / q_exact;
    println!(
        "exact peak {q_exact:.6}; N = 5: {q5:.6} ({:.1e}); raised: {q_raised:.6} ({:.1e}); \
         traced at N = 20: {q_traced:.6} ({:.1e}); converged: {:?}",
        off(q5),
        off(q_raised),
        off(q_traced),
        raised.harmonics_converged()
    );
    assert_eq!(raised.harmonics_converged(), Some(true));
    assert!((q_raised - q_traced).abs() <= 1e-3 * q_traced);
    // The folds located again on the raised points (`refold_raised`) are the N = 20 trace's.
    assert_eq!(raised.folds.len(), traced.folds.len(), "{:?}", raised.folds);
    for (a, b) in raised.folds.iter().zip(&traced.folds) {
        println!(
            "fold {:?}: raised {:.6}, traced at N = 20 {:.6}",
            a.kind, a.speed, b.speed
        );
        assert_eq!(a.kind, b.kind);
        assert!((a.speed - b.speed).abs() <= 1e-3 * b.speed);
    }
    assert!(off(q_raised) <= 1e-3, "{}", off(q_raised));
}

/// A trace at 2N that its own check would throw away is skipped (DESIGN §10.10,
/// `next_trace_harmonics`): the stop's sweep at N = 5 moves at 10 (2.4e-2 in q1) and the
/// moving points' solves at 10 move again at 20 (3.4e-3 at the N = 10 trace's check, above
/// the 1e-3 tolerance), so with `max_harmonics = 20` the next trace is at 20, not 10; its
/// peak is the whole sweep's traced at N = 20 alone (`Fixed`, the same truncation: within
/// 1e-6) and within 1e-3 of the exact curve of the penalty equation (`pwl`). Without the skip
/// the traces are 5, 10, 20. About 4 s.
#[test]
fn a_retrace_at_2n_that_would_move_again_is_skipped_for_4n() {
    let skipped = stop_sweep_at(5, 20, SpeedHarmonics::Retrace);
    let traced_at: Vec<usize> = skipped.retraces.iter().map(|t| t.harmonics).collect();
    assert_eq!(traced_at, vec![5, 20], "{:?}", skipped.retraces);
    assert!(skipped.points.iter().all(|p| p.point.harmonics == 20));
    let alone = stop_sweep_at(20, 20, SpeedHarmonics::Fixed);
    let (_, q_exact, _) = stop_exact().peak_before(2.2).expect("the exact peak");
    let (q, q_alone) = (sweep_peak(&skipped), sweep_peak(&alone));
    println!(
        "peak: traced at 5 then 20 {q:.8}, at 20 alone {q_alone:.8}, exact {q_exact:.8}; \
         largest change at 2N of the N = 20 trace {:?}",
        skipped.retraces[1].largest_change
    );
    assert!((q - q_alone).abs() <= 1e-6 * q_alone);
    assert!((q - q_exact).abs() <= 1e-3 * q_exact);
}

/// The largest first harmonic of a sweep's mass.
fn sweep_peak(sweep: &SpeedSweep) -> f64 {
    (sweep.points.iter())
        .map(|p| p.point.first_harmonic(0))
        .fold(0.0, f64::max)
}

/// N converged by retracing (DESIGN §10.10): the stop's sweep traced at N = 10 is NOT
/// converged at the default tolerance (1e-3: its checked points move at N = 20), so it is
/// traced again at N = 20 and checked at 40; every point of the kept sweep is at N = 20 and
/// its checked points carry their verdict. Against the exact curve of the penalty equation
/// (`pwl`: exact switches, shooting, arc length through the folds; W = Omega here), the
/// retraced sweep's peak is within 1e-3 of the exact peak (the issue asks 1 %), and closer to
/// it than the sweep kept at N = 10 (`Check`), whose check says it is not converged. About 10 s.
#[test]
fn a_retraced_sweep_is_converged_in_n_against_the_exact_curve() {
    let checked = stop_sweep(SpeedHarmonics::Check);
    let retraced = stop_sweep(SpeedHarmonics::Retrace);
    assert_eq!(checked.harmonics, 10);
    assert_eq!(checked.retraces.len(), 1);
    assert!(!checked.retraces[0].converged(), "{:?}", checked.retraces);
    assert_eq!(retraced.termination, FrfTermination::Complete);
    let ns: Vec<usize> = retraced.retraces.iter().map(|t| t.harmonics).collect();
    assert_eq!(ns, vec![10, 20]);
    assert_eq!(retraced.harmonics, 20);
    assert!(retraced.points.iter().all(|p| p.point.harmonics == 20));
    let last = retraced.retraces.last().unwrap();
    for &i in &last.checked {
        assert!(
            !matches!(
                retraced.points[i].point.harmonic_check,
                HarmonicCheck::Unchecked
            ),
            "point {i} checked"
        );
    }
    let exact_curve = stop_exact();
    let (w_peak, q_exact, _) = exact_curve.peak_before(2.2).expect("the exact peak");
    let (q10, q20) = (sweep_peak(&checked), sweep_peak(&retraced));
    let off = |q: f64| (q - q_exact).abs() / q_exact;
    println!(
        "exact peak {q_exact:.6} at W = {w_peak:.6}; sweep at N = 10: {q10:.6} ({:.1e}), \
         retraced (N = 20, {} points): {q20:.6} ({:.1e}); largest change at 2N of the N = 10 \
         trace {:?}, of the N = 20 trace {:?}",
        off(q10),
        retraced.points.len(),
        off(q20),
        retraced.retraces[0].largest_change,
        last.largest_change
    );
    assert!(off(q20) < 1e-3, "{}", off(q20));
    assert!(off(q20) < off(q10));
    // Each trace's largest contact force, checked at 2N at its strongest point (`ForceCheck`):
    // the point of the trace with the largest force, its force there, and a solve at 2N whose
    // force moves less from N = 20 than the N = 10 trace's did from 10 (the force converges).
    let strongest = (retraced.points.iter().enumerate())
        .max_by(|a, b| {
            let f = |p: &nlmodes_forced::SpeedPoint| p.point.largest_contact_force();
            f(a.1).total_cmp(&f(b.1))
        })
        .map(|(i, _)| i)
        .unwrap();
    let force = last.force.expect("the N = 20 trace's force check");
    let first = retraced.retraces[0]
        .force
        .expect("the N = 10 trace's force check");
    println!("largest contact force: N = 10 {first:?}; N = 20 {force:?}");
    assert_eq!(force.point, strongest);
    assert_eq!(
        force.force,
        retraced.points[strongest].point.largest_contact_force()
    );
    let (c10, c20) = (first.change().unwrap(), force.change().unwrap());
    assert!(c20 < c10, "{c20:e} against {c10:e}");
    // The force the truncated series converges to, on the last trace only: the exact orbit's
    // (`ExactForce`, shot on the massless boundary, here the penalty equation itself) against
    // the oracle's orbits at its W, within 1e-6 (both flows exact; measured in
    // tests/forced_oracle_cli.rs: 7e-10).
    assert_eq!(first.exact, None);
    let exact = force.exact.expect("the last trace's exact force");
    let w = exact.omega;
    let oracle: Vec<f64> = (exact_curve.samples.windows(2).enumerate())
        .filter(|(_, p)| (p[0].orbit.omega - w) * (p[1].orbit.omega - w) <= 0.0)
        .filter_map(|(i, _)| exact_curve.orbit_on_segment(i, w))
        .map(|o| pwl::largest_penalty_force(&exact_curve.sys, &o, 1000))
        .collect();
    let error = (oracle.iter())
        .map(|f| (exact.force / f - 1.0).abs())
        .fold(f64::INFINITY, f64::min);
    println!("exact orbit's force {exact:?}, the oracle's orbits there {oracle:?} ({error:.1e})");
    assert!(error <= 1e-6, "{error:e}");
}

/// The 3-DOF system turning (`Turning`) with its running gap closing with the speed, as a
/// blade's tip clearance does: g0 (1 - a (Omega / Omega_r)^2).
struct Closing {
    turning: Turning,
    shrink: f64,
    speed_ref: f64,
}

impl SpeedFamily for Closing {
    fn at(&self, speed: f64) -> Result<SpeedProblem, ForcedError> {
        let mut problem = self.turning.at(speed)?;
        let gap = self.turning.gap * (1.0 - self.shrink * (speed / self.speed_ref).powi(2));
        let s = &problem.system;
        problem.system = System::new(
            s.mass().to_owned(),
            s.stiffness().to_owned(),
            s.contact_rows().to_owned(),
            vec![gap],
            2,
        )?;
        Ok(problem)
    }
}

/// The 3-DOF system turning (S = 3: its mode 1 climbs a third as fast as W = 3 Omega near the
/// crossing) with its gap closing by a = 0.2 at the crossing's speed, in contact (the penalty
/// law, kc = 10 x the static contact stiffness, 2 % damping), swept at e = 3 from N = `n`
/// under `policy` (stability off).
fn turning_contact_sweep(n: usize, policy: SpeedHarmonics) -> SpeedSweep {
    let t = Turning {
        s: 3.0,
        gap: 0.5,
        zeta: 0.02,
        force: 0.08,
    };
    let e = 3.0;
    let system = t.system(0.0);
    let wc = system.linear_frequencies()[0] / (e * e - t.s).sqrt();
    let settings = ForcedSettings {
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty {
                stiffness: 10.0 * system.contact_stiffness()[0],
            },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(n).unwrap()
    };
    let mut s = SpeedSweepSettings::new(3, 0, (0.8 * wc, 1.6 * wc), wc, settings);
    s.harmonic_policy = policy;
    s.max_harmonics = 4 * n;
    s.stability = false;
    let closing = Closing {
        turning: t,
        shrink: 0.2,
        speed_ref: wc,
    };
    speed_sweep(&closing, &s, |_| {}).unwrap()
}

/// The check at 2N of a sweep whose structure moves with the speed (S = 3, the gap closing)
/// solves every checked point again at 2N (DESIGN §10.10), each on its row normal to the
/// sweep with the structure following W = e Omega, as the trace's own steps are
/// (`SpeedStepper::on_speed_row`). Independent confirmation of the 2N solutions: the sweep
/// traced again at 2N (`Retrace`, a continuation of its own) peaks where the check says: the
/// relative change of the peak's q1 from N to 2N equals the check's change at the N sweep's
/// peak point within 20 % (measured 3.053e-3 against 3.057e-3; the two differ by the traces'
/// sampling of the peak and the row's slant). On the blade the old frozen-speed check failed
/// at 5 of 8 points (docs/ROTATION.md); this small system's frozen check happens to converge,
/// so the test guards the check's solves and their agreement with a retrace, not that
/// failure. About 2 s.
#[test]
fn the_check_at_2n_solves_every_point_of_a_moving_structure() {
    let n = 4;
    let checked = turning_contact_sweep(n, SpeedHarmonics::Check);
    assert_eq!(checked.termination, FrfTermination::Complete);
    let report = &checked.retraces[0];
    assert!(report.checkable && !report.checked.is_empty());
    let mut unsolved = Vec::new();
    for &i in &report.checked {
        let p = &checked.points[i];
        println!(
            "point {i} at {:.6} rad/s, q1 {:.6}: {:?}",
            p.speed,
            master(&p.point.coefficients),
            p.point.harmonic_check
        );
        if matches!(
            p.point.harmonic_check,
            HarmonicCheck::NotConverged { change: None } | HarmonicCheck::Unchecked
        ) {
            unsolved.push(i);
        }
    }
    assert!(unsolved.is_empty(), "not solved again at 2N: {unsolved:?}");

    let retraced = turning_contact_sweep(n, SpeedHarmonics::Retrace);
    assert_eq!(retraced.harmonics, 2 * n, "{:?}", retraced.retraces);
    let peak = |s: &SpeedSweep| {
        (s.points.iter())
            .map(|p| master(&p.point.coefficients))
            .fold(0.0, f64::max)
    };
    let (q_n, q_2n) = (peak(&checked), peak(&retraced));
    let top = (checked.points.iter())
        .position(|p| master(&p.point.coefficients) == q_n)
        .unwrap();
    let change = match checked.points[top].point.harmonic_check {
        HarmonicCheck::Converged { change } => change[0],
        HarmonicCheck::NotConverged { change: Some(c) } => c[0],
        other => panic!("the peak point {top} not solved at 2N: {other:?}"),
    };
    let moved = (q_n - q_2n).abs() / q_2n;
    println!("peak q1 at N {q_n:.6}, at 2N (retraced) {q_2n:.6}: moved {moved:.3e}, the check {change:.3e}");
    assert!(
        (moved - change).abs() <= 0.2 * moved.max(change) + 1e-5,
        "retrace {moved:.3e} against the check {change:.3e}"
    );
}
