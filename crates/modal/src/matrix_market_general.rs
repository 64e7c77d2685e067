//! Matrix Market files for general (rectangular, unsymmetric) real matrices, read into a dense
//! matrix: a load of the reduced-model directory (`F.mtx`, n rows, one column per load part).
//!
//! Accepted (NIST Matrix Market):
//!
//! ```text
//! %%MatrixMarket matrix array real general        %%MatrixMarket matrix coordinate real general
//! % <optional comment lines>                      % <optional comment lines>
//! <rows> <cols>                                   <rows> <cols> <entries>
//! <value>      rows x cols lines, column-major    <i> <j> <value>   1-based, missing entries 0
//! ```
//!
//! Field `real`, `double` or `integer`. Errors name the file and the line: malformed header or
//! size line, a value that is not a finite number, an index out of range, a repeated entry, too
//! few or too many values.

use std::path::Path;

use faer::Mat;

use crate::error::ModalError;
use crate::matrix_market_io::DataLines;

/// `array` or `coordinate`, from the header line.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Layout {
    Array,
    Coordinate,
}

fn header(lines: &mut DataLines<'_>) -> Result<Layout, ModalError> {
    let (no, text) = lines
        .raw()?
        .ok_or_else(|| lines.error(0, "the file is empty".into()))?;
    let t: Vec<String> = text
        .split_whitespace()
        .map(str::to_ascii_lowercase)
        .collect();
    let expected = "expected \"%%MatrixMarket matrix array real general\" or \
                    \"%%MatrixMarket matrix coordinate real general\"";
    if t.len() != 5 || t[0] != "%%matrixmarket" || t[1] != "matrix" {
        return Err(lines.error(no, format!("malformed header {text:?}: {expected}")));
    }
    let layout = match t[2].as_str() {
        "array" => Layout::Array,
        "coordinate" => Layout::Coordinate,
        other => return Err(lines.error(no, format!("format {other:?}: {expected}"))),
    };
    if !matches!(t[3].as_str(), "real" | "double" | "integer") || t[4] != "general" {
        return Err(lines.error(no, format!("{} {}: {expected}", t[3], t[4])));
    }
    Ok(layout)
}

/// The size line: `rows cols` (array) or `rows cols entries` (coordinate).
fn sizes(lines: &mut DataLines<'_>, layout: Layout) -> Result<Vec<usize>, ModalError> {
    let (no, text) = lines
        .data()?
        .ok_or_else(|| lines.error(0, "the size line is missing".into()))?;
    let count = if layout == Layout::Array { 2 } else { 3 };
    let v: Vec<usize> = text
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .map_err(|_| lines.error(no, format!("malformed size line {text:?}")))?;
    if v.len() != count || v[0] == 0 || v[1] == 0 {
        let want = if count == 2 {
            "rows cols"
        } else {
            "rows cols entries"
        };
        return Err(lines.error(
            no,
            format!("malformed size line {text:?}: expected \"{want}\", sizes > 0"),
        ));
    }
    Ok(v)
}

fn number(lines: &DataLines<'_>, no: usize, s: &str) -> Result<f64, ModalError> {
    let v: f64 = s
        .parse()
        .map_err(|_| lines.error(no, format!("value {s:?} is not a number")))?;
    if !v.is_finite() {
        return Err(lines.error(no, format!("value {v} is not finite")));
    }
    Ok(v)
}

fn array_values(
    lines: &mut DataLines<'_>,
    rows: usize,
    cols: usize,
) -> Result<Mat<f64>, ModalError> {
    let mut m = Mat::zeros(rows, cols);
    for k in 0..rows * cols {
        let (no, text) = lines.data()?.ok_or_else(|| {
            lines.error(
                0,
                format!(
                    "the file ends after {k} values, {rows} x {cols} = {} expected",
                    rows * cols
                ),
            )
        })?;
        m[(k % rows, k / rows)] = number(lines, no, &text)?;
    }
    if let Some((no, _)) = lines.data()? {
        return Err(lines.error(
            no,
            format!(
                "more than the {} values of a {rows} x {cols} array",
                rows * cols
            ),
        ));
    }
    Ok(m)
}

fn coordinate_values(
    lines: &mut DataLines<'_>,
    rows: usize,
    cols: usize,
    count: usize,
) -> Result<Mat<f64>, ModalError> {
    let mut m = Mat::zeros(rows, cols);
    let mut seen = vec![false; rows * cols];
    for k in 0..count {
        let (no, text) = lines.data()?.ok_or_else(|| {
            lines.error(
                0,
                format!("the file ends after {k} entries, {count} announced"),
            )
        })?;
        let f: Vec<&str> = text.split_whitespace().collect();
        if f.len() != 3 {
            return Err(lines.error(
                no,
                format!("malformed entry {text:?}: expected \"row col value\""),
            ));
        }
        let index = |s: &str, n: usize, what: &str| -> Result<usize, ModalError> {
            match s.parse::<usize>() {
                Ok(v) if (1..=n).contains(&v) => Ok(v - 1),
                _ => Err(lines.error(no, format!("{what} index {s:?} is not in 1..={n}"))),
            }
        };
        let (i, j) = (index(f[0], rows, "row")?, index(f[1], cols, "column")?);
        if std::mem::replace(&mut seen[j * rows + i], true) {
            return Err(lines.error(no, format!("entry ({}, {}) is repeated", i + 1, j + 1)));
        }
        m[(i, j)] = number(lines, no, f[2])?;
    }
    if let Some((no, _)) = lines.data()? {
        return Err(lines.error(no, format!("more entries than the {count} announced")));
    }
    Ok(m)
}

/// Writes `a` as `array real general` (column-major, 18 significant digits, atomically).
pub fn write_dense_general(
    path: &Path,
    a: faer::MatRef<'_, f64>,
    comment: &str,
) -> Result<(), ModalError> {
    use std::io::Write as _;
    crate::matrix_market_io::write_atomic(path, |w| {
        writeln!(w, "%%MatrixMarket matrix array real general")?;
        for line in comment.lines() {
            writeln!(w, "% {line}")?;
        }
        writeln!(w, "{} {}", a.nrows(), a.ncols())?;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                writeln!(w, "{:.17e}", a[(i, j)])?;
            }
        }
        Ok(())
    })
}

/// Reads a general real matrix (array or coordinate format) into a dense matrix.
pub fn read_dense_general(path: &Path) -> Result<Mat<f64>, ModalError> {
    let mut lines = DataLines::open(path)?;
    let layout = header(&mut lines)?;
    let s = sizes(&mut lines, layout)?;
    match layout {
        Layout::Array => array_values(&mut lines, s[0], s[1]),
        Layout::Coordinate => coordinate_values(&mut lines, s[0], s[1], s[2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Mat<f64>, ModalError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("F.mtx");
        std::fs::write(&p, text).unwrap();
        read_dense_general(&p)
    }

    #[test]
    fn written_arrays_read_back_bitwise() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("F.mtx");
        let a = Mat::from_fn(4, 2, |i, j| (i as f64 + 0.1) * (j as f64 - 0.7) / 3.0);
        write_dense_general(&p, a.as_ref(), "a load").unwrap();
        let b = read_dense_general(&p).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn array_is_column_major_and_coordinate_fills_zeros() {
        let a = read("%%MatrixMarket matrix array real general\n% a load\n3 2\n1\n2\n3\n4\n5\n6\n")
            .unwrap();
        assert_eq!((a.nrows(), a.ncols()), (3, 2));
        assert_eq!(
            (a[(0, 0)], a[(2, 0)], a[(0, 1)], a[(2, 1)]),
            (1.0, 3.0, 4.0, 6.0)
        );
        let c = read("%%MatrixMarket matrix coordinate real general\n3 2 2\n2 1 -1.5\n3 2 2e-3\n")
            .unwrap();
        assert_eq!(
            (c[(1, 0)], c[(2, 1)], c[(0, 0)], c[(0, 1)]),
            (-1.5, 2e-3, 0.0, 0.0)
        );
    }

    #[test]
    fn errors_name_the_line_and_what_is_wrong() {
        let cases = [
            (
                "%%MatrixMarket matrix array real general\n2 1\n1\n",
                "ends after 1 values",
            ),
            (
                "%%MatrixMarket matrix array real general\n2 1\n1\n2\n3\n",
                "F.mtx:5: more than",
            ),
            (
                "%%MatrixMarket matrix array real general\n2 1\n1\nnan\n",
                "F.mtx:4: value",
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 1\n3 1 1.0\n",
                "row index \"3\"",
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1\n1 1 2\n",
                "repeated",
            ),
            (
                "%%MatrixMarket matrix array real symmetric\n2 2\n",
                "expected",
            ),
            ("1 2 3\n", "malformed header"),
        ];
        for (text, want) in cases {
            let e = read(text).unwrap_err().to_string();
            assert!(e.contains(want), "`{want}` not in `{e}`");
        }
        let e = read("%%MatrixMarket matrix array real general\n2 1\n1\nnan\n").unwrap_err();
        assert!(
            e.to_string().contains("not finite") || e.to_string().contains("not a number"),
            "{e}"
        );
    }
}
