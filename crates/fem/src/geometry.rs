//! Isoparametric geometry: Jacobian of the reference-to-physical map and its checks.

use crate::error::FemError;
use crate::shape;
use crate::tet_kind::TetKind;

/// Relative threshold below which a positive det J counts as degenerate: det J < 1e-10 h^3.
/// (A regular tetrahedron of edge h has det J = 6 V = h^3 / sqrt 2; the slivers that real
/// mesh generators produce are orders of magnitude above 1e-10 h^3.)
pub const DEGENERATE_DET_J: f64 = 1e-10;

/// Jacobian `J[d][k] = d x_d / d xi_k = sum_a x_a[d] dN_a/dxi_k`.
#[inline]
pub fn jacobian(coords: &[[f64; 3]], ref_grads: &[[f64; 3]]) -> [[f64; 3]; 3] {
    let mut j = [[0.0; 3]; 3];
    for (x, g) in coords.iter().zip(ref_grads) {
        for d in 0..3 {
            for k in 0..3 {
                j[d][k] += x[d] * g[k];
            }
        }
    }
    j
}

/// Determinant of a 3x3 matrix.
#[inline]
pub fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Adjugate (transposed cofactor matrix) of a 3x3 matrix: m adj(m) = det(m) I.
#[inline]
pub fn adjugate3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [
        [
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[0][2] * m[2][1] - m[0][1] * m[2][2],
            m[0][1] * m[1][2] - m[0][2] * m[1][1],
        ],
        [
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[0][0] * m[2][2] - m[0][2] * m[2][0],
            m[0][2] * m[1][0] - m[0][0] * m[1][2],
        ],
        [
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
            m[0][1] * m[2][0] - m[0][0] * m[2][1],
            m[0][0] * m[1][1] - m[0][1] * m[1][0],
        ],
    ]
}

/// Inverse of a 3x3 matrix with known determinant `det` (non-zero).
#[inline]
pub fn inverse3(m: &[[f64; 3]; 3], det: f64) -> [[f64; 3]; 3] {
    let r = 1.0 / det;
    adjugate3(m).map(|row| row.map(|v| v * r))
}

/// The Jacobian of a TET4/TET10 map as an affine function of the reference point:
/// `J(xi) = j0 + sum_m xi_m jm[m]` (exact, because the shape-function gradients are affine in
/// xi for these elements; jm = 0 for TET4). Built from node coordinates relative to vertex 0,
/// which avoids cancellation when the element is far from the origin.
#[derive(Clone, Copy, Debug)]
pub struct AffineJacobian {
    j0: [[f64; 3]; 3],
    jm: [[[f64; 3]; 3]; 3],
}

impl AffineJacobian {
    /// Builds the map for an element of `kind` with node coordinates `coords` (m).
    pub fn new(kind: TetKind, coords: &[[f64; 3]]) -> Self {
        let npe = kind.nodes_per_element();
        let origin = coords[0];
        let mut rel = [[0.0; 3]; 10];
        for (r, x) in rel.iter_mut().zip(&coords[..npe]) {
            *r = [x[0] - origin[0], x[1] - origin[1], x[2] - origin[2]];
        }
        let mut g = [[0.0; 3]; 10];
        let mut at = |xi: [f64; 3]| {
            shape::gradients_into(kind, xi, &mut g);
            jacobian(&rel[..npe], &g[..npe])
        };
        let j0 = at([0.0; 3]);
        let mut jm = [[[0.0; 3]; 3]; 3];
        for (m, jmm) in jm.iter_mut().enumerate() {
            let mut e = [0.0; 3];
            e[m] = 1.0;
            let j1 = at(e);
            for d in 0..3 {
                for k in 0..3 {
                    jmm[d][k] = j1[d][k] - j0[d][k];
                }
            }
        }
        AffineJacobian { j0, jm }
    }

    /// J at reference point `xi`.
    #[inline]
    pub fn at(&self, xi: [f64; 3]) -> [[f64; 3]; 3] {
        let mut j = self.j0;
        for d in 0..3 {
            for k in 0..3 {
                j[d][k] +=
                    xi[0] * self.jm[0][d][k] + xi[1] * self.jm[1][d][k] + xi[2] * self.jm[2][d][k];
            }
        }
        j
    }
}

/// Longest edge between the four vertices (m).
pub fn longest_vertex_edge(coords: &[[f64; 3]]) -> f64 {
    let mut h2: f64 = 0.0;
    for a in 0..4 {
        for b in (a + 1)..4 {
            let d2: f64 = (0..3).map(|d| (coords[a][d] - coords[b][d]).powi(2)).sum();
            h2 = h2.max(d2);
        }
    }
    h2.sqrt()
}

/// Checks det J at a quadrature point: positive, and not negligible relative to h^3.
#[inline]
pub fn check_det_j(
    det_j: f64,
    h: f64,
    element_tag: usize,
    point: [f64; 3],
) -> Result<(), FemError> {
    if det_j.is_nan() || det_j <= 0.0 {
        return Err(FemError::InvertedElement {
            element_tag,
            det_j,
            point,
        });
    }
    if det_j < DEGENERATE_DET_J * h * h * h {
        return Err(FemError::DegenerateElement {
            element_tag,
            det_j,
            h,
            threshold: DEGENERATE_DET_J,
            point,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_times_matrix_is_identity() {
        // Well-conditioned matrix (cond ~ 10): products accurate to ~1e-15.
        let m = [[2.0, 0.3, -0.5], [0.1, 1.5, 0.2], [-0.4, 0.7, 3.0]];
        let d = det3(&m);
        let inv = inverse3(&m, d);
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| m[i][k] * inv[k][j]).sum();
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((p - e).abs() < 1e-14);
            }
        }
        // det by cofactor expansion along a column (independent of the row expansion used).
        let d_col = m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2])
            - m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2])
            + m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2]);
        assert!((d - d_col).abs() < 1e-14 * d.abs());
    }

    #[test]
    fn affine_jacobian_matches_direct_evaluation() {
        // Curved TET10 far from the origin: J(xi) by the affine form and by the direct sum
        // over nodes agree to the round-off of the direct sum, whose O(0.25 m) terms cancel to O(h = 2e-3 m)
        // entries: ~10 eps x 0.25 = 5e-16 absolute, 1e-11 x h = 2e-14 leaves margin.
        let mut c: Vec<[f64; 3]> = shape::reference_nodes(TetKind::Tet10)
            .iter()
            .map(|p| {
                [
                    0.25 + 2e-3 * p[0],
                    -0.1 + 2e-3 * (p[1] + 0.1 * p[0]),
                    0.3 + 2e-3 * p[2],
                ]
            })
            .collect();
        c[4][2] += 1e-4;
        c[8][0] -= 5e-5;
        let aj = AffineJacobian::new(TetKind::Tet10, &c);
        let mut g = [[0.0; 3]; 10];
        for xi in [[0.1, 0.2, 0.3], [0.7, 0.1, 0.1], [0.0, 0.0, 1.0]] {
            shape::gradients_into(TetKind::Tet10, xi, &mut g);
            let direct = jacobian(&c, &g);
            let affine = aj.at(xi);
            for d in 0..3 {
                for k in 0..3 {
                    assert!(
                        (direct[d][k] - affine[d][k]).abs() < 1e-11 * 2e-3,
                        "{xi:?} {d} {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn det_j_checks() {
        assert!(check_det_j(0.1, 1.0, 3, [0.25; 3]).is_ok());
        assert!(matches!(
            check_det_j(-0.1, 1.0, 3, [0.25; 3]),
            Err(FemError::InvertedElement { element_tag: 3, .. })
        ));
        assert!(matches!(
            check_det_j(f64::NAN, 1.0, 3, [0.25; 3]),
            Err(FemError::InvertedElement { .. })
        ));
        assert!(matches!(
            check_det_j(1e-12, 1.0, 4, [0.25; 3]),
            Err(FemError::DegenerateElement { element_tag: 4, .. })
        ));
    }
}
