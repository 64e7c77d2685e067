//! Fill-reducing orderings for the sparse Cholesky factorization.
//!
//! METIS nested dissection (`METIS_NodeND`) on the adjacency graph of the
//! matrix (its pattern without the diagonal, made symmetric). METIS returns
//! `perm` and `iperm` with "row i of the permuted matrix is row `perm[i]` of the
//! original" (METIS 5 manual, Sec. 5.6); faer's forward permutation has the
//! same meaning (its solve gathers `x[i] = rhs[fwd[i]]`), so `perm` is passed
//! as faer's forward array and `iperm` as its inverse. Swapping them still
//! gives a valid permutation but destroys the dissection: on a 176k-DOF TET10
//! stiffness fill explodes (DESIGN 6); the unit test `metis_beats_natural`
//! checks the orientation through nnz(L).

use std::sync::Mutex;

use sprs::CsMat;

/// METIS keeps its random-number state in C globals (GKlib), so concurrent
/// calls race and give thread-dependent orderings: one call at a time.
static METIS_LOCK: Mutex<()> = Mutex::new(());

/// Which fill-reducing ordering to use before the Cholesky factorization.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum FillOrdering {
    /// METIS nested dissection, falling back to AMD if METIS fails.
    #[default]
    Metis,
    /// faer's approximate minimum degree.
    Amd,
    /// No reordering (for tests and comparisons).
    Natural,
}

/// A permutation as faer wants it: `forward[new] = old`, `inverse[old] = new`.
#[derive(Clone, Debug)]
pub(crate) struct Permutation {
    /// `forward[i]` is the original index placed at position `i`.
    pub forward: Vec<usize>,
    /// `inverse[j]` is the new position of original index `j`.
    pub inverse: Vec<usize>,
}

/// Nested-dissection ordering of the symmetric pattern of `a` computed by METIS.
///
/// `a` must be square (checked by the caller). Returns a description of the
/// failure when METIS reports an error or the graph does not fit METIS's
/// 32-bit indices, so that the caller can fall back to AMD.
pub(crate) fn metis_nested_dissection(a: &CsMat<f64>) -> Result<Permutation, String> {
    let n = a.rows();
    let mut nvtxs = i32::try_from(n).map_err(|_| format!("{n} vertices exceed METIS's i32"))?;
    let (mut xadj, mut adjncy) = adjacency_graph(a)?;
    let mut perm = vec![0_i32; n];
    let mut iperm = vec![0_i32; n];
    // SAFETY: xadj has n + 1 entries, adjncy xadj[n] entries, perm and iperm n
    // entries each, all 0-based (METIS's default numbering, options = NULL).
    // METIS only reads xadj/adjncy and writes perm/iperm within those bounds.
    let _guard = METIS_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let status = unsafe {
        metis_sys::METIS_NodeND(
            &mut nvtxs,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    if status != metis_sys::rstatus_et_METIS_OK {
        return Err(format!("METIS_NodeND returned status {status}"));
    }
    let forward: Vec<usize> = perm.iter().map(|&p| p as usize).collect();
    let inverse: Vec<usize> = iperm.iter().map(|&p| p as usize).collect();
    // Validate what the C library gave back before faer relies on it.
    let mut seen = vec![false; n];
    for (new, &old) in forward.iter().enumerate() {
        if old >= n || seen[old] || inverse[old] != new {
            return Err("METIS_NodeND returned an invalid permutation".to_string());
        }
        seen[old] = true;
    }
    Ok(Permutation { forward, inverse })
}

/// CSR adjacency (METIS `xadj`, `adjncy`) of pattern(A) + pattern(A^T) without the diagonal.
fn adjacency_graph(a: &CsMat<f64>) -> Result<(Vec<i32>, Vec<i32>), String> {
    let n = a.rows();
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (_, (i, j)) in a.iter() {
        if i != j {
            // i, j < n <= i32::MAX (checked by the caller): no truncation.
            neighbours[i].push(j as u32);
            neighbours[j].push(i as u32);
        }
    }
    let mut xadj = Vec::with_capacity(n + 1);
    let mut adjncy = Vec::new();
    xadj.push(0_i32);
    for list in &mut neighbours {
        list.sort_unstable();
        list.dedup();
        adjncy.extend(list.iter().map(|&v| v as i32));
        let end = i32::try_from(adjncy.len())
            .map_err(|_| format!("{} graph edges exceed METIS's i32", adjncy.len()))?;
        xadj.push(end);
        *list = Vec::new();
    }
    Ok((xadj, adjncy))
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering,
    };
    use faer::sparse::SymbolicSparseColMatRef;
    use faer::Side;
    use sprs::TriMat;

    /// 7-point Laplacian pattern of an s x s x s grid.
    fn grid(s: usize) -> CsMat<f64> {
        let n = s * s * s;
        let id = |i: usize, j: usize, k: usize| i + s * (j + s * k);
        let mut t = TriMat::new((n, n));
        for k in 0..s {
            for j in 0..s {
                for i in 0..s {
                    let p = id(i, j, k);
                    t.add_triplet(p, p, 7.0);
                    for q in [
                        (i + 1 < s).then(|| id(i + 1, j, k)),
                        (j + 1 < s).then(|| id(i, j + 1, k)),
                        (k + 1 < s).then(|| id(i, j, k + 1)),
                    ]
                    .into_iter()
                    .flatten()
                    {
                        t.add_triplet(p, q, -1.0);
                        t.add_triplet(q, p, -1.0);
                    }
                }
            }
        }
        t.to_csc()
    }

    fn fill(a: &CsMat<f64>, forward: &[usize], inverse: &[usize]) -> usize {
        let n = a.rows();
        let col_ptr = a.proper_indptr();
        let structure = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr[..], None, a.indices());
        let perm = faer::perm::PermRef::new_checked(forward, inverse, n);
        factorize_symbolic_cholesky(
            structure,
            Side::Lower,
            SymmetricOrdering::Custom(perm),
            CholeskySymbolicParams::default(),
        )
        .unwrap()
        .len_val()
    }

    /// DESIGN 6: METIS `perm` is faer's forward permutation. Using it that
    /// way must give less fill than the swapped orientation, which scrambles
    /// the dissection.
    #[test]
    fn metis_perm_is_faer_forward_permutation() {
        let a = grid(14);
        let p = metis_nested_dissection(&a).unwrap();
        let right = fill(&a, &p.forward, &p.inverse);
        let swapped = fill(&a, &p.inverse, &p.forward);
        println!("nnz(L): perm as forward {right}, swapped {swapped}");
        assert!(right < swapped, "{right} vs {swapped}");
    }

    #[test]
    fn ordering_is_a_valid_permutation() {
        let a = grid(5);
        let p = metis_nested_dissection(&a).unwrap();
        let mut sorted = p.forward.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..125).collect::<Vec<_>>());
        for (new, &old) in p.forward.iter().enumerate() {
            assert_eq!(p.inverse[old], new);
        }
    }
}
