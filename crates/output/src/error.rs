//! The error type of the output crate.

use std::path::PathBuf;

/// Everything that can go wrong while writing outputs. Messages name the file, field or value at
/// fault and say what was expected.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// An operating-system I/O error on `path` (create, write, sync, rename, read).
    #[error("I/O error on {}: {source}", path.display())]
    Io {
        /// The file (or directory) being accessed.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A NaN or infinite value was about to be written: outputs never contain them.
    #[error("{what}: non-finite value {value} at index {index} (outputs must be finite numbers)")]
    NonFinite {
        /// Which data (field name and file) held the value.
        what: String,
        /// Index of the first offending value in the flat data.
        index: usize,
        /// The offending value (NaN, inf or -inf).
        value: f64,
    },
    /// Input data that cannot be written as asked (wrong length, bad index, empty name, ...).
    #[error("{what}: {reason}")]
    InvalidInput {
        /// What was being written (names the file and the item).
        what: String,
        /// What is wrong and what was expected.
        reason: String,
    },
    /// A text file that could not be parsed back (CSV reader).
    #[error("{what}, line {line}: {reason}")]
    Parse {
        /// What was being parsed.
        what: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The SVG could not be rasterized to PNG.
    #[error("cannot render PNG {}: {reason}", path.display())]
    Render {
        /// The PNG file.
        path: PathBuf,
        /// What failed.
        reason: String,
    },
    /// No font is installed, so a PNG would lose all its text (the SVG is unaffected).
    #[error(
        "cannot render PNG {}: no system font found (install e.g. the Debian package \
         fonts-dejavu-core); the plot's text needs one",
        path.display()
    )]
    NoFonts {
        /// The PNG file.
        path: PathBuf,
    },
}

impl OutputError {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        OutputError::Io {
            path: path.into(),
            source,
        }
    }

    /// An [`OutputError::InvalidInput`] from two displayable parts.
    pub fn invalid(what: impl Into<String>, reason: impl Into<String>) -> Self {
        OutputError::InvalidInput {
            what: what.into(),
            reason: reason.into(),
        }
    }
}
