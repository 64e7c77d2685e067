//! What the backbone predicts of the forced response (DESIGN §10.7): the amplitude-dependent
//! damping of the nonlinear mode and the single-nonlinear-mode synthesis of the frequency
//! response (Krack, Panning-von Scheidt & Wallaschek 2013, JSV 332; shared/DESIGN.md §8).
//!
//! For a free orbit u(t) = sum_h u_h cos(h w t) of the conservative model at master amplitude q
//! (the backbone point), with the fundamental shape psi = u_1 / q (master component 1) and its
//! modal mass m = psi^T M psi, the damping ratio of the nonlinear mode is the energy balance
//!
//!   D(q) = sum_h h^2 u_h^T C u_h / (2 w m q^2) = sum_h h^2 u_h^T C u_h / (2 w u_1^T M u_1),
//!
//! the power the damping dissipates over the whole orbit, measured against the fundamental's
//! modal mass (Krack 2015's normalization psi_1^H M psi_1 = 1; exact for a linear mode: D = zeta).
//! shared/DESIGN.md §8 writes sum_h h^2 u_h^T M u_h in the denominator; with it the synthesized
//! peak misses the energy balance of phase resonance (F q = w sum_h h^2 u_h^T C u_h for a force
//! F on the master) by the share of the higher harmonics (+45 % on the 3-DOF penalty system of
//! `tests/crowning.rs`); with the fundamental's mass the synthesized peak is that balance. A
//! single-mode model forced by f = f^c cos Wt + f^s sin Wt reads
//! (w^2 - W^2 + 2 i D w W) m q = psi^T (f^c - i f^s), whence for each backbone point
//!
//!   W^2 = w^2 (1 - 2 D^2) +- sqrt(|psi^T f|^2 / (m q)^2 - 4 D^2 w^4 (1 - D^2)),
//!
//! two frequencies (the two flanks of the resonance) where the square root is real; the peak is
//! where it vanishes, q = |psi^T f| / (2 D w^2 m sqrt(1 - D^2)).

use faer::MatRef;

use crate::error::ForcedError;
use crate::load::Load;

/// A backbone point as the synthesis needs it.
#[derive(Clone, Debug)]
pub struct FreeOrbit<'a> {
    /// Master amplitude q (first harmonic of the master, length unit).
    pub q: f64,
    /// Frequency w (rad/s).
    pub omega: f64,
    /// Cosine coefficients u_h, h = 0..=N (each n values).
    pub coefficients: &'a [Vec<f64>],
}

/// The synthesis at one backbone point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SynthesizedPoint {
    /// Master amplitude q.
    pub q: f64,
    /// The backbone's w (rad/s).
    pub omega: f64,
    /// Damping ratio of the nonlinear mode D(q).
    pub damping_ratio: f64,
    /// The two excitation frequencies W (rad/s) with response amplitude q, lower and upper
    /// flank; `None` above the synthesized peak.
    pub flanks: Option<(f64, f64)>,
    /// |psi^T f|^2 / (m q)^2 - 4 D^2 w^4 (1 - D^2) (rad^4/s^4): positive below the synthesized
    /// peak, zero at it.
    pub discriminant: f64,
}

/// The synthesized peak along a branch of points ordered by q: where the discriminant changes
/// sign, q and W = w (1 - 2 D^2)^(1/2) by linear interpolation between the two points.
pub fn synthesized_peak(points: &[SynthesizedPoint]) -> Option<(f64, f64)> {
    points.windows(2).find_map(|w| {
        let (a, b) = (&w[0], &w[1]);
        (a.discriminant >= 0.0 && b.discriminant < 0.0).then(|| {
            let t = a.discriminant / (a.discriminant - b.discriminant);
            let q = a.q + t * (b.q - a.q);
            let omega = a.omega + t * (b.omega - a.omega);
            let d = a.damping_ratio + t * (b.damping_ratio - a.damping_ratio);
            (q, omega * (1.0 - 2.0 * d * d).max(0.0).sqrt())
        })
    })
}

/// sum_h h^2 u_h^T A u_h for a symmetric A.
fn weighted_energy(a: MatRef<'_, f64>, u: &[Vec<f64>]) -> f64 {
    let n = a.nrows();
    u.iter()
        .enumerate()
        .skip(1)
        .map(|(h, uh)| {
            let quad: f64 = (0..n)
                .map(|i| uh[i] * (0..n).map(|j| a[(i, j)] * uh[j]).sum::<f64>())
                .sum();
            (h * h) as f64 * quad
        })
        .sum()
}

/// D(q) of one free orbit (see module docs).
pub fn nonlinear_damping_ratio(
    m: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    orbit: &FreeOrbit<'_>,
) -> f64 {
    weighted_energy(c, orbit.coefficients)
        / (2.0 * orbit.omega * weighted_energy(m, orbit.coefficients))
}

/// Checks free orbits against a model of order `n`: q and w finite and > 0, at least the mean
/// and the fundamental, every coefficient vector of n finite values (a backbone of another
/// model has another order). The error names the point (0-based) and both sizes.
pub fn check_orbits(n: usize, orbits: &[FreeOrbit<'_>]) -> Result<(), ForcedError> {
    for (k, o) in orbits.iter().enumerate() {
        for (name, v) in [("q", o.q), ("w", o.omega)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ForcedError::Load {
                    what: format!("backbone point {k}"),
                    detail: format!("{name} = {v:e}: expected a finite value > 0"),
                });
            }
        }
        if o.coefficients.len() < 2 {
            return Err(ForcedError::Shape {
                what: format!("backbone point {k}"),
                found: format!("{} harmonic(s)", o.coefficients.len()),
                expected: "the mean and at least the fundamental (2)".into(),
            });
        }
        for (h, u) in o.coefficients.iter().enumerate() {
            if u.len() != n {
                return Err(ForcedError::Shape {
                    what: format!("backbone point {k}, harmonic {h}"),
                    found: format!("{} coordinates", u.len()),
                    expected: format!("{n} (the order of the model)"),
                });
            }
            if let Some(i) = u.iter().position(|v| !v.is_finite()) {
                return Err(ForcedError::Load {
                    what: format!("backbone point {k}, harmonic {h}"),
                    detail: format!("coordinate {i} = {}: expected a finite value", u[i]),
                });
            }
        }
    }
    Ok(())
}

/// The single-nonlinear-mode synthesis at each backbone point under the fundamental of `load`;
/// the orbits are checked first ([`check_orbits`] against the order of M).
pub fn synthesize(
    m: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    load: &Load,
    orbits: &[FreeOrbit<'_>],
) -> Result<Vec<SynthesizedPoint>, ForcedError> {
    let n = m.nrows();
    check_orbits(n, orbits)?;
    if c.nrows() != n || c.ncols() != n {
        return Err(ForcedError::Shape {
            what: "damping matrix C".into(),
            found: format!("{}x{}", c.nrows(), c.ncols()),
            expected: format!("{n}x{n}"),
        });
    }
    let highest = load.harmonics.iter().map(|h| h.harmonic).max().unwrap_or(1);
    load.validate(n, highest)?;
    let (fc, fs) = load.at(1, n);
    Ok(orbits
        .iter()
        .filter(|o| o.q > 0.0 && o.coefficients.len() > 1)
        .map(|o| {
            let psi: Vec<f64> = o.coefficients[1].iter().map(|v| v / o.q).collect();
            let modal_mass: f64 = (0..n)
                .map(|i| psi[i] * (0..n).map(|j| m[(i, j)] * psi[j]).sum::<f64>())
                .sum();
            let (pc, ps): (f64, f64) = (0..n).fold((0.0, 0.0), |(a, b), i| {
                (a + psi[i] * fc[i], b + psi[i] * fs[i])
            });
            let force = pc.hypot(ps) / (modal_mass * o.q);
            let d = nonlinear_damping_ratio(m, c, o);
            let w2 = o.omega * o.omega;
            let disc = force * force - 4.0 * d * d * w2 * w2 * (1.0 - d * d);
            let centre = w2 * (1.0 - 2.0 * d * d);
            let flanks = (disc >= 0.0 && centre - disc.sqrt() > 0.0)
                .then(|| ((centre - disc.sqrt()).sqrt(), (centre + disc.sqrt()).sqrt()));
            SynthesizedPoint {
                q: o.q,
                omega: o.omega,
                damping_ratio: d,
                flanks,
                discriminant: disc,
            }
        })
        .collect())
}
