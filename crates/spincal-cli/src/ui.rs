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

    /// One bar per label in `multi`, each prefixed with its label (padded to the longest):
    /// "waiting" until its unit starts.
    pub fn labelled_bars(&self, multi: &MultiProgress, labels: &[String]) -> Vec<ProgressBar> {
        let width = labels.iter().map(String::len).max().unwrap_or(4);
        let template =
            format!("{{prefix:<{width}}} {{msg:>20}} [{{bar:30}}] {{pos}}/{{len}} {{elapsed_precise}}");
        labels
            .iter()
            .map(|label| {
                let bar = multi.add(self.progress(1, "waiting"));
                if let Ok(style) = ProgressStyle::with_template(&template) {
                    bar.set_style(style.progress_chars("=> "));
                }
                bar.set_prefix(label.clone());
                bar
            })
            .collect()
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

/// A fit's progress as a spinner shows it: its stage, iteration and cost.
pub fn iteration_message(p: &Progress) -> String {
    format!(
        "{}: iteration {}, cost {:.6e}",
        p.stage,
        p.done,
        p.cost.unwrap_or(f64::NAN)
    )
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
/// The library names its parameters (`sample_rate_hz`); on the command line they are flags. Only
/// names whose flag is spelled otherwise, and that no library message uses in another sense.
const PARAMETER_FLAGS: [(&str, &str); 8] = [
    ("`accel_unit`", "`--accel-unit`"),
    ("`accel_scale`", "`--accel-scale`"),
    ("`accel_offset`", "`--accel-offset`"),
    ("`sample_rate_hz`", "`--sample-rate`"),
    ("`time_unit`", "`--time-unit`"),
    ("`topic`", "`--topic`"),
    ("`force`", "`--force`"),
    ("`axes`", "`--objective-axes`"),
];

/// A library message in the command line's words.
pub fn in_flags(message: &str) -> String {
    PARAMETER_FLAGS
        .iter()
        .fold(message.to_string(), |text, (parameter, flag)| {
            text.replace(parameter, flag)
        })
}

pub fn exit_code(result: anyhow::Result<()>) -> i32 {
    match result {
        Ok(()) => 0,
        Err(e) => {
            if e.downcast_ref::<UsageError>().is_some() {
                eprintln!("error: {}", in_flags(&e.to_string()));
                return 2;
            }
            if e.downcast_ref::<RowsRefused>().is_some() || e.downcast_ref::<UnitsFailed>().is_some() {
                eprintln!("error: {}", in_flags(&e.to_string()));
                return 3;
            }
            eprintln!("error: {}", in_flags(&e.to_string()));
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {}", in_flags(&cause.to_string()));
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

/// On every catchable signal that ends a process (SIGINT, SIGTERM, SIGHUP, SIGQUIT): removes the
/// temporary files being written (the library's own, see `spincal::output::remove_temporaries`)
/// and the output folders this run made that are still empty, then ends the process by the same
/// signal. The signal
/// handler only writes the signal's number to a pipe; a thread does the rest. A signal that was
/// ignored when spincal started stays ignored.
#[cfg(unix)]
pub fn remove_temporaries_on_signals() {
    use std::sync::atomic::{AtomicI32, Ordering};
    static PIPE_WRITE: AtomicI32 = AtomicI32::new(-1);
    extern "C" fn handler(signal: libc::c_int) {
        let byte = signal as u8;
        // SAFETY: write(2) is async-signal-safe; the descriptor stays open for the process's life.
        unsafe {
            libc::write(PIPE_WRITE.load(Ordering::Relaxed), (&byte as *const u8).cast(), 1);
        }
    }
    let mut fds = [0 as libc::c_int; 2];
    // SAFETY: pipe(2) fills the two descriptors it is given.
    if unsafe { libc::pipe(fds.as_mut_ptr()) } != 0 {
        return;
    }
    PIPE_WRITE.store(fds[1], Ordering::Relaxed);
    let read_end = fds[0];
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || loop {
            let mut byte = 0u8;
            // SAFETY: reads one byte into a live local.
            let n = unsafe { libc::read(read_end, (&mut byte as *mut u8).cast(), 1) };
            if n == 1 {
                spincal::output::remove_temporaries();
                spincal::output::remove_empty_created_folders();
                let signal = libc::c_int::from(byte);
                // SAFETY: restores the default action and raises the signal again, so the process
                // ends as the signal says (exit status included).
                unsafe {
                    libc::signal(signal, libc::SIG_DFL);
                    libc::raise(signal);
                }
                std::process::exit(128 + signal);
            }
            if n == 0 || std::io::Error::last_os_error().kind() != std::io::ErrorKind::Interrupted {
                return;
            }
        });
    if spawned.is_err() {
        return;
    }
    for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT] {
        // SAFETY: the handler only calls write(2).
        unsafe {
            let previous = libc::signal(signal, handler as *const () as libc::sighandler_t);
            if previous == libc::SIG_IGN {
                libc::signal(signal, libc::SIG_IGN);
            }
        }
    }
}

/// Elsewhere, signals end the process as they always did.
#[cfg(not(unix))]
pub fn remove_temporaries_on_signals() {}
