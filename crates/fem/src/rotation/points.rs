//! Quadrature points of the rotation terms: which rule each term uses, and the geometry
//! (weight x det J, shape values, physical gradients dN/dX) at each point.
//!
//! Rules (degrees for an affine element; TET4 integrands are one degree lower per factor):
//! - total-Lagrangian internal force and tangent, stress stiffness: F is of degree p - 1 in
//!   the reference coordinates (p the element order), S of degree 2(p - 1), so F S dN/dX and
//!   the tangent terms (F dN_a)(F dN_b), F F^T dN_a . dN_b, dN_a . S dN_b are of degree
//!   4(p - 1): 4 for an affine TET10, exact with the 14-point degree-5 rule; 0 for TET4, exact
//!   with any rule (the 4-point rule of the linear stiffness is used). A curved TET10 gets the
//!   rule the linear stiffness picks for it ([`ElementRules::curved_stiffness_rule`]), whose
//!   first rung is the same 14-point rule: at u = 0 the tangent then equals the linear
//!   stiffness to round-off;
//! - centrifugal load int rho N_a P (x - p) dV: N_a x det J is of degree 2 + 2 + 3 = 7 for a
//!   curved TET10 (x = sum N_b x_b, also with the displacement), exact with the degree-7
//!   conical-product rule (64 points); degree 2 for TET4, exact with the 4-point rule.
//! - spin softening and Coriolis: the exact consistent mass ([`crate::exact_mass`]).

use std::sync::OnceLock;

use crate::element::{is_affine, ElementRules, TabulatedRule};
use crate::error::FemError;
use crate::geometry::{check_det_j, det3, inverse3, longest_vertex_edge, AffineJacobian};
use crate::quadrature::TetRule;
use crate::tet_kind::TetKind;

/// Geometry at one quadrature point of one element.
#[derive(Clone, Debug)]
pub struct PointGeometry {
    /// Reference coordinates of the point.
    pub xi: [f64; 3],
    /// Quadrature weight times det J (m^3).
    pub weight: f64,
    /// Shape values N_a (first `npe` entries used).
    pub values: [f64; 10],
    /// Physical gradients dN_a/dX (1/m) in the reference configuration (first `npe` used).
    pub gradients: [[f64; 3]; 10],
}

/// The 14-point degree-5 rule tabulated for TET10.
fn tet10_degree5() -> &'static TabulatedRule {
    static RULE: OnceLock<TabulatedRule> = OnceLock::new();
    RULE.get_or_init(|| TabulatedRule::new(TetKind::Tet10, TetRule::fourteen_point()))
}

/// The degree-7 conical-product rule tabulated for TET10.
fn tet10_degree7() -> &'static TabulatedRule {
    static RULE: OnceLock<TabulatedRule> = OnceLock::new();
    RULE.get_or_init(|| TabulatedRule::new(TetKind::Tet10, TetRule::conical_product(7)))
}

/// Rule of the total-Lagrangian terms and of the stress stiffness (module docs).
pub fn nonlinear_rule(kind: TetKind, coords: &[[f64; 3]]) -> &'static TabulatedRule {
    let rules = ElementRules::for_kind(kind);
    match kind {
        TetKind::Tet4 => &rules.stiffness_affine,
        TetKind::Tet10 if is_affine(kind, coords) => tet10_degree5(),
        TetKind::Tet10 => rules.curved_stiffness_rule(coords),
    }
}

/// Rule of the centrifugal load (module docs): exact for TET4 and TET10, curved or not.
pub fn load_rule(kind: TetKind) -> &'static TabulatedRule {
    match kind {
        TetKind::Tet4 => &ElementRules::for_kind(kind).stiffness_affine,
        TetKind::Tet10 => tet10_degree7(),
    }
}

/// Calls `f` with the geometry of every point of `tab` on the element `coords`, in rule order;
/// stops with an error at the first point where det J is not positive or negligible (what `f`
/// accumulated is then to be discarded).
pub fn for_each_point(
    coords: &[[f64; 3]],
    tab: &TabulatedRule,
    element_tag: usize,
    mut f: impl FnMut(&PointGeometry),
) -> Result<(), FemError> {
    let npe = tab.kind.nodes_per_element();
    let jac = AffineJacobian::new(tab.kind, coords);
    let h = longest_vertex_edge(coords);
    let mut pt = PointGeometry {
        xi: [0.0; 3],
        weight: 0.0,
        values: [0.0; 10],
        gradients: [[0.0; 3]; 10],
    };
    for (q, (&w, &xi)) in tab.rule.weights.iter().zip(&tab.rule.points).enumerate() {
        let j = jac.at(xi);
        let det = det3(&j);
        check_det_j(det, h, element_tag, xi)?;
        let inv = inverse3(&j, det);
        pt.xi = xi;
        pt.weight = w * det;
        pt.values[..npe].copy_from_slice(&tab.values[q * npe..(q + 1) * npe]);
        for a in 0..npe {
            let r = tab.gradients[q * npe + a];
            for d in 0..3 {
                pt.gradients[a][d] = r[0] * inv[0][d] + r[1] * inv[1][d] + r[2] * inv[2][d];
            }
        }
        f(&pt);
    }
    Ok(())
}
