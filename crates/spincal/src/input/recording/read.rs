//! Reading a recording: from a delimited text file, bytes or a parsed table, through a column
//! plan into SI units.

use std::io::BufRead;
use std::path::Path;

use super::columns::ColumnPlan;
use super::{ColumnMap, Recording, RecordingError, Source};
use crate::input::table::{read_file, Location, Table, TableError, TableHead};

impl Recording {
    /// Reads a recording from a delimited text file.
    pub fn read_csv_path(path: &Path, map: &ColumnMap) -> Result<Recording, RecordingError> {
        let file = path.display().to_string();
        let bytes = read_file(path).map_err(|source| TableError::Io {
            file: file.clone(),
            source,
        })?;
        Recording::parse_csv(&bytes, &file, map)
    }

    /// Reads a recording from any text source (to its end, then [`Recording::parse_csv`]); `name`
    /// is used in errors.
    pub fn read_csv<R: BufRead>(
        mut reader: R,
        name: &str,
        map: &ColumnMap,
    ) -> Result<Recording, RecordingError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).map_err(|source| TableError::Io {
            file: name.to_string(),
            source,
        })?;
        Recording::parse_csv(&bytes, name, map)
    }

    /// Parses a delimited text file held in memory; `name` is used in errors. Only the chosen
    /// columns are kept, converted to SI while they are parsed; the result and every error are
    /// those of [`Table::parse`] followed by [`Recording::from_table`].
    pub fn parse_csv(bytes: &[u8], name: &str, map: &ColumnMap) -> Result<Recording, RecordingError> {
        Recording::parse_csv_timed(bytes, name, map, None)
    }

    /// [`Recording::parse_csv`]; with `rate_hz`, time is sample number / rate and the time
    /// column's values are not used (nor checked): a sample index, or a clock too coarse to use.
    pub fn parse_csv_timed(
        bytes: &[u8],
        name: &str,
        map: &ColumnMap,
        rate_hz: Option<f64>,
    ) -> Result<Recording, RecordingError> {
        let head = TableHead::new(bytes, name, &map.table)?;
        let plan = match ColumnPlan::new(&head.header, head.width(), name, map) {
            Ok(plan) => plan,
            Err(e) => {
                // An error in the table comes first, as when the whole table was read before.
                head.rows(&[])?;
                return Err(e);
            }
        };
        let rows = head.rows_skipping_incomplete(&plan.targets())?;
        let metadata = head.metadata.iter().map(|(_, s)| s.clone()).collect();
        let mut recording = Recording::from_columns(
            plan,
            rows.columns.into_iter(),
            name.to_string(),
            metadata,
            rows.lines,
            rate_hz,
        )?;
        recording.source.incomplete_rows = rows.incomplete;
        Ok(recording)
    }

    /// Picks time/accel/gyro columns out of a table and converts them to SI.
    pub fn from_table(table: &Table, map: &ColumnMap) -> Result<Recording, RecordingError> {
        Recording::from_table_timed(table, map, None)
    }

    /// [`Recording::from_table`], with time = sample number / `rate_hz` when given (see
    /// [`Recording::parse_csv_timed`]).
    pub fn from_table_timed(
        table: &Table,
        map: &ColumnMap,
        rate_hz: Option<f64>,
    ) -> Result<Recording, RecordingError> {
        let plan = ColumnPlan::new(&table.header, table.n_columns(), &table.file, map)?;
        let columns: Vec<Vec<f64>> = plan
            .targets()
            .into_iter()
            .map(|(c, k)| table.columns[c].iter().map(|v| v * k).collect())
            .collect();
        let metadata = table.metadata.iter().map(|(_, s)| s.clone()).collect();
        Recording::from_columns(
            plan,
            columns.into_iter(),
            table.file.clone(),
            metadata,
            table.lines.clone(),
            rate_hz,
        )
    }

    /// A recording from the plan's columns in SI, in its order (time, accel x y z, gyro x y z when
    /// planned); checks the time.
    fn from_columns(
        plan: ColumnPlan,
        mut columns: impl Iterator<Item = Vec<f64>>,
        name: String,
        metadata: Vec<String>,
        lines: Vec<usize>,
        rate_hz: Option<f64>,
    ) -> Result<Recording, RecordingError> {
        let mut plan = plan;
        let mut next = || columns.next().unwrap_or_default();
        let mut time_s = next();
        let mut time_notes = Vec::new();
        if let Some(rate) = rate_hz {
            for (i, t) in time_s.iter_mut().enumerate() {
                *t = i as f64 / rate;
            }
        } else if time_s.iter().all(|t| t.is_finite()) {
            time_notes = plan.settle_time(&mut time_s, &name, &lines)?;
        }
        let accel_mps2 = [next(), next(), next()];
        let gyro_radps = plan.gyro.then(|| [next(), next(), next()]);
        let temperature_c = plan.temperature.map(|unit| {
            let mut column = next();
            column.iter_mut().for_each(|v| *v = unit.to_celsius(*v));
            column
        });
        // The file's values were finite; a unit's factor can still carry one past f64's range.
        let converted: Vec<&Vec<f64>> = std::iter::once(&time_s)
            .filter(|_| rate_hz.is_none())
            .chain(accel_mps2.iter())
            .chain(gyro_radps.iter().flatten())
            .chain(temperature_c.iter())
            .collect();
        let skip = usize::from(rate_hz.is_some());
        for (k, column) in converted.into_iter().enumerate() {
            let k = k + skip;
            if let Some(i) = column.iter().position(|v| !v.is_finite()) {
                return Err(RecordingError::NonFiniteAfterConversion {
                    at: Location {
                        file: name,
                        line: lines.get(i).copied().unwrap_or(i + 1),
                        column: Some(plan.indices[k] + 1),
                        column_name: Some(plan.names[k].clone()),
                    },
                    converted: column[i],
                    factor: plan.scales[k],
                });
            }
        }
        let recording = Recording {
            time_s,
            accel_mps2,
            gyro_radps,
            temperature_c,
            source: Source {
                name,
                format: "csv".into(),
                columns: plan.names,
                metadata,
                lines,
                incomplete_rows: Default::default(),
                time_notes,
            },
        };
        recording.check_time()?;
        Ok(recording)
    }
}
