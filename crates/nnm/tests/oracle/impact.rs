//! Exact one-impact-per-period periodic orbits of `M u'' + K u = 0` with a rigid, perfectly elastic
//! stop `a . u <= g` (restitution 1): orbit, cosine coefficients, energy, monodromy matrix (free
//! linear flow and the impact's saltation matrix), Floquet multipliers, folds of the backbone
//! q(w) and stability transitions. Derivation and the 2-DOF numbers: `docs/oracle_impact.md`.
//! Units are those of M, K and g; time in seconds, w in rad/s.
//!
//! Orbit, time origin at the turning point (v(0) = 0), impact at t = tau = T/2 = pi/w. With the
//! M-orthonormal modes Phi (K Phi = M Phi W^2), eta = Phi^T M u and b = Phi^T a, the free flight
//! on [-tau, tau] is eta_k(t) = eta0_k cos(w_k t). Time symmetry needs v(tau-) = s M^-1 a, i.e.
//! eta0_k = -s b_k / (w_k sin(w_k tau)); contact at tau, a . u(tau) = g, gives
//! s = -g / D(tau) with D(tau) = sum_k b_k^2 cot(w_k tau) / w_k. The impact moves into the stop
//! iff s > 0, and the impulse per period is 2 s (the force is -2 s a per period at t = tau).

use faer::{c64, Mat, Side};
use std::f64::consts::PI;

/// Where t = 0 sits on the orbit when coefficients or states are taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeOrigin {
    /// t = 0 at the turning point (v = 0, farthest from the stop); impact at t = T/2.
    TurningPoint,
    /// t = 0 at the impact: the same orbit shifted by T/2, so u_n -> (-1)^n u_n. This is the
    /// convention of a harmonic-balance branch started from a linear mode with positive master
    /// component and q > 0 (the stop is touched where cos(w t) = 1).
    Impact,
}

/// A chain (any dense SPD M, K) with one rigid stop `a . u <= g`.
pub struct ImpactChain {
    mass: Mat<f64>,
    stiffness: Mat<f64>,
    contact: Vec<f64>,
    gap: f64,
    master: usize,
    /// Linear circular frequencies w_k (rad/s), ascending.
    omegas: Vec<f64>,
    /// M-orthonormal mode shapes (columns).
    modes: Mat<f64>,
    /// b = Phi^T a.
    modal_contact: Vec<f64>,
}

/// One exact symmetric one-impact orbit (time origin at the turning point unless stated).
#[derive(Clone, Debug)]
pub struct ImpactOrbit {
    /// Circular frequency w = 2 pi / T (rad/s).
    pub omega: f64,
    /// Period T (s).
    pub period: f64,
    /// Time from the turning point to the impact, tau = T / 2 (s).
    pub tau: f64,
    /// Displacement at the turning point u(0) (v(0) = 0).
    pub turning_point: Vec<f64>,
    /// Modal coordinates of the turning point, eta0 = Phi^T M u(0).
    pub modal_turning_point: Vec<f64>,
    /// Displacement at the impact u(tau) (a . u = g).
    pub impact_displacement: Vec<f64>,
    /// Velocity just before the impact v(tau-) = s M^-1 a; just after it is -v(tau-).
    pub velocity_before_impact: Vec<f64>,
    /// Half the impulse per impact, s (force-time / length of a); > 0 for a real impact.
    pub impulse_half: f64,
    /// Energy 1/2 v^T M v + 1/2 u^T K u (constant along the orbit; the impact conserves it).
    pub energy: f64,
    /// max of a . u - g over [0, tau) (< 0 when the flight stays off the stop).
    pub max_gap_before_impact: f64,
    /// s > 0 and the flight does not reach the stop before tau.
    pub admissible: bool,
}

/// A fold of the backbone q(w): dq/dw = 0.
#[derive(Clone, Copy, Debug)]
pub struct Fold {
    pub omega: f64,
    /// q with [`TimeOrigin::Impact`] (the turning-point q is its opposite).
    pub q_impact: f64,
}

/// Kind of a change of stability along the branch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransitionKind {
    /// A nontrivial multiplier pair meets at +1.
    PlusOne,
    /// A pair meets at -1 (period doubling).
    PeriodDoubling,
    /// Two pairs collide off the real axis (Krein collision, the conservative Neimark-Sacker).
    Krein,
}

/// A point of the branch where the stability changes.
#[derive(Clone, Copy, Debug)]
pub struct StabilityTransition {
    pub omega: f64,
    /// rho = (mu + 1/mu) / 2 of the pair that leaves [-1, 1] (or the unit circle).
    pub rho: c64,
    pub kind: TransitionKind,
    /// Whether the branch is stable just below `omega`.
    pub stable_below: bool,
}

impl ImpactChain {
    /// `m`, `k`: dense symmetric positive definite n x n (rows); `a`: contact row; `g` > 0: gap;
    /// `master`: index of the coordinate whose first harmonic is q. Panics on invalid input
    /// (test support).
    pub fn new(m: &[Vec<f64>], k: &[Vec<f64>], a: &[f64], g: f64, master: usize) -> Self {
        let n = a.len();
        assert!(n > 0 && m.len() == n && k.len() == n, "sizes");
        assert!(g > 0.0 && master < n, "g > 0 and master < n");
        let mass = Mat::from_fn(n, n, |i, j| 0.5 * (m[i][j] + m[j][i]));
        let stiffness = Mat::from_fn(n, n, |i, j| 0.5 * (k[i][j] + k[j][i]));
        let (omegas, modes) = modal_decomposition(&mass, &stiffness);
        let modal_contact = (0..n)
            .map(|c| (0..n).map(|i| modes[(i, c)] * a[i]).sum())
            .collect();
        Self {
            mass,
            stiffness,
            contact: a.to_vec(),
            gap: g,
            master,
            omegas,
            modes,
            modal_contact,
        }
    }

    /// The same chain from a solver [`nlmodes_nnm::System`] with exactly one contact row.
    pub fn from_system(system: &nlmodes_nnm::System) -> Self {
        assert_eq!(system.n_contacts(), 1, "one contact row");
        let n = system.n_dofs();
        let rows = |a: faer::MatRef<'_, f64>| -> Vec<Vec<f64>> {
            (0..n)
                .map(|i| (0..n).map(|j| a[(i, j)]).collect())
                .collect()
        };
        let contact: Vec<f64> = (0..n).map(|i| system.contact_rows()[(0, i)]).collect();
        Self::new(
            &rows(system.mass()),
            &rows(system.stiffness()),
            &contact,
            system.gaps()[0],
            system.master(),
        )
    }

    pub fn dofs(&self) -> usize {
        self.contact.len()
    }

    pub fn mass(&self) -> &Mat<f64> {
        &self.mass
    }

    pub fn stiffness(&self) -> &Mat<f64> {
        &self.stiffness
    }

    pub fn contact_row(&self) -> &[f64] {
        &self.contact
    }

    /// 1/2 v^T M v + 1/2 u^T K u, straight from M and K.
    pub fn energy_of_state(&self, u: &[f64], v: &[f64]) -> f64 {
        let n = self.dofs();
        let quad = |a: &Mat<f64>, x: &[f64]| -> f64 {
            (0..n)
                .map(|i| (0..n).map(|j| x[i] * a[(i, j)] * x[j]).sum::<f64>())
                .sum()
        };
        0.5 * quad(&self.mass, v) + 0.5 * quad(&self.stiffness, u)
    }

    /// -M^-1 K u(0): the acceleration at the turning point (the flow direction is (0, this)).
    pub fn turning_point_acceleration(&self, orbit: &ImpactOrbit) -> Vec<f64> {
        let y: Vec<f64> = (0..self.dofs())
            .map(|k| -self.omegas[k].powi(2) * orbit.modal_turning_point[k])
            .collect();
        self.to_physical(&y)
    }

    pub fn gap(&self) -> f64 {
        self.gap
    }

    /// Linear circular frequencies (rad/s), ascending.
    pub fn linear_omegas(&self) -> &[f64] {
        &self.omegas
    }

    /// b = Phi^T a (modal contact row).
    pub fn modal_contact(&self) -> &[f64] {
        &self.modal_contact
    }

    /// Mode shape k (M-normalized).
    pub fn mode(&self, k: usize) -> Vec<f64> {
        self.modes.col(k).iter().copied().collect()
    }

    /// Grazing frequency of the first-mode branch: w_1.
    pub fn grazing_omega(&self) -> f64 {
        assert!(
            self.modal_contact[0] != 0.0,
            "mode 1 does not touch the contact row"
        );
        self.omegas[0]
    }

    /// First-harmonic coefficient vector of the grazing orbit, impact origin: the linear mode 1
    /// scaled so that max a . u = g, u(t) = (g / b_1) phi_1 cos(w_1 t).
    pub fn grazing_first_harmonic(&self) -> Vec<f64> {
        let b1 = self.modal_contact[0];
        self.mode(0).iter().map(|p| self.gap * p / b1).collect()
    }

    /// D(tau) = sum_k b_k^2 cot(w_k tau) / w_k at tau = pi / w (uncoupled modes, b_k = 0,
    /// contribute nothing).
    fn compliance_sum(&self, omega: f64) -> f64 {
        self.omegas
            .iter()
            .zip(&self.modal_contact)
            .filter(|(_, b)| **b != 0.0)
            .map(|(w, b)| {
                let (sn, cs) = phase(*w, omega);
                b * b * cs / (sn * w)
            })
            .sum()
    }

    /// Modes-to-physical: Phi y.
    fn to_physical(&self, y: &[f64]) -> Vec<f64> {
        let n = self.dofs();
        (0..n)
            .map(|i| (0..n).map(|k| self.modes[(i, k)] * y[k]).sum())
            .collect()
    }

    /// Physical-to-modes: Phi^T M x.
    fn to_modal(&self, x: &[f64]) -> Vec<f64> {
        let n = self.dofs();
        let mx: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| self.mass[(i, j)] * x[j]).sum())
            .collect();
        (0..n)
            .map(|k| (0..n).map(|i| self.modes[(i, k)] * mx[i]).sum())
            .collect()
    }

    /// a . u(t) - g on the free flight of `orbit` (turning-point time, |t| <= tau).
    fn gap_on_flight(&self, eta0: &[f64], t: f64) -> f64 {
        let au: f64 = (0..self.dofs())
            .map(|k| self.modal_contact[k] * eta0[k] * (self.omegas[k] * t).cos())
            .sum();
        au - self.gap
    }

    /// The symmetric one-impact orbit of frequency `omega`; None where it does not exist
    /// (D(tau) = 0: infinite energy; sin(w_k tau) = 0 with b_k != 0: internal resonance).
    pub fn orbit_at_omega(&self, omega: f64) -> Option<ImpactOrbit> {
        if !(omega.is_finite() && omega > 0.0) {
            return None;
        }
        let n = self.dofs();
        let tau = PI / omega;
        let d = self.compliance_sum(omega);
        let s = -self.gap / d;
        let eta0: Vec<f64> = (0..n)
            .map(|k| {
                let (w, b) = (self.omegas[k], self.modal_contact[k]);
                if b == 0.0 {
                    0.0
                } else {
                    -s * b / (w * phase(w, omega).0)
                }
            })
            .collect();
        if !(s.is_finite() && eta0.iter().all(|e| e.is_finite())) {
            return None;
        }
        let eta_impact: Vec<f64> = (0..n)
            .map(|k| eta0[k] * phase(self.omegas[k], omega).1)
            .collect();
        let eta_dot: Vec<f64> = self.modal_contact.iter().map(|b| s * b).collect();
        let energy = 0.5
            * (0..n)
                .map(|k| (self.omegas[k] * eta0[k]).powi(2))
                .sum::<f64>();
        let max_gap = self.max_gap_before_impact(&eta0, tau);
        Some(ImpactOrbit {
            omega,
            period: 2.0 * tau,
            tau,
            turning_point: self.to_physical(&eta0),
            modal_turning_point: eta0,
            impact_displacement: self.to_physical(&eta_impact),
            velocity_before_impact: self.to_physical(&eta_dot),
            impulse_half: s,
            energy,
            max_gap_before_impact: max_gap,
            admissible: s > 0.0 && max_gap < 0.0,
        })
    }

    /// max of a . u(t) - g over [0, tau - dt] (the flight is even in t): samples resolving the
    /// fastest mode (>= 64 per half period), each sampled local maximum refined by golden section.
    fn max_gap_before_impact(&self, eta0: &[f64], tau: f64) -> f64 {
        let w_max = self.omegas[self.dofs() - 1];
        let samples = 400 + 64 * (w_max * tau / PI).ceil() as usize;
        let dt = tau / samples as f64;
        let h = |t: f64| self.gap_on_flight(eta0, t);
        let values: Vec<f64> = (0..samples).map(|i| h(i as f64 * dt)).collect();
        let mut worst = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for i in 1..samples - 1 {
            if values[i] >= values[i - 1] && values[i] >= values[i + 1] {
                let (lo, hi) = ((i - 1) as f64 * dt, (i + 1) as f64 * dt);
                worst = worst.max(golden_section_max(h, lo, hi));
            }
        }
        worst
    }

    /// Orbits at `count` >= 2 evenly spaced frequencies from `w_from` to `w_to` (inclusive),
    /// skipping frequencies where none exists.
    pub fn branch(&self, w_from: f64, w_to: f64, count: usize) -> Vec<ImpactOrbit> {
        assert!(count >= 2);
        (0..count)
            .filter_map(|i| {
                let w = w_from + (w_to - w_from) * i as f64 / (count - 1) as f64;
                self.orbit_at_omega(w)
            })
            .collect()
    }

    /// Cosine coefficients u_0..u_N (u(t) = sum_n u_n cos(n w t)) by exact integration of the
    /// single smooth piece on [-tau, tau]:
    /// (1/tau) int cos(w_k t) cos(n w t) dt = sinc((w_k - n w) tau) + sinc((w_k + n w) tau),
    /// halved for the mean n = 0.
    pub fn cosine_coefficients(
        &self,
        orbit: &ImpactOrbit,
        harmonics: usize,
        origin: TimeOrigin,
    ) -> Vec<Vec<f64>> {
        let n = self.dofs();
        (0..=harmonics)
            .map(|h| {
                let nw = h as f64 * orbit.omega;
                let weight = if h == 0 { 0.5 } else { 1.0 };
                let sign = match origin {
                    TimeOrigin::Impact if h % 2 == 1 => -1.0,
                    _ => 1.0,
                };
                let y: Vec<f64> = (0..n)
                    .map(|k| {
                        let w = self.omegas[k];
                        let detuning = (-(h as f64)).mul_add(orbit.omega, w);
                        let overlap = sinc(detuning * orbit.tau) + sinc((w + nw) * orbit.tau);
                        sign * weight * overlap * orbit.modal_turning_point[k]
                    })
                    .collect();
                self.to_physical(&y)
            })
            .collect()
    }

    /// q = e_master . u_1 of `orbit` for the given time origin.
    pub fn q(&self, orbit: &ImpactOrbit, origin: TimeOrigin) -> f64 {
        self.cosine_coefficients(orbit, 1, origin)[1][self.master]
    }

    /// q in the convention of a harmonic-balance branch started from linear mode 1 with a
    /// positive master component and q > 0: that branch touches the stop at cos(w t) = 1 when
    /// phi_1[master] b_1 > 0 (impact origin), at cos(w t) = -1 otherwise (turning-point origin).
    /// Equals `System::grazing_amplitude(0)` at grazing.
    pub fn q_positive_at_grazing(&self, orbit: &ImpactOrbit) -> f64 {
        let sign = (self.modes[(self.master, 0)] * self.modal_contact[0]).signum();
        sign * self.q(orbit, TimeOrigin::Impact)
    }

    /// Closed form of q (impact origin) as a function of w:
    /// q = (2 g w / (pi D(pi/w))) r(w), r(w) = sum_k phi_k[master] b_k / (w_k^2 - w^2);
    /// returns (q, dq/dw) (dq/dw exact, used to locate folds).
    pub fn q_impact_closed_form(&self, omega: f64) -> (f64, f64) {
        let d = self.compliance_sum(omega);
        let (mut r, mut dr, mut dd_dtau) = (0.0, 0.0, 0.0);
        for k in 0..self.dofs() {
            let (w, b) = (self.omegas[k], self.modal_contact[k]);
            if b == 0.0 {
                continue;
            }
            let c = self.modes[(self.master, k)] * b;
            let den = (w - omega) * (w + omega);
            r += c / den;
            dr += c * 2.0 * omega / (den * den);
            dd_dtau -= b * b / phase(w, omega).0.powi(2);
        }
        let dd_dw = dd_dtau * (-PI / (omega * omega));
        let scale = 2.0 * self.gap / PI;
        let q = scale * omega * r / d;
        let dq = scale * (r / d + omega * dr / d - omega * r * dd_dw / (d * d));
        (q, dq)
    }

    /// Locates a fold dq/dw = 0 in [w_lo, w_hi] (dq/dw must change sign there) by bisection on
    /// the exact derivative, to |dw| <= 1e-13 w.
    pub fn fold_near(&self, w_lo: f64, w_hi: f64) -> Option<Fold> {
        let slope = |w: f64| self.q_impact_closed_form(w).1;
        let omega = bisect_sign_change(slope, w_lo, w_hi)?;
        Some(Fold {
            omega,
            q_impact: self.q_impact_closed_form(omega).0,
        })
    }

    /// Closed form of the energy as a function of w, E = -g^2 D'(tau) / (2 D(tau)^2) with
    /// D'(tau) = -sum_k b_k^2 / sin^2(w_k tau); returns (E, dE/dw), dE/dw exact.
    pub fn energy_closed_form(&self, omega: f64) -> (f64, f64) {
        let d = self.compliance_sum(omega);
        let (mut d1, mut d2) = (0.0, 0.0);
        for k in 0..self.dofs() {
            let (w, b) = (self.omegas[k], self.modal_contact[k]);
            if b == 0.0 {
                continue;
            }
            let (sn, cs) = phase(w, omega);
            d1 -= b * b / (sn * sn);
            d2 += 2.0 * b * b * w * cs / (sn * sn * sn);
        }
        let g2 = self.gap * self.gap;
        let energy = -g2 * d1 / (2.0 * d * d);
        let de_dtau = -g2 * (d2 * d - 2.0 * d1 * d1) / (2.0 * d * d * d);
        (energy, de_dtau * (-PI / (omega * omega)))
    }

    /// Extremum of the energy along the branch (dE/dw = 0) in [w_lo, w_hi], by bisection on the
    /// exact derivative; returns (w, E). In a conservative family a nontrivial multiplier pair
    /// passes +1 exactly there (independent check of the monodromy).
    pub fn energy_extremum(&self, w_lo: f64, w_hi: f64) -> Option<(f64, f64)> {
        let w = bisect_sign_change(|w| self.energy_closed_form(w).1, w_lo, w_hi)?;
        Some((w, self.energy_closed_form(w).0))
    }

    /// All frequencies in [w_from, w_to] where the admissible branch has q (impact origin) equal
    /// to `q`: sign changes of q(w) - q over `samples` points between admissible orbits, each
    /// bisected to |dw| <= 1e-13 w. For comparing a solver point (q, w) with the exact branch.
    pub fn omegas_at_q(&self, q: f64, w_from: f64, w_to: f64, samples: usize) -> Vec<f64> {
        let defect = |w: f64| self.q_impact_closed_form(w).0 - q;
        let admissible = |w: f64| self.orbit_at_omega(w).is_some_and(|o| o.admissible);
        let grid: Vec<f64> = (0..samples)
            .map(|i| w_from + (w_to - w_from) * i as f64 / (samples - 1) as f64)
            .collect();
        grid.windows(2)
            .filter(|p| admissible(p[0]) && admissible(p[1]))
            .filter_map(|p| bisect_sign_change(defect, p[0], p[1]))
            .collect()
    }

    /// Frequency above `w_lo` where D(pi/w) = 0 (the impulse and the energy diverge: the branch
    /// ends), searched in [w_lo, w_hi] by bisection.
    pub fn infinite_energy_omega(&self, w_lo: f64, w_hi: f64) -> Option<f64> {
        bisect_sign_change(|w| self.compliance_sum(w), w_lo, w_hi)
    }

    /// Displacement and velocity at time t (any t; periodic extension, right-continuous
    /// velocity at the impacts).
    pub fn state_at(
        &self,
        orbit: &ImpactOrbit,
        t: f64,
        origin: TimeOrigin,
    ) -> (Vec<f64>, Vec<f64>) {
        let t_turn = match origin {
            TimeOrigin::TurningPoint => t,
            TimeOrigin::Impact => t + orbit.tau,
        };
        let local = t_turn - orbit.period * ((t_turn + orbit.tau) / orbit.period).floor();
        let eta0 = &orbit.modal_turning_point;
        let n = self.dofs();
        let eta: Vec<f64> = (0..n)
            .map(|k| eta0[k] * (self.omegas[k] * local).cos())
            .collect();
        let eta_dot: Vec<f64> = (0..n)
            .map(|k| -eta0[k] * self.omegas[k] * (self.omegas[k] * local).sin())
            .collect();
        (self.to_physical(&eta), self.to_physical(&eta_dot))
    }

    /// Free linear flow exp(A t), A = [[0, I], [-M^-1 K, 0]], on x = (u, v), exact via the modes.
    pub fn free_flow(&self, t: f64) -> Mat<f64> {
        let n = self.dofs();
        let project = Mat::from_fn(n, n, |k, j| {
            (0..n)
                .map(|i| self.modes[(i, k)] * self.mass[(i, j)])
                .sum::<f64>()
        });
        let block = |f: &dyn Fn(f64) -> f64| {
            Mat::from_fn(n, n, |i, j| {
                (0..n)
                    .map(|k| self.modes[(i, k)] * f(self.omegas[k]) * project[(k, j)])
                    .sum::<f64>()
            })
        };
        let c = block(&|w| (w * t).cos());
        let s_over_w = block(&|w| if w == 0.0 { t } else { (w * t).sin() / w });
        let minus_ws = block(&|w| -w * (w * t).sin());
        Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
            (true, true) => c[(i, j)],
            (true, false) => s_over_w[(i, j - n)],
            (false, true) => minus_ws[(i - n, j)],
            (false, false) => c[(i - n, j - n)],
        })
    }

    /// Saltation matrix of the impact of `orbit` (state-jump saltation matrix of Leine &
    /// Nijmeijer 2004; Di Bernardo et al. 2008): S = G + (f+ - G f-) n^T / (n^T f-), with h(x) = a . u - g,
    /// n = grad h = (a, 0), jump map x -> (u, R v), G = diag(I, R),
    /// R = I - 2 M^-1 a a^T / (a^T M^-1 a), f- = (v-, -M^-1 K u), f+ = (R v-, -M^-1 K u).
    pub fn saltation(&self, orbit: &ImpactOrbit) -> Mat<f64> {
        let n = self.dofs();
        let minv_a = self.to_physical(&self.modal_contact);
        let a_minv_a: f64 = self.modal_contact.iter().map(|b| b * b).sum();
        let reflect = Mat::from_fn(n, n, |i, j| {
            let id = if i == j { 1.0 } else { 0.0 };
            id - 2.0 * minv_a[i] * self.contact[j] / a_minv_a
        });
        let v = &orbit.velocity_before_impact;
        let eta = self.to_modal(&orbit.impact_displacement);
        let minv_k_u = self.to_physical(
            &(0..n)
                .map(|k| self.omegas[k].powi(2) * eta[k])
                .collect::<Vec<_>>(),
        );
        let jump = Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
            (true, true) => f64::from(u8::from(i == j)),
            (false, false) => reflect[(i - n, j - n)],
            _ => 0.0,
        });
        let f_minus: Vec<f64> = v
            .iter()
            .copied()
            .chain(minv_k_u.iter().map(|x| -x))
            .collect();
        let rv: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| reflect[(i, j)] * v[j]).sum())
            .collect();
        let f_plus: Vec<f64> = rv.into_iter().chain(minv_k_u.iter().map(|x| -x)).collect();
        let g_f_minus: Vec<f64> = (0..2 * n)
            .map(|i| (0..2 * n).map(|j| jump[(i, j)] * f_minus[j]).sum())
            .collect();
        let normal_speed: f64 = (0..n).map(|i| self.contact[i] * v[i]).sum();
        Mat::from_fn(2 * n, 2 * n, |i, j| {
            let grad_h = if j < n { self.contact[j] } else { 0.0 };
            jump[(i, j)] + (f_plus[i] - g_f_minus[i]) * grad_h / normal_speed
        })
    }

    /// Monodromy over one period starting just after an impact, S exp(A T) (alias of
    /// [`Self::monodromy_after_impact`]).
    pub fn monodromy(&self, orbit: &ImpactOrbit) -> Mat<f64> {
        self.monodromy_after_impact(orbit)
    }

    /// Monodromy over one period starting just after an impact: S exp(A T).
    pub fn monodromy_after_impact(&self, orbit: &ImpactOrbit) -> Mat<f64> {
        self.saltation(orbit) * self.free_flow(orbit.period)
    }

    /// Monodromy over one period starting at the turning point: exp(A tau) S exp(A tau)
    /// (similar to [`Self::monodromy_after_impact`]; same multipliers).
    pub fn monodromy_at_turning_point(&self, orbit: &ImpactOrbit) -> Mat<f64> {
        let half = self.free_flow(orbit.tau);
        &half * self.saltation(orbit) * &half
    }

    /// Floquet multipliers (eigenvalues of the monodromy, 2n of them).
    pub fn multipliers(&self, orbit: &ImpactOrbit) -> Vec<c64> {
        self.monodromy_at_turning_point(orbit)
            .eigenvalues()
            .expect("eigenvalues of the monodromy")
    }

    /// rho = (mu + 1/mu) / 2 for each nontrivial reciprocal pair (the pair of multipliers nearest
    /// +1 — time shift and family direction — removed). rho in [-1, 1] for an elliptic (stable)
    /// pair; rho = (mu_i + mu_j) / 2 uses the pair sum, well conditioned at collisions.
    /// For n = 2 the single pair is taken from the trace, rho = tr/2 - 1 (exact, no eigenvalues).
    pub fn floquet_pairs(&self, orbit: &ImpactOrbit) -> Vec<c64> {
        if self.dofs() == 2 {
            let mon = self.monodromy_at_turning_point(orbit);
            let trace: f64 = (0..4).map(|i| mon[(i, i)]).sum();
            return vec![c64::new(0.5 * trace - 1.0, 0.0)];
        }
        self.floquet_pairs_from_eigenvalues(orbit)
    }

    /// [`Self::floquet_pairs`] from the eigenvalues, any n (the trivial pair: the two
    /// multipliers nearest +1; partners matched by nearest 1/mu).
    pub fn floquet_pairs_from_eigenvalues(&self, orbit: &ImpactOrbit) -> Vec<c64> {
        let mut mu = self.multipliers(orbit);
        mu.sort_by(|x, y| {
            (x - c64::new(1.0, 0.0))
                .norm()
                .total_cmp(&(y - c64::new(1.0, 0.0)).norm())
        });
        let mut rest: Vec<c64> = mu[2..].to_vec();
        let mut rho = Vec::new();
        while let Some(first) = rest.pop() {
            let inverse = c64::new(1.0, 0.0) / first;
            let (j, _) = rest
                .iter()
                .enumerate()
                .min_by(|(_, x), (_, y)| (*x - inverse).norm().total_cmp(&(*y - inverse).norm()))
                .expect("multipliers come in reciprocal pairs");
            let partner = rest.swap_remove(j);
            rho.push((first + partner) * 0.5);
        }
        rho
    }

    /// Signed instability measure: max over nontrivial pairs of |Re rho| - 1, or |Im rho| for a
    /// Krein quadruplet (|Im rho| > 1e-7). <= 0: linearly stable (all |mu| = 1).
    pub fn instability(&self, orbit: &ImpactOrbit) -> f64 {
        self.floquet_pairs(orbit)
            .iter()
            .map(|r| {
                if r.im.abs() > 1e-7 {
                    r.im.abs()
                } else {
                    r.re.abs() - 1.0
                }
            })
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Largest multiplier modulus.
    pub fn max_multiplier_modulus(&self, orbit: &ImpactOrbit) -> f64 {
        self.multipliers(orbit)
            .iter()
            .map(|m| m.norm())
            .fold(0.0, f64::max)
    }

    /// Stability transitions on [w_from, w_to]: scan `count` admissible orbits, bisect each
    /// sign change of [`Self::instability`] to |dw| <= 1e-13 w.
    pub fn stability_transitions(
        &self,
        w_from: f64,
        w_to: f64,
        count: usize,
    ) -> Vec<StabilityTransition> {
        let measure = |w: f64| {
            self.orbit_at_omega(w)
                .filter(|o| o.admissible)
                .map(|o| self.instability(&o))
        };
        let mut found = Vec::new();
        let mut previous: Option<(f64, f64)> = None;
        for i in 0..count {
            let w = w_from + (w_to - w_from) * i as f64 / (count - 1) as f64;
            let Some(m) = measure(w) else {
                previous = None;
                continue;
            };
            if let Some((w_prev, m_prev)) = previous {
                if (m_prev > 0.0) != (m > 0.0) {
                    let f = |x: f64| measure(x).unwrap_or(f64::NAN);
                    if let Some(omega) = bisect_sign_change(f, w_prev, w) {
                        found.push(self.classify(omega, m_prev <= 0.0));
                    }
                }
            }
            previous = Some((w, m));
        }
        found
    }

    fn classify(&self, omega: f64, stable_below: bool) -> StabilityTransition {
        let orbit = self.orbit_at_omega(omega).expect("orbit at a transition");
        let rho = self
            .floquet_pairs(&orbit)
            .into_iter()
            .max_by(|x, y| (x.re.abs() + x.im.abs()).total_cmp(&(y.re.abs() + y.im.abs())))
            .expect("n >= 2 has a nontrivial pair");
        let kind = if rho.im.abs() > 1e-7 {
            TransitionKind::Krein
        } else if rho.re > 0.0 {
            TransitionKind::PlusOne
        } else {
            TransitionKind::PeriodDoubling
        };
        StabilityTransition {
            omega,
            rho,
            kind,
            stable_below,
        }
    }

    /// Exact nonsmooth flow from (u, v) over `duration`: analytic free flight, impacts located
    /// by sampling a . u - g (>= 64 samples per period of the fastest mode) and bisection to
    /// machine precision, velocity jump v -> R v. Returns (u, v, impact times). Independent of
    /// the symmetric construction of [`Self::orbit_at_omega`]. Assumes transversal impacts.
    pub fn nonsmooth_flow(
        &self,
        u: &[f64],
        v: &[f64],
        duration: f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut eta = self.to_modal(u);
        let mut eta_dot = self.to_modal(v);
        let mut elapsed = 0.0;
        let mut impacts = Vec::new();
        while let Some(t_hit) = self.first_impact(&eta, &eta_dot, duration - elapsed) {
            (eta, eta_dot) = self.fly_modal(&eta, &eta_dot, t_hit);
            let b = &self.modal_contact;
            let b2: f64 = b.iter().map(|x| x * x).sum();
            let normal: f64 = b.iter().zip(&eta_dot).map(|(x, y)| x * y).sum();
            for (e, bk) in eta_dot.iter_mut().zip(b) {
                *e -= 2.0 * bk * normal / b2;
            }
            elapsed += t_hit;
            impacts.push(elapsed);
        }
        (eta, eta_dot) = self.fly_modal(&eta, &eta_dot, duration - elapsed);
        (self.to_physical(&eta), self.to_physical(&eta_dot), impacts)
    }

    fn fly_modal(&self, eta: &[f64], eta_dot: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
        let mut e = Vec::with_capacity(eta.len());
        let mut d = Vec::with_capacity(eta.len());
        for k in 0..eta.len() {
            let w = self.omegas[k];
            let (sn, cs) = (w * t).sin_cos();
            e.push(eta[k] * cs + eta_dot[k] * sn / w);
            d.push(-eta[k] * w * sn + eta_dot[k] * cs);
        }
        (e, d)
    }

    /// First t in (0, horizon] where a . u - g crosses 0 from below, or None. Between samples
    /// a maximum of a . u - g (sign change of its rate) is located too, so that a brief
    /// excursion above the stop near grazing is not stepped over.
    fn first_impact(&self, eta: &[f64], eta_dot: &[f64], horizon: f64) -> Option<f64> {
        let gap_and_rate = |t: f64| {
            let (e, d) = self.fly_modal(eta, eta_dot, t);
            let b = &self.modal_contact;
            let h = e.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() - self.gap;
            (h, d.iter().zip(b).map(|(x, y)| x * y).sum::<f64>())
        };
        let h = |t: f64| gap_and_rate(t).0;
        let rate = |t: f64| gap_and_rate(t).1;
        let dt = 2.0 * PI / (64.0 * self.omegas[self.dofs() - 1]);
        let steps = (horizon / dt).ceil().max(1.0) as usize;
        let mut t0 = 0.0;
        let (mut h0, mut r0) = gap_and_rate(0.0);
        for i in 1..=steps {
            let t1 = (i as f64 * dt).min(horizon);
            let (h1, r1) = gap_and_rate(t1);
            if h0 < 0.0 && h1 >= 0.0 {
                return bisect_sign_change(h, t0, t1);
            }
            if h0 < 0.0 && r0 > 0.0 && r1 < 0.0 {
                let t_max = bisect_sign_change(rate, t0, t1).unwrap_or(t0);
                if h(t_max) >= 0.0 {
                    return bisect_sign_change(h, t0, t_max);
                }
            }
            (t0, h0, r0) = (t1, h1, r1);
        }
        None
    }
}

/// M-orthonormal modes of (K, M): w_k ascending and Phi with Phi^T M Phi = I.
fn modal_decomposition(mass: &Mat<f64>, stiffness: &Mat<f64>) -> (Vec<f64>, Mat<f64>) {
    let n = mass.nrows();
    let llt = mass
        .llt(Side::Lower)
        .expect("M must be symmetric positive definite");
    let l = llt.L().to_owned();
    let mut left = stiffness.clone();
    l.solve_lower_triangular_in_place(left.as_mut());
    let mut reduced = left.transpose().to_owned();
    l.solve_lower_triangular_in_place(reduced.as_mut());
    let reduced = Mat::from_fn(n, n, |i, j| 0.5 * (reduced[(i, j)] + reduced[(j, i)]));
    let eig = reduced
        .self_adjoint_eigen(Side::Lower)
        .expect("symmetric eigenproblem");
    let omegas: Vec<f64> = (0..n)
        .map(|i| {
            let lambda = eig.S().column_vector()[i];
            assert!(lambda > 0.0, "K must be positive definite");
            lambda.sqrt()
        })
        .collect();
    let mut modes = eig.U().to_owned();
    l.transpose()
        .solve_upper_triangular_in_place(modes.as_mut());
    (omegas, modes)
}

/// (sin, cos) of w_k tau = pi w_k / w, accurate also where w_k / w is near an integer m
/// (grazing, internal resonance): w_k - m w is formed with one rounding (fused multiply-add)
/// and the phase reduced by m pi exactly.
fn phase(w_k: f64, omega: f64) -> (f64, f64) {
    let m = (w_k / omega).round();
    let (sn, cs) = (PI * (-m).mul_add(omega, w_k) / omega).sin_cos();
    if m.rem_euclid(2.0) == 1.0 {
        (-sn, -cs)
    } else {
        (sn, cs)
    }
}

/// sin(x) / x, stable near 0.
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

/// Root of `f` in [lo, hi] where f changes sign, by bisection until |hi - lo| <= 1e-13 |hi|
/// (or machine precision); None without a sign change at the ends.
fn bisect_sign_change(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> Option<f64> {
    let (mut lo, mut hi) = (lo, hi);
    let (f_lo, f_hi) = (f(lo), f(hi));
    if !(f_lo.is_finite() && f_hi.is_finite()) || (f_lo > 0.0) == (f_hi > 0.0) {
        return None;
    }
    let lo_positive = f_lo > 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi || hi - lo <= 1e-13 * hi.abs() {
            break;
        }
        if (f(mid) > 0.0) == lo_positive {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Maximum of a unimodal `f` on [lo, hi] by golden section (to machine precision in t).
fn golden_section_max(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let ratio = 0.5 * (5.0_f64.sqrt() - 1.0);
    let (mut a, mut b) = (lo, hi);
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..80 {
        if fc > fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    f(lo).max(f(hi)).max(fc).max(fd)
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n; exact for degree 2n - 1).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                (p0, p1) = (p1, p2);
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pn_minus = if n == 1 { 1.0 } else { p0 };
            derivative = n as f64 * (x * pn - pn_minus) / (x * x - 1.0);
            let step = pn / derivative;
            x -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * derivative * derivative);
    }
    (nodes, weights)
}
