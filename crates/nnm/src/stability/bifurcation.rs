//! Bifurcations between consecutive backbone points from the change of their unstable
//! multipliers ([`crate::Stability::unstable`]).
//!
//! In a conservative system the multipliers lie on the unit circle (stable) or leave it in pairs
//! (mu, 1/mu) through +1 (a real pair: fold of the branch, or branch point toward another
//! family), through -1 (period doubling), or as a complex quadruple after a collision of two
//! pairs of opposite Krein signature (the Hamiltonian analogue of a Neimark-Sacker bifurcation).
//! Only the multiplier with |mu| > 1 of each pair is counted, so each crossing changes one count
//! by one. A fold of q (BackbonePoint::fold) and a branch point both appear as a crossing of +1;
//! telling them apart needs the branch tangent, which the continuation has.

use serde::Serialize;

use super::Stability;

/// Kind of bifurcation between two points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bifurcation {
    /// A real multiplier crossed +1: fold (turning point of the branch) or branch point.
    FoldOrBranchPoint,
    /// A real multiplier crossed -1: period doubling.
    PeriodDoubling,
    /// A complex pair left (or re-entered) the unit circle: Neimark-Sacker (Krein collision).
    NeimarkSacker,
}

/// The bifurcation between `prev` and `next`, if the number of unstable multipliers of some kind
/// changed; with several changes at once, the first of +1, -1, complex is reported.
pub fn classify(prev: &Stability, next: &Stability) -> Option<Bifurcation> {
    let (a, b) = (prev.unstable, next.unstable);
    if a.real_positive != b.real_positive {
        Some(Bifurcation::FoldOrBranchPoint)
    } else if a.real_negative != b.real_negative {
        Some(Bifurcation::PeriodDoubling)
    } else if a.complex != b.complex {
        Some(Bifurcation::NeimarkSacker)
    } else {
        None
    }
}
