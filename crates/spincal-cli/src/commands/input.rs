//! How the commands read recordings: one set of flags, one function.

use std::path::Path;

use anyhow::Context;
use clap::Args;
use spincal::formats::{read_path, Format, ReadOptions};
use spincal::recording::{AccelUnit, ColumnMap, TimeUnit};
use spincal::table::Delimiter;
use spincal::Recording;

use crate::ui::UsageError;

/// Flags that say how to read a recording file.
#[derive(Args, Debug, Clone, Default)]
pub struct ReadArgs {
    /// Columns holding t,ax,ay,az[,gx,gy,gz]: header names or 1-based indices (guessed when absent).
    #[arg(long, value_name = "t,ax,ay,az")]
    pub columns: Option<String>,
    /// Unit of the acceleration columns: g or mps2 (default: from the column names, else m/s²).
    #[arg(long, value_name = "UNIT")]
    pub accel_unit: Option<String>,
    /// Unit of the time column: s, ms or us (default: from the column name, else s).
    #[arg(long, value_name = "UNIT")]
    pub time_unit: Option<String>,
    /// Field separator: comma, semicolon, tab or whitespace (default: detected).
    #[arg(long, value_name = "SEP")]
    pub delimiter: Option<String>,
    /// File format: csv, whitespace (imu_tk), imucal, mpu6050, phyphox, 3dm-gx1; detected when absent.
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<String>,
}

impl ReadArgs {
    /// Resolves the flags into a checked column map; bad values are usage errors.
    pub fn column_map(&self) -> anyhow::Result<ColumnMap> {
        let mut map = ColumnMap::default();
        if let Some(spec) = &self.columns {
            map = map.with_columns(spec).map_err(|e| UsageError(e.to_string()))?;
        }
        if let Some(u) = &self.accel_unit {
            map.accel_unit = Some(
                AccelUnit::parse(u)
                    .ok_or_else(|| UsageError(format!("--accel-unit {u}: expected g or mps2")))?,
            );
        }
        if let Some(u) = &self.time_unit {
            map.time_unit = Some(
                TimeUnit::parse(u)
                    .ok_or_else(|| UsageError(format!("--time-unit {u}: expected s, ms or us")))?,
            );
        }
        if let Some(d) = &self.delimiter {
            map.table.delimiter = Some(Delimiter::parse(d).ok_or_else(|| {
                UsageError(format!(
                    "--delimiter {d}: expected comma, semicolon, tab or whitespace"
                ))
            })?);
        }
        Ok(map)
    }

    /// Reads one recording in any supported format (detected unless `--format` is given).
    pub fn read(&self, path: &Path) -> anyhow::Result<Recording> {
        let format = match &self.format {
            Some(name) => Some(Format::parse(name).ok_or_else(|| {
                UsageError(format!(
                    "--format {name}: expected csv, whitespace, imucal, mpu6050, phyphox or 3dm-gx1"
                ))
            })?),
            None => None,
        };
        let options = ReadOptions {
            format,
            columns: self.column_map()?,
            ..ReadOptions::default()
        };
        let loaded = read_path(path, &options).with_context(|| format!("reading {}", path.display()))?;
        if loaded.raw_counts {
            return Err(UsageError(format!(
                "{}: the {} file holds raw counts; spincal needs m/s² or g here (use `spincal static` to calibrate the counts first)",
                path.display(),
                loaded.format.name()
            ))
            .into());
        }
        Ok(loaded.recording)
    }
}
