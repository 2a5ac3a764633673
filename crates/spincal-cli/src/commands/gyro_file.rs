//! `--gyro-file`: the gyroscope recorded in a second file, attached by the library's one rule
//! ([`spincal::input::gyro_file::attach_gyro_file`]: merged on time when the file has its own
//! times, sample for sample when not), with what the merge did said on standard error.

use std::path::{Path, PathBuf};

use spincal::input::formats::{Loaded, ReadOptions};
use spincal::input::recording::Recording;

use crate::ui::UsageError;

/// Attaches the gyro of the file `gyro` to `loaded` by the library's one rule (merged on time, or
/// sample for sample when it has no time column) and says on standard error what the merge did.
pub fn attach_gyro(loaded: &mut Loaded, gyro: &Path, options: &ReadOptions) -> anyhow::Result<()> {
    let note = spincal::input::gyro_file::attach_gyro_file(loaded, gyro, options)?;
    print_gyro_note(note);
    Ok(())
}

/// Prints the note of a gyro file merged on time (samples dropped, the rates).
pub fn print_gyro_note(note: Option<String>) {
    if let Some(note) = note {
        eprintln!("note: {}", crate::ui::in_flags(&note));
    }
}

/// [`attach_gyro`] for a command that needs rad/s: raw gyro counts are refused.
pub fn attach_in_si(loaded: &mut Loaded, gyro: &Path, options: &ReadOptions) -> anyhow::Result<()> {
    attach_gyro(loaded, gyro, options)?;
    if loaded.gyro_counts {
        return Err(UsageError(format!(
            "{}: the gyro values look like raw counts (an axis's mean beyond any rate); give --gyro-range-dps or --gyro-scale",
            gyro.display()
        ))
        .into());
    }
    Ok(())
}

impl super::fit::TurntableArgs {
    /// Reads the recordings, each with its `--gyro-file` when given (one per recording, in order).
    pub fn read_recordings(&self) -> anyhow::Result<Vec<Recording>> {
        if !self.gyro_file.is_empty() && self.gyro_file.len() != self.recordings.len() {
            return Err(UsageError(format!(
                "--gyro-file names {} file(s) for {} recording(s): give one per recording, in order",
                self.gyro_file.len(),
                self.recordings.len()
            ))
            .into());
        }
        (self.recordings.iter().enumerate())
            .map(|(k, path)| {
                self.read
                    .read_with(path, |loaded, options| match self.gyro_file.get(k) {
                        Some(gyro) => attach_in_si(loaded, gyro, options),
                        None => Ok(()),
                    })
            })
            .collect()
    }

    /// The files read: the recordings and their gyro files.
    pub fn inputs(&self) -> Vec<PathBuf> {
        self.recordings.iter().chain(&self.gyro_file).cloned().collect()
    }
}
