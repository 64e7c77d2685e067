//! Consistent nodal loads of a uniform pressure on a surface group.
//!
//! For a pressure p (Pa) on a surface S of the solid, the consistent nodal force of node i is
//!
//! f_i = -p ∫_S N_i n dA   (N),
//!
//! with n the unit normal pointing out of the solid: a positive pressure pushes into the solid
//! (the convention of code_aster `PRES_REP` and CalculiX `*DLOAD ... P`). Since the N_i sum to
//! one, the total force is -p ∫_S n dA, and since x = sum_i N_i x_i (isoparametric), the moment
//! sum_i x_i × f_i is -p ∫_S x × n dA: over a closed surface both vanish.
//!
//! **Which triangles.** The surface is the group's own 2-D elements as the MSH reader keeps
//! them ([`PhysicalGroup::triangles`]: TRI3 on a TET4 mesh, TRI6 on a TET10 mesh), not the
//! boundary faces of the tetrahedra whose nodes all belong to the group: node membership is
//! ambiguous where the group meets the rest of the boundary (a boundary face of a coarse TET4
//! mesh whose three vertices lie on the group's rim is not part of the group, yet all its nodes
//! are), while the surface elements are exactly the faces gmsh meshed on the physical surface.
//! Each triangle must be the face of exactly one tetrahedron (a boundary face; on TET10 with the
//! same mid-edge nodes): it is oriented by that tetrahedron, so that n points away from the
//! tetrahedron's fourth vertex, whatever the orientation of the stored triangle.
//!
//! **Quadrature.** On the reference triangle, n dA = (x_,xi × x_,eta) dxi deta. For TRI6
//! (isoparametric, curved faces allowed) the tangents are linear, their cross product
//! quadratic and N_i quadratic: the integrand is a polynomial of degree 4 in (xi, eta), and the
//! moment check x × n too; for TRI3 it is of degree 1 (2 for the moment). The collapsed
//! (conical product) rule of 3 × 3 points, Gauss-Legendre times Gauss-Jacobi (1 - x), is exact to
//! degree 5: the loads are exact on straight and curved faces.

use std::collections::HashMap;

use crate::error::FemError;
use crate::gauss_jacobi::gauss_jacobi;
use crate::mesh::{Mesh, PhysicalGroup};
use crate::shape::TET10_EDGES;
use crate::tet_kind::TetKind;

/// Points (xi, eta) and weights of the 9-point collapsed rule on the reference triangle
/// (0,0), (1,0), (0,1) (area 1/2), exact for polynomials of degree <= 5.
pub fn triangle_rule() -> Vec<([f64; 2], f64)> {
    let (a, wa) = gauss_jacobi(3, 0);
    let (b, wb) = gauss_jacobi(3, 1);
    let mut rule = Vec::with_capacity(9);
    for (bj, wbj) in b.iter().zip(&wb) {
        for (ai, wai) in a.iter().zip(&wa) {
            let eta = 0.5 * (1.0 + bj);
            let xi = 0.5 * (1.0 + ai) * (1.0 - eta);
            // d(xi, eta) = (1 - b) / 8 d(a, b); the (1 - b) is Gauss-Jacobi's weight.
            rule.push(([xi, eta], wai * wbj / 8.0));
        }
    }
    rule
}

/// Shape functions of the TRI3 (3 values) or TRI6 (6) triangle at (xi, eta) and their
/// derivatives with respect to xi and eta, gmsh order (mid-edge nodes of 0-1, 1-2, 2-0).
fn triangle_shape(npf: usize, xi: f64, eta: f64) -> ([f64; 6], [f64; 6], [f64; 6]) {
    let l = [1.0 - xi - eta, xi, eta];
    let dl = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
    let (mut n, mut dxi, mut deta) = ([0.0; 6], [0.0; 6], [0.0; 6]);
    if npf == 3 {
        n[..3].copy_from_slice(&l);
        for i in 0..3 {
            (dxi[i], deta[i]) = (dl[i][0], dl[i][1]);
        }
        return (n, dxi, deta);
    }
    for i in 0..3 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
        let f = 4.0 * l[i] - 1.0;
        (dxi[i], deta[i]) = (f * dl[i][0], f * dl[i][1]);
    }
    for (k, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
        n[3 + k] = 4.0 * l[a] * l[b];
        dxi[3 + k] = 4.0 * (dl[a][0] * l[b] + l[a] * dl[b][0]);
        deta[3 + k] = 4.0 * (dl[a][1] * l[b] + l[a] * dl[b][1]);
    }
    (n, dxi, deta)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The surface group `name`: a dim-2 group with triangles, else [`FemError::NotASurface`]
/// naming it and listing the mesh's groups (an unknown name is [`FemError::UnknownGroup`]).
pub fn surface_group<'m>(mesh: &'m Mesh, name: &str) -> Result<&'m PhysicalGroup, FemError> {
    let g = mesh.group(name)?;
    let reason = if g.dim != 2 {
        Some("a pressure acts on a surface group (dim 2)".to_string())
    } else if g.triangles.is_empty() {
        Some("it holds no triangles (a mesh read from MSH keeps them)".to_string())
    } else {
        None
    };
    match reason {
        None => Ok(g),
        Some(reason) => Err(FemError::NotASurface {
            name: name.to_string(),
            dim: g.dim,
            reason,
            available: mesh.group_list(),
        }),
    }
}

/// The triangles of surface group `name` (flat, [`TetKind::nodes_per_face`] nodes each), each
/// oriented so that (x1 - x0) × (x2 - x0) points out of the tetrahedron it is a face of.
/// Errors: not a surface group ([`surface_group`]), or a triangle that is not the face of exactly
/// one tetrahedron ([`FemError::SurfaceNotOnBoundary`]).
pub fn outward_triangles(mesh: &Mesh, name: &str) -> Result<Vec<usize>, FemError> {
    let group = surface_group(mesh, name)?;
    let npf = mesh.kind.nodes_per_face();
    let key = |t: &[usize]| {
        let mut k = [t[0], t[1], t[2]];
        k.sort_unstable();
        k
    };
    // The tetrahedra (element, opposite local vertex) of which each triangle is a face.
    let mut owners: HashMap<[usize; 3], Vec<(usize, usize)>> = group
        .triangles
        .chunks_exact(npf)
        .map(|t| (key(t), Vec::new()))
        .collect();
    for e in 0..mesh.n_elements() {
        let v = mesh.element(e);
        for opp in 0..4 {
            let face: Vec<usize> = (0..4).filter(|&j| j != opp).map(|j| v[j]).collect();
            if let Some(list) = owners.get_mut(&key(&face)) {
                list.push((e, opp));
            }
        }
    }
    let mut out = Vec::with_capacity(group.triangles.len());
    for t in group.triangles.chunks_exact(npf) {
        let found = &owners[&key(t)];
        let [(e, opp)] = found[..] else {
            return Err(not_on_boundary(name, t, found.len()));
        };
        if !mid_nodes_match(mesh, e, t) {
            return Err(not_on_boundary(name, t, 0));
        }
        let x = |i: usize| mesh.nodes[i];
        let normal = cross(sub(x(t[1]), x(t[0])), sub(x(t[2]), x(t[0])));
        let away = sub(x(t[0]), x(mesh.element(e)[opp]));
        if dot(normal, away) > 0.0 {
            out.extend_from_slice(t);
        } else if npf == 3 {
            out.extend([t[0], t[2], t[1]]);
        } else {
            out.extend([t[0], t[2], t[1], t[5], t[4], t[3]]);
        }
    }
    Ok(out)
}

fn not_on_boundary(group: &str, t: &[usize], owners: usize) -> FemError {
    FemError::SurfaceNotOnBoundary {
        group: group.to_string(),
        nodes: t.to_vec(),
        owners,
    }
}

/// On TET10, the triangle's mid-edge nodes are those of element `e`'s edges (always true on
/// TET4).
fn mid_nodes_match(mesh: &Mesh, e: usize, t: &[usize]) -> bool {
    if mesh.kind == TetKind::Tet4 {
        return true;
    }
    let v = mesh.element(e);
    [(0, 1, 3), (1, 2, 4), (2, 0, 5)].iter().all(|&(a, b, m)| {
        TET10_EDGES.iter().enumerate().any(|(k, &(i, j))| {
            let same = (v[i] == t[a] && v[j] == t[b]) || (v[i] == t[b] && v[j] == t[a]);
            same && v[4 + k] == t[m]
        })
    })
}

/// Calls `visit(node, N_node, n dA)` for every node of every oriented triangle at every
/// quadrature point, n dA (m^2) the outward area vector of the point's weight.
fn for_each_weighted_normal(
    mesh: &Mesh,
    triangles: &[usize],
    mut visit: impl FnMut(usize, f64, [f64; 3]),
) {
    let npf = mesh.kind.nodes_per_face();
    let rule = triangle_rule();
    for t in triangles.chunks_exact(npf) {
        for &([xi, eta], w) in &rule {
            let (n, dxi, deta) = triangle_shape(npf, xi, eta);
            let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
            for (k, &node) in t.iter().enumerate() {
                for d in 0..3 {
                    a[d] += dxi[k] * mesh.nodes[node][d];
                    b[d] += deta[k] * mesh.nodes[node][d];
                }
            }
            let c = cross(a, b);
            let nda = [w * c[0], w * c[1], w * c[2]];
            for (k, &node) in t.iter().enumerate() {
                visit(node, n[k], nda);
            }
        }
    }
}

/// The consistent nodal forces (N) of a uniform pressure `pressure` (Pa, positive into the
/// solid) on the surface group `name`: a vector of 3 × `mesh.n_nodes()` entries, node-major
/// (x, y, z of node 0, then node 1, ...), f_i = -p ∫ N_i n dA; zero off the surface.
pub fn pressure_load(mesh: &Mesh, name: &str, pressure: f64) -> Result<Vec<f64>, FemError> {
    let triangles = outward_triangles(mesh, name)?;
    let mut f = vec![0.0; 3 * mesh.n_nodes()];
    for_each_weighted_normal(mesh, &triangles, |node, n, nda| {
        for d in 0..3 {
            f[3 * node + d] -= pressure * n * nda[d];
        }
    });
    Ok(f)
}

/// ∫ n dA (m^2) over the surface group `name`, n outward: the total force of a pressure p is
/// -p times it.
pub fn area_vector(mesh: &Mesh, name: &str) -> Result<[f64; 3], FemError> {
    let triangles = outward_triangles(mesh, name)?;
    let mut s = [0.0; 3];
    // The N_i sum to one at each point: sum N_i n dA over the nodes.
    for_each_weighted_normal(mesh, &triangles, |_, n, nda| {
        for d in 0..3 {
            s[d] += n * nda[d];
        }
    });
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::box_mesh;

    const FACES: [(&str, usize, f64); 6] = [
        ("xmin", 0, -1.0),
        ("xmax", 0, 1.0),
        ("ymin", 1, -1.0),
        ("ymax", 1, 1.0),
        ("zmin", 2, -1.0),
        ("zmax", 2, 1.0),
    ];
    const SIZE: [f64; 3] = [2.0, 1.0, 0.5];

    /// x -> Q x + t with Q a rotation (about (1, 2, 3), 0.7 rad), as a 3 × 3 matrix.
    fn rotation() -> [[f64; 3]; 3] {
        let k = [1.0, 2.0, 3.0].map(|v: f64| v / 14f64.sqrt());
        let (s, c) = 0.7f64.sin_cos();
        let mut q = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let cross_ij = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]][i][j];
                q[i][j] = c * f64::from(u8::from(i == j)) + s * cross_ij + (1.0 - c) * k[i] * k[j];
            }
        }
        q
    }

    fn apply(q: &[[f64; 3]; 3], x: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| dot(q[i], x) + [0.3, -0.2, 1.1][i])
    }

    /// The box, moved rigidly, with every other stored triangle reversed (the orientation must
    /// come from the tetrahedra, not from the file).
    fn moved_box(kind: TetKind) -> Mesh {
        let mut m = box_mesh(SIZE, [3, 2, 2], kind).expect("box");
        let q = rotation();
        m.nodes.iter_mut().for_each(|x| *x = apply(&q, *x));
        let npf = kind.nodes_per_face();
        for g in &mut m.groups {
            for t in g.triangles.chunks_exact_mut(npf).step_by(2) {
                t.swap(1, 2);
                if npf == 6 {
                    t.swap(3, 5);
                }
            }
        }
        m
    }

    fn total(f: &[f64]) -> [f64; 3] {
        let mut s = [0.0; 3];
        for (i, v) in f.iter().enumerate() {
            s[i % 3] += v;
        }
        s
    }

    fn moment(mesh: &Mesh, f: &[f64], about: [f64; 3]) -> [f64; 3] {
        let mut m = [0.0; 3];
        for (i, x) in mesh.nodes.iter().enumerate() {
            let r = cross(sub(*x, about), [f[3 * i], f[3 * i + 1], f[3 * i + 2]]);
            (0..3).for_each(|d| m[d] += r[d]);
        }
        m
    }

    fn norm(v: [f64; 3]) -> f64 {
        dot(v, v).sqrt()
    }

    #[test]
    fn triangle_rule_is_exact_to_degree_5() {
        // int xi^a eta^b = a! b! / (a + b + 2)!; 9 terms of size <= 1/2: 1e-15 is round-off, and
        // degree 6 is missed (the test can fail).
        let fact = |n: u32| (1..=n).map(f64::from).product::<f64>();
        let rule = triangle_rule();
        for deg in 0..=6u32 {
            for a in 0..=deg {
                let b = deg - a;
                let q: f64 = rule
                    .iter()
                    .map(|([x, y], w)| w * x.powi(a as i32) * y.powi(b as i32))
                    .sum();
                let exact = fact(a) * fact(b) / fact(a + b + 2);
                let err = (q - exact).abs() / exact;
                if deg <= 5 {
                    assert!(err < 1e-14, "xi^{a} eta^{b}: {q} vs {exact}");
                } else if a == 0 {
                    assert!(err > 1e-6, "eta^6 is beyond the rule");
                }
            }
        }
    }

    #[test]
    fn flat_faces_carry_minus_p_area_normal_and_every_triangle_points_out() {
        // Every face of a rotated box, TET4 and TET10, half the triangles stored reversed:
        // sum f = -p A n with A the face's area and n its outward normal. Sums of a few hundred
        // terms of size p A: 1e-14 relative is round-off.
        let p = 2.5e5;
        let q = rotation();
        for kind in [TetKind::Tet4, TetKind::Tet10] {
            let mesh = moved_box(kind);
            for (name, d, sign) in FACES {
                let area = SIZE.iter().product::<f64>() / SIZE[d];
                let n: [f64; 3] = std::array::from_fn(|i| sign * q[i][d]);
                let f = pressure_load(&mesh, name, p).expect("face");
                let s = total(&f);
                let want = n.map(|v| -p * area * v);
                assert!(
                    norm(sub(s, want)) < 1e-14 * p * area,
                    "{kind:?} {name}: {s:?} vs {want:?}"
                );
                let av = area_vector(&mesh, name).expect("face");
                assert!(norm(sub(av, n.map(|v| area * v))) < 1e-14 * area, "{name}");
                let x = |i: usize| mesh.nodes[i];
                let tris = outward_triangles(&mesh, name).expect("face");
                for t in tris.chunks_exact(kind.nodes_per_face()) {
                    let c = cross(sub(x(t[1]), x(t[0])), sub(x(t[2]), x(t[0])));
                    assert!(dot(c, n) > 0.99 * norm(c), "{kind:?} {name} triangle {t:?}");
                }
            }
        }
    }

    /// A smooth non-affine map of the box: its TET10 faces become curved (mid-edge nodes mapped
    /// too, isoparametric), the TET4 faces stay flat triangles of a warped polyhedron.
    fn warp(x: [f64; 3]) -> [f64; 3] {
        [
            x[0] + 0.1 * (1.3 * x[1]).sin() + 0.05 * x[2] * x[2],
            x[1] + 0.08 * (0.9 * x[0]).cos() * x[2],
            x[2] + 0.06 * x[0] * x[1] + 0.04 * (2.0 * x[0]).sin(),
        ]
    }

    #[test]
    fn a_closed_surface_has_zero_net_force_and_moment() {
        // The six faces of a warped box close the solid: -p ∮ n dA = 0 and -p ∮ x × n dA = 0,
        // exactly for the isoparametric surface when the rule integrates N_i n dA exactly
        // (degree 4 on curved TRI6). Relative to p A (force) and p A L (moment), 1e-13 is
        // round-off of a few thousand terms; one face alone is far from zero (the check can fail).
        let p = 1e6;
        for kind in [TetKind::Tet4, TetKind::Tet10] {
            let mut mesh = box_mesh(SIZE, [3, 2, 2], kind).expect("box");
            mesh.nodes.iter_mut().for_each(|x| *x = warp(*x));
            let mut f = vec![0.0; 3 * mesh.n_nodes()];
            for (name, _, _) in FACES {
                let g = pressure_load(&mesh, name, p).expect("face");
                f.iter_mut().zip(&g).for_each(|(a, b)| *a += b);
            }
            let scale = p * 7.0; // p times the unwarped total area 2 (2 + 1 + 0.5) = 7 m^2
            assert!(
                norm(total(&f)) < 1e-13 * scale,
                "{kind:?} force {:?}",
                total(&f)
            );
            for about in [[0.0; 3], [5.0, -3.0, 2.0], [-1.0, 0.5, 10.0]] {
                let m = moment(&mesh, &f, about);
                assert!(
                    norm(m) < 1e-13 * scale * 10.0,
                    "{kind:?} moment about {about:?}: {m:?}"
                );
            }
            let one = pressure_load(&mesh, "xmax", p).expect("face");
            assert!(norm(total(&one)) > 0.1 * p * 0.5, "{kind:?}");
        }
    }

    #[test]
    fn tri6_flat_face_corners_get_zero_and_midsides_a_third() {
        // The classical result for a flat, straight TRI6 under uniform pressure: int N_corner dA
        // = 0 and int N_mid dA = A / 3. Checked node by node on every face of the TET10 box:
        // vertex nodes carry nothing, a mid-edge node -p n sum(A_t / 3) over its triangles.
        let p = 3.0e4;
        let q = rotation();
        let mesh = moved_box(TetKind::Tet10);
        for (name, d, sign) in FACES {
            let n: [f64; 3] = std::array::from_fn(|i| sign * q[i][d]);
            let f = pressure_load(&mesh, name, p).expect("face");
            let mut want = vec![0.0; 3 * mesh.n_nodes()];
            let tris = &mesh.group(name).expect("face").triangles;
            for t in tris.chunks_exact(6) {
                let x = |i: usize| mesh.nodes[t[i]];
                let a = 0.5 * norm(cross(sub(x(1), x(0)), sub(x(2), x(0))));
                for &m in &t[3..] {
                    (0..3).for_each(|c| want[3 * m + c] -= p * a / 3.0 * n[c]);
                }
            }
            let area = SIZE.iter().product::<f64>() / SIZE[d];
            let worst = f
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-15 * p * area, "{name}: {worst:e}");
            let corners: f64 = tris
                .chunks_exact(6)
                .flat_map(|t| &t[..3])
                .map(|&v| norm([f[3 * v], f[3 * v + 1], f[3 * v + 2]]))
                .sum();
            assert!(
                corners < 1e-15 * p * area * 10.0,
                "{name}: corners carry {corners:e}"
            );
        }
    }

    #[test]
    fn tet4_and_tet10_faces_carry_the_same_total() {
        // Same flat faces (the box under a shear, then rotated): TRI3 and TRI6 distribute the
        // load differently but their totals agree to round-off.
        let q = rotation();
        let shear = |x: [f64; 3]| [x[0] + 0.4 * x[1] - 0.2 * x[2], x[1] + 0.3 * x[2], x[2]];
        let meshes = [TetKind::Tet4, TetKind::Tet10].map(|k| {
            let mut m = box_mesh(SIZE, [3, 2, 2], k).expect("box");
            m.nodes.iter_mut().for_each(|x| *x = apply(&q, shear(*x)));
            m
        });
        for (name, _, _) in FACES {
            let [a, b] = [&meshes[0], &meshes[1]]
                .map(|m| total(&pressure_load(m, name, 1.0).expect("face")));
            assert!(norm(sub(a, b)) < 1e-14 * norm(a), "{name}: {a:?} vs {b:?}");
            assert!(norm(a) > 0.4, "{name}");
        }
    }

    #[test]
    fn groups_that_are_not_boundary_surfaces_are_errors() {
        let mut mesh = box_mesh(SIZE, [2, 2, 2], TetKind::Tet4).expect("box");
        let msg = pressure_load(&mesh, "volume", 1.0)
            .expect_err("dim 3")
            .to_string();
        assert!(
            msg.contains("'volume' (dim 3)") && msg.contains("'xmin' (dim 2)"),
            "{msg}"
        );
        let msg = pressure_load(&mesh, "casing", 1.0)
            .expect_err("absent")
            .to_string();
        assert!(
            msg.contains("casing") && msg.contains("'zmax' (dim 2)"),
            "{msg}"
        );
        // An interior face (shared by two tetrahedra) has no outward side.
        let v = mesh.element(0).to_vec();
        let interior = (0..4)
            .map(|opp| {
                (0..4)
                    .filter(|&j| j != opp)
                    .map(|j| v[j])
                    .collect::<Vec<_>>()
            })
            .find(|face| {
                face.iter().any(|&n| {
                    mesh.nodes[n]
                        .iter()
                        .zip(SIZE)
                        .all(|(x, s)| *x > 0.0 && *x < s)
                })
            })
            .expect("element 0 touches the box centre");
        mesh.groups[0].triangles = interior;
        let err = pressure_load(&mesh, "xmin", 1.0).expect_err("interior");
        assert!(
            matches!(err, FemError::SurfaceNotOnBoundary { owners: 2, .. }),
            "{err}"
        );
    }
}
