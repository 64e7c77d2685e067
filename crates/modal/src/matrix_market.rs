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

use std::io::Write;
use std::path::Path;

use faer::{Mat, MatRef};
use sprs::{CsMat, TriMat};

use crate::error::ModalError;
use crate::matrix_market_io::{write_atomic, DataLines};
use nlmodes_sparse::ops::{as_csc, check_symmetric_input, SYMMETRY_TOLERANCE};

/// Writes a dense symmetric matrix (lower triangle, every entry).
///
/// Errors: not square, non-finite or not symmetric (to [`SYMMETRY_TOLERANCE`]),
/// I/O failures.
pub fn write_symmetric_dense(
    path: &Path,
    a: MatRef<'_, f64>,
    comment: &str,
) -> Result<(), ModalError> {
    let what = format!("matrix to write to {}", path.display());
    let n = nlmodes_dense::check_symmetric(a).map_err(ModalError::symmetry(&what))?;
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
    let mut lines = DataLines::open(path)?;
    let (header_line, symmetric) = coordinate_header(&mut lines)?;
    let (n, count, size_line) = square_size(&mut lines, header_line, symmetric)?;
    let mut raw = entries(&mut lines, n, count, size_line)?;
    check_repeats(&lines, &mut raw)?;
    let entries = fold_triangles(&lines, raw, symmetric)?;
    Ok(LowerTriangle { n, entries })
}

/// The header of a coordinate file: its line and whether it is `symmetric` (else `general`).
fn coordinate_header(lines: &mut DataLines<'_>) -> Result<(usize, bool), ModalError> {
    let (no, header) = lines
        .raw()?
        .ok_or_else(|| lines.error(0, "the file is empty".to_string()))?;
    let tokens: Vec<String> = header
        .split_whitespace()
        .map(|t| t.to_ascii_lowercase())
        .collect();
    if tokens.len() != 5 || tokens[0] != "%%matrixmarket" || tokens[1] != "matrix" {
        return Err(lines.error(
            no,
            format!(
                "malformed header {header:?}: expected \
                 \"%%MatrixMarket matrix coordinate real symmetric\" (or general)"
            ),
        ));
    }
    if tokens[2] != "coordinate" {
        let message = format!(
            "format {:?} is not supported: expected coordinate",
            tokens[2]
        );
        return Err(lines.error(no, message));
    }
    if !matches!(tokens[3].as_str(), "real" | "double" | "integer") {
        let message = format!("field {:?} is not supported: expected real", tokens[3]);
        return Err(lines.error(no, message));
    }
    match tokens[4].as_str() {
        "symmetric" => Ok((no, true)),
        "general" => Ok((no, false)),
        other => Err(lines.error(
            no,
            format!("symmetry {other:?} is not supported: expected symmetric or general"),
        )),
    }
}

/// The size line of a square matrix: (n, entries announced, its line number).
fn square_size(
    lines: &mut DataLines<'_>,
    header_line: usize,
    symmetric: bool,
) -> Result<(usize, usize, usize), ModalError> {
    let (no, sizes) = lines
        .data()?
        .ok_or_else(|| lines.error(header_line, "the size line is missing".to_string()))?;
    let parsed: Vec<Option<usize>> = sizes.split_whitespace().map(|f| f.parse().ok()).collect();
    let (nrows, ncols, count) = match parsed.as_slice() {
        [Some(r), Some(c), Some(k)] => (*r, *c, *k),
        _ => {
            let message = format!("malformed size line {sizes:?}: expected \"rows cols entries\"");
            return Err(lines.error(no, message));
        }
    };
    if nrows != ncols {
        let message = format!("the matrix is {nrows} x {ncols}: a symmetric matrix must be square");
        return Err(lines.error(no, message));
    }
    let n = nrows;
    let max_count = if symmetric { n * (n + 1) / 2 } else { n * n };
    if count > max_count {
        let message =
            format!("{count} entries announced but a {n} x {n} matrix holds at most {max_count}");
        return Err(lines.error(no, message));
    }
    Ok((n, count, no))
}

/// The `count` entries announced on line `size_line`, 0-based, finite, in range.
fn entries(
    lines: &mut DataLines<'_>,
    n: usize,
    count: usize,
    size_line: usize,
) -> Result<Vec<RawEntry>, ModalError> {
    let mut raw: Vec<RawEntry> = Vec::with_capacity(count);
    while let Some((no, trimmed)) = lines.data()? {
        if raw.len() == count {
            let message = format!("more entries than the {count} announced on line {size_line}");
            return Err(lines.error(no, message));
        }
        raw.push(entry(lines, no, &trimmed, n)?);
    }
    if raw.len() != count {
        let message = format!(
            "the file ends after {} entries but line {size_line} announces {count}",
            raw.len()
        );
        return Err(lines.error(0, message));
    }
    Ok(raw)
}

/// One `row col value` line.
fn entry(
    lines: &DataLines<'_>,
    no: usize,
    trimmed: &str,
    n: usize,
) -> Result<RawEntry, ModalError> {
    let fields: Vec<&str> = trimmed.split_whitespace().collect();
    if fields.len() != 3 {
        let message = format!("malformed entry {trimmed:?}: expected \"row col value\"");
        return Err(lines.error(no, message));
    }
    let index = |s: &str, what: &str| -> Result<usize, ModalError> {
        let v: usize = s.parse().map_err(|_| {
            lines.error(no, format!("{what} index {s:?} is not a positive integer"))
        })?;
        if v == 0 || v > n {
            return Err(lines.error(no, format!("{what} index {v} is out of range 1..={n}")));
        }
        Ok(v - 1)
    };
    let row = index(fields[0], "row")?;
    let col = index(fields[1], "column")?;
    let value: f64 = fields[2]
        .parse()
        .map_err(|_| lines.error(no, format!("value {:?} is not a number", fields[2])))?;
    if !value.is_finite() {
        return Err(lines.error(no, format!("value {value} is not finite")));
    }
    Ok(RawEntry {
        row,
        col,
        value,
        line: no,
    })
}

/// Exact repeats (the same row and column twice) are an error.
fn check_repeats(lines: &DataLines<'_>, raw: &mut [RawEntry]) -> Result<(), ModalError> {
    raw.sort_by_key(|e| (e.col, e.row, e.line));
    for w in raw.windows(2) {
        if w[0].row == w[1].row && w[0].col == w[1].col {
            let message = format!(
                "entry ({}, {}) (1-based) is repeated: already given on line {}",
                w[1].row + 1,
                w[1].col + 1,
                w[0].line
            );
            return Err(lines.error(w[1].line, message));
        }
    }
    Ok(())
}

/// Each entry with its mirror: once per pair in a symmetric file; in a general one the two
/// triangles must agree to [`SYMMETRY_TOLERANCE`] and are averaged. (row, col, value), row >= col.
fn fold_triangles(
    lines: &DataLines<'_>,
    mut raw: Vec<RawEntry>,
    symmetric: bool,
) -> Result<Vec<(usize, usize, f64)>, ModalError> {
    raw.sort_by_key(|e| (e.row.min(e.col), e.row.max(e.col), e.line));
    let scale = raw.iter().fold(0.0_f64, |m, e| m.max(e.value.abs()));
    let bound = SYMMETRY_TOLERANCE * scale;
    let mut folded = Vec::with_capacity(raw.len());
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
                let message = format!(
                    "entry ({}, {}) mirrors the entry on line {}: a symmetric file stores \
                     each off-diagonal pair once",
                    f.row + 1,
                    f.col + 1,
                    e.line
                );
                return Err(lines.error(f.line, message));
            }
            (true, None) => e.value,
            (false, _) if lo == hi => e.value,
            (false, other) => mirrored_value(lines, e, other, bound)?,
        };
        folded.push((hi, lo, value));
        p += if mirror.is_some() { 2 } else { 1 };
    }
    Ok(folded)
}

/// The average of an off-diagonal entry of a general file and its mirror (0 when absent), or
/// the error when they differ by more than `bound`.
fn mirrored_value(
    lines: &DataLines<'_>,
    e: RawEntry,
    mirror: Option<RawEntry>,
    bound: f64,
) -> Result<f64, ModalError> {
    let mirror_value = mirror.map_or(0.0, |f| f.value);
    if (e.value - mirror_value).abs() <= bound {
        return Ok(0.5 * (e.value + mirror_value));
    }
    let where_mirror = mirror.map_or("absent".to_string(), |f| format!("line {}", f.line));
    let message = format!(
        "the matrix is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = {:e} \
         ({where_mirror}); tolerance {:e} relative to the largest entry (indices 1-based)",
        e.row + 1,
        e.col + 1,
        e.value,
        e.col + 1,
        e.row + 1,
        mirror_value,
        SYMMETRY_TOLERANCE
    );
    Err(lines.error(e.line, message))
}
