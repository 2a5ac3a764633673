//! `spincal correct`: streams a recording through a saved corrector in constant memory.
//!
//! Delimited text (and standard input) is streamed. Every input data row comes out, in place, as
//! its original text, then one corrected column per
//! corrected axis (in the input's acceleration unit), `valid` (0 for the first rows that lack a full
//! delay history, whose corrected values are the measured ones, and for refused rows) and `status`:
//! `ok`, `physics-only` (an input lies well outside the training range: a physical model corrects it,
//! a network on top of it is not applied), `outside-range` (the same for a network alone: the reading
//! goes through unchanged with `valid` 0), or `refused:` with
//! the line and the reason for a row that cannot be read or whose time goes backwards; its
//! corrected columns are empty. A row with an empty cell in a column used (a logger's packet of
//! another kind) comes out as `skipped:` with the column, and is counted. The summary on standard
//! error names the first refused lines, and the exit code is 3 when rows were refused.
//!
//! Other formats (imucal's and the MPU-6050 logger's files, MAT-files, bags, binary streams) and
//! the flags that need the whole file (`--sample-rate`, `--accel-scale`, `--retime`) are read by
//! the reader every other command uses; every sample it gives comes out with its source line (for
//! text), time in s, the values in SI units or counts (the column names say which), the label of
//! a labelled file, the corrected columns, `valid` and `status`.
//!
//! The output file is written through a temporary file and renamed when complete; an output that
//! is the input or the model is refused.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use spincal::correctors::model_file::CorrectorFile;
use spincal::correctors::rows::{RowCorrector, RowOutcome, RowStatus, RowValue, UnitFactors};
use spincal::input::formats::Loaded;
use spincal::input::recording::{ColumnMap, ColumnPlan};
use spincal::input::table::{display_name, Delimiter, Record, RowReader};

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
    /// How to read the input (the same flags as every command).
    #[command(flatten)]
    pub read: ReadArgs,
}

impl CorrectArgs {
    /// Whether the input is read whole by the common reader rather than streamed: a format other
    /// than delimited text, or a flag that needs the whole file.
    fn reads_whole_file(&self) -> anyhow::Result<bool> {
        let r = &self.read;
        // Standard input and pipes stream (their first bytes are read once); so does a missing
        // file, which the stream refuses by name.
        if spincal::output::is_stdio(&self.input) || !(self.input.is_file() || self.input.is_dir()) {
            return Ok(false);
        }
        let whole_file_flags = r.accel_scale.is_some()
            || r.accel_offset.is_some()
            || r.sample_rate.is_some()
            || r.retime
            || r.gx1_accel_gain.is_some()
            || r.gx1_gyro_gain.is_some();
        let delimited = spincal::input::formats::delimited_text_format(&self.input, r.format.map(Into::into))
            .with_context(|| format!("{}: cannot read", self.input.display()))?
            .is_some();
        Ok(whole_file_flags || !delimited)
    }

    /// The column map for the streamed rows.
    fn column_map(&self) -> anyhow::Result<ColumnMap> {
        let mut map = self.read.column_map()?;
        if self.read.format == Some(FormatArg::Whitespace) && map.table.delimiter.is_none() {
            map.table.delimiter = Some(spincal::input::table::Delimiter::Whitespace);
        }
        Ok(map)
    }
}

pub fn run(args: CorrectArgs, ui: Ui) -> anyhow::Result<()> {
    let outputs: Vec<&std::path::Path> = args.output.iter().map(PathBuf::as_path).collect();
    super::check_outputs(&[&args.input, &args.model], &outputs)?;
    let model = CorrectorFile::read_path(&args.model)?;
    let whole_file = args.reads_whole_file()?;
    let (source, name): (Option<Box<dyn BufRead>>, String) = if whole_file {
        (None, display_name(&args.input))
    } else if spincal::output::is_stdio(&args.input) {
        (
            Some(Box::new(BufReader::new(std::io::stdin().lock()))),
            "<stdin>".to_string(),
        )
    } else {
        let file =
            File::open(&args.input).with_context(|| format!("{}: cannot open", args.input.display()))?;
        (Some(Box::new(BufReader::new(file))), display_name(&args.input))
    };
    let loaded = if whole_file {
        Some(args.read.load(&args.input, &ui)?)
    } else {
        None
    };
    let map = args.column_map()?;
    let write = |out: &mut dyn Write, source: Option<Box<dyn BufRead>>| match (source, &loaded) {
        (Some(reader), _) => stream(&model, reader, &name, &map, out),
        (None, Some(loaded)) => correct_loaded(&model, loaded, &name, out),
        (None, None) => unreachable!("a source is either streamed or loaded"),
    };
    let result = match &args.output {
        Some(path) if !spincal::output::is_stdio(path) => {
            // The stream's own error is kept apart so that it, not a generic write error, is shown.
            let mut failure = None;
            let mut summary = None;
            let written = spincal::output::write_file(path, |out| match write(out, source) {
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
        _ => write(&mut BufWriter::new(std::io::stdout().lock()), source),
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
#[derive(Default)]
struct StreamSummary {
    rows: usize,
    /// Rows flagged as outside the training range, and the line of the first.
    outside_training_range: usize,
    first_outside_line: Option<usize>,
    refused: usize,
    /// The first refused rows: line and reason.
    first_refusals: Vec<String>,
    /// Rows without a value in a column used (written with status `skipped`), and the first.
    skipped: usize,
    first_skipped: Option<String>,
    /// The model calibrates a gyroscope but the file has no gyro columns.
    gyro_uncorrected: bool,
    /// Rows corrected as at the reference temperature (none given, or outside the thermal model's
    /// range), and the line of the first.
    thermal_fallback: usize,
    first_thermal_fallback: Option<(usize, RowStatus)>,
}

impl StreamSummary {
    /// Counts a corrected row.
    fn corrected(&mut self, line: usize, status: RowStatus) {
        match status {
            RowStatus::Ok => {}
            RowStatus::NoTemperature | RowStatus::OutsideTemperatureRange => {
                self.thermal_fallback += 1;
                self.first_thermal_fallback.get_or_insert((line, status));
            }
            RowStatus::PhysicsOnly | RowStatus::OutsideRange => {
                self.outside_training_range += 1;
                self.first_outside_line.get_or_insert(line);
            }
        }
    }

    /// Counts a refused row and keeps its reason when it is among the first.
    fn refused(&mut self, reason: &str) {
        self.refused += 1;
        if self.first_refusals.len() < LISTED_REFUSALS {
            self.first_refusals.push(reason.to_string());
        }
    }

    /// Warns about rows outside the training range and rows skipped; refused rows make the result
    /// an error (exit code 3).
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
                100.0 * spincal::correctors::ann::EXTRAPOLATION_MARGIN,
            );
        }
        if let Some((line, status)) = self.first_thermal_fallback {
            eprintln!(
                "warning: {name}: {} of {} rows were corrected as at the thermal model's reference temperature, valid 0: \
                 status `no-temperature` (the row has no temperature: name the column `temp_c`, or list it last in --columns) \
                 or `outside-temperature-range` (the die temperature lies outside the range the model was fitted on); the first, \
                 line {line}, is `{}`",
                self.thermal_fallback,
                self.rows,
                status.as_str()
            );
        }
        if let Some(first) = &self.first_skipped {
            eprintln!(
                "warning: {name}: {} of {} rows have no value in a column used (packets of another kind?) and were written with status `skipped` and empty corrected columns; the first: {first}",
                self.skipped, self.rows
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

/// Writes one output row: the input's fields, then the corrected values (empty when there are
/// none), `valid` and `status`.
fn write_row(
    out: &mut dyn Write,
    input: &str,
    sep: char,
    corrected: &[Option<f64>],
    valid: bool,
    status: &str,
) -> std::io::Result<()> {
    write!(out, "{input}")?;
    for v in corrected {
        match v {
            Some(v) => write!(out, "{sep}{v}")?,
            None => write!(out, "{sep}")?,
        }
    }
    writeln!(out, "{sep}{}{sep}{}", u8::from(valid), field(status, sep))
}

/// The corrected values written for a row, in the file's units: the corrected accelerometer axes,
/// then the gyro.
fn corrected_values(
    axes: &[spincal::correctors::corrector::Axis],
    outcome: &RowOutcome,
    gyro_width: usize,
    units: UnitFactors,
) -> Vec<Option<f64>> {
    // As before the row corrector was shared: the accelerometer times the reciprocal, the gyro
    // divided (Python's frames convert the same way, so both agree to the bit).
    let from_mps2 = 1.0 / units.accel_to_mps2;
    match outcome {
        RowOutcome::Corrected {
            accel_mps2,
            gyro_radps,
            ..
        } => axes
            .iter()
            .map(|a| Some(accel_mps2[a.index()] * from_mps2))
            .chain(
                gyro_radps
                    .iter()
                    .flatten()
                    .map(|&w| Some(w / units.gyro_to_radps)),
            )
            .collect(),
        RowOutcome::Refused(_) => vec![None; axes.len() + gyro_width],
    }
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
    let unit_matters = !matches!(
        model.corrector,
        spincal::correctors::model_file::CorrectorModel::Static(_)
    );
    if unit_matters && rows.header.is_empty() && map.accel_unit.is_none() {
        return Err(UsageError(format!(
            "{name}: no header line, so the acceleration unit cannot be known; pass --accel-unit g or --accel-unit mps2 (and --columns if the columns are not t,ax,ay,az)"
        ))
        .into());
    }
    let columns = ColumnPlan::new(&rows.header, width, name, map)?;
    // A row without a temperature is still corrected (and marked), so the column is not required.
    let temperature = columns.temperature_column();
    let used: Vec<usize> = columns
        .used_columns()
        .iter()
        .copied()
        .filter(|&c| Some(c) != temperature.map(|(t, _)| t))
        .collect();
    rows.choose_columns(&used);
    let units = UnitFactors {
        time_to_s: columns.time_to_s(),
        accel_to_mps2: columns.accel_to_mps2(),
        gyro_to_radps: columns.gyro_to_radps().unwrap_or(1.0),
    };
    let mut corrector = RowCorrector::new(model, units, columns.gyro_columns().is_some())?;
    let axes = corrector.corrected_axes().to_vec();
    let gyro = columns.gyro_columns().filter(|_| corrector.corrects_gyro());
    let gyro_width = if gyro.is_some() { 3 } else { 0 };
    let sep = rows.delimiter.as_char();
    let mut line = header
        .iter()
        .map(|h| field(h, sep))
        .collect::<Vec<_>>()
        .join(&sep.to_string());
    let corrected_names = axes
        .iter()
        .map(|a| columns.accel_columns()[a.index()])
        .chain(gyro.iter().flatten().copied());
    for col in corrected_names {
        line.push(sep);
        line.push_str(&field(&format!("{}_corrected", header[col]), sep));
    }
    line.push(sep);
    line.push_str("valid");
    line.push(sep);
    line.push_str("status");
    writeln!(out, "{line}")?;

    let mut values = Vec::with_capacity(width);
    let mut summary = StreamSummary {
        gyro_uncorrected: model.gyro.is_some() && columns.gyro_columns().is_none(),
        ..StreamSummary::default()
    };
    let value_name = |v: RowValue| {
        let c = match v {
            RowValue::Time => columns.time_column(),
            RowValue::Accel(a) => columns.accel_columns()[a],
            RowValue::Gyro(a) => gyro.map_or(0, |g| g[a]),
        };
        format!("column {} ({})", c + 1, header[c])
    };
    let blank = vec![None; axes.len() + gyro_width];
    while let Some(record) = rows.next_record(&mut values)? {
        summary.rows += 1;
        let line_no = match record {
            Record::Parsed { line } => line,
            Record::Incomplete { line, column, .. } => {
                let reason = format!("line {line}: column {column} ({}) is empty", header[column - 1]);
                summary.skipped += 1;
                summary.first_skipped.get_or_insert_with(|| reason.clone());
                write_row(
                    out,
                    &rows.line_text(),
                    sep,
                    &blank,
                    false,
                    &format!("skipped: {reason}"),
                )?;
                continue;
            }
            Record::Refused { line, text, error } => {
                let reason = format!("line {line}: {error}");
                summary.refused(&reason);
                let fields = refused_fields(&text, rows.delimiter, width)
                    .iter()
                    .map(|f| field(f, sep))
                    .collect::<Vec<_>>()
                    .join(&sep.to_string());
                write_row(out, &fields, sep, &blank, false, &format!("refused: {reason}"))?;
                continue;
            }
        };
        let outcome = corrector.correct(
            Some(values[columns.time_column()]),
            columns.accel_columns().map(|c| values[c]),
            gyro.map(|g| g.map(|c| values[c])),
            temperature.map(|(c, unit)| unit.to_celsius(values[c])),
            value_name,
        );
        let corrected = corrected_values(&axes, &outcome, gyro_width, units);
        match outcome {
            RowOutcome::Corrected { valid, status, .. } => {
                summary.corrected(line_no, status);
                write_row(out, &rows.line_text(), sep, &corrected, valid, status.as_str())?;
            }
            RowOutcome::Refused(reason) => {
                let reason = format!("line {line_no}, {reason}");
                summary.refused(&reason);
                write_row(
                    out,
                    &rows.line_text(),
                    sep,
                    &corrected,
                    false,
                    &format!("refused: {reason}"),
                )?;
            }
        }
    }
    out.flush()?;
    Ok(summary)
}

/// Corrects a recording read whole by the common reader and writes every sample it gave.
fn correct_loaded(
    model: &CorrectorFile,
    loaded: &Loaded,
    name: &str,
    out: &mut dyn Write,
) -> anyhow::Result<StreamSummary> {
    let rec = &loaded.recording;
    let static_input = match &model.corrector {
        spincal::correctors::model_file::CorrectorModel::Static(s) => Some(s.input_unit.as_str()),
        _ => None,
    };
    let counts_expected = static_input == Some("counts");
    if loaded.raw_counts != counts_expected {
        let what = if loaded.raw_counts { "raw counts" } else { "m/s²" };
        let wanted = if counts_expected {
            "raw counts (it was calibrated from them)"
        } else {
            "m/s² or g"
        };
        return Err(UsageError(format!(
            "{name}: the {} file holds {what}, but the model takes {wanted}; {}",
            loaded.format.name(),
            if loaded.raw_counts {
                "pass --accel-scale (and --accel-offset) to convert the counts, or correct it with a static calibration made from counts (`spincal static`)"
            } else {
                "correct the counts file the calibration was made from, or make the calibration from this file"
            }
        ))
        .into());
    }
    // The gyro is corrected when the model's calibration takes the file's unit (counts or rad/s).
    let gyro_unit_fits = model
        .gyro
        .as_ref()
        .is_some_and(|g| g.input_unit.is_rad_per_s() != loaded.gyro_counts);
    let gyro = rec.gyro_radps.as_ref().filter(|_| gyro_unit_fits);
    let units = UnitFactors {
        time_to_s: 1.0,
        accel_to_mps2: 1.0,
        gyro_to_radps: 1.0,
    };
    let mut corrector = RowCorrector::new(model, units, gyro.is_some())?;
    let axes = corrector.corrected_axes().to_vec();
    let gyro = gyro.filter(|_| corrector.corrects_gyro());
    let gyro_width = if gyro.is_some() { 3 } else { 0 };
    let accel_unit = if loaded.raw_counts { "counts" } else { "mps2" };
    let lines = (rec.source.lines.len() == rec.len()).then_some(&rec.source.lines);
    let mut header: Vec<String> = Vec::new();
    if lines.is_some() {
        header.push("line".into());
    }
    header.push("t_s".into());
    header.extend(["x", "y", "z"].map(|a| format!("a{a}_{accel_unit}")));
    if rec.gyro_radps.is_some() {
        let unit = if loaded.gyro_counts { "counts" } else { "radps" };
        header.extend(["x", "y", "z"].map(|a| format!("g{a}_{unit}")));
    }
    if rec.temperature_c.is_some() {
        header.push("temp_c".into());
    }
    if loaded.labels.is_some() {
        header.push("label".into());
    }
    header.extend(axes.iter().map(|a| format!("a{a}_corrected_mps2")));
    if gyro.is_some() {
        header.extend(["x", "y", "z"].map(|a| format!("g{a}_corrected_radps")));
    }
    header.extend(["valid".to_string(), "status".to_string()]);
    writeln!(out, "{}", header.join(","))?;
    let mut summary = StreamSummary {
        gyro_uncorrected: model.gyro.is_some() && rec.gyro_radps.is_none(),
        ..StreamSummary::default()
    };
    if model.gyro.is_some() && rec.gyro_radps.is_some() && !gyro_unit_fits {
        let (file, wanted) = if loaded.gyro_counts {
            ("raw counts", "rad/s")
        } else {
            ("rad/s", "raw counts")
        };
        eprintln!("warning: {name}: the gyro columns hold {file} but the model's gyro calibration takes {wanted}; only the accelerometer was corrected");
    }
    let value_name = |v: RowValue| match v {
        RowValue::Time => "t_s".to_string(),
        RowValue::Accel(a) => format!("a{}", ["x", "y", "z"][a]),
        RowValue::Gyro(a) => format!("g{}", ["x", "y", "z"][a]),
    };
    let mut input = String::new();
    for i in 0..rec.len() {
        summary.rows += 1;
        let line_no = lines.map_or(i + 1, |l| l[i]);
        input.clear();
        use std::fmt::Write as _;
        if lines.is_some() {
            write!(input, "{line_no},")?;
        }
        write!(input, "{}", rec.time_s[i])?;
        for a in &rec.accel_mps2 {
            write!(input, ",{}", a[i])?;
        }
        for g in rec.gyro_radps.iter().flatten() {
            write!(input, ",{}", g[i])?;
        }
        if let Some(t) = &rec.temperature_c {
            write!(input, ",{}", t[i])?;
        }
        if let Some(labels) = &loaded.labels {
            write!(input, ",{}", field(&labels[i], ','))?;
        }
        let outcome = corrector.correct(
            Some(rec.time_s[i]),
            std::array::from_fn(|a| rec.accel_mps2[a][i]),
            gyro.map(|g| std::array::from_fn(|a| g[a][i])),
            rec.temperature_c.as_ref().map(|t| t[i]),
            value_name,
        );
        let corrected = corrected_values(&axes, &outcome, gyro_width, units);
        match outcome {
            RowOutcome::Corrected { valid, status, .. } => {
                summary.corrected(line_no, status);
                write_row(out, &input, ',', &corrected, valid, status.as_str())?;
            }
            RowOutcome::Refused(reason) => {
                let where_ = if lines.is_some() { "line" } else { "sample" };
                let reason = format!("{where_} {line_no}, {reason}");
                summary.refused(&reason);
                write_row(out, &input, ',', &corrected, false, &format!("refused: {reason}"))?;
            }
        }
    }
    out.flush()?;
    Ok(summary)
}
