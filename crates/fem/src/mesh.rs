//! The mesh model: nodes, tetrahedra of one kind, named physical groups.

use crate::element;
use crate::error::FemError;
pub use crate::tet_kind::TetKind;

/// A named physical group of any dimension (0 = points, 1 = curves, 2 = surfaces, 3 = volumes).
#[derive(Clone, Debug, PartialEq)]
pub struct PhysicalGroup {
    /// Name from `$PhysicalNames` (the tag as text when the group has no name).
    pub name: String,
    /// Dimension 0..=3.
    pub dim: usize,
    /// gmsh physical tag.
    pub tag: i32,
    /// Nodes of the group's elements: sorted, unique, 0-based indices into `Mesh::nodes`.
    pub nodes: Vec<usize>,
    /// The triangles of a surface group (dim 2), flat: [`TetKind::nodes_per_face`] 0-based node
    /// indices each (TRI3 on a TET4 mesh, TRI6 on a TET10 mesh), gmsh order (corners, then the
    /// mid-edge nodes of edges 0-1, 1-2, 2-0), orientation as stored (not necessarily outward).
    /// Empty for the other dimensions and for groups built without their surface elements.
    pub triangles: Vec<usize>,
}

/// A tetrahedral mesh (all TET4 or all TET10) with named groups.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Node coordinates (m).
    pub nodes: Vec<[f64; 3]>,
    /// Element kind of every volume element.
    pub kind: TetKind,
    /// Flat connectivity, `nodes_per_element` 0-based node indices per tetrahedron, gmsh order.
    pub connectivity: Vec<usize>,
    /// gmsh element tag of each tetrahedron (for error messages).
    pub element_tags: Vec<usize>,
    /// Physical groups.
    pub groups: Vec<PhysicalGroup>,
}

impl Mesh {
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Number of tetrahedra.
    pub fn n_elements(&self) -> usize {
        self.connectivity.len() / self.kind.nodes_per_element()
    }

    /// 0-based node indices of element `i` (panics if `i >= n_elements()`, like slice indexing).
    pub fn element(&self, i: usize) -> &[usize] {
        let npe = self.kind.nodes_per_element();
        &self.connectivity[i * npe..(i + 1) * npe]
    }

    /// Coordinates of the nodes of element `i`, written into `out[..nodes_per_element]`.
    pub fn element_coords_into(&self, i: usize, out: &mut [[f64; 3]]) {
        for (o, &n) in out.iter_mut().zip(self.element(i)) {
            *o = self.nodes[n];
        }
    }

    /// gmsh tag of element `i` (its index when `element_tags` is empty).
    pub fn element_tag(&self, i: usize) -> usize {
        self.element_tags.get(i).copied().unwrap_or(i)
    }

    /// The group called `name`. The error lists the groups present.
    pub fn group(&self, name: &str) -> Result<&PhysicalGroup, FemError> {
        let mut found = self.groups.iter().filter(|g| g.name == name);
        match (found.next(), found.next()) {
            (Some(g), None) => Ok(g),
            (Some(_), Some(_)) => Err(FemError::AmbiguousGroup {
                name: name.to_string(),
                dims: self
                    .groups
                    .iter()
                    .filter(|g| g.name == name)
                    .map(|g| g.dim)
                    .collect(),
            }),
            (None, _) => Err(FemError::UnknownGroup {
                name: name.to_string(),
                available: self.group_list(),
            }),
        }
    }

    /// "name (dim d), ..." for messages; "(none)" when there are no groups.
    pub fn group_list(&self) -> String {
        if self.groups.is_empty() {
            return "(none)".to_string();
        }
        self.groups
            .iter()
            .map(|g| format!("'{}' (dim {})", g.name, g.dim))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Total volume (m^3): sum of the integrals of det J over the elements with the 14-point
    /// degree-5 rule, exact for TET10 (det J is cubic) even with curved edges.
    pub fn volume(&self) -> f64 {
        let npe = self.kind.nodes_per_element();
        let mut coords = [[0.0; 3]; 10];
        (0..self.n_elements())
            .map(|e| {
                self.element_coords_into(e, &mut coords);
                element::element_volume(self.kind, &coords[..npe])
            })
            .sum()
    }

    /// Checks internal consistency: connectivity length a multiple of the element size, node
    /// indices in range, one tag per element (or none), finite coordinates, group nodes sorted,
    /// unique and in range.
    pub fn validate(&self) -> Result<(), FemError> {
        let npe = self.kind.nodes_per_element();
        if !self.connectivity.len().is_multiple_of(npe) {
            return Err(FemError::InvalidMesh(format!(
                "connectivity has {} entries, not a multiple of {npe} ({:?})",
                self.connectivity.len(),
                self.kind
            )));
        }
        let n = self.nodes.len();
        if !self.element_tags.is_empty() && self.element_tags.len() != self.n_elements() {
            return Err(FemError::InvalidMesh(format!(
                "{} element tags for {} elements",
                self.element_tags.len(),
                self.n_elements()
            )));
        }
        for e in 0..self.n_elements() {
            if let Some(&bad) = self.element(e).iter().find(|&&v| v >= n) {
                return Err(FemError::InvalidMesh(format!(
                    "element {} refers to node index {bad}, but there are {n} nodes",
                    self.element_tag(e)
                )));
            }
        }
        for (i, x) in self.nodes.iter().enumerate() {
            if !x.iter().all(|v| v.is_finite()) {
                return Err(FemError::NonFiniteCoordinate {
                    node: i,
                    coords: *x,
                });
            }
        }
        let npf = self.kind.nodes_per_face();
        for g in &self.groups {
            let in_range = g.triangles.iter().all(|&v| v < n);
            if !g.triangles.len().is_multiple_of(npf)
                || !in_range
                || (g.dim != 2 && !g.triangles.is_empty())
            {
                return Err(FemError::InvalidMesh(format!(
                    "group '{}' (dim {}): triangles must belong to a dim-2 group, {npf} node indices < {n} each",
                    g.name, g.dim
                )));
            }
            let sorted = g.nodes.windows(2).all(|w| w[0] < w[1]);
            if !sorted || g.nodes.last().is_some_and(|&v| v >= n) || g.dim > 3 {
                return Err(FemError::InvalidMesh(format!(
                    "group '{}' (dim {}) must have dim <= 3 and sorted unique node indices < {n}",
                    g.name, g.dim
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_groups() -> Mesh {
        Mesh {
            nodes: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            kind: TetKind::Tet4,
            connectivity: vec![0, 1, 2, 3],
            element_tags: vec![7],
            groups: vec![
                PhysicalGroup {
                    name: "root".into(),
                    dim: 2,
                    tag: 1,
                    nodes: vec![0, 1, 2],
                    triangles: vec![0, 2, 1],
                },
                PhysicalGroup {
                    name: "tip_edge".into(),
                    dim: 0,
                    tag: 2,
                    nodes: vec![3],
                    triangles: Vec::new(),
                },
            ],
        }
    }

    #[test]
    fn group_lookup_and_unknown_group_lists_names() {
        let m = two_groups();
        assert_eq!(m.group("tip_edge").expect("present").nodes, vec![3]);
        let msg = m.group("casing").expect_err("absent").to_string();
        assert!(
            msg.contains("casing")
                && msg.contains("'root' (dim 2)")
                && msg.contains("'tip_edge' (dim 0)"),
            "{msg}"
        );
    }

    #[test]
    fn duplicate_names_are_ambiguous() {
        let mut m = two_groups();
        m.groups[1].name = "root".into();
        let msg = m.group("root").expect_err("ambiguous").to_string();
        assert!(msg.contains("root") && msg.contains("[2, 0]"), "{msg}");
    }

    #[test]
    fn unit_tet_volume_and_validation() {
        let m = two_groups();
        assert!(m.validate().is_ok());
        // 1/6 exactly up to round-off of a 14-term sum.
        assert!((m.volume() - 1.0 / 6.0).abs() < 1e-15);
        let mut bad = m.clone();
        bad.connectivity[3] = 9;
        assert!(bad
            .validate()
            .expect_err("out of range")
            .to_string()
            .contains("node index 9"));
        let mut bad = m;
        bad.nodes[2][1] = f64::NAN;
        assert!(matches!(
            bad.validate(),
            Err(FemError::NonFiniteCoordinate { node: 2, .. })
        ));
    }
}
