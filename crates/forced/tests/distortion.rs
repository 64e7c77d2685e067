//! Casing distortion in speed sweeps (docs/DESIGN.md §10.11): with an n-lobed casing the gap is
//! g0 - delta cos(n Omega t + phase) and the load acts at e Omega, so the orbit's fundamental
//! is gcd(e, n) Omega, the load at its harmonic e / gcd and the gap at n / gcd.
//!
//! - On a structure that does not change with the speed (S = 0), the speed sweep at e = 3 with
//!   n = 2 lobes (fundamental Omega: load at harmonic 3, gap at harmonic 2) is the frequency
//!   sweep of the same structure with the load at harmonic 3 of W and the gap at harmonic 2
//!   (`response_curve`, a second continuation): every point of the one solves the other's
//!   problem, the same folds and peak.
//! - On a turning structure (K = K0 + S Omega^2 M, S = 1.2), the points of the speed sweeps at
//!   e = 2 with n = 4 lobes (fundamental 2 Omega, the gap at its second harmonic) and of the
//!   casing alone (n = 2, no load) are periodic orbits of the penalty equation with the moving
//!   gap at their own speed: shot from the point's state by the exact piecewise-linear flow
//!   (`pwl`, independent of the crate), the orbit found has the point's first harmonic of the
//!   master within 1e-3 (N = 12).
//! - The exact tangent of the frequency continuation under a distortion is the curve's (the
//!   intrusion does not depend on W): dy/dW against a central difference to 1e-7.
//! - The distortion sweep at a fixed W (`casing_sweep`, the casing's intrusion grown at one
//!   speed): at rest below the gap, on the exact orbits of the moving gap above it.

mod common;
mod pwl;

use faer::Mat;
use nlmodes_forced::{
    casing_sweep, largest_force, response_curve, speed_sweep, CasingDistortion,
    CasingSweepSettings, Damping, ForcedError, ForcedSettings, ForcedSolver, FrequencyResponse,
    FrfSettings, FrfTermination, HarmonicLoad, Load, LobedCasing, SpeedFamily, SpeedProblem,
    SpeedSweep, SpeedSweepSettings,
};
use nlmodes_hb::{AlgorithmParams, ContactMethod, FullBasis, HarmonicSettings, System};
use pwl::{GapWave, Pwl};

/// The 3-DOF system of the other tests (`common::three_dof`, gap 0.5, contact row
/// 0.2 x0 + x2, master x2) turning: K(Omega) = K0 + S Omega^2 M, modal damping `zeta`, a force
/// `force` (N) on x2 at harmonic 1 of e Omega.
#[derive(Clone, Copy)]
struct Turning {
    s: f64,
    zeta: f64,
    force: f64,
}

const GAP: f64 = 0.5;

impl Turning {
    fn system(&self, speed: f64) -> System {
        let rest = common::three_dof(GAP);
        let (m, k0) = (rest.mass(), rest.stiffness());
        let k = Mat::from_fn(3, 3, |i, j| k0[(i, j)] + self.s * speed * speed * m[(i, j)]);
        let rows = rest.contact_rows().to_owned();
        System::new(m.to_owned(), k, rows, vec![GAP], 2).unwrap()
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

/// N = 12 on 128 samples, kc = 10 x the static contact stiffness.
fn settings(system: &System) -> ForcedSettings {
    ForcedSettings {
        harmonics: HarmonicSettings::new(12, 128).unwrap(),
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty {
                stiffness: 10.0 * system.contact_stiffness()[0],
            },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(12).unwrap()
    }
}

/// First-harmonic amplitude of x2.
fn master(c: &Mat<f64>) -> f64 {
    c[(2, FullBasis::cos_index(1))].hypot(c[(2, FullBasis::sin_index(1))])
}

/// S = 0, e = 3, n = 2 (delta = 0.2, below the gap, phase 0.5 rad): every point of the speed
/// sweep solves the frequency sweep's problem at W = Omega (solved again there it does not
/// move: its residual is within the solver's 1e-10 g0); the same folds, each of the speed
/// sweep's (the parabola through its three points around it) within the span of those
/// points of the frequency sweep's (measured: 1.2e-8 at the turn of the resonance, 1.0e-4 at
/// the grazing corner below it, where the contact phase appears and the curve turns within a
/// step); the largest amplitudes within the sampling of the tops (measured 3.2e-4).
#[test]
fn a_lobed_casing_in_a_speed_sweep_is_the_frequency_sweep_on_the_common_fundamental() {
    let t = Turning {
        s: 0.0,
        zeta: 0.02,
        force: 0.08,
    };
    let system = t.system(0.0);
    let w1 = system.linear_frequencies()[0];
    let casing = LobedCasing {
        lobes: 2,
        amplitude: 0.2,
        phase: 0.5,
    };
    let range = (0.8 * w1 / 3.0, 1.6 * w1 / 3.0);
    let sweep_settings = SpeedSweepSettings {
        casing: Some(casing),
        stability: false,
        ..SpeedSweepSettings::new(3, 0, range, w1 / 3.0, settings(&system))
    };
    assert_eq!(sweep_settings.fundamental_order(), 1);
    let sweep = speed_sweep(&t, &sweep_settings, |_| {}).unwrap();
    assert_eq!(sweep.termination, FrfTermination::Complete);
    // The frequency sweep at W = Omega: the load at harmonic 3, the gap at harmonic 2.
    let problem = t.at(0.0).unwrap();
    let load = Load {
        harmonics: vec![HarmonicLoad {
            harmonic: 3,
            cos: vec![0.0, 0.0, t.force],
            sin: vec![0.0; 3],
        }],
    };
    let frequency = ForcedSettings {
        distortion: Some(CasingDistortion {
            harmonic: 2,
            amplitude: casing.amplitude,
            phase: casing.phase,
        }),
        ..settings(&system)
    };
    let solver = ForcedSolver::new(&problem.system, &problem.damping, &load, frequency).unwrap();
    let frf = FrfSettings {
        max_harmonics: Some(12),
        stability: false,
        ..FrfSettings::new(range.0, range.1)
    };
    let curve = response_curve(&solver, &frf, |_| {}).unwrap();
    assert_eq!(curve.termination, FrfTermination::Complete);
    assert_same_folds(&sweep, &curve);
    assert_points_solve(&sweep, &solver);
    assert_same_peak(&sweep, &curve);
}

/// The same folds, each of the speed sweep's within the span of its points around it of the
/// frequency sweep's (the test's docs).
fn assert_same_folds(sweep: &SpeedSweep, curve: &FrequencyResponse) {
    let kinds: Vec<_> = curve.folds.iter().map(|f| f.kind).collect();
    assert_eq!(
        sweep.folds.iter().map(|f| f.kind).collect::<Vec<_>>(),
        kinds
    );
    assert!(!kinds.is_empty(), "the casing's sweep folds");
    for (a, b) in sweep.folds.iter().zip(&curve.folds) {
        // The speed sweep's fold is the parabola through its three points around it; at a
        // grazing corner (the contact phase appears there) the curve turns within less than
        // its step, and the fold lies between its neighbours' speeds.
        let last = sweep.points.len() - 1;
        let around = &sweep.points[a.point.saturating_sub(1)..=(a.point + 1).min(last)];
        let speeds = around.iter().map(|p| p.speed);
        let spread = (speeds.clone().fold(f64::NEG_INFINITY, f64::max)
            - speeds.fold(f64::INFINITY, f64::min))
        .max(1e-5 * b.at);
        println!(
            "fold {:?}: speed sweep W = {:.9}, frequency sweep {:.9} ({:.1e}; the sweep's \
             points around it span {:.1e})",
            a.kind,
            a.speed,
            b.at,
            (a.speed - b.at) / b.at,
            spread / b.at
        );
        assert!((a.speed - b.at).abs() <= spread);
    }
}

/// Every point of the speed sweep solves the frequency problem at W = Omega: solved again there
/// at fixed W from itself, it does not move (its residual is within the solver's 1e-10 g0).
fn assert_points_solve(sweep: &SpeedSweep, solver: &ForcedSolver<'_>) {
    let mut moved = 0.0_f64;
    for p in &sweep.points {
        let again = solver
            .solve(ForcedSolver::start_from(&p.point), None)
            .unwrap();
        let d = (again.contact.iter().zip(&p.point.contact))
            .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        moved = moved.max(d / GAP);
    }
    println!("speed sweep points solved again on the frequency problem: moved {moved:.1e} g0");
    assert!(moved < 1e-8);
}

/// Both curves are the same orbits; their largest sampled amplitudes differ by the sampling of
/// the top: at most the change between the top sample and its neighbours on either.
fn assert_same_peak(sweep: &SpeedSweep, curve: &FrequencyResponse) {
    let on_sweep: Vec<f64> = sweep
        .points
        .iter()
        .map(|p| master(&p.point.coefficients))
        .collect();
    let on_curve: Vec<f64> = curve
        .points
        .iter()
        .map(|p| master(&p.coefficients))
        .collect();
    let ((q_speed, dq_speed), (q_freq, dq_freq)) = (top(&on_sweep), top(&on_curve));
    println!(
        "{} / {} points, peak q {q_speed:.9} / {q_freq:.9} ({:.1e}; the samples around the tops \
         differ by {:.1e}, {:.1e})",
        sweep.points.len(),
        curve.points.len(),
        (q_speed - q_freq) / q_freq,
        dq_speed / q_freq,
        dq_freq / q_freq
    );
    assert!((q_speed - q_freq).abs() <= dq_speed.max(dq_freq));
}

/// The largest of `q` and its largest difference from its neighbours.
fn top(q: &[f64]) -> (f64, f64) {
    let k = (0..q.len()).max_by(|&a, &b| q[a].total_cmp(&q[b])).unwrap();
    let around = q[k.saturating_sub(1)..=(k + 1).min(q.len() - 1)].iter();
    (q[k], around.fold(0.0_f64, |a, v| a.max((q[k] - v).abs())))
}

/// The oracle's system at `speed` on the sweep's fundamental k Omega: the load at harmonic 1
/// (e = k), the gap at harmonic n / k, the penalty stiffness `kc` (N/m, the sweep's: the same
/// at every speed).
fn oracle(t: &Turning, speed: f64, (casing, k): (&LobedCasing, usize), kc: f64) -> Pwl {
    let system = t.system(speed);
    let c = Damping::ModalRatios(vec![t.zeta]).matrix(&system).unwrap();
    let wave = GapWave {
        harmonic: casing.lobes / k,
        amplitude: casing.amplitude,
        phase: casing.phase,
    };
    let matrices = [system.mass(), c.as_ref(), system.stiffness()];
    let a = (0..3).map(|j| system.contact_rows()[(0, j)]).collect();
    Pwl::with_gap_wave(matrices, a, (GAP, kc), vec![0.0, 0.0, t.force], wave)
}

/// Every `every`-th point of `sweep` shot by the oracle at its speed from its state: the
/// largest relative difference of the master's first harmonic from the periodic orbit's found,
/// and how many of those orbits touch.
fn shot_distance(t: &Turning, sweep: &SpeedSweep, settings: &SpeedSweepSettings) -> (f64, usize) {
    let ContactMethod::Penalty { stiffness } = settings.solver.algorithm.method else {
        panic!("the penalty law");
    };
    let k = settings.fundamental_order();
    let casing = settings.casing.expect("a casing");
    let every = (sweep.points.len() / 12).max(1);
    let (mut worst, mut touching) = (0.0_f64, 0);
    for p in sweep.points.iter().step_by(every) {
        let w = k as f64 * p.speed;
        let z = common::state_at_zero(&p.point.coefficients, w);
        let sys = oracle(t, p.speed, (&casing, k), stiffness);
        let orbit = pwl::periodic_at(&sys, w, &z, 1e-12)
            .unwrap_or_else(|| panic!("no exact orbit at {} rad/s", p.speed));
        let exact = pwl::trace::first_harmonic(&sys, &orbit, &[0.0, 0.0, 1.0]);
        worst = worst.max((master(&p.point.coefficients) / exact - 1.0).abs());
        touching += usize::from(!orbit.flow.events.is_empty());
    }
    (worst, touching)
}

/// S = 1.2, 2 % damping: e = 2 with a 4-lobed casing (delta = 0.2 < gap, fundamental 2 Omega,
/// the gap at its harmonic 2) and the casing alone (n = 2, delta = 0.6 > gap, no load): at
/// every twelfth point the master's first harmonic within 1e-3 of the exact orbit's at its
/// speed (N = 12; at the crossing 2e-4, 2e-6 at N = 48: the velocities converge slowest, their
/// derivative jumps at the switches), points in contact among them.
#[test]
fn speed_sweep_points_are_exact_orbits_under_a_lobed_casing() {
    let loaded = Turning {
        s: 1.2,
        zeta: 0.02,
        force: 0.08,
    };
    let alone = Turning {
        force: 0.0,
        ..loaded
    };
    let cases = [
        (
            loaded,
            2,
            LobedCasing {
                lobes: 4,
                amplitude: 0.2,
                phase: 0.3,
            },
        ),
        (
            alone,
            2,
            LobedCasing {
                lobes: 2,
                amplitude: 0.6,
                phase: 0.0,
            },
        ),
    ];
    for (t, e, casing) in cases {
        let w10 = t.system(0.0).linear_frequencies()[0];
        let crossing = w10 / (e as f64 * e as f64 - t.s).sqrt();
        let settings = SpeedSweepSettings {
            casing: Some(casing),
            stability: false,
            ..SpeedSweepSettings::new(
                e,
                0,
                (0.85 * crossing, 1.25 * crossing),
                crossing,
                settings(&t.system(crossing)),
            )
        };
        let sweep = speed_sweep(&t, &settings, |_| {}).unwrap();
        assert_eq!(sweep.termination, FrfTermination::Complete);
        let (worst, touching) = shot_distance(&t, &sweep, &settings);
        let peak = (sweep.points.iter())
            .map(|p| master(&p.point.coefficients))
            .fold(0.0, f64::max);
        println!(
            "e = {e}, {} lobes, force {}: {} points, peak q/g0 {:.4}, {} folds; shot from every \
             twelfth point: largest first-harmonic error {worst:.2e}, {touching} in contact",
            casing.lobes,
            t.force,
            sweep.points.len(),
            peak / GAP,
            sweep.folds.len()
        );
        assert!(worst < 1e-3 && touching > 0);
    }
}

/// The W-derivative of the arc-length continuation under a casing distortion: the casing's
/// intrusion sits at a fixed harmonic of W and does not depend on W, so the exact tangent
/// (`ForcedSolver::tangent`, from dR/dy and dR/dW) is the curve's: at a point in contact on the
/// 3-DOF system (the gap at harmonic 2, delta = 0.2, a load at W), dy/dW from the tangent equals
/// the central difference of the orbits solved at W -+ 1e-5 W to 1e-6 (relative to its size;
/// the difference's truncation is O(h^2), its rounding the solves' 1e-10 g0 over 2h: measured
/// 1.0e-7).
#[test]
fn the_exact_tangent_under_a_distortion_is_the_curves() {
    let t = Turning {
        s: 0.0,
        zeta: 0.02,
        force: 0.08,
    };
    let problem = t.at(0.0).unwrap();
    let w1 = problem.system.linear_frequencies()[0];
    let fs = ForcedSettings {
        distortion: Some(CasingDistortion {
            harmonic: 2,
            amplitude: 0.2,
            phase: 0.5,
        }),
        ..settings(&problem.system)
    };
    let solver = ForcedSolver::new(&problem.system, &problem.damping, &problem.load, fs).unwrap();
    let at = |w: f64, from: Option<&nlmodes_forced::ForcedPoint>| {
        let start = match from {
            Some(p) => nlmodes_forced::ForcedStart {
                state: nlmodes_forced::OrbitState {
                    omega: w,
                    ..ForcedSolver::start_from(p).state
                },
                ..ForcedSolver::start_from(p)
            },
            None => solver.linear_start(w, 1.0).unwrap(),
        };
        solver.solve(start, None).unwrap()
    };
    let w0 = 0.95 * w1;
    let p = at(w0, None);
    assert!(p.touches());
    let along = nlmodes_forced::ArcRow {
        parameter: nlmodes_forced::Parameter::Frequency,
        tangent_y: vec![0.0; p.contact.len()],
        tangent_parameter: 1.0,
        predicted: ForcedSolver::start_from(&p).state,
        y_scale: 1.0,
        parameter_scale: 1.0,
    };
    let tangent = solver.tangent(&p, &along).unwrap();
    let l = p.contact.len();
    let h = 1e-5 * w0;
    let (up, down) = (at(w0 + h, Some(&p)), at(w0 - h, Some(&p)));
    let size = tangent[..l].iter().fold(0.0_f64, |a, v| a.max(v.abs())) / tangent[l];
    let worst = (0..l).fold(0.0_f64, |a, i| {
        let difference = (up.contact[i] - down.contact[i]) / (2.0 * h);
        a.max((tangent[i] / tangent[l] - difference).abs())
    });
    println!(
        "dy/dW from the tangent against the central difference: {:.1e}",
        worst / size
    );
    assert!(worst < 1e-6 * size);
}

/// The distortion sweep at a fixed W (`casing_sweep`; issue 39, item 6) on the 3-DOF system
/// at rest (2 %, no load, kc = 10 x the static contact stiffness, N = 12) at W = 0.7 w1 (below
/// the first mode, as the default blade's two lobes at 8000 rpm: 0.69), delta from 0 to 2 x
/// the gap in steps of 0.1 gap, phase 0.3 rad. Below the gap the casing never reaches the
/// structure: no contact and the structure at rest (its first harmonic 0 to round-off, the
/// orbit measured from the casing the intrusion itself). Above it every point is a periodic
/// orbit of the penalty equation with the moving gap: shot from the point's state by the
/// exact piecewise-linear flow (`pwl`, independent of the crate), the orbit found has the
/// master's first harmonic within 1e-3 of the point's (N = 12; measured below); the largest
/// contact force grows with delta.
#[test]
fn a_distortion_sweep_lies_on_exact_orbits() {
    let t = Turning {
        s: 0.0,
        zeta: 0.02,
        force: 0.0,
    };
    let system = t.system(0.0);
    let damping = Damping::ModalRatios(vec![t.zeta]).matrix(&system).unwrap();
    let w = 0.7 * system.linear_frequencies()[0];
    let amplitudes: Vec<f64> = (0..=20).map(|i| 0.1 * GAP * i as f64).collect();
    let mut settings = CasingSweepSettings::new(w, amplitudes, settings(&system));
    settings.phase = 0.3;
    settings.stability = false;
    let sweep = casing_sweep(&system, &damping, &settings, |_| {}).unwrap();
    assert!(sweep.stopped.is_none(), "{:?}", sweep.stopped);
    assert!(sweep.points.iter().all(|p| !p.jump));
    let ContactMethod::Penalty { stiffness } = settings.solver.algorithm.method else {
        panic!("the penalty law");
    };
    let (mut worst, mut shot) = (0.0_f64, 0);
    for p in &sweep.points {
        let c = &p.point.coefficients;
        if p.amplitude < GAP * (1.0 - 1e-9) {
            assert!(
                !p.point.touches(),
                "no contact below the gap: {}",
                p.amplitude
            );
            assert!(master(c) < 1e-12 * GAP, "at rest: {}", master(c));
            continue;
        }
        if !p.point.touches() {
            continue;
        }
        let z = common::state_at_zero(c, w);
        let casing = LobedCasing {
            lobes: 1,
            amplitude: p.amplitude,
            phase: settings.phase,
        };
        let sys = oracle(&t, 0.0, (&casing, 1), stiffness);
        let orbit = pwl::periodic_at(&sys, w, &z, 1e-12)
            .unwrap_or_else(|| panic!("no exact orbit at delta = {}", p.amplitude));
        let exact = pwl::trace::first_harmonic(&sys, &orbit, &[0.0, 0.0, 1.0]);
        worst = worst.max((master(c) / exact - 1.0).abs());
        shot += 1;
    }
    let forces: Vec<f64> = (sweep.points.iter())
        .filter(|p| p.point.touches())
        .map(|p| largest_force(&p.point))
        .collect();
    println!(
        "distortion sweep: {} points, N = {} (traced at {:?}), {shot} in contact shot: largest \
         difference of the first harmonic {worst:.2e}; largest contact force {:.4e} .. {:.4e}",
        sweep.points.len(),
        sweep.harmonics,
        sweep.traced,
        forces.first().copied().unwrap_or(0.0),
        forces.last().copied().unwrap_or(0.0)
    );
    assert!(shot >= 8, "{shot}");
    assert!(worst < 1e-3, "{worst}");
    assert!(forces.windows(2).all(|f| f[1] > f[0]), "{forces:?}");
}
