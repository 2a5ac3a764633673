//! `correct`'s pipeline: a recording streamed through a saved corrector into a table, in the
//! input's row order, every input row out (the CLI and Python both run it).
//!
//! The pipeline is a reader, the [`RowCorrector`](crate::correctors::rows::RowCorrector) and a
//! [`RowSink`]:
//! - delimited text (and standard input) is read row by row in constant memory; every
//!   data row comes out as its original text, then one corrected column per corrected axis (in
//!   the input's unit, named by [`corrected_column_names`]: `ax_corrected_mps2`,
//!   `ax_corrected_g`, `gx_corrected_dps`), `valid` and `status`;
//! - every other format, and the reading options that need the whole file (a scale for raw counts,
//!   a sample rate, retiming, 3DM-GX1 gains), is read whole by [`read_path`]; every
//!   sample comes out with its source line, time in s and its values under unit-named columns
//!   (`ax_mps2`, `gx_radps`; `counts` for raw counts), then the same corrected columns.
//!
//! Before any row is written, the first rows' median |a| is held against the gravity the model
//! expects: a file about 9.81 times too weak or too strong is in another unit than it is read in,
//! and stops the correction naming the unit ([`CorrectError::AccelUnit`]).
//!
//! A gyro file (`gyro_file`: the recording has no gyro columns, the model calibrates a gyro) is
//! merged on time inside the pipeline in constant memory (`gyro.rs`): each row gets the gyro
//! interpolated at its time and three corrected gyro columns; a row outside the gyro's span or
//! in its gaps is written with its accelerometer corrected, empty gyro columns, `valid` 0 and
//! status `no-gyro: line N, <why>`; under half the rows covered stops the correction naming
//! both spans (a file output is then not written).
//!
//! A row that cannot be corrected is written in place with status `refused: line N, <reason>` and
//! empty corrected columns; a row missing a value used is `skipped: …`. [`StreamSummary`] counts
//! what the stream saw and words what a user should be told; the library never prints.

mod gyro;
mod sink;
mod summary;
mod text;
mod unit_check;
mod whole;

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

pub use sink::{DelimitedSink, RowSink};
pub use summary::StreamSummary;
pub use text::corrected_column_names;

use crate::correctors::model_file::CorrectorFile;
use crate::correctors::rows::SingularGyro;
use crate::input::formats::{delimited_text_format, read_path, Format, FormatError, ReadOptions};
use crate::input::recording::RecordingError;
use crate::input::table::{display_name, TableError};
use crate::output::OutputError;

/// What can stop a correction before or while its rows are written (refused rows do not: they
/// are written and counted in the [`StreamSummary`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CorrectError {
    /// The acceleration unit matters to the model and nothing says it.
    #[error("{file}: no header line, so the acceleration unit cannot be known; give `accel_unit` (g or mps2), and `columns` if the columns are not t,ax,ay,az")]
    UnitUnknown { file: String },
    /// The file's values are raw counts and the model takes SI values, or the other way round.
    #[error("{file}: the {format} file holds {holds}, but the model takes {takes}; {advice}")]
    CountsMismatch {
        file: String,
        format: Format,
        holds: &'static str,
        takes: &'static str,
        advice: &'static str,
    },
    /// The first rows' median |a| is about g/9.81 or g·9.81 of the gravity the model expects: the
    /// values are in another unit than the one they are read in.
    #[error("{file}: the first {rows} rows read {median_mps2:.3} m/s² (median |a|) where the model expects about {expected_mps2:.3} m/s² at rest: the values look like {looks_like}, read as {read_as}; {fix}")]
    AccelUnit {
        file: String,
        rows: usize,
        median_mps2: f64,
        expected_mps2: f64,
        looks_like: &'static str,
        read_as: &'static str,
        fix: &'static str,
    },
    #[error("{file}: cannot open: {source}")]
    Open {
        file: String,
        #[source]
        source: std::io::Error,
    },
    // Boxed: the readers' errors are large, and every row's result carries this type.
    #[error(transparent)]
    Format(Box<FormatError>),
    #[error(transparent)]
    Table(Box<TableError>),
    #[error(transparent)]
    Columns(Box<RecordingError>),
    #[error(transparent)]
    Model(#[from] SingularGyro),
    /// The gyro file cannot be merged (no overlap, its length, the model takes no gyro, …).
    #[error(transparent)]
    Gyro(Box<crate::input::gyro_file::GyroFileError>),
    /// The temperature column is in another unit than its name says (the model needs it).
    #[error(transparent)]
    Temperature(#[from] crate::thermal::checks::TemperatureError),
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Writing the rows failed (a closed pipe included: its kind is `BrokenPipe`).
    #[error("writing the corrected rows: {0}")]
    Write(#[from] std::io::Error),
}

impl From<FormatError> for CorrectError {
    fn from(e: FormatError) -> Self {
        CorrectError::Format(Box::new(e))
    }
}

impl From<TableError> for CorrectError {
    fn from(e: TableError) -> Self {
        CorrectError::Table(Box::new(e))
    }
}

impl From<RecordingError> for CorrectError {
    fn from(e: RecordingError) -> Self {
        CorrectError::Columns(Box::new(e))
    }
}

impl CorrectError {
    /// Whether the error is the caller's choice of inputs or options rather than a failure.
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            CorrectError::UnitUnknown { .. }
                | CorrectError::CountsMismatch { .. }
                | CorrectError::AccelUnit { .. }
                | CorrectError::Output(_)
        )
    }

    /// Whether writing stopped because the reader of the output went away.
    pub fn is_broken_pipe(&self) -> bool {
        match self {
            CorrectError::Write(e) => e.kind() == std::io::ErrorKind::BrokenPipe,
            CorrectError::Output(OutputError::Io { source, .. }) => {
                source.kind() == std::io::ErrorKind::BrokenPipe
            }
            _ => false,
        }
    }
}

/// Whether `input` is read whole rather than streamed: a format other than delimited text, or
/// an option that needs every sample at once. Standard input (`-`), pipes and missing files
/// stream (a missing file is then refused by name).
pub fn reads_whole_file(input: &Path, options: &ReadOptions) -> Result<bool, CorrectError> {
    if crate::output::is_stdio(input) || !(input.is_file() || input.is_dir()) {
        return Ok(false);
    }
    let whole_file_options = options.accel_scale.is_some()
        || options.accel_offset.is_some()
        || options.sample_rate_hz.is_some()
        || options.retime
        || options.gx1.accel_gain_scale.is_some()
        || options.gx1.gyro_gain_scale.is_some();
    let delimited = delimited_text_format(input, options.format).map_err(|source| {
        CorrectError::from(FormatError::Io {
            file: input.display().to_string(),
            source,
        })
    })?;
    Ok(whole_file_options || delimited.is_none())
}

/// Corrects `input` (a path, or `-` for standard input) with `model`, with the gyro of
/// `gyro_file` when given (read with `options` as [`gyro_read_options`] says), and writes the
/// table to `out`, flushed. See the [module](self) for the layout.
///
/// [`gyro_read_options`]: crate::input::gyro_file::gyro_read_options
pub fn correct_to_writer(
    model: &CorrectorFile,
    input: &Path,
    options: &ReadOptions,
    gyro_file: Option<&Path>,
    out: &mut dyn Write,
) -> Result<StreamSummary, CorrectError> {
    let gyro = match gyro_file {
        Some(path) if model.gyro.is_none() => {
            return Err(CorrectError::Gyro(Box::new(
                crate::input::gyro_file::GyroFileError::NotUsed {
                    file: display_name(path),
                },
            )))
        }
        Some(path) => Some(gyro::GyroMerge::open(path, options)?),
        None => None,
    };
    // A gyro without time pairs with the input's samples one for one: the input is read whole.
    if gyro.as_ref().is_some_and(|g| !g.timed) || reads_whole_file(input, options)? {
        let loaded = read_path(input, options)?;
        let mut sink = DelimitedSink::new(out, ',');
        return whole::correct_loaded(model, &loaded, &display_name(input), gyro, &mut sink);
    }
    let (reader, name): (Box<dyn BufRead>, String) = if crate::output::is_stdio(input) {
        (
            Box::new(BufReader::new(std::io::stdin().lock())),
            "<stdin>".to_string(),
        )
    } else {
        let opened = crate::input::limits::check_streamable(input).and_then(|()| File::open(input));
        let file = opened.map_err(|source| CorrectError::Open {
            file: input.display().to_string(),
            source,
        })?;
        (Box::new(BufReader::new(file)), display_name(input))
    };
    text::correct_text(model, reader, &name, &options.columns, gyro, out)
}

/// [`correct_to_writer`] into the file `output`, written through a temporary file renamed into
/// place when every row is written ([`crate::output::write_file`]): a failed correction leaves
/// what was there before. The caller has checked that `output` may be written (it is not an
/// input, and spincal wrote any file there: [`crate::output::check_outputs`],
/// [`crate::output::claim_outputs`]).
pub fn correct_to_path(
    model: &CorrectorFile,
    input: &Path,
    options: &ReadOptions,
    gyro_file: Option<&Path>,
    output: &Path,
) -> Result<StreamSummary, CorrectError> {
    // The stream's own error is kept apart so that it, not a generic write error, is returned.
    let mut outcome = None;
    let written = crate::output::write_file(output, |out| {
        let result = correct_to_writer(model, input, options, gyro_file, out);
        let failed = result.is_err();
        outcome = Some(result);
        if failed {
            Err(std::io::Error::other("the correction failed"))
        } else {
            Ok(())
        }
    });
    match (outcome, written) {
        (Some(Err(e)), _) => Err(e),
        (_, Err(e)) => Err(e.into()),
        (Some(Ok(summary)), Ok(())) => Ok(summary),
        (None, Ok(())) => Err(CorrectError::Write(std::io::Error::other(
            "the output was written without its rows",
        ))),
    }
}

#[cfg(test)]
mod tests;
