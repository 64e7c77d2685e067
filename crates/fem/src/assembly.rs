//! Assembly of the global consistent mass and stiffness matrices: the discrete forms of the
//! paper's m(u, v) = int rho u.v dx (Eq. 5a) and k(u, v) = int sigma(u):eps(v) dx (Eq. 5b),
//! "consistent mass M and stiffness K structural matrices based on (5)" (Sec. 3).
//!
//! Global DOF numbering: `3 * node + component`. Both matrices share one CSC pattern built once
//! from the node adjacency (two nodes are adjacent when an element holds both); each node pair
//! gives a dense 3x3 block, stored in full (both triangles).
//!
//! Element matrices are computed in parallel (rayon) chunk by chunk, then scattered in
//! parallel into disjoint column ranges of the value arrays. Every entry is summed in element
//! order, so the result is deterministic and exactly symmetric: entry (p, q) and (q, p) add the
//! same element values (element matrices are exactly symmetric) in the same order.

use rayon::prelude::*;
use sprs::CsMat;

use crate::element::element_matrices;
use crate::error::FemError;
use crate::material::Isotropic;
use crate::mesh::Mesh;

/// Node adjacency in compressed form: the neighbours of node `v` (itself included), sorted,
/// are `adjacency[offsets[v]..offsets[v + 1]]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeAdjacency {
    /// Offsets, length n_nodes + 1.
    pub offsets: Vec<usize>,
    /// Concatenated sorted neighbour lists.
    pub adjacency: Vec<usize>,
}

impl NodeAdjacency {
    /// Builds the adjacency of the mesh nodes (mesh assumed valid).
    pub fn new(mesh: &Mesh) -> Self {
        let n = mesh.n_nodes();
        let ne = mesh.n_elements();
        // node -> elements, by counting sort.
        let mut elem_offsets = vec![0usize; n + 1];
        for &v in &mesh.connectivity {
            elem_offsets[v + 1] += 1;
        }
        for v in 0..n {
            elem_offsets[v + 1] += elem_offsets[v];
        }
        let mut fill = elem_offsets.clone();
        let mut elems = vec![0usize; mesh.connectivity.len()];
        for e in 0..ne {
            for &v in mesh.element(e) {
                elems[fill[v]] = e;
                fill[v] += 1;
            }
        }
        let lists: Vec<Vec<usize>> = (0..n)
            .into_par_iter()
            .map(|v| {
                let mut list = Vec::new();
                for &e in &elems[elem_offsets[v]..elem_offsets[v + 1]] {
                    list.extend_from_slice(mesh.element(e));
                }
                if list.is_empty() {
                    list.push(v);
                }
                list.sort_unstable();
                list.dedup();
                list
            })
            .collect();
        let mut offsets = Vec::with_capacity(n + 1);
        offsets.push(0);
        let mut adjacency = Vec::with_capacity(lists.iter().map(Vec::len).sum());
        for l in &lists {
            adjacency.extend_from_slice(l);
            offsets.push(adjacency.len());
        }
        NodeAdjacency { offsets, adjacency }
    }

    /// Sorted neighbours of node `v`.
    pub fn neighbours(&self, v: usize) -> &[usize] {
        &self.adjacency[self.offsets[v]..self.offsets[v + 1]]
    }

    /// Start of node `v`'s three columns in the DOF value array: 9 * offsets[v].
    pub(crate) fn column_block_start(&self, v: usize) -> usize {
        9 * self.offsets[v]
    }

    /// Node ranges `bounds[p]..bounds[p + 1]` whose DOF columns hold about `entries`
    /// stored entries each (at least one node per range; covers all nodes).
    pub(crate) fn partition(&self, entries: usize) -> Vec<usize> {
        let n = self.offsets.len() - 1;
        let mut bounds = vec![0usize];
        let step = (entries / 9).max(1);
        let mut target = step;
        while target < self.adjacency.len() {
            let v = self.offsets.partition_point(|&o| o < target).min(n);
            if v > *bounds.last().unwrap_or(&0) {
                bounds.push(v);
            }
            target += step;
        }
        if *bounds.last().unwrap_or(&0) < n {
            bounds.push(n);
        }
        bounds
    }

    /// CSC structure (indptr, indices) of the 3n x 3n DOF pattern, filled in parallel over
    /// the node ranges `bounds`.
    fn dof_pattern(&self, bounds: &[usize]) -> (Vec<usize>, Vec<usize>) {
        let n = self.offsets.len() - 1;
        let mut indptr = Vec::with_capacity(3 * n + 1);
        indptr.push(0);
        for v in 0..n {
            let deg = self.offsets[v + 1] - self.offsets[v];
            let start = self.column_block_start(v);
            for j in 1..=3 {
                indptr.push(start + 3 * j * deg);
            }
        }
        let mut indices = vec![0usize; 9 * self.adjacency.len()];
        split_by_nodes(&mut indices, bounds, self)
            .into_par_iter()
            .zip(bounds.par_windows(2))
            .for_each(|(part, w)| {
                let mut at = 0;
                for v in w[0]..w[1] {
                    let nb = self.neighbours(v);
                    for _ in 0..3 {
                        for &a in nb {
                            part[at..at + 3].copy_from_slice(&[3 * a, 3 * a + 1, 3 * a + 2]);
                            at += 3;
                        }
                    }
                }
            });
        (indptr, indices)
    }
}

/// Elements per parallel chunk (element matrices of a chunk are buffered: 2 x 900 f64 each,
/// 7 MB for TET10, so that they are still in cache when scattered).
const CHUNK: usize = 512;

/// Target size of one column partition of a value array for the parallel scatter (entries):
/// 64k f64 = 512 kB for K and as much for M, so that a partition's writes stay in L2 cache.
pub(crate) const PARTITION_ENTRIES: usize = 1 << 16;

/// Assembles the global stiffness K (N/m) and consistent mass M (kg), both 3n x 3n CSC with
/// full symmetric storage, global DOF = 3 * node + component.
///
/// Errors: invalid material or mesh (including a node that belongs to no element), and any
/// element with a non-positive (or negligible) Jacobian determinant at a quadrature point
/// (the first such element in mesh order).
pub fn assemble(mesh: &Mesh, mat: &Isotropic) -> Result<(CsMat<f64>, CsMat<f64>), FemError> {
    mat.validate()?;
    mesh.validate()?;
    let kind = mesh.kind;
    let npe = kind.nodes_per_element();
    let ndof_e = 3 * npe;
    let block = ndof_e * ndof_e;
    let n = mesh.n_nodes();
    let ne = mesh.n_elements();

    // A node of no element would give empty (singular) rows of K and M.
    let mut used = vec![false; n];
    for &v in &mesh.connectivity {
        used[v] = true;
    }
    if let Some(v) = used.iter().position(|&u| !u) {
        return Err(FemError::InvalidMesh(format!(
            "node {v} (0-based) belongs to no element: its rows of K and M would be empty"
        )));
    }
    let adj = NodeAdjacency::new(mesh);
    let bounds = adj.partition(PARTITION_ENTRIES);
    let n_parts = bounds.len() - 1;
    let mut part_of_node = vec![0u32; n];
    for (p, w) in bounds.windows(2).enumerate() {
        part_of_node[w[0]..w[1]].fill(p as u32);
    }
    let (indptr, indices) = adj.dof_pattern(&bounds);
    let nnz = indices.len();
    // Zeroed value arrays; the first touch of their pages (the page faults) is done in
    // parallel rather than during the scatter.
    let zeros = || {
        let mut v = vec![0.0; nnz];
        v.par_chunks_mut(1 << 16).for_each(|c| c.fill(0.0));
        v
    };
    let mut k_val = zeros();
    let mut m_val = zeros();

    let chunk_len = CHUNK.min(ne).max(1);
    let mut k_buf = vec![0.0; chunk_len * block];
    let mut m_buf = vec![0.0; chunk_len * block];
    // positions[(i * npe + lb) * npe + la]: index of node element(i)[la] in the sorted
    // neighbour list of node element(i)[lb].
    let mut positions = vec![0u32; chunk_len * npe * npe];
    // Per chunk, the (element, local node) pairs of each partition, in element order
    // (counting sort): bucket p is items[starts[p]..starts[p + 1]], item = i * npe + lb.
    let mut starts = vec![0usize; n_parts + 1];
    let mut items = vec![0u32; chunk_len * npe];
    let mut first = 0;
    while first < ne {
        let count = CHUNK.min(ne - first);
        // 1. Element matrices and scatter positions, in parallel; report the first failing
        //    element in mesh order.
        let failure = k_buf[..count * block]
            .par_chunks_mut(block)
            .zip(m_buf[..count * block].par_chunks_mut(block))
            .zip(positions[..count * npe * npe].par_chunks_mut(npe * npe))
            .enumerate()
            .filter_map(|(i, ((ke, me), pos))| {
                let e = first + i;
                let nodes = mesh.element(e);
                for (lb, &b) in nodes.iter().enumerate() {
                    let nb = adj.neighbours(b);
                    for (la, &a) in nodes.iter().enumerate() {
                        // Every node of the element is a neighbour of b by construction.
                        pos[lb * npe + la] = nb.binary_search(&a).unwrap_or(0) as u32;
                    }
                }
                let mut coords = [[0.0; 3]; 10];
                mesh.element_coords_into(e, &mut coords);
                element_matrices(kind, &coords[..npe], mat, mesh.element_tag(e), ke, me)
                    .err()
                    .map(|err| (e, err))
            })
            .min_by_key(|(e, _)| *e);
        if let Some((_, err)) = failure {
            return Err(err);
        }
        // 2. Bucket the (element, node) pairs by partition of the node, keeping element order.
        starts.fill(0);
        for &b in &mesh.connectivity[first * npe..(first + count) * npe] {
            starts[part_of_node[b] as usize + 1] += 1;
        }
        for p in 0..n_parts {
            starts[p + 1] += starts[p];
        }
        let mut fill = starts.clone();
        for (item, &b) in mesh.connectivity[first * npe..(first + count) * npe]
            .iter()
            .enumerate()
        {
            let p = part_of_node[b] as usize;
            items[fill[p]] = item as u32;
            fill[p] += 1;
        }
        // 3. Scatter, in parallel over disjoint column ranges (node partitions).
        let k_parts = split_by_nodes(&mut k_val, &bounds, &adj);
        let m_parts = split_by_nodes(&mut m_val, &bounds, &adj);
        k_parts
            .into_par_iter()
            .zip(m_parts.into_par_iter())
            .enumerate()
            .for_each(|(p, (kp, mp))| {
                let (lo, hi) = (bounds[p], bounds[p + 1]);
                let base = adj.column_block_start(lo);
                for &item in &items[starts[p]..starts[p + 1]] {
                    let (i, lb) = (item as usize / npe, item as usize % npe);
                    let b = mesh.connectivity[(first + i) * npe + lb];
                    debug_assert!(b >= lo && b < hi);
                    let ke = &k_buf[i * block..(i + 1) * block];
                    let me = &m_buf[i * block..(i + 1) * block];
                    let deg = adj.offsets[b + 1] - adj.offsets[b];
                    let col0 = adj.column_block_start(b) - base;
                    let pos = &positions[(i * npe + lb) * npe..(i * npe + lb + 1) * npe];
                    for j in 0..3 {
                        // Column 3 lb + j of the (symmetric) element matrices, read as row
                        // 3 lb + j: a contiguous triple per local node la.
                        let src = (3 * lb + j) * ndof_e;
                        let (kc, mc) = (&ke[src..src + ndof_e], &me[src..src + ndof_e]);
                        let dst = col0 + 3 * j * deg;
                        let kd = &mut kp[dst..dst + 3 * deg];
                        let md = &mut mp[dst..dst + 3 * deg];
                        for (la, &k) in pos.iter().enumerate() {
                            let d = 3 * k as usize;
                            for r in 0..3 {
                                kd[d + r] += kc[3 * la + r];
                                md[d + r] += mc[3 * la + r];
                            }
                        }
                    }
                }
            });
        first += count;
    }

    let ndof = 3 * n;
    let m = CsMat::try_new_csc((ndof, ndof), indptr.clone(), indices.clone(), m_val)
        .map_err(|(_, _, _, e)| FemError::InvalidMesh(format!("mass pattern: {e}")))?;
    let k = CsMat::try_new_csc((ndof, ndof), indptr, indices, k_val)
        .map_err(|(_, _, _, e)| FemError::InvalidMesh(format!("stiffness pattern: {e}")))?;
    Ok((k, m))
}

/// Splits a value array into the column ranges of the node partitions `bounds`.
pub(crate) fn split_by_nodes<'a, T>(
    vals: &'a mut [T],
    bounds: &[usize],
    adj: &NodeAdjacency,
) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(bounds.len().saturating_sub(1));
    let mut rest = vals;
    for w in bounds.windows(2) {
        let len = adj.column_block_start(w[1]) - adj.column_block_start(w[0]);
        let (head, tail) = rest.split_at_mut(len);
        out.push(head);
        rest = tail;
    }
    out
}
