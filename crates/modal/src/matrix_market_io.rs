//! The file plumbing of the Matrix Market readers and writers (`crate::matrix_market`,
//! `crate::matrix_market_general`): a reader of numbered data lines whose errors name the file
//! and the line, and an atomic writer (a temporary file and a rename).

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::ModalError;

/// The lines of a file that carry data (comments and blank lines skipped), numbered from 1.
pub(crate) struct DataLines<'p> {
    path: &'p Path,
    lines: std::iter::Enumerate<std::io::Lines<BufReader<std::fs::File>>>,
}

impl<'p> DataLines<'p> {
    pub(crate) fn open(path: &'p Path) -> Result<Self, ModalError> {
        let file = std::fs::File::open(path).map_err(|source| ModalError::Io {
            action: "cannot open",
            path: path.to_path_buf(),
            source,
        })?;
        Ok(Self {
            path,
            lines: BufReader::new(file).lines().enumerate(),
        })
    }

    pub(crate) fn error(&self, line: usize, message: String) -> ModalError {
        ModalError::MatrixMarket {
            path: self.path.to_path_buf(),
            line,
            message,
        }
    }

    /// The next line, comments included (the header is one).
    pub(crate) fn raw(&mut self) -> Result<Option<(usize, String)>, ModalError> {
        match self.lines.next() {
            None => Ok(None),
            Some((i, Ok(text))) => Ok(Some((i + 1, text))),
            Some((i, Err(e))) => Err(self.error(i + 1, format!("cannot read the line: {e}"))),
        }
    }

    /// The next line with data.
    pub(crate) fn data(&mut self) -> Result<Option<(usize, String)>, ModalError> {
        while let Some((no, text)) = self.raw()? {
            let t = text.trim();
            if !t.is_empty() && !t.starts_with('%') {
                return Ok(Some((no, t.to_string())));
            }
        }
        Ok(None)
    }
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
