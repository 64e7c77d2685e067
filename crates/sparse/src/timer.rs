//! Wall-clock and CPU time of a step and the resident memory of this process, for the log lines
//! of long factorizations and reductions (on a shared machine wall times depend on the load; CPU
//! times less). Linux `/proc` files; every reading is `None` elsewhere.

/// `bytes` as "12.34 GB" (1 GB = 1e9 bytes).
pub fn gigabytes(bytes: usize) -> String {
    format!("{:.2} GB", bytes as f64 * 1e-9)
}

/// CPU time (user + system, all threads) this process has used so far, seconds, from
/// `/proc/self/stat` (fields 14 and 15, in clock ticks of 1/100 s, the Linux USER_HZ); None
/// when it cannot be read. On a shared machine wall times depend on the load; CPU times less.
pub fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after_name = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<f64>().ok();
    Some((ticks(11)? + ticks(12)?) / 100.0)
}

/// Resident memory of this process now and at its peak so far, bytes (`VmRSS` and `VmHWM` of
/// `/proc/self/status`); None when it cannot be read (not Linux).
pub fn resident_bytes() -> Option<(usize, usize)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<usize> {
        let line = status.lines().find(|l| l.starts_with(name))?;
        let kib: usize = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// Wall-clock and CPU time of a step, and the resident memory at its end, for log lines:
/// "12.34 s (CPU 20.10 s), RSS 3.10 GB (peak so far 3.40 GB)".
pub struct StepTimer {
    wall: std::time::Instant,
    cpu: Option<f64>,
}

impl StepTimer {
    /// Starts timing.
    pub fn start() -> Self {
        Self {
            wall: std::time::Instant::now(),
            cpu: cpu_seconds(),
        }
    }

    /// "12.34 s (CPU 20.10 s), RSS 3.10 GB (peak so far 3.40 GB)" since the start (no CPU or
    /// RSS part when it cannot be read).
    pub fn elapsed(&self) -> String {
        let wall = self.wall.elapsed().as_secs_f64();
        let time = match (self.cpu, cpu_seconds()) {
            (Some(a), Some(b)) => format!("{wall:.2} s (CPU {:.2} s)", b - a),
            _ => format!("{wall:.2} s"),
        };
        match resident_bytes() {
            Some((now, peak)) => format!(
                "{time}, RSS {} (peak so far {})",
                gigabytes(now),
                gigabytes(peak)
            ),
            None => time,
        }
    }
}
