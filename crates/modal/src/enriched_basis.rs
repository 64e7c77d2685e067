//! A Craig-Bampton basis enriched with modes of other states (docs/ROTATION.md, "Parametric
//! reduced model"): the basis T of one speed misses the modes of the others under the
//! nonlinear prestress (19 % on the third frequency of the coarse blade at rest from a 5000
//! rpm basis); with the full model's lowest modes at the Ritz basis speeds added, it holds every
//! mode of the Campbell diagram's Ritz model.
//!
//! T = [Psi, Phi]: n_b constraint modes Psi (unit on their own boundary DOF, zero on the others)
//! and interior columns Phi (zero on every boundary DOF, mass-normalized). A mode v is added as
//! its part beyond the constraint modes, w = v - sum_j v[b_j] Psi_j (zero on the boundary DOFs,
//! which stay physical coordinates), M-orthogonalized twice against the interior columns and
//! the added ones, normalized, and dropped when less than 1e-8 of its M-norm is left
//! ([`MOrthonormalBasis`]).

use faer::{Mat, MatRef};
use sprs::CsMat;

use crate::error::ModalError;
use crate::m_orthonormal::{as_matrix, project_symmetric, MOrthonormalBasis};

/// The enlarged basis.
pub struct EnrichedBasis {
    /// T with the added columns after the original ones (d x (n_b + n_i + added)).
    pub basis: Mat<f64>,
    /// M_r = T^T M T, exactly symmetric (kg for SI matrices).
    pub mass: Mat<f64>,
    /// The number of columns added.
    pub added: usize,
}

/// `basis` (d x (n_b + n_i), the constraint modes first: `boundary[j]` is the DOF of column j)
/// enriched with the columns of `modes` (each block d x k, taken in order), in the M-inner
/// product of `m` (module docs). Errors: sizes that do not match, a boundary DOF out of range.
pub fn enrich_with_modes(
    basis: MatRef<'_, f64>,
    boundary: &[usize],
    modes: &[MatRef<'_, f64>],
    m: &CsMat<f64>,
) -> Result<EnrichedBasis, ModalError> {
    check_sizes(basis, boundary, modes, m)?;
    let n_b = boundary.len();
    let columns: Vec<Vec<f64>> = (0..basis.ncols())
        .map(|j| basis.col(j).iter().copied().collect())
        .collect();
    let (constraint, interior) = columns.split_at(n_b);
    let mut orthonormal = MOrthonormalBasis::with_orthonormal(m, interior.to_vec());
    let before = orthonormal.len();
    for block in modes {
        for j in 0..block.ncols() {
            let v = block.col(j);
            let mut w: Vec<f64> = v.iter().copied().collect();
            for (&b, psi) in boundary.iter().zip(constraint) {
                let vb = v[b];
                w.iter_mut().zip(psi).for_each(|(x, c)| *x -= vb * c);
            }
            orthonormal.add(w);
        }
    }
    let added = orthonormal.len() - before;
    let all: Vec<Vec<f64>> = constraint
        .iter()
        .cloned()
        .chain(orthonormal.into_columns())
        .collect();
    let basis = as_matrix(basis.nrows(), &all);
    let mass = project_symmetric(m, basis.as_ref()).reduced;
    Ok(EnrichedBasis { basis, mass, added })
}

fn check_sizes(
    basis: MatRef<'_, f64>,
    boundary: &[usize],
    modes: &[MatRef<'_, f64>],
    m: &CsMat<f64>,
) -> Result<(), ModalError> {
    let d = nlmodes_sparse::ops::check_square(m, "M of the enriched basis")?;
    let mismatch = |what: &str, found: usize| ModalError::DimensionMismatch {
        what: what.to_string(),
        expected: d,
        found,
    };
    if basis.nrows() != d {
        return Err(mismatch(
            "rows of the basis against the order of M",
            basis.nrows(),
        ));
    }
    if let Some(block) = modes.iter().find(|b| b.nrows() != d) {
        return Err(mismatch(
            "rows of a block of modes against the order of M",
            block.nrows(),
        ));
    }
    if boundary.len() > basis.ncols() {
        return Err(ModalError::InvalidArgument(format!(
            "{} boundary DOFs for a basis of {} columns",
            boundary.len(),
            basis.ncols()
        )));
    }
    if let Some(b) = boundary.iter().find(|&&b| b >= d) {
        return Err(ModalError::InvalidArgument(format!(
            "boundary DOF {b} of the enriched basis is out of range (order {d})"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ritz::tests::chain;
    use crate::ritz::RitzBasis;

    /// On the chain of `ritz`'s tests (9 masses, DOF 4 the boundary): a basis of the
    /// constraint mode of DOF 4 and 2 interior vectors, enriched with the exact modes 1-4 (mode
    /// 1 given twice), spans them: the Rayleigh-Ritz values of the enriched basis hold the
    /// exact lambda_1..4 to 1e-12, the columns stay zero on the boundary DOF but the first,
    /// M_r is T^T M T, and the repeated mode is dropped.
    #[test]
    fn the_enriched_basis_spans_the_added_modes() {
        let (k, m, lambda, s) = chain(9);
        let n = 9;
        let psi = Mat::from_fn(n, 1, |i, _| 1.0 - (i as f64 - 4.0).abs() / 5.0);
        let interior = Mat::from_fn(n, 2, |i, j| {
            if i == 4 {
                0.0
            } else {
                ((i + 1) as f64 * (j + 1) as f64 * 0.3).sin()
            }
        });
        let seed = RitzBasis::new(&[interior.as_ref()], &m).unwrap();
        let phi = seed.shapes(&seed.solve(&k, 2).unwrap(), 2);
        let t = Mat::from_fn(
            n,
            3,
            |i, j| if j == 0 { psi[(i, 0)] } else { phi[(i, j - 1)] },
        );
        let modes = Mat::from_fn(n, 5, |i, j| s[(i, [0, 1, 2, 3, 0][j])]);
        let enriched = enrich_with_modes(t.as_ref(), &[4], &[modes.as_ref()], &m).unwrap();
        assert_eq!(enriched.basis.ncols(), 3 + enriched.added);
        assert_eq!(enriched.added, 4, "the repeated mode adds nothing");
        for j in 1..enriched.basis.ncols() {
            assert_eq!(
                enriched.basis[(4, j)],
                0.0,
                "column {j} on the boundary DOF"
            );
        }
        let dense_m = nlmodes_sparse::ops::csmat_to_dense(&m);
        let exact_mass = enriched.basis.transpose() * &dense_m * &enriched.basis;
        for i in 0..enriched.mass.nrows() {
            for j in 0..enriched.mass.ncols() {
                assert!((enriched.mass[(i, j)] - exact_mass[(i, j)]).abs() < 1e-13);
            }
        }
        let dense_k = nlmodes_sparse::ops::csmat_to_dense(&k);
        let k_r = enriched.basis.transpose() * &dense_k * &enriched.basis;
        let k_r = (&k_r + k_r.transpose()) * faer::Scale(0.5);
        let (values, _) =
            crate::modes::dense_generalized_eigen(k_r.as_ref(), enriched.mass.as_ref())
                .expect("reduced eigenproblem");
        for j in 0..4 {
            let rel = (values[j] - lambda[j]).abs() / lambda[j];
            assert!(
                rel < 1e-12,
                "mode {j}: {} vs {} ({rel:e})",
                values[j],
                lambda[j]
            );
        }
    }

    #[test]
    fn sizes_that_do_not_match_are_typed_errors() {
        let (_, m, _, _) = chain(5);
        let t = Mat::<f64>::identity(5, 2);
        let short = Mat::<f64>::zeros(4, 1);
        assert!(matches!(
            enrich_with_modes(t.as_ref(), &[0], &[short.as_ref()], &m),
            Err(ModalError::DimensionMismatch { .. })
        ));
        assert!(matches!(
            enrich_with_modes(t.as_ref(), &[7], &[], &m),
            Err(ModalError::InvalidArgument(_))
        ));
    }
}
