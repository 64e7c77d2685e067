//! ParaView data collection (`.pvd`) files: a list of (time step, file) pairs that ParaView
//! opens as one time series (e.g. a nonlinear mode shape at m instants of its period).

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use crate::atomic::write_atomic;
use crate::finite::check_finite_value;
use crate::number::fmt_f64;
use crate::xml::escape;
use crate::OutputError;

/// One data set of the collection.
#[derive(Debug, Clone, Copy)]
pub struct PvdEntry<'a> {
    /// Time value shown by ParaView (any finite unit, e.g. s or fraction of the period).
    pub time: f64,
    /// The data file. A relative path is taken relative to the PVD file's directory and written
    /// as is; an absolute path is rewritten relative to that directory.
    pub file: &'a Path,
}

/// Writes the collection to `path` atomically. Entries keep their order; times must be finite.
pub fn write_pvd(path: &Path, entries: &[PvdEntry]) -> Result<(), OutputError> {
    write_pvd_with_note(path, entries, "")
}

/// As [`write_pvd`], with `note` (e.g. the unit of the time values) as an XML comment after the
/// XML declaration; an empty note writes no comment.
pub fn write_pvd_with_note(
    path: &Path,
    entries: &[PvdEntry],
    note: &str,
) -> Result<(), OutputError> {
    let file = path.display().to_string();
    let base = parent_dir_absolute(path)?;
    let mut s = String::from("<?xml version=\"1.0\"?>\n");
    if !note.is_empty() {
        // "--" may not appear inside an XML comment.
        let _ = writeln!(s, "<!-- {} -->", note.replace("--", "- -"));
    }
    s.push_str(
        "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
         <Collection>\n",
    );
    for (i, e) in entries.iter().enumerate() {
        check_finite_value(&format!("time of entry {i} of {file}"), e.time)?;
        let rel = if e.file.is_absolute() {
            relative_path(&base, e.file)
        } else {
            e.file.to_path_buf()
        };
        let text = rel.to_str().ok_or_else(|| {
            OutputError::invalid(
                format!("entry {i} of {file}"),
                format!("path {} is not valid UTF-8", rel.display()),
            )
        })?;
        if text.is_empty() {
            return Err(OutputError::invalid(
                format!("entry {i} of {file}"),
                "empty data file path",
            ));
        }
        let _ = writeln!(
            s,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>",
            fmt_f64(e.time),
            escape(text)
        );
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    write_atomic(path, s.as_bytes())
}

/// Absolute directory of `path`, without touching the file system.
fn parent_dir_absolute(path: &Path) -> Result<PathBuf, OutputError> {
    let abs = std::path::absolute(path).map_err(|e| OutputError::io(path, e))?;
    Ok(abs.parent().map(Path::to_path_buf).unwrap_or(abs))
}

/// `target` relative to the directory `base` (both absolute), with `..` where needed.
/// `.` and `..` components are resolved lexically.
fn relative_path(base: &Path, target: &Path) -> PathBuf {
    let (b, t) = (lexical_components(base), lexical_components(target));
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    let mut rel = PathBuf::new();
    for _ in common..b.len() {
        rel.push("..");
    }
    for c in &t[common..] {
        rel.push(c.as_os_str());
    }
    rel
}

/// Components of `p` with `.` dropped and `..` applied to the preceding normal component.
fn lexical_components(p: &Path) -> Vec<Component<'_>> {
    let mut out: Vec<Component> = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if matches!(out.last(), Some(Component::Normal(_))) {
                    out.pop();
                }
            }
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths() {
        let r = |b: &str, t: &str| relative_path(Path::new(b), Path::new(t));
        assert_eq!(r("/a/b", "/a/b/c/d.vtu"), PathBuf::from("c/d.vtu"));
        assert_eq!(r("/a/b", "/a/x/d.vtu"), PathBuf::from("../x/d.vtu"));
        assert_eq!(r("/a/b/", "/a/b/./d.vtu"), PathBuf::from("d.vtu"));
        assert_eq!(r("/a/b", "/a/b/../b/d.vtu"), PathBuf::from("d.vtu"));
        assert_eq!(r("/", "/d.vtu"), PathBuf::from("d.vtu"));
    }

    #[test]
    fn writes_collection_with_relative_files() {
        let dir = tempfile::tempdir().expect("tempdir");
        let pvd = dir.path().join("mode.pvd");
        let abs = dir.path().join("frames").join("mode_0001.vtu");
        let entries = [
            PvdEntry {
                time: 0.0,
                file: Path::new("frames/mode_0000.vtu"),
            },
            PvdEntry {
                time: 0.125,
                file: &abs,
            },
        ];
        write_pvd(&pvd, &entries).expect("write pvd");
        let text = std::fs::read_to_string(&pvd).expect("read");
        let sets: Vec<&str> = text.lines().filter(|l| l.contains("<DataSet")).collect();
        assert_eq!(sets.len(), 2);
        assert!(
            sets[0].contains("timestep=\"0\"") && sets[0].contains("file=\"frames/mode_0000.vtu\"")
        );
        assert!(
            sets[1].contains("timestep=\"0.125\"")
                && sets[1].contains("file=\"frames/mode_0001.vtu\"")
        );
        assert!(text.starts_with("<?xml") && text.trim_end().ends_with("</VTKFile>"));
    }

    #[test]
    fn non_finite_time_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let pvd = dir.path().join("bad.pvd");
        let err = write_pvd(
            &pvd,
            &[PvdEntry {
                time: f64::NAN,
                file: Path::new("a.vtu"),
            }],
        )
        .expect_err("NaN time");
        assert!(err.to_string().contains("bad.pvd"), "{err}");
        assert!(!pvd.exists());
    }
}
