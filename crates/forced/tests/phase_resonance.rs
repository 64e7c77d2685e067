//! Phase resonance, exact (Peeters, Kerschen & Golinval 2011; DESIGN §8 of shared/DESIGN.md):
//! a free orbit x(t) of the conservative model, forced on the damped model by exactly its damping
//! force f(t) = C x'(t) at its own frequency, is a solution of the forced problem. The free orbit
//! comes from the free-mode solver (`nlmodes-nnm`, cosine basis, Algorithm 1), the forced orbit
//! from this crate (full basis, the same Algorithm 1 of the engine) started from the linear
//! response: the forced solve must return the free orbit, with zero sine terms, to the
//! accuracy both were converged to, from a start 5 % off it (the linear start lands on the
//! coexisting small orbit out of contact). This checks the forced assembly (damping, load, full basis,
//! condensation) with the exact contact end to end, in deep contact.

mod common;

use nlmodes_forced::{
    Damping, ForcedSettings, ForcedSolver, ForcedStart, HarmonicLoad, Load, OrbitState,
};
use nlmodes_hb::{AlgorithmParams, FullBasis, HarmonicSettings};
use nlmodes_nnm::{backbone, ContinuationSettings};

#[test]
fn the_damping_force_of_a_free_orbit_holds_it() {
    let system = common::three_dof(0.5);
    let (nh, m) = (12, 128);
    let harmonics = HarmonicSettings::new(nh, m).unwrap();
    let algorithm = AlgorithmParams {
        epsilon: 1e-8,
        ..AlgorithmParams::default()
    };
    let q_graze = system.grazing_amplitude(0).unwrap().unwrap();
    // The backbone from the linear regime to 3 q_g (through the fold after grazing); the orbit
    // used is its last point, deep in contact.
    let cont = ContinuationSettings {
        q_start: 0.5 * q_graze,
        q_max: 3.0 * q_graze,
        step: 0.05 * q_graze,
        ..ContinuationSettings::default()
    };
    let family = backbone(&system, harmonics, algorithm.clone(), &cont, |_| {}).unwrap();
    let orbit = family.points.last().unwrap().clone();
    // Exact contact on a coordinate with mass is an impact (one sample in contact per period);
    // the orbit is strongly nonlinear all the same: its frequency is well above the linear one.
    assert!(orbit.omega_ratio > 1.05, "w / w1 = {}", orbit.omega_ratio);

    let c = Damping::Rayleigh {
        alpha: 0.03,
        beta: 0.02,
    }
    .matrix(&system)
    .unwrap();
    // f = C x' with x' = - sum_n n w u_n sin(n w t): a sine load on every harmonic.
    let w = orbit.omega;
    let load = Load {
        harmonics: (1..=nh)
            .map(|n| {
                let cu: Vec<f64> = (0..3)
                    .map(|i| {
                        (0..3)
                            .map(|j| c[(i, j)] * orbit.coefficients[n][j])
                            .sum::<f64>()
                    })
                    .collect();
                HarmonicLoad {
                    harmonic: n,
                    cos: vec![0.0; 3],
                    sin: cu.iter().map(|v| -(n as f64) * w * v).collect(),
                }
            })
            .filter(|h| h.sin.iter().any(|v| *v != 0.0))
            .collect(),
    };
    let settings = ForcedSettings {
        harmonics,
        algorithm,
        ..ForcedSettings::new(nh).unwrap()
    };
    let forced = ForcedSolver::new(&system, &c, &load, settings).unwrap();
    // Above the linear resonance the forced problem has several orbits (the linear start lands on
    // the small one, out of contact); start 5 % above the free orbit (a start below it is out of contact and Newton
    // goes to the small orbit in one linear step), with its multipliers.
    let t = 2 * nh + 1;
    let mut y = vec![0.0; t];
    for i in 0..3 {
        let a = system.contact_rows()[(0, i)];
        y[0] += a * orbit.coefficients[0][i];
        for n in 1..=nh {
            y[FullBasis::cos_index(n)] += 1.05 * a * orbit.coefficients[n][i];
        }
    }
    let start = ForcedStart {
        state: OrbitState {
            y,
            omega: w,
            level: 1.0,
        },
        multipliers: orbit.multipliers.clone(),
    };
    let point = forced.solve(start, None).unwrap();

    let scale = orbit.coefficients[1]
        .iter()
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    let mut worst = 0.0_f64;
    for i in 0..3 {
        worst = worst.max((point.coefficients[(i, 0)] - orbit.coefficients[0][i]).abs());
        for n in 1..=nh {
            let a = point.coefficients[(i, FullBasis::cos_index(n))];
            let b = point.coefficients[(i, FullBasis::sin_index(n))];
            worst = worst.max((a - orbit.coefficients[n][i]).abs()).max(b.abs());
        }
    }
    println!("phase resonance: max coefficient difference {:.3e} of the fundamental {scale:.3e}; G = {:.2e}", worst, point.powell_measure);
    // Both orbits satisfy the sampled complementarity to epsilon g0 = 1e-8 g0; the orbit moves
    // with the contact residual by at most a few times that (the gap is 0.5, q about 1).
    assert!(
        worst <= 1e-7 * scale,
        "forced orbit differs from the free one by {worst:e}"
    );
}
