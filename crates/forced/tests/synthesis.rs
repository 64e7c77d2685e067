//! The single-nonlinear-mode synthesis (`synthesize`, `synthesized_peak`) in the linear regime,
//! where the backbone is the linear mode: D(q) equals the modal damping ratio, and the
//! synthesized peak equals the peak of the forced response computed by harmonic balance on the
//! whole model, to the contribution of the non-resonant modes (added in quadrature at the peak:
//! a relative effect of order (2 zeta w1^2 / (w2^2 - w1^2))^2, below 1e-3 here).

mod common;

use nlmodes_forced::{
    nonlinear_damping_ratio, response_curve, synthesize, synthesized_peak, Damping, ForcedSettings,
    ForcedSolver, FreeOrbit, FrfSettings, Load,
};
use nlmodes_hb::FullBasis;

#[test]
fn linear_synthesis_matches_the_modal_damping_and_the_forced_peak() {
    let system = common::three_dof(1e3); // never in contact
    let zeta = 0.005;
    let c = Damping::ModalRatios(vec![zeta]).matrix(&system).unwrap();
    let load = Load::fundamental(vec![0.0, 0.0, 1e-3]);
    let w1 = system.linear_frequencies()[0];
    let phi = system.linear_mode(0).unwrap();
    // The backbone of the linear system: the linear mode at amplitudes q (master = DOF 2).
    let qs: Vec<f64> = (1..=400).map(|i| 0.002 * i as f64).collect();
    let coefficients: Vec<Vec<Vec<f64>>> = qs
        .iter()
        .map(|q| vec![vec![0.0; 3], phi.iter().map(|v| v * q / phi[2]).collect()])
        .collect();
    let orbits: Vec<FreeOrbit> = qs
        .iter()
        .zip(&coefficients)
        .map(|(&q, u)| FreeOrbit {
            q,
            omega: w1,
            coefficients: u,
        })
        .collect();
    let d = nonlinear_damping_ratio(system.mass(), c.as_ref(), &orbits[10]);
    assert!((d - zeta).abs() < 1e-14, "D = {d}");
    let synth = synthesize(system.mass(), c.as_ref(), &load, &orbits).expect("synthesis");
    let (q_synth, w_synth) = synthesized_peak(&synth).unwrap();

    let settings = ForcedSettings::new(3).unwrap();
    let solver = ForcedSolver::new(&system, &c, &load, settings).unwrap();
    let frf = FrfSettings {
        step: 0.0005,
        max_step: 0.001,
        ..FrfSettings::new(0.98 * w1, 1.02 * w1)
    };
    let curve = response_curve(&solver, &frf, |_| {}).unwrap();
    let amp = |p: &nlmodes_forced::ForcedPoint| {
        p.coefficients[(2, FullBasis::cos_index(1))]
            .hypot(p.coefficients[(2, FullBasis::sin_index(1))])
    };
    let peak = curve
        .points
        .iter()
        .max_by(|a, b| amp(a).total_cmp(&amp(b)))
        .unwrap();
    println!(
        "peak q: synthesized {q_synth:.6e}, forced {:.6e}; W/w1 {:.6} vs {:.6}",
        amp(peak),
        w_synth / w1,
        peak.omega / w1
    );
    // q: the linear interpolation of the discriminant on a 0.002 grid (0.3 % of q) and the other
    // modes; W: the forced curve's point spacing (1e-3 w1 at most).
    assert!(
        (q_synth / amp(peak) - 1.0).abs() < 5e-3,
        "{q_synth} vs {}",
        amp(peak)
    );
    assert!((w_synth - peak.omega).abs() < 1e-3 * w1);
}
