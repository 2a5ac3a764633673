//! A recording: time, three accelerometer axes and optionally three gyro axes, in SI units.
//!
//! Frame: the sensor's own axes as printed on its case (x, y, z right-handed). Inside spincal time is
//! in seconds, acceleration in m/s², angular rate in rad/s; files may use g, ms or deg/s and say so
//! in their column names (`ax_g`, `t_ms`, `gx_dps`) or through [`ColumnMap`] options.

use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::input::table::{Incomplete, Location, TableError};

mod columns;
mod interpolate;
mod read;
pub mod time;
mod units;

pub(crate) use columns::gyro_only_map;
pub use columns::{temperature_unit_of_name, ColumnMap, ColumnPlan};
pub use interpolate::{interpolate_onto, merge_onto, Bracket, Uncovered};
pub use units::{AccelUnit, GyroUnit, TemperatureUnit, TimeUnit, STANDARD_GRAVITY};

/// Where a recording came from and how it was read.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Source {
    /// File name or other description.
    pub name: String,
    /// Format name as detected or chosen (`csv`, `phyphox`, `3dm-gx1`, …).
    pub format: String,
    /// Columns used, as `t,ax,ay,az[,gx,gy,gz][,temperature]` names from the file.
    pub columns: Vec<String>,
    /// Lines skipped before the data (metadata), as read.
    pub metadata: Vec<String>,
    /// 1-based source line of every sample, when read from text (empty otherwise).
    #[serde(skip)]
    pub lines: Vec<usize>,
    /// Data rows left out because a chosen column was empty (a logger's packets of another
    /// kind, interleaved).
    #[serde(default)]
    pub incomplete_rows: Incomplete,
    /// What was decided about the time column (its unit found from the values, a counter
    /// unwrapped: [`time`]).
    #[serde(default)]
    pub time_notes: Vec<String>,
}

/// Time series of one IMU session, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// Accelerometer x, y, z, m/s² (specific force, sensor frame).
    pub accel_mps2: [Vec<f64>; 3],
    /// Gyro x, y, z, rad/s (sensor frame), when recorded.
    pub gyro_radps: Option<[Vec<f64>; 3]>,
    /// The sensor's reported temperature, °C, when recorded (a die or board sensor: it may lag the
    /// die and be quantised; see [`crate::thermal`]).
    pub temperature_c: Option<Vec<f64>>,
    pub source: Source,
}

/// Everything that can be wrong with a recording as a whole.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    ImplausibleTime(#[from] time::ImplausibleTime),
    #[error("{file}: no column '{key}' (columns: {available})")]
    NoSuchColumn {
        file: String,
        key: String,
        available: String,
    },
    #[error("{file}: cannot tell which columns hold time and acceleration (columns: {available}); name them in `columns`: t,ax,ay,az")]
    AmbiguousColumns { file: String, available: String },
    #[error("{file}: no time column among {available} (the acceleration is in {accel}); name the time column first in `columns`: T,{accel} (with `time_unit` ms, us or ns if it is not in s), or, when the file has none, any column as T with `sample_rate_hz`")]
    NoTimeColumn {
        file: String,
        available: String,
        accel: String,
    },
    #[error("`columns` needs 4, 5, 7 or 8 entries (t,ax,ay,az[,gx,gy,gz][,temperature]), got {0}")]
    ColumnCount(usize),
    #[error("{at}: time goes backwards ({previous} s, then {current} s)")]
    TimeNotIncreasing {
        at: Location,
        previous: f64,
        current: f64,
    },
    #[error("{at}: the value is finite in the file but {converted} after conversion to SI units (× {factor}); spincal needs finite numbers: check the column's unit or the value")]
    NonFiniteAfterConversion {
        at: Location,
        converted: f64,
        factor: f64,
    },
    #[error("{file}: only {found} samples; at least {needed} are needed")]
    TooShort {
        file: String,
        found: usize,
        needed: usize,
    },
    /// Writing an output file failed (the previous file, if any, is kept).
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("{file}: cannot write: {source}")]
    Write {
        file: String,
        #[source]
        source: std::io::Error,
    },
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Duration from first to last sample, s.
    pub fn duration_s(&self) -> f64 {
        match (self.time_s.first(), self.time_s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// Nominal sample rate, Hz: the inverse of the median sample interval.
    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / sample_interval(&self.time_s)
    }

    /// Checks that time strictly increases; the error names the file line.
    pub fn check_time(&self) -> Result<(), RecordingError> {
        for i in 1..self.time_s.len() {
            let (previous, current) = (self.time_s[i - 1], self.time_s[i]);
            // Equal stamps are kept: coarse clocks repeat them (a T265 log has 10 ms stamps at
            // 62.5 Hz); the rate then comes from all timestamps and `inspect` reports the repeats.
            if current < previous {
                return Err(RecordingError::TimeNotIncreasing {
                    at: self.location(i),
                    previous,
                    current,
                });
            }
        }
        Ok(())
    }

    /// Location of sample `i` in the source file (sample number when not read from text).
    pub fn location(&self, i: usize) -> Location {
        Location {
            file: self.source.name.clone(),
            line: self.source.lines.get(i).copied().unwrap_or(i + 1),
            column: None,
            column_name: None,
        }
    }

    /// The samples where `keep` is true, with their source lines (gaps where samples were dropped).
    pub fn select(&self, keep: &[bool]) -> Recording {
        let pick =
            |v: &[f64]| -> Vec<f64> { v.iter().zip(keep).filter(|(_, k)| **k).map(|(x, _)| *x).collect() };
        let lines = if self.source.lines.len() == self.len() {
            self.source
                .lines
                .iter()
                .zip(keep)
                .filter(|(_, k)| **k)
                .map(|(l, _)| *l)
                .collect()
        } else {
            (0..self.len()).filter(|&i| keep[i]).map(|i| i + 1).collect()
        };
        Recording {
            time_s: pick(&self.time_s),
            accel_mps2: std::array::from_fn(|a| pick(&self.accel_mps2[a])),
            gyro_radps: self
                .gyro_radps
                .as_ref()
                .map(|g| std::array::from_fn(|a| pick(&g[a]))),
            temperature_c: self.temperature_c.as_deref().map(pick),
            source: Source {
                lines,
                ..self.source.clone()
            },
        }
    }

    /// Writes the recording as CSV with unit-bearing header names (`t_s,ax_mps2,…` or `ax_g`, and
    /// `temp_c` when the recording has a temperature).
    pub fn write_csv<W: Write>(&self, mut out: W, unit: AccelUnit) -> std::io::Result<()> {
        let u = unit.suffix();
        write!(out, "t_s,ax_{u},ay_{u},az_{u}")?;
        if self.gyro_radps.is_some() {
            write!(out, ",gx_radps,gy_radps,gz_radps")?;
        }
        if self.temperature_c.is_some() {
            write!(out, ",temp_c")?;
        }
        writeln!(out)?;
        let k = 1.0 / unit.to_si();
        for i in 0..self.len() {
            let a = &self.accel_mps2;
            write!(
                out,
                "{},{},{},{}",
                self.time_s[i],
                a[0][i] * k,
                a[1][i] * k,
                a[2][i] * k
            )?;
            if let Some(g) = &self.gyro_radps {
                write!(out, ",{},{},{}", g[0][i], g[1][i], g[2][i])?;
            }
            if let Some(temperature) = &self.temperature_c {
                write!(out, ",{}", temperature[i])?;
            }
            writeln!(out)?;
        }
        out.flush()
    }

    /// Writes the recording to a file path (see [`Recording::write_csv`]).
    pub fn write_csv_path(&self, path: &Path, unit: AccelUnit) -> Result<(), RecordingError> {
        crate::output::write_file(path, |out| self.write_csv(out, unit))?;
        Ok(())
    }
}

/// The sampling interval from all the timestamps: the median of (t\[i+k\] − t\[i\]) / k over
/// non-overlapping windows of k steps (k up to 64). Unlike the median step it is right for
/// quantised clocks, whose steps alternate between whole ticks (a 3DM-GX1 at 1 or 2 ticks of
/// 6.5536 ms), and for coarse timestamps that repeat; a gap or a backward step spoils only the one
/// window it falls in. NaN for fewer than two samples.
pub fn sample_interval(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return f64::NAN;
    }
    let steps = t.len() - 1;
    let k = (steps / 8).clamp(1, 64);
    let mut rates: Vec<f64> = (0..steps / k)
        .map(|w| (t[(w + 1) * k] - t[w * k]) / k as f64)
        .collect();
    let mid = rates.len() / 2;
    *rates.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The least positive step: the timestamps' resolution when the clock is coarser than the rate.
pub(crate) fn time_quantum(t: &[f64]) -> f64 {
    t.windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min)
}

/// Median of successive differences of `t` (NaN for fewer than two samples).
pub fn median_interval(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return f64::NAN;
    }
    let mut dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = dt.len() / 2;
    *dt.select_nth_unstable_by(mid, f64::total_cmp).1
}
#[cfg(test)]
mod tests;
