//! Which quadrature each element gets, and why.
//!
//! The Jacobian J is evaluated at every quadrature point. For an *affine* element (TET4, or
//! TET10 with every mid-edge node at its edge midpoint, see [`AFFINE_TOLERANCE`]) J is
//! constant and the stiffness integrand is a polynomial of degree 2(p - 1) (p = 1 or 2 the
//! element order): the 4-point rule [`TetRule::four_point`] (degree 2) is exact.
//!
//! Mass, all elements: det J is a polynomial of degree <= 3 (cubic for a curved TET10), so
//! N_a N_b det J has degree <= 7 and the mass is computed exactly from det J at the 20 cubic
//! Lagrange points ([`crate::exact_mass`], weights integrated once with the degree-7
//! conical-product rule; checked against the closed form of the affine TET10 mass and
//! against a 4096-point rule on curved elements).
//!
//! Stiffness of a *curved* TET10 (J linear in the reference coordinates): the integrand is
//! rational (adj(J) is quadratic and divided by det J), so no rule is exact, and the number of
//! points needed depends on how close det J comes to zero near the element. Measured against
//! a 4096-point rule, for the 1e-10 target: offsets of the mid-edge nodes up to ~1e-4 of the
//! edge are converged with the 14-point rule, 1e-3 needs 14 or 64 points, 1 % 64 (regular
//! element) to 125, 3-5 % 216 to 1000 and sometimes more, depending on the element's shape
//! (test `curved_tet10_stiffness_rule_is_converged`, which prints the histogram). A fixed rule would be either wasteful or
//! inaccurate, so the rule is chosen per element from the ladder [`STIFFNESS_LADDER`]
//! (14 points, then conical products of degree 7, 9, ..., 19 with 64 ... 1000 points): the
//! first rule whose value of the scalar functional T = int sum_a |grad N_a|^2 dV (the trace of
//! the stiffness up to material constants: the same rational structure, at about a tenth of
//! the cost per point) agrees with the next rule's to [`LADDER_TOLERANCE`] is used. That test
//! checks on about 140 random curved elements (offsets 1e-8 to 15 %) that the stiffness so obtained
//! differs from the 4096-point rule by less than 1e-10 relative (Frobenius norm) whenever the
//! ladder converges, and that it converges for at least 95 % of the elements with offsets up
//! to 5 %. An element so distorted that no pair agrees uses the last (1000-point) rule. On
//! gmsh meshes (`examples/mesh_report.rs`): a 138k-DOF thin cylindrical shell used the
//! 14-point rule for 82 % of its elements and 64 points for the rest; a coarse sphere 64 or 125
//! points for most boundary elements.

use std::sync::OnceLock;

use crate::exact_mass::CubicMassWeights;
use crate::geometry::{adjugate3, det3, longest_vertex_edge, AffineJacobian};
use crate::quadrature::TetRule;
use crate::shape;
use crate::tabulated_rule::TabulatedRule;
use crate::tet_kind::TetKind;

/// A TET10 whose mid-edge nodes are all within `AFFINE_TOLERANCE * h` of their edge midpoints
/// (h the longest vertex edge) is treated as affine. The stiffness error of the affine rule is
/// first order in the offset (about 0.2 x offset / h relative, measured by the convergence
/// test), so this tolerance keeps it near 1e-11 while absorbing the round-off of
/// midpoints written to file with 16 significant digits.
pub const AFFINE_TOLERANCE: f64 = 1e-10;

/// Stiffness rules tried, in order, for curved TET10: 0 stands for the 14-point degree-5 rule,
/// d > 0 for the conical-product rule of degree d ((d + 1)^3 / 8 points).
pub const STIFFNESS_LADDER: [usize; 8] = [0, 7, 9, 11, 13, 15, 17, 19];

/// Relative agreement of the trace functional between consecutive ladder rules at which the
/// lower one is accepted for a curved TET10 stiffness.
pub const LADDER_TOLERANCE: f64 = 1e-11;

/// The tabulated rules the element uses (see the module docs for the choice).
#[derive(Debug)]
pub struct ElementRules {
    /// Stiffness of affine elements.
    pub stiffness_affine: TabulatedRule,
    /// Stiffness candidates for curved TET10, see [`STIFFNESS_LADDER`] (empty for TET4).
    pub stiffness_ladder: Vec<TabulatedRule>,
    /// Exact mass of affine and curved elements (module docs).
    pub mass: CubicMassWeights,
    /// Volume rule (14 points, degree 5 >= 3, the degree of det J).
    pub volume: TetRule,
}

impl ElementRules {
    fn build(kind: TetKind) -> Self {
        let ladder = match kind {
            // TET4 is always affine: no ladder.
            TetKind::Tet4 => Vec::new(),
            TetKind::Tet10 => STIFFNESS_LADDER
                .iter()
                .map(|&d| {
                    let rule = if d == 0 {
                        TetRule::fourteen_point()
                    } else {
                        TetRule::conical_product(d)
                    };
                    TabulatedRule::new(kind, rule)
                })
                .collect(),
        };
        ElementRules {
            stiffness_affine: TabulatedRule::new(kind, TetRule::four_point()),
            mass: CubicMassWeights::new(kind),
            volume: TetRule::fourteen_point(),
            stiffness_ladder: ladder,
        }
    }

    /// The rules for `kind`, tabulated once per process.
    pub fn for_kind(kind: TetKind) -> &'static ElementRules {
        static TET4: OnceLock<ElementRules> = OnceLock::new();
        static TET10: OnceLock<ElementRules> = OnceLock::new();
        match kind {
            TetKind::Tet4 => TET4.get_or_init(|| Self::build(kind)),
            TetKind::Tet10 => TET10.get_or_init(|| Self::build(kind)),
        }
    }

    /// The stiffness rule for a curved element (module docs): the first ladder rule whose
    /// trace functional agrees with the next one to [`LADDER_TOLERANCE`], else the last.
    /// If det J <= 0 at a point of a ladder rule, the first rule is returned: the element is
    /// invalid anyway, and the stiffness computation reports it if one of that rule's points
    /// is affected.
    pub fn curved_stiffness_rule(&self, coords: &[[f64; 3]]) -> &TabulatedRule {
        let ladder = &self.stiffness_ladder;
        let Some(first) = ladder.first() else {
            return &self.stiffness_affine;
        };
        let jac = AffineJacobian::new(first.kind, coords);
        let Some(mut previous) = trace_functional(&jac, first) else {
            return first;
        };
        for i in 0..ladder.len() - 1 {
            let Some(next) = trace_functional(&jac, &ladder[i + 1]) else {
                return first;
            };
            if (previous - next).abs() <= LADDER_TOLERANCE * next.abs() {
                return &ladder[i];
            }
            previous = next;
        }
        &ladder[ladder.len() - 1]
    }
}

/// T = int sum_a |grad N_a|^2 dV with the given rule; `None` if det J <= 0 at a point.
///
/// With J^-1 = adj(J) / det J: sum_a |J^-T g_a|^2 det J = tr(adj adj^T S) / det J, where
/// S = sum_a g_a g_a^T is tabulated (g_a the reference gradients).
fn trace_functional(jac: &AffineJacobian, tab: &TabulatedRule) -> Option<f64> {
    let mut t = 0.0;
    for ((&w, &p), s) in tab
        .rule
        .weights
        .iter()
        .zip(&tab.rule.points)
        .zip(&tab.gradient_gram)
    {
        let j = jac.at(p);
        let det = det3(&j);
        if det.is_nan() || det <= 0.0 {
            return None;
        }
        let adj = adjugate3(&j);
        // tr(adj adj^T S) = sum_k c_k^T S c_k with c_k the k-th column of adj (S symmetric).
        let mut tr = 0.0;
        for k in 0..3 {
            let c = [adj[0][k], adj[1][k], adj[2][k]];
            let sc = [
                s[0][0] * c[0] + s[0][1] * c[1] + s[0][2] * c[2],
                s[1][0] * c[0] + s[1][1] * c[1] + s[1][2] * c[2],
                s[2][0] * c[0] + s[2][1] * c[1] + s[2][2] * c[2],
            ];
            tr += c[0] * sc[0] + c[1] * sc[1] + c[2] * sc[2];
        }
        t += w * tr / det;
    }
    Some(t)
}

/// Largest distance of a TET10 mid-edge node from its edge midpoint, divided by the longest
/// vertex edge (0 for TET4).
pub fn curvature(kind: TetKind, coords: &[[f64; 3]]) -> f64 {
    if kind == TetKind::Tet4 {
        return 0.0;
    }
    let h = longest_vertex_edge(coords);
    let mut worst: f64 = 0.0;
    for (k, &(a, b)) in shape::TET10_EDGES.iter().enumerate() {
        let d2: f64 = (0..3)
            .map(|d| (coords[4 + k][d] - 0.5 * (coords[a][d] + coords[b][d])).powi(2))
            .sum();
        worst = worst.max(d2.sqrt());
    }
    worst / h
}

/// True for TET4 and for TET10 whose mid-edge nodes are at their edge midpoints within
/// [`AFFINE_TOLERANCE`].
pub fn is_affine(kind: TetKind, coords: &[[f64; 3]]) -> bool {
    curvature(kind, coords) <= AFFINE_TOLERANCE
}
