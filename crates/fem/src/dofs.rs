//! Dirichlet conditions by DOF elimination, and the map between free and global DOFs.
//! The paper's u = 0 on Gamma_d (Eq. 3b; the space V of Eq. 4) for the clamped blade root,
//! generalized to a subset of components (`bottom:z`).
//!
//! Global DOF = 3 * node + component (0 = x, 1 = y, 2 = z). Free DOFs are numbered in
//! increasing global order, so restriction keeps the sorted CSC structure.

use sprs::CsMat;

use crate::error::FemError;
use crate::mesh::Mesh;

/// Map between the 3 n global DOFs and the free (unconstrained) ones.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DofMap {
    n_nodes: usize,
    /// Free index of each global DOF, `usize::MAX` when fixed.
    free_of_global: Vec<usize>,
    /// Global DOF of each free index (increasing).
    global_of_free: Vec<usize>,
}

const FIXED: usize = usize::MAX;

impl DofMap {
    /// Builds the map for `n_nodes` nodes with the given fixed (node, component) pairs
    /// (duplicates allowed). Errors on a node index >= n_nodes or a component > 2.
    pub fn new(n_nodes: usize, fixed: &[(usize, usize)]) -> Result<Self, FemError> {
        let mut is_fixed = vec![false; 3 * n_nodes];
        for &(node, component) in fixed {
            if node >= n_nodes || component > 2 {
                return Err(FemError::InvalidFixedDof {
                    node,
                    component,
                    n_nodes,
                });
            }
            is_fixed[3 * node + component] = true;
        }
        let mut free_of_global = vec![FIXED; 3 * n_nodes];
        let mut global_of_free = Vec::with_capacity(3 * n_nodes);
        for (g, &f) in is_fixed.iter().enumerate() {
            if !f {
                free_of_global[g] = global_of_free.len();
                global_of_free.push(g);
            }
        }
        Ok(DofMap {
            n_nodes,
            free_of_global,
            global_of_free,
        })
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Number of global DOFs (3 n).
    pub fn n_global(&self) -> usize {
        3 * self.n_nodes
    }

    /// Number of free DOFs.
    pub fn n_free(&self) -> usize {
        self.global_of_free.len()
    }

    /// Free index of a global DOF, `None` when it is fixed or out of range.
    pub fn free_index(&self, global_dof: usize) -> Option<usize> {
        self.free_of_global
            .get(global_dof)
            .copied()
            .filter(|&f| f != FIXED)
    }

    /// Global DOF of free index `i` (panics if `i >= n_free()`, like slice indexing).
    pub fn global_of_free(&self, i: usize) -> usize {
        self.global_of_free[i]
    }

    /// All free global DOFs, increasing.
    pub fn free_dofs(&self) -> &[usize] {
        &self.global_of_free
    }

    /// True when the global DOF is fixed.
    pub fn is_fixed(&self, global_dof: usize) -> bool {
        self.free_of_global.get(global_dof) == Some(&FIXED)
    }

    /// Deletes the fixed rows and columns of a 3n x 3n matrix (CSC or CSR in), CSC out.
    ///
    /// # Panics
    /// If the matrix is not 3n x 3n (a programming error); see [`DofMap::try_restrict`].
    pub fn restrict(&self, a: &CsMat<f64>) -> CsMat<f64> {
        match self.try_restrict(a) {
            Ok(r) => r,
            Err(e) => panic!("DofMap::restrict: {e}"),
        }
    }

    /// [`DofMap::restrict`] returning an error when the matrix is not 3n x 3n.
    pub fn try_restrict(&self, a: &CsMat<f64>) -> Result<CsMat<f64>, FemError> {
        let ng = self.n_global();
        for (what, found) in [("matrix rows", a.rows()), ("matrix columns", a.cols())] {
            if found != ng {
                return Err(FemError::DimensionMismatch {
                    what,
                    found,
                    expected: ng,
                });
            }
        }
        let csc;
        let a = if a.is_csc() {
            a
        } else {
            csc = a.to_csc();
            &csc
        };
        let nf = self.n_free();
        let mut indptr = Vec::with_capacity(nf + 1);
        let mut indices = Vec::new();
        let mut data = Vec::new();
        indptr.push(0);
        for &g in &self.global_of_free {
            if let Some(col) = a.outer_view(g) {
                for (row, &v) in col.iter() {
                    let f = self.free_of_global[row];
                    if f != FIXED {
                        indices.push(f);
                        data.push(v);
                    }
                }
            }
            indptr.push(indices.len());
        }
        CsMat::try_new_csc((nf, nf), indptr, indices, data)
            .map_err(|(_, _, _, e)| FemError::InvalidMesh(format!("restricted matrix: {e}")))
    }

    /// Free vector -> global vector with zeros on the fixed DOFs.
    ///
    /// # Panics
    /// If `free.len() != n_free()` (a programming error); see [`DofMap::try_expand`].
    pub fn expand(&self, free: &[f64]) -> Vec<f64> {
        match self.try_expand(free) {
            Ok(v) => v,
            Err(e) => panic!("DofMap::expand: {e}"),
        }
    }

    /// [`DofMap::expand`] returning an error on a length mismatch.
    pub fn try_expand(&self, free: &[f64]) -> Result<Vec<f64>, FemError> {
        if free.len() != self.n_free() {
            return Err(FemError::DimensionMismatch {
                what: "free vector",
                found: free.len(),
                expected: self.n_free(),
            });
        }
        let mut full = vec![0.0; self.n_global()];
        for (&g, &v) in self.global_of_free.iter().zip(free) {
            full[g] = v;
        }
        Ok(full)
    }

    /// Global vector -> free vector (the fixed entries are dropped).
    pub fn try_restrict_vector(&self, full: &[f64]) -> Result<Vec<f64>, FemError> {
        if full.len() != self.n_global() {
            return Err(FemError::DimensionMismatch {
                what: "global vector",
                found: full.len(),
                expected: self.n_global(),
            });
        }
        Ok(self.global_of_free.iter().map(|&g| full[g]).collect())
    }
}

/// Parses a constraint: `GROUP` (all three components) or `GROUP:COMPONENTS` where
/// COMPONENTS is a non-empty set of `x`, `y`, `z` (e.g. `bottom:z`, `root:xy`).
/// Returns the group name and the sorted components (0 = x, 1 = y, 2 = z).
pub fn parse_fix_spec(s: &str) -> Result<(String, Vec<usize>), FemError> {
    let err = |reason: String| FemError::InvalidFixSpec {
        spec: s.to_string(),
        reason,
    };
    let spec = s.trim();
    let (name, comps) = match spec.rsplit_once(':') {
        Some((name, comps)) => (name.trim(), Some(comps.trim())),
        None => (spec, None),
    };
    if name.is_empty() {
        return Err(err("the group name is empty".into()));
    }
    let Some(comps) = comps else {
        return Ok((name.to_string(), vec![0, 1, 2]));
    };
    if comps.is_empty() {
        return Err(err("no component after ':'".into()));
    }
    let mut out = Vec::new();
    for c in comps.chars() {
        let k = match c.to_ascii_lowercase() {
            'x' => 0,
            'y' => 1,
            'z' => 2,
            other => return Err(err(format!("unknown component '{other}' (use x, y, z)"))),
        };
        if out.contains(&k) {
            return Err(err(format!("component '{c}' is given twice")));
        }
        out.push(k);
    }
    out.sort_unstable();
    Ok((name.to_string(), out))
}

/// The fixed (node, component) pairs of a list of constraint specs (see [`parse_fix_spec`]),
/// sorted and unique. Errors on a bad spec, an unknown group (listing the groups present) or
/// a group without nodes.
pub fn fixed_dofs<S: AsRef<str>>(
    mesh: &Mesh,
    specs: &[S],
) -> Result<Vec<(usize, usize)>, FemError> {
    let mut fixed = Vec::new();
    for spec in specs {
        let (name, comps) = parse_fix_spec(spec.as_ref())?;
        let group = mesh.group(&name)?;
        if group.nodes.is_empty() {
            return Err(FemError::InvalidFixSpec {
                spec: spec.as_ref().to_string(),
                reason: format!("physical group '{name}' has no nodes"),
            });
        }
        for &node in &group.nodes {
            for &c in &comps {
                fixed.push((node, c));
            }
        }
    }
    fixed.sort_unstable();
    fixed.dedup();
    Ok(fixed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sprs::TriMat;

    #[test]
    fn fix_specs() {
        assert_eq!(
            parse_fix_spec("root").expect("ok"),
            ("root".to_string(), vec![0, 1, 2])
        );
        assert_eq!(
            parse_fix_spec("bottom:z").expect("ok"),
            ("bottom".to_string(), vec![2])
        );
        assert_eq!(
            parse_fix_spec(" root : YX ").expect("ok"),
            ("root".to_string(), vec![0, 1])
        );
        for bad in ["", ":x", "root:", "root:w", "root:xx", "root:x y"] {
            let e = parse_fix_spec(bad).expect_err(bad);
            assert!(matches!(e, FemError::InvalidFixSpec { .. }), "{bad}: {e}");
            assert!(e.to_string().contains(&format!("'{bad}'")), "{e}");
        }
    }

    #[test]
    fn map_restrict_expand() {
        // 2 nodes, 6 DOFs; fix node 0 z (dof 2) and node 1 x (dof 3).
        let map = DofMap::new(2, &[(0, 2), (1, 0), (0, 2)]).expect("valid");
        assert_eq!(map.n_free(), 4);
        assert_eq!(map.free_dofs(), &[0, 1, 4, 5]);
        assert_eq!(map.free_index(4), Some(2));
        assert_eq!(map.free_index(2), None);
        assert_eq!(map.free_index(6), None);
        assert_eq!(map.global_of_free(3), 5);
        assert!(map.is_fixed(3) && !map.is_fixed(0));
        assert_eq!(
            map.expand(&[1.0, 2.0, 3.0, 4.0]),
            vec![1.0, 2.0, 0.0, 0.0, 3.0, 4.0]
        );
        assert!(map.try_expand(&[1.0]).is_err());
        assert_eq!(
            map.try_restrict_vector(&[1.0, 2.0, 9.0, 9.0, 3.0, 4.0])
                .expect("ok"),
            vec![1.0, 2.0, 3.0, 4.0]
        );

        // A(i, j) = 10 i + j, dense 6x6; restricted entries must be A(g(i), g(j)).
        let mut t = TriMat::new((6, 6));
        for i in 0..6 {
            for j in 0..6 {
                t.add_triplet(i, j, (10 * i + j) as f64);
            }
        }
        for a in [t.to_csc::<usize>(), t.to_csr::<usize>()] {
            let r = map.restrict(&a);
            assert!(r.is_csc());
            assert_eq!(r.shape(), (4, 4));
            for i in 0..4 {
                for j in 0..4 {
                    let (gi, gj) = (map.global_of_free(i), map.global_of_free(j));
                    assert_eq!(r.get(i, j).copied(), Some((10 * gi + gj) as f64));
                }
            }
        }
        let wrong = TriMat::<f64>::new((5, 5)).to_csc::<usize>();
        assert!(matches!(
            map.try_restrict(&wrong),
            Err(FemError::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn out_of_range_fixed_dofs_are_errors() {
        assert!(matches!(
            DofMap::new(2, &[(2, 0)]),
            Err(FemError::InvalidFixedDof { node: 2, .. })
        ));
        assert!(matches!(
            DofMap::new(2, &[(0, 3)]),
            Err(FemError::InvalidFixedDof { component: 3, .. })
        ));
    }
}
