//! `spincal correct`: streams a recording through a saved corrector in constant memory.
//!
//! Every input data row comes out, in place, with its original columns, one corrected column per
//! corrected axis (in the input's acceleration unit), `valid` (0 for the first rows that lack a full
//! delay history, whose corrected values are the measured ones, and for refused rows) and `status`:
//! `ok`, `physics-only` (an input lies well outside the training range: a physical model corrects it,
//! a network on top of it is not applied), `outside-range` (the same for a network alone: the reading
//! goes through unchanged with `valid` 0), or `refused:` with
//! the line and the reason for a row that cannot be read or whose time goes backwards; its
//! corrected columns are empty. The summary on standard error names the first refused lines, and
//! the exit code is 3 when rows were refused. The output file is written through a temporary file
//! and renamed when complete; an output that is the input or the model is refused.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use spincal::corrector::Corrector;
use spincal::table::{display_name, Delimiter, Record, RowReader, Table};
use spincal::CorrectorFile;
use spincal::{ColumnMap, Recording};

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
            ("--retime", r.retime),
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
    /// Gyro x, y, z, when the file has them.
    gyro: Option<[usize; 3]>,
    /// Multiply file values by these to get s, m/s² and rad/s.
    time_to_s: f64,
    accel_to_mps2: f64,
    gyro_to_radps: f64,
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
    let gyro = if names.len() >= 7 {
        Some([index(&names[4])?, index(&names[5])?, index(&names[6])?])
    } else {
        None
    };
    Ok(Columns {
        time: index(&names[0])?,
        accel: [index(&names[1])?, index(&names[2])?, index(&names[3])?],
        gyro,
        time_to_s: recording.time_s[0],
        accel_to_mps2: recording.accel_mps2[0][0],
        gyro_to_radps: recording.gyro_radps.as_ref().map_or(1.0, |g| g[0][0]),
    })
}

pub fn run(args: CorrectArgs, _ui: Ui) -> anyhow::Result<()> {
    let map = args.column_map()?;
    let outputs: Vec<&std::path::Path> = args.output.iter().map(PathBuf::as_path).collect();
    super::check_outputs(&[&args.input, &args.model], &outputs)?;
    let model = CorrectorFile::read_path(&args.model)?;
    let (reader, name): (Box<dyn BufRead>, String) = if spincal::output::is_stdio(&args.input) {
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
        Some(path) if !spincal::output::is_stdio(path) => {
            // The stream's own error is kept apart so that it, not a generic write error, is shown.
            let mut failure = None;
            let mut summary = None;
            let written =
                spincal::output::write_file(path, |out| match stream(&model, reader, &name, &map, out) {
                    Ok(s) => {
                        summary = Some(s);
                        Ok(())
                    }
                    Err(e) => {
                        failure = Some(e);
                        Err(std::io::Error::other("the stream failed"))
                    }
                });
            match (failure, written, summary) {
                (Some(e), _, _) => Err(e),
                (None, Err(e), _) => Err(e.into()),
                (None, Ok(()), summary) => summary.context("the output was written without its rows"),
            }
        }
        _ => stream(
            &model,
            reader,
            &name,
            &map,
            &mut BufWriter::new(std::io::stdout().lock()),
        ),
    };
    match result {
        Ok(summary) => summary.finish(&name),
        Err(e) if is_broken_pipe(&e) => Ok(()),
        Err(e) => Err(e),
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

/// Refused rows listed by line in the summary.
const LISTED_REFUSALS: usize = 5;

/// What a finished stream saw, beyond the rows it wrote.
struct StreamSummary {
    rows: usize,
    /// Rows flagged as outside the training range, and the line of the first.
    outside_training_range: usize,
    first_outside_line: Option<usize>,
    refused: usize,
    /// The first refused rows: line and reason.
    first_refusals: Vec<String>,
    /// The model calibrates a gyroscope but the file has no gyro columns.
    gyro_uncorrected: bool,
}

impl StreamSummary {
    /// Warns about rows outside the training range; refused rows make the result an error (exit code 3).
    fn finish(&self, name: &str) -> anyhow::Result<()> {
        if self.gyro_uncorrected {
            eprintln!(
                "warning: {name}: the model calibrates the gyroscope, but no gyro columns were found (pass --columns t,ax,ay,az,gx,gy,gz); only the accelerometer was corrected"
            );
        }
        if let Some(line) = self.first_outside_line {
            eprintln!(
                "warning: {name}: {} of {} rows ({:.1} %) have an input more than {:.0} % of the training \
                 range outside it (first at line {line}): a network is not applied there (status \
                 `outside-range`, valid 0, the reading unchanged; `physics-only` where a physical \
                 model corrects it alone)",
                self.outside_training_range,
                self.rows,
                100.0 * self.outside_training_range as f64 / self.rows.max(1) as f64,
                100.0 * spincal::ann::EXTRAPOLATION_MARGIN,
            );
        }
        if self.refused > 0 {
            return Err(RowsRefused(format!(
                "{name}: {} of {} rows refused (written in place with status `refused` and empty corrected columns); the first: {}",
                self.refused,
                self.rows,
                self.first_refusals.join("; ")
            ))
            .into());
        }
        Ok(())
    }
}

/// A field for the output: quoted when it holds the separator or a quote.
fn field(text: &str, delimiter: char) -> String {
    if text.contains(delimiter) || text.contains('"') || (delimiter == ' ' && text.contains('\t')) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The original fields of a refused line, as many as the table is wide (missing ones empty, extra
/// ones kept together in the last).
fn refused_fields(text: &str, delimiter: Delimiter, width: usize) -> Vec<String> {
    let parts: Vec<&str> = match delimiter {
        Delimiter::Whitespace => text.split_whitespace().collect(),
        other => text.split(other.as_char()).collect(),
    };
    let mut fields: Vec<String> = parts
        .iter()
        .take(width.saturating_sub(1))
        .map(|s| s.to_string())
        .collect();
    if parts.len() >= width && width > 0 {
        fields.push(parts[width - 1..].join(&delimiter.as_char().to_string()));
    }
    fields.resize(width, String::new());
    fields
}

fn stream(
    model: &CorrectorFile,
    reader: Box<dyn BufRead>,
    name: &str,
    map: &ColumnMap,
    out: &mut dyn Write,
) -> anyhow::Result<StreamSummary> {
    let mut rows = RowReader::new(reader, name, &map.table)?;
    let width = rows.width();
    let header: Vec<String> = if rows.header.is_empty() {
        (1..=width).map(|c| format!("column{c}")).collect()
    } else {
        rows.header.clone()
    };
    // Networks and linear maps were trained in m/s²; a static calibration states its own unit.
    let unit_matters = !matches!(model.corrector, spincal::CorrectorModel::Static(_));
    if unit_matters && rows.header.is_empty() && map.accel_unit.is_none() {
        return Err(UsageError(format!(
            "{name}: no header line, so the acceleration unit cannot be known; pass --accel-unit g or --accel-unit mps2 (and --columns if the columns are not t,ax,ay,az)"
        ))
        .into());
    }
    let columns = resolve_columns(&rows.header, width, name, map)?;
    let corrector = &model.corrector;
    let axes = corrector.corrected_axes();
    let delimiter = rows.delimiter;
    let sep = delimiter.as_char();
    let mut line = header
        .iter()
        .map(|h| field(h, sep))
        .collect::<Vec<_>>()
        .join(&sep.to_string());
    for axis in &axes {
        line.push(sep);
        line.push_str(&field(
            &format!("{}_corrected", header[columns.accel[axis.index()]]),
            sep,
        ));
    }
    // The gyro calibration, when the model has one and the file has gyro columns.
    let gyro = match (&model.gyro, columns.gyro) {
        (Some(g), Some(c)) => Some((
            g.corrector()
                .context("the model's gyro sensitivity is singular")?,
            c,
        )),
        _ => None,
    };
    if let Some((_, c)) = &gyro {
        for &col in c {
            line.push(sep);
            line.push_str(&field(&format!("{}_corrected", header[col]), sep));
        }
    }
    let gyro_width = if gyro.is_some() { 3 } else { 0 };
    line.push(sep);
    line.push_str("valid");
    line.push(sep);
    line.push_str("status");
    writeln!(out, "{line}")?;

    let mut state = corrector.stream();
    let mut values = Vec::with_capacity(width);
    let mut previous_time: Option<f64> = None;
    let from_mps2 = 1.0 / columns.accel_to_mps2;
    let mut summary = StreamSummary {
        rows: 0,
        outside_training_range: 0,
        first_outside_line: None,
        refused: 0,
        first_refusals: Vec::new(),
        gyro_uncorrected: model.gyro.is_some() && columns.gyro.is_none(),
    };
    let refuse = |summary: &mut StreamSummary, out: &mut dyn Write, fields: Vec<String>, reason: String| {
        summary.refused += 1;
        if summary.first_refusals.len() < LISTED_REFUSALS {
            summary.first_refusals.push(reason.clone());
        }
        let mut row = fields
            .iter()
            .map(|f| field(f, sep))
            .collect::<Vec<_>>()
            .join(&sep.to_string());
        for _ in 0..axes.len() + gyro_width {
            row.push(sep);
        }
        writeln!(
            out,
            "{row}{sep}0{sep}{}",
            field(&format!("refused: {reason}"), sep)
        )
    };
    while let Some(record) = rows.next_record(&mut values)? {
        summary.rows += 1;
        let line_no = match record {
            Record::Parsed { line } => line,
            Record::Refused { line, text, error } => {
                refuse(
                    &mut summary,
                    out,
                    refused_fields(&text, delimiter, width),
                    format!("line {line}: {error}"),
                )?;
                continue;
            }
        };
        let t = values[columns.time] * columns.time_to_s;
        if let Some(p) = previous_time.filter(|&p| t < p) {
            let fields = values.iter().map(f64::to_string).collect();
            let reason = format!("line {line_no}: time {t} s goes backwards (previous row {p} s)");
            refuse(&mut summary, out, fields, reason)?;
            continue;
        }
        // Finite in the file is not enough: a unit's factor can carry a value past f64's range.
        let converted = std::iter::once((columns.time, columns.time_to_s))
            .chain(columns.accel.map(|c| (c, columns.accel_to_mps2)))
            .chain(
                gyro.iter()
                    .flat_map(|(_, c)| c.map(|col| (col, columns.gyro_to_radps))),
            );
        if let Some((c, factor)) = converted.into_iter().find(|&(c, k)| !(values[c] * k).is_finite()) {
            let fields = values.iter().map(f64::to_string).collect();
            let reason = format!(
                "line {line_no}, column {} ({}): {:e} is {} after conversion to SI units (× {factor}); spincal needs finite numbers",
                c + 1,
                header[c],
                values[c],
                values[c] * factor
            );
            refuse(&mut summary, out, fields, reason)?;
            continue;
        }
        previous_time = Some(t);
        let accel = columns.accel.map(|c| values[c] * columns.accel_to_mps2);
        let sample = state.correct_sample(accel);
        let gyro_rate = gyro
            .as_ref()
            .map(|(corrector, c)| corrector.correct(c.map(|col| values[col] * columns.gyro_to_radps)));
        let corrected_finite = axes
            .iter()
            .map(|axis| sample.accel_mps2[axis.index()] * from_mps2)
            .chain(gyro_rate.iter().flatten().map(|w| w / columns.gyro_to_radps))
            .all(f64::is_finite);
        if !corrected_finite {
            let fields = values.iter().map(f64::to_string).collect();
            let reason = format!(
                "line {line_no}: the corrected value is not finite (the input is far outside anything the model was made for)"
            );
            refuse(&mut summary, out, fields, reason)?;
            continue;
        }
        if sample.outside_training_range {
            summary.outside_training_range += 1;
            summary.first_outside_line.get_or_insert(line_no);
        }
        for (c, v) in values.iter().enumerate() {
            if c > 0 {
                write!(out, "{sep}")?;
            }
            write!(out, "{v}")?;
        }
        for axis in &axes {
            write!(out, "{sep}{}", sample.accel_mps2[axis.index()] * from_mps2)?;
        }
        if let Some(rate) = gyro_rate {
            for w in rate {
                write!(out, "{sep}{}", w / columns.gyro_to_radps)?;
            }
        }
        let status = match (sample.valid, sample.outside_training_range) {
            (_, false) => "ok",
            (true, true) => "physics-only",
            (false, true) => "outside-range",
        };
        writeln!(out, "{sep}{}{sep}{status}", u8::from(sample.valid))?;
    }
    out.flush()?;
    Ok(summary)
}
