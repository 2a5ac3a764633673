//! `spincal correct`: streams a recording through a saved corrector in constant memory.
//!
//! Every input data row comes out, with its original columns, one corrected column per corrected
//! axis (in the input's acceleration unit) and `valid` (0 for the first rows that lack a full
//! delay history: their corrected values are the measured ones). A row that cannot be read, or
//! whose time does not increase, stops the command with its line number and the reason; a partial
//! output file is then removed, so an output file is always complete. Rows whose input lies well
//! outside a network's training range are corrected as well, and counted in a warning on standard
//! error (the network extrapolates there).

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Args, ValueEnum};
use spincal::corrector::Corrector;
use spincal::table::{display_name, RowReader, Table};
use spincal::CorrectorFile;
use spincal::{ColumnMap, Recording};

use super::input::ReadArgs;
use super::values::FormatArg;
use crate::ui::{Ui, UsageError};

#[derive(Args)]
pub struct CorrectArgs {
    /// Corrector file written by `spincal train`.
    #[arg(long, value_name = "MODEL.json")]
    pub model: PathBuf,
    /// Recording to correct (CSV), or - for standard input.
    #[arg(value_name = "IN.csv")]
    pub input: PathBuf,
    /// Output CSV (standard output when absent).
    #[arg(short, long, value_name = "OUT.csv")]
    pub output: Option<PathBuf>,
    /// How to read the input (the same flags as every command; delimited text only, since rows
    /// are streamed).
    #[command(flatten)]
    pub read: ReadArgs,
}

impl CorrectArgs {
    /// The column map for the streamed rows; flags that only whole-file readers use are refused.
    fn column_map(&self) -> anyhow::Result<ColumnMap> {
        let r = &self.read;
        if let Some(format) = r
            .format
            .filter(|f| !matches!(f, FormatArg::Csv | FormatArg::Whitespace))
        {
            return Err(UsageError(format!(
                "--format {}: correct streams delimited text (csv or whitespace); this format is read whole by the other commands",
                format.to_possible_value().map(|v| v.get_name().to_string()).unwrap_or_default()
            ))
            .into());
        }
        let whole_file_only = [
            ("--accel-scale", r.accel_scale.is_some()),
            ("--accel-offset", r.accel_offset.is_some()),
            ("--sample-rate", r.sample_rate.is_some()),
            ("--gx1-accel-gain", r.gx1_accel_gain.is_some()),
            ("--gx1-gyro-gain", r.gx1_gyro_gain.is_some()),
        ];
        if let Some((flag, _)) = whole_file_only.iter().find(|(_, given)| *given) {
            return Err(UsageError(format!(
                "{flag} is not supported by correct: it streams rows of time and acceleration in g or m/s²"
            ))
            .into());
        }
        let mut map = r.column_map()?;
        if r.format == Some(FormatArg::Whitespace) && map.table.delimiter.is_none() {
            map.table.delimiter = Some(spincal::table::Delimiter::Whitespace);
        }
        Ok(map)
    }
}

/// Where the time and acceleration columns are, and their units, from a header.
struct Columns {
    time: usize,
    accel: [usize; 3],
    /// Multiply file values by these to get s and m/s².
    time_to_s: f64,
    accel_to_mps2: f64,
}

/// Resolves columns with the same rules as whole-file reading, by reading a one-row table of
/// ones: the recording's column names give the indices, its values the unit factors.
fn resolve_columns(header: &[String], width: usize, file: &str, map: &ColumnMap) -> anyhow::Result<Columns> {
    let probe = Table {
        file: file.to_string(),
        delimiter: spincal::table::Delimiter::Comma,
        header: header.to_vec(),
        metadata: Vec::new(),
        columns: vec![vec![1.0]; width],
        lines: vec![1],
    };
    let recording = Recording::from_table(&probe, map)?;
    let index = |name: &str| -> anyhow::Result<usize> {
        header
            .iter()
            .position(|h| h == name)
            .or_else(|| {
                name.strip_prefix("column ")
                    .and_then(|n| n.parse::<usize>().ok())
                    .map(|n| n - 1)
            })
            .with_context(|| format!("{file}: cannot locate column {name}"))
    };
    let names = &recording.source.columns;
    Ok(Columns {
        time: index(&names[0])?,
        accel: [index(&names[1])?, index(&names[2])?, index(&names[3])?],
        time_to_s: recording.time_s[0],
        accel_to_mps2: recording.accel_mps2[0][0],
    })
}

pub fn run(args: CorrectArgs, _ui: Ui) -> anyhow::Result<()> {
    let map = args.column_map()?;
    let model = CorrectorFile::read_path(&args.model)?;
    let (reader, name): (Box<dyn BufRead>, String) = if args.input.as_os_str() == "-" {
        (
            Box::new(BufReader::new(std::io::stdin().lock())),
            "<stdin>".to_string(),
        )
    } else {
        let file =
            File::open(&args.input).with_context(|| format!("{}: cannot open", args.input.display()))?;
        (Box::new(BufReader::new(file)), display_name(&args.input))
    };
    let result = match &args.output {
        Some(path) => {
            let file = File::create(path).with_context(|| format!("{}: cannot create", path.display()))?;
            let result = stream(&model, reader, &name, &map, BufWriter::new(file));
            if result.is_err() {
                remove_partial(path);
            }
            result
        }
        None => stream(
            &model,
            reader,
            &name,
            &map,
            BufWriter::new(std::io::stdout().lock()),
        ),
    }
    .map(|summary| summary.warn(&name));
    match result {
        Err(e) if is_broken_pipe(&e) => Ok(()),
        other => other,
    }
}

fn remove_partial(path: &Path) {
    // Best effort: the error being reported matters more than a failed cleanup.
    let _ = std::fs::remove_file(path);
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

/// What a finished stream saw, beyond the rows it wrote.
struct StreamSummary {
    rows: usize,
    /// Rows flagged as outside the training range, and the line of the first.
    outside_training_range: usize,
    first_outside_line: Option<usize>,
}

impl StreamSummary {
    fn warn(&self, name: &str) {
        if let Some(line) = self.first_outside_line {
            eprintln!(
                "warning: {name}: {} of {} rows ({:.1} %) have an input more than {:.0} % of the training \
                 range outside it (first at line {line}); the network extrapolates there",
                self.outside_training_range,
                self.rows,
                100.0 * self.outside_training_range as f64 / self.rows.max(1) as f64,
                100.0 * spincal::ann::EXTRAPOLATION_MARGIN,
            );
        }
    }
}

fn stream(
    model: &CorrectorFile,
    reader: Box<dyn BufRead>,
    name: &str,
    map: &ColumnMap,
    mut out: impl Write,
) -> anyhow::Result<StreamSummary> {
    let mut rows = RowReader::new(reader, name, &map.table)?;
    let width = rows.width();
    let header: Vec<String> = if rows.header.is_empty() {
        (1..=width).map(|c| format!("column{c}")).collect()
    } else {
        rows.header.clone()
    };
    let columns = resolve_columns(&rows.header, width, name, map)?;
    let corrector = &model.corrector;
    let axes = corrector.corrected_axes();
    let delimiter = rows.delimiter.as_char();
    let mut line = header.join(&delimiter.to_string());
    for axis in &axes {
        line.push(delimiter);
        line.push_str(&format!("{}_corrected", header[columns.accel[axis.index()]]));
    }
    line.push(delimiter);
    line.push_str("valid");
    writeln!(out, "{line}")?;

    let mut state = corrector.stream();
    let mut values = Vec::with_capacity(width);
    let mut previous_time: Option<f64> = None;
    let from_mps2 = 1.0 / columns.accel_to_mps2;
    let mut summary = StreamSummary {
        rows: 0,
        outside_training_range: 0,
        first_outside_line: None,
    };
    while let Some(line_no) = rows.next_row(&mut values)? {
        let t = values[columns.time] * columns.time_to_s;
        if let Some(p) = previous_time {
            if t <= p {
                anyhow::bail!(
                    "{name}:{line_no}: time {t} s does not increase (previous row {p} s); row refused"
                );
            }
        }
        previous_time = Some(t);
        let accel = columns.accel.map(|c| values[c] * columns.accel_to_mps2);
        let sample = state.correct_sample(accel);
        summary.rows += 1;
        if sample.outside_training_range {
            summary.outside_training_range += 1;
            summary.first_outside_line.get_or_insert(line_no);
        }
        for (c, v) in values.iter().enumerate() {
            if c > 0 {
                write!(out, "{delimiter}")?;
            }
            write!(out, "{v}")?;
        }
        for axis in &axes {
            write!(out, "{delimiter}{}", sample.accel_mps2[axis.index()] * from_mps2)?;
        }
        writeln!(out, "{delimiter}{}", u8::from(sample.valid))?;
    }
    out.flush()?;
    Ok(summary)
}
