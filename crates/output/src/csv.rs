//! Small CSV tables (RFC 4180 quoting, `\n` line ends), written atomically at full precision.
//!
//! Numbers are written with the shortest digits that parse back to the same `f64` (exponent
//! notation below 1e-5 and from 1e16 on); NaN and infinities are refused.

use std::path::Path;

use crate::atomic::write_atomic;
use crate::finite::check_finite_value;
use crate::number::fmt_f64;
use crate::OutputError;

/// One cell of a table.
#[derive(Debug, Clone, PartialEq)]
pub enum CsvValue {
    /// A finite number, written at full precision.
    Num(f64),
    /// An integer (counts, indices).
    Int(i64),
    /// Text, quoted when it holds a comma, a quote or a line break.
    Text(String),
}

impl From<f64> for CsvValue {
    fn from(v: f64) -> Self {
        CsvValue::Num(v)
    }
}

impl From<i64> for CsvValue {
    fn from(v: i64) -> Self {
        CsvValue::Int(v)
    }
}

impl From<usize> for CsvValue {
    fn from(v: usize) -> Self {
        // usize above i64::MAX cannot occur for counts held in memory; saturate rather than wrap.
        CsvValue::Int(i64::try_from(v).unwrap_or(i64::MAX))
    }
}

impl From<&str> for CsvValue {
    fn from(v: &str) -> Self {
        CsvValue::Text(v.to_string())
    }
}

impl From<String> for CsvValue {
    fn from(v: String) -> Self {
        CsvValue::Text(v)
    }
}

/// A table: a header and rows of the same width.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvTable {
    header: Vec<String>,
    rows: Vec<Vec<CsvValue>>,
}

impl CsvTable {
    /// A table with the given column names.
    pub fn new<S: AsRef<str>>(header: &[S]) -> Self {
        CsvTable {
            header: header.iter().map(|h| h.as_ref().to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Column names.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Rows added so far.
    pub fn rows(&self) -> &[Vec<CsvValue>] {
        &self.rows
    }

    /// Appends a row; refuses a wrong width or a non-finite number (naming row and column).
    pub fn push_row(&mut self, row: Vec<CsvValue>) -> Result<(), OutputError> {
        let r = self.rows.len();
        if row.len() != self.header.len() {
            return Err(OutputError::invalid(
                format!("CSV row {r}"),
                format!(
                    "{} values; expected {} (one per column)",
                    row.len(),
                    self.header.len()
                ),
            ));
        }
        for (c, v) in row.iter().enumerate() {
            if let CsvValue::Num(x) = v {
                check_finite_value(&format!("CSV row {r}, column `{}`", self.header[c]), *x)?;
            }
        }
        self.rows.push(row);
        Ok(())
    }

    /// Appends a row of numbers (see [`push_row`](CsvTable::push_row)).
    pub fn push_numbers(&mut self, row: &[f64]) -> Result<(), OutputError> {
        self.push_row(row.iter().map(|&v| CsvValue::Num(v)).collect())
    }

    /// The CSV text: header line, then one line per row, each ending in `\n`.
    pub fn to_csv_string(&self) -> String {
        let mut s = String::new();
        push_line(&mut s, self.header.iter().map(|h| quote(h)));
        for row in &self.rows {
            push_line(
                &mut s,
                row.iter().map(|v| match v {
                    CsvValue::Num(x) => fmt_f64(*x),
                    CsvValue::Int(i) => i.to_string(),
                    CsvValue::Text(t) => quote(t),
                }),
            );
        }
        s
    }

    /// Writes the table to `path` atomically.
    pub fn write(&self, path: &Path) -> Result<(), OutputError> {
        write_atomic(path, self.to_csv_string().as_bytes())
    }
}

/// Writes numeric columns of equal length (e.g. `q`, `omega/omega1`) as a CSV file.
pub fn write_csv_columns(
    path: &Path,
    header: &[&str],
    columns: &[&[f64]],
) -> Result<(), OutputError> {
    let file = path.display().to_string();
    if header.len() != columns.len() {
        return Err(OutputError::invalid(
            file,
            format!(
                "{} column names for {} columns",
                header.len(),
                columns.len()
            ),
        ));
    }
    let n = columns.first().map_or(0, |c| c.len());
    if let Some(k) = columns.iter().position(|c| c.len() != n) {
        return Err(OutputError::invalid(
            file,
            format!(
                "column `{}` has {} values; column `{}` has {n}",
                header[k],
                columns[k].len(),
                header[0]
            ),
        ));
    }
    let mut table = CsvTable::new(header);
    for i in 0..n {
        table
            .push_numbers(&columns.iter().map(|c| c[i]).collect::<Vec<_>>())
            .map_err(|e| match e {
                OutputError::NonFinite { what, index, value } => OutputError::NonFinite {
                    what: format!("{what} of {file}"),
                    index,
                    value,
                },
                other => other,
            })?;
    }
    table.write(path)
}

/// Parses CSV text (RFC 4180: quoted fields may hold commas, `""` and line breaks; `\n` or
/// `\r\n` line ends) into records of fields. `what` names the source in errors. Only the tests
/// read CSV back, so it is not part of the crate's API.
#[cfg(test)]
pub(crate) fn parse_csv(what: &str, text: &str) -> Result<Vec<Vec<String>>, OutputError> {
    let mut records = Vec::new();
    let mut record = Vec::new();
    let mut field = String::new();
    let mut chars = text.chars().peekable();
    let mut line = 1usize;
    let mut in_quotes = false;
    let mut field_started = false;
    while let Some(c) = chars.next() {
        if in_quotes {
            match c {
                '"' if chars.peek() == Some(&'"') => {
                    chars.next();
                    field.push('"');
                }
                '"' => {
                    in_quotes = false;
                    if !matches!(chars.peek(), None | Some(',') | Some('\n') | Some('\r')) {
                        return Err(OutputError::Parse {
                            what: what.to_string(),
                            line,
                            reason: "text after a closing quote".into(),
                        });
                    }
                }
                '\n' => {
                    line += 1;
                    field.push(c);
                }
                _ => field.push(c),
            }
            continue;
        }
        match c {
            '"' if !field_started => {
                in_quotes = true;
                field_started = true;
            }
            '"' => {
                return Err(OutputError::Parse {
                    what: what.to_string(),
                    line,
                    reason: "quote inside an unquoted field".into(),
                })
            }
            ',' => {
                record.push(std::mem::take(&mut field));
                field_started = false;
            }
            '\r' if chars.peek() == Some(&'\n') => {}
            '\n' => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
                field_started = false;
                line += 1;
            }
            _ => {
                field.push(c);
                field_started = true;
            }
        }
    }
    if in_quotes {
        return Err(OutputError::Parse {
            what: what.to_string(),
            line,
            reason: "unterminated quoted field".into(),
        });
    }
    if field_started || !record.is_empty() {
        record.push(field);
        records.push(record);
    }
    Ok(records)
}

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn push_line(s: &mut String, cells: impl Iterator<Item = String>) {
    for (i, c) in cells.enumerate() {
        if i > 0 {
            s.push(',');
        }
        s.push_str(&c);
    }
    s.push('\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_through_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("backbone.csv");
        let mut t = CsvTable::new(&["q/g0", "omega/omega1", "label", "n_active"]);
        let rows: Vec<(f64, f64, &str, i64)> = vec![
            (0.0, 1.0, "linear", 0),
            (5.7, 1.0000000000000002, "a, \"quoted\" one", 0),
            (9.3, 1.0123456789012345, "multi\nline", 2),
            (31.3, 1.2e-17, "", 9),
            (-1e300, 6.02214076e23, "ünïcode", -1),
        ];
        for &(a, b, s, n) in &rows {
            t.push_row(vec![a.into(), b.into(), s.into(), n.into()])
                .expect("push");
        }
        t.write(&path).expect("write");
        let text = std::fs::read_to_string(&path).expect("read");
        let rec = parse_csv("backbone.csv", &text).expect("parse");
        assert_eq!(rec.len(), rows.len() + 1);
        assert_eq!(rec[0], vec!["q/g0", "omega/omega1", "label", "n_active"]);
        for (r, &(a, b, s, n)) in rec[1..].iter().zip(&rows) {
            // Exact equality: the format is round-trip by construction.
            assert_eq!(r[0].parse::<f64>().expect("f64").to_bits(), a.to_bits());
            assert_eq!(r[1].parse::<f64>().expect("f64").to_bits(), b.to_bits());
            assert_eq!(r[2], s);
            assert_eq!(r[3].parse::<i64>().expect("i64"), n);
        }
    }

    #[test]
    fn columns_writer_checks_lengths_and_values() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("cols.csv");
        write_csv_columns(&path, &["t", "u"], &[&[0.0, 0.5], &[1.0, -1.0]]).expect("write");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            "t,u\n0,1\n0.5,-1\n"
        );
        let err =
            write_csv_columns(&path, &["t", "u"], &[&[0.0, 0.5], &[1.0]]).expect_err("ragged");
        assert!(err.to_string().contains("cols.csv"), "{err}");
        let err = write_csv_columns(&path, &["t", "u"], &[&[0.0, 0.5], &[1.0, f64::NAN]])
            .expect_err("NaN");
        let msg = err.to_string();
        assert!(
            msg.contains("column `u`") && msg.contains("row 1") && msg.contains("cols.csv"),
            "{msg}"
        );
        // The failed writes left the first file intact.
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            "t,u\n0,1\n0.5,-1\n"
        );
    }

    #[test]
    fn push_row_checks_width() {
        let mut t = CsvTable::new(&["a", "b"]);
        assert!(t.push_numbers(&[1.0]).is_err());
        assert!(t.push_numbers(&[1.0, f64::INFINITY]).is_err());
        assert!(t.rows().is_empty());
    }

    #[test]
    fn parser_rejects_malformed_input() {
        assert!(parse_csv("x", "a,\"b").is_err());
        assert!(parse_csv("x", "a,b\"c\n").is_err());
        assert!(parse_csv("x", "\"a\"b\n").is_err());
        let r = parse_csv("x", "a,b\r\n1,2").expect("crlf");
        assert_eq!(r, vec![vec!["a", "b"], vec!["1", "2"]]);
    }
}
