//! Memory budget of large reductions: the bytes the next steps will allocate, estimated from the
//! symbolic factorization before any numeric work, against the memory the system has available
//! (`MemAvailable` of `/proc/meminfo`), so that a model too large fails at once with a message
//! naming its size instead of being killed by the kernel minutes later.

use crate::error::ModalError;
pub use nlmodes_sparse::timer::{cpu_seconds, gigabytes, resident_bytes, StepTimer};

/// The large allocations still to come, by name (bytes).
#[derive(Clone, Debug, Default)]
pub struct MemoryEstimate {
    /// What each part is ("factor L of K_ii", "constraint modes", ...) and its bytes.
    pub parts: Vec<(String, usize)>,
}

impl MemoryEstimate {
    /// Adds a part.
    pub fn add(&mut self, what: &str, bytes: usize) {
        self.parts.push((what.to_string(), bytes));
    }

    /// Sum of the parts, bytes.
    pub fn total(&self) -> usize {
        self.parts.iter().map(|(_, b)| b).sum()
    }

    /// "factor L of K_ii 0.94 GB, constraint modes 0.14 GB, ..." (GB = 1e9 bytes).
    pub fn describe(&self) -> String {
        self.parts
            .iter()
            .map(|(what, b)| format!("{what} {}", gigabytes(*b)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The memory available for new allocations now, bytes: `MemAvailable` of `/proc/meminfo`
/// (free memory plus the page cache the kernel can drop). None when it cannot be read (not
/// Linux): the check is then skipped.
pub fn available_bytes() -> Option<usize> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_mem_available(&text)
}

/// `MemAvailable:   23456789 kB` -> bytes.
fn parse_mem_available(meminfo: &str) -> Option<usize> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Ok when `estimate` fits in `available` bytes (None: unknown, Ok); otherwise
/// [`ModalError::InsufficientMemory`] naming `what` (the computation and the model's size), the
/// bytes needed, by part, and the bytes available.
pub fn check_fits(
    what: &str,
    estimate: &MemoryEstimate,
    available: Option<usize>,
) -> Result<(), ModalError> {
    let needed = estimate.total();
    tracing::info!(
        "memory: {what} needs about {} more ({}); available {}",
        gigabytes(needed),
        estimate.describe(),
        available.map_or_else(|| "unknown".to_string(), gigabytes)
    );
    match available {
        Some(available) if needed > available => Err(ModalError::InsufficientMemory {
            what: what.to_string(),
            needed: gigabytes(needed),
            parts: estimate.describe(),
            available: gigabytes(available),
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_in_bytes() {
        let text = "MemTotal:       24570000 kB\nMemFree:  100 kB\nMemAvailable:   22000000 kB\n";
        assert_eq!(parse_mem_available(text), Some(22_000_000 * 1024));
        assert_eq!(parse_mem_available("MemTotal: 1 kB\n"), None);
    }

    /// A model whose factor alone exceeds the memory available fails before any numeric work,
    /// with the size, the need and the availability in the message; one that fits passes, and
    /// an unknown availability never blocks.
    #[test]
    fn too_large_a_model_is_refused_with_its_size() {
        let mut e = MemoryEstimate::default();
        e.add("factor L of K_ii", 14_000_000_000);
        e.add("constraint modes", 600_000_000);
        let what = "Craig-Bampton reduction of a 2100000-DOF model";
        let err = check_fits(what, &e, Some(8_000_000_000)).unwrap_err();
        let msg = err.to_string();
        assert!(
            matches!(err, ModalError::InsufficientMemory { .. }),
            "{msg}"
        );
        for part in [
            "2100000-DOF",
            "14.60 GB",
            "8.00 GB",
            "factor L of K_ii 14.00 GB",
        ] {
            assert!(msg.contains(part), "`{part}` missing from: {msg}");
        }
        assert!(check_fits(what, &e, Some(15_000_000_000)).is_ok());
        assert!(check_fits(what, &e, None).is_ok());
    }
}
