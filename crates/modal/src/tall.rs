//! Dense products of tall matrices (n rows, a few hundred columns at most), as the block
//! eigensolver needs them: A^T B, W - V C and V Y, in row chunks run in parallel on rayon,
//! each chunk a sequential faer product.
//!
//! Why not faer's own parallel matmul: these shapes (n ~ 1e6, 16 x 300 outputs) are split by
//! faer inside each product with a barrier per panel, which on the shared 2-core machine was
//! measured spending a quarter of the eigensolver's time waiting (docs/LARGE_MODELS.md);
//! independent row chunks need one join per product. Results are deterministic: the chunk
//! sums of A^T B are added in chunk order whatever the scheduling.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Rows per chunk: 4096 rows of a 16-column block are 512 KiB, which stays in cache
/// between the reads of the chunk.
const ROW_CHUNK: usize = 4096;

/// A^T B for A (n x p) and B (n x q): p x q (also the distributed reduction's T^T (K T) on a
/// rank's rows, `nlmodes_distributed`).
pub fn tall_gram(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let (n, p, q) = (a.nrows(), a.ncols(), b.ncols());
    let starts: Vec<usize> = (0..n).step_by(ROW_CHUNK).collect();
    let partial: Vec<Mat<f64>> = starts
        .into_par_iter()
        .map(|start| {
            let len = ROW_CHUNK.min(n - start);
            let mut c = Mat::<f64>::zeros(p, q);
            matmul(
                c.as_mut(),
                Accum::Replace,
                a.subrows(start, len).transpose(),
                b.subrows(start, len),
                1.0,
                Par::Seq,
            );
            c
        })
        .collect();
    let mut sum = Mat::<f64>::zeros(p, q);
    for c in &partial {
        sum += c;
    }
    sum
}

/// W <- W - V C for W (n x q), V (n x p), C (p x q).
pub(crate) fn tall_sub_product(w: MatMut<'_, f64>, v: MatRef<'_, f64>, c: MatRef<'_, f64>) {
    w.par_row_chunks_mut(ROW_CHUNK)
        .enumerate()
        .for_each(|(i, w_chunk)| {
            let start = i * ROW_CHUNK;
            let len = w_chunk.nrows();
            matmul(
                w_chunk,
                Accum::Add,
                v.subrows(start, len),
                c,
                -1.0,
                Par::Seq,
            );
        });
}

/// V Y for V (n x p), Y (p x q): n x q.
pub(crate) fn tall_product(v: MatRef<'_, f64>, y: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(v.nrows(), y.ncols());
    out.as_mut()
        .par_row_chunks_mut(ROW_CHUNK)
        .enumerate()
        .for_each(|(i, out_chunk)| {
            let start = i * ROW_CHUNK;
            let len = out_chunk.nrows();
            matmul(
                out_chunk,
                Accum::Replace,
                v.subrows(start, len),
                y,
                1.0,
                Par::Seq,
            );
        });
    out
}

/// V[.., ..q] <- V[.., ..p] Y for V (n x at least p and q columns), Y (p x q), chunk by chunk
/// in place: no n x q temporary (0.8 GB for 100 columns of a million rows).
pub(crate) fn tall_transform_in_place(v: MatMut<'_, f64>, y: MatRef<'_, f64>) {
    let (p, q) = (y.nrows(), y.ncols());
    v.par_row_chunks_mut(ROW_CHUNK).for_each(|chunk| {
        let product = chunk.as_ref().get(.., ..p) * y;
        chunk.get_mut(.., ..q).copy_from(&product);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunked products equal faer's single products to round-off (1e-13 relative) on a
    /// matrix spanning several chunks with a partial last one.
    #[test]
    fn chunked_products_match_plain_ones() {
        let n = 3 * ROW_CHUNK + 17;
        let a = Mat::<f64>::from_fn(n, 5, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let b = Mat::<f64>::from_fn(n, 3, |i, j| ((i * 5 + j) % 13) as f64 * 0.25 - 1.0);
        let c = Mat::<f64>::from_fn(5, 3, |i, j| (i + 2 * j) as f64 - 3.0);
        let close = |x: &Mat<f64>, y: &Mat<f64>| {
            let scale = y.norm_max().max(1.0);
            assert!(
                (x - y).norm_max() <= 1e-13 * scale,
                "{}",
                (x - y).norm_max()
            );
        };
        close(&tall_gram(a.as_ref(), b.as_ref()), &(a.transpose() * &b));
        close(&tall_product(a.as_ref(), c.as_ref()), &(&a * &c));
        let mut w = b.clone();
        tall_sub_product(w.as_mut(), a.as_ref(), c.as_ref());
        close(&w, &(&b - &a * &c));
        let mut v = a.clone();
        tall_transform_in_place(v.as_mut(), c.as_ref());
        close(&v.get(.., ..3).to_owned(), &(&a * &c));
        assert_eq!(v.get(.., 3..), a.get(.., 3..));
    }
}
