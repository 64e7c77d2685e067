//! Global assembly of the rotation terms, with the DOF numbering (3 * node + component) and the
//! CSC pattern of [`crate::assemble`]: a full 3x3 block for every pair of nodes sharing an
//! element, both triangles stored, rows sorted.
//!
//! Element contributions are computed in parallel (rayon) chunk by chunk and scattered
//! sequentially in element order, so the result is deterministic and a matrix assembled from
//! exactly symmetric element matrices is exactly symmetric.

use rayon::prelude::*;
use sprs::CsMat;

use crate::assembly::NodeAdjacency;
use crate::error::FemError;
use crate::mesh::Mesh;
use crate::rotation::element_ref::ElementRef;

/// Elements per parallel chunk.
const CHUNK: usize = 256;

/// The CSC structure of the 3n x 3n DOF pattern of a mesh.
#[derive(Clone, Debug)]
pub struct BlockPattern {
    adjacency: NodeAdjacency,
    indptr: Vec<usize>,
    indices: Vec<usize>,
}

impl BlockPattern {
    /// Builds the pattern of `mesh` (assumed valid).
    pub fn new(mesh: &Mesh) -> Self {
        let adjacency = NodeAdjacency::new(mesh);
        let n = mesh.n_nodes();
        let mut indptr = Vec::with_capacity(3 * n + 1);
        let mut indices = Vec::with_capacity(9 * adjacency.adjacency.len());
        indptr.push(0);
        for v in 0..n {
            for _ in 0..3 {
                for &a in adjacency.neighbours(v) {
                    indices.extend_from_slice(&[3 * a, 3 * a + 1, 3 * a + 2]);
                }
                indptr.push(indices.len());
            }
        }
        BlockPattern {
            adjacency,
            indptr,
            indices,
        }
    }

    /// Number of global DOFs, 3 n.
    pub fn n_dofs(&self) -> usize {
        self.indptr.len() - 1
    }

    /// Index in the value array of entry (3 a + i, 3 b + j), a and b adjacent nodes.
    fn position(&self, a: usize, i: usize, b: usize, j: usize) -> usize {
        let k = self
            .adjacency
            .neighbours(b)
            .binary_search(&a)
            .expect("nodes of one element are adjacent");
        self.indptr[3 * b + j] + 3 * k + i
    }
}

/// What an element routine fills: the element vector (3 npe) and the element matrix
/// ((3 npe)^2, row-major); either may be left untouched if not wanted.
pub type ElementRoutine<'f> =
    dyn Fn(usize, &ElementRef<'_>, &mut [f64], &mut [f64]) -> Result<(), FemError> + Sync + 'f;

/// A global vector (length 3n) and matrix (3n x 3n), each present when asked for.
pub type Assembled = (Option<Vec<f64>>, Option<CsMat<f64>>);

/// Assembles a global vector (length 3n) and/or matrix (3n x 3n CSC with `pattern`) from the
/// element routine `routine(e, element, vector, matrix)`. Errors: the first failing element in
/// mesh order.
pub fn assemble_global(
    mesh: &Mesh,
    pattern: &BlockPattern,
    want_vector: bool,
    want_matrix: bool,
    routine: &ElementRoutine<'_>,
) -> Result<Assembled, FemError> {
    let n = 3 * mesh.kind.nodes_per_element();
    let ne = mesh.n_elements();
    let mut vector = vec![0.0; pattern.n_dofs()];
    let mut values = vec![
        0.0;
        if want_matrix {
            pattern.indices.len()
        } else {
            0
        }
    ];
    let mut v_buf = vec![0.0; CHUNK * n];
    let mut m_buf = vec![0.0; if want_matrix { CHUNK * n * n } else { 0 }];
    let mut first = 0;
    while first < ne {
        let count = CHUNK.min(ne - first);
        let m_chunks: Vec<&mut [f64]> = if want_matrix {
            m_buf[..count * n * n].chunks_mut(n * n).collect()
        } else {
            (0..count).map(|_| &mut [][..]).collect()
        };
        compute_chunk(mesh, first, &mut v_buf[..count * n], m_chunks, routine)?;
        for i in 0..count {
            let nodes = mesh.element(first + i);
            if want_vector {
                scatter_vector(nodes, &v_buf[i * n..(i + 1) * n], &mut vector);
            }
            if want_matrix {
                let me = &m_buf[i * n * n..(i + 1) * n * n];
                scatter_matrix(pattern, nodes, me, &mut values);
            }
        }
        first += count;
    }
    let matrix = if want_matrix {
        let nd = pattern.n_dofs();
        let (indptr, indices) = (pattern.indptr.clone(), pattern.indices.clone());
        let m = CsMat::try_new_csc((nd, nd), indptr, indices, values)
            .map_err(|(_, _, _, e)| FemError::InvalidMesh(format!("rotation pattern: {e}")))?;
        Some(m)
    } else {
        None
    };
    Ok((want_vector.then_some(vector), matrix))
}

/// Runs `routine` on the elements `first..` (one per chunk of `v_buf` and entry of `m_chunks`)
/// in parallel, buffers zeroed first; the first failing element in mesh order is the error.
fn compute_chunk(
    mesh: &Mesh,
    first: usize,
    v_buf: &mut [f64],
    m_chunks: Vec<&mut [f64]>,
    routine: &ElementRoutine<'_>,
) -> Result<(), FemError> {
    let (kind, npe) = (mesh.kind, mesh.kind.nodes_per_element());
    let failure = v_buf
        .par_chunks_mut(3 * npe)
        .zip(m_chunks)
        .enumerate()
        .filter_map(|(i, (ve, me))| {
            let e = first + i;
            let mut coords = [[0.0; 3]; 10];
            mesh.element_coords_into(e, &mut coords);
            ve.fill(0.0);
            me.fill(0.0);
            let element = ElementRef {
                kind,
                coords: &coords[..npe],
                tag: mesh.element_tag(e),
            };
            routine(e, &element, ve, me).err().map(|err| (e, err))
        })
        .min_by_key(|(e, _)| *e);
    match failure {
        Some((_, err)) => Err(err),
        None => Ok(()),
    }
}

fn scatter_vector(nodes: &[usize], ve: &[f64], out: &mut [f64]) {
    for (la, &a) in nodes.iter().enumerate() {
        for i in 0..3 {
            out[3 * a + i] += ve[3 * la + i];
        }
    }
}

fn scatter_matrix(pattern: &BlockPattern, nodes: &[usize], me: &[f64], values: &mut [f64]) {
    let n = 3 * nodes.len();
    for (lb, &b) in nodes.iter().enumerate() {
        for (la, &a) in nodes.iter().enumerate() {
            for j in 0..3 {
                let start = pattern.position(a, 0, b, j);
                for i in 0..3 {
                    values[start + i] += me[(3 * la + i) * n + 3 * lb + j];
                }
            }
        }
    }
}

/// Gathers the element DOFs of a global vector (3 n) for element `e`.
pub fn gather(mesh: &Mesh, e: usize, global: &[f64], out: &mut [f64]) {
    for (la, &a) in mesh.element(e).iter().enumerate() {
        out[3 * la..3 * la + 3].copy_from_slice(&global[3 * a..3 * a + 3]);
    }
}
