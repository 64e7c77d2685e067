//! Bad-input problems collected before any work: each one line naming the file (or flag), the
//! `table.key`, the value and what was expected; reported together (exit code 2).

use anyhow::Result;
use std::path::Path;

use crate::exit::bad_input;

/// Problems found so far, each labelled by where the value came from.
pub struct Problems {
    /// `label("nnm.samples")` names the setting in a message: `FILE: nnm.samples` for a case
    /// file, `--samples` for a command-line flag.
    label: Box<dyn Fn(&str) -> String>,
    lines: Vec<String>,
}

impl Problems {
    pub fn new(label: impl Fn(&str) -> String + 'static) -> Self {
        Self {
            label: Box::new(label),
            lines: Vec::new(),
        }
    }

    /// Problems of a case file: `FILE: table.key = value: expected ...`.
    pub fn of_file(path: &Path) -> Self {
        let file = path.display().to_string();
        Self::new(move |key| format!("{file}: {key}"))
    }

    /// Records `key = value: expected ...` unless `ok`.
    pub fn check(&mut self, ok: bool, key: &str, value: impl std::fmt::Debug, expected: &str) {
        if !ok {
            let line = format!("{} = {value:?}: expected {expected}", (self.label)(key));
            self.lines.push(line);
        }
    }

    /// Records a message about `key`.
    pub fn note(&mut self, key: &str, message: &str) {
        let line = format!("{}: {message}", (self.label)(key));
        self.lines.push(line);
    }

    /// Ok when nothing was recorded, else one bad-input error listing every problem.
    pub fn finish(self) -> Result<()> {
        if self.lines.is_empty() {
            return Ok(());
        }
        Err(bad_input(self.lines.join("\n")))
    }
}
