//! `spincal correct`: a recording streamed through a saved corrector by the library's pipeline
//! ([`spincal::correctors::stream`], which documents the output's layout); this file parses the
//! flags, makes the one call and prints the summary. Exit code 3 when rows were refused (they are
//! written, marked, in place).

use std::io::BufWriter;
use std::path::PathBuf;

use clap::Args;
use spincal::correctors::model_file::CorrectorFile;
use spincal::correctors::stream::{self, CorrectError};

use super::input::ReadArgs;
use super::values::FormatArg;
use crate::ui::{RowsRefused, Ui, UsageError};

#[derive(Args)]
pub struct CorrectArgs {
    /// Corrector file (model.json): written by `spincal calibrate` (recordings or `--campaign`),
    /// `spincal fleet`, `spincal train` or `spincal static -o`; any kind (ann, linear, static,
    /// physical, physical_ann).
    #[arg(long, value_name = "MODEL.json")]
    pub model: PathBuf,
    /// Recording to correct (any format the other commands read; delimited text is streamed), or -
    /// for standard input (delimited text).
    #[arg(value_name = "IN.csv")]
    pub input: PathBuf,
    /// Output CSV (standard output when absent).
    #[arg(short, long, value_name = "OUT.csv")]
    pub output: Option<PathBuf>,
    /// The gyroscope from a second file (the input has no gyro columns; the model calibrates a
    /// gyro), read with the same flags: merged on time inside the stream when it has a time
    /// column (rows outside its span or in its gaps written with status `no-gyro`, valid 0;
    /// refused under half overlap), sample for sample when it has none.
    #[arg(long, value_name = "GYRO")]
    pub gyro_file: Option<PathBuf>,
    /// How to read the input (the same flags as every command).
    #[command(flatten)]
    pub read: ReadArgs,
}

pub fn run(args: CorrectArgs, _ui: Ui) -> anyhow::Result<()> {
    let outputs: Vec<&std::path::Path> = args.output.iter().map(PathBuf::as_path).collect();
    let inputs = [Some(&args.input), Some(&args.model), args.gyro_file.as_ref()];
    let inputs: Vec<&std::path::Path> = inputs.into_iter().flatten().map(PathBuf::as_path).collect();
    super::check_outputs(&inputs, &outputs)?;
    let model = CorrectorFile::read_path(&args.model)?;
    let mut options = args.read.options()?;
    if args.read.format == Some(FormatArg::Whitespace) && options.columns.table.delimiter.is_none() {
        options.columns.table.delimiter = Some(spincal::input::table::Delimiter::Whitespace);
    }
    let gyro = args.gyro_file.as_deref();
    let result = match &args.output {
        Some(path) if !spincal::output::is_stdio(path) => {
            stream::correct_to_path(&model, &args.input, &options, gyro, path)
        }
        _ => stream::correct_to_writer(
            &model,
            &args.input,
            &options,
            gyro,
            &mut BufWriter::new(std::io::stdout().lock()),
        ),
    };
    let summary = match result {
        Ok(summary) => summary,
        Err(e) if e.is_broken_pipe() => return Ok(()),
        Err(e) if e.is_usage() => return Err(UsageError(e.to_string()).into()),
        Err(CorrectError::Format(e)) => {
            return Err(anyhow::Error::from(*e).context(format!("reading {}", args.input.display())))
        }
        Err(e) => return Err(e.into()),
    };
    for note in &summary.notes {
        eprintln!("note: {}: {}", summary.file, crate::ui::in_flags(note));
    }
    for warning in summary.warnings() {
        eprintln!("warning: {warning}");
    }
    match summary.refusals() {
        Some(refusals) => Err(RowsRefused(refusals).into()),
        None => Ok(()),
    }
}
