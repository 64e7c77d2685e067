//! The event-based monodromy of a backbone point (docs/STABILITY.md, Sec. 3.1 and 10): when it
//! applies, the modes it takes from the orbit and from their impulse response, its trivial pair
//! and the data of its verdict. The monodromy itself is `saltation::ModalFlow`'s.

use faer::c64;

use super::hill::stability_with_trivial;
use super::saltation::{reduced_multipliers, unresolved_impacts, Impact, ModalFlow};
use super::{FloquetAnalysis, Stability, StabilityMethod, UnresolvedPair, UNRESOLVED_SHARE_LIMIT};
use crate::point::BackbonePoint;
use crate::NnmError;

impl FloquetAnalysis<'_> {
    /// The event-based monodromy (`saltation` module) when it applies, `None` otherwise.
    ///
    /// The modes the orbit's N harmonics resolve (w_k <= `mode_cutoff` (N + 1) w) take their
    /// state at the impacts from the orbit; the modes above it from their exact periodic response
    /// to the orbit's impulses, and only when they are weakly coupled: together they carry at
    /// most [`UNRESOLVED_SHARE_LIMIT`] of every contact row's inverse mass. Otherwise the impacts
    /// drive modes whose share of the impact the orbit misrepresents, and its data are far from a
    /// periodic orbit of the rigid-impact model (coarse blade, every mode dynamic: trivial pair
    /// error 36 and 73, max |mu| 50 and 93; docs/STABILITY.md, Sec. 3.1 and 10).
    pub(super) fn analyze_by_saltation(
        &self,
        point: &BackbonePoint,
        harmonics: usize,
    ) -> Result<Option<Stability>, NnmError> {
        let limit = self.settings().mode_cutoff * (harmonics as f64 + 1.0) * point.omega;
        let resolved = self.modes().omega.iter().filter(|&&w| w <= limit).count();
        let shares = self.modes().inverse_mass_shares();
        let unresolved_share =
            |k: usize| (0..shares.nrows()).fold(0.0_f64, |a, j| a.max(shares[(j, k)]));
        let row_share = |j: usize| {
            (resolved..shares.ncols())
                .map(|k| shares[(j, k)])
                .sum::<f64>()
        };
        if !self.settings().saltation
            || self.settings().impact_width <= 0.0
            || resolved == 0
            || (0..shares.nrows()).any(|j| row_share(j) > UNRESOLVED_SHARE_LIMIT)
        {
            return Ok(None);
        }
        let width = self.settings().impact_width * point.period() / harmonics as f64;
        let Some(impacts) = unresolved_impacts(point, width) else {
            return Ok(None);
        };
        let flow = ModalFlow {
            omega: &self.modes().omega,
            contact_modal: self.modes().contact_modal.as_ref(),
            projection: self.modes().projection.as_ref(),
            resolved,
        };
        let Some(monodromy) = flow.monodromy(point, &impacts) else {
            return Ok(None);
        };
        let flow_direction = flow.flow_direction(point, &impacts);
        let n = self.modes().omega.len();
        if (0..2 * n).any(|i| (0..2 * n).any(|j| !monodromy[(i, j)].is_finite()))
            || flow_direction.iter().any(|v| !v.is_finite())
        {
            tracing::debug!(w = point.omega, "event-based monodromy not finite");
            return Ok(None);
        }
        let (nontrivial, mut trivial) = reduced_multipliers(&monodromy, &flow_direction)?;
        if resolved < n {
            trivial = self.resolved_trivial_pair(point, &impacts, resolved)?;
        }
        let period = point.period();
        let exponent = |mu: &c64| c64::new(mu.norm().ln() / period, mu.arg() / period);
        let exponents: Vec<c64> = trivial.iter().chain(&nontrivial).map(exponent).collect();
        let mut out =
            stability_with_trivial(&exponents, Some([0, 1]), period, self.settings().tolerance);
        out.method = StabilityMethod::Saltation;
        // No eigenvector selection: both margins 0 (outputs must be finite).
        out.selection_mean_harmonic_max = 0.0;
        out.rejection_mean_harmonic_min = 0.0;
        out.modes_kept = n;
        out.harmonics = harmonics;
        out.impacts = impacts.len();
        out.orbit_shift = flow.unresolved_gap_error(point, &impacts, self.system().gaps());
        out.unresolved_acceleration = flow.unresolved_acceleration_share(point, &impacts);
        out.unresolved = (resolved..n)
            .map(|k| UnresolvedPair {
                angle: (self.modes().omega[k] * period).rem_euclid(2.0 * std::f64::consts::PI),
                share: unresolved_share(k),
            })
            .collect();
        Ok(Some(out))
    }

    /// The trivial pair of the event-based monodromy of the modes 0..resolved alone (same data).
    /// With modes above the orbit's harmonics in the monodromy, the flow direction f carries their
    /// fast motion (-w_k^2 eta_k), and the compression of the monodromy onto span(f, J^T f) that
    /// gives the trivial pair picks up their rotation over the period: its split grows with it
    /// (0.08-0.71 on the weakly padded chain) although the data's inconsistency,
    /// |phi f - f| / |f| in the energy norm, is the same to 4 digits with and without them
    /// (docs/STABILITY.md, Sec. 10). The resolved modes' split measures that inconsistency as for
    /// a model with every mode resolved.
    fn resolved_trivial_pair(
        &self,
        point: &BackbonePoint,
        impacts: &[Impact],
        resolved: usize,
    ) -> Result<[c64; 2], NnmError> {
        let flow = ModalFlow {
            omega: &self.modes().omega[..resolved],
            contact_modal: self.modes().contact_modal.subcols(0, resolved),
            projection: self.modes().projection.subrows(0, resolved),
            resolved,
        };
        let nan = c64::new(f64::NAN, f64::NAN);
        let Some(monodromy) = flow.monodromy(point, impacts) else {
            return Ok([nan, nan]);
        };
        let direction = flow.flow_direction(point, impacts);
        Ok(reduced_multipliers(&monodromy, &direction)?.1)
    }
}
