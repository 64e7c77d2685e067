//! Algorithm 1 of the paper as printed: the frequency-time augmented Lagrangian with Powell's
//! measure and adaptive penalties (Powell 1978; Arora, Chahande & Paeng 1991).
//!
//! ```text
//! i = 0, G^(0) = inf, theta = theta^(1), kappa = kappa^(1)
//! while i < i_max:
//!     solve Eq. (20) at (theta, kappa); evaluate g_{j,k}; v = max(g, -theta) / g0
//!     L = { (j,k) : |v_{j,k}| >= G^(i) / alpha }
//!     Gbar = max_{j,k} |v_{j,k}|                                  (Eq. 21)
//!     if Gbar >= G^(i):  kappa_L <- beta kappa_L,  theta_L <- theta_L / beta
//!     else:
//!         i <- i + 1;  G^(i) <- Gbar
//!         if G^(i) <= epsilon: converged
//!         theta <- theta + max(g, -theta)                          (Eq. 16)
//!         if G^(i) >= G^(i-1) / alpha:  kappa_L <- beta kappa_L
//! ```
//!
//! Not printed, and off by default: where the loop ends short of epsilon (i_max, a guard, a failed
//! inner solve), the orbit of the last accepted iterate is returned if its G is at most
//! `stall_factor` x epsilon
//! ([`AlgorithmParams::stall_factor`], docs/DESIGN.md §3.5).
//!
//! G is Powell's measure; by default the entrywise maximum max_{j,k} |v_{j,k}| (see
//! [`PowellMeasure`] for why not the row-maximum reading of docs/DESIGN.md §3, which can accept orbits that
//! violate complementarity). G is measured in units of the initial gap: v is divided by g0_j, so epsilon is relative to g0.
//! The rejection branch scales kappa up and theta down by the same factor, which keeps the
//! multiplier estimate kappa * theta unchanged. Initial penalties: kappa^(1)_j =
//! `initial_penalty` x (static stiffness seen by contact row j, 1 / (A_j K^-1 A_j^T)); theta^(1) = 0
//! (or the warm start). Penalties are capped at `max_penalty` x that stiffness: a very stiff
//! penalty makes the inner problem nearly a degenerate complementarity problem (more sampled
//! constraints than harmonics per contact row) on which Newton cycles. Where the cap binds, the
//! rejection branch updates the multiplier by Eq. (16) instead of raising kappa (the method of
//! multipliers at fixed penalty), and kappa * theta is conserved when kappa is raised by less than
//! beta.

use serde::{Deserialize, Serialize};

use crate::check::{at_least_one, greater_than_one, positive, require};
use crate::contact::{powell_measure_of, violations, Multipliers, PowellMeasure};
use crate::error::HbError;

/// How the contact constraint is enforced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ContactMethod {
    /// Algorithm 1: augmented Lagrangian with Powell's multiplier and penalty updates.
    #[default]
    AugmentedLagrangian,
    /// Plain penalty: lambda = stiffness (g)_+ with theta = 0 and no update (one inner solve). The
    /// stiffness is absolute (force per length), the same for every contact row.
    Penalty {
        /// Penalty stiffness kc (force per length).
        stiffness: f64,
    },
}

/// What the penalty increase of an accepted iteration does to theta (Algorithm 1, last branch).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum PenaltyUpdate {
    /// kappa_L <- beta kappa_L and theta_L <- theta_L / beta: the multiplier estimate kappa theta
    /// just computed by Eq. (16) is kept, as in the rejection branch and in Powell's method.
    #[default]
    KeepMultiplier,
    /// kappa_L <- beta kappa_L only, literally as printed: this multiplies the new multiplier
    /// estimate kappa theta by beta on L, which over-pushes (G grows at the next solve) and then
    /// needs rejections to undo; kept for comparison.
    AsPrinted,
}

/// Parameters of Algorithm 1 (the inner solver's settings are [`crate::solver_settings::SolverSettings`], which
/// holds these). Every field has a default (`#[serde(default)]`), so a settings file only lists
/// what it changes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AlgorithmParams {
    /// alpha > 1: required decrease factor of G per accepted iteration (default 4, Powell's value).
    pub alpha: f64,
    /// beta > 1: penalty growth factor (default 10).
    pub beta: f64,
    /// epsilon > 0: convergence when G <= epsilon, G in units of g0 (default 1e-4: penetration
    /// and complementarity error below 1e-4 g0). On the default blade this makes the backbone
    /// independent of the continuation step to 1e-4 in w (`tests/step_independence.rs`); with
    /// 1e-3 two runs differ by up to 2.7e-4 (docs/VERIFICATION.md §"Algorithm 1's tolerance").
    /// Needs `max_penalty` of about 1e4: with 1e3 Algorithm 1 stalls at G of 1.1-1.7e-4 with
    /// many nodes in contact.
    pub epsilon: f64,
    /// A point whose Algorithm 1 stops short of epsilon (i_max, `max_inner_solves`, the Newton
    /// budget or a failed inner solve) is still accepted at its last accepted iterate when that
    /// iterate's G is at most `stall_factor` x epsilon. Default 1: never, as printed. With many
    /// nodes in contact the sampled complementarity problem can floor G just above a tight
    /// epsilon (1.2-1.4e-4 on the blade's second mode), and refusing the point makes the
    /// continuation halve its step, down to a jump; 10 keeps such points (blade mode 2: 4.7 s
    /// instead of 8.9 s) at the price of less accurate points, which on dense steps can bend the
    /// branch into spurious weak tongues (docs/DESIGN.md §3.5). A kept point carries its G
    /// (`powell_measure` > epsilon in backbone.csv). Not in the paper.
    pub stall_factor: f64,
    /// Reading of Eq. (21) (default entrywise, see [`PowellMeasure`]).
    pub measure: PowellMeasure,
    /// Penalty increase after an accepted iteration with too little progress (see
    /// [`PenaltyUpdate`]; default `KeepMultiplier`).
    pub penalty_update: PenaltyUpdate,
    /// i_max: maximum accepted iterations (default 50).
    pub max_iterations: usize,
    /// Maximum inner solves, accepted or not, per point (default 100): a guard the printed
    /// algorithm does not need in theory.
    pub max_inner_solves: usize,
    /// kappa^(1) as a multiple of the static stiffness seen by each contact row (default 10).
    pub initial_penalty: f64,
    /// Cap of kappa as a multiple of the same stiffness (default 1e4). At the cap the multiplier
    /// moves by Eq. (16) at fixed kappa; a higher cap drains the multiplier of samples that
    /// separate faster (by kappa g per update), a lower one stalls at tight epsilon (1e3: G
    /// floors at 1.1-1.7e-4 on the blade), a much higher one makes Newton cycle (DESIGN §3.5).
    pub max_penalty: f64,
    /// Augmented Lagrangian (default) or plain penalty.
    pub method: ContactMethod,
    /// Newton iterations allowed per point, all inner solves and fallbacks included (default 400):
    /// bounds the cost of a point that does not converge.
    pub newton_budget: usize,
    /// Warning threshold on the highest harmonic's share of the contact-row motion,
    /// max_j |A_j u_N| / max_j (sum_{n>=1} |A_j u_n|^2)^(1/2) (default 1e-3): above it the point is
    /// flagged and a tracing warning says N is too small for this amplitude.
    pub truncation_warning: f64,
}

impl Default for AlgorithmParams {
    fn default() -> Self {
        Self {
            alpha: 4.0,
            beta: 10.0,
            epsilon: 1e-4,
            stall_factor: 1.0,
            measure: PowellMeasure::Entrywise,
            penalty_update: PenaltyUpdate::KeepMultiplier,
            max_iterations: 50,
            max_inner_solves: 100,
            initial_penalty: 10.0,
            max_penalty: 1e4,
            method: ContactMethod::AugmentedLagrangian,
            newton_budget: 400,
            truncation_warning: 1e-3,
        }
    }
}

impl AlgorithmParams {
    /// Checks every parameter range; the error names the parameter.
    pub fn validate(&self) -> Result<(), HbError> {
        let (gt1, pos) = (greater_than_one, positive);
        gt1("alpha", self.alpha)?;
        gt1("beta", self.beta)?;
        pos("epsilon", self.epsilon)?;
        let stall = self.stall_factor;
        require(
            "stall_factor",
            stall,
            stall.is_finite() && stall >= 1.0,
            "a finite value >= 1",
        )?;
        pos("initial_penalty", self.initial_penalty)?;
        pos("max_penalty", self.max_penalty)?;
        pos("truncation_warning", self.truncation_warning)?;
        if self.max_penalty < self.initial_penalty {
            return Err(HbError::InvalidParameter {
                name: "max_penalty",
                value: self.max_penalty,
                expected: ">= initial_penalty",
            });
        }
        at_least_one("max_iterations", self.max_iterations)?;
        at_least_one("newton_budget", self.newton_budget)?;
        at_least_one("max_inner_solves", self.max_inner_solves)?;
        if let ContactMethod::Penalty { stiffness } = self.method {
            pos("method.stiffness", stiffness)?;
        }
        Ok(())
    }
}

/// Counters and final measure of one run of Algorithm 1.
#[derive(Clone, Copy, Debug, Default)]
pub struct OuterReport {
    /// Final Powell measure G (units of g0).
    pub measure: f64,
    /// Accepted iterations i.
    pub accepted: usize,
    /// Inner solves.
    pub solves: usize,
    /// Newton iterations summed over the inner solves.
    pub newton_iterations: usize,
    /// Accepted at its last accepted iterate with G above epsilon (see
    /// [`AlgorithmParams::stall_factor`]).
    pub stalled: bool,
}

/// The inner solves Algorithm 1 drives (Eq. 20 at given multipliers), and the orbit of its last
/// accepted iterate.
pub trait InnerSolves {
    /// Solves Eq. (20) at `multipliers`, writes the gap samples (c x m) into `gaps` and returns
    /// the Newton iterations spent.
    fn solve(&mut self, multipliers: &Multipliers, gaps: &mut Vec<f64>) -> Result<usize, HbError>;
    /// Remembers the orbit just solved (an accepted iterate).
    fn keep(&mut self);
    /// Returns to the orbit last kept.
    fn restore(&mut self);
}

/// The rejection branch of Algorithm 1 on L = { |v| >= threshold }: kappa_L <- beta kappa_L and
/// theta_L <- theta_L / beta (capped at `kappa_cap`, the multiplier estimate kappa theta kept);
/// where kappa is at its cap, the multiplier is updated by Eq. (16) instead (the method of
/// multipliers at fixed penalty).
fn reject(
    mu: &mut Multipliers,
    v: &[f64],
    threshold: f64,
    g0: &[f64],
    kappa_cap: &[f64],
    beta: f64,
) {
    let m = mu.samples;
    for i in 0..v.len() {
        if v[i].abs() >= threshold {
            let (j, cap) = (i / m, kappa_cap[i / m]);
            if mu.kappa[i] >= cap {
                mu.theta[i] += v[i] * g0[j];
            } else {
                let old = mu.kappa[i];
                let new = (old * beta).min(cap);
                mu.kappa[i] = new;
                mu.theta[i] *= old / new;
            }
        }
    }
}

/// Eq. (16) at an accepted iteration: theta <- theta + max(g, -theta), with v = max(g, -theta)
/// / g0 (v in units of g0).
fn update_multipliers(mu: &mut Multipliers, v: &[f64], g0: &[f64]) {
    let m = mu.samples;
    for (j, &g0j) in g0.iter().enumerate() {
        for k in 0..m {
            let i = j * m + k;
            mu.theta[i] += v[i] * g0j;
        }
    }
}

/// Too little progress at an accepted iteration: kappa_L <- beta kappa_L on
/// L = { |v| >= threshold } (capped, never lowered), and theta_L <- theta_L kappa_old / kappa_new
/// with [`PenaltyUpdate::KeepMultiplier`].
fn raise_penalties(
    mu: &mut Multipliers,
    v: &[f64],
    threshold: f64,
    kappa_cap: &[f64],
    beta: f64,
    update: PenaltyUpdate,
) {
    let m = mu.samples;
    for i in 0..v.len() {
        if v[i].abs() >= threshold {
            let cap = kappa_cap[i / m];
            let old = mu.kappa[i];
            let new = (old * beta).min(cap).max(old);
            mu.kappa[i] = new;
            if update == PenaltyUpdate::KeepMultiplier {
                mu.theta[i] *= old / new;
            }
        }
    }
}

/// Failure of Algorithm 1 with what was reached.
pub struct OuterFailure {
    pub report: OuterReport,
    pub reason: String,
}

/// Runs Algorithm 1 with `inner` solving Eq. (20); `kappa_cap[j]` bounds kappa on row j. On
/// return `multipliers` are those of the orbit `inner` holds (the converged one, or the last
/// accepted iterate of a point accepted by [`AlgorithmParams::stall_factor`]).
pub fn run_algorithm1(
    params: &AlgorithmParams,
    g0: &[f64],
    kappa_cap: &[f64],
    multipliers: &mut Multipliers,
    inner: &mut dyn InnerSolves,
) -> Result<OuterReport, OuterFailure> {
    let m = multipliers.samples;
    let c = g0.len();
    let mut gaps = vec![0.0; c * m];
    let mut v = vec![0.0; c * m];
    let mut rep = OuterReport {
        measure: f64::INFINITY,
        ..Default::default()
    };
    let mut g_accepted = f64::INFINITY; // G^(i)
    let mut kept = multipliers.clone(); // the multipliers of the last accepted iterate
    let (alpha, beta) = (params.alpha, params.beta);
    let reason = loop {
        if rep.accepted >= params.max_iterations {
            break format!(
                "i_max = {} accepted iterations reached",
                params.max_iterations
            );
        }
        if rep.solves >= params.max_inner_solves {
            break format!("{} inner solves without convergence", rep.solves);
        }
        rep.solves += 1;
        match inner.solve(multipliers, &mut gaps) {
            Ok(it) => rep.newton_iterations += it,
            Err(e) => break format!("inner solve failed: {e}"),
        }
        violations(&gaps, &multipliers.theta, g0, m, &mut v);
        let g_bar = powell_measure_of(&v, m, params.measure);
        rep.measure = g_bar;
        if g_bar >= g_accepted {
            reject(multipliers, &v, g_accepted / alpha, g0, kappa_cap, beta);
        } else {
            rep.accepted += 1;
            let g_previous = g_accepted;
            g_accepted = g_bar;
            if g_bar <= params.epsilon {
                return Ok(rep);
            }
            if params.stall_factor > 1.0 {
                inner.keep();
                kept.clone_from(multipliers);
            }
            update_multipliers(multipliers, &v, g0);
            if g_bar >= g_previous / alpha {
                let update = params.penalty_update;
                raise_penalties(multipliers, &v, g_previous / alpha, kappa_cap, beta, update);
            }
        }
    };
    if g_accepted <= params.stall_factor * params.epsilon {
        inner.restore();
        *multipliers = kept;
        rep.measure = g_accepted;
        rep.stalled = true;
        return Ok(rep);
    }
    Err(OuterFailure {
        report: rep,
        reason,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An inner solve whose gap samples follow a script: solve i penetrates sample 0 by
    /// `script[i]` g0 (the last entry repeats; NaN: the solve fails) and keeps the others open by
    /// g0, so Powell's measure of solve i is `script[i]` whatever the multipliers. `orbit`
    /// numbers the solves (0: none yet).
    struct Scripted {
        script: Vec<f64>,
        solves: usize,
        orbit: usize,
        kept: Option<usize>,
        seen: Vec<Multipliers>,
    }

    impl InnerSolves for Scripted {
        fn solve(&mut self, mu: &Multipliers, gaps: &mut Vec<f64>) -> Result<usize, HbError> {
            let g = self.script[self.solves.min(self.script.len() - 1)];
            self.solves += 1;
            self.orbit = self.solves;
            self.seen.push(mu.clone());
            if g.is_nan() {
                return Err(HbError::NonFiniteResult {
                    what: "a scripted solve",
                });
            }
            gaps.iter_mut().for_each(|v| *v = -1.0);
            gaps[0] = g;
            Ok(1)
        }
        fn keep(&mut self) {
            self.kept = Some(self.orbit);
        }
        fn restore(&mut self) {
            self.orbit = self.kept.expect("restore without keep");
        }
    }

    /// Algorithm 1 (epsilon = 1e-4, `stall_factor` and `max_iterations` as given) on a script.
    fn run(
        script: &[f64],
        stall_factor: f64,
        max_iterations: usize,
    ) -> (Result<OuterReport, OuterFailure>, Scripted, Multipliers) {
        let params = AlgorithmParams {
            epsilon: 1e-4,
            stall_factor,
            max_iterations,
            ..AlgorithmParams::default()
        };
        let mut inner = Scripted {
            script: script.to_vec(),
            solves: 0,
            orbit: 0,
            kept: None,
            seen: Vec::new(),
        };
        let mut mu = Multipliers::uniform(&[10.0], 4);
        let r = run_algorithm1(&params, &[1.0], &[1e4], &mut mu, &mut inner);
        (r, inner, mu)
    }

    /// The point is the third solve's (G = 3e-4 <= 10 epsilon): orbit and multipliers restored.
    fn assert_third_solve_kept(
        r: Result<OuterReport, OuterFailure>,
        inner: &Scripted,
        mu: &Multipliers,
    ) {
        let rep = r.unwrap_or_else(|f| panic!("{}", f.reason));
        assert!(rep.stalled);
        assert_eq!((rep.measure, rep.accepted), (3e-4, 3));
        assert_eq!(inner.orbit, 3);
        assert_eq!(*mu, inner.seen[2]);
        assert_ne!(*mu, *inner.seen.last().unwrap());
    }

    #[test]
    fn a_floor_below_the_stall_factor_keeps_the_last_accepted_iterate() {
        // G: 0.5, 0.1, 3e-4 (accepted), then 3e-4 for ever (rejected): a floor above epsilon,
        // ended by max_inner_solves.
        let (r, inner, mu) = run(&[0.5, 0.1, 3e-4], 10.0, 50);
        assert_eq!(inner.solves, AlgorithmParams::default().max_inner_solves);
        assert_third_solve_kept(r, &inner, &mu);
    }

    #[test]
    fn a_failed_inner_solve_after_an_accepted_iterate_keeps_that_iterate() {
        // The fourth solve fails (its orbit is garbage): the third is restored.
        let (r, inner, mu) = run(&[0.5, 0.1, 3e-4, 2e-4, f64::NAN], 10.0, 50);
        assert_eq!(inner.solves, 5);
        assert!(r.as_ref().is_ok_and(|rep| rep.measure == 2e-4));
        let (r, inner, mu2) = run(&[0.5, 0.1, 3e-4, f64::NAN], 10.0, 50);
        assert_eq!(inner.solves, 4);
        assert_third_solve_kept(r, &inner, &mu2);
        assert_ne!(mu, mu2);
    }

    #[test]
    fn i_max_ends_a_stall_too() {
        // Three accepted iterates, the last too slow (2.5e-4 > 3e-4 / alpha): i_max = 3 ends it.
        let (r, inner, mu) = run(&[0.5, 3e-4, 2.5e-4, 1e-5], 10.0, 3);
        let rep = r.unwrap_or_else(|f| panic!("{}", f.reason));
        assert!(rep.stalled);
        assert_eq!((rep.measure, rep.accepted, inner.solves), (2.5e-4, 3, 3));
        assert_eq!((inner.orbit, &mu), (3, &inner.seen[2]));
    }

    #[test]
    fn a_stall_above_the_factor_a_factor_of_one_or_no_accepted_iterate_is_an_error() {
        let cases: [(&[f64], f64, &str); 4] = [
            (&[0.5, 0.1, 3e-4], 1.0, "inner solves"),
            (&[0.5, 0.1, 3e-3], 10.0, "inner solves"),
            (&[f64::NAN], 1e300, "inner solve failed"),
            (&[0.5, 0.1, 3e-4, f64::NAN], 2.0, "inner solve failed"),
        ];
        for (script, factor, reason) in cases {
            let (r, _, _) = run(script, factor, 50);
            let f = r.expect_err("a stalled point must fail");
            assert!(f.reason.contains(reason), "{}", f.reason);
            assert!(!f.report.stalled);
        }
    }

    #[test]
    fn convergence_below_epsilon_is_not_a_stall() {
        let (r, inner, _) = run(&[0.5, 0.1, 1e-2, 5e-5], 10.0, 50);
        let rep = r.unwrap_or_else(|f| panic!("{}", f.reason));
        assert!(!rep.stalled);
        assert_eq!((rep.measure, rep.solves, inner.orbit), (5e-5, 4, 4));
    }

    #[test]
    fn a_nan_violation_is_not_a_small_measure() {
        let v = [1e-6, f64::NAN, 0.0, 0.0];
        for kind in [PowellMeasure::Entrywise, PowellMeasure::RowMaximum] {
            assert!(powell_measure_of(&v, 4, kind).is_nan(), "{kind:?}");
        }
    }
}
