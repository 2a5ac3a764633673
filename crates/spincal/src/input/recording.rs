//! A recording: time, three accelerometer axes and optionally three gyro axes, in SI units.
//!
//! Frame: the sensor's own axes as printed on its case (x, y, z right-handed). Inside spincal time is
//! in seconds, acceleration in m/s², angular rate in rad/s; files may use g, ms or deg/s and say so
//! in their column names (`ax_g`, `t_ms`, `gx_dps`) or through [`ColumnMap`] options.

use std::io::{BufRead, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::input::table::{
    find_column, read_file, Incomplete, Location, Table, TableError, TableHead, TableOptions,
};

/// Standard gravity, m/s² (the default local g).
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// Unit of acceleration values in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AccelUnit {
    /// Metres per second squared.
    Mps2,
    /// Multiples of standard gravity (9.80665 m/s²).
    G,
}

impl AccelUnit {
    pub fn to_si(self) -> f64 {
        match self {
            AccelUnit::Mps2 => 1.0,
            AccelUnit::G => STANDARD_GRAVITY,
        }
    }
    pub fn parse(text: &str) -> Option<AccelUnit> {
        match text.to_ascii_lowercase().as_str() {
            "g" => Some(AccelUnit::G),
            "mps2" | "m/s2" | "m/s^2" | "m/s²" | "si" => Some(AccelUnit::Mps2),
            _ => None,
        }
    }
    pub fn suffix(self) -> &'static str {
        match self {
            AccelUnit::Mps2 => "mps2",
            AccelUnit::G => "g",
        }
    }
}

/// Unit of time values in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeUnit {
    S,
    Ms,
    Us,
    /// Nanoseconds: ROS stamps and Linux loggers, often since the epoch (an f64 holds such a stamp
    /// to about 0.25 µs).
    Ns,
}

impl TimeUnit {
    pub fn to_si(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
            TimeUnit::Ns => 1e-9,
        }
    }
    pub fn parse(text: &str) -> Option<TimeUnit> {
        match text.to_ascii_lowercase().as_str() {
            "s" => Some(TimeUnit::S),
            "ms" => Some(TimeUnit::Ms),
            "us" | "µs" => Some(TimeUnit::Us),
            "ns" => Some(TimeUnit::Ns),
            _ => None,
        }
    }
}

/// Unit of angular-rate values in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GyroUnit {
    Radps,
    Dps,
}

impl GyroUnit {
    pub fn to_si(self) -> f64 {
        match self {
            GyroUnit::Radps => 1.0,
            GyroUnit::Dps => std::f64::consts::PI / 180.0,
        }
    }
    pub fn parse(text: &str) -> Option<GyroUnit> {
        match text.to_ascii_lowercase().as_str() {
            "radps" | "rad/s" => Some(GyroUnit::Radps),
            "dps" | "deg/s" => Some(GyroUnit::Dps),
            _ => None,
        }
    }
}

/// Unit of a temperature column in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TemperatureUnit {
    /// Degrees Celsius.
    C,
    /// Kelvin.
    K,
    /// Degrees Fahrenheit.
    F,
    /// The MPU-6000/6050 family's TEMP_OUT register, raw counts: °C = counts / 340 + 36.53
    /// (InvenSense MPU-6000/MPU-6050 Register Map, rev. 4.2, register 65–66).
    Mpu6050Counts,
}

impl TemperatureUnit {
    /// The value in °C.
    pub fn to_celsius(self, value: f64) -> f64 {
        match self {
            TemperatureUnit::C => value,
            TemperatureUnit::K => value - 273.15,
            TemperatureUnit::F => (value - 32.0) * 5.0 / 9.0,
            TemperatureUnit::Mpu6050Counts => value / 340.0 + 36.53,
        }
    }
    /// Its name as [`TemperatureUnit::parse`] reads it (and as serde writes it).
    pub fn name(self) -> &'static str {
        match self {
            TemperatureUnit::C => "c",
            TemperatureUnit::K => "k",
            TemperatureUnit::F => "f",
            TemperatureUnit::Mpu6050Counts => "mpu6050counts",
        }
    }
    pub fn parse(text: &str) -> Option<TemperatureUnit> {
        match text.to_ascii_lowercase().as_str() {
            "c" | "degc" | "°c" | "celsius" => Some(TemperatureUnit::C),
            "k" | "kelvin" => Some(TemperatureUnit::K),
            "f" | "degf" | "°f" => Some(TemperatureUnit::F),
            "mpu6050" | "mpu6050counts" | "counts" => Some(TemperatureUnit::Mpu6050Counts),
            _ => None,
        }
    }
}

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
    #[error("{file}: no column '{key}' (columns: {available})")]
    NoSuchColumn {
        file: String,
        key: String,
        available: String,
    },
    #[error("{file}: cannot tell which columns hold time and acceleration (columns: {available}); pass --columns t,ax,ay,az")]
    AmbiguousColumns { file: String, available: String },
    #[error("{file}: no time column among {available} (the acceleration is in {accel}); pass --columns T,{accel} naming the time column (with --time-unit ms, us or ns if it is not in s), or, when the file has none, any column as T with --sample-rate HZ")]
    NoTimeColumn {
        file: String,
        available: String,
        accel: String,
    },
    #[error("--columns needs 4, 5, 7 or 8 entries (t,ax,ay,az[,gx,gy,gz][,temperature]), got {0}")]
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

/// Which columns hold what, and in which units.
#[derive(Debug, Clone, Default)]
pub struct ColumnMap {
    /// `t,ax,ay,az[,gx,gy,gz][,temperature]` as names or 1-based indices; guessed from the header
    /// when `None`.
    pub columns: Option<Vec<String>>,
    /// Acceleration unit; from the column name suffix (`_g`, `_mps2`) or m/s² when `None`.
    pub accel_unit: Option<AccelUnit>,
    /// Time unit; from the column name suffix (`_s`, `_ms`, `_us`) or seconds when `None`.
    pub time_unit: Option<TimeUnit>,
    /// Gyro unit; from the column name suffix (`_dps`, `_radps`) or rad/s when `None`.
    pub gyro_unit: Option<GyroUnit>,
    /// Temperature unit; from the column name suffix (`_c`, `_k`, `_f`) or °C when `None`.
    pub temperature_unit: Option<TemperatureUnit>,
    pub table: TableOptions,
}

impl ColumnMap {
    /// Parses `t,ax,ay,az[,gx,gy,gz][,temperature]`.
    pub fn with_columns(mut self, spec: &str) -> Result<Self, RecordingError> {
        let keys: Vec<String> = spec.split(',').map(|s| s.trim().to_string()).collect();
        if ![4, 5, 7, 8].contains(&keys.len()) {
            return Err(RecordingError::ColumnCount(keys.len()));
        }
        self.columns = Some(keys);
        Ok(self)
    }
}

const TIME_NAMES: &[&str] = &[
    "t",
    "time",
    "timestamp",
    "time (s)",
    "t_s",
    "t_ms",
    "t_us",
    "time_s",
    "time_ms",
    "time_us",
    "t_ns",
    "time_ns",
    "timestamp_ms",
    "timestamp_us",
    "timestamp_ns",
    "stamp",
    "stamp_ns",
    // `rostopic echo -p`: the receive time and the message's own stamp, both in ns.
    "field.header.stamp",
    "%time",
];

/// Time columns in nanoseconds without saying so in a suffix (ROS's CSV dumps).
const NANOSECOND_TIME_NAMES: &[&str] = &["%time", "field.header.stamp", "header.stamp", "stamp"];
const AXIS: [&str; 3] = ["x", "y", "z"];

/// Header names spincal recognises for accelerometer axis `a` (0 = x).
fn accel_names(a: usize) -> Vec<String> {
    let x = AXIS[a];
    let mut names = vec![
        format!("a{x}"),
        format!("acc_{x}"),
        format!("acc{x}"),
        format!("accel_{x}"),
        format!("accel{x}"),
        format!("a_{x}"),
        format!("linear acceleration {x} (m/s^2)"),
        format!("acceleration {x} (m/s^2)"),
        format!("linear_acceleration_{x}"),
        format!("linear_acceleration.{x}"),
        format!("field.linear_acceleration.{x}"),
    ];
    for unit in ["g", "mps2"] {
        names.push(format!("a{x}_{unit}"));
        names.push(format!("acc_{x}_{unit}"));
    }
    names
}

fn gyro_names(a: usize) -> Vec<String> {
    let x = AXIS[a];
    let mut names = vec![
        format!("g{x}"),
        format!("gyr_{x}"),
        format!("gyro_{x}"),
        format!("gyro{x}"),
        format!("w{x}"),
        format!("gyroscope {x} (rad/s)"),
        format!("angular_velocity_{x}"),
        format!("angular_velocity.{x}"),
        format!("field.angular_velocity.{x}"),
    ];
    for unit in ["dps", "radps"] {
        names.push(format!("g{x}_{unit}"));
        names.push(format!("gyr_{x}_{unit}"));
    }
    names
}

/// Header names spincal recognises for a temperature column (°C unless a unit suffix says
/// otherwise: `temp_k`, `temperature_f`).
fn temperature_names() -> Vec<String> {
    let mut names: Vec<String> = ["temperature (°c)", "temp (°c)", "temperature (c)", "temp (c)"]
        .map(String::from)
        .to_vec();
    for stem in [
        "temp",
        "temperature",
        "imu_temp",
        "die_temp",
        "temp_die",
        "imu_temperature",
    ] {
        names.push(stem.to_string());
        for unit in ["c", "degc", "k", "f"] {
            names.push(format!("{stem}_{unit}"));
        }
    }
    names
}

fn find_any(header: &[String], names: &[String]) -> Option<usize> {
    header
        .iter()
        .position(|h| names.iter().any(|n| h.trim().eq_ignore_ascii_case(n)))
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
        let mut next = || columns.next().unwrap_or_default();
        let mut time_s = next();
        if let Some(rate) = rate_hz {
            for (i, t) in time_s.iter_mut().enumerate() {
                *t = i as f64 / rate;
            }
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
            },
        };
        recording.check_time()?;
        Ok(recording)
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

/// Reads a unit from a column-name suffix: `ax_g`, `t_ms`, `gx (deg/s)`.
fn unit_from_name<U>(name: &str, parse: impl Fn(&str) -> Option<U>) -> Option<U> {
    let lower = name.to_ascii_lowercase();
    if let (Some(open), Some(close)) = (lower.rfind('('), lower.rfind(')')) {
        if open < close {
            if let Some(u) = parse(lower[open + 1..close].trim()) {
                return Some(u);
            }
        }
    }
    lower.rsplit_once('_').and_then(|(_, suffix)| parse(suffix))
}

/// Which columns of a table become time, acceleration, rate and temperature, and each one's
/// factor to SI: the one reading of a header that every entry point shares (whole files, the
/// streaming `correct`, Python's DataFrames).
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnPlan {
    /// File columns of t, ax, ay, az[, gx, gy, gz][, temperature].
    indices: Vec<usize>,
    /// Whether gx, gy, gz are among them.
    gyro: bool,
    /// The temperature column's unit, when there is one (its factor in `scales` is 1: the
    /// conversion to °C is affine, applied after reading).
    temperature: Option<TemperatureUnit>,
    /// Factor to SI of each.
    scales: Vec<f64>,
    /// Their names in the file (or `column N`).
    names: Vec<String>,
}

impl ColumnPlan {
    /// Reads a header (empty when the table has none) of a table `n_columns` wide by the column
    /// rules: `map.columns` when given, else the names (`t`, `ax_g`, `gx (deg/s)`, `temp_c`, …),
    /// else position for a bare 4- or 7-column table. `file` names the table in errors.
    pub fn new(
        header: &[String],
        n_columns: usize,
        file: &str,
        map: &ColumnMap,
    ) -> Result<ColumnPlan, RecordingError> {
        let (indices, gyro, has_temperature) = resolve_columns(header, n_columns, file, map)?;
        let name_of = |i: usize| {
            header
                .get(i)
                .cloned()
                .unwrap_or_else(|| format!("column {}", i + 1))
        };
        let time_name = name_of(indices[0]);
        let time_unit = map
            .time_unit
            .or_else(|| unit_from_name(&time_name, TimeUnit::parse))
            .or_else(|| {
                NANOSECOND_TIME_NAMES
                    .iter()
                    .any(|n| time_name.trim().eq_ignore_ascii_case(n))
                    .then_some(TimeUnit::Ns)
            })
            .unwrap_or(TimeUnit::S);
        let accel_unit = map
            .accel_unit
            .or_else(|| unit_from_name(&name_of(indices[1]), AccelUnit::parse))
            .unwrap_or(AccelUnit::Mps2);
        let mut scales = vec![
            time_unit.to_si(),
            accel_unit.to_si(),
            accel_unit.to_si(),
            accel_unit.to_si(),
        ];
        if gyro {
            let unit = map
                .gyro_unit
                .or_else(|| unit_from_name(&name_of(indices[4]), GyroUnit::parse))
                .unwrap_or(GyroUnit::Radps);
            scales.extend([unit.to_si(); 3]);
        }
        let temperature = has_temperature.then(|| {
            scales.push(1.0);
            map.temperature_unit
                .or_else(|| unit_from_name(&name_of(*indices.last().unwrap_or(&0)), TemperatureUnit::parse))
                .unwrap_or(TemperatureUnit::C)
        });
        let names = indices.iter().map(|&i| name_of(i)).collect();
        Ok(ColumnPlan {
            gyro,
            temperature,
            indices,
            scales,
            names,
        })
    }

    /// The time column (0-based).
    pub fn time_column(&self) -> usize {
        self.indices[0]
    }

    /// The acceleration's x, y, z columns (0-based).
    pub fn accel_columns(&self) -> [usize; 3] {
        [self.indices[1], self.indices[2], self.indices[3]]
    }

    /// The rate's x, y, z columns (0-based), when the table has them.
    pub fn gyro_columns(&self) -> Option<[usize; 3]> {
        self.gyro
            .then(|| [self.indices[4], self.indices[5], self.indices[6]])
    }

    /// The temperature column (0-based) and its unit, when the table has one.
    pub fn temperature_column(&self) -> Option<(usize, TemperatureUnit)> {
        self.temperature
            .map(|unit| (self.indices[self.indices.len() - 1], unit))
    }

    /// Every column used, in the order above.
    pub fn used_columns(&self) -> &[usize] {
        &self.indices
    }

    /// The names of the columns used, in the order above (`column N` where the table has no
    /// header).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Multiply the time column by this to get s.
    pub fn time_to_s(&self) -> f64 {
        self.scales[0]
    }

    /// Multiply the acceleration columns by this to get m/s².
    pub fn accel_to_mps2(&self) -> f64 {
        self.scales[1]
    }

    /// Multiply the rate columns by this to get rad/s, when the table has them.
    pub fn gyro_to_radps(&self) -> Option<f64> {
        self.gyro.then(|| self.scales[4])
    }

    /// (file column, factor) of each output column.
    fn targets(&self) -> Vec<(usize, f64)> {
        self.indices
            .iter()
            .copied()
            .zip(self.scales.iter().copied())
            .collect()
    }
}

/// The file columns of t, ax, ay, az[, gx, gy, gz][, temperature], whether the gyro is among them,
/// and whether the temperature is.
fn resolve_columns(
    header: &[String],
    n_columns: usize,
    file: &str,
    map: &ColumnMap,
) -> Result<(Vec<usize>, bool, bool), RecordingError> {
    let available = || {
        if header.is_empty() {
            format!("{} unnamed", n_columns)
        } else {
            header.join(", ")
        }
    };
    if let Some(keys) = &map.columns {
        let indices = keys
            .iter()
            .map(|k| {
                find_column(header, n_columns, k).ok_or_else(|| RecordingError::NoSuchColumn {
                    file: file.to_string(),
                    key: k.clone(),
                    available: available(),
                })
            })
            .collect::<Result<Vec<usize>, _>>()?;
        let (gyro, temperature) = (indices.len() >= 7, matches!(indices.len(), 5 | 8));
        return Ok((indices, gyro, temperature));
    }
    if header.is_empty() {
        return match n_columns {
            4 => Ok((vec![0, 1, 2, 3], false, false)),
            n if n >= 7 => Ok(((0..7).collect(), true, false)),
            _ => Err(RecordingError::AmbiguousColumns {
                file: file.to_string(),
                available: available(),
            }),
        };
    }
    let names: Vec<String> = TIME_NAMES.iter().map(|s| s.to_string()).collect();
    let time = find_any(header, &names);
    let accel: Option<Vec<usize>> = (0..3).map(|a| find_any(header, &accel_names(a))).collect();
    if let (None, Some(accel)) = (time, &accel) {
        return Err(RecordingError::NoTimeColumn {
            file: file.to_string(),
            available: available(),
            accel: accel
                .iter()
                .map(|&c| header[c].clone())
                .collect::<Vec<_>>()
                .join(","),
        });
    }
    let (Some(time), Some(accel)) = (time, accel) else {
        return Err(RecordingError::AmbiguousColumns {
            file: file.to_string(),
            available: available(),
        });
    };
    let mut indices = vec![time];
    indices.extend(accel);
    let gyro: Option<Vec<usize>> = (0..3).map(|a| find_any(header, &gyro_names(a))).collect();
    let has_gyro = gyro.is_some();
    indices.extend(gyro.into_iter().flatten());
    let temperature = find_any(header, &temperature_names());
    indices.extend(temperature);
    Ok((indices, has_gyro, temperature.is_some()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, map: &ColumnMap) -> Result<Recording, RecordingError> {
        Recording::read_csv(text.as_bytes(), "rec.csv", map)
    }

    #[test]
    fn guesses_columns_and_units_from_header() {
        let r = read(
            "t_ms;ax_g;ay_g;az_g\n0;0;0;1\n10;0.1;0;1\n",
            &ColumnMap::default(),
        )
        .unwrap();
        assert_eq!(r.time_s, [0.0, 0.01]);
        assert!((r.accel_mps2[2][0] - STANDARD_GRAVITY).abs() < 1e-12);
        assert!((r.sample_rate_hz() - 100.0).abs() < 1e-9);
    }

    #[test]
    fn explicit_columns_by_name_and_index() {
        let map = ColumnMap::default().with_columns("4,x,y,z").unwrap();
        let r = read("x y z time\n1 2 3 0\n4 5 6 1\n", &map).unwrap();
        assert_eq!(r.time_s, [0.0, 1.0]);
        assert_eq!(r.accel_mps2[0], [1.0, 4.0]);
        let e = read(
            "x y z time\n1 2 3 0\n",
            &ColumnMap::default().with_columns("t,x,y,z").unwrap(),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "rec.csv: no column 't' (columns: x, y, z, time)");
    }

    #[test]
    fn temperature_column_by_name_unit_or_position() {
        let r = read(
            "t,ax,ay,az,gx,gy,gz,Temperature\n0,0,0,9.8,0,0,0,24.5\n0.01,0,0,9.8,0,0,0,25\n",
            &ColumnMap::default(),
        )
        .unwrap();
        assert_eq!(r.temperature_c, Some(vec![24.5, 25.0]));
        assert!(r.gyro_radps.is_some());
        let r = read(
            "t,ax,ay,az,temp_f\n0,0,0,9.8,212\n0.01,0,0,9.8,32\n",
            &ColumnMap::default(),
        )
        .unwrap();
        assert_eq!(r.temperature_c, Some(vec![100.0, 0.0]));
        let map = ColumnMap::default().with_columns("time,x,y,z,die").unwrap();
        let r = read(
            "time,x,y,z,die\n0,0,0,9.8,300\n1,0,0,9.8,301\n",
            &ColumnMap {
                temperature_unit: Some(TemperatureUnit::K),
                ..map
            },
        )
        .unwrap();
        assert!((r.temperature_c.as_ref().unwrap()[1] - 27.85).abs() < 1e-9);
        assert!(r.gyro_radps.is_none());
        // Written as temp_c and read back.
        let mut out = Vec::new();
        r.write_csv(&mut out, AccelUnit::Mps2).unwrap();
        let back = read(std::str::from_utf8(&out).unwrap(), &ColumnMap::default()).unwrap();
        assert_eq!(back.temperature_c, r.temperature_c);
        // The MPU-6050 register map: −521 counts is 35 °C.
        assert!((TemperatureUnit::Mpu6050Counts.to_celsius(-521.0) - 35.0).abs() < 0.005);
    }

    #[test]
    fn time_going_backwards_names_the_line() {
        let e = read(
            "t,ax,ay,az\n0,0,0,1\n0.02,0,0,1\n0.01,0,0,1\n",
            &ColumnMap::default(),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "rec.csv:4: time goes backwards (0.02 s, then 0.01 s)"
        );
    }

    #[test]
    fn round_trips_through_csv() {
        let r = read(
            "t,ax,ay,az,gx,gy,gz\n0,0.5,0,9.8,0,0,0.1\n0.01,0.25,0,9.7,0,0,0.2\n",
            &ColumnMap::default(),
        )
        .unwrap();
        let mut out = Vec::new();
        r.write_csv(&mut out, AccelUnit::G).unwrap();
        let back = read(std::str::from_utf8(&out).unwrap(), &ColumnMap::default()).unwrap();
        for a in 0..3 {
            for (x, y) in r.accel_mps2[a].iter().zip(&back.accel_mps2[a]) {
                assert!((x - y).abs() < 1e-12);
            }
        }
        assert_eq!(back.gyro_radps, r.gyro_radps);
    }

    /// Parsing with units applied on the way gives what reading the table and then converting gave:
    /// the same bits, and the same first error (a bad cell anywhere before a column problem).
    #[test]
    fn units_applied_while_parsing_match_the_table_route() {
        let map = |columns: Option<&str>| match columns {
            Some(c) => ColumnMap::default().with_columns(c).unwrap(),
            None => ColumnMap::default(),
        };
        let mut long = String::from("t_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp\n");
        for i in 0..40_000 {
            let x = (i as f64 * 0.37).sin();
            long.push_str(&format!(
                "{},{x},{},{},{},{},{},25.5\n",
                i * 10,
                x / 7.0,
                1.0 - x,
                x * 300.0,
                -x,
                x / 3.0
            ));
        }
        let cases: Vec<(String, ColumnMap)> = vec![
            ("t_ms;ax_g;ay_g;az_g\n0;0;0;1\n10;0.1;0;1\n".into(), map(None)),
            (
                "t,ax,ay,az,gx_dps,gy_dps,gz_dps\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n".into(),
                map(None),
            ),
            ("x y z time\n1 2 3 0\n4 5 6 1\n".into(), map(Some("4,x,y,z"))),
            ("t,a\n0,1\n1,2\n".into(), map(Some("t,a,a,a"))),
            ("0,1,2,3\n1,2,3,4\n".into(), map(None)),
            ("0,1,2,3,4,5,6,7\n1,2,3,4,5,6,7,8\n".into(), map(None)),
            ("t,ax,ay,az\n0,1,2,3\n1,x,2,3\n".into(), map(None)),
            ("x y z time\n1 2 3 0\n4 5 q 1\n".into(), map(Some("time,x,y,z"))),
            ("x y z time\n1 2 3 0\n4 5 6 1\n".into(), map(Some("t,x,y,z"))),
            ("t,ax,ay,az\n0,0,0,1\n0.02,0,0,1\n0.01,0,0,1\n".into(), map(None)),
            (long.clone(), map(None)),
            (long.clone(), map(Some("t_ms,temp,ax_g,ax_g"))),
            (long.replace("\n39000,", "\n39000,,"), map(None)),
        ];
        for (text, map) in &cases {
            let table_route = Table::parse(text.as_bytes(), "rec.csv", &map.table)
                .map_err(RecordingError::from)
                .and_then(|t| Recording::from_table(&t, map));
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let parsed = pool.install(|| Recording::parse_csv(text.as_bytes(), "rec.csv", map));
                match (&parsed, &table_route) {
                    (Ok(a), Ok(b)) => {
                        assert_eq!(a, b);
                        let bits = |r: &Recording| {
                            let mut v: Vec<u64> = r.time_s.iter().map(|x| x.to_bits()).collect();
                            for axis in r.accel_mps2.iter().chain(r.gyro_radps.iter().flatten()) {
                                v.extend(axis.iter().map(|x| x.to_bits()));
                            }
                            v
                        };
                        assert_eq!(bits(a), bits(b));
                    }
                    (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                    _ => panic!("{parsed:?} vs {table_route:?}"),
                }
            }
        }
    }
}
