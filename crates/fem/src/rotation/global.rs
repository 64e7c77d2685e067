//! Global assembly of the rotation terms, with the DOF numbering (3 * node + component) and the
//! CSC pattern of [`crate::assemble`]: a full 3x3 block for every pair of nodes sharing an
//! element, both triangles stored, rows sorted.
//!
//! Element contributions, with their positions in the value array, are computed in parallel
//! (rayon) chunk by chunk, then scattered in parallel into disjoint column ranges of the value
//! array (the node partitions of [`crate::assemble`]), each entry summed in element order: the
//! sums of a sequential scatter in element order, bit for bit. The result is deterministic, and
//! a matrix assembled from exactly symmetric element matrices is exactly symmetric. Element
//! matrices need not be symmetric (the Coriolis matrix is skew): column 3 b + j of an element
//! matrix is read as such.

use rayon::prelude::*;
use sprs::CsMat;

use crate::assembly::{split_by_nodes, NodeAdjacency, PARTITION_ENTRIES};
use crate::error::FemError;
use crate::mesh::Mesh;
use crate::rotation::element_ref::ElementRef;

/// Elements per parallel chunk (a TET10 element matrix is 7 kB: 7.4 MB of buffers).
const CHUNK: usize = 1024;

/// The CSC structure of the 3n x 3n DOF pattern of a mesh, and its node partitions for the
/// parallel scatter.
#[derive(Clone, Debug)]
pub struct BlockPattern {
    adjacency: NodeAdjacency,
    indptr: Vec<usize>,
    indices: Vec<usize>,
    /// Node ranges `bounds[p]..bounds[p + 1]` of the scatter's column partitions.
    bounds: Vec<usize>,
    /// The partition of each node.
    part_of_node: Vec<u32>,
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
        let bounds = adjacency.partition(PARTITION_ENTRIES);
        let mut part_of_node = vec![0u32; n];
        for (p, w) in bounds.windows(2).enumerate() {
            part_of_node[w[0]..w[1]].fill(p as u32);
        }
        BlockPattern {
            adjacency,
            indptr,
            indices,
            bounds,
            part_of_node,
        }
    }

    /// Number of global DOFs, 3 n.
    pub fn n_dofs(&self) -> usize {
        self.indptr.len() - 1
    }

    /// Number of column partitions of the scatter.
    fn n_parts(&self) -> usize {
        self.bounds.len() - 1
    }
}

/// What an element routine fills: the element vector (3 npe) and the element matrix
/// ((3 npe)^2, row-major); either may be left untouched if not wanted.
pub type ElementRoutine<'f> =
    dyn Fn(usize, &ElementRef<'_>, &mut [f64], &mut [f64]) -> Result<(), FemError> + Sync + 'f;

/// A global vector (length 3n) and matrix (3n x 3n), each present when asked for.
pub type Assembled = (Option<Vec<f64>>, Option<CsMat<f64>>);

/// The buffers of one chunk of elements: element vectors and matrices, and the scatter
/// positions `positions[(i * npe + lb) * npe + la]`, the index of node `element(i)[la]` in
/// the sorted neighbour list of node `element(i)[lb]`.
struct ChunkBuffers {
    vectors: Vec<f64>,
    matrices: Vec<f64>,
    positions: Vec<u32>,
    /// The (element, local node) pairs of the chunk by partition of the node, in element order:
    /// partition p's are `items[starts[p]..starts[p + 1]]`, item = i * npe + lb.
    starts: Vec<usize>,
    items: Vec<u32>,
}

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
    let npe = mesh.kind.nodes_per_element();
    let n = 3 * npe;
    let ne = mesh.n_elements();
    let mut vector = vec![0.0; if want_vector { pattern.n_dofs() } else { 0 }];
    let mut values = vec![
        0.0;
        if want_matrix {
            pattern.indices.len()
        } else {
            0
        }
    ];
    let chunk = CHUNK.min(ne).max(1);
    let mut buf = ChunkBuffers {
        vectors: vec![0.0; chunk * n],
        matrices: vec![0.0; if want_matrix { chunk * n * n } else { 0 }],
        positions: vec![0; if want_matrix { chunk * npe * npe } else { 0 }],
        starts: vec![0; pattern.n_parts() + 1],
        items: vec![0; chunk * npe],
    };
    let mut first = 0;
    while first < ne {
        let count = chunk.min(ne - first);
        compute_chunk(mesh, pattern, first, count, &mut buf, want_matrix, routine)?;
        if want_vector {
            for i in 0..count {
                let ve = &buf.vectors[i * n..(i + 1) * n];
                scatter_vector(mesh.element(first + i), ve, &mut vector);
            }
        }
        if want_matrix {
            scatter_chunk(mesh, pattern, first, count, &mut buf, &mut values);
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

/// Runs `routine` on the elements `first..first + count` in parallel (buffers zeroed first)
/// and, for a matrix, computes their scatter positions; the first failing element in mesh
/// order is the error.
fn compute_chunk(
    mesh: &Mesh,
    pattern: &BlockPattern,
    first: usize,
    count: usize,
    buf: &mut ChunkBuffers,
    want_matrix: bool,
    routine: &ElementRoutine<'_>,
) -> Result<(), FemError> {
    let (kind, npe) = (mesh.kind, mesh.kind.nodes_per_element());
    let n = 3 * npe;
    let (mn, pn) = if want_matrix {
        (n * n, npe * npe)
    } else {
        (0, 0)
    };
    let m_chunks: Vec<&mut [f64]> = if want_matrix {
        buf.matrices[..count * mn].chunks_mut(mn).collect()
    } else {
        (0..count).map(|_| &mut [][..]).collect()
    };
    let p_chunks: Vec<&mut [u32]> = if want_matrix {
        buf.positions[..count * pn].chunks_mut(pn).collect()
    } else {
        (0..count).map(|_| &mut [][..]).collect()
    };
    let failure = buf.vectors[..count * n]
        .par_chunks_mut(n)
        .zip(m_chunks)
        .zip(p_chunks)
        .enumerate()
        .filter_map(|(i, ((ve, me), pos))| {
            let e = first + i;
            let nodes = mesh.element(e);
            if !pos.is_empty() {
                for (lb, &b) in nodes.iter().enumerate() {
                    let nb = pattern.adjacency.neighbours(b);
                    for (la, &a) in nodes.iter().enumerate() {
                        // Every node of an element is a neighbour of the others.
                        pos[lb * npe + la] = nb.binary_search(&a).unwrap_or(0) as u32;
                    }
                }
            }
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

/// Adds the element matrices of the chunk into `values`, in parallel over the column
/// partitions: the (element, node) pairs are bucketed by the partition of the node (counting
/// sort, element order kept), and each partition adds its pairs' columns in that order.
fn scatter_chunk(
    mesh: &Mesh,
    pattern: &BlockPattern,
    first: usize,
    count: usize,
    buf: &mut ChunkBuffers,
    values: &mut [f64],
) {
    let npe = mesh.kind.nodes_per_element();
    let n = 3 * npe;
    let connectivity = &mesh.connectivity[first * npe..(first + count) * npe];
    let (starts, items) = (&mut buf.starts, &mut buf.items);
    starts.fill(0);
    for &b in connectivity {
        starts[pattern.part_of_node[b] as usize + 1] += 1;
    }
    for p in 0..pattern.n_parts() {
        starts[p + 1] += starts[p];
    }
    let mut fill = starts.clone();
    for (item, &b) in connectivity.iter().enumerate() {
        let p = pattern.part_of_node[b] as usize;
        items[fill[p]] = item as u32;
        fill[p] += 1;
    }
    let adj = &pattern.adjacency;
    let (matrices, positions) = (&buf.matrices, &buf.positions);
    let (starts, items) = (&buf.starts, &buf.items);
    split_by_nodes(values, &pattern.bounds, adj)
        .into_par_iter()
        .enumerate()
        .for_each(|(p, part)| {
            let base = adj.column_block_start(pattern.bounds[p]);
            for &item in &items[starts[p]..starts[p + 1]] {
                let (i, lb) = (item as usize / npe, item as usize % npe);
                let b = connectivity[i * npe + lb];
                let me = &matrices[i * n * n..(i + 1) * n * n];
                let pos = &positions[(i * npe + lb) * npe..(i * npe + lb + 1) * npe];
                let deg = adj.offsets[b + 1] - adj.offsets[b];
                let col0 = adj.column_block_start(b) - base;
                for j in 0..3 {
                    let column = &mut part[col0 + 3 * j * deg..col0 + 3 * (j + 1) * deg];
                    for (la, &k) in pos.iter().enumerate() {
                        let d = 3 * k as usize;
                        for r in 0..3 {
                            column[d + r] += me[(3 * la + r) * n + 3 * lb + j];
                        }
                    }
                }
            }
        });
}

fn scatter_vector(nodes: &[usize], ve: &[f64], out: &mut [f64]) {
    for (la, &a) in nodes.iter().enumerate() {
        for i in 0..3 {
            out[3 * a + i] += ve[3 * la + i];
        }
    }
}

/// Gathers the element DOFs of a global vector (3 n) for element `e`.
pub fn gather(mesh: &Mesh, e: usize, global: &[f64], out: &mut [f64]) {
    for (la, &a) in mesh.element(e).iter().enumerate() {
        out[3 * la..3 * la + 3].copy_from_slice(&global[3 * a..3 * a + 3]);
    }
}
