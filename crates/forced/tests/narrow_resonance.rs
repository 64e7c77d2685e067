//! A resonance narrower than the continuation's step is not jumped over. A 1-DOF oscillator
//! (m = k = 1) at 0.03 % damping, forced below grazing (linear peak at half the gap): its
//! half-power bandwidth is 6e-4 w1, thirty times smaller than the largest step (0.02 w1 when the
//! curve is flat), and the first harmonic's phase turns by pi inside it. Before the phase check
//! (`frf::PHASE_REACH`), the continuation went from below the peak to past it in one step (13
//! points, largest amplitude 0.024 of the peak, a phase turn of 3.1 rad between two points); now
//! the curve's largest amplitude is the exact linear peak F / (2 zeta sqrt(1 - zeta^2) k) to 1 %
//! (measured 9e-5: the points sample the peak), and the phase between consecutive points never
//! turns by more than 1 rad (measured 0.04 rad; 91 points).

use faer::Mat;
use nlmodes_forced::{response_curve, Damping, ForcedSettings, ForcedSolver, FrfSettings, Load};
use nlmodes_hb::{AlgorithmParams, ContactMethod, FullBasis, System};

#[test]
fn a_resonance_narrower_than_the_step_is_traced() {
    let zeta = 3e-4;
    let gap = 2.0;
    let system = System::new(
        Mat::from_fn(1, 1, |_, _| 1.0),
        Mat::from_fn(1, 1, |_, _| 1.0),
        Mat::from_fn(1, 1, |_, _| 1.0),
        vec![gap],
        0,
    )
    .unwrap();
    let c = Damping::ModalRatios(vec![zeta]).matrix(&system).unwrap();
    let force = 2.0 * zeta * 0.5 * gap;
    let load = Load::fundamental(vec![force]);
    let settings = ForcedSettings {
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: 3.0 },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(5).unwrap()
    };
    let solver = ForcedSolver::new(&system, &c, &load, settings).unwrap();
    let curve = response_curve(&solver, &FrfSettings::new(0.9, 1.1), |_| {}).unwrap();
    let amp = |p: &nlmodes_forced::ForcedPoint| {
        p.coefficients[(0, FullBasis::cos_index(1))]
            .hypot(p.coefficients[(0, FullBasis::sin_index(1))])
    };
    let phase = |p: &nlmodes_forced::ForcedPoint| {
        p.coefficients[(0, FullBasis::sin_index(1))]
            .atan2(p.coefficients[(0, FullBasis::cos_index(1))])
    };
    let exact_peak = force / (2.0 * zeta * (1.0 - zeta * zeta).sqrt());
    let largest = curve.points.iter().map(amp).fold(0.0, f64::max);
    let worst_turn = curve
        .points
        .windows(2)
        .map(|w| {
            let d = phase(&w[1]) - phase(&w[0]);
            (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
        })
        .fold(0.0_f64, |a, d| a.max(d.abs()));
    eprintln!(
        "{} points, largest amplitude {largest:.6} (exact peak {exact_peak:.6}), largest phase turn {worst_turn:.3} rad",
        curve.points.len()
    );
    assert!(
        (largest - exact_peak).abs() <= 0.01 * exact_peak,
        "the curve's peak {largest} against the exact {exact_peak}"
    );
    assert!(
        worst_turn <= 1.0,
        "the phase turned by {worst_turn} rad in one step"
    );
}
