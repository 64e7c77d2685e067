//! A-posteriori estimate of the harmonic-truncation error of a converged point (issue 12,
//! docs/DESIGN.md §8.5): the same point re-solved at the same master amplitude q with twice the
//! harmonics (2N) and at least twice the samples, warm-started from the point itself, and the
//! relative change of w and the change of the contact share reported. The N-harmonic point is
//! trusted where both changes are below a stated tolerance (`truncation_tolerance`, 1e-3 by
//! default in the case file); unlike the former "highest harmonic share" indicator this measures
//! the quantity a user reads (the frequency), so it is calibrated by construction.

use serde::Serialize;

use crate::point::BackbonePoint;
use crate::solver::{Solver, Start};
use crate::NnmError;
use nlmodes_hb::fourier::HarmonicSettings;
use nlmodes_hb::solver_settings::SolverSettings;
use nlmodes_hb::system::System;

/// Largest change of the primary modal share for the 2N solve to count as the same orbit.
const SAME_ORBIT_SHARE: f64 = 0.05;

/// The change of a point when its harmonics are doubled.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TruncationEstimate {
    /// Harmonics of the reference solve (2N).
    pub harmonics: usize,
    /// Samples of the reference solve.
    pub samples: usize,
    /// |w(2N) - w(N)| / w(N).
    pub omega_change: f64,
    /// max over contact rows of |share(2N) - share(N)|, shares being the fractions of the period
    /// in contact (dimensionless, 0..1).
    pub contact_share_change: f64,
    /// 1 / m of the N-harmonic solve: a contact share can only be resolved to that.
    pub share_resolution: f64,
    /// Whether the 2N solve found the same orbit: its primary modal share (starting mode at
    /// harmonic 1) within 0.05 of the point's. Where several orbits share the same q (near
    /// internal resonances, which more harmonics can reach) the 2N solve may land on another one;
    /// the changes are then no estimate of the truncation error.
    pub same_orbit: bool,
}

impl TruncationEstimate {
    /// Whether both changes are within `tolerance` (relative for w; absolute for the share, which
    /// is resolved only to 1/m: a change of up to two samples is accepted there).
    pub fn within(&self, tolerance: f64) -> bool {
        self.omega_change <= tolerance
            && self.contact_share_change <= tolerance.max(2.0 * self.share_resolution)
    }
}

/// Re-solves `point` (computed with `settings`) with 2N harmonics and max(2m, 8N) samples at the
/// same q, and returns the changes. Errors when the reference solve does not converge.
pub fn truncation_estimate(
    system: &System,
    settings: HarmonicSettings,
    params: &SolverSettings,
    point: &BackbonePoint,
) -> Result<TruncationEstimate, NnmError> {
    let harmonics = 2 * settings.harmonics;
    let samples = (2 * settings.samples).max(8 * settings.harmonics);
    let fine = HarmonicSettings::new(harmonics, samples)?;
    let reference =
        Solver::new(system, fine, params.clone())?.solve_point(point.q, Start::Point(point))?;
    let contact_share_change = point
        .contact_fraction
        .iter()
        .zip(&reference.contact_fraction)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    Ok(TruncationEstimate {
        harmonics,
        samples,
        omega_change: (reference.omega - point.omega).abs() / point.omega,
        contact_share_change,
        share_resolution: 1.0 / settings.samples as f64,
        same_orbit: (reference.primary_share - point.primary_share).abs() <= SAME_ORBIT_SHARE,
    })
}
