//! The element kinds of a mesh (TET4, TET10), on their own so that the element formulas and
//! the mesh can both name them without importing each other.

/// Tetrahedral element kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TetKind {
    /// 4-node linear tetrahedron (gmsh type 4).
    Tet4,
    /// 10-node quadratic tetrahedron (gmsh type 11), possibly curved.
    Tet10,
}

impl TetKind {
    /// Nodes per element: 4 or 10.
    pub fn nodes_per_element(self) -> usize {
        match self {
            TetKind::Tet4 => 4,
            TetKind::Tet10 => 10,
        }
    }

    /// Nodes per boundary triangle: 3 (TRI3, gmsh type 2) or 6 (TRI6, gmsh type 9).
    pub fn nodes_per_face(self) -> usize {
        match self {
            TetKind::Tet4 => 3,
            TetKind::Tet10 => 6,
        }
    }

    /// gmsh element type number: 4 or 11.
    pub fn gmsh_type(self) -> i32 {
        match self {
            TetKind::Tet4 => 4,
            TetKind::Tet10 => 11,
        }
    }
}
