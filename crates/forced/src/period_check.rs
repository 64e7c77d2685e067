//! An independent check of a penalty orbit (DESIGN §10.6): one period of the equation of motion
//!
//!   M u'' + C u' + K u + A^T kc (A u - g(t))_+ = f(t)
//!
//! (g(t) = g0, or g0 - delta cos(h W t + phi) under a casing distortion, DESIGN §10.11)
//! integrated by the trapezoidal rule (Newmark's average acceleration, unconditionally stable,
//! second order; the contact set of each step solved implicitly) from the harmonic-balance
//! orbit's state at t = 0. A harmonic-balance orbit that is a periodic solution of this equation
//! returns to its start within the integrator's error, O((w dt)^2) (5e-6 on the coarse blade out
//! of contact at 2000 steps); one that is not (contact dynamics beyond the N harmonics: penalty
//! contact on coordinates with mass rings at sqrt(kc / m_c)) does not, and its Floquet verdict,
//! the linearization along it, cannot be backed (`frf`: undetermined).

use std::collections::HashMap;

use faer::linalg::solvers::{PartialPivLu, Solve};
use faer::Mat;
use nlmodes_hb::{FullBasis, System};

use crate::distortion::CasingDistortion;
use crate::dynamics::product;
use crate::load::Load;

/// Trapezoidal steps per period.
pub const PERIOD_STEPS: usize = 2000;

/// The penalty equation of one orbit's frequency, ready to integrate.
pub struct PeriodCheck<'a> {
    system: &'a System,
    c: &'a Mat<f64>,
    load: &'a Load,
    kc: f64,
    omega: f64,
    dt: f64,
    k_eff: Mat<f64>,
    factors: HashMap<Vec<bool>, PartialPivLu<f64>>,
    distortion: Option<CasingDistortion>,
}

/// (u, v, a) at a step.
struct State {
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
}

fn mul(a: faer::MatRef<'_, f64>, x: &[f64]) -> Vec<f64> {
    let xm = faer::MatRef::from_column_major_slice(x, x.len(), 1);
    let y = product(a, xm);
    (0..a.nrows()).map(|i| y[(i, 0)]).collect()
}

impl<'a> PeriodCheck<'a> {
    /// The check at W = `omega` for penalty stiffness `kc` (N/m).
    pub fn new(system: &'a System, c: &'a Mat<f64>, load: &'a Load, kc: f64, omega: f64) -> Self {
        let dt = 2.0 * std::f64::consts::PI / omega / PERIOD_STEPS as f64;
        let (m, k) = (system.mass(), system.stiffness());
        let k_eff = Mat::from_fn(k.nrows(), k.ncols(), |i, j| {
            k[(i, j)] + 2.0 * c[(i, j)] / dt + 4.0 * m[(i, j)] / (dt * dt)
        });
        Self {
            system,
            c,
            load,
            kc,
            omega,
            dt,
            k_eff,
            factors: HashMap::new(),
            distortion: None,
        }
    }

    /// The same check with the gaps of a casing distortion (`None`: constant gaps).
    pub fn with_distortion(self, distortion: Option<CasingDistortion>) -> Self {
        Self { distortion, ..self }
    }

    /// Every row's gap at time `t` (s): g0_j less the casing's intrusion.
    fn gaps_at(&self, t: f64) -> Vec<f64> {
        let c = self
            .distortion
            .map_or(0.0, |d| d.intrusion_at(self.omega * t));
        self.system.gaps().iter().map(|g| g - c).collect()
    }

    fn force(&self, t: f64) -> Vec<f64> {
        let n = self.system.n_dofs();
        let mut f = vec![0.0; n];
        for h in &self.load.harmonics {
            let (c, s) = (
                (h.harmonic as f64 * self.omega * t).cos(),
                (h.harmonic as f64 * self.omega * t).sin(),
            );
            (0..n).for_each(|i| f[i] += h.cos[i] * c + h.sin[i] * s);
        }
        f
    }

    fn active(&self, u: &[f64], gaps: &[f64]) -> Vec<bool> {
        let y = mul(self.system.contact_rows(), u);
        y.iter().zip(gaps).map(|(y, g)| y > g).collect()
    }

    /// u of the implicit step for the right-hand side r (semi-smooth Newton on the contact set)
    /// with the gaps `g0` of the step's end.
    fn solve_step(&mut self, r: &[f64], guess: &[f64], g0: &[f64]) -> Vec<f64> {
        let rows = self.system.contact_rows();
        let mut u = guess.to_vec();
        for _ in 0..30 {
            let active = self.active(&u, g0);
            let mut rhs = r.to_vec();
            for (j, _) in active.iter().enumerate().filter(|(_, a)| **a) {
                (0..rhs.len()).for_each(|i| rhs[i] += self.kc * rows[(j, i)] * g0[j]);
            }
            if self.factors.len() > 256 {
                self.factors.clear();
            }
            if !self.factors.contains_key(&active) {
                let mut a = self.k_eff.clone();
                for (j, _) in active.iter().enumerate().filter(|(_, a)| **a) {
                    let row = rows.row(j);
                    a += Mat::from_fn(a.nrows(), a.ncols(), |p, q| self.kc * row[p] * row[q]);
                }
                self.factors.insert(active.clone(), a.partial_piv_lu());
            }
            let b = Mat::from_fn(rhs.len(), 1, |i, _| rhs[i]);
            let x = self.factors[&active].solve(&b);
            u = (0..rhs.len()).map(|i| x[(i, 0)]).collect();
            if self.active(&u, g0) == active {
                break;
            }
        }
        u
    }

    fn step(&mut self, s: &State, t_next: f64) -> State {
        let (n, dt) = (s.u.len(), self.dt);
        let mu: Vec<f64> = (0..n)
            .map(|i| 4.0 / (dt * dt) * s.u[i] + 4.0 / dt * s.v[i] + s.a[i])
            .collect();
        let cu: Vec<f64> = (0..n).map(|i| 2.0 / dt * s.u[i] + s.v[i]).collect();
        let (mm, cc, f) = (
            mul(self.system.mass(), &mu),
            mul(self.c.as_ref(), &cu),
            self.force(t_next),
        );
        let r: Vec<f64> = (0..n).map(|i| f[i] + mm[i] + cc[i]).collect();
        let gaps = self.gaps_at(t_next);
        let u = self.solve_step(&r, &s.u, &gaps);
        let a: Vec<f64> = (0..n)
            .map(|i| 4.0 / (dt * dt) * (u[i] - s.u[i]) - 4.0 / dt * s.v[i] - s.a[i])
            .collect();
        let v: Vec<f64> = (0..n)
            .map(|i| s.v[i] + dt / 2.0 * (s.a[i] + a[i]))
            .collect();
        State { u, v, a }
    }

    /// ||x(T) - x(0)|| / ||x(0)|| in the state (u, v / W), from the orbit's coefficients
    /// (n x (2N + 1), `FullBasis` order).
    pub fn residual(&mut self, coefficients: &Mat<f64>) -> f64 {
        let n = coefficients.nrows();
        let series = |i: usize| {
            (0..coefficients.ncols())
                .map(|k| coefficients[(i, k)])
                .collect::<Vec<f64>>()
        };
        let u: Vec<f64> = (0..n)
            .map(|i| FullBasis::value_at(&series(i), 0.0))
            .collect();
        let v: Vec<f64> = (0..n)
            .map(|i| FullBasis::rate_at(&series(i), self.omega, 0.0))
            .collect();
        // a(0) from the equation of motion.
        let (ku, cv, f) = (
            mul(self.system.stiffness(), &u),
            mul(self.c.as_ref(), &v),
            self.force(0.0),
        );
        let y = mul(self.system.contact_rows(), &u);
        let mut rhs: Vec<f64> = (0..n).map(|i| f[i] - ku[i] - cv[i]).collect();
        for (j, (yj, gj)) in y.iter().zip(self.gaps_at(0.0)).enumerate() {
            if *yj > gj {
                (0..n).for_each(|i| {
                    rhs[i] -= self.system.contact_rows()[(j, i)] * self.kc * (yj - gj)
                });
            }
        }
        let llt = self
            .system
            .mass()
            .llt(faer::Side::Lower)
            .expect("M > 0 (checked by System)");
        let am = llt.solve(Mat::from_fn(n, 1, |i, _| rhs[i]));
        let start = State {
            u,
            v,
            a: (0..n).map(|i| am[(i, 0)]).collect(),
        };
        let omega = self.omega;
        let scaled = |s: &State| -> Vec<f64> {
            s.u.iter()
                .copied()
                .chain(s.v.iter().map(|v| v / omega))
                .collect()
        };
        let x0 = scaled(&start);
        let mut s = start;
        for k in 1..=PERIOD_STEPS {
            s = self.step(&s, k as f64 * self.dt);
        }
        let x1 = scaled(&s);
        let norm = x0.iter().map(|v| v * v).sum::<f64>().sqrt();
        x1.iter()
            .zip(&x0)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt()
            / norm
    }
}
