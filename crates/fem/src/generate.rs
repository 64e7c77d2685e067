//! Small structured meshes built in code (no gmsh needed): for tests and examples, here and in
//! the other crates (e.g. a cantilever beam for the modal analysis).

use std::collections::HashMap;

use crate::error::FemError;
use crate::mesh::{Mesh, PhysicalGroup};
use crate::shape::TET10_EDGES;
use crate::tet_kind::TetKind;

/// Splits a hexahedron into 6 tetrahedra along its main diagonal (Kuhn / Freudenthal split).
///
/// `hex[b]` is the vertex with local bits b = bx + 2 by + 4 bz (bx, by, bz in {0, 1}). Each
/// tetrahedron follows a monotone path 000 -> 111 in local coordinates, so every face is cut
/// along the diagonal joining its local-min and local-max vertices. Neighbouring hexahedra
/// whose local axes increase in the same global directions therefore cut their shared face
/// alike: the split is conforming. Orientation is not fixed here (see [`orient_positive`]).
pub fn kuhn_split(hex: [usize; 8]) -> [[usize; 4]; 6] {
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    PERMS.map(|p| {
        let b1 = 1 << p[0];
        let b2 = b1 | (1 << p[1]);
        [hex[0], hex[b1], hex[b2], hex[7]]
    })
}

/// Six times the signed volume of the tetrahedron (a, b, c, d).
pub fn signed_volume6(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

/// Swaps vertices 1 and 2 of a TET4 if its signed volume is negative.
pub fn orient_positive(nodes: &[[f64; 3]], tet: [usize; 4]) -> [usize; 4] {
    let [a, b, c, d] = tet;
    if signed_volume6(nodes[a], nodes[b], nodes[c], nodes[d]) < 0.0 {
        [a, c, b, d]
    } else {
        tet
    }
}

/// Converts a TET4 mesh to TET10 with straight edges: one new node at the midpoint of every
/// edge (shared between the elements of the edge), appended after the existing nodes, gmsh
/// order. Groups of dimension 0 are unchanged; a group of dimension >= 1 gains the mid-edge
/// node of every edge with both ends in the group (right for the planar faces of convex
/// bodies and for volume groups); a surface group's TRI3 become TRI6 on the same mid-edge nodes.
pub fn tet4_to_tet10(mesh: &Mesh) -> Result<Mesh, FemError> {
    if mesh.kind != TetKind::Tet4 {
        return Err(FemError::InvalidMesh(
            "tet4_to_tet10 expects a TET4 mesh".into(),
        ));
    }
    mesh.validate()?;
    let mut nodes = mesh.nodes.clone();
    let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
    let mut connectivity = Vec::with_capacity(mesh.n_elements() * 10);
    for e in 0..mesh.n_elements() {
        let v = mesh.element(e);
        connectivity.extend_from_slice(v);
        for &(a, b) in &TET10_EDGES {
            let key = (v[a].min(v[b]), v[a].max(v[b]));
            let id = *mid.entry(key).or_insert_with(|| {
                let (p, q) = (mesh.nodes[key.0], mesh.nodes[key.1]);
                nodes.push([
                    0.5 * (p[0] + q[0]),
                    0.5 * (p[1] + q[1]),
                    0.5 * (p[2] + q[2]),
                ]);
                nodes.len() - 1
            });
            connectivity.push(id);
        }
    }
    let mut edges: Vec<((usize, usize), usize)> = mid.into_iter().collect();
    edges.sort_unstable();
    let groups = mesh
        .groups
        .iter()
        .map(|g| {
            let mut g = g.clone();
            g.triangles = tri3_to_tri6(&g.triangles, &edges)?;
            if g.dim >= 1 {
                for &((a, b), m) in &edges {
                    if g.nodes.binary_search(&a).is_ok() && g.nodes.binary_search(&b).is_ok() {
                        g.nodes.push(m);
                    }
                }
                g.nodes.sort_unstable();
                g.nodes.dedup();
            }
            Ok(g)
        })
        .collect::<Result<_, FemError>>()?;
    Ok(Mesh {
        nodes,
        kind: TetKind::Tet10,
        connectivity,
        element_tags: mesh.element_tags.clone(),
        groups,
    })
}

/// TRI3 triangles (flat) as TRI6 (corners, then the mid-edge nodes of edges 0-1, 1-2, 2-0), the
/// mid-edge nodes looked up in the sorted (edge, node) list; an edge that no tetrahedron has is
/// an error.
fn tri3_to_tri6(tri3: &[usize], edges: &[((usize, usize), usize)]) -> Result<Vec<usize>, FemError> {
    let mid = |a: usize, b: usize| {
        let key = (a.min(b), a.max(b));
        edges
            .binary_search_by_key(&key, |&(e, _)| e)
            .map(|i| edges[i].1)
            .map_err(|_| {
                FemError::InvalidMesh(format!("triangle edge {key:?} is no tetrahedron's edge"))
            })
    };
    let mut out = Vec::with_capacity(2 * tri3.len());
    for t in tri3.chunks_exact(3) {
        out.extend_from_slice(t);
        out.extend([mid(t[0], t[1])?, mid(t[1], t[2])?, mid(t[2], t[0])?]);
    }
    Ok(out)
}

/// The box [0, size_x] x [0, size_y] x [0, size_z] (m) cut into `cells` hexahedra, each split
/// into 6 tetrahedra ([`kuhn_split`]), TET4 or TET10 (straight edges). Element tags are 1..
/// Groups (dim 2): `xmin`, `xmax`, `ymin`, `ymax`, `zmin`, `zmax`; (dim 3): `volume`.
pub fn box_mesh(size: [f64; 3], cells: [usize; 3], kind: TetKind) -> Result<Mesh, FemError> {
    if cells.contains(&0) || size.iter().any(|&s| !(s.is_finite() && s > 0.0)) {
        return Err(FemError::InvalidMesh(format!(
            "box_mesh needs positive sizes and cell counts, got {size:?} and {cells:?}"
        )));
    }
    let [nx, ny, nz] = cells;
    let id = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1) * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([
                    size[0] * i as f64 / nx as f64,
                    size[1] * j as f64 / ny as f64,
                    size[2] * k as f64 / nz as f64,
                ]);
            }
        }
    }
    let mut connectivity = Vec::with_capacity(24 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let hex = std::array::from_fn(|b| {
                    id(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1))
                });
                for tet in kuhn_split(hex) {
                    connectivity.extend_from_slice(&orient_positive(&nodes, tet));
                }
            }
        }
    }
    let n_elements = connectivity.len() / 4;
    let mut tet4 = Mesh {
        nodes,
        kind: TetKind::Tet4,
        connectivity,
        element_tags: (1..=n_elements).collect(),
        groups: Vec::new(),
    };
    tet4.groups = box_groups(&tet4, size);
    let mesh = match kind {
        TetKind::Tet4 => tet4,
        TetKind::Tet10 => tet4_to_tet10(&tet4)?,
    };
    mesh.validate()?;
    Ok(mesh)
}

/// The groups of [`box_mesh`] on its TET4 mesh: the six faces (nodes on the plane, and the
/// boundary faces of the tetrahedra on it as TRI3, in the tetrahedra's vertex order) and the
/// volume.
fn box_groups(tet4: &Mesh, size: [f64; 3]) -> Vec<PhysicalGroup> {
    let mut count: HashMap<[usize; 3], (usize, [usize; 3])> = HashMap::new();
    for e in 0..tet4.n_elements() {
        let v = tet4.element(e);
        for face in [
            [v[1], v[2], v[3]],
            [v[0], v[3], v[2]],
            [v[0], v[1], v[3]],
            [v[0], v[2], v[1]],
        ] {
            let mut key = face;
            key.sort_unstable();
            count.entry(key).or_insert((0, face)).0 += 1;
        }
    }
    let mut boundary: Vec<[usize; 3]> = count
        .into_values()
        .filter(|(c, _)| *c == 1)
        .map(|(_, f)| f)
        .collect();
    boundary.sort_unstable();
    let mut groups = Vec::new();
    let names = [["xmin", "xmax"], ["ymin", "ymax"], ["zmin", "zmax"]];
    for (d, pair) in names.iter().enumerate() {
        for (side, name) in pair.iter().enumerate() {
            let target = if side == 0 { 0.0 } else { size[d] };
            let tol = 1e-12 * size[d];
            let on = |v: usize| (tet4.nodes[v][d] - target).abs() <= tol;
            groups.push(PhysicalGroup {
                name: (*name).to_string(),
                dim: 2,
                tag: (2 * d + side + 1) as i32,
                nodes: (0..tet4.n_nodes()).filter(|&v| on(v)).collect(),
                triangles: boundary
                    .iter()
                    .filter(|f| f.iter().all(|&v| on(v)))
                    .flatten()
                    .copied()
                    .collect(),
            });
        }
    }
    groups.push(PhysicalGroup {
        name: "volume".to_string(),
        dim: 3,
        tag: 7,
        nodes: (0..tet4.n_nodes()).collect(),
        triangles: Vec::new(),
    });
    groups
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_counts_volume_and_faces() {
        for kind in [TetKind::Tet4, TetKind::Tet10] {
            let m = box_mesh([2.0, 1.0, 0.5], [3, 2, 2], kind).expect("valid");
            assert_eq!(m.n_elements(), 6 * 12);
            let expected_nodes = match kind {
                TetKind::Tet4 => 4 * 3 * 3,
                // The Kuhn split's edges are the cube edges, face diagonals and main diagonal,
                // whose midpoints make up the grid refined twice.
                TetKind::Tet10 => 7 * 5 * 5,
            };
            assert_eq!(m.n_nodes(), expected_nodes);
            // Exact volume 1 up to round-off of 72 element sums.
            assert!((m.volume() - 1.0).abs() < 1e-14);
            let xmin = m.group("xmin").expect("face");
            let per_face = if kind == TetKind::Tet4 { 9 } else { 25 };
            assert_eq!(xmin.nodes.len(), per_face);
            for e in 0..m.n_elements() {
                let v = m.element(e);
                let x = |i: usize| m.nodes[v[i]];
                assert!(signed_volume6(x(0), x(1), x(2), x(3)) > 0.0);
            }
        }
        assert!(box_mesh([1.0, 1.0, 0.0], [1, 1, 1], TetKind::Tet4).is_err());
    }
}
