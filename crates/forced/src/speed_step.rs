//! One point of a speed sweep (`speed_sweep`): the forced orbit of the structure at its own
//! speed Omega under the excitation at W = e Omega, at a fixed speed or on a pseudo-arc-length
//! row in (orbit, Omega). Under an n-lobed casing the orbit's fundamental is W = k Omega,
//! k = gcd(e, n), the load at its harmonic e / k and the gap at n / k (DESIGN §10.11); e
//! below stands for k.
//!
//! Under the penalty law a row is one Newton solve in (orbit, W), the structure following
//! W = e Omega (`ForcedSolver::solve_following`, `following::Following`): the structure
//! linearized in W around the speed where a run starts, the Newton matrix's column the total
//! dR/dW = dR/dW|_structure + (1/e) dR/dOmega|_W (K, C and the contact rows by the difference
//! of the structures at two speeds, the running gaps through the law's Jacobian), a second run
//! from the converged orbit on the structure at its speed removing the linearization's error,
//! until the structure's speed and W / e agree within `speed_tolerance` x Omega_ref; then onto
//! the speed line of that structure at fixed W, as below. The later runs start from a residual
//! of the linearization's size, where each frozen-speed correction starts from the jump of the
//! running gaps under the stiff penalty law (0.1 g0 on the default blade, 3-5 Newton
//! iterations per correction): the default blade's EO 3 sweep at N = 10 traces in half the
//! CPU time (docs/BENCHMARKS.md, session 20).
//!
//! Under exact contact (Algorithm 1, whose outer loop holds one structure's gaps), and on the
//! grazing passages' and the harmonic checks' rows, the structure is frozen at a speed Omega_f
//! and its harmonic balance solved with W free on the row (`ForcedSolver::solve`, the
//! frequency as the row's parameter, W / e playing Omega); then Omega_f is moved to W / e,
//! first by a Newton step with the slope of F found at the last point (by substitution before
//! any), then by the secant method on the mismatch F(Omega_f) = W(Omega_f) / e - Omega_f,
//! until |F| <= `speed_tolerance` x Omega_ref. F' = 0 only where the row meets the true curve
//! tangentially (the bordered system of the true curve is then singular too), so the secant
//! converges superlinearly wherever the continuation is regular; substitution alone would
//! diverge where the structure's frequency moves faster with the speed than e Omega does.

use faer::Mat;
use nlmodes_hb::{Multipliers, System};

use crate::curve::ExactForce;
use crate::dynamics::ModalDynamics;
use crate::error::ForcedError;
use crate::exact_force::exact_largest_force;
use crate::following::MovingStructure;
use crate::load::Load;
use crate::newton::{ArcRow, OrbitState, Parameter};
use crate::point_stability::{Assessment, PointStability};
use crate::settled_stability::assess_point_settled;
use crate::solver::{FollowingSolve, ForcedPoint, ForcedSettings, ForcedSolver, ForcedStart};
use crate::speed_curve::{SpeedPoint, SpeedSweepSettings};

/// Corrections of the frozen speed one point may take before its step is refused: the secant
/// settles in 3-6 on smooth curves.
const SPEED_CORRECTIONS: usize = 12;

/// The forced problem at one rotation speed: the structure there (K(Omega) with its stress
/// stiffening and spin softening, the contact rows and running gaps), its damping C (N s/m)
/// and the load (N, its harmonics of W).
#[derive(Clone)]
pub struct SpeedProblem {
    /// The structure at the speed.
    pub system: System,
    /// C at the speed (N s/m).
    pub damping: Mat<f64>,
    /// The excitation at the speed.
    pub load: Load,
}

impl SpeedProblem {
    /// The forced solver of this problem.
    pub fn solver(&self, settings: &ForcedSettings) -> Result<ForcedSolver<'_>, ForcedError> {
        ForcedSolver::new(&self.system, &self.damping, &self.load, settings.clone())
    }
}

/// A structure whose forced problem follows the rotation speed (a parametric reduced model).
pub trait SpeedFamily: Sync {
    /// The problem at `speed` (rad/s); [`ForcedError::Speed`] where it cannot be built.
    fn at(&self, speed: f64) -> Result<SpeedProblem, ForcedError>;
}

/// A step of the continuation: its prediction and row in the scaled space (`speed_sweep`).
pub(crate) struct SpeedArc {
    /// Unit direction, scaled: contact coordinates, then the speed.
    pub(crate) tangent: Vec<f64>,
    /// Predicted contact coordinates (m).
    pub(crate) y: Vec<f64>,
    /// Predicted speed (rad/s).
    pub(crate) speed: f64,
    /// The step h in the scaled space.
    pub(crate) step: f64,
    /// y_s (m) and Omega_ref (rad/s) of the scaled space.
    pub(crate) y_scale: f64,
    pub(crate) speed_scale: f64,
}

impl SpeedArc {
    /// The row with W = e Omega as its parameter: W / (e Omega_ref) = Omega / Omega_ref.
    pub(crate) fn row(&self, engine_order: f64) -> ArcRow {
        let l = self.y.len();
        ArcRow {
            parameter: Parameter::Frequency,
            tangent_y: self.tangent[..l].to_vec(),
            tangent_parameter: self.tangent[l],
            predicted: OrbitState {
                y: self.y.clone(),
                omega: engine_order * self.speed,
                level: 1.0,
            },
            y_scale: self.y_scale,
            parameter_scale: engine_order * self.speed_scale,
        }
    }
}

/// Solves the points of one sweep.
pub(crate) struct SpeedStepper<'a> {
    pub(crate) family: &'a dyn SpeedFamily,
    pub(crate) settings: &'a SpeedSweepSettings,
    /// dF / dOmega_f of the last point's secant (F the mismatch; smooth along the curve): the
    /// next point's first correction is a Newton step with it (substitution, slope -1,
    /// before any).
    pub(crate) slope: std::cell::Cell<Option<f64>>,
    /// The solver's settings on the orbit's fundamental
    /// ([`SpeedSweepSettings::solver_settings`]).
    pub(crate) solver: ForcedSettings,
}

/// The problem of `family` at `speed` with its load on the orbit's fundamental k Omega (the
/// family's load acts at harmonics of e Omega).
pub(crate) fn problem_at(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    speed: f64,
) -> Result<SpeedProblem, ForcedError> {
    let mut problem = family.at(speed)?;
    let k = settings.fundamental_order();
    if k != settings.engine_order {
        problem.load = problem.load.on_lower_fundamental(settings.engine_order / k);
    }
    Ok(problem)
}

impl SpeedStepper<'_> {
    /// The stepper of one sweep of `family`.
    pub(crate) fn new<'a>(
        family: &'a dyn SpeedFamily,
        settings: &'a SpeedSweepSettings,
    ) -> SpeedStepper<'a> {
        SpeedStepper {
            family,
            settings,
            slope: std::cell::Cell::new(None),
            solver: settings.solver_settings(),
        }
    }

    /// k of the orbit's fundamental W = k Omega.
    pub(crate) fn fundamental(&self) -> f64 {
        self.settings.fundamental_order() as f64
    }

    fn problem(&self, speed: f64) -> Result<SpeedProblem, ForcedError> {
        problem_at(self.family, self.settings, speed)
    }

    /// The orbit at the fixed `speed` (rad/s), from `from` carried to this speed's contact
    /// coordinates, or from the linear response.
    pub(crate) fn at_speed(
        &self,
        speed: f64,
        from: Option<&SpeedPoint>,
    ) -> Result<SpeedPoint, ForcedError> {
        let problem = self.problem(speed)?;
        let solver = problem.solver(&self.solver)?;
        let w = self.fundamental() * speed;
        let start = match from {
            Some(p) => carried(p, &solver, w),
            None => solver.linear_start(w, 1.0)?,
        };
        let point = solver.solve(start, None)?;
        Ok(self.finish(speed, point, &solver, 1))
    }

    /// The orbit on the row of `arc`, from `from` (module docs): under the penalty law one
    /// Newton solve in (orbit, W) with the structure following W = e Omega
    /// ([`Self::on_arc_following`]), under exact contact the frozen speed corrected
    /// ([`Self::on_row`]).
    pub(crate) fn on_arc(
        &self,
        from: &SpeedPoint,
        arc: &SpeedArc,
    ) -> Result<SpeedPoint, ForcedError> {
        let row = arc.row(self.fundamental());
        let start = ForcedStart {
            state: row.predicted.clone(),
            multipliers: from.point.multipliers.clone(),
        };
        // A point on the row lies within about the step of the prediction (the judge takes
        // one step): twice that bounds the speed's corrections.
        let reach = 2.0 * arc.step * arc.speed_scale;
        self.on_speed_row(start, &row, arc.speed, reach)
    }

    /// The orbit on `row` (its parameter W = k Omega) from `start` (an orbit near the speed
    /// `speed`): under the penalty law one Newton solve in (orbit, W) with the structure
    /// following W ([`Self::on_arc_following`]), under exact contact the frozen speed
    /// corrected ([`Self::on_row`], moving at most `reach` rad/s from `speed`). The trace's
    /// steps and the harmonic checks' solves at 2N (`speed_harmonics`) both go through here:
    /// a row that crosses the speed line's curve need not cross the response of the structure
    /// frozen at one speed nearby (the check's rows, normal to the sweep, at the blade's peak
    /// and folds did not: session 22, docs/ROTATION.md).
    pub(crate) fn on_speed_row(
        &self,
        start: ForcedStart,
        row: &ArcRow,
        speed: f64,
        reach: f64,
    ) -> Result<SpeedPoint, ForcedError> {
        let problem = self.problem(speed)?;
        let solver = problem.solver(&self.solver)?;
        let following = StructureAtSpeed::of(self);
        // The structure is built again where W moves by more than the speed tolerance.
        let band = self.fundamental() * self.settings.speed_tolerance * self.settings.speed_scale;
        if let Some(solved) = solver.solve_following(start.clone(), row, (&following, band)) {
            return self.on_arc_following(solved?);
        }
        self.on_row(start, speed, &|_, _| row.clone(), &|_, _| true, reach)
    }

    /// The point of an orbit converged with the structure following W (`solved`, its
    /// structure's W_s within the speed tolerance of its W): onto the speed line of that
    /// structure, W = W_s at the speed W_s / e, from it (as the frozen-speed path's last solve;
    /// at a fold of the speed that solve can fail: the row's point stays, on its structure).
    /// Its solves: the runs and that last one.
    fn on_arc_following(&self, solved: FollowingSolve) -> Result<SpeedPoint, ForcedError> {
        let on = solved.structure_omega;
        let (mut start, iterations) = (solved.orbit, solved.iterations);
        let speed = on / self.fundamental();
        let problem = self.problem(speed)?;
        let solver = problem.solver(&self.solver)?;
        let row = start.clone();
        start.state.omega = on;
        let mut point = match solver.solve(start, None) {
            Ok(p) => p,
            Err(_) => solver.solve(row, None)?,
        };
        point.newton_iterations += iterations;
        Ok(self.finish(speed, point, &solver, solved.runs + 1))
    }

    /// The orbit on the row `row(solver, start)` builds at each frozen speed (from the speed
    /// `speed` and the orbit `start` on), the frozen speed moved to W / e (module docs); a
    /// point within the speed tolerance is kept when `settled(solver, point)`, else solved
    /// again at the same speed from itself. The frozen speed moves at most `reach` (rad/s)
    /// from `speed`.
    pub(crate) fn on_row(
        &self,
        mut start: ForcedStart,
        mut speed: f64,
        row: &dyn Fn(&ForcedSolver<'_>, &OrbitState) -> ArcRow,
        settled: &dyn Fn(&ForcedSolver<'_>, &ForcedPoint) -> bool,
        reach: f64,
    ) -> Result<SpeedPoint, ForcedError> {
        let e = self.fundamental();
        let first = speed;
        let tolerance = self.settings.speed_tolerance * self.settings.speed_scale;
        let mut previous: Option<(f64, f64)> = None;
        for corrections in 1..=SPEED_CORRECTIONS {
            let problem = self.problem(speed)?;
            let solver = problem.solver(&self.solver)?;
            let arc = row(&solver, &start.state);
            let point = solver.solve(start, Some(&arc))?;
            let mismatch = point.omega / e - speed;
            tracing::debug!(
                "speed sweep: correction {corrections} at {speed:.9e} rad/s: W / e - speed = \
                 {mismatch:.3e} rad/s"
            );
            start = ForcedSolver::start_from(&point);
            if mismatch.abs() <= tolerance {
                if !settled(&solver, &point) {
                    continue;
                }
                // Onto the speed line itself: W = e Omega exactly, from the point next to it
                // (at a fold of the speed the fixed-W solve can fail: the row's point stays).
                // Polishing from farther (1 % of the step) was measured slower on the blade:
                // 100 s against 72 s for the EO 3 sweep.
                start.state.omega = e * speed;
                let point = solver.solve(start, None).unwrap_or(point);
                return Ok(self.finish(speed, point, &solver, corrections + 1));
            }
            let slope = match previous {
                Some((s0, m0)) if m0 != mismatch => {
                    let slope = (mismatch - m0) / (speed - s0);
                    self.slope.set(Some(slope).filter(|v| v.is_finite()));
                    slope
                }
                _ => self.slope.get().unwrap_or(-1.0),
            };
            // The frozen speed stays within `reach` of where it started: farther, the slope
            // of the last point no longer holds (a contact event between), and the secant
            // would walk to another intersection of the row with the curve.
            let next = (speed - mismatch / slope).clamp(first - reach, first + reach);
            previous = Some((speed, mismatch));
            speed = next;
        }
        Err(ForcedError::NotConverged {
            omega: e * speed,
            reason: format!(
                "the structure's speed and W / {e} did not agree within {tolerance:.3e} rad/s \
                 after {SPEED_CORRECTIONS} corrections"
            ),
        })
    }

    /// The sweep's point of a converged orbit at `speed` (its stability: `assess`).
    pub(crate) fn finish(
        &self,
        speed: f64,
        point: ForcedPoint,
        solver: &ForcedSolver<'_>,
        corrections: usize,
    ) -> SpeedPoint {
        let system = solver.system();
        SpeedPoint {
            speed,
            gap_reference: system.gap_reference(),
            running_gaps: system.gaps().to_vec(),
            mode_frequency: system.linear_frequencies()[self.settings.mode],
            point,
            stability: None,
            corrections,
        }
    }
}

/// The structure of a sweep at W: its problem at the speed W / k (k the orbit's fundamental
/// order), condensed on the sweep's basis (`newton::MovingStructure`).
struct StructureAtSpeed<'a> {
    family: &'a dyn SpeedFamily,
    settings: &'a SpeedSweepSettings,
    /// N of the sweep's solves.
    harmonics: usize,
}

impl<'a> StructureAtSpeed<'a> {
    /// The structure of `stepper`'s sweep (what it reads of the stepper: the family, the
    /// settings and N, all shared between threads).
    fn of(stepper: &'a SpeedStepper<'a>) -> Self {
        Self {
            family: stepper.family,
            settings: stepper.settings,
            harmonics: stepper.solver.harmonics.harmonics,
        }
    }
}

impl MovingStructure for StructureAtSpeed<'_> {
    fn at(&self, omega: f64) -> Result<(ModalDynamics, Vec<f64>), ForcedError> {
        let speed = omega / self.settings.fundamental_order() as f64;
        let problem = problem_at(self.family, self.settings, speed)?;
        let dynamics = ModalDynamics::new(
            &problem.system,
            &problem.damping,
            &problem.load,
            self.harmonics,
        )?;
        Ok((dynamics, problem.system.gaps().to_vec()))
    }
}

/// The Floquet stability of an accepted point of `family`'s sweep, on the problem at its
/// speed; a failed analysis is undetermined (with a warning).
pub(crate) fn assess(
    family: &dyn SpeedFamily,
    s: &SpeedSweepSettings,
    p: &SpeedPoint,
) -> PointStability {
    let analysis = problem_at(family, s, p.speed).and_then(|problem| {
        let solver = problem.solver(&s.solver_settings())?;
        let how = Assessment {
            margin: s.stability_margin,
            period_tolerance: s.period_tolerance,
            verify: false,
        };
        assess_point_settled(&solver, &p.point, &how)
    });
    analysis.unwrap_or_else(|e| {
        tracing::warn!("speed sweep: no stability at {:.6e} rad/s: {e}", p.speed);
        PointStability::unchecked()
    })
}

/// The largest contact force of an accepted point of `family`'s sweep on its exact orbit
/// (`exact_force`), on the problem at its speed.
pub(crate) fn exact_force_at(
    family: &dyn SpeedFamily,
    s: &SpeedSweepSettings,
    p: &SpeedPoint,
) -> Result<Option<ExactForce>, ForcedError> {
    let problem = problem_at(family, s, p.speed)?;
    let solver = problem.solver(&s.solver_settings())?;
    exact_largest_force(&solver, &p.point)
}

/// The start at W of a point of another speed: its physical orbit seen through this speed's
/// contact rows (the reduced coordinates mean the same at every speed; measured from the
/// casing under a distortion), its multipliers.
fn carried(p: &SpeedPoint, solver: &ForcedSolver<'_>, w: f64) -> ForcedStart {
    let mut y = contact_of(solver.system(), &p.point.coefficients);
    y.iter_mut().zip(solver.casing()).for_each(|(v, c)| *v += c);
    ForcedStart {
        state: OrbitState {
            y,
            omega: w,
            level: 1.0,
        },
        multipliers: Multipliers::clone(&p.point.multipliers),
    }
}

/// Contact coordinates y = A u of physical coefficients `u` (n x (2N + 1)), signal-major as
/// `ForcedPoint::contact`.
pub(crate) fn contact_of(system: &System, u: &Mat<f64>) -> Vec<f64> {
    let a = system.contact_rows();
    let terms = u.ncols();
    let mut y = vec![0.0; a.nrows() * terms];
    for j in 0..a.nrows() {
        for p in 0..terms {
            y[j * terms + p] = (0..a.ncols()).map(|i| a[(j, i)] * u[(i, p)]).sum();
        }
    }
    y
}
