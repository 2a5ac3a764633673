//! Terminal concerns: progress bars, output, exit codes.

use std::io::{IsTerminal, Write};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use spincal::progress::Progress;

/// What every command gets: whether progress may be drawn.
#[derive(Clone, Copy)]
pub struct Ui {
    show_progress: bool,
}

impl Ui {
    pub fn new(quiet: bool) -> Ui {
        Ui {
            show_progress: !quiet && std::io::stderr().is_terminal(),
        }
    }

    /// A progress bar on stderr for `total` steps, hidden when quiet or not a terminal.
    pub fn progress(&self, total: u64, message: &str) -> ProgressBar {
        if !self.show_progress {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
                .expect("static template")
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        bar
    }

    /// A group of bars drawn together on stderr (one per fleet unit); hidden when quiet or not a
    /// terminal. Bars made by [`Ui::progress`] are added to it.
    pub fn multi(&self) -> MultiProgress {
        if self.show_progress {
            MultiProgress::new()
        } else {
            MultiProgress::with_draw_target(ProgressDrawTarget::hidden())
        }
    }

    /// A spinner for work of unknown length.
    pub fn spinner(&self, message: &str) -> ProgressBar {
        if !self.show_progress {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new_spinner();
        bar.set_message(message.to_string());
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        bar
    }
}

/// Shows the library's progress on a bar: the stage as its message, done of total.
pub fn show(bar: &ProgressBar, p: Progress) {
    bar.set_message(p.stage.to_string());
    if let Some(total) = p.total {
        bar.set_length(total.max(1) as u64);
    }
    bar.set_position(p.done as u64);
}

/// Writes `text` to stdout; a closed pipe ends the program quietly with success.
pub fn print(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        other => Ok(other?),
    }
}

/// Writes a serialisable value as pretty JSON to stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    print(&(serde_json::to_string_pretty(value)? + "\n"))
}

/// Maps a command's result to the process exit code, printing the error chain.
pub fn exit_code(result: anyhow::Result<()>) -> i32 {
    match result {
        Ok(()) => 0,
        Err(e) => {
            if e.downcast_ref::<UsageError>().is_some() {
                eprintln!("error: {e}");
                return 2;
            }
            if e.downcast_ref::<RowsRefused>().is_some() || e.downcast_ref::<UnitsFailed>().is_some() {
                eprintln!("error: {e}");
                return 3;
            }
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            1
        }
    }
}

/// Bad usage found after parsing (contradicting options): exit code 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// `spincal fleet` finished and wrote every other unit's outputs, but some units failed: exit
/// code 3.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UnitsFailed(pub String);

/// The command finished and wrote every row, but refused some rows: exit code 3.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct RowsRefused(pub String);
