use nlmodes_fem::{assemble, fixed_dofs, read_msh, DofMap, Isotropic};
use nlmodes_modal::SparseCholesky;
use std::time::Instant;
fn main() {
    let mesh = read_msh(std::path::Path::new("/tmp/b.msh")).unwrap();
    let mat = Isotropic::new(113.8e9, 0.342, 4430.0).unwrap();
    let fixed = fixed_dofs(&mesh, &["root".to_string()]).unwrap();
    let dofs = DofMap::new(mesh.n_nodes(), &fixed).unwrap();
    let (k, _m) = assemble(&mesh, &mat).unwrap();
    let k = dofs.try_restrict(&k).unwrap();
    let t = Instant::now();
    let f = SparseCholesky::new(&k).unwrap();
    println!(
        "factor {:.2} s nnzL {}",
        t.elapsed().as_secs_f64(),
        f.nnz_l()
    );
    let n = k.rows();
    for b in [1usize, 4, 8, 16, 32] {
        let mut x = faer::Mat::<f64>::from_fn(n, b, |i, j| ((i * 31 + j * 7) % 13) as f64);
        let t = Instant::now();
        for _ in 0..3 {
            f.solve_many(x.as_mut()).unwrap();
        }
        let dt = t.elapsed().as_secs_f64() / 3.0;
        println!(
            "b {b}: {:.3} s per block, {:.4} s per vector",
            dt,
            dt / b as f64
        );
    }
}
