//! Atomic file writing: all outputs of nlmodes go through here.
//!
//! The data are written to a temporary file `.<name>.tmp-<pid>-<n>` in the target's directory
//! (same file system, so the final rename is atomic), flushed and renamed over the target. If
//! anything fails, or the [`AtomicFile`] is dropped without [`AtomicFile::commit`], the temporary
//! file is removed and the target is left as it was: a reader sees either the old file or the
//! complete new one, also when the process is killed midway (a killed process leaves at most a
//! stale temporary file, which [`remove_stale_temporaries`] clears).
//!
//! There is no `fsync`: the guarantee is against interrupted runs, not against power loss (which
//! the page cache may lose either way). Syncing each of the ~75 VTU frames of a blade run (350 MB)
//! cost 5-8 s on the project machine, more than writing them.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::OutputError;

/// Distinguishes temporary files of concurrent writers within one process.
static SEQUENCE: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically (see the module documentation).
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), OutputError> {
    let mut file = AtomicFile::create(path)?;
    file.put(bytes)?;
    file.commit()
}

/// Creates `path` atomically from what `write` puts into the [`AtomicFile`]. If `write` returns
/// an error, the temporary file is removed, the target is untouched and the error is returned.
pub fn write_atomic_with<F>(path: impl AsRef<Path>, write: F) -> Result<(), OutputError>
where
    F: FnOnce(&mut AtomicFile) -> Result<(), OutputError>,
{
    let mut file = AtomicFile::create(path)?;
    write(&mut file)?; // on error `file` is dropped here, which removes the temporary file
    file.commit()
}

/// A file being written atomically: implements [`Write`]; becomes visible under its target name
/// only on [`commit`](AtomicFile::commit). Dropping it uncommitted removes the temporary file.
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Creates the temporary file next to `path`. Fails if `path` has no file name or its
    /// directory does not exist or is not writable (the error names the path).
    pub fn create(path: impl AsRef<Path>) -> Result<Self, OutputError> {
        let target = path.as_ref().to_path_buf();
        let name = target.file_name().ok_or_else(|| {
            OutputError::invalid(
                format!("output path {}", target.display()),
                "has no file name (expected a path to a file)",
            )
        })?;
        let dir = parent_dir(&target);
        let seq = SEQUENCE.fetch_add(1, Ordering::Relaxed);
        let mut temp_name = std::ffi::OsString::from(".");
        temp_name.push(name);
        temp_name.push(format!(".tmp-{}-{seq}", std::process::id()));
        let temp = dir.join(temp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)
            .map_err(|e| OutputError::io(&temp, e))?;
        Ok(AtomicFile {
            target,
            temp,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The final path of the file.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The temporary path the data go to until the commit.
    pub fn temp_path(&self) -> &Path {
        &self.temp
    }

    /// Writes all of `bytes`, with errors naming the target.
    pub fn put(&mut self, bytes: &[u8]) -> Result<(), OutputError> {
        self.write_all(bytes)
            .map_err(|e| OutputError::io(&self.target, e))
    }

    /// Writes a string (see [`put`](AtomicFile::put)).
    pub fn put_str(&mut self, s: &str) -> Result<(), OutputError> {
        self.put(s.as_bytes())
    }

    /// Flushes and renames the temporary file over the target. On failure the temporary file is
    /// removed and the target is left untouched.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let writer = self.writer.take().ok_or_else(|| {
            OutputError::invalid(self.target.display().to_string(), "committed twice")
        })?;
        let file = writer
            .into_inner()
            .map_err(|e| OutputError::io(&self.target, e.into_error()))?;
        drop(file);
        std::fs::rename(&self.temp, &self.target).map_err(|e| OutputError::io(&self.target, e))?;
        // The temporary name no longer exists: nothing left for Drop to clean.
        self.temp = PathBuf::new();
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.writer.as_mut() {
            Some(w) => w.write(buf),
            None => Err(std::io::Error::other("atomic file already committed")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self.writer.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        drop(self.writer.take());
        if !self.temp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Removes the temporary files (`.<name>.tmp-<pid>-<n>`) that a killed run left under `dir`,
/// recursively; returns how many were removed. A missing `dir` is not an error.
pub fn remove_stale_temporaries(dir: &Path) -> Result<usize, OutputError> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(OutputError::io(dir, e)),
    };
    let mut removed = 0;
    for entry in entries {
        let entry = entry.map_err(|e| OutputError::io(dir, e))?;
        let path = entry.path();
        let kind = entry.file_type().map_err(|e| OutputError::io(&path, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if kind.is_dir() {
            removed += remove_stale_temporaries(&path)?;
        } else if name.starts_with('.') && name.contains(".tmp-") {
            std::fs::remove_file(&path).map_err(|e| OutputError::io(&path, e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// The directory holding `path` (`.` for a bare file name).
fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .expect("read temp dir")
            .map(|e| {
                e.expect("dir entry")
                    .file_name()
                    .to_string_lossy()
                    .into_owned()
            })
            .filter(|n| n.contains(".tmp-"))
            .collect()
    }

    #[test]
    fn stale_temporaries_are_removed_recursively_and_nothing_else() {
        let dir = tempfile::tempdir().expect("tempdir");
        let sub = dir.path().join("amplitude_q9.3");
        std::fs::create_dir_all(&sub).expect("mkdir");
        std::fs::write(sub.join(".frame_000.vtu.tmp-123-4"), b"partial").expect("write");
        std::fs::write(dir.path().join(".backbone.csv.tmp-9-0"), b"partial").expect("write");
        std::fs::write(sub.join("frame_001.vtu"), b"complete").expect("write");
        let removed = remove_stale_temporaries(dir.path()).expect("clean");
        assert_eq!(removed, 2);
        assert!(leftovers(&sub).is_empty() && leftovers(dir.path()).is_empty());
        assert!(sub.join("frame_001.vtu").exists());
        assert_eq!(
            remove_stale_temporaries(&dir.path().join("absent")).expect("absent dir"),
            0
        );
    }

    #[test]
    fn writes_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("a.txt");
        write_atomic(&path, b"first").expect("write");
        assert_eq!(std::fs::read(&path).expect("read"), b"first");
        write_atomic(&path, b"second, longer").expect("overwrite");
        assert_eq!(std::fs::read(&path).expect("read"), b"second, longer");
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn failing_writer_leaves_old_target_and_no_temporary() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("result.csv");
        write_atomic(&path, b"old complete content\n").expect("write");
        let mut temp_seen = PathBuf::new();
        let err = write_atomic_with(&path, |f| {
            f.put_str("new partial line 1\n")?;
            temp_seen = f.temp_path().to_path_buf();
            // The partial data exist only under the temporary name.
            assert!(temp_seen.exists());
            Err(OutputError::invalid("row 2", "simulated failure midway"))
        })
        .expect_err("the writer's error must come back");
        assert!(err.to_string().contains("simulated failure midway"));
        assert_eq!(
            std::fs::read(&path).expect("read"),
            b"old complete content\n",
            "target must keep its old content"
        );
        assert!(!temp_seen.exists(), "temporary file must be removed");
        assert!(leftovers(dir.path()).is_empty());

        // Same when there was no previous target: nothing appears at all.
        let fresh = dir.path().join("fresh.csv");
        let _ = write_atomic_with(&fresh, |f| {
            f.put_str("partial")?;
            Err(OutputError::invalid("x", "fail"))
        });
        assert!(!fresh.exists());
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn dropped_uncommitted_file_is_removed() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("x.vtu");
        {
            let mut f = AtomicFile::create(&path).expect("create");
            f.put(b"abc").expect("put");
            assert_eq!(f.target(), path.as_path());
        }
        assert!(!path.exists());
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn missing_directory_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("no_such_dir").join("x.txt");
        let err = write_atomic(&path, b"x").expect_err("must fail");
        assert!(err.to_string().contains("no_such_dir"), "{err}");
        let err = write_atomic(Path::new("/"), b"x").expect_err("no file name");
        assert!(matches!(err, OutputError::InvalidInput { .. }), "{err:?}");
    }

    #[test]
    fn bare_file_name_goes_to_current_directory() {
        assert_eq!(parent_dir(Path::new("a.txt")), PathBuf::from("."));
        assert_eq!(parent_dir(Path::new("d/a.txt")), PathBuf::from("d"));
    }
}
