//! Isoparametric TET4/TET10 element matrices: consistent mass (paper Eq. 5a) and
//! linear-elastic stiffness (Eq. 5b, Hooke's law of Sec. 2.2).
//!
//! Element DOF numbering: `3 * local_node + component` (component 0 = x, 1 = y, 2 = z).
//! Element matrices are dense, row-major, `(3 npe) x (3 npe)`, exactly symmetric (the upper
//! triangle is computed and mirrored).
//!
//! Stiffness, linear isotropic elasticity with Lamé constants (lambda, mu):
//! `K_(a,i),(b,j) = int [lambda dN_a/dx_i dN_b/dx_j + mu dN_a/dx_j dN_b/dx_i
//! + mu delta_ij grad N_a . grad N_b] dV`, which equals `int B^T D B dV` (checked by a test).
//!
//! Consistent mass: `M_(a,i),(b,j) = delta_ij int rho N_a N_b dV`.
//!
//! The quadrature rules are chosen in [`crate::rule_choice`] (and justified there).

use crate::error::FemError;
use crate::geometry::{check_det_j, det3, inverse3, longest_vertex_edge, AffineJacobian};
use crate::material::{Isotropic, Lame};
use crate::shape;
use crate::tet_kind::TetKind;

pub use crate::rule_choice::{
    curvature, is_affine, ElementRules, AFFINE_TOLERANCE, LADDER_TOLERANCE, STIFFNESS_LADDER,
};
pub use crate::tabulated_rule::TabulatedRule;

/// Physical gradients dN_a/dx = J^-T dN_a/dxi at one point, into `out`.
#[inline]
fn physical_gradients(inv: &[[f64; 3]; 3], ref_grads: &[[f64; 3]], out: &mut [[f64; 3]]) {
    // dN/dx_d = sum_k dN/dxi_k dxi_k/dx_d = sum_k g_k inv[k][d]
    for (o, g) in out.iter_mut().zip(ref_grads) {
        for d in 0..3 {
            o[d] = g[0] * inv[0][d] + g[1] * inv[1][d] + g[2] * inv[2][d];
        }
    }
}

/// Mirrors the upper triangle of a row-major `n x n` matrix into its lower triangle.
fn mirror_upper(out: &mut [f64], n: usize) {
    for p in 0..n {
        for q in 0..p {
            out[p * n + q] = out[q * n + p];
        }
    }
}

/// Element stiffness (N/m) with a given tabulated rule, into `out` (row-major,
/// `(3 npe)^2`, overwritten). Errors if det J is not positive (or negligible) at a point.
///
/// The quadrature computes H = sum_q w_q det J_q v_q v_q^T with v_q the 3 npe physical
/// gradients (v[3a + k] = dN_a/dx_k), node-pair block by node-pair block; then
/// K_(a,i),(b,j) = lambda H_(a,i),(b,j) + mu H_(a,j),(b,i) + mu delta_ij sum_k H_(a,k),(b,k).
pub fn stiffness_with_rule(
    coords: &[[f64; 3]],
    lame: Lame,
    tab: &TabulatedRule,
    element_tag: usize,
    out: &mut [f64],
) -> Result<(), FemError> {
    let npe = tab.kind.nodes_per_element();
    let n = 3 * npe;
    let out = &mut out[..n * n];
    let mut hm = [0.0; 900];
    // Fixed sizes let the compiler unroll the per-node loops.
    match tab.kind {
        TetKind::Tet4 => gradient_products::<4, 12>(coords, tab, element_tag, &mut hm)?,
        TetKind::Tet10 => gradient_products::<10, 30>(coords, tab, element_tag, &mut hm)?,
    }
    // Symmetric access through the upper triangle of H.
    let hv = |p: usize, q: usize| if p <= q { hm[p * n + q] } else { hm[q * n + p] };
    out.fill(0.0);
    for a in 0..npe {
        for b in a..npe {
            let trace = hv(3 * a, 3 * b) + hv(3 * a + 1, 3 * b + 1) + hv(3 * a + 2, 3 * b + 2);
            for i in 0..3 {
                for j in 0..3 {
                    let mut v =
                        lame.lambda * hv(3 * a + i, 3 * b + j) + lame.mu * hv(3 * a + j, 3 * b + i);
                    if i == j {
                        v += lame.mu * trace;
                    }
                    out[(3 * a + i) * n + 3 * b + j] = v;
                }
            }
        }
    }
    // Blocks b >= a hold the DOF upper triangle (and more); mirroring it makes the matrix
    // exactly symmetric.
    mirror_upper(out, n);
    Ok(())
}

/// Quadrature points processed per block in [`gradient_products`] (their gradients live on the
/// stack: 2 x 10 x 64 x 3 f64 = 30 kB).
const POINT_BLOCK: usize = 64;

/// H = sum_q w_q det J_q v_q v_q^T (row-major N x N in `hm[..N * N]`, blocks of node pairs
/// a <= b filled), v_q[3a + k] = dN_a/dx_k at point q (NPE nodes, N = 3 NPE); checks det J at
/// every point.
///
/// Computed as 3x3 node-pair tiles, each a sum over the points of (c_q g_a) g_b^T with nine
/// accumulators in registers: no per-point read-modify-write of the whole N x N matrix.
fn gradient_products<const NPE: usize, const N: usize>(
    coords: &[[f64; 3]],
    tab: &TabulatedRule,
    element_tag: usize,
    hm: &mut [f64; 900],
) -> Result<(), FemError> {
    let jac = AffineJacobian::new(tab.kind, coords);
    let h = longest_vertex_edge(coords);
    let mut tiles = [[[0.0; 3]; 3]; 100];
    let mut g = [[[0.0; 3]; POINT_BLOCK]; NPE];
    let mut gc = [[[0.0; 3]; POINT_BLOCK]; NPE];
    let n_points = tab.rule.len();
    let mut start = 0;
    while start < n_points {
        let len = POINT_BLOCK.min(n_points - start);
        for i in 0..len {
            let q = start + i;
            let point = tab.rule.points[q];
            let j = jac.at(point);
            let det = det3(&j);
            check_det_j(det, h, element_tag, point)?;
            let inv = inverse3(&j, det);
            let c = tab.rule.weights[q] * det;
            for a in 0..NPE {
                let r = tab.gradients[q * NPE + a];
                for d in 0..3 {
                    let v = r[0] * inv[0][d] + r[1] * inv[1][d] + r[2] * inv[2][d];
                    g[a][i][d] = v;
                    gc[a][i][d] = c * v;
                }
            }
        }
        for a in 0..NPE {
            for b in a..NPE {
                let mut t = tiles[a * 10 + b];
                for (x, y) in gc[a][..len].iter().zip(&g[b][..len]) {
                    for k in 0..3 {
                        for l in 0..3 {
                            t[k][l] += x[k] * y[l];
                        }
                    }
                }
                tiles[a * 10 + b] = t;
            }
        }
        start += len;
    }
    for a in 0..NPE {
        for b in a..NPE {
            for k in 0..3 {
                for l in 0..3 {
                    hm[(3 * a + k) * N + 3 * b + l] = tiles[a * 10 + b][k][l];
                }
            }
        }
    }
    Ok(())
}

/// Element consistent mass (kg) with a given tabulated rule, into `out` (row-major,
/// `(3 npe)^2`, overwritten).
pub fn mass_with_rule(
    coords: &[[f64; 3]],
    density: f64,
    tab: &TabulatedRule,
    element_tag: usize,
    out: &mut [f64],
) -> Result<(), FemError> {
    let npe = tab.kind.nodes_per_element();
    let n = 3 * npe;
    let out = &mut out[..n * n];
    let jac = AffineJacobian::new(tab.kind, coords);
    let h = longest_vertex_edge(coords);
    let mut m = [0.0; 100];
    for (q, (&w, &point)) in tab.rule.weights.iter().zip(&tab.rule.points).enumerate() {
        let det = det3(&jac.at(point));
        check_det_j(det, h, element_tag, point)?;
        let c = w * det * density;
        let nv = &tab.values[q * npe..(q + 1) * npe];
        for a in 0..npe {
            let ca = c * nv[a];
            for b in a..npe {
                m[a * npe + b] += ca * nv[b];
            }
        }
    }
    out.fill(0.0);
    for a in 0..npe {
        for b in a..npe {
            let v = m[a * npe + b];
            for i in 0..3 {
                out[(3 * a + i) * n + 3 * b + i] = v;
                out[(3 * b + i) * n + 3 * a + i] = v;
            }
        }
    }
    Ok(())
}

/// Stiffness and consistent mass of one element with the documented rule choice
/// (module docs). `k_out`, `m_out`: row-major `(3 npe)^2`, overwritten.
pub fn element_matrices(
    kind: TetKind,
    coords: &[[f64; 3]],
    mat: &Isotropic,
    element_tag: usize,
    k_out: &mut [f64],
    m_out: &mut [f64],
) -> Result<(), FemError> {
    let rules = ElementRules::for_kind(kind);
    let k_rule = if is_affine(kind, coords) {
        &rules.stiffness_affine
    } else {
        rules.curved_stiffness_rule(coords)
    };
    stiffness_with_rule(coords, mat.lame(), k_rule, element_tag, k_out)?;
    rules.mass.element_mass(coords, mat.density, m_out);
    Ok(())
}

/// Volume of one element (m^3): integral of det J with the 14-point degree-5 rule, exact for
/// TET4 and TET10 (det J is at most cubic). No sign check: an inverted element counts negative.
pub fn element_volume(kind: TetKind, coords: &[[f64; 3]]) -> f64 {
    let jac = AffineJacobian::new(kind, coords);
    let rule = &ElementRules::for_kind(kind).volume;
    rule.weights
        .iter()
        .zip(&rule.points)
        .map(|(&w, &p)| w * det3(&jac.at(p)))
        .sum()
}

/// Small strain (Voigt: xx, yy, zz, yz, xz, xy; engineering shear, dimensionless) at
/// reference point `xi` of an element with nodal displacements `u_e` (m, DOF 3 a + i).
pub fn strain_at(
    kind: TetKind,
    coords: &[[f64; 3]],
    u_e: &[f64],
    xi: [f64; 3],
    element_tag: usize,
) -> Result<[f64; 6], FemError> {
    let npe = kind.nodes_per_element();
    if coords.len() != npe {
        return Err(FemError::DimensionMismatch {
            what: "element coordinates",
            found: coords.len(),
            expected: npe,
        });
    }
    if u_e.len() != 3 * npe {
        return Err(FemError::DimensionMismatch {
            what: "element displacements",
            found: u_e.len(),
            expected: 3 * npe,
        });
    }
    let j = AffineJacobian::new(kind, coords).at(xi);
    let det = det3(&j);
    check_det_j(det, longest_vertex_edge(coords), element_tag, xi)?;
    let mut rg = [[0.0; 3]; 10];
    shape::gradients_into(kind, xi, &mut rg);
    let mut g = [[0.0; 3]; 10];
    physical_gradients(&inverse3(&j, det), &rg[..npe], &mut g[..npe]);
    // du_i/dx_j
    let mut grad_u = [[0.0; 3]; 3];
    for a in 0..npe {
        for i in 0..3 {
            for j in 0..3 {
                grad_u[i][j] += u_e[3 * a + i] * g[a][j];
            }
        }
    }
    Ok([
        grad_u[0][0],
        grad_u[1][1],
        grad_u[2][2],
        grad_u[1][2] + grad_u[2][1],
        grad_u[0][2] + grad_u[2][0],
        grad_u[0][1] + grad_u[1][0],
    ])
}

/// Cauchy stress (Pa, Voigt order as [`strain_at`]) at reference point `xi`.
pub fn stress_at(
    kind: TetKind,
    coords: &[[f64; 3]],
    u_e: &[f64],
    mat: &Isotropic,
    xi: [f64; 3],
    element_tag: usize,
) -> Result<[f64; 6], FemError> {
    Ok(mat.stress(&strain_at(kind, coords, u_e, xi, element_tag)?))
}
