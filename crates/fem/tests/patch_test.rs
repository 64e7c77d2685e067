//! MacNeal-Harder solid patch test (MacNeal & Harder 1985; DESIGN 4): unit cube, 8 interior
//! nodes forming a distorted inner hexahedron, 6 hexahedra joining its faces to the cube's,
//! each hexahedron split into 6 tetrahedra. A linear displacement imposed on the boundary must
//! be reproduced exactly everywhere, with uniform strain 1e-3 and stresses 2000 / 400.

// Index loops mirror the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

mod common;

use std::collections::HashMap;

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use nlmodes_fem::element::stress_at;
use nlmodes_fem::generate::{kuhn_split, orient_positive, tet4_to_tet10};
use nlmodes_fem::{assemble, Isotropic, Mesh, TetKind, TetRule};

/// Interior nodes of the MacNeal-Harder patch (DESIGN 4).
const INTERIOR: [[f64; 3]; 8] = [
    [0.249, 0.342, 0.192],
    [0.826, 0.288, 0.288],
    [0.850, 0.649, 0.263],
    [0.273, 0.750, 0.230],
    [0.320, 0.186, 0.643],
    [0.677, 0.305, 0.683],
    [0.788, 0.693, 0.644],
    [0.165, 0.745, 0.702],
];

/// Exact displacement field (m): u = 1e-3 (2x + y + z)/2, v = 1e-3 (x + 2y + z)/2,
/// w = 1e-3 (x + y + 2z)/2.
fn exact(x: [f64; 3]) -> [f64; 3] {
    [
        1e-3 * (2.0 * x[0] + x[1] + x[2]) / 2.0,
        1e-3 * (x[0] + 2.0 * x[1] + x[2]) / 2.0,
        1e-3 * (x[0] + x[1] + 2.0 * x[2]) / 2.0,
    ]
}

/// Sorted faces of a set of tetrahedra that appear once (the boundary of their union).
fn outer_faces(tets: &[[usize; 4]]) -> Vec<[usize; 3]> {
    let mut count: HashMap<[usize; 3], usize> = HashMap::new();
    for t in tets {
        for skip in 0..4 {
            let mut f = [0; 3];
            let mut k = 0;
            for (i, &v) in t.iter().enumerate() {
                if i != skip {
                    f[k] = v;
                    k += 1;
                }
            }
            f.sort_unstable();
            *count.entry(f).or_insert(0) += 1;
        }
    }
    count
        .into_iter()
        .filter(|&(_, c)| c == 1)
        .map(|(f, _)| f)
        .collect()
}

/// Splits each hexahedron into 6 tetrahedra along one of its 4 main diagonals (Kuhn split
/// after relabelling the corners so that the chosen diagonal runs from local 000 to 111), the
/// diagonals chosen so that neighbouring hexahedra cut their shared faces alike: exhaustive
/// search over the 4^7 combinations, keeping the first in which every face triangle of every
/// hexahedron is either on the cube boundary or matched by the neighbour.
fn conforming_split(hexes: &[[usize; 8]], nodes: &[[f64; 3]]) -> Vec<[usize; 4]> {
    // Per hexahedron, per diagonal choice: its 6 tetrahedra and its 12 face triangles.
    type Split = (Vec<[usize; 4]>, Vec<[usize; 3]>);
    let options: Vec<Vec<Split>> = hexes
        .iter()
        .map(|hex| {
            (0..4)
                .map(|c| {
                    let relabelled: [usize; 8] = std::array::from_fn(|b| hex[b ^ c]);
                    let tets = kuhn_split(relabelled).to_vec();
                    let faces = outer_faces(&tets);
                    (tets, faces)
                })
                .collect()
        })
        .collect();
    let on_boundary = |f: &[usize; 3]| {
        (0..3)
            .any(|d| f.iter().all(|&n| nodes[n][d] == 0.0) || f.iter().all(|&n| nodes[n][d] == 1.0))
    };
    for combo in 0..4usize.pow(hexes.len() as u32) {
        let choice: Vec<usize> = (0..hexes.len()).map(|h| (combo >> (2 * h)) & 3).collect();
        let mut count: HashMap<[usize; 3], usize> = HashMap::new();
        for (h, &c) in choice.iter().enumerate() {
            for f in &options[h][c].1 {
                *count.entry(*f).or_insert(0) += 1;
            }
        }
        if count
            .iter()
            .all(|(f, &n)| n == 2 || (n == 1 && on_boundary(f)))
        {
            return choice
                .iter()
                .enumerate()
                .flat_map(|(h, &c)| options[h][c].0.clone())
                .collect();
        }
    }
    panic!("no conforming choice of main diagonals");
}

/// The 7-hexahedron patch split into 42 TET4.
///
/// Nodes live on a 4x4x4 "lattice": outer corners at lattice coordinates in {0, 3}, interior
/// nodes in {1, 2}; the hexahedra are the inner one and the six joining its faces to the
/// cube's. Conformity of the split is checked independently by the first test.
fn patch_tet4() -> Mesh {
    let mut nodes = Vec::new();
    let mut id: HashMap<[usize; 3], usize> = HashMap::new();
    for k in [0, 3] {
        for j in [0, 3] {
            for i in [0, 3] {
                id.insert([i, j, k], nodes.len());
                nodes.push([i as f64 / 3.0, j as f64 / 3.0, k as f64 / 3.0]);
            }
        }
    }
    for x in INTERIOR {
        let lattice = x.map(|c| if c < 0.5 { 1 } else { 2 });
        assert!(
            id.insert(lattice, nodes.len()).is_none(),
            "interior node table is not a hexahedron"
        );
        nodes.push(x);
    }
    let mut hexes: Vec<[usize; 8]> = Vec::new();
    hexes.push(std::array::from_fn(|b| {
        id[&[1 + (b & 1), 1 + ((b >> 1) & 1), 1 + ((b >> 2) & 1)]]
    }));
    for d in 0..3 {
        for plus in [false, true] {
            hexes.push(std::array::from_fn(|b| {
                let bits = [b & 1, (b >> 1) & 1, (b >> 2) & 1];
                let outer = if plus { bits[d] == 1 } else { bits[d] == 0 };
                let mut l = [0; 3];
                for e in 0..3 {
                    l[e] = if outer { 3 * bits[e] } else { 1 + bits[e] };
                }
                l[d] = match (plus, outer) {
                    (false, true) => 0,
                    (false, false) => 1,
                    (true, false) => 2,
                    (true, true) => 3,
                };
                id[&l]
            }));
        }
    }
    let mut connectivity = Vec::new();
    for tet in conforming_split(&hexes, &nodes) {
        connectivity.extend_from_slice(&orient_positive(&nodes, tet));
    }
    let n_el = connectivity.len() / 4;
    Mesh {
        nodes,
        kind: TetKind::Tet4,
        connectivity,
        element_tags: (1..=n_el).collect(),
        groups: Vec::new(),
    }
}

fn on_cube_boundary(x: [f64; 3]) -> bool {
    x.iter()
        .any(|&c| c.abs() < 1e-12 || (c - 1.0).abs() < 1e-12)
}

#[test]
fn patch_is_a_conforming_tetrahedrization_of_the_cube() {
    let mesh = patch_tet4();
    assert_eq!(mesh.n_elements(), 42);
    // Volume 1 up to round-off; every element positively oriented with a sensible volume.
    let vol = mesh.volume();
    let mut faces: HashMap<[usize; 3], usize> = HashMap::new();
    for e in 0..mesh.n_elements() {
        let v = mesh.element(e);
        let x = |i: usize| mesh.nodes[v[i]];
        assert!(nlmodes_fem::generate::signed_volume6(x(0), x(1), x(2), x(3)) > 1e-3);
        for skip in 0..4 {
            let mut f: Vec<usize> = (0..4).filter(|&i| i != skip).map(|i| v[i]).collect();
            f.sort_unstable();
            *faces.entry([f[0], f[1], f[2]]).or_insert(0) += 1;
        }
    }
    // Conforming: every face is shared by two tetrahedra, except faces on the cube boundary
    // (one tetrahedron), and the boundary faces tile the 6 unit squares: 6 x 2 triangles.
    let mut boundary = 0;
    for (f, count) in &faces {
        let on_face = (0..3).any(|d| {
            let c: Vec<f64> = f.iter().map(|&n| mesh.nodes[n][d]).collect();
            c.iter().all(|&v| v == 0.0) || c.iter().all(|&v| v == 1.0)
        });
        match (count, on_face) {
            (1, true) => boundary += 1,
            (2, false) => {}
            _ => panic!("face {f:?} used {count} times (on the boundary: {on_face})"),
        }
    }
    assert_eq!(boundary, 12);
    assert!((vol - 1.0).abs() < 1e-14, "volume {vol}");
}

fn run_patch(mesh: &Mesh) {
    let mat = Isotropic::new(1e6, 0.25, 1.0).expect("valid");
    let (k, _) = assemble(mesh, &mat).expect("valid patch");
    let n = mesh.n_nodes();
    let fixed: Vec<bool> = mesh.nodes.iter().map(|&x| on_cube_boundary(x)).collect();
    let free: Vec<usize> = (0..3 * n).filter(|&g| !fixed[g / 3]).collect();
    let mut u = vec![0.0; 3 * n];
    for (i, &x) in mesh.nodes.iter().enumerate() {
        if fixed[i] {
            u[3 * i..3 * i + 3].copy_from_slice(&exact(x));
        }
    }
    // K_ff u_f = -K_fb u_b, dense Cholesky.
    let kd = common::dense(&k);
    let kff = Mat::<f64>::from_fn(free.len(), free.len(), |i, j| kd[free[i]][free[j]]);
    let rhs = Mat::<f64>::from_fn(free.len(), 1, |i, _| {
        -(0..3 * n)
            .filter(|&g| fixed[g / 3])
            .map(|g| kd[free[i]][g] * u[g])
            .sum::<f64>()
    });
    let sol = kff.llt(Side::Lower).expect("K_ff is SPD").solve(&rhs);
    for (i, &g) in free.iter().enumerate() {
        u[g] = sol[(i, 0)];
    }
    // All nodal displacements exact. The solve's round-off is about cond(K_ff) eps |u| with
    // cond ~1e3 here: 1e-10 relative to |u|max = 2e-3 m is ample and far below any
    // consistency error (a failing patch test is off by O(1e-2) relative).
    for (i, &x) in mesh.nodes.iter().enumerate() {
        let e = exact(x);
        for d in 0..3 {
            assert!(
                (u[3 * i + d] - e[d]).abs() < 1e-10 * 2e-3,
                "node {i} comp {d}: {} vs {}",
                u[3 * i + d],
                e[d]
            );
        }
    }
    // Strains 1e-3 and stresses (2000, 2000, 2000, 400, 400, 400) Pa at every quadrature point
    // of the 4- and 14-point rules in every element, 1e-9 relative.
    let npe = mesh.kind.nodes_per_element();
    let mut points = TetRule::four_point().points;
    points.extend(TetRule::fourteen_point().points);
    let mut coords = [[0.0; 3]; 10];
    for e in 0..mesh.n_elements() {
        mesh.element_coords_into(e, &mut coords);
        let ue: Vec<f64> = mesh
            .element(e)
            .iter()
            .flat_map(|&v| u[3 * v..3 * v + 3].to_vec())
            .collect();
        for &xi in &points {
            let strain = nlmodes_fem::element::strain_at(mesh.kind, &coords[..npe], &ue, xi, e)
                .expect("valid");
            for s in strain {
                assert!(
                    (s - 1e-3).abs() < 1e-9 * 1e-3,
                    "element {e}: strain {strain:?}"
                );
            }
            let sigma = stress_at(mesh.kind, &coords[..npe], &ue, &mat, xi, e).expect("valid");
            let expected = [2000.0, 2000.0, 2000.0, 400.0, 400.0, 400.0];
            for (s, x) in sigma.iter().zip(expected) {
                assert!(
                    (s - x).abs() < 1e-9 * 2000.0,
                    "element {e}: stress {sigma:?}"
                );
            }
        }
    }
}

#[test]
fn tet4_patch_test() {
    let mesh = patch_tet4();
    // Only the 8 cube corners are on the boundary.
    assert_eq!(
        mesh.nodes.iter().filter(|&&x| on_cube_boundary(x)).count(),
        8
    );
    run_patch(&mesh);
}

#[test]
fn tet10_patch_test() {
    let mesh = tet4_to_tet10(&patch_tet4()).expect("valid");
    assert_eq!(mesh.kind, TetKind::Tet10);
    run_patch(&mesh);
}
