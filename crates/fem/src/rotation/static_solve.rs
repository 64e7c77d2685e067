//! The static centrifugal equilibrium on the free DOFs (DESIGN §9: CalculiX's NLGEOM static
//! step with CENTRIF): f_int(u) = f_c(u, Omega).
//!
//! - Geometrically nonlinear ([`RotatingModel::solve_nonlinear`]): total Lagrangian, St
//!   Venant-Kirchhoff, the load following the deformed position; load steps in Omega^2
//!   (nominally uniform, Omega_k^2 = Omega^2 k / n), Newton in each step from the previous
//!   converged state with the consistent tangent K_T(u) - Omega^2 M_spin (the load's
//!   derivative included, so convergence is quadratic), with chord steps on the factor of an
//!   earlier tangent while they contract the residual fast ([`crate::rotation::newton`]). A failed step is retried with half the
//!   increment ([`NewtonOptions::max_cutbacks`]). Why this matters: the first iteration of the
//!   first step uses K_e - Omega_1^2 M_spin, without stress stiffening, which is indefinite as
//!   soon as Omega_1 exceeds the lowest in-plane frequency of the unstressed structure (a
//!   slender blade or bar at high speed; the radial-bar test hits it), while every later step
//!   starts from a prestressed tangent; the cutbacks bring the first step below that speed.
//! - Linearized ([`RotatingModel::solve_linearized`]): K_e u = f_c(X), optionally
//!   (K_e - Omega^2 M_spin) u = f_c(X) (the load following the small displacement).
//!
//! Convergence criterion: ||r||_2 <= tol ||f_c(u)||_2 on the free DOFs, r = f_int - f_c, with
//! tol = [`NewtonOptions::relative_tolerance`] (default 1e-10). The centrifugal load is the
//! only force on the structure, so the criterion reads "the unbalanced force is a fraction tol
//! of the applied force", independent of units, mesh size and speed. Its round-off floor is
//! eps times the ratio of the element internal forces meeting at a node to the net nodal load
//! (about L / h for a bar); measured on the radial-bar test: 1e-13 to 1e-12, reached from
//! 1e-7 in one quadratic step. 1e-10 thus sits two to three orders above the floor, costs at
//! most one extra iteration, and leaves a displacement error of about tol times the condition
//! of the problem restricted to the load's modes (below 1e-8 relative on the test cases, far
//! below every tolerance of the checks). At Omega = 0 the load and the residual at u = 0 are
//! both exactly zero and the
//! criterion holds at iteration 0.

use sprs::CsMat;

use crate::FemError;

use nlmodes_sparse::LinearSolver;

use crate::rotation::error::{NewtonIteration, RotationError, StopReason};
use crate::rotation::model::RotatingModel;
use crate::rotation::stress_stiffness::{linear_stress_at, stress_stiffness_with_rule};

/// Kinematics of a static solution (and of the stress and stiffness derived from it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kinematics {
    /// Small strain: the stress is D eps(u), the stiffness at speed K_e + K_sigma - Omega^2
    /// M_spin.
    Linear,
    /// Green-Lagrange strain, St Venant-Kirchhoff: the stress is S (Cauchy F S F^T / J for
    /// output), the stiffness at speed K_T(u) - Omega^2 M_spin.
    GreenLagrange,
}

/// Options of the nonlinear static solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonOptions {
    /// Number of load steps, uniform in Omega^2 (>= 1), when no step needs a cutback.
    /// Default 4.
    pub load_steps: usize,
    /// Cutbacks allowed per step: a step that fails (Newton diverges, reaches the iteration
    /// limit or meets a singular or indefinite tangent) is retried from the last converged
    /// state with half the Omega^2 increment, up to this many times; after a converged step
    /// the increment doubles again, up to the nominal Omega^2 / load_steps. The increment never
    /// falls below the nominal one / 2^max_cutbacks either (a limit point approached by steps
    /// that alternately fail and pass ends there). Default 10.
    pub max_cutbacks: usize,
    /// Newton iterations allowed per step (>= 1), chord steps not counted
    /// ([`crate::rotation::newton`]). Default 25.
    pub max_iterations: usize,
    /// Convergence when ||r|| <= relative_tolerance ||f_c|| (module docs). Default 1e-10.
    pub relative_tolerance: f64,
    /// Divergence when ||r|| > divergence_factor x the residual at the start of the step.
    /// Default 1e4 (a Newton iterate can overshoot once; four orders is a lost iteration).
    pub divergence_factor: f64,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            load_steps: 4,
            max_cutbacks: 10,
            max_iterations: 25,
            relative_tolerance: 1e-10,
            divergence_factor: 1e4,
        }
    }
}

impl NewtonOptions {
    fn validate(&self) -> Result<(), RotationError> {
        let bad = |name, value: f64, expected| RotationError::InvalidOption {
            name,
            value,
            expected,
        };
        if self.load_steps == 0 {
            return Err(bad("load_steps", 0.0, ">= 1"));
        }
        if self.max_iterations == 0 {
            return Err(bad("max_iterations", 0.0, ">= 1"));
        }
        if !(self.relative_tolerance > 0.0 && self.relative_tolerance < 1.0) {
            return Err(bad(
                "relative_tolerance",
                self.relative_tolerance,
                "in (0, 1)",
            ));
        }
        if self.divergence_factor.is_nan() || self.divergence_factor <= 1.0 {
            return Err(bad("divergence_factor", self.divergence_factor, "> 1"));
        }
        Ok(())
    }
}

/// The Newton history of one load step.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadStep {
    /// 1-based step number.
    pub step: usize,
    /// Speed of the step (rad/s, >= 0: the static problem depends on Omega^2 only).
    pub omega: f64,
    /// Failed attempts (with half the increment each time) before this step converged.
    pub cutbacks: usize,
    /// Iterations, starting with iteration 0 (the state the step starts from).
    pub iterations: Vec<NewtonIteration>,
}

/// A converged static centrifugal state.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticSolution {
    /// Speed (rad/s).
    pub omega: f64,
    /// Kinematics of the solve.
    pub kinematics: Kinematics,
    /// Whether -Omega^2 M_spin was in the static operator (always for the nonlinear solve,
    /// where the load follows the deformation).
    pub spin_softening_in_operator: bool,
    /// Displacement on the free DOFs (m).
    pub displacement_free: Vec<f64>,
    /// Displacement on all 3n DOFs (m), zero on the fixed ones.
    pub displacement: Vec<f64>,
    /// Per load step Newton history (one step with two entries for a linearized solve).
    pub steps: Vec<LoadStep>,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl RotatingModel<'_> {
    /// Geometrically nonlinear static equilibrium at speed `omega` (rad/s) (module docs), the
    /// linear systems solved by `solver`. Errors name the load step, its speed and the reason
    /// (diverged, iteration limit, singular tangent, non-finite residual) once the cutbacks
    /// are exhausted.
    pub fn solve_nonlinear(
        &self,
        omega: f64,
        options: &NewtonOptions,
        solver: &mut dyn LinearSolver,
    ) -> Result<StaticSolution, RotationError> {
        self.solve_nonlinear_from(None, omega, options, solver)
    }

    /// [`RotatingModel::solve_nonlinear`] continued from a converged state `start` at a lower
    /// speed (`None`: from rest): the load steps run from start.omega^2 to omega^2, the first
    /// Newton iterate is the start's displacement. Used to march over the speeds of a Campbell
    /// diagram, where a step of a few hundred rpm converges in 2-3 iterations.
    pub fn solve_nonlinear_from(
        &self,
        start: Option<&StaticSolution>,
        omega: f64,
        options: &NewtonOptions,
        solver: &mut dyn LinearSolver,
    ) -> Result<StaticSolution, RotationError> {
        self.solve_nonlinear_with_stiffness(start, omega, options, solver)
            .map(|(solution, _)| solution)
    }

    /// [`RotatingModel::solve_nonlinear_from`], and the stiffness at speed of the solution
    /// (N/m, free DOFs): the tangent of the last Newton iteration, evaluated at the converged
    /// state, so bit for bit what [`RotatingModel::stiffness_at_speed`] assembles again.
    pub fn solve_nonlinear_with_stiffness(
        &self,
        start: Option<&StaticSolution>,
        omega: f64,
        options: &NewtonOptions,
        solver: &mut dyn LinearSolver,
    ) -> Result<(StaticSolution, CsMat<f64>), RotationError> {
        options.validate()?;
        check_speed(omega)?;
        let target = omega * omega;
        let (level0, mut u) = match start {
            Some(s)
                if s.kinematics == Kinematics::GreenLagrange && s.omega.abs() <= omega.abs() =>
            {
                if s.displacement_free.len() != self.dofs().n_free() {
                    return Err(FemError::DimensionMismatch {
                        what: "start displacement (free DOFs)",
                        found: s.displacement_free.len(),
                        expected: self.dofs().n_free(),
                    }
                    .into());
                }
                (s.omega * s.omega, s.displacement_free.clone())
            }
            Some(_) => {
                return Err(RotationError::InvalidOption {
                    name: "start (a nonlinear state at a lower speed)",
                    value: start.map_or(f64::NAN, |s| s.omega),
                    expected: "a total-Lagrangian state at a speed <= the target",
                })
            }
            None => (0.0, vec![0.0; self.dofs().n_free()]),
        };
        let nominal = (target - level0) / options.load_steps as f64;
        // Cutbacks count per step and a success doubles the increment again, so near a limit
        // point (the tangent about to turn indefinite) the level could creep towards it with
        // steps that alternately fail and pass, forever (a soft blade did: 10 minutes of load
        // steps). The increment may not fall below nominal / 2^max_cutbacks, whatever the step.
        let smallest = nominal * 0.5_f64.powi(options.max_cutbacks as i32);
        let (mut level, mut increment, mut cutbacks) = (level0, nominal, 0);
        let mut steps = Vec::with_capacity(options.load_steps);
        let mut stiffness = None;
        while steps.is_empty() || level < target {
            // The last step lands exactly on the target (no sliver step from round-off).
            let next = if level + increment >= target * (1.0 - 1e-12) {
                target
            } else {
                level + increment
            };
            let omega_k = next.sqrt();
            let mut trial = u.clone();
            match self.newton_step(omega_k, &mut trial, options, solver) {
                Ok((iterations, tangent)) => {
                    steps.push(LoadStep {
                        step: steps.len() + 1,
                        omega: omega_k,
                        cutbacks,
                        iterations,
                    });
                    stiffness = Some(tangent);
                    (u, level, cutbacks) = (trial, next, 0);
                    increment = (2.0 * increment).min(nominal);
                }
                Err((reason, history))
                    if cutbacks >= options.max_cutbacks || 0.5 * increment < smallest =>
                {
                    return Err(RotationError::StaticSolve {
                        step: steps.len() + 1,
                        omega: omega_k,
                        target_omega: omega,
                        cutbacks,
                        reason,
                        history,
                    });
                }
                Err(_) => {
                    increment *= 0.5;
                    cutbacks += 1;
                }
            }
        }
        let solution = StaticSolution {
            omega,
            kinematics: Kinematics::GreenLagrange,
            spin_softening_in_operator: true,
            displacement: self.dofs().try_expand(&u)?,
            displacement_free: u,
            steps,
        };
        let stiffness = stiffness.expect("the loop ends after a converged step");
        Ok((solution, stiffness))
    }

    /// Linearized static solution at speed `omega` (rad/s): K_e u = f_c(X), or
    /// (K_e - Omega^2 M_spin) u = f_c(X) when `spin_softening` (module docs). One load step,
    /// history: iteration 0 (u = 0, residual ||f_c(X)||) and 1 (the solve's residual).
    pub fn solve_linearized(
        &self,
        omega: f64,
        spin_softening: bool,
        solver: &mut dyn LinearSolver,
    ) -> Result<StaticSolution, RotationError> {
        check_speed(omega)?;
        let operator = self.linear_operator(if spin_softening { omega } else { 0.0 })?;
        let zero = vec![0.0; self.dofs().n_global()];
        let load = self
            .dofs()
            .try_restrict_vector(&self.centrifugal_load(omega, &zero)?)?;
        let stop = |reason, history| RotationError::StaticSolve {
            step: 1,
            omega,
            target_omega: omega,
            cutbacks: 0,
            reason,
            history,
        };
        let load_norm = norm(&load);
        let mut history = vec![NewtonIteration {
            iteration: 0,
            residual_norm: load_norm,
            load_norm,
            correction_norm: None,
            chord: false,
        }];
        let u = solver
            .solve(&operator, &load)
            .map_err(|e| stop(StopReason::SingularTangent(e.0), history.clone()))?;
        let mut r = load.clone();
        for (&v, (row, col)) in operator.iter() {
            r[row] -= v * u[col];
        }
        history.push(NewtonIteration {
            iteration: 1,
            residual_norm: norm(&r),
            load_norm,
            correction_norm: Some(norm(&u)),
            chord: false,
        });
        Ok(StaticSolution {
            omega,
            kinematics: Kinematics::Linear,
            spin_softening_in_operator: spin_softening,
            displacement: self.dofs().try_expand(&u)?,
            displacement_free: u,
            steps: vec![LoadStep {
                step: 1,
                omega,
                cutbacks: 0,
                iterations: history,
            }],
        })
    }

    /// K_e - omega_spin^2 M_spin on the free DOFs (N/m).
    pub fn linear_operator(&self, omega_spin: f64) -> Result<CsMat<f64>, RotationError> {
        let k = self.dofs().try_restrict(&self.linear_stiffness()?)?;
        if omega_spin == 0.0 {
            return Ok(k);
        }
        let s = self.dofs().try_restrict(&self.spin_softening_matrix()?)?;
        Ok(&k - &s.map(|v| omega_spin * omega_spin * v))
    }

    /// The stiffness at speed of a converged static state, on the free DOFs (N/m), exactly
    /// symmetric (DESIGN §9, CalculiX's PERTURBATION step after NLGEOM):
    /// - [`Kinematics::GreenLagrange`]: K_T(u0) - Omega^2 M_spin, K_T the total-Lagrangian
    ///   tangent (material part with the initial-displacement terms + stress stiffness of the
    ///   converged S), i.e. the Newton tangent at the solution;
    /// - [`Kinematics::Linear`]: K_e + K_sigma(D eps(u0)) - Omega^2 M_spin.
    ///
    /// At Omega = 0 and u0 = 0 both are K_e, the stiffness of [`crate::assemble`], to round-off.
    pub fn stiffness_at_speed(
        &self,
        solution: &StaticSolution,
    ) -> Result<CsMat<f64>, RotationError> {
        let omega = solution.omega;
        match solution.kinematics {
            Kinematics::GreenLagrange => {
                let (_, k) = self.internal_force_and_tangent(omega, &solution.displacement)?;
                Ok(self.dofs().try_restrict(&k)?)
            }
            Kinematics::Linear => {
                let (mesh, lame, u) = (self.mesh(), self.material().lame(), &solution.displacement);
                let k_sigma = self.matrix(&|e, el, _, k| {
                    let mut u_e = [0.0; 30];
                    crate::rotation::global::gather(mesh, e, u, &mut u_e[..el.ndof()]);
                    let stress = |pt: &_| linear_stress_at(pt, el.npe(), &u_e, lame);
                    stress_stiffness_with_rule(el, self.nonlinear_rule_of(e), stress, k)
                })?;
                let k_sigma = self.dofs().try_restrict(&k_sigma)?;
                Ok(&self.linear_operator(omega)? + &k_sigma)
            }
        }
    }
}

fn check_speed(omega: f64) -> Result<(), RotationError> {
    if omega.is_finite() {
        Ok(())
    } else {
        Err(RotationError::InvalidOption {
            name: "omega (rad/s)",
            value: omega,
            expected: "a finite speed",
        })
    }
}
