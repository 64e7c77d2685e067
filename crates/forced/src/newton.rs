//! The inner solve of the forced harmonic balance at fixed augmented-Lagrangian multipliers
//! (Eq. 14 on the full basis; DESIGN §10.4): a semi-smooth Newton method on the contact
//! coordinates y alone, the structure being condensed exactly (`dynamics`):
//!
//!   R(y, W, s) = y - c - s y_F(W) + G(W) Lambda(y) = 0,   Lambda = P kappa (E y - g0 + theta)_+,
//!
//! (c the casing's intrusion under a distortion, y then measured from the casing; c = 0
//! otherwise: DESIGN §10.11)
//! with Jacobian I + G J_Lambda, J_Lambda block-diagonal over the contact rows (one (2N+1)^2
//! block P diag(slope) E per row, `FullBasis::project_slopes`). Rows with no active sample have a
//! zero block, so the system is solved on the active rows and the others follow. For a
//! continuation one parameter p (W, or the load scale s at fixed W) is an unknown too, bordered
//! by the pseudo-arc-length row t_y . (y - y_p) / y_s + t_p (p - p_p) / p_s = 0 (the bordered
//! matrix stays regular at folds); its column is dR/dW = -dy_lin/dW or dR/ds = -y_F.
//!
//! On a speed sweep's row the structure moves with W (`following::Following`: the structure
//! at the speed Omega = W / e, DESIGN §10.10), linearized in W around the structure where the
//! solve starts, and the column is the total dR/dW = dR/dW|_structure + (1/e) dR/dOmega|_W
//! (`InnerNewton::structure_rate`).

use faer::Mat;
use nlmodes_dense::DenseLu;
use nlmodes_hb::contact::{apply_contact_law, Multipliers};
use nlmodes_hb::penalty_integral::{penalty_force, ContactPhases};
use nlmodes_hb::FullBasis;

use crate::active_jacobian::ActiveJacobian;
use crate::compliance::{Blended, ContactCompliance};
use crate::dynamics::ModalDynamics;
use crate::error::ForcedError;
use crate::following::{Following, StructurePair, STRUCTURE_STEP};

/// An orbit as the Newton solve sees it: contact coordinates y (signal-major, length unit), W
/// and the load scale s.
#[derive(Clone, Debug, PartialEq)]
pub struct OrbitState {
    /// y[j (2N + 1) + p].
    pub y: Vec<f64>,
    /// Excitation frequency W (rad/s).
    pub omega: f64,
    /// Load scale s: the load is s times the solver's (1 in a frequency sweep).
    pub level: f64,
}

/// The parameter an arc-length row sets free; the other stays at the state's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parameter {
    /// W (rad/s): the frequency response at a fixed load.
    Frequency,
    /// s (the load scale): the response to a growing load at a fixed W.
    Level,
}

impl OrbitState {
    /// The value of `parameter`.
    pub fn parameter(&self, parameter: Parameter) -> f64 {
        match parameter {
            Parameter::Frequency => self.omega,
            Parameter::Level => self.level,
        }
    }

    /// Sets `parameter` to `value`.
    pub fn set_parameter(&mut self, parameter: Parameter, value: f64) {
        match parameter {
            Parameter::Frequency => self.omega = value,
            Parameter::Level => self.level = value,
        }
    }
}

/// The pseudo-arc-length row (see module docs); tangent in the scaled space.
#[derive(Clone, Debug)]
pub struct ArcRow {
    /// The free parameter (W or s).
    pub parameter: Parameter,
    /// t_y.
    pub tangent_y: Vec<f64>,
    /// t_p, the parameter's component.
    pub tangent_parameter: f64,
    /// Predicted point.
    pub predicted: OrbitState,
    /// y_s (length).
    pub y_scale: f64,
    /// p_s (rad/s for W, 1 for s).
    pub parameter_scale: f64,
}

impl ArcRow {
    fn residual(&self, s: &OrbitState) -> f64 {
        let dy: f64 = self
            .tangent_y
            .iter()
            .zip(s.y.iter().zip(&self.predicted.y))
            .map(|(t, (a, b))| t * (a - b))
            .sum();
        let dp = s.parameter(self.parameter) - self.predicted.parameter(self.parameter);
        dy / self.y_scale + self.tangent_parameter * dp / self.parameter_scale
    }
}

/// How the force coefficients Lambda of the contact law and their Jacobian are computed.
#[derive(Clone, Copy, Debug)]
pub enum ForceIntegration {
    /// Sampled on the time grid and projected (the AFT of Eqs. 18-19): the augmented-Lagrangian
    /// law of Algorithm 1, whose multipliers live on the samples.
    Sampled,
    /// The plain penalty law lambda = k (g)_+ integrated exactly between its switch instants
    /// (`nlmodes_hb::penalty_integral`, DESIGN §10.9): no corners where a sample enters contact.
    ExactPenalty {
        /// k (force per length), the same on every row.
        stiffness: f64,
        /// The switch search.
        phases: ContactPhases,
    },
}

/// The contact law evaluated on an orbit: gaps, forces and slopes at the samples (c x m), and the
/// force coefficients Lambda (c x (2N + 1)) with, for the exact penalty law, each row's Jacobian.
pub struct ContactSamples {
    /// g = A u - g0 at the samples.
    pub gaps: Vec<f64>,
    /// lambda at the samples.
    pub force: Vec<f64>,
    /// d lambda / d g at the samples.
    pub slope: Vec<f64>,
    /// Lambda, signal-major.
    pub coefficients: Vec<f64>,
    /// d Lambda_j / d y_j per row ((2N + 1)^2), `None` for a row out of contact; empty for the
    /// sampled law (its Jacobian is projected from `slope`).
    pub blocks: Vec<Option<Mat<f64>>>,
}

impl ContactSamples {
    /// Whether any row touches anywhere in the period.
    pub fn touches(&self, samples: usize) -> bool {
        (0..self.gaps.len() / samples.max(1)).any(|j| self.row_active(j, samples))
    }

    /// The contact rows with a nonzero force coefficient (`terms` = 2N + 1 per row).
    pub fn loaded_rows(&self, terms: usize) -> Vec<usize> {
        (self.coefficients.chunks_exact(terms.max(1)).enumerate())
            .filter(|(_, row)| row.iter().any(|&v| v != 0.0))
            .map(|(j, _)| j)
            .collect()
    }

    /// Whether contact row `j` touches anywhere in the period.
    pub fn row_active(&self, j: usize, samples: usize) -> bool {
        match self.blocks.get(j) {
            Some(block) => block.is_some(),
            None => self.slope[j * samples..(j + 1) * samples]
                .iter()
                .any(|&v| v != 0.0),
        }
    }
}

/// Evaluates the sampled contact law of `multipliers` on the contact coordinates `y` (the exact
/// law; [`contact_samples_smoothed`] for the smoothing path).
pub fn contact_samples(
    basis: &FullBasis,
    g0: &[f64],
    y: &[f64],
    mu: &Multipliers,
    integration: ForceIntegration,
) -> ContactSamples {
    contact_samples_smoothed(basis, g0, y, mu, 0.0, integration)
}

/// [`contact_samples`] with the positive part smoothed by `smoothing` (length units; 0: exact;
/// the sampled law only), see `nlmodes_hb::contact::apply_contact_law`.
pub fn contact_samples_smoothed(
    basis: &FullBasis,
    g0: &[f64],
    y: &[f64],
    mu: &Multipliers,
    smoothing: f64,
    integration: ForceIntegration,
) -> ContactSamples {
    let (c, m, t) = (g0.len(), basis.samples(), basis.terms());
    let mut gaps = vec![0.0; c * m];
    let mut rates = vec![0.0; c * m];
    basis.synthesize_signals(&y[..c * t], &mut gaps, Some(&mut rates));
    // The phase derivatives d g / d(W t) at the samples bracket short contact phases of the
    // exact law's switch search.
    let sampled_rates = std::mem::take(&mut rates);
    let raw_gaps = gaps.clone();
    for j in 0..c {
        gaps[j * m..(j + 1) * m]
            .iter_mut()
            .for_each(|g| *g -= g0[j]);
    }
    let mut force = vec![0.0; c * m];
    let mut slope = vec![0.0; c * m];
    apply_contact_law(&gaps, mu, smoothing, &mut force, &mut slope);
    let mut coefficients = vec![0.0; c * t];
    let mut blocks = Vec::new();
    match integration {
        ForceIntegration::Sampled => {
            for j in 0..c {
                basis.analyze(
                    &force[j * m..(j + 1) * m],
                    &mut coefficients[j * t..(j + 1) * t],
                );
            }
        }
        ForceIntegration::ExactPenalty { stiffness, phases } => {
            // Each row's law is integrated on its own series (the rows are independent), so
            // the rows run in parallel and the result is the same in any order.
            use rayon::prelude::*;
            let rows: Vec<(Vec<f64>, Option<Mat<f64>>)> = (g0.par_iter().enumerate())
                .map(|(j, &gap)| {
                    let (rows, samples) = (j * t..(j + 1) * t, j * m..(j + 1) * m);
                    let series = &y[rows];
                    let contact = if m >= phases.grid() {
                        phases.above_sampled(
                            series,
                            &raw_gaps[samples.clone()],
                            &sampled_rates[samples],
                            gap,
                        )
                    } else {
                        phases.above(series, gap)
                    };
                    let mut block = (!contact.is_empty()).then(|| Mat::zeros(t, t));
                    let lambda = penalty_force(
                        &contact,
                        series,
                        gap,
                        stiffness,
                        block.as_mut().map(|b| b.as_mut()),
                    );
                    (lambda, block)
                })
                .collect();
            for (j, (lambda, block)) in rows.into_iter().enumerate() {
                coefficients[j * t..(j + 1) * t].copy_from_slice(&lambda);
                blocks.push(block);
            }
        }
    }
    ContactSamples {
        gaps,
        force,
        slope,
        coefficients,
        blocks,
    }
}

/// The first stiffness of the exactly integrated penalty law's rescue path, as a fraction of
/// the law's (`InnerNewton::penalty_homotopy`).
const PENALTY_START: f64 = 1e-3;
/// The smallest ratio between two stiffnesses of that path before it gives up.
const PENALTY_RATIO_MIN: f64 = 1.02;
/// Newton iterations the path may spend.
const PENALTY_BUDGET: usize = 400;

/// The shortest fraction of a Newton step tried on the exactly integrated law.
const SHORTEST_STEP: f64 = 1e-6;

/// Newton settings of the inner solve.
#[derive(Clone, Copy, Debug)]
pub struct InnerTolerance {
    /// Converged when max |R| <= tolerance x y_scale and |R_arc| <= tolerance.
    pub tolerance: f64,
    /// Iterations allowed per inner solve.
    pub max_iterations: usize,
}

/// One inner solve: the problem's data and the multipliers it runs at.
pub struct InnerNewton<'p> {
    /// The condensed structure.
    pub dynamics: &'p ModalDynamics,
    /// The basis and its samples.
    pub basis: &'p FullBasis,
    /// Initial gaps g0 (c).
    pub g0: &'p [f64],
    /// Scale of y (the mean gap).
    pub y_scale: f64,
    /// Tolerances.
    pub settings: InnerTolerance,
    /// The compliance at the last W used (recomputed when W changes).
    pub cache: Option<ContactCompliance>,
    /// A following structure's second and blended compliances at the last W off W_s
    /// (`jacobian_compliance`).
    pub blended: Blended,
    /// Smoothing of the law in the current solve (length units; 0 = exact).
    pub smoothing: f64,
    /// How the law's coefficients are computed.
    pub integration: ForceIntegration,
    /// The casing's intrusion c on every row (signal-major; empty without a distortion): y is
    /// measured from the casing and R = y - c - s y_F + G Lambda (DESIGN §10.11).
    pub casing: &'p [f64],
    /// The structure following W on a speed sweep's row (`dynamics` and `g0` are then only the
    /// structure's until the first evaluation); `None`: the structure is fixed.
    pub following: Option<Following<'p>>,
}

impl InnerNewton<'_> {
    /// The condensed structure: the following structure's S_s once built, else the fixed one.
    fn structure(&self) -> &ModalDynamics {
        match self.following.as_ref().and_then(|f| f.built.as_ref()) {
            Some(b) => &b.a.0,
            None => self.dynamics,
        }
    }

    /// Builds a following structure at W when it has none yet (nothing for a fixed one).
    fn move_to(&mut self, omega: f64) -> Result<(), ForcedError> {
        let Some(f) = &mut self.following else {
            return Ok(());
        };
        if f.built.is_some() {
            return Ok(());
        }
        let h = -STRUCTURE_STEP * omega;
        // The two structures are independent builds (an eigen-decomposition of the model at
        // each speed): side by side.
        let structure = f.structure;
        let (a, b) = rayon::join(|| structure.at(omega), || structure.at(omega + h));
        f.built = Some(StructurePair {
            omega,
            a: a?,
            b: b?,
            h,
        });
        (self.cache, self.blended) = (None, Blended::default());
        Ok(())
    }

    /// The compliance at W of the structure the residual holds, on the columns of the contact
    /// rows `rows` at least (`ModalDynamics::compliance_rows_into`).
    fn compliance(
        &mut self,
        omega: f64,
        rows: &[usize],
    ) -> Result<&ContactCompliance, ForcedError> {
        let dynamics = match self.following.as_ref().and_then(|f| f.built.as_ref()) {
            Some(b) => &b.a.0,
            None => self.dynamics,
        };
        let cache = self
            .cache
            .get_or_insert_with(|| ContactCompliance::empty(dynamics.contacts(), dynamics.terms()));
        dynamics.compliance_rows_into(omega, rows, cache)?;
        Ok(cache)
    }

    /// The compliance of the structure the residual at W holds: G(W) of the fixed structure,
    /// or of a following one linearized between S_s and S(W_s + h) (`following::Following`),
    /// G_s(W) + (W - W_s) / h (G_h(W) - G_s(W)) (R's term -(W - W_s) D carries the second
    /// structure's G, and the Newton matrix I + G J_Lambda must carry it too: with G_s alone the
    /// matrix is off by (W - W_s) dG/dW|_structure J_Lambda, which under the stiff penalty law
    /// stalled the line search (the blade's EO 3 sweep, session 25; DESIGN §10.10)). On the
    /// columns of the contact rows `rows` at least; computed once per W and row (the Newton
    /// matrix and the W column share it).
    fn jacobian_compliance(
        &mut self,
        omega: f64,
        rows: &[usize],
    ) -> Result<&ContactCompliance, ForcedError> {
        let pair =
            (self.following.as_ref().and_then(|f| f.built.as_ref())).filter(|p| p.omega != omega);
        let Some(pair) = pair else {
            return self.compliance(omega, rows);
        };
        let shift = (omega - pair.omega) / pair.h;
        let second = &mut self.blended.second;
        if !second.has_shape(pair.b.0.contacts(), pair.b.0.terms()) {
            *second = ContactCompliance::empty(pair.b.0.contacts(), pair.b.0.terms());
        }
        pair.b.0.compliance_rows_into(omega, rows, second)?;
        self.compliance(omega, rows)?;
        let first = self.cache.as_ref().expect("just written");
        self.blended.blend(first, shift, rows);
        Ok(&self.blended.compliance)
    }

    /// R(y, W) and the contact samples it used.
    fn residual(
        &mut self,
        s: &OrbitState,
        mu: &Multipliers,
    ) -> Result<(Vec<f64>, ContactSamples), ForcedError> {
        self.move_to(s.omega)?;
        let pair = self.following.as_ref().and_then(|f| f.built.as_ref());
        let moved_gaps = pair.map(|p| p.gaps_at(s.omega));
        let cs = contact_samples_smoothed(
            self.basis,
            moved_gaps.as_deref().unwrap_or(self.g0),
            &s.y,
            mu,
            self.smoothing,
            self.integration,
        );
        let casing = self.casing;
        let comp = self.compliance(s.omega, &cs.loaded_rows(self.basis.terms()))?;
        let g_lambda = comp.apply(&cs.coefficients);
        let mut r: Vec<f64> = (0..s.y.len())
            .map(|i| s.y[i] - s.level * comp.y_load[i] + g_lambda[i])
            .collect();
        r.iter_mut().zip(casing).for_each(|(v, c)| *v -= c);
        if let Some(p) = self.following.as_ref().and_then(|f| f.built.as_ref()) {
            if s.omega != p.omega {
                let motion = structure_motion(p, s, &cs)?;
                let shift = (s.omega - p.omega) / p.h;
                r.iter_mut().zip(motion).for_each(|(v, d)| *v -= shift * d);
            }
        }
        Ok((r, cs))
    }

    fn merit(&self, r: &[f64], arc: Option<(&ArcRow, &OrbitState)>) -> f64 {
        let ry = r.iter().fold(0.0_f64, |a, v| a.max(v.abs())) / self.y_scale;
        ry.max(arc.map_or(0.0, |(a, s)| a.residual(s).abs()))
    }

    /// Runs Newton from `state` at `mu` (W fixed unless `arc` is given) on the exact law; when it
    /// stagnates (the semi-smooth Newton cycling between active sets), restarts from `state` along
    /// a smoothing path mu = 1e-2 .. 1e-8 y_scale, each solve starting from the previous one,
    /// and ends on the exact law. Returns the iterations of every attempt.
    pub fn run(
        &mut self,
        state: &mut OrbitState,
        mu: &Multipliers,
        arc: Option<&ArcRow>,
    ) -> Result<usize, ForcedError> {
        let start = state.clone();
        self.smoothing = 0.0;
        let mut spent = self.settings.max_iterations;
        let first = match self.run_once(state, mu, arc) {
            Ok(it) => return Ok(it),
            Err(e) => e,
        };
        if let ForceIntegration::ExactPenalty { stiffness, phases } = self.integration {
            state.clone_from(&start);
            let done = self.penalty_homotopy(state, mu, arc, stiffness, phases);
            self.integration = ForceIntegration::ExactPenalty { stiffness, phases };
            return match done {
                Some(it) => Ok(spent + it),
                None => {
                    *state = start;
                    Err(first)
                }
            };
        }
        *state = start;
        for k in 2..=8 {
            self.smoothing = 10f64.powi(-k) * self.y_scale;
            spent += self
                .run_once(state, mu, arc)
                .unwrap_or(self.settings.max_iterations);
        }
        self.smoothing = 0.0;
        match self.run_once(state, mu, arc) {
            Ok(it) => Ok(spent + it),
            Err(_) => Err(first),
        }
    }

    /// The exactly integrated penalty law's rescue (DESIGN §10.9): its Jacobian is continuous
    /// but, where a contact phase appears, changes like k sqrt(penetration), and with a stiff law
    /// on a lightly damped resonance Newton's basin can be narrower than the distance from a
    /// prediction (or from the orbit at another N) to the orbit. At a soft stiffness
    /// `PENALTY_START` x k the basin is wide; the stiffness then grows geometrically to k, each
    /// stage from the last converged orbit, by a ratio that halves (in decades) after a failed
    /// stage and doubles after a converged one, between `PENALTY_RATIO_MIN` and 10. Returns the
    /// iterations spent, or `None` (the state is then left anywhere).
    fn penalty_homotopy(
        &mut self,
        state: &mut OrbitState,
        mu: &Multipliers,
        arc: Option<&ArcRow>,
        stiffness: f64,
        phases: ContactPhases,
    ) -> Option<usize> {
        let mut spent = 0;
        let (mut factor, mut decades) = (PENALTY_START, 1.0_f64);
        let mut converged = false;
        let mut last = state.clone();
        while spent < PENALTY_BUDGET {
            let trial = if converged {
                (factor * 10f64.powf(decades)).min(1.0)
            } else {
                factor
            };
            self.integration = ForceIntegration::ExactPenalty {
                stiffness: stiffness * trial,
                phases,
            };
            match self.run_once(state, mu, arc) {
                Ok(it) => {
                    spent += it;
                    if trial >= 1.0 {
                        return Some(spent);
                    }
                    (factor, converged) = (trial, true);
                    last.clone_from(state);
                    decades = (2.0 * decades).min(1.0);
                }
                Err(_) => {
                    spent += self.settings.max_iterations;
                    if !converged || decades < PENALTY_RATIO_MIN.log10() {
                        return None;
                    }
                    state.clone_from(&last);
                    decades *= 0.5;
                }
            }
        }
        None
    }

    /// One Newton run at the current smoothing (see [`Self::run`]).
    fn run_once(
        &mut self,
        state: &mut OrbitState,
        mu: &Multipliers,
        arc: Option<&ArcRow>,
    ) -> Result<usize, ForcedError> {
        let (mut r, mut cs) = self.residual(state, mu)?;
        let mut merit = self.merit(&r, arc.map(|a| (a, &*state)));
        for it in 0..self.settings.max_iterations {
            tracing::trace!(
                iteration = it,
                merit,
                omega = state.omega,
                "forced inner Newton"
            );
            if merit <= self.settings.tolerance {
                return Ok(it);
            }
            let (dy, dp) = self.direction(state, &r, &cs, arc)?;
            // The exactly integrated law is continuously differentiable: the Newton direction
            // decreases every residual for a short enough step, so only a decrease is taken
            // (down to `SHORTEST_STEP`); the sampled law's kinks may need a step that does not
            // decrease to leave a cycle between active sets (taken at 1/64).
            let exact = matches!(self.integration, ForceIntegration::ExactPenalty { .. });
            let forced_at = if exact { 0.0 } else { 1.0 / 64.0 };
            let mut step = 1.0;
            loop {
                if exact && step < SHORTEST_STEP {
                    return Err(ForcedError::NotConverged {
                        omega: state.omega,
                        reason: format!(
                            "inner Newton: no step along the Newton direction decreases the \
                             residual {merit:.3e} (units of g0)"
                        ),
                    });
                }
                let mut trial = OrbitState {
                    y: state.y.iter().zip(&dy).map(|(a, d)| a + step * d).collect(),
                    ..state.clone()
                };
                if let Some(a) = arc {
                    let p = state.parameter(a.parameter);
                    trial.set_parameter(a.parameter, p + step * dp);
                }
                let (rt, ct) = self.residual(&trial, mu)?;
                let mt = self.merit(&rt, arc.map(|a| (a, &trial)));
                if mt.is_finite() && (mt < merit || step < forced_at) {
                    (*state, r, cs, merit) = (trial, rt, ct, mt);
                    break;
                }
                step *= 0.5;
            }
        }
        if merit <= self.settings.tolerance {
            return Ok(self.settings.max_iterations);
        }
        Err(ForcedError::NotConverged {
            omega: state.omega,
            reason: format!(
                "inner Newton: residual {merit:.3e} (units of g0) after {} iterations",
                self.settings.max_iterations
            ),
        })
    }
}

impl InnerNewton<'_> {
    /// The unit tangent of the solution curve at the converged `state` (in the scaled space of
    /// `along`: dy / y_scale, dp / p_scale), oriented so that it has a positive component along
    /// `along`'s tangent: the null vector of [dR/dy, dR/dp], bordered by that tangent.
    pub fn tangent(
        &mut self,
        state: &OrbitState,
        mu: &Multipliers,
        along: &ArcRow,
    ) -> Result<Vec<f64>, ForcedError> {
        let (_, cs) = self.residual(state, mu)?;
        let zero = vec![0.0; state.y.len()];
        let (dy, dp) = self.bordered_solve(state, &zero, &cs, Some((along, -1.0)))?;
        let mut t: Vec<f64> = dy.iter().map(|v| v / along.y_scale).collect();
        t.push(dp / along.parameter_scale);
        let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(ForcedError::NotConverged {
                omega: state.omega,
                reason: "no tangent: the bordered matrix is singular".into(),
            });
        }
        Ok(t.into_iter().map(|v| v / norm).collect())
    }

    /// The Newton direction (dy, dp) from the reduced (bordered) system on the active rows.
    fn direction(
        &mut self,
        s: &OrbitState,
        r: &[f64],
        cs: &ContactSamples,
        arc: Option<&ArcRow>,
    ) -> Result<(Vec<f64>, f64), ForcedError> {
        self.bordered_solve(s, r, cs, arc.map(|a| (a, a.residual(s))))
    }

    /// Solves [dR/dy, dR/dp; arc row] (dy, dp) = -(r, arc residual) on the active rows, the
    /// inactive ones following (the arc row and its residual given with `arc`).
    fn bordered_solve(
        &mut self,
        s: &OrbitState,
        r: &[f64],
        cs: &ContactSamples,
        arc_row: Option<(&ArcRow, f64)>,
    ) -> Result<(Vec<f64>, f64), ForcedError> {
        let arc = arc_row.map(|(a, _)| a);
        let l = s.y.len();
        self.move_to(s.omega)?;
        let jac = self.active_jacobian(cs);
        let rate = match arc.map(|a| a.parameter) {
            Some(Parameter::Frequency) => self.frequency_column(s, cs, &jac)?,
            Some(Parameter::Level) => self
                .compliance(s.omega, &[])?
                .y_load
                .iter()
                .map(|v| -v)
                .collect(),
            None => vec![0.0; l],
        };
        let (t, contacts) = (self.basis.terms(), self.g0.len());
        let comp = self.jacobian_compliance(s.omega, jac.active())?;
        let mut row_active = vec![false; contacts];
        jac.active().iter().for_each(|&j| row_active[j] = true);
        let inactive: Vec<usize> = (0..l).filter(|&i| !row_active[i / t]).collect();
        let la = jac.len();
        let dim = la + usize::from(arc.is_some());
        let mut lu = DenseLu::default();
        let mut rhs = vec![0.0; dim];
        {
            let square = jac.square(comp);
            let mut a = lu.matrix(dim);
            a.as_mut().submatrix_mut(0, 0, la, la).copy_from(&square);
            for row in 0..la {
                let gi = jac.global(row);
                a[(row, row)] += 1.0;
                if arc.is_some() {
                    a[(row, la)] = rate[gi];
                }
                rhs[row] = -r[gi];
            }
            if let Some(arc) = arc {
                // The inactive rows eliminated: their tangent components times their rows
                // dy_i = -r_i - (G J dy)_i - rate_i dW, folded into the arc row.
                let tv = |i: usize| arc.tangent_y[i] / arc.y_scale;
                let mut tv_inactive = vec![0.0; l];
                inactive.iter().for_each(|&i| tv_inactive[i] = tv(i));
                let against =
                    |v: &[f64]| -> f64 { inactive.iter().map(|&i| tv_inactive[i] * v[i]).sum() };
                let through = jac.transpose_times(comp, &tv_inactive);
                for col in 0..la {
                    a[(la, col)] = tv(jac.global(col)) - through[col];
                }
                a[(la, la)] = arc.tangent_parameter / arc.parameter_scale - against(&rate);
                let residual = arc_row.map_or(0.0, |(_, v)| v);
                rhs[la] = -residual + against(r);
            }
        }
        if dim > 0 {
            if !lu.factor() {
                return Err(ForcedError::NotConverged {
                    omega: s.omega,
                    reason: format!(
                        "singular Newton matrix ({} active contact rows)",
                        jac.active().len()
                    ),
                });
            }
            lu.solve_slice(&mut rhs);
        }
        let dw = if arc.is_some() { rhs[la] } else { 0.0 };
        let mut dy = vec![0.0; l];
        for (ai, &j) in jac.active().iter().enumerate() {
            dy[j * t..(j + 1) * t].copy_from_slice(&rhs[ai * t..(ai + 1) * t]);
        }
        // The inactive rows follow: dy_i = -r_i - (G J dy_active)_i - rate_i dW.
        let follow = jac.times(comp, &rhs[..la]);
        for &i in &inactive {
            dy[i] = -r[i] - follow[i] - rate[i] * dw;
        }
        Ok((dy, dw))
    }

    /// dR/dW at `s` (L values): -dy_lin/dW of the structure as it stands, plus, for a following
    /// structure, the structure's own motion (`structure_rate`). `jac`: G J over the active
    /// rows (`active_jacobian`).
    fn frequency_column(
        &mut self,
        s: &OrbitState,
        cs: &ContactSamples,
        jac: &ActiveJacobian,
    ) -> Result<Vec<f64>, ForcedError> {
        let dynamics = self.structure();
        let z = dynamics.response(s.omega, s.level, &cs.coefficients)?;
        let mut rate = dynamics.response_rate(s.omega, &z)?;
        let pair = self.following.as_ref().and_then(|f| f.built.as_ref());
        if let Some(p) = pair.filter(|p| p.omega != s.omega) {
            // -(W - W_s) D(W, Lambda) of R moves with W at fixed y too: (W - W_s) / h times
            // the difference of the two structures' rates.
            let shift = (s.omega - p.omega) / p.h;
            let other = &p.b.0;
            let zb = other.response(s.omega, s.level, &cs.coefficients)?;
            let rate_b = other.response_rate(s.omega, &zb)?;
            rate.iter_mut()
                .zip(rate_b)
                .for_each(|(a, b)| *a += shift * (b - *a));
        }
        let mut rate: Vec<f64> = rate.into_iter().map(|v| -v).collect();
        if self.following.is_some() {
            let own = self.structure_rate(s, cs, jac)?;
            rate.iter_mut().zip(own).for_each(|(r, o)| *r += o);
        }
        Ok(rate)
    }

    /// The following structure's own dR/dW at fixed y and W: with S the structure at W / e,
    /// dR/dS dS/dW = -d y_lin/dS|_Lambda + G dLambda/dg0 dg0/dW, where y_lin = Psi z is the
    /// linear response to the load and the forces Lambda(y) (`structure_motion`) and, the law
    /// acting on y_j(t) - g0_j, dLambda_j/dg0_j = -J_j e_0 (e_0 the mean's coefficient), so the
    /// gap term is -sum_j (dg0_j/dW) (G J)[:, mean of row j] (`jac`: G J over the active
    /// rows); dS/dW by the difference of `Following`'s two structures.
    fn structure_rate(
        &mut self,
        s: &OrbitState,
        cs: &ContactSamples,
        jac: &ActiveJacobian,
    ) -> Result<Vec<f64>, ForcedError> {
        self.move_to(s.omega)?;
        let t = self.basis.terms();
        let f = self.following.as_ref().expect("a following structure");
        let pair = f.built.as_ref().expect("just built");
        let mut rate: Vec<f64> = (structure_motion(pair, s, cs)?.into_iter())
            .map(|d| -d / pair.h)
            .collect();
        let gap_rates: Vec<f64> = (jac.active().iter())
            .map(|&j| (pair.b.1[j] - pair.a.1[j]) / pair.h)
            .collect();
        let comp = self.jacobian_compliance(s.omega, jac.active())?;
        for (ai, dg) in gap_rates.into_iter().enumerate() {
            let column = jac.column(comp, ai * t);
            rate.iter_mut().zip(column).for_each(|(r, g)| *r -= dg * g);
        }
        Ok(rate)
    }

    /// R at `s` and the Newton direction (dy, dp) there on `arc` (W fixed without one), for
    /// the check that R(y + t dy, p + t dp) = (1 - t) R(y, p) + o(t) (`speed_column_check`).
    #[cfg(test)]
    pub(crate) fn residual_and_direction(
        &mut self,
        s: &OrbitState,
        mu: &Multipliers,
        arc: Option<&ArcRow>,
    ) -> Result<(Vec<f64>, Vec<f64>, f64), ForcedError> {
        let (r, cs) = self.residual(s, mu)?;
        let (dy, dp) = self.direction(s, &r, &cs, arc)?;
        Ok((r, dy, dp))
    }

    /// R at `s` only (`residual`), for the tests.
    #[cfg(test)]
    pub(crate) fn residual_only(
        &mut self,
        s: &OrbitState,
        mu: &Multipliers,
    ) -> Result<Vec<f64>, ForcedError> {
        Ok(self.residual(s, mu)?.0)
    }

    /// R at `s` and the column dR/dW of its bordered Newton matrix (`frequency_column`), for
    /// the check of that column against a difference of R (`speed_column_check`).
    #[cfg(test)]
    pub(crate) fn residual_and_column(
        &mut self,
        s: &OrbitState,
        mu: &Multipliers,
    ) -> Result<(Vec<f64>, Vec<f64>), ForcedError> {
        let (r, cs) = self.residual(s, mu)?;
        let jac = self.active_jacobian(&cs);
        let column = self.frequency_column(s, &cs, &jac)?;
        Ok((r, column))
    }

    /// The active rows of `cs` with their blocks of the block-diagonal J_Lambda: the exact
    /// blocks of the integrated penalty law, or the projected slopes of the sampled law.
    fn active_jacobian(&self, cs: &ContactSamples) -> ActiveJacobian {
        let (t, m) = (self.basis.terms(), self.basis.samples());
        let active: Vec<usize> = (0..self.g0.len())
            .filter(|&j| cs.row_active(j, m))
            .collect();
        let blocks = (active.iter())
            .map(|&j| match cs.blocks.get(j) {
                Some(Some(exact)) => exact.clone(),
                _ => {
                    let mut projected = Mat::zeros(t, t);
                    (self.basis).project_slopes(&cs.slope[j * m..(j + 1) * m], projected.as_mut());
                    projected
                }
            })
            .collect();
        ActiveJacobian::new(active, blocks, t)
    }
}

/// y_lin(W, Lambda; S(W_s + h)) - y_lin(W, Lambda; S_s) at the orbit `s` (signal-major, L
/// values): y_lin = Psi z the contact coordinates of the linear response to the load and the
/// forces Lambda of `cs` (`ModalDynamics::response`), on each structure of `pair`.
fn structure_motion(
    pair: &StructurePair,
    s: &OrbitState,
    cs: &ContactSamples,
) -> Result<Vec<f64>, ForcedError> {
    let linear = |d: &ModalDynamics| -> Result<Mat<f64>, ForcedError> {
        let z = d.response(s.omega, s.level, &cs.coefficients)?;
        Ok(crate::dynamics::product(
            d.contact_modes().as_ref(),
            z.as_ref(),
        ))
    };
    let (ya, yb) = (linear(&pair.a.0)?, linear(&pair.b.0)?);
    let t = ya.ncols();
    Ok((0..ya.nrows() * t)
        .map(|i| yb[(i / t, i % t)] - ya[(i / t, i % t)])
        .collect())
}
