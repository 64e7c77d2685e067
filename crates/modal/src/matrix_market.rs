//! Matrix Market files for symmetric real matrices.
//!
//! Written format (NIST Matrix Market, coordinate):
//!
//! ```text
//! %%MatrixMarket matrix coordinate real symmetric
//! % <optional comment lines>
//! <rows> <cols> <entries>
//! <i> <j> <value>          one line per entry of the lower triangle (i >= j), 1-based
//! ```
//!
//! Values are written with `{:.17e}` (18 significant digits), so reading a
//! file back gives bitwise the same f64 values (including -0.0). Dense
//! matrices are written with every lower-triangle entry, zeros included;
//! sparse matrices with their stored lower-triangle entries. Writes are
//! atomic: the file is written as `<name>.tmp` in the same directory, flushed
//! to disk, then renamed.
//!
//! Reading accepts `coordinate` files with field `real`, `double` or
//! `integer` and symmetry `symmetric` (each off-diagonal pair stored once, in
//! either triangle) or `general` (then the matrix must be symmetric to
//! [`SYMMETRY_TOLERANCE`] relative to its largest entry, and the two
//! triangles are averaged). Errors name the file and line: malformed
//! header, size line or entry, wrong entry count, index out of range,
//! duplicated entry, non-finite value, non-square or non-symmetric matrix.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use faer::{Mat, MatRef};
use sprs::{CsMat, TriMat};

use crate::dense::check_dense_symmetric;
use crate::error::ModalError;
use crate::sparse_ops::{as_csc, check_symmetric_input, SYMMETRY_TOLERANCE};

/// Writes a dense symmetric matrix (lower triangle, every entry).
///
/// Errors: not square, non-finite or not symmetric (to [`SYMMETRY_TOLERANCE`]),
/// I/O failures.
pub fn write_symmetric_dense(
    path: &Path,
    a: MatRef<'_, f64>,
    comment: &str,
) -> Result<(), ModalError> {
    let n = check_dense_symmetric(a, &format!("matrix to write to {}", path.display()))?;
    let count = n * (n + 1) / 2;
    write_atomic(path, |w| {
        write_header(w, comment, n, count)?;
        for j in 0..n {
            for i in j..n {
                writeln!(w, "{} {} {:.17e}", i + 1, j + 1, a[(i, j)])?;
            }
        }
        Ok(())
    })
}

/// Writes a sparse symmetric matrix (its stored lower-triangle entries).
///
/// Errors: not square, non-finite or not symmetric, I/O failures.
pub fn write_symmetric_sparse(
    path: &Path,
    a: &CsMat<f64>,
    comment: &str,
) -> Result<(), ModalError> {
    let n = check_symmetric_input(a, &format!("matrix to write to {}", path.display()))?;
    let a = as_csc(a);
    let count = a.iter().filter(|(_, (i, j))| i >= j).count();
    write_atomic(path, |w| {
        write_header(w, comment, n, count)?;
        for (j, col) in a.outer_iterator().enumerate() {
            for (i, &v) in col.iter() {
                if i >= j {
                    writeln!(w, "{} {} {:.17e}", i + 1, j + 1, v)?;
                }
            }
        }
        Ok(())
    })
}

/// Reads a symmetric matrix into a dense faer matrix.
pub fn read_symmetric_dense(path: &Path) -> Result<Mat<f64>, ModalError> {
    let lower = read_lower_triangle(path)?;
    let mut a = Mat::<f64>::zeros(lower.n, lower.n);
    for &(i, j, v) in &lower.entries {
        a[(i, j)] = v;
        a[(j, i)] = v;
    }
    Ok(a)
}

/// Reads a symmetric matrix into a CSC matrix with both triangles stored.
pub fn read_symmetric_sparse(path: &Path) -> Result<CsMat<f64>, ModalError> {
    let lower = read_lower_triangle(path)?;
    let mut t = TriMat::with_capacity((lower.n, lower.n), 2 * lower.entries.len());
    for &(i, j, v) in &lower.entries {
        t.add_triplet(i, j, v);
        if i != j {
            t.add_triplet(j, i, v);
        }
    }
    Ok(t.to_csc())
}

/// Writes `path` through `<path>.tmp` and a rename, so readers never see a
/// partial file.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), ModalError> {
    let tmp = tmp_path(path);
    let io_err = |action: &'static str, p: &Path| {
        let p = p.to_path_buf();
        move |source| ModalError::Io {
            action,
            path: p,
            source,
        }
    };
    let file = File::create(&tmp).map_err(io_err("cannot create", &tmp))?;
    let mut writer = BufWriter::new(file);
    let result = body(&mut writer).and_then(|_| writer.flush());
    let result = result.and_then(|_| writer.get_ref().sync_all());
    if let Err(source) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(ModalError::Io {
            action: "cannot write",
            path: tmp,
            source,
        });
    }
    drop(writer);
    std::fs::rename(&tmp, path).map_err(io_err("cannot rename the temporary file to", path))
}

fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|s| s.to_os_string())
        .unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

fn write_header<W: Write>(w: &mut W, comment: &str, n: usize, count: usize) -> std::io::Result<()> {
    writeln!(w, "%%MatrixMarket matrix coordinate real symmetric")?;
    for line in comment.lines() {
        writeln!(w, "% {line}")?;
    }
    writeln!(w, "{n} {n} {count}")
}

/// A symmetric matrix as its lower triangle: (row, col, value) with row >= col, 0-based.
struct LowerTriangle {
    n: usize,
    entries: Vec<(usize, usize, f64)>,
}

/// One entry as read: 0-based indices, value, 1-based line number.
#[derive(Clone, Copy)]
struct RawEntry {
    row: usize,
    col: usize,
    value: f64,
    line: usize,
}

fn read_lower_triangle(path: &Path) -> Result<LowerTriangle, ModalError> {
    let err = |line: usize, message: String| ModalError::MatrixMarket {
        path: path.to_path_buf(),
        line,
        message,
    };
    let file = File::open(path).map_err(|source| ModalError::Io {
        action: "cannot open",
        path: path.to_path_buf(),
        source,
    })?;
    let mut lines = BufReader::new(file).lines().enumerate();
    let mut next_line = || -> Result<Option<(usize, String)>, ModalError> {
        match lines.next() {
            None => Ok(None),
            Some((i, Ok(text))) => Ok(Some((i + 1, text))),
            Some((i, Err(source))) => Err(ModalError::MatrixMarket {
                path: path.to_path_buf(),
                line: i + 1,
                message: format!("cannot read the line: {source}"),
            }),
        }
    };

    // Header.
    let (line_no, header) = next_line()?.ok_or_else(|| err(0, "the file is empty".to_string()))?;
    let tokens: Vec<String> = header
        .split_whitespace()
        .map(|t| t.to_ascii_lowercase())
        .collect();
    if tokens.len() != 5 || tokens[0] != "%%matrixmarket" || tokens[1] != "matrix" {
        return Err(err(
            line_no,
            format!(
                "malformed header {header:?}: expected \
                 \"%%MatrixMarket matrix coordinate real symmetric\" (or general)"
            ),
        ));
    }
    if tokens[2] != "coordinate" {
        return Err(err(
            line_no,
            format!(
                "format {:?} is not supported: expected coordinate",
                tokens[2]
            ),
        ));
    }
    if !matches!(tokens[3].as_str(), "real" | "double" | "integer") {
        return Err(err(
            line_no,
            format!("field {:?} is not supported: expected real", tokens[3]),
        ));
    }
    let symmetric = match tokens[4].as_str() {
        "symmetric" => true,
        "general" => false,
        other => {
            return Err(err(
                line_no,
                format!("symmetry {other:?} is not supported: expected symmetric or general"),
            ))
        }
    };

    // Size line (after comments and blank lines).
    let (size_line, sizes) = loop {
        match next_line()? {
            None => return Err(err(line_no, "the size line is missing".to_string())),
            Some((_, text)) if text.trim().is_empty() || text.trim_start().starts_with('%') => {}
            Some((no, text)) => break (no, text),
        }
    };
    let fields: Vec<&str> = sizes.split_whitespace().collect();
    let parsed: Vec<Option<usize>> = fields.iter().map(|f| f.parse().ok()).collect();
    let (nrows, ncols, count) = match parsed.as_slice() {
        [Some(r), Some(c), Some(k)] => (*r, *c, *k),
        _ => {
            return Err(err(
                size_line,
                format!("malformed size line {sizes:?}: expected \"rows cols entries\""),
            ))
        }
    };
    if nrows != ncols {
        return Err(err(
            size_line,
            format!("the matrix is {nrows} x {ncols}: a symmetric matrix must be square"),
        ));
    }
    let n = nrows;
    let max_count = if symmetric { n * (n + 1) / 2 } else { n * n };
    if count > max_count {
        return Err(err(
            size_line,
            format!("{count} entries announced but a {n} x {n} matrix holds at most {max_count}"),
        ));
    }

    // Entries.
    let mut raw: Vec<RawEntry> = Vec::with_capacity(count);
    while let Some((no, text)) = next_line()? {
        let trimmed = text.trim();
        if trimmed.is_empty() || trimmed.starts_with('%') {
            continue;
        }
        if raw.len() == count {
            return Err(err(
                no,
                format!("more entries than the {count} announced on line {size_line}"),
            ));
        }
        let fields: Vec<&str> = trimmed.split_whitespace().collect();
        if fields.len() != 3 {
            return Err(err(
                no,
                format!("malformed entry {trimmed:?}: expected \"row col value\""),
            ));
        }
        let index = |s: &str, what: &str| -> Result<usize, ModalError> {
            let v: usize = s
                .parse()
                .map_err(|_| err(no, format!("{what} index {s:?} is not a positive integer")))?;
            if v == 0 || v > n {
                return Err(err(no, format!("{what} index {v} is out of range 1..={n}")));
            }
            Ok(v - 1)
        };
        let row = index(fields[0], "row")?;
        let col = index(fields[1], "column")?;
        let value: f64 = fields[2]
            .parse()
            .map_err(|_| err(no, format!("value {:?} is not a number", fields[2])))?;
        if !value.is_finite() {
            return Err(err(no, format!("value {value} is not finite")));
        }
        raw.push(RawEntry {
            row,
            col,
            value,
            line: no,
        });
    }
    if raw.len() != count {
        return Err(err(
            0,
            format!(
                "the file ends after {} entries but line {size_line} announces {count}",
                raw.len()
            ),
        ));
    }

    // Exact duplicates (same row and column).
    raw.sort_by_key(|e| (e.col, e.row, e.line));
    for w in raw.windows(2) {
        if w[0].row == w[1].row && w[0].col == w[1].col {
            return Err(err(
                w[1].line,
                format!(
                    "entry ({}, {}) (1-based) is repeated: already given on line {}",
                    w[1].row + 1,
                    w[1].col + 1,
                    w[0].line
                ),
            ));
        }
    }

    // Group each entry with its mirror: key (max, min).
    raw.sort_by_key(|e| (e.row.min(e.col), e.row.max(e.col), e.line));
    let scale = raw.iter().fold(0.0_f64, |m, e| m.max(e.value.abs()));
    let bound = SYMMETRY_TOLERANCE * scale;
    let mut entries = Vec::with_capacity(raw.len());
    let mut p = 0;
    while p < raw.len() {
        let e = raw[p];
        let (lo, hi) = (e.row.min(e.col), e.row.max(e.col));
        let mirror = raw
            .get(p + 1)
            .filter(|f| f.row.min(f.col) == lo && f.row.max(f.col) == hi)
            .copied();
        let value = match (symmetric, mirror) {
            (true, Some(f)) => {
                return Err(err(
                    f.line,
                    format!(
                        "entry ({}, {}) mirrors the entry on line {}: a symmetric file stores \
                         each off-diagonal pair once",
                        f.row + 1,
                        f.col + 1,
                        e.line
                    ),
                ))
            }
            (true, None) => e.value,
            (false, _) if lo == hi => e.value,
            (false, other) => {
                let mirror_value = other.map_or(0.0, |f| f.value);
                if (e.value - mirror_value).abs() > bound {
                    let where_mirror =
                        other.map_or("absent".to_string(), |f| format!("line {}", f.line));
                    return Err(err(
                        e.line,
                        format!(
                            "the matrix is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = \
                             {:e} ({where_mirror}); tolerance {:e} relative to the largest \
                             entry (indices 1-based)",
                            e.row + 1,
                            e.col + 1,
                            e.value,
                            e.col + 1,
                            e.row + 1,
                            mirror_value,
                            SYMMETRY_TOLERANCE
                        ),
                    ));
                }
                0.5 * (e.value + mirror_value)
            }
        };
        entries.push((hi, lo, value));
        p += if mirror.is_some() { 2 } else { 1 };
    }
    Ok(LowerTriangle { n, entries })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tmp_name_is_in_the_same_directory() {
        assert_eq!(
            tmp_path(Path::new("/a/b/K.mtx")),
            PathBuf::from("/a/b/K.mtx.tmp")
        );
    }
}
