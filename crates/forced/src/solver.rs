//! One forced orbit: Algorithm 1 (augmented Lagrangian, exact contact) or the plain penalty law
//! around the condensed inner Newton solve (`newton`), on the full Fourier basis (DESIGN §10).

use faer::Mat;
use nlmodes_hb::augmented_lagrangian::{run_algorithm1, InnerSolves};
use nlmodes_hb::floquet::{switched_monodromy, ContactOrbit, SampledMonodromy};
use nlmodes_hb::{
    AlgorithmParams, ContactMethod, FullBasis, HarmonicSettings, HbError, Multipliers, System,
};

use crate::distortion::CasingDistortion;
use crate::dynamics::ModalDynamics;
use crate::error::ForcedError;
use crate::following::{Following, MovingStructure};
use crate::harmonic_check::HarmonicCheck;
use crate::load::Load;
use crate::newton::{
    contact_samples, ArcRow, ForceIntegration, InnerNewton, InnerTolerance, OrbitState,
};
use crate::period_check::PeriodCheck;
use nlmodes_hb::penalty_integral::ContactPhases;

/// Newton iterations one forced point may spend over all of Algorithm 1's inner solves. A
/// continuation step that needs more is cheaper retried shorter: on the blade a converged point
/// takes 3-50 iterations, a failing attempt used to burn the free-mode budget of 400 (30 s).
pub const FORCED_NEWTON_BUDGET: usize = 150;

/// Runs of `ForcedSolver::solve_following` before it gives up: each removes the previous
/// run's linearization error (two or three per point on the default blade's EO 3 sweep).
const FOLLOWING_RUNS: usize = 6;

/// What a forced solve is configured with.
#[derive(Clone, Debug)]
pub struct ForcedSettings {
    /// N and m (m >= 2N + 1).
    pub harmonics: HarmonicSettings,
    /// Algorithm 1's parameters and the contact method (augmented Lagrangian or penalty).
    pub algorithm: AlgorithmParams,
    /// Inner Newton tolerance on max |R| in units of the mean gap (default 1e-10).
    pub newton_tolerance: f64,
    /// Inner Newton iterations per solve (default 60).
    pub newton_iterations: usize,
    /// The casing's distortion (DESIGN §10.11): every row's gap g0_j - delta cos(h W t + phi);
    /// `None` (default): constant gaps.
    pub distortion: Option<CasingDistortion>,
}

impl ForcedSettings {
    /// Defaults for N harmonics: m = `HarmonicSettings::default_samples`, Algorithm 1 defaults
    /// with a Newton budget of [`FORCED_NEWTON_BUDGET`] per point, 30 inner iterations.
    pub fn new(harmonics: usize) -> Result<Self, ForcedError> {
        Ok(Self {
            harmonics: HarmonicSettings::with_default_samples(harmonics)?,
            algorithm: AlgorithmParams {
                newton_budget: FORCED_NEWTON_BUDGET,
                ..AlgorithmParams::default()
            },
            newton_tolerance: 1e-10,
            newton_iterations: 30,
            distortion: None,
        })
    }
}

/// A converged forced orbit.
#[derive(Clone, Debug)]
pub struct ForcedPoint {
    /// Excitation frequency W (rad/s).
    pub omega: f64,
    /// Load scale s: the load is s times the solver's (1 in a frequency sweep).
    pub level: f64,
    /// Physical coefficients, n x (2N + 1): column p is u_0, a_1, b_1, ... (see `FullBasis`).
    pub coefficients: Mat<f64>,
    /// Contact coordinates measured from the casing, y~ = A u + delta cos(h W t + phi)
    /// (signal-major c (2N + 1); A u itself without a distortion, DESIGN §10.11): the row
    /// touches where y~_j > g0_j.
    pub contact: Vec<f64>,
    /// Contact force samples (c x m, force units) of the converged law.
    pub contact_force: Vec<f64>,
    /// Gap samples g = A u - g(t) (c x m; g(t) = g0 without a distortion).
    pub gaps: Vec<f64>,
    /// The augmented-Lagrangian variables at convergence.
    pub multipliers: Multipliers,
    /// Powell's measure G (units of g0; 0 for the penalty law).
    pub powell_measure: f64,
    /// Inner solves and Newton iterations spent.
    pub inner_solves: usize,
    /// Newton iterations summed over the inner solves.
    pub newton_iterations: usize,
    /// N of the basis the point was solved on.
    pub harmonics: usize,
    /// Whether the orbit touches (a contact phase anywhere in the period, however short).
    pub touching: bool,
    /// What the check of N found (`ladder`; `Unchecked` from a plain solve).
    pub harmonic_check: HarmonicCheck,
}

impl ForcedPoint {
    /// Whether the orbit touches anywhere in the period.
    pub fn touches(&self) -> bool {
        self.touching
    }

    /// First-harmonic amplitude sqrt(a_1^2 + b_1^2) of physical coordinate `i` (length units).
    pub fn first_harmonic(&self, i: usize) -> f64 {
        self.coefficients[(i, 1)].hypot(self.coefficients[(i, 2)])
    }

    /// The largest contact force over the samples and rows (force units; 0 out of contact).
    pub fn largest_contact_force(&self) -> f64 {
        (self.contact_force.iter()).fold(0.0_f64, |m, f| m.max(f.abs()))
    }
}

/// What `ForcedSolver::solve_following` converged to.
#[derive(Clone, Debug)]
pub struct FollowingSolve {
    /// The orbit (on the row) and its multipliers.
    pub orbit: ForcedStart,
    /// Newton iterations over the runs.
    pub iterations: usize,
    /// Runs (Newton solves, each on the structure where it started).
    pub runs: usize,
    /// W_s (rad/s) of the last run's structure, within the band of the orbit's W.
    pub structure_omega: f64,
}

/// The forced problem for one system, damping and load.
pub struct ForcedSolver<'s> {
    system: &'s System,
    damping: Mat<f64>,
    load: Load,
    dynamics: ModalDynamics,
    basis: FullBasis,
    settings: ForcedSettings,
    kappa_initial: Vec<f64>,
    kappa_cap: Vec<f64>,
    integration: ForceIntegration,
    /// The casing's intrusion on every row, signal-major (empty without a distortion).
    casing: Vec<f64>,
}

/// The state Algorithm 1 drives: the orbit and the one it last accepted.
struct ForcedInner<'a, 'p> {
    newton: &'a mut InnerNewton<'p>,
    state: OrbitState,
    kept: OrbitState,
    arc: Option<&'a ArcRow>,
}

impl InnerSolves for ForcedInner<'_, '_> {
    fn solve(&mut self, mu: &Multipliers, gaps: &mut Vec<f64>) -> Result<usize, HbError> {
        let it = self
            .newton
            .run(&mut self.state, mu, self.arc)
            .map_err(|e| HbError::InnerSolve {
                detail: e.to_string(),
            })?;
        let cs = contact_samples(
            self.newton.basis,
            self.newton.g0,
            &self.state.y,
            mu,
            self.newton.integration,
        );
        *gaps = cs.gaps;
        Ok(it)
    }

    fn keep(&mut self) {
        self.kept.clone_from(&self.state);
    }

    fn restore(&mut self) {
        self.state.clone_from(&self.kept);
    }
}

/// Where a forced solve starts: an orbit and its multipliers (a previous point), or the linear
/// response at W with theta = 0 and kappa = kappa^(1).
#[derive(Clone, Debug)]
pub struct ForcedStart {
    /// The initial orbit.
    pub state: OrbitState,
    /// The initial multipliers.
    pub multipliers: Multipliers,
}

impl<'s> ForcedSolver<'s> {
    /// Validates the inputs and precomputes the modal data. `damping` is C (n x n).
    pub fn new(
        system: &'s System,
        damping: &Mat<f64>,
        load: &Load,
        settings: ForcedSettings,
    ) -> Result<Self, ForcedError> {
        settings.algorithm.validate()?;
        let positive = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ForcedError::Parameter {
                    name,
                    value: v,
                    expected: "a finite value > 0",
                })
            }
        };
        positive("newton_tolerance", settings.newton_tolerance)?;
        positive("newton_iterations", settings.newton_iterations as f64)?;
        let highest = settings.harmonics.harmonics;
        match settings.distortion {
            Some(d) => d.validate(highest)?,
            None => load.validate(system.n_dofs(), highest)?,
        }
        let dynamics = ModalDynamics::new(system, damping, load, highest)?;
        let basis = FullBasis::new(settings.harmonics)?;
        let casing = settings.distortion.map_or_else(Vec::new, |d| {
            d.offsets(system.contact_rows().nrows(), basis.terms())
        });
        let ks = system.contact_stiffness();
        let (kappa_initial, kappa_cap) = match settings.algorithm.method {
            ContactMethod::AugmentedLagrangian => (
                ks.iter()
                    .map(|k| k * settings.algorithm.initial_penalty)
                    .collect(),
                ks.iter()
                    .map(|k| k * settings.algorithm.max_penalty)
                    .collect(),
            ),
            ContactMethod::Penalty { stiffness } => {
                (vec![stiffness; ks.len()], vec![stiffness; ks.len()])
            }
        };
        let integration = match settings.algorithm.method {
            ContactMethod::Penalty { stiffness } => ForceIntegration::ExactPenalty {
                stiffness,
                phases: ContactPhases::new(basis.harmonics(), basis.samples()),
            },
            ContactMethod::AugmentedLagrangian => ForceIntegration::Sampled,
        };
        Ok(Self {
            system,
            damping: damping.clone(),
            load: load.clone(),
            dynamics,
            basis,
            settings,
            kappa_initial,
            kappa_cap,
            integration,
            casing,
        })
    }

    /// The same problem on N = `harmonics` (the time samples grown with N in proportion, at
    /// least `HarmonicSettings::default_samples`).
    pub fn with_harmonics(&self, harmonics: usize) -> Result<ForcedSolver<'s>, ForcedError> {
        let base = self.settings.harmonics;
        let samples = (base.samples * harmonics)
            .div_ceil(base.harmonics)
            .max(HarmonicSettings::default_samples(harmonics));
        let settings = ForcedSettings {
            harmonics: HarmonicSettings::new(harmonics, samples)?,
            ..self.settings.clone()
        };
        ForcedSolver::new(self.system, &self.damping, &self.load, settings)
    }

    /// The system.
    pub fn system(&self) -> &'s System {
        self.system
    }

    /// The modal data.
    pub fn dynamics(&self) -> &ModalDynamics {
        &self.dynamics
    }

    /// The basis.
    pub fn basis(&self) -> &FullBasis {
        &self.basis
    }

    /// C (n x n, N s/m).
    pub fn damping(&self) -> &Mat<f64> {
        &self.damping
    }

    /// The excitation.
    pub fn load(&self) -> &Load {
        &self.load
    }

    /// The settings.
    pub fn settings(&self) -> &ForcedSettings {
        &self.settings
    }

    /// The casing's intrusion on every contact row, signal-major as `ForcedPoint::contact`
    /// (empty without a distortion): the contact coordinates measured from the casing are
    /// A u plus these (DESIGN §10.11).
    pub fn casing(&self) -> &[f64] {
        &self.casing
    }

    /// Floquet multipliers of a converged point (`nlmodes_hb::floquet::switched_monodromy`: the
    /// exact monodromy of the variational equation along the orbit, contact switches located on
    /// the reconstructed gaps).
    pub fn monodromy(&self, point: &ForcedPoint) -> Result<SampledMonodromy, ForcedError> {
        let orbit = ContactOrbit {
            basis: &self.basis,
            contact: &point.contact,
            gaps: self.system.gaps(),
            multipliers: &point.multipliers,
        };
        let period = 2.0 * std::f64::consts::PI / point.omega;
        Ok(switched_monodromy(
            self.system.mass(),
            self.damping.as_ref(),
            self.system.stiffness(),
            self.system.contact_rows(),
            &orbit,
            period,
        )?)
    }

    /// What the massless contact boundary of this problem is built from, under `load`.
    fn boundary_inputs<'a>(
        &'a self,
        load: &'a Load,
        keep_all: bool,
    ) -> crate::boundary::BoundaryInputs<'a> {
        crate::boundary::BoundaryInputs {
            system: self.system,
            damping: self.damping.as_ref(),
            load,
            penalty: match self.settings.algorithm.method {
                ContactMethod::Penalty { stiffness } => Some(stiffness),
                ContactMethod::AugmentedLagrangian => None,
            },
            harmonics: self.basis.harmonics(),
            keep_all,
        }
    }

    /// The multipliers of the point on the massless contact boundary (`boundary`), `None` where
    /// that model does not apply or shooting does not converge. `keep_all`: a penalty model
    /// whose modes are all resolved is kept whole (the penalty equation, shot exactly). Under a
    /// casing distortion every row's gap moves with it (`boundary::moving_gap_monodromy`,
    /// docs/STABILITY.md Sec. 9.5; DESIGN §10.11).
    pub fn boundary_monodromy(
        &self,
        point: &ForcedPoint,
        keep_all: bool,
    ) -> Result<Option<crate::boundary::BoundaryMonodromy>, ForcedError> {
        let load = self.load.scaled(point.level);
        let inputs = self.boundary_inputs(&load, keep_all);
        let (c, w) = (&point.coefficients, point.omega);
        Ok(match &self.settings.distortion {
            Some(d) => crate::boundary::moving_gap_monodromy(&inputs, d, c, w)?,
            None => crate::boundary::boundary_monodromy(&inputs, c, w)?,
        })
    }

    /// The exact response curve of the massless boundary (`boundary_curve`) at the level of the
    /// harmonic-balance curve's `points`, from the first (the linear orbit at the start of the
    /// range) to W = `end` (rad/s), its modal coordinates scaled by the largest of those
    /// orbits'; `None` where that model does not apply (and under a casing distortion: the
    /// boundary's gaps are constant).
    pub fn boundary_curve(
        &self,
        points: &[ForcedPoint],
        end: f64,
        margin: f64,
    ) -> Result<Option<crate::BoundaryCurve>, ForcedError> {
        let Some(first) = points.first() else {
            return Ok(None);
        };
        if self.settings.distortion.is_some() {
            return Ok(None);
        }
        let load = self.load.scaled(first.level);
        let orbits: Vec<(&Mat<f64>, f64)> =
            points.iter().map(|p| (&p.coefficients, p.omega)).collect();
        Ok(crate::boundary::boundary_curve(
            &self.boundary_inputs(&load, true),
            &orbits,
            end,
            margin,
        )?)
    }

    /// Whether every linear mode lies below the boundary's cutoff (N + 1) W at W = `omega`
    /// (rad/s): the boundary then has no discarded mode (`boundary`).
    pub fn every_mode_resolved(&self, omega: f64) -> bool {
        let limit =
            crate::boundary::BOUNDARY_CUTOFF * (self.basis.harmonics() as f64 + 1.0) * omega;
        self.system.eigenvalues().iter().all(|l| l.sqrt() <= limit)
    }

    /// One period of time integration of the penalty equation from the point's start, its
    /// relative distance to the start (`period_check`); `None` for exact contact, and for an
    /// orbit whose gaps stay open (then the equation is linear and its harmonic balance exact:
    /// nothing for the check to find).
    pub fn period_residual(&self, point: &ForcedPoint) -> Option<f64> {
        let ContactMethod::Penalty { stiffness } = self.settings.algorithm.method else {
            return None;
        };
        if self.gaps_stay_open(point) {
            return None;
        }
        let load = self.load.scaled(point.level);
        let mut check = PeriodCheck::new(self.system, &self.damping, &load, stiffness, point.omega)
            .with_distortion(self.settings.distortion);
        Some(check.residual(&point.coefficients))
    }

    /// Whether every reconstructed contact coordinate stays below its gap by 1e-6 g0 at 8 m
    /// points of the period (m the samples): a contact-free, linear orbit.
    fn gaps_stay_open(&self, point: &ForcedPoint) -> bool {
        let t = self.basis.terms();
        let points = 8 * self.basis.samples();
        self.system.gaps().iter().enumerate().all(|(j, &g0)| {
            let series = &point.contact[j * t..(j + 1) * t];
            (0..points).all(|k| {
                let phase = 2.0 * std::f64::consts::PI * k as f64 / points as f64;
                FullBasis::value_at(series, phase) < g0 * (1.0 - 1e-6)
            })
        })
    }

    /// The linear response at W to `level` times the load (no contact force), theta = 0,
    /// kappa = kappa^(1); measured from the casing under a distortion.
    pub fn linear_start(&self, omega: f64, level: f64) -> Result<ForcedStart, ForcedError> {
        let mut y: Vec<f64> = self
            .dynamics
            .compliance(omega)?
            .y_load
            .into_iter()
            .map(|v| level * v)
            .collect();
        y.iter_mut().zip(&self.casing).for_each(|(v, c)| *v += c);
        let multipliers = Multipliers::uniform(&self.kappa_initial, self.basis.samples());
        Ok(ForcedStart {
            state: OrbitState { y, omega, level },
            multipliers,
        })
    }

    /// The start of a point from a converged one (its orbit and multipliers).
    pub fn start_from(point: &ForcedPoint) -> ForcedStart {
        ForcedStart {
            state: OrbitState {
                y: point.contact.clone(),
                omega: point.omega,
                level: point.level,
            },
            multipliers: point.multipliers.clone(),
        }
    }

    /// The inner Newton solve of this problem.
    fn inner_newton(&self) -> InnerNewton<'_> {
        InnerNewton {
            dynamics: &self.dynamics,
            basis: &self.basis,
            g0: self.system.gaps(),
            y_scale: self.system.gap_reference(),
            settings: InnerTolerance {
                tolerance: self.settings.newton_tolerance,
                max_iterations: self.settings.newton_iterations,
            },
            cache: None,
            blended: Default::default(),
            smoothing: 0.0,
            integration: self.integration,
            casing: &self.casing,
            following: None,
        }
    }

    /// The unit tangent of the curve at the converged `point` in the scaled space of `along`
    /// (see `InnerNewton::tangent`), oriented along `along`'s tangent.
    pub fn tangent(&self, point: &ForcedPoint, along: &ArcRow) -> Result<Vec<f64>, ForcedError> {
        let state = OrbitState {
            y: point.contact.clone(),
            omega: point.omega,
            level: point.level,
        };
        self.inner_newton()
            .tangent(&state, &point.multipliers, along)
    }

    /// Whether the contact law is integrated exactly (the penalty law): its curve has no corners.
    pub fn integrates_exactly(&self) -> bool {
        matches!(self.integration, ForceIntegration::ExactPenalty { .. })
    }

    /// Solves at the start's W (fixed) or on the arc row `arc` (W free).
    pub fn solve(
        &self,
        start: ForcedStart,
        arc: Option<&ArcRow>,
    ) -> Result<ForcedPoint, ForcedError> {
        let g0 = self.system.gaps();
        let mut newton = self.inner_newton();
        let ForcedStart {
            state,
            mut multipliers,
        } = start;
        let omega0 = state.omega;
        let mut inner = ForcedInner {
            newton: &mut newton,
            kept: state.clone(),
            state,
            arc,
        };
        let (measure, solves, iterations) = match self.settings.algorithm.method {
            ContactMethod::Penalty { .. } => {
                multipliers.theta.iter_mut().for_each(|t| *t = 0.0);
                let mut gaps = Vec::new();
                let it = inner.solve(&multipliers, &mut gaps).map_err(|e| {
                    ForcedError::NotConverged {
                        omega: omega0,
                        reason: e.to_string(),
                    }
                })?;
                (0.0, 1, it)
            }
            ContactMethod::AugmentedLagrangian => {
                let rep = run_algorithm1(
                    &self.settings.algorithm,
                    g0,
                    &self.kappa_cap,
                    &mut multipliers,
                    &mut inner,
                )
                .map_err(|f| ForcedError::NotConverged {
                    omega: inner_omega(arc, omega0),
                    reason: format!(
                        "Algorithm 1: {} (last G = {:.3e})",
                        f.reason, f.report.measure
                    ),
                })?;
                (rep.measure, rep.solves, rep.newton_iterations)
            }
        };
        let state = inner.state;
        self.point(state, multipliers, measure, solves, iterations)
    }

    /// The orbit on the arc row `arc` (W free) of a structure that moves with W (`structure`:
    /// a speed sweep's structure at W / e), under the penalty law, whose one inner solve is the
    /// whole solve (Algorithm 1's outer loop holds one structure's gaps: `None` under exact
    /// contact, for the caller's frozen-structure path). Each run linearizes the structure
    /// around the W it starts from (`following::Following`); while the converged W lies farther
    /// than `band` (rad/s) from that W, a run from the converged orbit on the structure there
    /// removes the linearization's error, starting from a residual of that error's size.
    pub fn solve_following(
        &self,
        start: ForcedStart,
        arc: &ArcRow,
        (structure, band): (&dyn MovingStructure, f64),
    ) -> Option<Result<FollowingSolve, ForcedError>> {
        if !self.integrates_exactly() {
            return None;
        }
        let ForcedStart {
            mut state,
            mut multipliers,
        } = start;
        multipliers.theta.iter_mut().for_each(|t| *t = 0.0);
        let mut iterations = 0;
        for runs in 1..=FOLLOWING_RUNS {
            let mut newton = self.inner_newton();
            newton.following = Some(Following::new(structure));
            match newton.run(&mut state, &multipliers, Some(arc)) {
                Ok(it) => iterations += it,
                Err(e) => {
                    return Some(Err(ForcedError::NotConverged {
                        omega: arc.predicted.omega,
                        reason: e.to_string(),
                    }))
                }
            }
            let on = (newton.following.as_ref())
                .and_then(Following::structure_omega)
                .unwrap_or(state.omega);
            if (state.omega - on).abs() <= band {
                return Some(Ok(FollowingSolve {
                    orbit: ForcedStart { state, multipliers },
                    iterations,
                    runs,
                    structure_omega: on,
                }));
            }
        }
        Some(Err(ForcedError::NotConverged {
            omega: state.omega,
            reason: format!(
                "the structure's W and the orbit's did not agree within {band:.3e} rad/s after \
                 {FOLLOWING_RUNS} runs"
            ),
        }))
    }

    fn point(
        &self,
        state: OrbitState,
        multipliers: Multipliers,
        measure: f64,
        solves: usize,
        iterations: usize,
    ) -> Result<ForcedPoint, ForcedError> {
        let cs = contact_samples(
            &self.basis,
            self.system.gaps(),
            &state.y,
            &multipliers,
            self.integration,
        );
        let z = self
            .dynamics
            .response(state.omega, state.level, &cs.coefficients)?;
        let coefficients = self.dynamics.physical(&z);
        if coefficients
            .col_iter()
            .any(|c| c.iter().any(|v| !v.is_finite()))
            || !state.omega.is_finite()
        {
            return Err(HbError::NonFiniteResult {
                what: "forced orbit coefficients",
            }
            .into());
        }
        Ok(ForcedPoint {
            omega: state.omega,
            level: state.level,
            coefficients,
            contact: state.y,
            touching: cs.touches(self.basis.samples()),
            contact_force: cs.force,
            gaps: cs.gaps,
            multipliers,
            powell_measure: measure,
            inner_solves: solves,
            newton_iterations: iterations,
            harmonics: self.basis.harmonics(),
            harmonic_check: HarmonicCheck::Unchecked,
        })
    }
}

/// The W to name in an error: the predicted one on an arc, else the fixed one.
fn inner_omega(arc: Option<&ArcRow>, omega: f64) -> f64 {
    arc.map_or(omega, |a| a.predicted.omega)
}
