//! The nonlinear-mode solver at one amplitude: Algorithm 1 around the inner Newton solve, and the
//! assembly of a [`BackbonePoint`] from the converged state.

use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_hb::augmented_lagrangian::{
    run_algorithm1, AlgorithmParams, ContactMethod, InnerSolves, OuterReport,
};
use nlmodes_hb::contact::{powell_measure, Multipliers};
use nlmodes_hb::fourier::{Aft, HarmonicSettings};
use nlmodes_hb::linear_model::{LinearModel, ParameterRow};
use nlmodes_hb::newton::{
    Evaluation, InnerProblem, NewtonReport, NewtonSettings, NewtonState, NewtonWork,
};
use nlmodes_hb::newton_fallback::solve_inner_robust;
use nlmodes_hb::solver_settings::SolverSettings;
use nlmodes_hb::system::System;

/// Where a solve starts from.
#[derive(Clone, Copy, Debug)]
pub enum Start<'a> {
    /// Linear mode `mode` (0-based) scaled to the requested q, w = its linear frequency, theta = 0,
    /// kappa = kappa^(1). Exact below grazing.
    LinearMode(usize),
    /// A previously computed point: coefficients, w, theta and kappa (warm start).
    Point(&'a BackbonePoint),
}

/// An initial guess in physical coordinates.
#[derive(Clone)]
pub(crate) struct Guess {
    pub mode: usize,
    pub coefficients: Vec<Vec<f64>>,
    pub omega: f64,
    pub q: f64,
    pub multipliers: Multipliers,
}

/// Reusable solver for one system, harmonic settings and solver settings: FFT plans,
/// condensation basis and Newton buffers are built once.
pub struct Solver<'s> {
    system: &'s System,
    settings: HarmonicSettings,
    /// Algorithm 1's parameters.
    params: AlgorithmParams,
    /// The inner Newton solver's settings.
    newton: NewtonSettings,
    model: Box<dyn LinearModel + 's>,
    aft: Aft,
    work: NewtonWork,
    kappa_initial: Vec<f64>,
    kappa_cap: Vec<f64>,
    norm_scale: f64,
    omegas: Vec<f64>,
}

impl<'s> Solver<'s> {
    /// Validates the settings and precomputes what does not change between amplitudes.
    /// `solver` is a [`SolverSettings`], or just the [`AlgorithmParams`] (then with the default
    /// Newton settings and condensation).
    pub fn new(
        system: &'s System,
        settings: HarmonicSettings,
        solver: impl Into<SolverSettings>,
    ) -> Result<Self, NnmError> {
        let SolverSettings {
            algorithm: params,
            newton,
            condensation,
        } = solver.into();
        settings.validate()?;
        params.validate()?;
        newton.validate()?;
        let model =
            condensation.linear_model(system, newton.resonance_window, settings.harmonics)?;
        let ks = system.contact_stiffness();
        let kappa_initial = ks.iter().map(|k| k * params.initial_penalty).collect();
        let kappa_cap = ks.iter().map(|k| k * params.max_penalty).collect();
        let master = system.master();
        Ok(Self {
            system,
            settings,
            aft: Aft::new(settings),
            params,
            newton,
            model,
            work: NewtonWork::default(),
            kappa_initial,
            kappa_cap,
            norm_scale: system.stiffness()[(master, master)].sqrt(),
            omegas: system.linear_frequencies(),
        })
    }

    /// The system solved.
    pub fn system(&self) -> &'s System {
        self.system
    }

    /// Harmonic settings in use.
    pub fn settings(&self) -> HarmonicSettings {
        self.settings
    }

    /// Algorithm 1's parameters in use.
    pub fn params(&self) -> &AlgorithmParams {
        &self.params
    }

    /// Linear circular frequency of `mode` (rad/s).
    pub fn linear_frequency(&self, mode: usize) -> Result<f64, NnmError> {
        self.omegas
            .get(mode)
            .copied()
            .ok_or(NnmError::ModeOutOfRange {
                mode,
                count: self.omegas.len(),
            })
    }

    /// Solves the nonlinear mode at master amplitude `q` > 0 (Algorithm 1, or one penalty solve).
    pub fn solve_point(&mut self, q: f64, start: Start<'_>) -> Result<BackbonePoint, NnmError> {
        if !(q.is_finite() && q > 0.0) {
            return Err(NnmError::InvalidParameter {
                name: "q",
                value: q,
                expected: "a finite master amplitude > 0",
            });
        }
        let guess = self.guess(start, q)?;
        let w_ref = self.linear_frequency(guess.mode)?;
        let row = ParameterRow::fixed_amplitude(q, self.system.gap_reference(), w_ref);
        self.solve_with_row(row, guess, None)
    }

    /// Initial guess from a start, scaled to amplitude q for a linear mode.
    pub(crate) fn guess(&self, start: Start<'_>, q: f64) -> Result<Guess, NnmError> {
        let (n, nh, m) = (
            self.system.n_dofs(),
            self.settings.terms(),
            self.settings.samples,
        );
        match start {
            Start::LinearMode(mode) => {
                let phi = self.system.linear_mode(mode)?;
                let scale = q / phi[self.system.master()];
                let mut coefficients = vec![vec![0.0; n]; nh];
                coefficients[1] = phi.iter().map(|v| v * scale).collect();
                Ok(Guess {
                    mode,
                    coefficients,
                    omega: self.linear_frequency(mode)?,
                    q,
                    multipliers: Multipliers::uniform(&self.kappa_initial, m),
                })
            }
            Start::Point(p) => {
                if p.coefficients.iter().any(|c| c.len() != n) || p.coefficients.len() < 2 {
                    return Err(NnmError::WarmStart {
                        detail: format!(
                            "the point has {} coefficient vectors of length {}, the system has {n} DOFs",
                            p.coefficients.len(),
                            p.coefficients.first().map_or(0, Vec::len)
                        ),
                    });
                }
                self.linear_frequency(p.mode)?;
                let mut coefficients = p.coefficients.clone();
                coefficients.resize(nh, vec![0.0; n]);
                let c = self.system.n_contacts();
                let multipliers =
                    if p.multipliers.samples == m && p.multipliers.theta.len() == c * m {
                        p.multipliers.clone()
                    } else {
                        Multipliers::uniform(&self.kappa_initial, m)
                    };
                Ok(Guess {
                    mode: p.mode,
                    coefficients,
                    omega: p.omega,
                    q: p.q,
                    multipliers,
                })
            }
        }
    }

    /// Solves with a general parameter row (fixed q or pseudo-arc-length) from a guess. With a
    /// `leash`, the solve is abandoned ([`NnmError::LeftPredictor`]) as soon as an iterate of
    /// Algorithm 1 lies farther than the leash from the row's predictor (q_p, w_p), in the row's
    /// scaled units: a continuation corrector that would be rejected as far from its predictor
    /// stops early instead of converging there (docs/DESIGN.md §8.2).
    pub(crate) fn solve_with_row(
        &mut self,
        row: ParameterRow,
        guess: Guess,
        leash: Option<f64>,
    ) -> Result<BackbonePoint, NnmError> {
        let layout = self.model.layout();
        let n = self.system.n_dofs();
        let physical = layout.with_dim(n);
        let mut u = vec![0.0; physical.len()];
        for (h, c) in guess.coefficients.iter().enumerate().take(layout.count()) {
            physical.harmonic_mut(&mut u, h).copy_from_slice(c);
        }
        let mut x = vec![0.0; layout.len()];
        self.model.physical_to_model(&u, layout.count(), &mut x);
        let mut multipliers = guess.multipliers;
        let g0 = self.system.gaps();
        let mut inner = InnerSolve {
            model: self.model.as_mut(),
            aft: &mut self.aft,
            spent0: self.work.spent,
            work: &mut self.work,
            newton: &self.newton,
            row: &row,
            g0,
            samples: self.settings.samples,
            norm_scale: self.norm_scale,
            arc_scale: self.norm_scale * self.system.gap_reference(),
            g_ref: self.system.gap_reference(),
            budget: self.params.newton_budget,
            state: NewtonState {
                x,
                omega: guess.omega,
                q: guess.q,
            },
            last_good: None,
            kept: None,
            leash,
        };
        let report = match self.params.method {
            ContactMethod::Penalty { stiffness } => {
                multipliers =
                    Multipliers::uniform(&vec![stiffness; g0.len()], self.settings.samples);
                penalty_solve(&mut inner, &multipliers, &self.params).map_err(|e| {
                    NnmError::NotConverged {
                        q: row.q_p,
                        q_over_g0: row.q_p / self.system.gap_reference(),
                        reason: format!("penalty solve failed: {e}"),
                        measure: f64::INFINITY,
                        epsilon: self.params.epsilon,
                        accepted: 0,
                        solves: 1,
                        newton_iterations: 0,
                    }
                })?
            }
            ContactMethod::AugmentedLagrangian => run_algorithm1(
                &self.params,
                g0,
                &self.kappa_cap,
                &mut multipliers,
                &mut inner,
            )
            .map_err(|f| NnmError::NotConverged {
                q: inner.state.q,
                q_over_g0: inner.state.q / self.system.gap_reference(),
                reason: f.reason,
                measure: f.report.measure,
                epsilon: self.params.epsilon,
                accepted: f.report.accepted,
                solves: f.report.solves,
                newton_iterations: f.report.newton_iterations,
            })?,
        };
        let state = inner.state;
        self.build_point(guess.mode, &state, multipliers, report)
    }

    /// The converged point: orbit in physical coordinates, contact summary, energy, truncation
    /// indicator and modal shares.
    fn build_point(
        &self,
        mode: usize,
        state: &NewtonState,
        multipliers: Multipliers,
        report: OuterReport,
    ) -> Result<BackbonePoint, NnmError> {
        let sys = self.system;
        let (n, nh) = (sys.n_dofs(), self.model.layout().count());
        let mut flat = vec![0.0; n * nh];
        self.model.model_to_physical(&state.x, nh, &mut flat);
        let coefficients: Vec<Vec<f64>> = flat.chunks(n).map(<[f64]>::to_vec).collect();
        let contact = self.contact_summary();
        let energy = self.turning_point_energy(&coefficients);
        let truncation_share = self.truncation_share();
        let truncation_warning = truncation_share > self.params.truncation_warning;
        let w_ref = self.linear_frequency(mode)?;
        let shares = sys.modal_shares(&coefficients);
        let (secondary_mode, secondary_harmonic, secondary_share) = shares.largest_other(mode);
        let point = BackbonePoint {
            mode,
            q: state.q,
            omega: state.omega,
            omega_ratio: state.omega / w_ref,
            frequency_hz: state.omega / (2.0 * std::f64::consts::PI),
            energy,
            mean_gap: contact.mean_gap,
            max_gap: contact.max_gap,
            mean_gap_overall: contact.mean_gap_overall,
            max_gap_overall: contact.max_gap_overall,
            max_penetration: contact.max_gap_overall.max(0.0),
            contact_fraction: contact.contact_fraction,
            powell_measure: report.measure,
            outer_iterations: report.accepted,
            inner_solves: report.solves,
            newton_iterations: report.newton_iterations,
            fold: false,
            jump: false,
            branch: 0,
            pre_fold: false,
            truncation: None,
            converged: None,
            stability: None,
            bifurcation: None,
            truncation_share,
            truncation_warning,
            primary_share: shares.share(mode, 1),
            secondary_mode,
            secondary_harmonic,
            secondary_share,
            coefficients,
            contact_force: contact.contact_force,
            multipliers,
        };
        if !(point.omega.is_finite() && point.q.is_finite() && point.energy.is_finite())
            || point.coefficients.iter().flatten().any(|v| !v.is_finite())
        {
            return Err(NnmError::NonFiniteResult {
                what: "the converged orbit",
            });
        }
        if report.stalled {
            tracing::debug!(
                q_over_g0 = point.q / self.system.gap_reference(),
                measure = report.measure,
                epsilon = self.params.epsilon,
                "Algorithm 1 stalled above epsilon: point accepted at its last accepted iterate"
            );
        }
        if truncation_warning {
            tracing::debug!(
                q_over_g0 = point.q / self.system.gap_reference(),
                share = truncation_share,
                limit = self.params.truncation_warning,
                "highest harmonic holds a large share of the contact motion: N = {} may be too small",
                self.settings.harmonics
            );
        }
        Ok(point)
    }

    /// Gaps and contact forces of the last evaluated state, per contact row and overall.
    fn contact_summary(&self) -> ContactSummary {
        let (m, c) = (self.settings.samples, self.system.n_contacts());
        let ev = &self.work.current;
        let mut mean_gap = Vec::with_capacity(c);
        let mut max_gap = Vec::with_capacity(c);
        let mut contact_fraction = Vec::with_capacity(c);
        let mut contact_force = Vec::with_capacity(c);
        for j in 0..c {
            let g = &ev.gaps[j * m..(j + 1) * m];
            let l = &ev.lambda[j * m..(j + 1) * m];
            mean_gap.push(g.iter().sum::<f64>() / m as f64);
            max_gap.push(g.iter().fold(f64::NEG_INFINITY, |a, &v| a.max(v)));
            contact_fraction.push(l.iter().filter(|&&v| v > 0.0).count() as f64 / m as f64);
            contact_force.push(l.to_vec());
        }
        let mean_gap_overall = if c > 0 {
            mean_gap.iter().sum::<f64>() / c as f64
        } else {
            0.0
        };
        let max_gap_overall = max_gap
            .iter()
            .fold(f64::NEG_INFINITY, |a: f64, &v| a.max(v));
        let max_gap_overall = if c > 0 { max_gap_overall } else { 0.0 };
        ContactSummary {
            mean_gap,
            max_gap,
            contact_fraction,
            contact_force,
            mean_gap_overall,
            max_gap_overall,
        }
    }

    /// Energy at the turning point t = 0: (1/2) u(0)^T K u(0), plus (1/2) kc (g_j(0))_+^2 per row
    /// with the plain penalty law (joules for SI input).
    fn turning_point_energy(&self, coefficients: &[Vec<f64>]) -> f64 {
        let sys = self.system;
        let (n, m, c) = (sys.n_dofs(), self.settings.samples, sys.n_contacts());
        let u0: Vec<f64> = (0..n)
            .map(|i| coefficients.iter().map(|u| u[i]).sum())
            .collect();
        let k = sys.stiffness();
        let mut energy = 0.0;
        for j in 0..n {
            let mut kj = 0.0;
            for i in 0..n {
                kj += k[(i, j)] * u0[i];
            }
            energy += 0.5 * kj * u0[j];
        }
        if let ContactMethod::Penalty { stiffness } = self.params.method {
            let gaps = &self.work.current.gaps;
            for j in 0..c {
                energy += 0.5 * stiffness * gaps[j * m].max(0.0).powi(2);
            }
        }
        energy
    }

    /// Truncation indicator: the top harmonic of the contact motion relative to its whole motion,
    /// max_j |A_j u_N| / max_j (sum_{n>=1} |A_j u_n|^2)^(1/2).
    fn truncation_share(&self) -> f64 {
        let layout = self.model.layout();
        let (nh, c) = (layout.count(), self.system.n_contacts());
        let ev = &self.work.current;
        let mut top = 0.0_f64;
        let mut total = 0.0_f64;
        for j in 0..c {
            let coef = layout.signals(c).series(&ev.coef, j);
            top = top.max(coef[nh - 1].abs());
            total = total.max(coef[1..].iter().map(|v| v * v).sum::<f64>().sqrt());
        }
        if total > 0.0 {
            top / total
        } else {
            0.0
        }
    }
}

/// Gaps (A u - g0, length unit of the system) and contact forces of an orbit's samples.
struct ContactSummary {
    mean_gap: Vec<f64>,
    max_gap: Vec<f64>,
    contact_fraction: Vec<f64>,
    contact_force: Vec<Vec<f64>>,
    mean_gap_overall: f64,
    max_gap_overall: f64,
}

/// One plain penalty solve (no multiplier update): Eq. (20) with lambda = kc (g)_+.
fn penalty_solve(
    inner: &mut InnerSolve<'_>,
    multipliers: &Multipliers,
    params: &AlgorithmParams,
) -> Result<OuterReport, NnmError> {
    let mut gaps = Vec::new();
    let iterations = inner.solve(multipliers, &mut gaps)?;
    Ok(OuterReport {
        measure: powell_measure(
            &gaps,
            &multipliers.theta,
            inner.g0,
            inner.samples,
            params.measure,
        ),
        accepted: 1,
        solves: 1,
        newton_iterations: iterations,
        stalled: false,
    })
}

/// Penalty factors tried, in order, as the soft start of a penalty homotopy when the first inner
/// solve of a point fails from its warm start.
const SOFT_START: [f64; 2] = [1e-2, 1e-4];

/// The inner solves of one point (Eq. 20 at the multipliers Algorithm 1 asks for) and the state
/// they share: the Newton state, the last converged (state, multipliers) of the point, and the
/// point's Newton budget. A solve that fails from its warm start is retried by a multiplier
/// homotopy from the last converged multipliers, or, for the point's first solve, by a penalty
/// homotopy from a softer contact (see docs/DESIGN.md §3.6).
struct InnerSolve<'a> {
    model: &'a mut dyn LinearModel,
    aft: &'a mut Aft,
    work: &'a mut NewtonWork,
    newton: &'a NewtonSettings,
    row: &'a ParameterRow,
    g0: &'a [f64],
    samples: usize,
    norm_scale: f64,
    arc_scale: f64,
    g_ref: f64,
    /// Newton iterations allowed for the point, and the work counter when it started.
    budget: usize,
    spent0: usize,
    state: NewtonState,
    last_good: Option<(NewtonState, Multipliers)>,
    /// The orbit of Algorithm 1's last accepted iterate and its evaluation.
    kept: Option<(NewtonState, Evaluation)>,
    /// Largest scaled (q, w) distance of an iterate from the row's predictor (`solve_with_row`).
    leash: Option<f64>,
}

impl InnerSolves for InnerSolve<'_> {
    /// Solves Eq. (20) at `mu` (with the fallbacks), writes the gap samples (c x m) and returns
    /// the Newton iterations spent.
    fn solve(&mut self, mu: &Multipliers, gaps: &mut Vec<f64>) -> Result<usize, NnmError> {
        let mut state = self.state.clone();
        let result = self.solve_from(mu, &mut state);
        self.state = state;
        let iterations = result?;
        self.check_leash()?;
        self.last_good = Some((self.state.clone(), mu.clone()));
        gaps.clear();
        gaps.extend_from_slice(&self.work.current.gaps);
        Ok(iterations)
    }

    fn keep(&mut self) {
        self.kept = Some((self.state.clone(), self.work.current.clone()));
    }

    fn restore(&mut self) {
        debug_assert!(self.kept.is_some(), "restore without an accepted iterate");
        if let Some((state, evaluation)) = &self.kept {
            self.state.clone_from(state);
            self.work.current.clone_from(evaluation);
        }
    }
}

impl InnerSolve<'_> {
    /// Fails when the current iterate is farther than the leash from the row's predictor.
    fn check_leash(&self) -> Result<(), NnmError> {
        let Some(radius) = self.leash else {
            return Ok(());
        };
        let row = self.row;
        let distance = ((self.state.q - row.q_p) / row.q_scale)
            .hypot((self.state.omega - row.w_p) / row.w_scale);
        if distance > radius {
            return Err(NnmError::LeftPredictor { distance, radius });
        }
        Ok(())
    }

    fn solve_from(&mut self, mu: &Multipliers, state: &mut NewtonState) -> Result<usize, NnmError> {
        let start = state.clone();
        let first = match self.attempt(mu, state, true) {
            Ok(rep) => return Ok(rep.iterations),
            Err(e) => e,
        };
        match self.last_good.clone() {
            Some((good_state, good_mu)) => {
                *state = good_state;
                self.homotopy(&good_mu, mu, state).map_err(|_| first)
            }
            None => self.soft_start(mu, &start, state).ok_or(first),
        }
    }

    /// First solve of a point that failed: solve with kappa softened by each factor of
    /// `SOFT_START`, then move to `mu` by the multiplier homotopy.
    fn soft_start(
        &mut self,
        mu: &Multipliers,
        start: &NewtonState,
        state: &mut NewtonState,
    ) -> Option<usize> {
        for softening in SOFT_START {
            *state = start.clone();
            let mut soft = mu.clone();
            soft.kappa.iter_mut().for_each(|k| *k *= softening);
            if let Ok(rep) = self.attempt(&soft, state, false) {
                if let Ok(it) = self.homotopy(&soft, mu, state) {
                    return Some(rep.iterations + it);
                }
            }
        }
        None
    }

    /// One inner Newton solve at `mu` from `state`; `fallback` allows the smoothing path of
    /// `solve_inner_robust`. Fails once the point's Newton budget is spent.
    fn attempt(
        &mut self,
        mu: &Multipliers,
        state: &mut NewtonState,
        fallback: bool,
    ) -> Result<NewtonReport, NnmError> {
        let spent = self.work.spent - self.spent0;
        if spent > self.budget {
            return Err(NnmError::NewtonFailed {
                iterations: spent,
                residual: f64::INFINITY,
                tolerance: self.newton.tolerance,
                reason: format!(
                    "Newton budget of {} iterations for the point exhausted",
                    self.budget
                ),
            });
        }
        let problem = InnerProblem {
            samples: self.samples,
            g0: self.g0,
            multipliers: mu,
            row: self.row,
            norm_scale: self.norm_scale,
            arc_scale: self.arc_scale,
            smoothing: 0.0,
        };
        solve_inner_robust(
            &mut *self.model,
            self.aft,
            &problem,
            self.g_ref,
            self.newton,
            state,
            self.work,
            fallback,
        )
    }

    /// Moves the multipliers from `from` to `to` in substeps (theta linearly, kappa
    /// geometrically), solving at each and halving a substep that fails (down to 1/16 of the
    /// path). The final substep uses `to` exactly. Returns the Newton iterations spent.
    fn homotopy(
        &mut self,
        from: &Multipliers,
        to: &Multipliers,
        state: &mut NewtonState,
    ) -> Result<usize, NnmError> {
        let (mut tau, mut dtau) = (0.0_f64, 0.25_f64);
        let mut iterations = 0;
        let mut mid = to.clone();
        while tau < 1.0 {
            let t1 = (tau + dtau).min(1.0);
            if t1 < 1.0 {
                for i in 0..mid.theta.len() {
                    mid.theta[i] = from.theta[i] + t1 * (to.theta[i] - from.theta[i]);
                    mid.kappa[i] = from.kappa[i] * (to.kappa[i] / from.kappa[i]).powf(t1);
                }
            }
            let target = if t1 >= 1.0 { to } else { &mid };
            let saved = state.clone();
            match self.attempt(target, state, false) {
                Ok(rep) => {
                    iterations += rep.iterations;
                    tau = t1;
                    dtau = (2.0 * dtau).min(0.5);
                }
                Err(e) => {
                    *state = saved;
                    dtau *= 0.5;
                    if dtau < 1.0 / 16.0 {
                        return Err(e);
                    }
                }
            }
        }
        Ok(iterations)
    }
}

/// Convenience: builds a [`Solver`] and solves one point.
pub fn solve_point(
    system: &System,
    settings: HarmonicSettings,
    params: impl Into<SolverSettings>,
    q: f64,
    start: Start<'_>,
) -> Result<BackbonePoint, NnmError> {
    Solver::new(system, settings, params)?.solve_point(q, start)
}

#[cfg(test)]
mod leash_tests {
    use super::*;
    use faer::Mat;

    /// x'' + x = 0 against a rigid stop at gap 1 (M = K = A = [1]), solved at master amplitude
    /// q = 2 (first harmonic) on the row q = 2 whose predictor is (q, w) = (2, w0): the orbit
    /// stiffens to w / w0 of about 1.68, that much minus 1 from the predictor in scaled units.
    fn one_dof_point(leash: Option<f64>) -> Result<BackbonePoint, NnmError> {
        let one = || Mat::from_fn(1, 1, |_, _| 1.0);
        let system = System::new(one(), one(), one(), vec![1.0], 0).expect("valid system");
        let settings = HarmonicSettings::new(20, 256).expect("valid settings");
        let mut solver = Solver::new(&system, settings, AlgorithmParams::default())?;
        let guess = solver.guess(Start::LinearMode(0), 2.0)?;
        let row = ParameterRow::fixed_amplitude(2.0, 1.0, 1.0);
        solver.solve_with_row(row, guess, leash)
    }

    #[test]
    fn a_corrector_past_its_leash_stops_and_one_within_converges_unchanged() {
        let free = one_dof_point(None).expect("converges without a leash");
        let away = free.omega_ratio - 1.0;
        assert!(away > 0.5, "w/w0 = {}", free.omega_ratio);
        // Algorithm 1 stops at its first iterate (0 accepted): from uniform multipliers it lies
        // at w / w0 = 2.3, 1.3 from the predictor, past the leash.
        match one_dof_point(Some(0.1)) {
            Err(NnmError::NotConverged {
                reason, accepted, ..
            }) => {
                assert!(reason.contains("left its predictor"), "{reason}");
                assert_eq!(accepted, 0);
            }
            other => panic!("expected the leash to stop the solve, got {other:?}"),
        }
        let within = one_dof_point(Some(2.0)).expect("converges within the leash");
        assert_eq!(within.omega.to_bits(), free.omega.to_bits());
        assert_eq!(within.newton_iterations, free.newton_iterations);
    }
}
