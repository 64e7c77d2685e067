//! Logging (tracing) and progress bars (indicatif), both silenced by `--quiet`.

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::LazyLock;
use std::time::Instant;

static QUIET: AtomicBool = AtomicBool::new(false);

/// Every bar and spinner of the run, so that those of stages running side by side (the forced
/// stages at rest and at speed, `crate::run`) stack instead of drawing over each other.
static BARS: LazyLock<MultiProgress> = LazyLock::new(MultiProgress::new);

/// Set up the tracing subscriber. `RUST_LOG` overrides the default level (`info`, or `warn` when quiet).
pub fn init(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
    let default = if quiet { "warn" } else { "info" };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    // Colour only on a terminal (a redirected log gets plain text) and never with NO_COLOR set
    // (https://no-color.org).
    use std::io::IsTerminal;
    let colour = std::io::stderr().is_terminal()
        && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty());
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_target(false)
        .with_ansi(colour)
        .with_writer(std::io::stderr)
        .try_init();
}

pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// A progress bar over `len` steps, hidden when quiet or when stderr is not a terminal.
pub fn bar(len: u64, what: &str) -> ProgressBar {
    if quiet() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>10} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(what.to_string());
    BARS.add(pb)
}

/// A spinner for a stage of unknown length.
pub fn spinner(what: &str) -> ProgressBar {
    if quiet() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new_spinner();
    pb.set_style(
        ProgressStyle::with_template("{spinner} {prefix}: {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    pb.set_prefix(what.to_string());
    let pb = BARS.add(pb);
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}

/// Run `f` with eigensolver options whose progress callback drives a spinner named `what`
/// ("N solves" of (K - sigma M)^-1), cleared when `f` returns.
pub fn with_solve_spinner<T>(
    what: &str,
    f: impl FnOnce(&nlmodes_modal::EigenOptions<'_>) -> T,
) -> T {
    let spinner = spinner(what);
    let tick = |i: usize| {
        if i % 10 == 0 {
            spinner.set_message(format!("{i} solves"));
        }
    };
    let opts = nlmodes_modal::EigenOptions {
        on_iteration: Some(&tick),
        ..nlmodes_modal::EigenOptions::default()
    };
    let out = f(&opts);
    spinner.finish_and_clear();
    out
}

/// Times a stage and logs one line when it ends.
pub struct Stage {
    name: &'static str,
    start: Instant,
}

impl Stage {
    pub fn start(name: &'static str) -> Self {
        tracing::info!("stage {name}: started");
        Self {
            name,
            start: Instant::now(),
        }
    }

    pub fn done(self, what: &str) {
        tracing::info!(
            "stage {}: {} ({:.2} s)",
            self.name,
            what,
            self.start.elapsed().as_secs_f64()
        );
    }
}

/// Print a result (a table or a summary) to stdout; results are printed even with `--quiet`,
/// which silences progress bars and log lines only.
pub fn say(line: &str) {
    println!("{line}");
}
