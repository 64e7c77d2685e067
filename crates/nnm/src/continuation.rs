//! The backbone family of one linear mode (docs/DESIGN.md §8): the linear segment up to grazing,
//! the nonlinear main branch from the grazing orbit, and the internal-resonance tongues it meets.
//!
//! * Below grazing the orbit is the linear mode scaled to q, w = w_lin exactly: those points are
//!   solved at fixed q up to the grazing amplitude q_g = g0 phi_master / max_j |A_j phi| (Sec. 2.6
//!   normalization), whose orbit touches the obstacle at one instant.
//! * The nonlinear branch starts at that grazing orbit. Its first predictor moves along the
//!   frequency axis only (the branch leaves grazing with w rising while q may first decrease: a
//!   fold just after grazing on chains with a stop), so no corner of the (q, w) curve is cut.
//! * Then pseudo-arc-length continuation ([`crate::continuation`] internals in `trace`) in the
//!   scaled space X = (q / g_ref, w / w_lin, y / (g_ref sqrt(c + 1))), y the kept coordinates of
//!   every harmonic (contact coefficients A_j u_n and master coefficients e . u_n): the predictor
//!   steps along the secant of the branch, the corrector solves Algorithm 1 with the parameter row
//!   t . (X - X_pred) = 0 in place of q = const, so q is an unknown and folds of q are followed and
//!   flagged (sign change of dq/ds). A corrector that lands far from its predictor (more than
//!   `jump_factor` times the step) is rejected and the step shrunk: the branch is not allowed to
//!   hop to another one, whatever the step size.
//! * A point whose energy has moved into another linear mode k at a harmonic n >= 2 (its modal
//!   share above the primary one) has entered an internal-resonance tongue (n w near w_k): the
//!   tongue is followed as its own branch (up to `tongue_points` points), then the main branch is
//!   continued past the resonance by a predictor on its own tangent beyond the tongue.
//!
//! Adaptive step: grow after an easy point, shrink after a failure or a rejected corrector.

use serde::{Deserialize, Serialize};

use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_hb::check::positive;

/// Continuation settings. Amplitudes are in units of the reference gap g_ref (the mean initial
/// gap, [`crate::System::gap_reference`]); steps are arc lengths in the scaled plane (q / g_ref, w / w_lin).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContinuationSettings {
    /// Linear mode the backbone starts from (0-based, default 0).
    pub mode: usize,
    /// Several linear modes traced one after the other (0-based, e.g. [0, 1, 2]); empty (the
    /// default): `mode` only. Read by the `nlmodes` CLI, which gives each mode its own results
    /// folder; [`crate::backbone`] traces `mode`.
    pub modes: Vec<usize>,
    /// First amplitude q / g_ref (default 0.5; choose it below grazing to start on the exact
    /// linear solution).
    pub q_start: f64,
    /// Last amplitude q / g_ref (default 35, the study of `cases/blade.toml`).
    pub q_max: f64,
    /// Initial arc-length step (default 0.25).
    pub step: f64,
    /// Smallest step before giving up (default 1e-4).
    pub min_step: f64,
    /// Largest step (default 1).
    pub max_step: f64,
    /// Maximum number of points (default 1000).
    pub max_points: usize,
    /// Step growth factor after an easy point (default 1.5).
    pub growth: f64,
    /// Step reduction factor after a failure (default 0.5).
    pub shrink: f64,
    /// A point is easy when it took at most this many Newton iterations in total (default 8).
    pub easy_iterations: usize,
    /// Step control (docs/DESIGN.md §8.2): a corrector that lands farther than this times the
    /// step from the predictor is rejected and the step shrunk (default 1, a turn of 45 degrees
    /// per step); at `min_step` it is accepted (a corner of the sampled branch, where a sample
    /// changes contact state), flagged as a jump, and the step restarts from `step`.
    pub jump_factor: f64,
    /// First arc-length step of the nonlinear branch from the grazing orbit (default 0.01): the
    /// first predictor moves along the frequency axis only (w / w_lin + step), where the branch
    /// leaves grazing; later steps follow the secant and grow (docs/DESIGN.md §8.1).
    pub grazing_step: f64,
    /// Do not follow internal-resonance tongues (default false). A point whose largest secondary
    /// component (linear mode k, harmonic n >= 2) holds more energy than the primary one
    /// (starting mode, n = 1) has entered a tongue where energy flows into mode k at a frequency
    /// locked near w_k / n, if n w is within `resonance_tolerance` of w_k or q has just turned
    /// back (docs/DESIGN.md §8.3). By default the tongue is followed as its own branch (at most
    /// `tongue_points` points) and the main branch is then continued past it by a predictor on
    /// its tangent beyond the resonance; with `true` the tongue is only recorded in
    /// [`Backbone::internal_resonances`] and the main branch continued past it.
    pub skip_internal_resonances: bool,
    /// Points computed along each tongue branch before it is left (default 20).
    pub tongue_points: usize,
    /// Follow every fold of q on the main branch as part of it (default false). By default a
    /// fold from rising to falling q on the main branch is read as the entry into an internal-
    /// resonance tongue (the energy shares may show it only later) and handled as one. With
    /// `true`, tongues further than `resonance_tolerance` from their linear resonance are not
    /// detected at all (they are entered by a fold).
    pub skip_folds: bool,
    /// Largest detuning |n w - w_k| / w_k (linear w_k) at which a shift of energy into mode k at
    /// harmonic n >= 2 alone, with q still rising, is read as the entry into a tongue (default
    /// 0.05). Further from the resonance the orbit distorts without resonating and the branch
    /// goes on: on the 3-DOF chain of `tests/passage_guard.rs` mode 3 at harmonic 2 outweighs the
    /// fundamental from w/w1 = 1.53, 12.6 % below w3, on the exact one-impact branch. With a fold
    /// of q the detuning is not limited: the other mode's own frequency moves with its contact
    /// (the blade's 3:1 tongue with mode 2 at q/g0 = 21.9 is 12.3 % above the linear w2).
    pub resonance_tolerance: f64,
}

impl Default for ContinuationSettings {
    fn default() -> Self {
        Self {
            mode: 0,
            modes: Vec::new(),
            q_start: 0.5,
            q_max: 35.0,
            step: 0.25,
            min_step: 1e-4,
            max_step: 1.0,
            max_points: 1000,
            growth: 1.5,
            shrink: 0.5,
            easy_iterations: 8,
            jump_factor: 1.0,
            grazing_step: 0.01,
            skip_internal_resonances: false,
            tongue_points: 20,
            skip_folds: false,
            resonance_tolerance: 0.05,
        }
    }
}

impl ContinuationSettings {
    /// Checks the ranges; the error names the parameter.
    pub fn validate(&self) -> Result<(), NnmError> {
        let pos = positive;
        pos("q_start", self.q_start)?;
        pos("q_max", self.q_max)?;
        pos("step", self.step)?;
        pos("min_step", self.min_step)?;
        pos("max_step", self.max_step)?;
        pos("jump_factor", self.jump_factor)?;
        pos("grazing_step", self.grazing_step)?;
        pos("resonance_tolerance", self.resonance_tolerance)?;
        if self.q_max <= self.q_start {
            return Err(NnmError::InvalidParameter {
                name: "q_max",
                value: self.q_max,
                expected: "a value > q_start",
            });
        }
        if !(self.min_step <= self.step && self.step <= self.max_step) {
            return Err(NnmError::InvalidParameter {
                name: "step",
                value: self.step,
                expected: "min_step <= step <= max_step",
            });
        }
        if !(self.growth.is_finite() && self.growth >= 1.0) {
            return Err(NnmError::InvalidParameter {
                name: "growth",
                value: self.growth,
                expected: "a finite value >= 1",
            });
        }
        if !(self.shrink > 0.0 && self.shrink < 1.0) {
            return Err(NnmError::InvalidParameter {
                name: "shrink",
                value: self.shrink,
                expected: "0 < shrink < 1",
            });
        }
        if self.max_points == 0 {
            return Err(NnmError::InvalidParameter {
                name: "max_points",
                value: 0.0,
                expected: ">= 1",
            });
        }
        if let Some(twice) = (1..self.modes.len()).find_map(|i| {
            self.modes[..i]
                .contains(&self.modes[i])
                .then_some(self.modes[i])
        }) {
            return Err(NnmError::InvalidParameter {
                name: "modes",
                value: twice as f64,
                expected: "each mode listed once (0-based linear mode indices)",
            });
        }
        Ok(())
    }
}

/// Why a backbone run stopped.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Termination {
    /// The last point is at q_max.
    ReachedMaxAmplitude,
    /// `max_points` points were computed.
    MaxPoints,
    /// The step fell below `min_step`; `reason` is the last solver error.
    StepTooSmall {
        /// Master amplitude of the last converged point.
        q: f64,
        /// Step that failed.
        step: f64,
        /// Last error.
        reason: String,
    },
    /// The branch turned back and reached q <= 0 (the normalization degenerates).
    AmplitudeNotPositive,
    /// The continuation stopped moving: consecutive points identical to round-off (for example a
    /// gap so small that no step changes the scaled state).
    NoProgress {
        /// Master amplitude of the last point.
        q: f64,
    },
    /// The branch entered an internal-resonance tongue and no predictor past it converged.
    InternalResonance {
        /// Master amplitude of the last point before the tongue.
        q: f64,
        /// The resonating linear mode (0-based).
        mode: usize,
        /// The harmonic close to it.
        harmonic: usize,
    },
    /// The first point could not be computed.
    StartFailed {
        /// The error.
        reason: String,
    },
}

/// A computed backbone.
#[derive(Clone, Debug, Serialize)]
pub struct Backbone {
    /// Points in continuation order (not necessarily increasing in q after a fold).
    pub points: Vec<BackbonePoint>,
    /// Why the run stopped.
    pub termination: Termination,
    /// Linear frequency of the starting mode (rad/s).
    pub omega_linear: f64,
    /// Reference gap g_ref used for the amplitude scaling.
    pub gap_reference: f64,
    /// Master amplitude where the linear mode first touches (None if no contact row moves).
    pub grazing_amplitude: Option<f64>,
    /// Amplitude levels that could not be solved (amplitude sweep only), with the error.
    pub skipped: Vec<SkippedLevel>,
    /// Internal-resonance tongues met by [`crate::backbone`].
    pub internal_resonances: Vec<InternalResonance>,
    /// The branches the points belong to ([`BackbonePoint::branch`] indexes this list): the
    /// linear segment, the main nonlinear branch, and one per tongue followed.
    pub branches: Vec<Branch>,
}

impl Backbone {
    /// A backbone with no point yet: `termination` until the run says otherwise, the linear
    /// frequency `omega_linear`, the gap reference and the grazing amplitude of the mode.
    pub(crate) fn empty(
        termination: Termination,
        omega_linear: f64,
        gap_reference: f64,
        grazing_amplitude: Option<f64>,
    ) -> Self {
        Self {
            points: Vec::new(),
            termination,
            omega_linear,
            gap_reference,
            grazing_amplitude,
            skipped: Vec::new(),
            internal_resonances: Vec::new(),
            branches: Vec::new(),
        }
    }
}

/// What a branch of [`Backbone::branches`] is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BranchKind {
    /// The linear mode below grazing (w = w_lin exactly), up to and including the grazing orbit.
    Linear,
    /// The nonlinear mode's main branch, from grazing (or from `q_start` when that is above
    /// grazing or the mode never touches).
    Main,
    /// An internal-resonance tongue leaving the main branch, where harmonic `harmonic` of the
    /// orbit is near linear mode `mode` (0-based).
    Tongue {
        /// The resonating linear mode (0-based).
        mode: usize,
        /// The harmonic n with n w near its frequency.
        harmonic: usize,
    },
}

/// One branch of a backbone family.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Branch {
    /// Index in [`Backbone::branches`].
    pub id: usize,
    /// The branch it leaves from (None for the first one).
    pub parent: Option<usize>,
    /// What it is.
    pub kind: BranchKind,
    /// Why it ended (a short phrase: "grazing", "q_max reached", "tongue point limit", ...).
    pub end: String,
}

/// How the main branch got past an internal-resonance tongue (docs/DESIGN.md §8.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Passage {
    /// Branch switching: a predictor on the main branch's secant beyond the tongue, corrected on
    /// the arc-length row, then the branch filled back toward the tongue.
    Predictor,
    /// Last resort: a solve at fixed q ahead of the tongue (the point is flagged as a jump).
    FixedQHop,
}

/// An internal resonance met by the continuation: the branch turned into a tongue where linear
/// mode `mode` at harmonic `harmonic` took over the orbit (`harmonic` x w close to w_mode).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InternalResonance {
    /// Master amplitude of the tongue point (length unit of the system).
    pub q: f64,
    /// w / w_lin at the tongue point.
    pub omega_ratio: f64,
    /// The resonating linear mode (0-based).
    pub mode: usize,
    /// The harmonic n with n w close to its frequency.
    pub harmonic: usize,
    /// Its share of the orbit's energy.
    pub share: f64,
    /// Relative detuning (n w - w_k) / w_k from the linear frequency of the mode (contact stiffens
    /// the modes, so the tongue may sit a few percent away from it).
    pub detuning: f64,
    /// How the main branch was continued past the tongue (None: it was not).
    pub passed: Option<Passage>,
    /// When the two pieces of the main branch around the tongue do not meet, the q interval
    /// between them: the last point before the tongue and the lowest point of the piece past it
    /// (length unit of the system). None when they meet, or when the passage was not by a
    /// predictor.
    #[serde(default)]
    pub unjoined: Option<[f64; 2]>,
    /// Why the fill-back from the piece past the tongue stopped short of the piece before it
    /// ("it enters the tongue", "it turns in q", ...), with `unjoined`.
    #[serde(default)]
    pub fill_back_stop: Option<String>,
    /// The branch id of the tongue when it was followed ([`Backbone::branches`]).
    pub branch: Option<usize>,
}

/// An amplitude level of `testing::amplitude_sweep` that did not converge.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SkippedLevel {
    /// Master amplitude q (length unit of the system).
    pub q: f64,
    /// The solver error.
    pub reason: String,
}

impl ContinuationSettings {
    /// The modes a case traces: `modes`, or `mode` when `modes` is empty.
    pub fn modes_to_trace(&self) -> Vec<usize> {
        if self.modes.is_empty() {
            vec![self.mode]
        } else {
            self.modes.clone()
        }
    }

    /// The internal resonance a point sits in, if its largest secondary component (mode k,
    /// harmonic n >= 2) outweighs the primary one (starting mode, n = 1): the orbit is then no
    /// longer the primary mode's. `omegas`: linear circular frequencies, for the detuning
    /// (n w - w_k) / w_k recorded with it.
    pub(crate) fn tongue(&self, p: &BackbonePoint, omegas: &[f64]) -> Option<InternalResonance> {
        let (k, n) = (p.secondary_mode, p.secondary_harmonic);
        if n < 2 || p.secondary_share <= p.primary_share {
            return None;
        }
        let wk = *omegas.get(k)?;
        Some(InternalResonance {
            q: p.q,
            omega_ratio: p.omega_ratio,
            mode: k,
            harmonic: n,
            share: p.secondary_share,
            detuning: (n as f64 * p.omega - wk) / wk,
            passed: None,
            unjoined: None,
            fill_back_stop: None,
            branch: None,
        })
    }
}
