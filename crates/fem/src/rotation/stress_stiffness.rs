//! Stress (geometric) stiffness of a prestress field (DESIGN §9):
//! K_sigma^ab = I_3 int (grad N_a)^T S (grad N_b) dV (N/m), S a symmetric stress (Pa) in the
//! reference configuration (the second Piola-Kirchhoff stress of the prestressed state; for a
//! linear prestress the small-strain stress). It is the geometric part of the
//! total-Lagrangian tangent ([`crate::rotation::total_lagrangian`]).

use crate::element::TabulatedRule;
use crate::error::FemError;
use crate::material::Lame;
use crate::rotation::axis::{dot, mat_vec, Mat3};
use crate::rotation::element_ref::{mirror_upper, ElementRef};
use crate::rotation::points::{for_each_point, nonlinear_rule, PointGeometry};

/// Adds c (G_a . S G_b) to the diagonal of the blocks b >= a of the row-major (3 npe)^2
/// matrix `k`, c the point weight.
pub(crate) fn add_geometric_blocks(pt: &PointGeometry, npe: usize, s: &Mat3, k: &mut [f64]) {
    let n = 3 * npe;
    for a in 0..npe {
        let sga = mat_vec(s, &pt.gradients[a]);
        for b in a..npe {
            let v = pt.weight * dot(&sga, &pt.gradients[b]);
            for i in 0..3 {
                k[(3 * a + i) * n + 3 * b + i] += v;
            }
        }
    }
}

/// Stress stiffness of one element (N/m, row-major (3 npe)^2, overwritten, exactly symmetric)
/// for the stress field `stress`, called at each quadrature point with its geometry (reference
/// coordinates, shape values, gradients) and returning S there (Pa, symmetric). The rule is
/// [`crate::rotation::points::nonlinear_rule`].
pub fn stress_stiffness_element(
    element: &ElementRef<'_>,
    stress: impl FnMut(&PointGeometry) -> Mat3,
    out: &mut [f64],
) -> Result<(), FemError> {
    let tab = nonlinear_rule(element.kind, element.coords);
    stress_stiffness_with_rule(element, tab, stress, out)
}

/// [`stress_stiffness_element`] with the element's rule `tab` given (its [`nonlinear_rule`],
/// chosen once per mesh by the global assembly).
pub(crate) fn stress_stiffness_with_rule(
    element: &ElementRef<'_>,
    tab: &TabulatedRule,
    mut stress: impl FnMut(&PointGeometry) -> Mat3,
    out: &mut [f64],
) -> Result<(), FemError> {
    element.check_matrix(out, "element stress stiffness")?;
    let (npe, n) = (element.npe(), element.ndof());
    out[..n * n].fill(0.0);
    for_each_point(element.coords, tab, element.tag, |pt| {
        let s = stress(pt);
        add_geometric_blocks(pt, npe, &s, out);
    })?;
    mirror_upper(out, n);
    Ok(())
}

/// The small-strain stress D eps(u) (Pa) at a point, as a symmetric tensor: the prestress of a
/// linearized static solution. `u_e` in m (element DOF order).
pub fn linear_stress_at(
    pt: &PointGeometry,
    npe: usize,
    u_e: &[f64],
    lame: crate::material::Lame,
) -> Mat3 {
    let mut eps = [[0.0; 3]; 3];
    for a in 0..npe {
        for i in 0..3 {
            for j in 0..3 {
                eps[i][j] += 0.5
                    * (u_e[3 * a + i] * pt.gradients[a][j] + u_e[3 * a + j] * pt.gradients[a][i]);
            }
        }
    }
    svk_stress(&eps, lame)
}

/// St Venant-Kirchhoff stress S = lambda tr(E) I + 2 mu E (Pa) of a symmetric strain E;
/// with the small strain in place of E it is Hooke's law of [`crate::material`].
pub fn svk_stress(e: &Mat3, lame: Lame) -> Mat3 {
    let tr = e[0][0] + e[1][1] + e[2][2];
    let mut s = e.map(|row| row.map(|v| 2.0 * lame.mu * v));
    for (i, row) in s.iter_mut().enumerate() {
        row[i] += lame.lambda * tr;
    }
    s
}
