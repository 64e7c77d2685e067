//! Lagrange shape functions of the TET4 and TET10 elements on the reference tetrahedron.
//!
//! Reference tetrahedron: vertices (0,0,0), (1,0,0), (0,1,0), (0,0,1) in reference
//! coordinates (xi, eta, zeta); its volume is 1/6. Barycentric coordinates
//! L0 = 1 - xi - eta - zeta, L1 = xi, L2 = eta, L3 = zeta.
//!
//! Node order is gmsh's. TET10 edge nodes: 4:(0,1) 5:(1,2) 6:(0,2) 7:(0,3) 8:(2,3) 9:(1,3).
//! TET4: N_i = L_i. TET10: vertex N_i = L_i (2 L_i - 1), edge node N = 4 L_a L_b.

use crate::tet_kind::TetKind;

/// Vertex pairs of the six TET10 edge nodes 4..9, gmsh order.
pub const TET10_EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)];

/// Gradients of the barycentric coordinates L0..L3 with respect to (xi, eta, zeta).
const BARY_GRAD: [[f64; 3]; 4] = [
    [-1.0, -1.0, -1.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

/// Reference coordinates of the nodes of `kind`, gmsh order.
pub fn reference_nodes(kind: TetKind) -> &'static [[f64; 3]] {
    const NODES: [[f64; 3]; 10] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.5, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.0, 0.5, 0.0],
        [0.0, 0.0, 0.5],
        [0.0, 0.5, 0.5],
        [0.5, 0.0, 0.5],
    ];
    &NODES[..kind.nodes_per_element()]
}

fn barycentric(xi: [f64; 3]) -> [f64; 4] {
    [1.0 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]]
}

/// TET4 shape functions at reference point `xi`.
pub fn tet4_values(xi: [f64; 3]) -> [f64; 4] {
    barycentric(xi)
}

/// TET4 shape-function gradients dN_i/d(xi, eta, zeta) (constant).
pub fn tet4_gradients(_xi: [f64; 3]) -> [[f64; 3]; 4] {
    BARY_GRAD
}

/// TET10 shape functions at reference point `xi`.
pub fn tet10_values(xi: [f64; 3]) -> [f64; 10] {
    let l = barycentric(xi);
    let mut n = [0.0; 10];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
    }
    for (k, &(a, b)) in TET10_EDGES.iter().enumerate() {
        n[4 + k] = 4.0 * l[a] * l[b];
    }
    n
}

/// TET10 shape-function gradients dN_i/d(xi, eta, zeta) at reference point `xi`.
pub fn tet10_gradients(xi: [f64; 3]) -> [[f64; 3]; 10] {
    let l = barycentric(xi);
    let mut g = [[0.0; 3]; 10];
    for i in 0..4 {
        let f = 4.0 * l[i] - 1.0;
        for d in 0..3 {
            g[i][d] = f * BARY_GRAD[i][d];
        }
    }
    for (k, &(a, b)) in TET10_EDGES.iter().enumerate() {
        for d in 0..3 {
            g[4 + k][d] = 4.0 * (BARY_GRAD[a][d] * l[b] + l[a] * BARY_GRAD[b][d]);
        }
    }
    g
}

/// Shape-function values of `kind` at `xi`, written into `out[..nodes_per_element]`.
pub fn values_into(kind: TetKind, xi: [f64; 3], out: &mut [f64]) {
    match kind {
        TetKind::Tet4 => out[..4].copy_from_slice(&tet4_values(xi)),
        TetKind::Tet10 => out[..10].copy_from_slice(&tet10_values(xi)),
    }
}

/// Shape-function gradients of `kind` at `xi`, written into `out[..nodes_per_element]`.
pub fn gradients_into(kind: TetKind, xi: [f64; 3], out: &mut [[f64; 3]]) {
    match kind {
        TetKind::Tet4 => out[..4].copy_from_slice(&tet4_gradients(xi)),
        TetKind::Tet10 => out[..10].copy_from_slice(&tet10_gradients(xi)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KINDS: [TetKind; 2] = [TetKind::Tet4, TetKind::Tet10];

    fn values(kind: TetKind, xi: [f64; 3]) -> Vec<f64> {
        let mut v = vec![0.0; kind.nodes_per_element()];
        values_into(kind, xi, &mut v);
        v
    }

    fn gradients(kind: TetKind, xi: [f64; 3]) -> Vec<[f64; 3]> {
        let mut g = vec![[0.0; 3]; kind.nodes_per_element()];
        gradients_into(kind, xi, &mut g);
        g
    }

    /// Points inside and on the boundary of the reference tetrahedron.
    fn sample_points() -> Vec<[f64; 3]> {
        vec![
            [0.25, 0.25, 0.25],
            [0.1, 0.2, 0.3],
            [0.7, 0.1, 0.05],
            [0.0, 0.0, 0.0],
            [0.3, 0.0, 0.6],
            [0.05, 0.8, 0.1],
        ]
    }

    #[test]
    fn nodality() {
        // N_i(x_j) = delta_ij: the values are products of exact binary fractions
        // (0, 0.5, 1), so they are exact in floating point; 1e-15 only guards the sums.
        for kind in KINDS {
            for (j, &xj) in reference_nodes(kind).iter().enumerate() {
                for (i, n) in values(kind, xj).into_iter().enumerate() {
                    let expected = if i == j { 1.0 } else { 0.0 };
                    assert!((n - expected).abs() < 1e-15, "{kind:?} N_{i}(x_{j}) = {n}");
                }
            }
        }
    }

    #[test]
    fn partition_of_unity_and_zero_gradient_sum() {
        // Sum of ten O(1) terms: round-off is a few ulp, 1e-14 is a safe bound.
        for kind in KINDS {
            for xi in sample_points() {
                let s: f64 = values(kind, xi).iter().sum();
                assert!((s - 1.0).abs() < 1e-14, "{kind:?} sum N = {s} at {xi:?}");
                let g = gradients(kind, xi);
                for d in 0..3 {
                    let gs: f64 = g.iter().map(|gi| gi[d]).sum();
                    assert!(gs.abs() < 1e-14, "{kind:?} sum dN/dxi_{d} = {gs} at {xi:?}");
                }
            }
        }
    }

    #[test]
    fn linear_completeness_reproduces_coordinates() {
        // sum_i N_i(xi) X_i = xi for the reference nodes (isoparametric identity map).
        for kind in KINDS {
            for xi in sample_points() {
                let n = values(kind, xi);
                for d in 0..3 {
                    let x: f64 = n
                        .iter()
                        .zip(reference_nodes(kind))
                        .map(|(ni, xn)| ni * xn[d])
                        .sum();
                    assert!(
                        (x - xi[d]).abs() < 1e-14,
                        "{kind:?} coordinate {d} at {xi:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn gradients_match_central_differences() {
        // The shape functions are quadratic, so the central difference
        // (N(x+h e) - N(x-h e)) / 2h is exact up to round-off ~ eps / h = 2e-16 / 1e-4
        // = 2e-12 (times O(1) values); 1e-10 leaves margin without hiding an O(1) error.
        let h = 1e-4;
        for kind in KINDS {
            for xi in sample_points() {
                let g = gradients(kind, xi);
                for d in 0..3 {
                    let mut xp = xi;
                    let mut xm = xi;
                    xp[d] += h;
                    xm[d] -= h;
                    let (np, nm) = (values(kind, xp), values(kind, xm));
                    for i in 0..kind.nodes_per_element() {
                        let fd = (np[i] - nm[i]) / (2.0 * h);
                        assert!(
                            (fd - g[i][d]).abs() < 1e-10,
                            "{kind:?} dN_{i}/dxi_{d} at {xi:?}: analytic {} vs fd {fd}",
                            g[i][d]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn edge_nodes_sit_at_edge_midpoints() {
        let nodes = reference_nodes(TetKind::Tet10);
        for (k, &(a, b)) in TET10_EDGES.iter().enumerate() {
            for d in 0..3 {
                assert_eq!(nodes[4 + k][d], 0.5 * (nodes[a][d] + nodes[b][d]));
            }
        }
    }
}
