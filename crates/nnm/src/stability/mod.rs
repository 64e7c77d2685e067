//! Floquet stability of computed nonlinear-mode orbits (Hill's method) and bifurcation flags.
//!
//! The paper (Laxalde, Legrand & Pierre 2009, Sec. 5) names "stability and bifurcations
//! analysis" as the next step; this module provides it for the orbits of [`crate::BackbonePoint`].
//! See docs/STABILITY.md for the derivation, the tolerances and the convergence tables.
//!
//! # Linearized equation
//! Along an orbit u(t) = sum_n u_n cos(n w t) the perturbation y obeys
//! M y'' + K y + A^T D(t) A y = 0 (physical units: M in kg, K in N/m, D in N/m), where D(t) is the
//! generalized Jacobian of the sampled contact law at convergence,
//! lambda_{j,k} = kappa_{j,k} max(0, g_j(t_k) + theta_{j,k}) (the integrand of Eq. 15): kappa on
//! the active samples (g + theta > 0), zero elsewhere. It is the Jacobian the semi-smooth Newton
//! of Eq. (20) uses, so Hill's matrix at s = 0 restricted to cosines is the harmonic-balance
//! Jacobian itself.
//!
//! What D approximates: a penalty (or augmented-Lagrangian) spring kappa regularizes the rigid
//! impact. For the rigid, elastic impact the exact monodromy is the free flow between impacts
//! times the saltation matrix of each impact (Leine & Nijmeijer 2004, "Dynamics and Bifurcations
//! of Non-smooth Mechanical Systems", Sec. 7.2); the regularized flow converges to it as kappa
//! grows if the contact phase, of duration ~ pi / sqrt(kappa / m_eff), stays resolved: Hill needs
//! N w well above sqrt(kappa / m_eff). Penalty orbits use their own kappa (the exact linearization
//! of the penalty equation). Augmented-Lagrangian orbits carry their impacts on one or two samples
//! with the capped kappa, a spring far too short to reverse the perturbation's normal velocity:
//! their short rigid phases are replaced by the impact-equivalent spring of `impact` (an elastic
//! bounce of width `impact_width` T / N). The tests check both against an exact one-impact oracle.
//!
//! By default ([`JacobianInTime::Continuous`]) a row is active where the reconstructed
//! g_j(t) + theta_j > 0, with the switch instants located in time and the moments integrated
//! exactly; [`JacobianInTime::SampleIntervals`] uses the sample quadrature of the harmonic balance
//! (its Newton Jacobian), whose O(1/m) quantization of the contact duration splits the trivial
//! pair by O(m^-1/2) (docs/STABILITY.md, Sec. 3).
//!
//! # Event-based monodromy (unresolved impacts)
//! For an augmented-Lagrangian orbit whose contact phases are all unresolved impacts (each shorter
//! than `impact_width` T / N, one row at a time; [`FloquetSettings::saltation`]) on a model whose
//! modes the N harmonics all resolve, no spring
//! reproduces the impact near grazing: the saltation matrix's term 2 M^-1 a (a.acc) a^T /
//! (c a.v-) needs a bounce much shorter than a.v- / |a.acc|, and a.v- -> 0 at grazing. Those
//! orbits get the exact linearization of the rigid problem instead: the free linear flow between
//! the impacts and the saltation matrix of the elastic impact at each (Leine & Nijmeijer 2004,
//! Sec. 7.2), with the impact instant, impulse and displacement taken from the orbit, and the
//! non-trivial multipliers read from the monodromy reduced to the energy surface modulo the flow
//! (`saltation` module; docs/STABILITY.md, Sec. 3.1). [`Stability::method`] says which method
//! gave a point's multipliers.
//!
//! # Hill's method
//! y(t) = e^{s t} p(t) with p T-periodic on the full basis {1, sqrt2 cos(n w t), sqrt2 sin(n w t)},
//! n = 1..N (orthonormal for the time average). The Galerkin projection gives the quadratic
//! eigenproblem (H0 + s G + s^2 H2) x = 0 with H2 = I (modal coordinates), G skew (gyroscopic
//! terms +-2 n w coupling cos n and sin n) and H0 symmetric: (w_k^2 - (n w)^2) on the diagonal plus
//! the contact term, whose blocks are the cosine and sine moments of D over the period. Since H0 is symmetric and G skew the linearization
//! [[0, I], [-H0, -G]] is Hamiltonian: the exponents come in quadruples (s, -s, conj s, -conj s), so
//! the multipliers mu = exp(s T) come in reciprocal, conjugate pairs exactly (up to round-off),
//! whatever N and m.
//!
//! Of the 2 r (2N + 1) eigenvalues only 2 r are Floquet exponents (r modes); the others are copies
//! shifted by i n w with less accurate eigenvectors. The selection follows Lazarus & Thomas
//! (C. R. Mecanique 338, 2010, 510-517): write each eigenvector's periodic part on complex
//! harmonics e^{i n w t}, n = -N..N, and keep, of each family of copies s + i k w, the one whose
//! harmonic content is best centred on n = 0 (smallest |weighted mean of n|). Visiting the
//! eigenvalues by increasing |mean| and discarding the copies of each kept one makes every family
//! give exactly one exponent. Ties by the rms harmonic (sum n^2 |c_n|^2 / sum |c_n|^2)^1/2, which
//! the real eigenvectors of a degenerate real eigenvalue need (s = 0 from the copies +-i w1 -+ i w
//! in the linear regime: mean 0 but rms 1), then by |Im s|; each exponent off the imaginary axis is
//! taken with its Hamiltonian partner -conj(s).
//! Guillot, Lazarus, Thomas, Vergez & Cochelin (J. Comput. Phys. 416, 2020, 109477) discuss this
//! criterion against the |Im s| <= w/2 one; the eigenvector criterion keeps a high mode's exponent
//! at +-i w_k instead of a folded copy that the truncation represents badly.
//!
//! # Reduction for large models
//! Hill's matrix is built on the r linear modes with w_k <= `mode_cutoff` (N + 1) w (default 0.5,
//! at least `min_modes`: the modes whose exponents N harmonics resolve, N >~ 2 w_k / w); the discarded modes act quasi-statically on the contact rows through their
//! residual flexibility R = A (K^-1 - Phi_r W_r^-2 Phi_r^T) A^T, so that each sample's contact
//! stiffness becomes D_eff = (D_S^-1 + R_SS)^-1 on its active set S (the series spring of the
//! penalty and the discarded modes, the idea of the project's modal tail). This neglects the
//! inertia of the discarded modes at the frequencies (n w + Im s), a relative error
//! O(((N + 1) w / w_k)^2) in their response, and drops their exponents (near +-i w_k, on the
//! unit circle to the same order). With every mode kept (a large `mode_cutoff`) nothing is
//! approximated beyond N and m.

mod backbone_curve;
mod bifurcation;
mod boundary_at_q;
mod boundary_backbone;
mod boundary_flow;
mod boundary_history;
mod boundary_holes;
mod boundary_shooting;
mod event_based;
mod hill;
mod impact;
mod modal_basis;
mod monodromy;
mod saltation;
#[cfg(test)]
mod test_models;

pub use backbone_curve::{BoundaryBackbonePoint, BoundaryPiece};
pub use bifurcation::{classify, Bifurcation};
pub use boundary_at_q::{ConvergedOrbit, ConvergenceSettings, ConvergenceStop, ExactOrbitAtQ};
pub use boundary_backbone::{boundary_backbone, BoundaryBackbone};
pub use boundary_history::{boundary_history, BoundaryHistory};
pub use boundary_holes::{HoleFollow, HoleFollowEnd};
pub use hill::FloquetAnalysis;
pub use modal_basis::DECOUPLED_SHARE;
pub use monodromy::{monodromy_by_integration, JacobianInTime, Monodromy, MonodromySettings};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::continuation::Backbone;
use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_hb::check::{at_least_one, require};
use nlmodes_hb::system::System;

/// Settings of the Hill stability analysis. Every field has a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FloquetSettings {
    /// Keep the linear modes with w_k <= mode_cutoff (N + 1) w (default 0.5): the others are
    /// condensed statically onto the contact rows. A large value (e.g. 1e9) keeps every mode.
    /// Why 0.5: under strong contact the exponent of a mode k couples to its conjugate copy
    /// 2 w_k / w harmonics away, so Hill resolves it only for N >~ 2 w_k / w (on the truncated
    /// blade the exponents of modes at 22 w are off by 1e-2 with N = 12 and 24 and right to 7e-5
    /// with N = 48; docs/STABILITY.md).
    pub mode_cutoff: f64,
    /// Keep at least this many modes (default 2), whatever the cutoff.
    pub min_modes: usize,
    /// Static correction of the discarded modes on the contact rows (default true).
    pub static_correction: bool,
    /// A point is stable when every non-trivial multiplier has |mu| <= 1 + tolerance (default
    /// 1e-6). Hill's linearization is Hamiltonian, so a simple multiplier on the unit circle stays
    /// on it under any symmetric perturbation (N, m, round-off): what leaves it is a genuine pair
    /// (mu, 1/mu). The tolerance only absorbs the round-off of the non-symmetric eigensolver,
    /// ~1e-12 relative to the largest exponent (|mu| - 1 ~ 1e-9 for kappa / w^2 ~ 1e6).
    pub tolerance: f64,
    /// Contact Jacobian in Hill's matrix (default continuous): `SampleIntervals` projects the
    /// sampled Jacobian by the sample quadrature of the harmonic balance (exactly its Newton
    /// Jacobian); `Continuous` integrates exactly the Jacobian whose rows are active where the
    /// reconstructed g_j(t) + theta_j > 0 (switch instants located in time), which removes the
    /// O(1/m) quantization of the contact duration (see docs/STABILITY.md).
    pub jacobian: JacobianInTime,
    /// Impact-equivalent linearization of the short rigid contact phases of augmented-Lagrangian
    /// orbits (see docs/STABILITY.md): a phase shorter than `impact_width` T / N with theta > 0 is
    /// replaced by the spring m_eff (pi / tau)^2 acting for tau = `impact_width` T / N (an elastic
    /// bounce of the perturbation). Default 1.5; 0 keeps the augmented-Lagrangian Jacobian as is.
    /// Continuous Jacobian only; penalty orbits (theta = 0) are never changed.
    pub impact_width: f64,
    /// Event-based monodromy for augmented-Lagrangian orbits whose contact phases are all
    /// unresolved impacts (default true): free linear flow between the impacts and the saltation
    /// matrix of the elastic impact at each (docs/STABILITY.md, Sec. 3). An impact is a run of
    /// samples with a positive contact force, with theta > 0 (the rigid law), shorter than
    /// `impact_width` T / N, and no other row in contact on or next to its samples, on a model
    /// whose linear modes all satisfy w_k <= `mode_cutoff` (N + 1) w (all resolved). Orbits with
    /// any other contact phase (persistent contact, simultaneous impacts, penalty law) and
    /// contact-free orbits use Hill's method. Off: Hill's method everywhere.
    pub saltation: bool,
    /// Stability on the massless contact boundary (default true; docs/STABILITY.md, Sec. 9):
    /// for an orbit in contact on a model with modes above `shooting_cutoff` (N + 1) w, the
    /// modes up to that cutoff stay dynamic, the others act on the contact rows through their
    /// residual flexibility, the contact displacements carry no mass, and the periodic orbit of
    /// that model nearest the harmonic-balance orbit is found by shooting; its multipliers are
    /// the eigenvalues of its exact monodromy. Off, or where shooting does not converge: Hill's
    /// method.
    pub shooting: bool,
    /// Modes kept dynamic on the massless boundary: w_k <= shooting_cutoff (N + 1) w (default 1:
    /// the modes whose resonant harmonics the orbit holds), at least one (issue 38: not
    /// `min_modes`, which is Hill's).
    pub shooting_cutoff: f64,
    /// Check every k-th point's shooting verdict by an independent RK4 integration of the
    /// massless boundary ([`ShootingCheck`]); a verdict the check does not confirm becomes
    /// `undetermined`. 0 (default): no check. The check costs about one RK4 period with
    /// 200 steps per period of the fastest contact frequency per checked point (0.04 s on the
    /// default blade). Set by the program's `[stability] verify_every`, not read from a file.
    #[serde(skip)]
    pub verify_every: usize,
}

impl Default for FloquetSettings {
    fn default() -> Self {
        Self {
            mode_cutoff: 0.5,
            min_modes: 2,
            static_correction: true,
            tolerance: 1e-6,
            jacobian: JacobianInTime::Continuous,
            impact_width: 1.5,
            saltation: true,
            shooting: true,
            shooting_cutoff: 1.0,
            verify_every: 0,
        }
    }
}

impl FloquetSettings {
    /// Checks the ranges; the error names the parameter.
    pub fn validate(&self) -> Result<(), NnmError> {
        let m = self.mode_cutoff;
        require(
            "mode_cutoff",
            m,
            m.is_finite() && m > 0.0,
            "a finite multiple of (N + 1) w > 0",
        )?;
        at_least_one("min_modes", self.min_modes)?;
        let s = self.shooting_cutoff;
        require(
            "shooting_cutoff",
            s,
            s.is_finite() && s > 0.0,
            "a finite multiple of (N + 1) w > 0",
        )?;
        let w = self.impact_width;
        require(
            "impact_width",
            w,
            w.is_finite() && w >= 0.0,
            "a finite width >= 0 (units of T / N)",
        )?;
        let t = self.tolerance;
        require(
            "tolerance",
            t,
            t.is_finite() && t >= 0.0,
            "a finite tolerance >= 0",
        )?;
        Ok(())
    }
}

/// Multipliers outside the unit circle (|mu| > 1 + tolerance), by where they left it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct UnstableCounts {
    /// Real multipliers > 1 (left through +1: fold or branch point).
    pub real_positive: usize,
    /// Real multipliers < -1 (left through -1: period doubling).
    pub real_negative: usize,
    /// Complex multipliers (a complex quadruple: Neimark-Sacker, Krein collision). A multiplier is
    /// counted complex when its conjugate is also selected; a real pair keeps a small spurious
    /// imaginary part from the truncation (see docs/STABILITY.md).
    pub complex: usize,
}

/// Which computation gave the multipliers of a [`Stability`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StabilityMethod {
    /// Hill's method on the linear modes (module docs).
    Hill,
    /// Event-based monodromy: free linear flow between impacts, a saltation matrix at each.
    Saltation,
    /// The exact monodromy of the shot periodic orbit of the massless contact boundary.
    Shooting,
}

/// Largest trivial-pair error at which Hill's method gives a verdict. The trivial pair is
/// exactly 1 for the exact orbit; computed off by more than this, the moduli of the other
/// multipliers are uncertain by as much and a verdict would be a guess (issue 24: on the blade
/// 145 of 155 augmented-Lagrangian points had errors above 0.05, median 1.3).
pub const TRIVIAL_PAIR_LIMIT: f64 = 0.05;

/// Largest trivial-pair error at which the event-based monodromy gives a verdict. Its monodromy
/// is a product of exact free flows and exact saltation matrices evaluated on the
/// harmonic-balance orbit's data (impact instants, impulses, displacements), whose errors
/// O(1/N) perturb it by some delta. The trivial pair is a Jordan block at +1 (time shift and
/// change of period with energy), which a perturbation delta splits by about sqrt(delta), while
/// a simple multiplier moves by O(delta): the split eps says delta ~ eps^2. Past 0.3 (delta ~
/// 0.1) that first-order picture is no longer a bound. Measured on the exact impact oracles
/// (docs/STABILITY.md, "Verdicts"): the 2-DOF chain at N = 40 has eps = 0.03..0.15 with the
/// largest multiplier within 1.1e-2 of the exact one (eps^2 |mu| = 1.2e-2 there).
pub const SALTATION_TRIVIAL_LIMIT: f64 = 0.3;

/// Largest relative distance |w_shot - w| / w between the harmonic-balance orbit and the shot
/// orbit of the massless boundary at which the shot orbit's verdict is the point's. The two
/// orbits differ by the truncation to N harmonics and by the inertia of the discarded modes
/// (O(((N + 1) w / w_k)^2) of their quasi-static response); further apart, the shot orbit is
/// another member of the family (or of a tongue) and says nothing of this point.
pub const SHOOTING_SHIFT_LIMIT: f64 = 1e-2;

/// Largest share of a contact row's inverse mass c_j = a_j M^-1 a_j^T that the modes above the
/// event-based monodromy's cutoff (w_k > `mode_cutoff` (N + 1) w) may carry together for it to
/// apply (docs/STABILITY.md, Sec. 10). Those modes take their state at the impacts from their
/// exact response to the orbit's impulses; an impact hands them about 4 x this share of its
/// normal momentum exchange, which the N-harmonic orbit itself represents only quasi-statically.
/// Above it (a Craig-Bampton contact node, whose inverse mass sits mostly in modes far above
/// N w) the orbit's impact data are not those of the rigid-impact model, and the massless
/// contact boundary (Sec. 9) is the model.
pub const UNRESOLVED_SHARE_LIMIT: f64 = 1e-2;

/// Largest share of the normal acceleration at an impact that the modes above the orbit's
/// harmonics may carry for an event-based verdict (docs/STABILITY.md, Sec. 10). Their share goes
/// like share (w_k / w) |cot(w_k T / 2)|: small off their internal resonances w_k = m w, it
/// dominates the impact's timing term next to one, where the exact multipliers change by O(1)
/// within 0.1 % of w (1.02 to 6.9 on the weakly padded 3-DOF system) while the N-harmonic
/// orbit does not represent that mode's response at all.
pub const UNRESOLVED_ACCELERATION_LIMIT: f64 = 0.25;

/// A mode the event-based monodromy computes from its impulse response (above the orbit's
/// harmonics, weakly coupled): where its free pair exp(+-i angle) sits and how strongly the
/// impacts reach it. Its pair is on the unit circle unless the coupling moves it; the verdict
/// weighs the orbit's error on it by the coupling ([`verdict_word`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct UnresolvedPair {
    /// w_k T reduced to [0, 2 pi) (rad).
    pub angle: f64,
    /// Its largest share b_jk^2 / c_j of a contact row's inverse mass.
    pub share: f64,
}

/// What a point's verdict is read from: its [`Stability`], or the record of it in a results file.
#[derive(Clone, Copy, Debug)]
pub struct VerdictInputs<'a> {
    pub method: StabilityMethod,
    /// Every non-trivial multiplier within the unit circle (to the analysis tolerance).
    pub stable: bool,
    /// Largest |mu| over the non-trivial multipliers.
    pub max_multiplier_abs: f64,
    /// max |mu - 1| over the trivial pair.
    pub trivial_pair_error: f64,
    /// Every multiplier (re, im), the trivial pair included.
    pub multipliers: &'a [[f64; 2]],
    /// Indices of the trivial pair in `multipliers`.
    pub trivial: [usize; 2],
    /// |w_shot - w| / w for the shooting method (0 for the others).
    pub orbit_shift: f64,
    /// The RK4 check disagreed with the shooting monodromy (false where none was made).
    pub check_failed: bool,
    /// The event-based monodromy's modes above the orbit's harmonics (empty for the others).
    pub unresolved: &'a [UnresolvedPair],
    /// Their share of the normal acceleration at an impact (0 for the other methods).
    pub unresolved_acceleration: f64,
}

impl<'a> VerdictInputs<'a> {
    /// The inputs of a computed stability.
    pub fn of(s: &'a Stability) -> Self {
        Self {
            method: s.method,
            stable: s.stable,
            max_multiplier_abs: s.max_multiplier_abs,
            trivial_pair_error: s.trivial_pair_error,
            multipliers: &s.multipliers,
            trivial: s.trivial,
            orbit_shift: s.orbit_shift,
            check_failed: s.check.as_ref().is_some_and(|c| !c.agrees()),
            unresolved: &s.unresolved,
            unresolved_acceleration: s.unresolved_acceleration,
        }
    }
}

/// The word of a point's stability: `stable`, `unstable` or `undetermined` when the method's own
/// error estimate cannot back either (docs/STABILITY.md, "Verdicts").
///
/// * Hill's method: undetermined when the trivial-pair error passes [`TRIVIAL_PAIR_LIMIT`], or
///   when the point is flagged unstable by less than that error (|mu|_max - 1 <= error).
/// * Event-based monodromy: with eps the trivial-pair error and delta ~ eps^2 the perturbation
///   of the monodromy it reveals (see [`SALTATION_TRIVIAL_LIMIT`]): undetermined when eps passes
///   that limit; unstable when |mu|_max - 1 > 2 eps^2 |mu|_max; stable unless a non-trivial
///   multiplier lies within 2 eps of +1 or -1, where a collision (fold, period doubling) is
///   within the error ([`collision_radii`]: 2 eps sqrt(share) for the pair of a weakly coupled
///   unresolved mode); else undetermined.
/// * Every method: undetermined when the orbit whose multipliers these are lies more than
///   [`SHOOTING_SHIFT_LIMIT`] from the point (`orbit_shift`), when the modes above the orbit's
///   harmonics carry more than [`UNRESOLVED_ACCELERATION_LIMIT`] of an impact's normal
///   acceleration, or when an RK4 check disagreed.
pub fn verdict_word(v: &VerdictInputs<'_>) -> &'static str {
    let eps = v.trivial_pair_error;
    let limit = match v.method {
        StabilityMethod::Hill | StabilityMethod::Shooting => TRIVIAL_PAIR_LIMIT,
        StabilityMethod::Saltation => SALTATION_TRIVIAL_LIMIT,
    };
    let shift_ok = !(v.orbit_shift > SHOOTING_SHIFT_LIMIT || v.orbit_shift.is_nan());
    let unresolved_ok = !(v.unresolved_acceleration > UNRESOLVED_ACCELERATION_LIMIT
        || v.unresolved_acceleration.is_nan());
    if eps.is_nan() || eps > limit || !shift_ok || !unresolved_ok || v.check_failed {
        return "undetermined";
    }
    let margin = v.max_multiplier_abs - 1.0;
    let (decided, near_collision) = match v.method {
        StabilityMethod::Hill | StabilityMethod::Shooting => (margin > eps, false),
        StabilityMethod::Saltation => {
            let radii = collision_radii(v, eps);
            (
                margin > 2.0 * eps * eps * v.max_multiplier_abs,
                v.multipliers
                    .iter()
                    .zip(&radii)
                    .enumerate()
                    .filter(|(i, _)| !v.trivial.contains(i))
                    .any(|(_, (m, radius))| {
                        let d = |x: f64| (m[0] - x).hypot(m[1]);
                        d(1.0).min(d(-1.0)) < *radius
                    }),
            )
        }
    };
    match (v.stable, decided, near_collision) {
        (true, _, false) => "stable",
        (false, true, _) => "unstable",
        _ => "undetermined",
    }
}

/// The distance from +-1 within which a non-trivial multiplier of the event-based monodromy may
/// be a collision the orbit's error hides: 2 eps (a perturbation delta ~ eps^2 moves a pair
/// meeting at +-1 by sqrt(delta)). The orbit's error reaches the pair of a mode above its
/// harmonics only through that mode's coupling: its radius is 2 eps sqrt(share). The pair is
/// the two non-trivial multipliers nearest exp(+-i angle), taken only within 2 eps +
/// 4 sqrt(share) of it (the coupling moves a pair off a resonance by O(share); a multiplier
/// farther away is another mode's, which keeps 2 eps).
fn collision_radii(v: &VerdictInputs<'_>, eps: f64) -> Vec<f64> {
    let mut radii = vec![2.0 * eps; v.multipliers.len()];
    let mut taken: Vec<bool> = (0..v.multipliers.len())
        .map(|i| v.trivial.contains(&i))
        .collect();
    for pair in v.unresolved {
        let reach = 2.0 * eps + 4.0 * pair.share.sqrt();
        for sign in [1.0, -1.0] {
            let target = [pair.angle.cos(), sign * pair.angle.sin()];
            let nearest = (0..v.multipliers.len())
                .filter(|&i| !taken[i])
                .map(|i| {
                    let m = v.multipliers[i];
                    (i, (m[0] - target[0]).hypot(m[1] - target[1]))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((i, _)) = nearest.filter(|(_, d)| *d <= reach) {
                taken[i] = true;
                radii[i] = 2.0 * eps * pair.share.sqrt();
            }
        }
    }
    radii
}

/// The independent check of a shooting verdict: one period of RK4 of the massless-boundary
/// model from the shot orbit's start, with the contact problem solved afresh at every stage and
/// the variational equation integrated alongside (docs/STABILITY.md, Sec. 9).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ShootingCheck {
    /// RK4 steps over the period.
    pub steps: usize,
    /// Distance of the RK4 end state from the start in the scaled state (q / |q0|,
    /// q' / (w |q0|)): 0 for an exact periodic orbit and an exact integrator.
    pub periodicity: f64,
    /// Largest distance from a non-trivial multiplier of the RK4 monodromy to the nearest
    /// non-trivial exact one (the trivial pair, the two nearest +1, left out of both: a Jordan
    /// block that any perturbation delta splits by sqrt(delta)).
    pub multiplier_distance: f64,
    /// Largest |mu| of the RK4 monodromy's non-trivial multipliers (1 if none is outside).
    pub max_multiplier_abs: f64,
    /// |max_multiplier_abs - the exact monodromy's|: the difference in the decision quantity.
    pub max_multiplier_change: f64,
}

/// Largest [`ShootingCheck::max_multiplier_change`] (and periodicity) at which the RK4 check
/// confirms a shooting verdict. The check cuts its steps at the contact switches, so RK4 keeps
/// its fourth order with h s_max = 2 pi / 200: on the default blade its largest |mu| agrees with
/// the exact monodromy's to 6e-7 and its end state with the start to 2e-7 (50 points;
/// docs/STABILITY.md, Sec. 9). A disagreement past 1e-4 means the exact flow or the shot orbit
/// is wrong, and the verdict is not given.
pub const SHOOTING_CHECK_LIMIT: f64 = 1e-4;

impl ShootingCheck {
    /// The check confirms the exact monodromy: the shot orbit is periodic for RK4 and the
    /// largest non-trivial |mu| is the same within [`SHOOTING_CHECK_LIMIT`].
    pub fn agrees(&self) -> bool {
        self.max_multiplier_change <= SHOOTING_CHECK_LIMIT
            && self.periodicity <= SHOOTING_CHECK_LIMIT
    }
}

/// Floquet stability of one orbit (Hill's method or the event-based monodromy).
#[derive(Clone, Debug, Serialize)]
pub struct Stability {
    /// How the multipliers were computed.
    pub method: StabilityMethod,
    /// Impacts per period treated by saltation matrices (0 for Hill's method); contact switches
    /// per period of the shot orbit for the shooting method.
    pub impacts: usize,
    /// How far the orbit whose multipliers these are lies from the harmonic-balance orbit:
    /// |w_shot - w| / w for the shooting method (the massless boundary's shot periodic orbit);
    /// for the event-based monodromy, the largest relative error of the contact displacement at
    /// an impact that the orbit's series makes in the modes above its harmonics (0 when it
    /// resolves every coupled mode); 0 for Hill's method.
    pub orbit_shift: f64,
    /// w of the shot periodic orbit (rad/s; shooting method, 0 for the others): the converged
    /// reference of the harmonic refinement (docs/STABILITY.md Sec. 9.4).
    pub orbit_omega: f64,
    /// Shooting method: the share of the period each contact row of the shot orbit is closed,
    /// exact (from its switch instants); empty for the other methods.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub contact_shares: Vec<f64>,
    /// The RK4 check of a shooting verdict, where it was made (`verify_every`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub check: Option<ShootingCheck>,
    /// The 2 r multipliers mu = exp(s T) as (re, im), sorted by decreasing |mu|, then by
    /// increasing argument; the trivial pair included.
    pub multipliers: Vec<[f64; 2]>,
    /// The selected Floquet exponents s (1/s) as (re, im), in the order of `multipliers`.
    pub exponents: Vec<[f64; 2]>,
    /// Indices in `multipliers` of the trivial pair (the two closest to +1).
    pub trivial: [usize; 2],
    /// max |mu - 1| over the trivial pair: 0 for the exact smooth problem; the sampled contact
    /// law breaks the time-shift invariance of the orbit and moves it (see docs/STABILITY.md).
    pub trivial_pair_error: f64,
    /// Largest |mu| over the non-trivial multipliers (1 if there is none).
    pub max_multiplier_abs: f64,
    /// max_mu min_nu |nu - 1 / conj(mu)| / |mu|: how far the selected set is from closed under
    /// mu -> 1/conj(mu) (round-off, or a selection that split a quadruple).
    pub reciprocal_pair_error: f64,
    /// Every non-trivial multiplier has |mu| <= 1 + tolerance.
    pub stable: bool,
    /// Non-trivial multipliers outside the circle, by kind.
    pub unstable: UnstableCounts,
    /// Linear modes r kept in Hill's matrix (all n for the event-based monodromy).
    pub modes_kept: usize,
    /// Harmonics N of Hill's basis (those of the orbit).
    pub harmonics: usize,
    /// Linear modes left out as decoupled from every contact row (their pairs exp(+-i w_k T) on
    /// the unit circle; docs/STABILITY.md, Sec. 10).
    pub decoupled_modes: usize,
    /// Event-based monodromy: the modes above the orbit's harmonics, computed from their
    /// impulse response (empty for the other methods and when every coupled mode is resolved).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub unresolved: Vec<UnresolvedPair>,
    /// Event-based monodromy: the largest share of the normal acceleration at an impact carried
    /// by the modes above the orbit's harmonics (0 for the other methods; docs/STABILITY.md,
    /// Sec. 10).
    pub unresolved_acceleration: f64,
    /// Largest |mean harmonic| of a selected eigenvector (the centring of the selection criterion,
    /// see the module docs): 0 in the linear regime, 1/2 at a period doubling (0 for the
    /// event-based monodromy, which has no copies to select from).
    pub selection_mean_harmonic_max: f64,
    /// Smallest |mean harmonic| of a rejected eigenvector (about 1 in the linear regime; 1/2 for
    /// the discarded copies of a period-doubling quadruple; 0 for the event-based monodromy).
    pub rejection_mean_harmonic_min: f64,
}

/// Floquet stability of every point of `backbone` (docs/DESIGN.md §9), stored in
/// [`BackbonePoint::stability`], and [`BackbonePoint::bifurcation`] set where the stability
/// changed since the previous point of the same branch whose verdict is determined (a branch's
/// first point is compared with the point of its parent it leaves from); an `undetermined`
/// point ([`verdict_word`]) neither carries a bifurcation nor serves as the reference, so that
/// no change is read from a flag its method cannot back. The points are analysed in parallel (each alone:
/// the same numbers as one by one), then compared in order. `progress(done, total)` is called
/// after each point. A point whose analysis fails keeps `None` (logged); the others go on.
/// Returns how many failed.
pub fn analyze_backbone(
    system: &System,
    backbone: &mut Backbone,
    settings: &FloquetSettings,
    progress: impl Fn(usize, usize) + Sync,
) -> Result<usize, NnmError> {
    let analysis = FloquetAnalysis::new(system, settings.clone())?;
    let total = backbone.points.len();
    let done = AtomicUsize::new(0);
    let results: Vec<Result<Stability, NnmError>> = backbone
        .points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let verify = settings.verify_every > 0 && i % settings.verify_every == 0;
            let result = analysis.analyze_checked(p, verify);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            result
        })
        .collect();
    let mut last: Vec<Option<Stability>> = vec![None; backbone.branches.len().max(1)];
    let mut failed = 0;
    for (i, result) in results.into_iter().enumerate() {
        let branch = backbone.points[i].branch;
        if last[branch].is_none() {
            let parent = backbone.branches.get(branch).and_then(|b| b.parent);
            last[branch] = parent.and_then(|p| last[p].clone());
        }
        match result {
            Ok(s) => {
                let p = &mut backbone.points[i];
                if verdict_word(&VerdictInputs::of(&s)) != "undetermined" {
                    p.bifurcation = last[branch].as_ref().and_then(|prev| classify(prev, &s));
                    last[branch] = Some(s.clone());
                }
                p.stability = Some(s);
            }
            Err(e) => {
                failed += 1;
                tracing::warn!(
                    q_over_g0 = backbone.points[i].q / backbone.gap_reference,
                    error = %e,
                    "Floquet analysis failed"
                );
            }
        }
    }
    Ok(failed)
}

/// Hill stability of `point` on `system` (builds a [`FloquetAnalysis`]; reuse one for many points).
pub fn floquet(
    system: &System,
    point: &BackbonePoint,
    settings: &FloquetSettings,
) -> Result<Stability, NnmError> {
    FloquetAnalysis::new(system, settings.clone())?.analyze(point)
}

/// Sorts multipliers by decreasing modulus, then by increasing argument (moduli equal to 1e-12
/// relative count as ties: the moduli are compared on a logarithmic grid of that spacing, which
/// keeps the comparison a total order).
pub(crate) fn sort_multipliers(values: &mut [[f64; 2]]) {
    let key = |v: &[f64; 2]| (v[0].hypot(v[1]).ln() * 1e12).round();
    values.sort_by(|a, b| {
        key(b)
            .total_cmp(&key(a))
            .then(a[1].atan2(a[0]).total_cmp(&b[1].atan2(b[0])))
    });
}

#[cfg(test)]
mod verdict_tests {
    use super::*;

    fn word(
        method: StabilityMethod,
        stable: bool,
        mu: f64,
        eps: f64,
        others: &[[f64; 2]],
    ) -> &'static str {
        let mut multipliers = vec![[1.0 + eps, 0.0], [1.0 - eps, 0.0]];
        multipliers.extend_from_slice(others);
        verdict_word(&VerdictInputs {
            method,
            stable,
            max_multiplier_abs: mu,
            trivial_pair_error: eps,
            multipliers: &multipliers,
            trivial: [0, 1],
            orbit_shift: 0.0,
            check_failed: false,
            unresolved: &[],
            unresolved_acceleration: 0.0,
        })
    }

    #[test]
    fn a_hill_verdict_needs_a_trivial_pair_closer_to_one_than_the_decision() {
        let hill = |stable, mu, eps| word(StabilityMethod::Hill, stable, mu, eps, &[]);
        assert_eq!(hill(true, 1.0, 1e-8), "stable");
        assert_eq!(hill(false, 1.5, 1e-3), "unstable");
        // Unstable by less than the trivial pair's own error.
        assert_eq!(hill(false, 1.01, 0.02), "undetermined");
        // Past the limit, whatever the flag.
        assert_eq!(hill(true, 1.0, 0.2), "undetermined");
        assert_eq!(hill(false, 3.0, 0.2), "undetermined");
        assert_eq!(hill(true, 1.0, f64::NAN), "undetermined");
    }

    #[test]
    fn a_saltation_verdict_weighs_the_multipliers_by_the_square_of_the_trivial_split() {
        let s = StabilityMethod::Saltation;
        let on_circle = |deg: f64| {
            let t = deg.to_radians();
            [[t.cos(), t.sin()], [t.cos(), -t.sin()]]
        };
        // eps = 0.1: delta ~ 1e-2, |mu| = 1.22 is decided (margin 0.22 > 2.4e-2).
        assert_eq!(
            word(s, false, 1.22, 0.1, &[[1.22, 0.0], [1.0 / 1.22, 0.0]]),
            "unstable"
        );
        // Unstable by less than 2 eps^2 |mu|.
        assert_eq!(
            word(s, false, 1.01, 0.1, &[[1.01, 0.0], [1.0 / 1.01, 0.0]]),
            "undetermined"
        );
        // A pair on the circle far from +-1 is stable; within 2 eps of -1 it is not decided.
        assert_eq!(word(s, true, 1.0, 0.1, &on_circle(90.0)), "stable");
        assert_eq!(word(s, true, 1.0, 0.1, &on_circle(175.0)), "undetermined");
        assert_eq!(word(s, true, 1.0, 0.1, &on_circle(5.0)), "undetermined");
        // Past the limit of the method.
        assert_eq!(
            word(s, false, 3.0, 0.31, &[[3.0, 0.0], [1.0 / 3.0, 0.0]]),
            "undetermined"
        );
        // The same numbers under Hill's rule: past its limit.
        assert_eq!(
            word(StabilityMethod::Hill, true, 1.0, 0.1, &on_circle(90.0)),
            "undetermined"
        );
    }

    fn saltation_word(
        multipliers: &[[f64; 2]],
        unresolved: &[UnresolvedPair],
        acceleration: f64,
    ) -> &'static str {
        verdict_word(&VerdictInputs {
            method: StabilityMethod::Saltation,
            stable: true,
            max_multiplier_abs: 1.0,
            trivial_pair_error: 0.1,
            multipliers,
            trivial: [0, 1],
            orbit_shift: 0.0,
            check_failed: false,
            unresolved,
            unresolved_acceleration: acceleration,
        })
    }

    #[test]
    fn a_weakly_coupled_pair_near_one_is_weighed_by_its_coupling() {
        // A pair 0.1 from +1, eps = 0.1: a collision within the error for a resolved pair.
        let t: f64 = 0.1;
        let multipliers = [
            [1.1, 0.0],
            [1.0 / 1.1, 0.0],
            [t.cos(), t.sin()],
            [t.cos(), -t.sin()],
        ];
        assert_eq!(saltation_word(&multipliers, &[], 0.0), "undetermined");
        // The pair of a mode holding 1e-3 of the row's inverse mass: radius 2 eps sqrt(1e-3).
        let weak = [UnresolvedPair {
            angle: 0.11,
            share: 1e-3,
        }];
        assert_eq!(saltation_word(&multipliers, &weak, 0.0), "stable");
        // Too far from the mode's free pair (0.9 rad): not that mode's, radius 2 eps.
        let far = [UnresolvedPair {
            angle: 1.0,
            share: 1e-3,
        }];
        assert_eq!(saltation_word(&multipliers, &far, 0.0), "undetermined");
        // Next to an internal resonance of that mode: its acceleration share above the limit.
        assert_eq!(saltation_word(&multipliers, &weak, 0.3), "undetermined");
    }
}
