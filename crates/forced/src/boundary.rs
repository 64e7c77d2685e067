//! The forced problem on the massless contact boundary (docs/STABILITY.md Sec. 9; DESIGN §10.6):
//! what its model is built from ([`BoundaryInputs`]: the system, the damping, the load at a
//! level, the contact law) handed to `nlmodes_boundary`, whose shot orbit gives a point's
//! multipliers ([`boundary_monodromy`]) and whose continuation gives the exact response curve
//! ([`boundary_curve`]).

use faer::{Mat, MatRef};

use crate::distortion::CasingDistortion;
use crate::load::Load;
use nlmodes_boundary::{BoundaryCurve, DrivenInputs, LoadHarmonic};
use nlmodes_hb::system::System;
use nlmodes_hb::HbError;

pub use nlmodes_boundary::{BoundaryMonodromy, BOUNDARY_CUTOFF, BOUNDARY_SHIFT_LIMIT};

/// What the boundary model is built from.
pub struct BoundaryInputs<'a> {
    pub system: &'a System,
    /// C (n x n).
    pub damping: MatRef<'a, f64>,
    /// The load at the point's level.
    pub load: &'a Load,
    /// kc of a penalty law (N/m), `None` for exact contact.
    pub penalty: Option<f64>,
    /// Harmonics N of the orbit.
    pub harmonics: usize,
    /// Whether a penalty model whose modes are all below the cutoff is kept whole (the penalty
    /// equation itself, solved exactly); otherwise the boundary needs a discarded mode.
    pub keep_all: bool,
}

impl BoundaryInputs<'_> {
    /// The same inputs in `nlmodes_boundary`'s terms.
    pub(crate) fn driven(&self) -> DrivenInputs<'_> {
        DrivenInputs {
            system: self.system,
            damping: self.damping,
            load: self
                .load
                .harmonics
                .iter()
                .map(|h| LoadHarmonic {
                    harmonic: h.harmonic,
                    cos: &h.cos,
                    sin: &h.sin,
                })
                .collect(),
            penalty: self.penalty,
            harmonics: self.harmonics,
            keep_all: self.keep_all,
            gap_motion: Vec::new(),
        }
    }
}

/// The multipliers of the forced orbit `coefficients` (n x (2N + 1)) at W = `omega` (rad/s) on
/// the massless boundary (`nlmodes_boundary::boundary_monodromy`), or `None` where that model
/// does not apply or shooting does not converge.
pub fn boundary_monodromy(
    inputs: &BoundaryInputs<'_>,
    coefficients: &Mat<f64>,
    omega: f64,
) -> Result<Option<BoundaryMonodromy>, HbError> {
    nlmodes_boundary::boundary_monodromy(&inputs.driven(), coefficients, omega)
}

/// [`boundary_monodromy`] under a casing distortion: every row's gap g0_j - delta cos(h W t +
/// phi) (DESIGN §10.11; docs/STABILITY.md Sec. 9.5), the intrusion a harmonic of the boundary's
/// drive.
pub fn moving_gap_monodromy(
    inputs: &BoundaryInputs<'_>,
    distortion: &CasingDistortion,
    coefficients: &Mat<f64>,
    omega: f64,
) -> Result<Option<BoundaryMonodromy>, HbError> {
    let mut driven = inputs.driven();
    driven.gap_motion = vec![distortion.gap_harmonic(inputs.system.n_contacts())];
    nlmodes_boundary::boundary_monodromy(&driven, coefficients, omega)
}

/// The exact response curve of the level of `inputs` on the massless boundary
/// (`nlmodes_boundary::boundary_curve`) from the first of the harmonic-balance orbits `orbits`
/// ((coefficients, W in rad/s)) to W = `end` (rad/s); `margin` as
/// `FrfSettings::stability_margin`.
pub fn boundary_curve(
    inputs: &BoundaryInputs<'_>,
    orbits: &[(&Mat<f64>, f64)],
    end: f64,
    margin: f64,
) -> Result<Option<BoundaryCurve>, HbError> {
    nlmodes_boundary::boundary_curve(&inputs.driven(), orbits, end, margin)
}
