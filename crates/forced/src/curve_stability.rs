//! The Floquet stability of every point of a response curve (docs/STABILITY.md Secs. 8-9), in
//! parallel, then the changes of stability between determined points of one piece
//! (`point_stability` holds the per-point verdict).

use crate::curve::{FrequencyResponse, FrfSettings};
use crate::error::ForcedError;
use crate::ladder::HarmonicLadder;
use nlmodes_hb::floquet::Verdict;

use crate::point_stability::{Assessment, PointStability};
use crate::settled_stability::assess_point_settled;

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
            let how = Assessment {
                margin: settings.stability_margin,
                period_tolerance: settings.period_tolerance,
                verify: false,
            };
            assess_point_settled(ladder.solver_of(point), point, &how)
        })
        .collect();
    for (k, st) in assessed.into_iter().enumerate() {
        // A point whose analysis fails (a decomposition that no check trusts) is undetermined,
        // as on a speed sweep: the curve it belongs to stands.
        let mut st = st.unwrap_or_else(|e| {
            let omega = curve.points[from + k].omega;
            tracing::warn!("forced response: no stability at W = {omega:.6e} rad/s: {e}");
            PointStability::unchecked()
        });
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
