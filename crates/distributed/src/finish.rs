//! The post-processing of eigenpairs common to every method over MPI, as the serial solvers'
//! ([`nlmodes_modal::Modes`]): ascending, mass-normalized, each vector's largest-magnitude
//! entry positive (over all ranks; the first such in rank order), relative residual
//! ||K x - lambda M x|| / (|lambda| ||M x||).

use faer::Mat;

use crate::collective::{gather_to_all, sum_all};
use crate::error::Result;
use crate::restricted::Restricted;

/// Eigenpairs with the vectors' rows of this rank (the row layout of K).
pub struct LocalModes {
    /// Eigenvalues, ascending (rad^2/s^2 for SI matrices).
    pub eigenvalues: Vec<f64>,
    /// Local rows of the mass-normalized vectors, one column per pair.
    pub vectors: Mat<f64>,
    /// Relative residual of each pair.
    pub residuals: Vec<f64>,
}

/// Eigenpairs of (K, M) with the local rows of their vectors in `vectors` (one column per
/// value, any scale), post-processed (module documentation): one block product with M and
/// one with K for all the vectors.
pub fn finish_pairs(
    k: &Restricted,
    m: &Restricted,
    values: &[f64],
    mut vectors: Mat<f64>,
) -> Result<LocalModes> {
    let n = values.len();
    let mut mx = m.apply_block(vectors.as_ref())?;
    let m_norms2 = column_dots_all(&vectors, &mx);
    let signs = largest_entry_signs(&vectors);
    for j in 0..n {
        let scale = signs[j] / m_norms2[j].sqrt();
        for r in 0..vectors.nrows() {
            vectors[(r, j)] *= scale;
            mx[(r, j)] *= scale;
        }
    }
    let mut kx = k.apply_block(vectors.as_ref())?;
    for (j, &lambda) in values.iter().enumerate() {
        for r in 0..kx.nrows() {
            kx[(r, j)] -= lambda * mx[(r, j)];
        }
    }
    let (r2, mx2) = (column_dots_all(&kx, &kx), column_dots_all(&mx, &mx));
    let residuals: Vec<f64> = (0..n)
        .map(|j| r2[j].sqrt() / (values[j].abs() * mx2[j].sqrt()))
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    Ok(LocalModes {
        eigenvalues: order.iter().map(|&j| values[j]).collect(),
        vectors: Mat::from_fn(vectors.nrows(), n, |r, c| vectors[(r, order[c])]),
        residuals: order.iter().map(|&j| residuals[j]).collect(),
    })
}

/// a_j^T b_j for each column j, over all ranks.
fn column_dots_all(a: &Mat<f64>, b: &Mat<f64>) -> Vec<f64> {
    let mut dots: Vec<f64> = (0..a.ncols())
        .map(|j| {
            a.col(j)
                .iter()
                .zip(b.col(j).iter())
                .map(|(x, y)| x * y)
                .sum()
        })
        .collect();
    sum_all(&mut dots);
    dots
}

/// +1 or -1 per column: the sign that makes its largest-magnitude entry over all ranks (the
/// first such in rank order) positive.
fn largest_entry_signs(vectors: &Mat<f64>) -> Vec<f64> {
    let largest = |values: &mut dyn Iterator<Item = f64>| {
        values.fold(0.0f64, |b, v| if v.abs() > b.abs() { v } else { b })
    };
    let n = vectors.ncols();
    let local: Vec<f64> = (0..n)
        .map(|j| largest(&mut vectors.col(j).iter().copied()))
        .collect();
    let all = gather_to_all(&local);
    (0..n)
        .map(|j| {
            let global = largest(&mut all.iter().skip(j).step_by(n).copied());
            if global < 0.0 {
                -1.0
            } else {
                1.0
            }
        })
        .collect()
}
