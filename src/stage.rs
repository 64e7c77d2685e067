//! One stage of `nlmodes run` (issue 23, item 7): the hash of its inputs, the files it writes and
//! its work. Make-like with content hashes instead of time stamps: a stage's inputs (the case
//! keys it reads and the hash of the stage it depends on, or the .geo file's bytes for the mesh)
//! are hashed; the hash is stored in `<layout>/.stamps/<name>` after the stage succeeded, and the
//! stage is skipped when the stored hash equals the new one and its outputs exist. A stage that
//! stops early (`crate::exit::StoppedEarly`) keeps its partial outputs and writes no stamp, so
//! it reruns next time.

use anyhow::Result;
use std::path::{Path, PathBuf};

use crate::layout::Layout;

/// Which stages to run (`nlmodes run --only`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Only {
    Mesh,
    Modes,
    Reduce,
    Backbone,
    Forced,
    /// The prestress and the reduced model at the operating speed (`[rotation]`).
    Speed,
    /// The Campbell diagram (`[rotation]`).
    Campbell,
    /// The speed sweeps through the Campbell crossings (`[speed_sweep]`).
    SpeedSweep,
    Post,
}

/// A stage of the pipeline.
pub trait Stage: Sync {
    /// The stamp's file name and the name in the log (`backbone_mode2`, `speed`, ...).
    fn name(&self) -> String;
    /// The `--only` choice that selects it.
    fn only(&self) -> Only;
    /// The hash of its inputs.
    fn hash(&self) -> &str;
    /// The layout whose `.stamps/` holds its stamp.
    fn layout(&self) -> &Layout;
    /// The files that must exist for it to be up to date.
    fn outputs(&self) -> Vec<PathBuf>;
    /// Computes and writes the outputs.
    fn work(&self) -> Result<()>;
}

/// Whether the stamp holds the stage's hash and every output exists.
pub fn up_to_date(stage: &dyn Stage) -> bool {
    let stored = std::fs::read_to_string(stage.layout().stamp(&stage.name())).unwrap_or_default();
    stored.trim() == stage.hash() && stage.outputs().iter().all(|p| p.exists())
}

/// Records that the stage's outputs belong to its current inputs.
pub fn stamp(stage: &dyn Stage) -> Result<()> {
    let p = stage.layout().stamp(&stage.name());
    std::fs::create_dir_all(p.parent().unwrap_or(Path::new(".")))?;
    crate::post::output::write_atomic(&p, stage.hash().as_bytes())
}

/// Runs the stage unless it is up to date (`force`: even then), and stamps it. The old stamp
/// goes first: the work overwrites the outputs, so a stage that stops early or fails must not
/// leave a stamp that vouches for them (going back to the earlier inputs would otherwise take
/// the partial outputs as up to date and exit 0).
pub fn run_if_needed(stage: &dyn Stage, force: bool) -> Result<()> {
    if !force && up_to_date(stage) {
        let root = &stage.layout().root;
        tracing::info!("stage {}: up to date (in {})", stage.name(), root.display());
        return Ok(());
    }
    let old = stage.layout().stamp(&stage.name());
    if old.exists() {
        std::fs::remove_file(&old)?;
    }
    on_own_thread(|| stage.work())?;
    stamp(stage)
}

/// Runs `work` on a thread of its own (64 MiB of stack, like the main thread's budget and
/// more) and returns its result. Measured on the default case: after the reduction had run
/// ARPACK and its BLAS on the main thread, the backbone that followed on that thread took 16.5 s
/// instead of 8.8 s, with the same points: the libraries leave thread-local CPU state behind
/// (most likely the AVX upper halves of the vector registers, which slow the SSE code after
/// them). A fresh thread per stage starts clean.
pub fn on_own_thread<T: Send>(work: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("stage".into())
            .stack_size(64 << 20)
            .spawn_scoped(s, work)
            .map_err(|e| anyhow::anyhow!("cannot start a thread for the stage: {e}"))?
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p))
    })
}

/// Serialized bytes of a settings table, for a stage hash.
pub fn json<T: serde::Serialize>(v: &T) -> Vec<u8> {
    serde_json::to_vec(v).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stage writing `out.txt`, then failing when `fail` is set.
    struct Probe {
        layout: Layout,
        hash: String,
        fail: bool,
    }

    impl Stage for Probe {
        fn name(&self) -> String {
            "probe".into()
        }
        fn only(&self) -> Only {
            Only::Post
        }
        fn hash(&self) -> &str {
            &self.hash
        }
        fn layout(&self) -> &Layout {
            &self.layout
        }
        fn outputs(&self) -> Vec<PathBuf> {
            vec![self.layout.root.join("out.txt")]
        }
        fn work(&self) -> Result<()> {
            std::fs::write(self.layout.root.join("out.txt"), &self.hash)?;
            anyhow::ensure!(!self.fail, "stopped early");
            Ok(())
        }
    }

    /// Inputs A run, inputs B stop early after overwriting the outputs, then inputs A again:
    /// the stage reruns (the partial outputs of B are not taken for A's).
    #[test]
    fn a_stage_that_stops_early_leaves_no_stamp() {
        let dir = std::env::temp_dir().join(format!("nlmodes-stage-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let probe = |hash: &str, fail| Probe {
            layout: Layout::new(dir.clone()),
            hash: hash.into(),
            fail,
        };
        run_if_needed(&probe("A", false), false).unwrap();
        assert!(up_to_date(&probe("A", false)));
        assert!(run_if_needed(&probe("B", true), false).is_err());
        assert!(
            !up_to_date(&probe("A", false)),
            "B's partial outputs taken for A's"
        );
        run_if_needed(&probe("A", false), false).unwrap();
        assert_eq!(std::fs::read_to_string(dir.join("out.txt")).unwrap(), "A");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
