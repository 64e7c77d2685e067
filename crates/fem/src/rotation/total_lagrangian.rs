//! Total-Lagrangian internal force and tangent of a St Venant-Kirchhoff solid (DESIGN §9:
//! the geometrically nonlinear static step, CalculiX's NLGEOM).
//!
//! With reference gradients G_a = dN_a/dX, displacement u = sum_a N_a u_a:
//! F = I + H, H = sum_a u_a G_a^T, Green-Lagrange E = (F^T F - I) / 2 = (H + H^T + H^T H) / 2, second Piola-Kirchhoff
//! S = lambda tr(E) I + 2 mu E (the isotropic material of [`crate::material`]);
//! internal force f_a = int F S G_a dV (N, reference volume);
//! tangent df_a/du_b = int [lambda (F G_a)(F G_b)^T + mu (F G_b)(F G_a)^T
//! + mu (G_a . G_b) F F^T] dV (material part, with the initial-displacement terms through F)
//! + int (G_a . S G_b) dV I_3 (geometric part, the stress stiffness of S).
//!
//! Derivation of the material part: dE = sym(F^T dF), dE/du_bj = sym(F_j (x) G_b) with F_j the
//! j-th row of F; C : dE/du_bj contracted with dE/du_ai gives lambda (F G_a)_i (F G_b)_j +
//! mu [(F F^T)_ij G_a . G_b + (F G_b)_i (F G_a)_j]. At F = I it is the linear stiffness of
//! [`crate::element`] (lambda dN_a/dx_i dN_b/dx_j + mu dN_a/dx_j dN_b/dx_i + mu delta_ij
//! grad N_a . grad N_b).

use crate::element::TabulatedRule;
use crate::error::FemError;
use crate::material::Lame;
use crate::rotation::axis::{dot, mat_vec, Mat3};
use crate::rotation::element_ref::{mirror_upper, ElementRef};
use crate::rotation::points::{for_each_point, nonlinear_rule, PointGeometry};
use crate::rotation::stress_stiffness::{add_geometric_blocks, svk_stress};

/// Displacement gradient H = du/dX = sum_a u_a G_a^T at a point (`u_e` in element DOF order,
/// m; `gradients` dN_a/dX, 1/m).
pub fn displacement_gradient(u_e: &[f64], gradients: &[[f64; 3]]) -> Mat3 {
    let mut h = [[0.0; 3]; 3];
    for (a, g) in gradients.iter().enumerate() {
        for i in 0..3 {
            for j in 0..3 {
                h[i][j] += u_e[3 * a + i] * g[j];
            }
        }
    }
    h
}

/// Deformation gradient F = I + H.
pub fn deformation_gradient(h: &Mat3) -> Mat3 {
    let mut f = *h;
    for (i, row) in f.iter_mut().enumerate() {
        row[i] += 1.0;
    }
    f
}

/// Green-Lagrange strain E = (H + H^T + H^T H) / 2 = (F^T F - I) / 2 (dimensionless), exactly
/// symmetric, from the displacement gradient H: this form has no cancellation, whereas
/// F^T F - I loses the digits of small strains (a strain of 1e-9 would keep only 7; the static
/// solve at low speed then stalls at a residual of 1e-5 of the load).
pub fn green_lagrange(h: &Mat3) -> Mat3 {
    let mut e = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            let hth = h[0][i] * h[0][j] + h[1][i] * h[1][j] + h[2][i] * h[2][j];
            e[i][j] = 0.5 * ((h[i][j] + h[j][i]) + hth);
            e[j][i] = e[i][j];
        }
    }
    e
}

/// Cauchy stress sigma = F S F^T / det F (Pa) from the second Piola-Kirchhoff stress S.
pub fn cauchy_stress(f: &Mat3, s: &Mat3) -> Mat3 {
    let det = crate::geometry::det3(f);
    let fs: Mat3 = std::array::from_fn(|i| std::array::from_fn(|k| dot(&f[i], &column(s, k))));
    let mut sigma = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            sigma[i][j] = dot(&fs[i], &f[j]) / det;
            sigma[j][i] = sigma[i][j];
        }
    }
    sigma
}

fn column(m: &Mat3, k: usize) -> [f64; 3] {
    [m[0][k], m[1][k], m[2][k]]
}

/// Internal force f_a = int F S G_a dV (N) at nodal displacements `u_e` (m) into `force`
/// (length 3 npe, overwritten) and, when given, the tangent df/du (N/m, row-major (3 npe)^2,
/// overwritten, exactly symmetric) into `tangent`. Module docs for the formulas; the rule is
/// [`nonlinear_rule`].
pub fn internal_force_and_tangent_element(
    element: &ElementRef<'_>,
    u_e: &[f64],
    lame: Lame,
    force: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<(), FemError> {
    let tab = nonlinear_rule(element.kind, element.coords);
    internal_force_and_tangent_with_rule(element, tab, u_e, lame, force, tangent)
}

/// [`internal_force_and_tangent_element`] with the element's rule `tab` given (the
/// [`nonlinear_rule`] of the element, chosen once per mesh by the global assembly).
pub(crate) fn internal_force_and_tangent_with_rule(
    element: &ElementRef<'_>,
    tab: &TabulatedRule,
    u_e: &[f64],
    lame: Lame,
    force: &mut [f64],
    mut tangent: Option<&mut [f64]>,
) -> Result<(), FemError> {
    element.check_vector(u_e, "element displacements")?;
    element.check_vector(force, "element internal force")?;
    let (npe, n) = (element.npe(), element.ndof());
    if let Some(k) = tangent.as_deref_mut() {
        element.check_matrix(k, "element tangent")?;
        k[..n * n].fill(0.0);
    }
    force.fill(0.0);
    for_each_point(element.coords, tab, element.tag, |pt| {
        let h = displacement_gradient(u_e, &pt.gradients[..npe]);
        let f = deformation_gradient(&h);
        let s = svk_stress(&green_lagrange(&h), lame);
        for a in 0..npe {
            let fsg = mat_vec(&f, &mat_vec(&s, &pt.gradients[a]));
            for i in 0..3 {
                force[3 * a + i] += pt.weight * fsg[i];
            }
        }
        if let Some(k) = tangent.as_deref_mut() {
            add_material_blocks(pt, npe, &f, lame, k);
            add_geometric_blocks(pt, npe, &s, k);
        }
    })?;
    if let Some(k) = tangent {
        mirror_upper(k, n);
    }
    Ok(())
}

/// Adds the material part of the tangent at one point to the blocks b >= a of `k`.
///
/// Entry (3a + i, 3b + j) gets c (lambda (F G_a)_i (F G_b)_j + mu (F G_b)_i (F G_a)_j) plus
/// c mu (G_a . G_b) (F F^T)_ij, evaluated in that order; the rows are walked as contiguous
/// runs over (b, j) so that the compiler vectorizes them (same operations per entry as the
/// plain loops over a, b, i, j, hence the same bits).
fn add_material_blocks(pt: &PointGeometry, npe: usize, f: &Mat3, lame: Lame, k: &mut [f64]) {
    let n = 3 * npe;
    let c = pt.weight;
    // fg[3b + j] = (F G_b)_j; mu_fg[i][3b + j] = mu (F G_b)_i; fft_row[i][3b + j] = (F F^T)_ij.
    let (mut fg, mut mu_fg) = ([0.0; 30], [[0.0; 30]; 3]);
    for b in 0..npe {
        let v = mat_vec(f, &pt.gradients[b]);
        fg[3 * b..3 * b + 3].copy_from_slice(&v);
        for i in 0..3 {
            mu_fg[i][3 * b..3 * b + 3].fill(lame.mu * v[i]);
        }
    }
    let mut fft_row = [[0.0; 30]; 3];
    for (i, row) in fft_row.iter_mut().enumerate() {
        let fft_i: [f64; 3] = std::array::from_fn(|j| dot(&f[i], &f[j]));
        for (m, v) in row[..n].iter_mut().enumerate() {
            *v = fft_i[m % 3];
        }
    }
    for a in 0..npe {
        // fa[3b + j] = (F G_a)_j; gab[3b + j] = c mu G_a . G_b.
        let (mut fa, mut gab) = ([0.0; 30], [0.0; 30]);
        for b in a..npe {
            fa[3 * b..3 * b + 3].copy_from_slice(&fg[3 * a..3 * a + 3]);
            gab[3 * b..3 * b + 3].fill(c * lame.mu * dot(&pt.gradients[a], &pt.gradients[b]));
        }
        let lo = 3 * a;
        for i in 0..3 {
            let la = lame.lambda * fg[3 * a + i];
            let row = &mut k[(3 * a + i) * n + lo..(3 * a + i) * n + n];
            let terms = fg[lo..n]
                .iter()
                .zip(&mu_fg[i][lo..n])
                .zip(&fa[lo..n])
                .zip(gab[lo..n].iter().zip(&fft_row[i][lo..n]));
            for (kk, (((&fb, &mb), &fa), (&g, &ff))) in row.iter_mut().zip(terms) {
                *kk += c * (la * fb + mb * fa) + g * ff;
            }
        }
    }
}
