//! Matrix Market round trips and malformed files.

mod common;

use std::path::Path;

use common::{spring_grid, Lcg};
use faer::Mat;
use nlmodes_modal::matrix_market::{
    read_symmetric_dense, read_symmetric_sparse, write_symmetric_dense, write_symmetric_sparse,
};
use nlmodes_modal::ModalError;

/// A dense symmetric matrix with awkward values: random mantissas over many
/// magnitudes, subnormal, -0.0, exact zeros.
fn awkward(n: usize) -> Mat<f64> {
    let mut rng = Lcg::new(99);
    let mut a = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        for i in j..n {
            let e = (rng.next_f64() * 60.0 - 30.0).round() as i32;
            let v = (2.0 * rng.next_f64() - 1.0) * 10f64.powi(e);
            a[(i, j)] = v;
            a[(j, i)] = v;
        }
    }
    a[(1, 0)] = -0.0;
    a[(0, 1)] = -0.0;
    a[(2, 2)] = 0.0;
    a[(3, 1)] = 5e-324;
    a[(1, 3)] = 5e-324;
    a
}

/// Writing with `{:.17e}` and reading back must reproduce every bit
/// (18 significant digits identify an f64 uniquely).
#[test]
fn dense_round_trip_is_bitwise() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("A.mtx");
    let a = awkward(9);
    write_symmetric_dense(&path, a.as_ref(), "test matrix\nsecond comment line").unwrap();
    assert!(
        !dir.path().join("A.mtx.tmp").exists(),
        "temporary file left behind"
    );
    let b = read_symmetric_dense(&path).unwrap();
    for j in 0..9 {
        for i in 0..9 {
            assert_eq!(a[(i, j)].to_bits(), b[(i, j)].to_bits(), "({i}, {j})");
        }
    }
}

#[test]
fn sparse_round_trip_is_bitwise() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("K.mtx");
    let (k, _) = spring_grid(5, 4, 3, 8);
    write_symmetric_sparse(&path, &k, "").unwrap();
    let back = read_symmetric_sparse(&path).unwrap();
    assert_eq!(back.shape(), k.shape());
    assert_eq!(back.nnz(), k.nnz());
    for (&v, (i, j)) in k.iter() {
        assert_eq!(back.get(i, j).map(|x| x.to_bits()), Some(v.to_bits()));
    }
}

fn write(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
}

fn read_err(text: &str) -> ModalError {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.mtx");
    write(&path, text);
    read_symmetric_dense(&path).unwrap_err()
}

fn assert_error(text: &str, line: usize, fragment: &str) {
    let err = read_err(text);
    match &err {
        ModalError::MatrixMarket {
            line: l,
            message,
            path,
        } => {
            assert_eq!(*l, line, "{err}");
            assert!(message.contains(fragment), "{err}");
            assert!(path.ends_with("bad.mtx"));
        }
        other => panic!("unexpected error {other}"),
    }
    assert!(
        err.to_string().contains(&format!("bad.mtx:{line}:")),
        "{err}"
    );
}

#[test]
fn malformed_files_give_errors_naming_file_and_line() {
    assert_error("", 0, "empty");
    assert_error(
        "%%MatrixMarket matrix coordinate real\n2 2 1\n1 1 1\n",
        1,
        "malformed header",
    );
    assert_error(
        "%%MatrixMarket matrix array real symmetric\n2 2\n1\n",
        1,
        "coordinate",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate complex symmetric\n",
        1,
        "field",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real skew-symmetric\n",
        1,
        "symmetry",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n% c\n2 x 1\n",
        3,
        "size line",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 3 1\n",
        2,
        "square",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 1.0\n",
        0,
        "ends after 1 entries",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 1 1.0\n2 2 1.0\n",
        4,
        "more entries",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n3 1 1.0\n",
        3,
        "out of range",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n0 1 1.0\n",
        3,
        "out of range",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 1 abc\n",
        3,
        "not a number",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 1 nan\n",
        3,
        "not finite",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 1.0\n1 1 2.0\n",
        4,
        "repeated",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 1.0\n2 1 0.5\n1 2 0.5\n",
        5,
        "mirrors",
    );
    assert_error(
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 1\n",
        3,
        "malformed entry",
    );
}

/// A `general` file is accepted when symmetric and rejected otherwise, the
/// error naming an offending entry and the lines involved.
#[test]
fn general_files_are_checked_for_symmetry() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.mtx");
    write(
        &good,
        "%%MatrixMarket matrix coordinate real general\n2 2 4\n1 1 2.0\n2 1 -1.0\n1 2 -1.0\n2 2 3.0\n",
    );
    let a = read_symmetric_dense(&good).unwrap();
    assert_eq!(
        (a[(0, 0)], a[(1, 0)], a[(0, 1)], a[(1, 1)]),
        (2.0, -1.0, -1.0, 3.0)
    );
    let err = read_err(
        "%%MatrixMarket matrix coordinate real general\n2 2 4\n1 1 2.0\n2 1 -1.0\n1 2 -1.5\n2 2 3.0\n",
    );
    let text = err.to_string();
    assert!(text.contains("not symmetric"), "{text}");
    assert!(
        text.contains("line 5") || text.contains("bad.mtx:5:"),
        "{text}"
    );
    // A missing mirror entry is an asymmetry too.
    let err = read_err("%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 2.0\n2 1 -1.0\n");
    assert!(err.to_string().contains("absent"), "{err}");
}

/// Writing a non-symmetric matrix is refused (the upper triangle would be lost).
#[test]
fn writing_a_non_symmetric_matrix_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let a = faer::mat![[1.0, 2.0], [3.0, 4.0]];
    let err = write_symmetric_dense(&dir.path().join("A.mtx"), a.as_ref(), "").unwrap_err();
    assert!(matches!(err, ModalError::NotSymmetric { .. }), "{err}");
    assert!(!dir.path().join("A.mtx").exists());
}
