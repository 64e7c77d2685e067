//! Errors of the finite-element front end.
//!
//! Every message names what it is about (the file, the physical group, the element tag, the
//! value) and what was expected, so that a user can fix the input without reading the code.

use std::path::PathBuf;

/// Errors returned by `nlmodes-fem`.
#[derive(Debug, thiserror::Error)]
pub enum FemError {
    /// The mesh file could not be read from disk.
    #[error("cannot read mesh file '{}': {source}", path.display())]
    Io {
        /// The file that was asked for.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The file does not start with a `$MeshFormat` section: it is not a gmsh MSH file.
    #[error("'{}' is not a gmsh MSH file: {reason}", path.display())]
    NotMsh {
        /// The file.
        path: PathBuf,
        /// What was found instead.
        reason: String,
    },

    /// The file is a gmsh MSH file of a version other than 4.1.
    #[error(
        "'{}' is in MSH format version {found}; only MSH 4.1 (ASCII or binary) is supported \
         (re-export it with `gmsh ... -format msh41`)",
        path.display()
    )]
    UnsupportedMshVersion {
        /// The file.
        path: PathBuf,
        /// The version string found in `$MeshFormat`, e.g. `"2.2"`.
        found: String,
    },

    /// The MSH 4.1 content is malformed.
    #[error("cannot parse MSH file '{}': {message}", path.display())]
    MshParse {
        /// The file.
        path: PathBuf,
        /// What went wrong and where (line, section).
        message: String,
    },

    /// The file holds no tetrahedra (gmsh types 4 or 11).
    #[error(
        "'{}' contains no tetrahedra (gmsh element type 4 = TET4 or 11 = TET10); \
         did you mesh in 3D (`gmsh -3`) and define a Physical Volume?",
        path.display()
    )]
    NoTetrahedra {
        /// The file.
        path: PathBuf,
    },

    /// A volume element block holds an element type other than TET4/TET10.
    #[error(
        "'{}': volume entity {entity_tag} holds elements of unsupported gmsh type {gmsh_type} \
         ({type_name}); only tetrahedra of type 4 (TET4) or 11 (TET10) are supported",
        path.display()
    )]
    UnsupportedVolumeElement {
        /// The file.
        path: PathBuf,
        /// The gmsh element type number.
        gmsh_type: i32,
        /// A readable name of that type.
        type_name: String,
        /// The gmsh entity holding the elements.
        entity_tag: i32,
    },

    /// The volume mixes TET4 and TET10.
    #[error(
        "'{}' mixes TET4 (gmsh type 4) and TET10 (gmsh type 11) volume elements; \
         mesh with a single order (`-order 1` or `-order 2`)",
        path.display()
    )]
    MixedVolumeElements {
        /// The file.
        path: PathBuf,
    },

    /// An element refers to a node tag absent from `$Nodes`.
    #[error("'{}': element {element_tag} refers to node tag {node_tag}, which is not in $Nodes", path.display())]
    UnknownNodeTag {
        /// The file.
        path: PathBuf,
        /// gmsh tag of the element.
        element_tag: usize,
        /// The missing node tag.
        node_tag: usize,
    },

    /// A physical group holds a node that belongs to no tetrahedron.
    #[error(
        "'{}': physical group '{group}' holds node tag {node_tag}, which belongs to no tetrahedron \
         of the volume mesh",
        path.display()
    )]
    GroupNodeOutsideVolume {
        /// The file.
        path: PathBuf,
        /// Group name.
        group: String,
        /// gmsh node tag.
        node_tag: usize,
    },

    /// A surface group holds 2-D elements that are not the faces of the volume's tetrahedra.
    #[error(
        "'{}': surface group '{group}' holds elements of gmsh type {gmsh_type} ({type_name}); \
         the faces of a {kind:?} mesh are gmsh type {expected} triangles",
        path.display()
    )]
    UnsupportedSurfaceElement {
        /// The file.
        path: PathBuf,
        /// Group name.
        group: String,
        /// The gmsh type found.
        gmsh_type: i32,
        /// A readable name of that type.
        type_name: String,
        /// The gmsh type expected (2 = TRI3, 9 = TRI6).
        expected: i32,
        /// The volume's element kind.
        kind: crate::tet_kind::TetKind,
    },

    /// A group given as a surface (a pressure load) is not one: wrong dimension, or no triangles.
    #[error(
        "physical group '{name}' (dim {dim}) is not a surface of triangles: {reason}; groups \
         present: {available}"
    )]
    NotASurface {
        /// The group's name.
        name: String,
        /// Its dimension.
        dim: usize,
        /// What is wrong.
        reason: String,
        /// The groups of the mesh, with their dimensions.
        available: String,
    },

    /// A triangle of a surface group is not the face of exactly one tetrahedron.
    #[error(
        "surface group '{group}': the triangle on nodes {nodes:?} (0-based) is a face of \
         {owners} tetrahedra; a surface load needs boundary faces, each the face of exactly one \
         tetrahedron (with matching mid-edge nodes on TET10)"
    )]
    SurfaceNotOnBoundary {
        /// The group's name.
        group: String,
        /// The triangle's nodes (0-based).
        nodes: Vec<usize>,
        /// How many tetrahedra have it as a face.
        owners: usize,
    },

    /// A physical group name was asked for that the mesh does not have.
    #[error("no physical group named '{name}'; groups present: {available}")]
    UnknownGroup {
        /// The requested name.
        name: String,
        /// The names present, with their dimensions, comma-separated.
        available: String,
    },

    /// Two physical groups of different dimensions share a name.
    #[error(
        "physical group name '{name}' is used by groups of dimensions {dims:?}; rename one of them"
    )]
    AmbiguousGroup {
        /// The shared name.
        name: String,
        /// Their dimensions.
        dims: Vec<usize>,
    },

    /// The Jacobian determinant is not positive at a quadrature point.
    #[error(
        "element {element_tag} is inverted: det J = {det_j:e} <= 0 at reference point \
         ({:.4}, {:.4}, {:.4}) (check node ordering / curved mid-edge nodes)",
        point[0], point[1], point[2]
    )]
    InvertedElement {
        /// gmsh tag of the element.
        element_tag: usize,
        /// The Jacobian determinant found (m^3 per unit reference volume).
        det_j: f64,
        /// Reference coordinates (xi, eta, zeta) of the quadrature point.
        point: [f64; 3],
    },

    /// The Jacobian determinant is positive but negligible relative to h^3.
    #[error(
        "element {element_tag} is degenerate (flat): det J = {det_j:e} at reference point \
         ({:.4}, {:.4}, {:.4}) is below {threshold:e} x h^3 with longest edge h = {h:e}",
        point[0], point[1], point[2]
    )]
    DegenerateElement {
        /// gmsh tag of the element.
        element_tag: usize,
        /// The Jacobian determinant found.
        det_j: f64,
        /// Longest vertex-to-vertex edge length (m).
        h: f64,
        /// Relative threshold used.
        threshold: f64,
        /// Reference coordinates of the quadrature point.
        point: [f64; 3],
    },

    /// A material constant is out of its admissible range (or not finite).
    #[error("invalid material: {parameter} = {value}; expected {expected}")]
    InvalidMaterial {
        /// Which constant.
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// The admissible range.
        expected: &'static str,
    },

    /// A node of a mesh file has a non-finite coordinate.
    #[error("{path}: node {node_tag} has a non-finite coordinate {coords:?}: every coordinate must be a finite number (m)")]
    MshNonFiniteCoordinate {
        /// The file.
        path: PathBuf,
        /// The node's tag in the file.
        node_tag: u64,
        /// Its coordinates.
        coords: [f64; 3],
    },

    /// A node appears twice in one point (dimension 0) physical group: two point elements of the
    /// group share a mesh node, so the group has fewer distinct nodes than point elements.
    #[error(
        "{path}: node {node_tag} appears in {count} point elements of the physical group '{group}' \
         (dim 0): each point of the group must be its own mesh node (merge or remove the duplicated points)"
    )]
    DuplicateGroupNode {
        /// The file.
        path: PathBuf,
        /// The group's name.
        group: String,
        /// The node's tag in the file.
        node_tag: u64,
        /// How many point elements of the group hold it.
        count: usize,
    },

    /// A node has a non-finite coordinate (a mesh built in code; files report
    /// [`FemError::MshNonFiniteCoordinate`] with the node tag).
    #[error("node {node} (0-based) has a non-finite coordinate {coords:?}")]
    NonFiniteCoordinate {
        /// 0-based node index.
        node: usize,
        /// Its coordinates.
        coords: [f64; 3],
    },

    /// A Dirichlet specification could not be parsed.
    #[error("invalid constraint '{spec}': {reason} (expected GROUP or GROUP:COMPONENTS, e.g. 'root' or 'bottom:z' or 'root:xy')")]
    InvalidFixSpec {
        /// The text given.
        spec: String,
        /// What is wrong.
        reason: String,
    },

    /// A fixed DOF is out of range.
    #[error("fixed DOF (node {node}, component {component}) is out of range: the mesh has {n_nodes} nodes and components are 0, 1, 2")]
    InvalidFixedDof {
        /// 0-based node index.
        node: usize,
        /// Component (0 = x, 1 = y, 2 = z).
        component: usize,
        /// Number of nodes.
        n_nodes: usize,
    },

    /// A matrix or vector does not have the size the DOF map expects.
    #[error("{what} has size {found}, expected {expected}")]
    DimensionMismatch {
        /// What was passed.
        what: &'static str,
        /// Its size.
        found: usize,
        /// The size expected.
        expected: usize,
    },

    /// A mesh built in code is inconsistent.
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
}
