//! Delimited text streamed row by row: each data row out as its original text plus the corrected
//! columns, in constant memory.

use std::io::{BufRead, Write};

use super::gyro::{without_gyro, GyroMerge};
use super::sink::{field, DelimitedSink, RowSink};
use super::{unit_check, CorrectError, StreamSummary};
use crate::correctors::corrector::Axis;
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::correctors::rows::{RowCorrector, RowOutcome, RowValue, UnitFactors};
use crate::input::recording::{ColumnMap, ColumnPlan, TemperatureUnit};
use crate::input::table::{Delimiter, Record, RowReader};
use crate::thermal::checks::{check_unit, UNIT_CHECK_ROWS};

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

/// The names of the columns a corrected row adds, one rule for every writer (the text stream,
/// the whole-file path, Python's frames): `<axis>_corrected_<unit>` for each corrected
/// accelerometer axis (`ax_corrected_mps2`, `ay_corrected_g`), then the gyro's three when it is
/// corrected (`gx_corrected_dps`), then, when the model predicts its error, each accelerometer
/// axis's standard deviation (`ax_corrected_sd_mps2`) and `predicted_better`. The axis is
/// spincal's (`ax` … `gz`), never the input's column name; the unit is the one the values are in
/// (the input's, in the text stream: `mps2`, `g`, `radps`, `dps`).
pub fn corrected_column_names(
    axes: &[Axis],
    accel_unit: &str,
    gyro_unit: Option<&str>,
    predicted: bool,
) -> Vec<String> {
    let accel = |a: &Axis, what: &str| format!("a{}_{what}_{accel_unit}", a.name());
    let mut names: Vec<String> = axes.iter().map(|a| accel(a, "corrected")).collect();
    if let Some(unit) = gyro_unit {
        names.extend(["x", "y", "z"].map(|a| format!("g{a}_corrected_{unit}")));
    }
    if predicted {
        names.extend(axes.iter().map(|a| accel(a, "corrected_sd")));
        names.push("predicted_better".into());
    }
    names
}

/// The columns a corrected row adds: the corrected accelerometer axes, the gyro's when it is
/// corrected, and, for a model whose covariance predicts its error, each corrected axis's
/// predicted standard deviation and the flag `predicted_better`.
pub(super) struct CorrectedColumns {
    pub(super) axes: Vec<Axis>,
    pub(super) gyro: bool,
    pub(super) predicted: bool,
}

impl CorrectedColumns {
    pub(super) fn new(corrector: &RowCorrector<'_>, gyro: bool) -> CorrectedColumns {
        CorrectedColumns {
            axes: corrector.corrected_axes().to_vec(),
            gyro,
            predicted: corrector.predicts_error(),
        }
    }

    /// The names ([`corrected_column_names`]), the accelerometer's values in `accel_unit`, the
    /// gyro's in `gyro_unit`.
    pub(super) fn names(&self, accel_unit: &str, gyro_unit: &str) -> Vec<String> {
        corrected_column_names(
            &self.axes,
            accel_unit,
            self.gyro.then_some(gyro_unit),
            self.predicted,
        )
    }

    /// A row with none of them (skipped or refused).
    pub(super) fn blank(&self) -> Vec<Option<f64>> {
        let width = self.axes.len() * if self.predicted { 2 } else { 1 }
            + if self.gyro { 3 } else { 0 }
            + usize::from(self.predicted);
        vec![None; width]
    }

    /// A row's values in the file's units (None where the row was refused).
    pub(super) fn values(&self, outcome: &RowOutcome, units: UnitFactors) -> Vec<Option<f64>> {
        // The accelerometer times the reciprocal, the gyro divided: Python's frames convert the
        // same way, so both agree to the bit.
        let from_mps2 = 1.0 / units.accel_to_mps2;
        let RowOutcome::Corrected {
            accel_mps2,
            gyro_radps,
            predicted,
            ..
        } = outcome
        else {
            return self.blank();
        };
        let mut values: Vec<Option<f64>> = self
            .axes
            .iter()
            .map(|a| Some(accel_mps2[a.index()] * from_mps2))
            .collect();
        if self.gyro {
            match gyro_radps {
                Some(rate) => values.extend(rate.iter().map(|&w| Some(w / units.gyro_to_radps))),
                None => values.extend([None; 3]),
            }
        }
        if self.predicted {
            match predicted {
                Some(p) => {
                    values.extend(self.axes.iter().map(|a| Some(p.sd_mps2[a.index()] * from_mps2)));
                    values.push(Some(f64::from(u8::from(p.better))));
                }
                None => values.extend(std::iter::repeat_n(None, self.axes.len() + 1)),
            }
        }
        values
    }
}

/// Rows read ahead before any is written: to learn the time column's unit when the model needs
/// time, and to hold the acceleration unit against the model's gravity (at least
/// [`unit_check::UNIT_CHECK_ROWS`]).
const LOOK_AHEAD_ROWS: usize = 256;

/// A row read and not yet corrected.
struct Pending {
    record: Record,
    text: String,
    values: Vec<f64>,
}

/// The state of one stream: what each row goes through.
struct TextStream<'a, 'w> {
    corrector: RowCorrector<'a>,
    columns: &'a ColumnPlan,
    header: &'a [String],
    gyro: Option<[usize; 3]>,
    /// A gyro file merged on time (the input then has no gyro columns).
    merged: Option<GyroMerge>,
    temperature: Option<(usize, TemperatureUnit)>,
    added: CorrectedColumns,
    /// The corrected columns of a row that has none (skipped or refused), made once.
    blank: Vec<Option<f64>>,
    units: UnitFactors,
    width: usize,
    delimiter: Delimiter,
    sink: DelimitedSink<'w>,
    summary: StreamSummary,
}

impl TextStream<'_, '_> {
    /// Corrects and writes one row (`text` is its line as read).
    fn row(&mut self, record: Record, text: &str, values: &[f64]) -> Result<(), CorrectError> {
        let sep = self.delimiter.as_char();
        self.summary.rows += 1;
        let line_no = match record {
            Record::Parsed { line } => line,
            Record::Incomplete { line, column, .. } => {
                let reason = format!(
                    "line {line}: column {column} ({}) is empty",
                    self.header[column - 1]
                );
                self.summary.skip(&reason);
                self.sink
                    .row(text, &self.blank, false, &format!("skipped: {reason}"))?;
                return Ok(());
            }
            Record::Refused { line, text, error } => {
                let reason = format!("line {line}: {error}");
                self.summary.refuse(&reason);
                let fields = refused_fields(&text, self.delimiter, self.width)
                    .iter()
                    .map(|f| field(f, sep))
                    .collect::<Vec<_>>()
                    .join(&sep.to_string());
                self.sink
                    .row(&fields, &self.blank, false, &format!("refused: {reason}"))?;
                return Ok(());
            }
        };
        let (columns, header, gyro) = (self.columns, self.header, self.gyro);
        let value_name = |v: RowValue| {
            let c = match v {
                RowValue::Time => columns.time_column(),
                RowValue::Accel(a) => columns.accel_columns()[a],
                RowValue::Gyro(a) => gyro.map_or(0, |g| g[a]),
            };
            format!("column {} ({})", c + 1, header[c])
        };
        let time = values[columns.time_column()];
        let (mut gyro_values, mut no_gyro) = (gyro.map(|g| g.map(|c| values[c])), None);
        if let Some(merged) = self.merged.as_mut().filter(|_| time.is_finite()) {
            // Interpolated in rad/s; the corrector takes the file's gyro unit.
            match merged.at(time * self.units.time_to_s)? {
                Ok(w) => gyro_values = Some(w.map(|w| w / self.units.gyro_to_radps)),
                Err(why) => no_gyro = Some(why),
            }
        }
        let outcome = self.corrector.correct(
            Some(time),
            columns.accel_columns().map(|c| values[c]),
            gyro_values,
            self.temperature.map(|(c, unit)| unit.to_celsius(values[c])),
            value_name,
        );
        let corrected = self.added.values(&outcome, self.units);
        match outcome {
            RowOutcome::Corrected {
                valid,
                status,
                predicted,
                ..
            } => {
                self.summary.corrected(line_no, status, predicted);
                match no_gyro {
                    Some(why) => {
                        let status = without_gyro(status.as_str(), line_no, why);
                        self.summary.no_gyro(&status);
                        self.sink.row(text, &corrected, false, &status)?;
                    }
                    None => self.sink.row(text, &corrected, valid, status.as_str())?,
                }
            }
            RowOutcome::Refused(reason) => {
                let reason = format!("line {line_no}, {reason}");
                self.summary.refuse(&reason);
                self.sink
                    .row(text, &corrected, false, &format!("refused: {reason}"))?;
            }
        }
        Ok(())
    }
}

/// Streams delimited text from `reader` through `model` into `out`, every row in its order.
pub(super) fn correct_text(
    model: &CorrectorFile,
    reader: Box<dyn BufRead>,
    name: &str,
    map: &ColumnMap,
    merged: Option<GyroMerge>,
    out: &mut dyn Write,
) -> Result<StreamSummary, CorrectError> {
    let mut rows = RowReader::new(reader, name, &map.table)?;
    let width = rows.width();
    let header: Vec<String> = if rows.header.is_empty() {
        (1..=width).map(|c| format!("column{c}")).collect()
    } else {
        rows.header.clone()
    };
    // Networks and linear maps were trained in m/s²; a static calibration states its own unit.
    let unit_matters = !matches!(model.corrector, CorrectorModel::Static(_));
    if unit_matters && rows.header.is_empty() && map.accel_unit.is_none() {
        return Err(CorrectError::UnitUnknown {
            file: name.to_string(),
        });
    }
    let mut columns = ColumnPlan::new(&rows.header, width, name, map)?;
    // A row without a temperature is still corrected (and marked), so the column is not required.
    let temperature = columns.temperature_column();
    let used: Vec<usize> = columns
        .used_columns()
        .iter()
        .copied()
        .filter(|&c| Some(c) != temperature.map(|(t, _)| t))
        .collect();
    rows.choose_columns(&used);
    if columns.gyro_columns().is_some() && merged.is_some() {
        return Err(gyro_twice(name, merged));
    }
    let with_gyro = columns.gyro_columns().is_some() || merged.is_some();
    // A merged gyro needs each row's time, as a model that corrects with time does.
    let needs_time = RowCorrector::new(model, UnitFactors::SI, with_gyro)?.needs_time() || merged.is_some();
    // The first rows are read ahead: a model that needs time learns the time column's unit from
    // them, as a file read whole does, and the acceleration unit is held against the model's
    // gravity; they are corrected first, in their order.
    let expected_gravity = unit_check::expected_gravity_mps2(&model.corrector);
    let mut pending = Vec::new();
    let mut notes = Vec::new();
    if needs_time || expected_gravity.is_some() {
        let mut values = Vec::with_capacity(width);
        while pending.len() < LOOK_AHEAD_ROWS {
            let Some(record) = rows.next_record(&mut values)? else {
                break;
            };
            let text = rows.line_text().into_owned();
            pending.push(Pending {
                record,
                text,
                values: values.clone(),
            });
        }
    }
    if let Some(expected) = expected_gravity {
        let to_mps2 = columns.accel_to_mps2();
        let mut magnitudes: Vec<f64> = pending
            .iter()
            .filter(|p| matches!(p.record, Record::Parsed { .. }))
            .map(|p| {
                let a = columns.accel_columns().map(|c| p.values[c] * to_mps2);
                (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
            })
            .filter(|m| m.is_finite())
            .take(unit_check::UNIT_CHECK_ROWS)
            .collect();
        unit_check::check_accel_unit(name, &mut magnitudes, expected)?;
    }
    if needs_time {
        let k = columns.time_to_s();
        let mut times: Vec<f64> = pending
            .iter()
            .filter(|p| matches!(p.record, Record::Parsed { .. }))
            .map(|p| p.values[columns.time_column()] * k)
            .filter(|t| t.is_finite())
            .collect();
        notes = columns
            .settle_time(&mut times, name, &[])
            .map_err(crate::input::recording::RecordingError::from)?;
    }
    // The temperature's unit, from the rows read ahead, before any row is written.
    if let (Some(_), Some((c, unit))) = (&model.thermal, temperature) {
        let values: Vec<f64> = pending
            .iter()
            .filter(|p| matches!(p.record, Record::Parsed { .. }))
            .take(UNIT_CHECK_ROWS)
            .map(|p| unit.to_celsius(p.values[c]))
            .collect();
        check_unit(name, &header[c], &values, unit)?;
    }
    let units = UnitFactors {
        time_to_s: columns.time_to_s(),
        accel_to_mps2: columns.accel_to_mps2(),
        gyro_to_radps: columns.gyro_to_radps().unwrap_or(1.0),
    };
    let corrector = RowCorrector::new(model, units, with_gyro)?;
    let gyro = columns.gyro_columns().filter(|_| corrector.corrects_gyro());
    let merged = merged.filter(|_| corrector.corrects_gyro());
    let sep = rows.delimiter.as_char();
    let mut sink = DelimitedSink::new(out, sep);
    let added = CorrectedColumns::new(&corrector, gyro.is_some() || merged.is_some());
    // Named in the units the values are written in: the file's own.
    let corrected_names = added.names(
        columns.accel_unit().suffix(),
        columns.gyro_unit().map_or("radps", |u| u.suffix()),
    );
    let names: Vec<String> = header
        .iter()
        .cloned()
        .chain(corrected_names)
        .chain(["valid".to_string(), "status".to_string()])
        .collect();
    sink.header(&names)?;
    let mut summary = StreamSummary::new(name, model);
    summary.gyro_uncorrected = model.gyro.is_some() && !with_gyro;
    summary.notes = notes;
    let mut stream = TextStream {
        corrector,
        columns: &columns,
        header: &header,
        gyro,
        merged,
        temperature,
        blank: added.blank(),
        added,
        units,
        width,
        delimiter: rows.delimiter,
        sink,
        summary,
    };
    for p in pending {
        stream.row(p.record, &p.text, &p.values)?;
    }
    let mut values = Vec::with_capacity(width);
    while let Some(record) = rows.next_record(&mut values)? {
        stream.row(record, &rows.line_text(), &values)?;
    }
    if let Some(merged) = stream.merged.take() {
        // Before the last flush: under half the rows covered fails the correction.
        let notes = merged.finish()?;
        stream.summary.notes.extend(notes);
    }
    stream.sink.flush()?;
    Ok(stream.summary)
}

/// The input has gyro columns and a gyro file was given too.
pub(super) fn gyro_twice(name: &str, merged: Option<GyroMerge>) -> CorrectError {
    CorrectError::Gyro(Box::new(crate::input::gyro_file::GyroFileError::GyroTwice {
        file: merged.map(|m| m.file).unwrap_or_default(),
        recording: name.to_string(),
    }))
}
