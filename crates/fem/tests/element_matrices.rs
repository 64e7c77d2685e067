//! Element mass and stiffness against closed forms and independent constructions.

// Index loops mirror the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

mod common;

use common::{curve_mid_edge_nodes, straight_tet10, Lcg};
use faer::linalg::solvers::Solve;
use faer::Mat;
use nlmodes_fem::element::{element_matrices, element_volume, stiffness_with_rule, TabulatedRule};
use nlmodes_fem::generate::box_mesh;
use nlmodes_fem::shape::TET10_EDGES;
use nlmodes_fem::{FemError, Isotropic, TetKind, TetRule};

/// A general (non-symmetric) tetrahedron, positively oriented.
const VERTS: [[f64; 3]; 4] = [
    [0.1, 0.0, 0.05],
    [1.2, 0.1, 0.0],
    [0.3, 1.1, -0.1],
    [0.2, 0.3, 0.9],
];

fn steel() -> Isotropic {
    Isotropic::new(210e9, 0.3, 7800.0).expect("valid")
}

fn matrices(kind: TetKind, coords: &[[f64; 3]], mat: &Isotropic) -> (Vec<f64>, Vec<f64>) {
    let n = 3 * kind.nodes_per_element();
    let (mut k, mut m) = (vec![0.0; n * n], vec![0.0; n * n]);
    element_matrices(kind, coords, mat, 1, &mut k, &mut m).expect("valid element");
    (k, m)
}

fn tet_volume(v: &[[f64; 3]]) -> f64 {
    nlmodes_fem::generate::signed_volume6(v[0], v[1], v[2], v[3]) / 6.0
}

fn frobenius(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Closed-form consistent mass of an affine TET10, per component (DESIGN 4):
/// rho V / 420 x [vertex-vertex 6 diagonal / 1 off; vertex & edge containing it -4;
/// vertex & edge not containing it -6; same edge 32; edges sharing a vertex 16; opposite 8].
fn tet10_mass_table(a: usize, b: usize) -> f64 {
    let edge = |k: usize| TET10_EDGES[k - 4];
    match (a < 4, b < 4) {
        (true, true) => {
            if a == b {
                6.0
            } else {
                1.0
            }
        }
        (true, false) | (false, true) => {
            let (v, e) = if a < 4 { (a, edge(b)) } else { (b, edge(a)) };
            if e.0 == v || e.1 == v {
                -4.0
            } else {
                -6.0
            }
        }
        (false, false) => {
            let (e, f) = (edge(a), edge(b));
            if a == b {
                32.0
            } else if e.0 == f.0 || e.0 == f.1 || e.1 == f.0 || e.1 == f.1 {
                16.0
            } else {
                8.0
            }
        }
    }
}

#[test]
fn affine_mass_matches_closed_forms() {
    let mat = steel();
    let v = tet_volume(&VERTS);
    for kind in [TetKind::Tet4, TetKind::Tet10] {
        let coords = straight_tet10(&VERTS);
        let coords = &coords[..kind.nodes_per_element()];
        let (_, m) = matrices(kind, coords, &mat);
        let npe = kind.nodes_per_element();
        let n = 3 * npe;
        let scale = mat.density * v;
        let mut worst: f64 = 0.0;
        for a in 0..npe {
            for b in 0..npe {
                let exact = match kind {
                    TetKind::Tet4 => scale / 20.0 * if a == b { 2.0 } else { 1.0 },
                    TetKind::Tet10 => scale / 420.0 * tet10_mass_table(a, b),
                };
                for i in 0..3 {
                    for j in 0..3 {
                        let e = if i == j { exact } else { 0.0 };
                        worst = worst.max((m[(3 * a + i) * n + 3 * b + j] - e).abs());
                    }
                }
            }
        }
        // The quadrature is exact (degree 2 / 5 rules for degree 2 / 4 integrands): only
        // round-off of <= 14-term sums of O(rho V) values remains, ~1e-15 relative.
        assert!(
            worst < 1e-13 * scale,
            "{kind:?}: worst deviation {worst:e} (rho V = {scale:e})"
        );
    }
}

#[test]
fn translations_carry_the_total_mass() {
    // r^T M r = rho V for each rigid translation r; V from the exact volume integral
    // (14-point rule on the cubic det J), M from the element rules (4 / 14 / 64 points):
    // independent computations, equal to round-off (1e-13 relative).
    let mat = steel();
    let mut curved = straight_tet10(&VERTS);
    curved[4][2] -= 0.08;
    curved[5][0] += 0.05;
    curved[8][1] -= 0.04;
    let cases: Vec<(TetKind, Vec<[f64; 3]>)> = vec![
        (TetKind::Tet4, VERTS.to_vec()),
        (TetKind::Tet10, straight_tet10(&VERTS)),
        (TetKind::Tet10, curved),
    ];
    for (kind, coords) in cases {
        let (_, m) = matrices(kind, &coords, &mat);
        let n = 3 * kind.nodes_per_element();
        let rho_v = mat.density * element_volume(kind, &coords);
        for d in 0..3 {
            let r: Vec<f64> = (0..n).map(|p| if p % 3 == d { 1.0 } else { 0.0 }).collect();
            let mass: f64 = (0..n)
                .map(|p| (0..n).map(|q| r[p] * m[p * n + q] * r[q]).sum::<f64>())
                .sum();
            assert!(
                (mass - rho_v).abs() < 1e-13 * rho_v,
                "{kind:?} dir {d}: {mass} vs {rho_v}"
            );
        }
    }
}

/// Independent stiffness of an affine element: barycentric gradients from a faer LU solve of
/// the 4x4 system [1; x; y; z], B matrices in Voigt form, D from the material, sum of
/// w B^T D B 6V over the 4-point rule (exact for the degree-2 integrand).
fn stiffness_bdb(kind: TetKind, v: &[[f64; 3]; 4], mat: &Isotropic) -> Vec<f64> {
    let x = Mat::<f64>::from_fn(4, 4, |r, c| if r == 0 { 1.0 } else { v[c][r - 1] });
    let lu = x.partial_piv_lu();
    // grad L_i = d L_i / d(x, y, z) = (X^-1)[i][1..4]
    let inv = lu.solve(Mat::<f64>::identity(4, 4));
    let grad_l: Vec<[f64; 3]> = (0..4)
        .map(|i| [inv[(i, 1)], inv[(i, 2)], inv[(i, 3)]])
        .collect();
    let d = mat.elasticity_matrix();
    let npe = kind.nodes_per_element();
    let n = 3 * npe;
    let mut k = vec![0.0; n * n];
    let rule = TetRule::four_point();
    let six_v = 6.0 * tet_volume(v);
    for (p, &w) in rule.points.iter().zip(&rule.weights) {
        let l = [1.0 - p[0] - p[1] - p[2], p[0], p[1], p[2]];
        let mut g = vec![[0.0; 3]; npe];
        for a in 0..4 {
            let f = if kind == TetKind::Tet4 {
                1.0
            } else {
                4.0 * l[a] - 1.0
            };
            g[a] = grad_l[a].map(|c| f * c);
        }
        if kind == TetKind::Tet10 {
            for (e, &(a, b)) in TET10_EDGES.iter().enumerate() {
                g[4 + e] =
                    std::array::from_fn(|c| 4.0 * (l[a] * grad_l[b][c] + l[b] * grad_l[a][c]));
            }
        }
        let mut bm = vec![[0.0; 6]; n]; // column p of B, as 6 entries
        for a in 0..npe {
            let [gx, gy, gz] = g[a];
            bm[3 * a] = [gx, 0.0, 0.0, 0.0, gz, gy];
            bm[3 * a + 1] = [0.0, gy, 0.0, gz, 0.0, gx];
            bm[3 * a + 2] = [0.0, 0.0, gz, gy, gx, 0.0];
        }
        for r in 0..n {
            let db: Vec<f64> = (0..6)
                .map(|s| (0..6).map(|t| d[s][t] * bm[r][t]).sum())
                .collect();
            for c in 0..n {
                let v: f64 = (0..6).map(|s| bm[c][s] * db[s]).sum();
                k[c * n + r] += w * six_v * v;
            }
        }
    }
    k
}

#[test]
fn affine_stiffness_equals_b_transpose_d_b() {
    // Two constructions of the same exact integral: round-off only, ~1e-15 relative in the
    // Frobenius norm; 1e-13 leaves margin for the LU solve of the 4x4 system.
    for mat in [
        steel(),
        Isotropic::new(1e6, 0.25, 1.0).expect("valid"),
        Isotropic::new(3.0, -0.4, 1.0).expect("valid"),
    ] {
        for kind in [TetKind::Tet4, TetKind::Tet10] {
            let coords = straight_tet10(&VERTS);
            let (k, _) = matrices(kind, &coords[..kind.nodes_per_element()], &mat);
            let reference = stiffness_bdb(kind, &VERTS, &mat);
            let diff: Vec<f64> = k.iter().zip(&reference).map(|(a, b)| a - b).collect();
            let rel = frobenius(&diff) / frobenius(&reference);
            assert!(
                rel < 1e-13,
                "{kind:?} nu = {}: relative difference {rel:e}",
                mat.poisson
            );
        }
    }
}

#[test]
fn element_matrices_are_exactly_symmetric_and_annihilate_rigid_motions() {
    let mat = steel();
    let mut rng = Lcg(3);
    let mut curved = straight_tet10(&VERTS);
    for node in curved.iter_mut().skip(4) {
        let u = rng.unit();
        for d in 0..3 {
            node[d] += 0.06 * u[d];
        }
    }
    for (kind, coords) in [
        (TetKind::Tet4, VERTS.to_vec()),
        (TetKind::Tet10, straight_tet10(&VERTS)),
        (TetKind::Tet10, curved),
    ] {
        let (k, m) = matrices(kind, &coords, &mat);
        let n = 3 * kind.nodes_per_element();
        for p in 0..n {
            for q in 0..n {
                assert_eq!(
                    k[p * n + q].to_bits(),
                    k[q * n + p].to_bits(),
                    "K not symmetric at ({p}, {q})"
                );
                assert_eq!(
                    m[p * n + q].to_bits(),
                    m[q * n + p].to_bits(),
                    "M not symmetric at ({p}, {q})"
                );
            }
        }
        let kmax = k.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for r in common::rigid_body_modes(&coords) {
            let rn = common::norm(&r);
            for p in 0..n {
                let f: f64 = (0..n).map(|q| k[p * n + q] * r[q]).sum();
                // Isoparametric elements reproduce rigid motions exactly: zero strain at
                // every point, so K r vanishes up to round-off of n-term sums (~n eps).
                assert!(f.abs() < 1e-13 * kmax * rn, "{kind:?}: (K r)_{p} = {f:e}");
            }
        }
    }
}

#[test]
fn linear_field_energy_is_exact_on_curved_elements() {
    // u = G x is reproduced exactly by the isoparametric interpolation, so the strain is
    // uniform and u^T K u = V eps^T D eps with V the exact element volume. This checks the
    // curved stiffness (Jacobian at each point, the rule ladder) against the material law
    // and the volume integral; round-off only (1e-12 relative).
    let mat = Isotropic::new(1e6, 0.25, 1.0).expect("valid");
    let g = [
        [1.0e-3, 2.0e-4, -3.0e-4],
        [5.0e-4, -1.0e-3, 4.0e-4],
        [1.0e-4, 6.0e-4, 2.0e-3],
    ];
    let eps = [
        g[0][0],
        g[1][1],
        g[2][2],
        g[1][2] + g[2][1],
        g[0][2] + g[2][0],
        g[0][1] + g[1][0],
    ];
    let sigma = mat.stress(&eps);
    let energy_density: f64 = eps.iter().zip(&sigma).map(|(a, b)| a * b).sum();
    let mut rng = Lcg(11);
    for offset in [0.0, 0.01, 0.05, 0.1] {
        let mut coords = straight_tet10(&VERTS);
        for node in coords.iter_mut().skip(4) {
            let u = rng.unit();
            for d in 0..3 {
                node[d] += offset * u[d];
            }
        }
        let (k, _) = matrices(TetKind::Tet10, &coords, &mat);
        let u: Vec<f64> = coords
            .iter()
            .flat_map(|x| (0..3).map(move |i| (0..3).map(|j| g[i][j] * x[j]).sum::<f64>()))
            .collect();
        let e: f64 = (0..30)
            .map(|p| (0..30).map(|q| u[p] * k[p * 30 + q] * u[q]).sum::<f64>())
            .sum();
        let exact = element_volume(TetKind::Tet10, &coords) * energy_density;
        assert!(
            (e - exact).abs() < 1e-12 * exact,
            "offset {offset}: {e} vs {exact}"
        );
        // strain and stress helpers at an interior point
        let s =
            nlmodes_fem::element::stress_at(TetKind::Tet10, &coords, &u, &mat, [0.2, 0.3, 0.1], 1)
                .expect("valid");
        for c in 0..6 {
            assert!(
                (s[c] - sigma[c]).abs() < 1e-12 * sigma.iter().fold(0.0f64, |a, b| a.max(b.abs()))
            );
        }
    }
}

#[test]
fn inverted_and_degenerate_elements_are_errors_naming_the_tag() {
    let mat = steel();
    let n = 30;
    let (mut k, mut m) = (vec![0.0; n * n], vec![0.0; n * n]);
    // Swap vertices 1 and 2 (and the mid-edge nodes follow the swapped vertices): det J < 0.
    let swapped = [VERTS[0], VERTS[2], VERTS[1], VERTS[3]];
    let err = element_matrices(
        TetKind::Tet10,
        &straight_tet10(&swapped),
        &mat,
        42,
        &mut k,
        &mut m,
    )
    .expect_err("inverted");
    assert!(
        matches!(err, FemError::InvertedElement { element_tag: 42, det_j, .. } if det_j < 0.0),
        "{err}"
    );
    assert!(err.to_string().contains("element 42"), "{err}");
    // A mid-edge node pushed past the opposite side folds the element at some points.
    let mut folded = straight_tet10(&VERTS);
    folded[4] = [0.65, 0.05, 1.5];
    let err =
        element_matrices(TetKind::Tet10, &folded, &mat, 43, &mut k, &mut m).expect_err("folded");
    assert!(
        matches!(
            err,
            FemError::InvertedElement {
                element_tag: 43,
                ..
            }
        ),
        "{err}"
    );
    // Nearly flat: the fourth vertex 1e-12 above the plane of the others.
    let flat = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.3, 0.3, 1e-12],
    ];
    let err = element_matrices(TetKind::Tet4, &flat, &mat, 44, &mut k, &mut m).expect_err("flat");
    assert!(
        matches!(
            err,
            FemError::DegenerateElement {
                element_tag: 44,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn curved_mesh_element_matrices_converge_to_affine_ones_as_curvature_vanishes() {
    // Continuity across the affine / curved switch: a mesh curved by 1e-9 of the edge
    // (curved path, ladder rules) and the straight one (affine rules) give stiffnesses that
    // differ by O(1e-9) relative, not by a quadrature-rule artefact.
    let mat = steel();
    let straight = box_mesh([1.0, 1.0, 1.0], [1, 1, 1], TetKind::Tet10).expect("valid");
    let mut bent = straight.clone();
    curve_mid_edge_nodes(&mut bent, 1e-9, 5);
    let mut coords_s = [[0.0; 3]; 10];
    let mut coords_b = [[0.0; 3]; 10];
    for e in 0..straight.n_elements() {
        straight.element_coords_into(e, &mut coords_s);
        bent.element_coords_into(e, &mut coords_b);
        let (ks, ms) = matrices(TetKind::Tet10, &coords_s, &mat);
        let (kb, mb) = matrices(TetKind::Tet10, &coords_b, &mat);
        let dk: Vec<f64> = ks.iter().zip(&kb).map(|(a, b)| a - b).collect();
        let dm: Vec<f64> = ms.iter().zip(&mb).map(|(a, b)| a - b).collect();
        assert!(frobenius(&dk) < 1e-8 * frobenius(&ks));
        assert!(frobenius(&dm) < 1e-8 * frobenius(&ms));
    }
    // The same element through the generic entry point with the 4-point rule.
    let tab = TabulatedRule::new(TetKind::Tet10, TetRule::four_point());
    let mut k = vec![0.0; 900];
    straight.element_coords_into(0, &mut coords_s);
    stiffness_with_rule(&coords_s, mat.lame(), &tab, 1, &mut k).expect("valid");
    let (ks, _) = matrices(TetKind::Tet10, &coords_s, &mat);
    assert_eq!(k, ks);
}
