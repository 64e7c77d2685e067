//! The Floquet stability of every point of a response curve (docs/STABILITY.md Secs. 8-9), in
//! parallel, then the changes of stability between determined points of one piece
//! (`point_stability` holds the per-point verdict).

use crate::curve::{FrequencyResponse, FrfSettings};
use crate::error::ForcedError;
use crate::ladder::HarmonicLadder;
use nlmodes_hb::floquet::Verdict;

use crate::point_stability::PointStability;

/// Floquet stability of the points not assessed yet (when asked for): each point's period
/// check and monodromy in parallel (they depend on the point alone, so the result is the
/// same in any order), then the changes of stability in order.
pub(crate) fn assess_stability(
    ladder: &HarmonicLadder<'_, '_>,
    settings: &FrfSettings,
    curve: &mut FrequencyResponse,
) -> Result<(), ForcedError> {
    use rayon::prelude::*;
    if !settings.stability {
        return Ok(());
    }
    let from = curve.stability.len();
    let assessed: Vec<Result<PointStability, ForcedError>> = curve.points[from..]
        .par_iter()
        .map(|point| {
            let solver = ladder.solver_of(point);
            let touching = point.touches();
            if touching {
                if let Some(b) = solver.boundary_monodromy(point, false)? {
                    return Ok(PointStability::on_boundary(&b, settings.stability_margin));
                }
            }
            let residual = solver.period_residual(point);
            let mut st = if residual.is_some_and(|r| r > settings.period_tolerance) {
                // Not a periodic solution of the equation the monodromy linearizes. Under a
                // penalty law on a model whose modes are all resolved, the exact periodic
                // orbit of that equation next to the point answers (its verdict, unless
                // farther than the shift limit); otherwise no verdict to compute.
                let exact = if touching && solver.every_mode_resolved(point.omega) {
                    solver.boundary_monodromy(point, true)?
                } else {
                    None
                };
                exact.map_or_else(PointStability::unchecked, |b| {
                    PointStability::on_boundary(&b, settings.stability_margin)
                })
            } else {
                let mono = solver.monodromy(point)?;
                PointStability::of(&mono, settings.stability_margin)
            };
            st.period_residual = residual;
            Ok(st)
        })
        .collect();
    for st in assessed {
        let mut st = st?;
        // A change of stability is between points of one piece.
        let piece = curve
            .pieces
            .iter()
            .copied()
            .filter(|&k| k <= curve.stability.len())
            .max()
            .unwrap_or(0);
        let determined = curve.stability[piece..]
            .iter()
            .rev()
            .find(|p| p.verdict != Verdict::Undetermined);
        if let Some(prev) = determined {
            st.classify(prev);
        }
        curve.stability.push(st);
    }
    Ok(())
}
