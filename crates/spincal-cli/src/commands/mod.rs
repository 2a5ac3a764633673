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
pub mod input;
pub mod inspect;
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

use std::path::Path;

use anyhow::Context;

/// Refuses outputs that are also inputs (followed through links) or that name the same file, before
/// any work starts: a usage error.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> anyhow::Result<()> {
    spincal::output::check_outputs(inputs, outputs).map_err(|e| crate::ui::UsageError(e.to_string()).into())
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
