//! The parts of an MSH 4.1 file that mshio does not give us: the header checks done before
//! handing the bytes to mshio (version, so that the message can say which version was found;
//! data sizes, on which mshio would panic), `$PhysicalNames` (which mshio ignores) and the node
//! tags (which mshio drops when they are contiguous, assuming they are in increasing order).

use std::path::Path;

use crate::error::FemError;

/// What the `$MeshFormat` header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct MshHeader {
    /// true for ASCII (file-type 0), false for binary (1).
    pub ascii: bool,
    /// Size of `size_t` in bytes (4 or 8).
    pub size_t_size: usize,
    /// Byte order of a binary file (true for ASCII).
    pub little_endian: bool,
}

fn parse_error(path: &Path, message: impl Into<String>) -> FemError {
    FemError::MshParse {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Offset just past the line holding exactly `$name` (optionally with `\r`), if any.
/// Only line starts are considered, so `$Nodes` does not match `$NodeData`.
pub(crate) fn find_section(bytes: &[u8], name: &str) -> Option<usize> {
    let tag = name.as_bytes();
    let mut start = 0;
    while start < bytes.len() {
        let rel = bytes[start..].windows(tag.len()).position(|w| w == tag)?;
        let i = start + rel;
        let at_line_start = i == 0 || bytes[i - 1] == b'\n';
        let mut j = i + tag.len();
        if j < bytes.len() && bytes[j] == b'\r' {
            j += 1;
        }
        if at_line_start && (j == bytes.len() || bytes[j] == b'\n') {
            return Some((j + 1).min(bytes.len()));
        }
        start = i + 1;
    }
    None
}

/// The next line after `pos` (without its terminator) and the offset after it.
fn next_line(bytes: &[u8], pos: usize) -> (&[u8], usize) {
    let rest = &bytes[pos.min(bytes.len())..];
    let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
    let line = &rest[..len];
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    (line, pos + len + 1)
}

/// Reads and checks the `$MeshFormat` header: version 4.1, file type 0 or 1, size_t of 4 or 8
/// bytes, and the byte order of a binary file.
pub(crate) fn read_header(bytes: &[u8], path: &Path) -> Result<MshHeader, FemError> {
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    let (first, pos) = next_line(bytes, start);
    if first.trim_ascii() != b"$MeshFormat" {
        let shown: String = String::from_utf8_lossy(&first[..first.len().min(40)]).into_owned();
        return Err(FemError::NotMsh {
            path: path.to_path_buf(),
            reason: format!("it does not start with $MeshFormat (first line: {shown:?})"),
        });
    }
    let (line, after) = next_line(bytes, pos);
    let text = String::from_utf8_lossy(line);
    let fields: Vec<&str> = text.split_ascii_whitespace().collect();
    let Some(&version) = fields.first() else {
        return Err(parse_error(path, "empty $MeshFormat header line"));
    };
    if version != "4.1" {
        return Err(FemError::UnsupportedMshVersion {
            path: path.to_path_buf(),
            found: version.to_string(),
        });
    }
    let ascii = match fields.get(1).copied() {
        Some("0") => true,
        Some("1") => false,
        other => {
            return Err(parse_error(
                path,
                format!(
                    "$MeshFormat file-type is '{}', expected 0 (ASCII) or 1 (binary)",
                    other.unwrap_or("")
                ),
            ))
        }
    };
    let size_t_size = match fields.get(2).copied() {
        Some("8") => 8,
        Some("4") => 4,
        other => {
            return Err(parse_error(
                path,
                format!(
                    "$MeshFormat data-size is '{}', expected 8 (or 4)",
                    other.unwrap_or("")
                ),
            ))
        }
    };
    let little_endian = if ascii {
        true
    } else {
        let one = bytes
            .get(after..after + 4)
            .ok_or_else(|| parse_error(path, "binary header is truncated"))?;
        match one {
            [1, 0, 0, 0] => true,
            [0, 0, 0, 1] => false,
            _ => {
                return Err(parse_error(
                    path,
                    "binary header: cannot detect the byte order",
                ))
            }
        }
    };
    Ok(MshHeader {
        ascii,
        size_t_size,
        little_endian,
    })
}

/// One `$PhysicalNames` entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct PhysicalName {
    pub dim: usize,
    pub tag: i32,
    pub name: String,
}

/// Parses `$PhysicalNames` (an ASCII section in both ASCII and binary files); empty if absent.
pub(crate) fn physical_names(bytes: &[u8], path: &Path) -> Result<Vec<PhysicalName>, FemError> {
    let Some(mut pos) = find_section(bytes, "$PhysicalNames") else {
        return Ok(Vec::new());
    };
    let bad = |what: &str| parse_error(path, format!("in $PhysicalNames: {what}"));
    let (line, next) = next_line(bytes, pos);
    pos = next;
    let count: usize = std::str::from_utf8(line)
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .ok_or_else(|| bad("the first line must be the number of names"))?;
    let mut names = Vec::with_capacity(count.min(1 << 16));
    for _ in 0..count {
        if pos > bytes.len() {
            return Err(bad(&format!(
                "expected {count} names, the section ends early"
            )));
        }
        let (line, next) = next_line(bytes, pos);
        pos = next;
        let text = String::from_utf8_lossy(line);
        let entry = || {
            bad(&format!(
                "cannot read entry {text:?} (expected: dim tag \"name\")"
            ))
        };
        let mut parts = text.trim().splitn(3, char::is_whitespace);
        let dim: usize = parts
            .next()
            .and_then(|s| s.parse().ok())
            .ok_or_else(entry)?;
        let tag: i32 = parts
            .next()
            .and_then(|s| s.parse().ok())
            .ok_or_else(entry)?;
        let quoted = parts.next().map(str::trim).ok_or_else(entry)?;
        let name = quoted
            .strip_prefix('"')
            .and_then(|s| s.strip_suffix('"'))
            .ok_or_else(entry)?;
        if dim > 3 {
            return Err(bad(&format!(
                "group '{name}' has dimension {dim}, expected 0..3"
            )));
        }
        names.push(PhysicalName {
            dim,
            tag,
            name: name.to_string(),
        });
    }
    Ok(names)
}

/// Reads values of the `$Nodes` section: ASCII tokens or binary fields.
struct NodeSectionReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    header: MshHeader,
    path: &'a Path,
}

impl<'a> NodeSectionReader<'a> {
    fn truncated(&self) -> FemError {
        parse_error(
            self.path,
            format!(
                "$Nodes section is truncated or malformed near byte {}",
                self.pos
            ),
        )
    }

    fn token(&mut self) -> Result<&'a str, FemError> {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.truncated());
        }
        let bytes: &'a [u8] = self.bytes;
        std::str::from_utf8(&bytes[start..self.pos]).map_err(|_| self.truncated())
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], FemError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| self.truncated())?;
        let bytes: &'a [u8] = self.bytes;
        let s = &bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn size_t(&mut self) -> Result<u64, FemError> {
        if self.header.ascii {
            let t = self.token()?;
            return t.parse().map_err(|_| {
                parse_error(
                    self.path,
                    format!("in $Nodes: expected an unsigned integer, found {t:?}"),
                )
            });
        }
        let (n, le) = (self.header.size_t_size, self.header.little_endian);
        let b = self.take(n)?;
        let mut v: u64 = 0;
        for k in 0..n {
            let byte = if le { b[n - 1 - k] } else { b[k] };
            v = (v << 8) | u64::from(byte);
        }
        Ok(v)
    }

    fn int(&mut self) -> Result<i64, FemError> {
        if self.header.ascii {
            let t = self.token()?;
            return t.parse().map_err(|_| {
                parse_error(
                    self.path,
                    format!("in $Nodes: expected an integer, found {t:?}"),
                )
            });
        }
        let b = self.take(4)?;
        let arr = [b[0], b[1], b[2], b[3]];
        Ok(i64::from(if self.header.little_endian {
            i32::from_le_bytes(arr)
        } else {
            i32::from_be_bytes(arr)
        }))
    }

    fn skip_doubles(&mut self, n: usize) -> Result<(), FemError> {
        if self.header.ascii {
            for _ in 0..n {
                self.token()?;
            }
            Ok(())
        } else {
            let len = n.checked_mul(8).ok_or_else(|| self.truncated())?;
            self.take(len).map(|_| ())
        }
    }
}

/// The node tags of every node block of `$Nodes`, in file order (empty if there is no
/// `$Nodes` section).
pub(crate) fn node_tags(
    bytes: &[u8],
    header: MshHeader,
    path: &Path,
) -> Result<Vec<Vec<u64>>, FemError> {
    let Some(pos) = find_section(bytes, "$Nodes") else {
        return Ok(Vec::new());
    };
    let mut r = NodeSectionReader {
        bytes,
        pos,
        header,
        path,
    };
    let n_blocks = r.size_t()?;
    let n_nodes = r.size_t()?;
    let _min_tag = r.size_t()?;
    let _max_tag = r.size_t()?;
    let mut blocks = Vec::new();
    let mut total: u64 = 0;
    for _ in 0..n_blocks {
        let _entity_dim = r.int()?;
        let entity_tag = r.int()?;
        let parametric = r.int()?;
        let count = usize::try_from(r.size_t()?).map_err(|_| r.truncated())?;
        if parametric != 0 {
            return Err(parse_error(
                path,
                format!("node block of entity {entity_tag} is parametric, which is not supported"),
            ));
        }
        // Each tag takes at least one byte: a count beyond the file size is corrupt.
        if count > bytes.len() {
            return Err(r.truncated());
        }
        let mut tags = Vec::with_capacity(count);
        for _ in 0..count {
            tags.push(r.size_t()?);
        }
        r.skip_doubles(3 * count)?;
        total += count as u64;
        blocks.push(tags);
    }
    if total != n_nodes {
        return Err(parse_error(
            path,
            format!("$Nodes announces {n_nodes} nodes but its blocks hold {total}"),
        ));
    }
    Ok(blocks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_whole_line_sections_only() {
        let b = b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$NodeData\nx\n$Nodes\r\n1 2\n";
        let p = find_section(b, "$Nodes").expect("present");
        assert_eq!(&b[p..p + 3], b"1 2");
        assert!(find_section(b, "$Elements").is_none());
    }

    #[test]
    fn header_versions() {
        let p = Path::new("x.msh");
        let h = read_header(b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n", p).expect("ok");
        assert!(h.ascii && h.size_t_size == 8);
        let e = read_header(b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n", p).expect_err("2.2");
        assert!(matches!(e, FemError::UnsupportedMshVersion { ref found, .. } if found == "2.2"));
        let e = read_header(b"hello", p).expect_err("garbage");
        assert!(matches!(e, FemError::NotMsh { .. }));
        let e = read_header(b"$MeshFormat\n4.1 0 3\n$EndMeshFormat\n", p).expect_err("size 3");
        assert!(e.to_string().contains("data-size"), "{e}");
    }

    #[test]
    fn physical_names_parse_names_with_spaces() {
        let b = b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n3 1 \"the blade\"\n0 7 \"tip_edge\"\n$EndPhysicalNames\n";
        let n = physical_names(b, Path::new("x.msh")).expect("ok");
        assert_eq!(n.len(), 2);
        assert_eq!(
            (n[0].dim, n[0].tag, n[0].name.as_str()),
            (3, 1, "the blade")
        );
        assert_eq!((n[1].dim, n[1].tag, n[1].name.as_str()), (0, 7, "tip_edge"));
        let bad = b"$PhysicalNames\n1\n3 x \"a\"\n$EndPhysicalNames\n";
        assert!(physical_names(bad, Path::new("x.msh")).is_err());
    }
}
