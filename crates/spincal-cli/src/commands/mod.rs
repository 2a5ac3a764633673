//! One file per subcommand: its clap arguments and a `run` function.

pub mod allan;
pub mod calibrate;
pub mod campaign;
pub mod compare;
pub mod correct;
pub mod demo;
pub mod export;
pub mod fit;
pub mod fleet;
pub mod gyro_file;
pub mod init;
pub mod input;
pub mod inspect;
pub mod phone;
pub mod sensitivity;
pub mod simulate;
pub mod static_cal;
pub mod strobe;
pub mod sweep;
pub mod sysid;
pub mod tables;
pub mod train;
pub mod values;

pub use input::{format_line, InputArgs};

use std::path::{Path, PathBuf};

use anyhow::Context;

/// Refuses outputs that are also inputs (followed through links) or that name the same file, and
/// existing outputs that spincal did not write (see [`claim_outputs`]), before any work starts: a
/// usage error.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> anyhow::Result<()> {
    spincal::output::check_outputs(inputs, outputs)
        .map_err(|e| anyhow::Error::from(crate::ui::UsageError(e.to_string())))?;
    claim_outputs(outputs)
}

/// Recordings are required by every command but `calibrate --campaign`, which checks itself.
pub fn require_recordings(recordings: &[PathBuf]) -> Result<(), crate::ui::UsageError> {
    if recordings.is_empty() {
        return Err(crate::ui::UsageError(
            "no recordings given: name at least one recording file".into(),
        ));
    }
    Ok(())
}

/// A probability strictly between 0 and 1 (`fleet --false-alarm`).
pub fn probability(text: &str) -> Result<f64, String> {
    let v: f64 = text.parse().map_err(|_| format!("{text}: not a number"))?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("{text}: must lie strictly between 0 and 1"))
    }
}

/// [`check_outputs`] for paths held as `PathBuf`s.
pub fn check_paths<'a>(
    inputs: impl IntoIterator<Item = &'a PathBuf>,
    outputs: impl IntoIterator<Item = &'a PathBuf>,
) -> anyhow::Result<()> {
    let inputs: Vec<&Path> = inputs.into_iter().map(PathBuf::as_path).collect();
    let outputs: Vec<&Path> = outputs.into_iter().map(PathBuf::as_path).collect();
    check_outputs(&inputs, &outputs)
}

/// Whether `--force` was given: existing outputs that spincal did not write may be replaced.
static FORCE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Records the global `--force` flag.
pub fn set_force(force: bool) {
    FORCE.store(force, std::sync::atomic::Ordering::Relaxed);
}

/// Whether `--force` was given.
pub fn force() -> bool {
    FORCE.load(std::sync::atomic::Ordering::Relaxed)
}

/// Refuses, before any work, to replace an existing output that spincal did not write (a usage
/// error naming it), unless `--force` was given; then says on standard error what is replaced.
/// spincal's own earlier outputs are replaced without a word, so a run repeated into its own
/// folder or file just works.
pub fn claim_outputs(outputs: &[&Path]) -> anyhow::Result<()> {
    let force = FORCE.load(std::sync::atomic::Ordering::Relaxed);
    let replaced = spincal::output::claim_outputs(outputs, force)
        .map_err(|e| anyhow::Error::from(crate::ui::UsageError(e.to_string())))?;
    for r in replaced {
        eprintln!(
            "spincal: --force: replacing {}, which spincal did not write",
            r.path.display()
        );
    }
    Ok(())
}

/// Makes the output folder named by `flag` (e.g. `--out`); a file there is refused by name.
pub fn create_folder(flag: &str, path: &Path) -> anyhow::Result<()> {
    spincal::output::create_folder(path).map_err(|e| crate::ui::UsageError(format!("{flag} {e}")).into())
}

/// Moves aside the outputs of an earlier run that this run does not write (a model.json beside
/// results that saved nothing), and says so on standard error.
pub fn set_aside_stale(folder: &Path, names: &[&str], written: &[&str]) -> anyhow::Result<()> {
    let moved = spincal::output::set_aside_stale(folder, names, written)
        .with_context(|| format!("moving earlier outputs aside in {}", folder.display()))?;
    for (from, to) in moved {
        eprintln!(
            "spincal: {} is from an earlier run and this run saved none: moved it to {}",
            from.display(),
            to.display()
        );
    }
    Ok(())
}

/// Writes text to a file through a temporary file renamed on success (see `spincal::output`).
pub fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    Ok(spincal::output::write_bytes(path, text.as_bytes())?)
}
