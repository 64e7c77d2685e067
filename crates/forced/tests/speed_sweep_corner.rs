//! The speed sweep past a sharp bend of its curve (`speed_sweep`, `SpeedTrace::at_corner`),
//! against the exact orbits of the penalty equation (`pwl`: exact switches, shooting, arc length
//! through the folds; independent of the crate).
//!
//! The 3-DOF system of the other tests (`common::three_dof`), the same at every speed (so the
//! speed sweep at e is its frequency response at W = e Omega), 1 % modal damping, a stiff
//! penalty law (kc = 100 x the static contact stiffness), N = 8. Where the orbit starts to
//! touch, the curve bends within one step: the tangent through the last point (a parabola
//! through the last three) is then off by a finite angle, and the corrector lands at the same
//! multiple of the step at every step. Before the rule of `at_corner`, the trace here turned
//! back along its own curve and left the range below its start after 1098 points (measured on
//! the commit before; the same happened on the default blade at N = 20, docs/ROTATION.md).

mod common;
mod pwl;

use faer::Mat;
use nlmodes_forced::{
    speed_sweep, Damping, FoldKind, ForcedError, ForcedSettings, FrfTermination, Load, SpeedFamily,
    SpeedHarmonics, SpeedProblem, SpeedSweepSettings,
};
use nlmodes_hb::{AlgorithmParams, ContactMethod, FullBasis, System};

const GAP: f64 = 0.5;
const ZETA: f64 = 0.01;
const FORCE: f64 = 0.08;
const ORDER: f64 = 3.0;

/// The 3-DOF system at every speed, the force on the master x2.
struct Still;

impl SpeedFamily for Still {
    fn at(&self, _speed: f64) -> Result<SpeedProblem, ForcedError> {
        let system: System = common::three_dof(GAP);
        let damping = Damping::ModalRatios(vec![ZETA]).matrix(&system)?;
        Ok(SpeedProblem {
            system,
            damping,
            load: Load::fundamental(vec![0.0, 0.0, FORCE]),
        })
    }
}

/// First-harmonic amplitude of x2.
fn master(c: &Mat<f64>) -> f64 {
    c[(2, FullBasis::cos_index(1))].hypot(c[(2, FullBasis::sin_index(1))])
}

/// The sweep completes through the bend at N = 8 and 16, and its peak and folds are the exact
/// curve's: the peak within 1 % at N = 8 and 1e-3 at 16, closer at 16 (measured 6.9e-3 and
/// 5.9e-4, 2.7e-3 at N = 12: the truncation of the impact's harmonics), its four folds of the
/// same kinds in the same order within 2e-3 in W (measured at most 8.5e-4: a fold is the
/// parabola through the three points around it; one misplaced by a step, up to 0.02, would be
/// off by 1e-2). The old rule left the range at N = 8 and 12. About 8 s.
#[test]
fn a_sweep_passes_a_sharp_bend_and_keeps_the_exact_curve() {
    let (peak8, folds8) = check(8);
    let (peak16, folds16) = check(16);
    assert!(
        peak8 < 1e-2 && peak16 < 1e-3,
        "peak {peak8:.2e}, {peak16:.2e}"
    );
    assert!(peak16 < peak8, "the peak converges to the exact one with N");
    assert!(
        folds8.max(folds16) < 2e-3,
        "folds {folds8:.2e}, {folds16:.2e}"
    );
}

/// The sweep at N = `n`: the relative errors of its peak and of its worst fold against the
/// exact curve.
fn check(n: usize) -> (f64, f64) {
    let system = common::three_dof(GAP);
    let w1 = system.linear_frequencies()[0];
    let kc = 100.0 * system.contact_stiffness()[0];
    let settings = ForcedSettings {
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: kc },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(n).unwrap()
    };
    let range = (0.8 * w1 / ORDER, 1.6 * w1 / ORDER);
    let mut s = SpeedSweepSettings::new(3, 0, range, w1 / ORDER, settings);
    s.harmonic_policy = SpeedHarmonics::Fixed;
    s.stability = false;
    let sweep = speed_sweep(&Still, &s, |_| {}).unwrap();
    assert_eq!(
        sweep.termination,
        FrfTermination::Complete,
        "{}",
        sweep.end_text()
    );
    let speeds: Vec<f64> = sweep.points.iter().map(|p| p.speed).collect();
    assert!(
        speeds.iter().all(|&v| v >= range.0),
        "no point below the range"
    );

    let damping = Damping::ModalRatios(vec![ZETA]).matrix(&system).unwrap();
    let dense = |m: &Mat<f64>| pwl::Dense::from_fn(3, |i, j| m[(i, j)]);
    let a = system.contact_rows();
    let sys = pwl::Pwl {
        n: 3,
        m: dense(&system.mass().to_owned()),
        c: dense(&damping),
        k: dense(&system.stiffness().to_owned()),
        a: (0..3).map(|j| a[(0, j)]).collect(),
        gap: GAP,
        kc,
        fc: vec![0.0, 0.0, FORCE],
        fs: vec![0.0; 3],
        distortion: None,
    };
    let w_end = ORDER * range.1;
    let exact = pwl::trace::ExactCurve::trace(
        sys,
        vec![0.0, 0.0, 1.0],
        (ORDER * range.0, w_end * 1.02),
        (GAP, w1),
        1e-10,
    )
    .expect("the exact curve");
    let (w_peak, q_exact, _) = exact.peak_before(w_end).expect("the exact peak");
    let q = (sweep.points.iter())
        .map(|p| master(&p.point.coefficients))
        .fold(0.0, f64::max);
    let off = (q - q_exact).abs() / q_exact;
    println!(
        "N = {n}: {} points; peak {q:.6} against the exact {q_exact:.6} at W = {w_peak:.6} ({off:.2e})",
        sweep.points.len()
    );
    let exact_folds: Vec<(bool, f64)> = (exact.folds.iter())
        .map(|f| (f.turns_back, exact.samples[f.sample].orbit.omega))
        .filter(|&(_, w)| w < w_end)
        .collect();
    assert_eq!(sweep.folds.len(), exact_folds.len(), "{exact_folds:?}");
    let mut worst: f64 = 0.0;
    for (f, &(back, w)) in sweep.folds.iter().zip(&exact_folds) {
        assert_eq!(f.kind == FoldKind::TurnsBack, back);
        let rel = (ORDER * f.speed - w).abs() / w;
        println!(
            "fold {:?} at W = {:.6}, exact {w:.6} ({rel:.2e})",
            f.kind,
            ORDER * f.speed
        );
        worst = worst.max(rel);
    }
    (off, worst)
}
