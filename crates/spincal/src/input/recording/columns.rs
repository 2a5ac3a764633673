//! Which columns hold what: the user's column map, the recognised column names, and the plan
//! resolved from a header (columns, units, factors).

use super::time::{settle_unit, unwrap_counter, ImplausibleTime, TimeUnitSource};
use super::units::{AccelUnit, GyroUnit, TemperatureUnit, TimeUnit};
use super::RecordingError;
use crate::input::table::{find_column, TableOptions};

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

/// Reads a unit from a column-name suffix: `ax_g`, `t_ms`, `gx (deg/s)`.
/// The temperature unit a column's name states (`temp_k`, `temperature (°F)`), if any.
pub fn temperature_unit_of_name(name: &str) -> Option<TemperatureUnit> {
    unit_from_name(name, TemperatureUnit::parse)
}

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

/// The map a gyro-only file (a header naming time and three gyro columns, none for acceleration:
/// `t,gx,gy,gz`, `time,gx_dps,…`) is read with: its time and gyro columns in the places of time
/// and acceleration, the gyro's unit from their names unless `map` states it. `map` unchanged
/// for any other header or when it chooses the columns itself.
pub(crate) fn gyro_only_map(header: &[String], map: ColumnMap) -> ColumnMap {
    if map.columns.is_some() || header.is_empty() {
        return map;
    }
    let time_names: Vec<String> = TIME_NAMES.iter().map(|s| s.to_string()).collect();
    let accel = (0..3).any(|a| find_any(header, &accel_names(a)).is_some());
    let gyro: Option<Vec<usize>> = (0..3).map(|a| find_any(header, &gyro_names(a))).collect();
    let (Some(time), Some(gyro), false) = (find_any(header, &time_names), gyro, accel) else {
        return map;
    };
    let named = unit_from_name(&header[gyro[0]], GyroUnit::parse);
    ColumnMap {
        columns: Some(
            std::iter::once(time)
                .chain(gyro)
                .map(|c| (c + 1).to_string())
                .collect(),
        ),
        accel_unit: Some(AccelUnit::Mps2),
        gyro_unit: map.gyro_unit.or(named),
        ..map
    }
}

/// Which columns of a table become time, acceleration, rate and temperature, and each one's
/// factor to SI: the one reading of a header that every entry point shares (whole files, the
/// streaming `correct`, Python's DataFrames).
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnPlan {
    /// File columns of t, ax, ay, az[, gx, gy, gz][, temperature].
    pub(super) indices: Vec<usize>,
    /// Whether gx, gy, gz are among them.
    pub(super) gyro: bool,
    /// The temperature column's unit, when there is one (its factor in `scales` is 1: the
    /// conversion to °C is affine, applied after reading).
    pub(super) temperature: Option<TemperatureUnit>,
    /// Factor to SI of each.
    pub(super) scales: Vec<f64>,
    /// Their names in the file (or `column N`).
    pub(super) names: Vec<String>,
    /// The acceleration's unit and the rate's (when the table has it).
    pub(super) accel_unit: AccelUnit,
    pub(super) gyro_unit: Option<GyroUnit>,
    /// The time column's unit and where it came from (see [`super::time`]).
    pub(super) time_unit: TimeUnit,
    pub(super) time_source: TimeUnitSource,
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
        let named = unit_from_name(&time_name, TimeUnit::parse).or_else(|| {
            NANOSECOND_TIME_NAMES
                .iter()
                .any(|n| time_name.trim().eq_ignore_ascii_case(n))
                .then_some(TimeUnit::Ns)
        });
        let (time_unit, time_source) = match (map.time_unit, named) {
            (Some(unit), _) => (unit, TimeUnitSource::Stated),
            (None, Some(unit)) => (unit, TimeUnitSource::Named),
            (None, None) => (TimeUnit::S, TimeUnitSource::Assumed),
        };
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
        let gyro_unit = gyro.then(|| {
            map.gyro_unit
                .or_else(|| unit_from_name(&name_of(indices[4]), GyroUnit::parse))
                .unwrap_or(GyroUnit::Radps)
        });
        if let Some(unit) = gyro_unit {
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
            accel_unit,
            gyro_unit,
            temperature,
            indices,
            scales,
            names,
            time_unit,
            time_source,
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

    /// The acceleration columns' unit.
    pub fn accel_unit(&self) -> AccelUnit {
        self.accel_unit
    }

    /// The rate columns' unit, when the table has them.
    pub fn gyro_unit(&self) -> Option<GyroUnit> {
        self.gyro_unit
    }

    /// Multiply the rate columns by this to get rad/s, when the table has them.
    pub fn gyro_to_radps(&self) -> Option<f64> {
        self.gyro.then(|| self.scales[4])
    }

    /// (file column, factor) of each output column.
    /// Holds the time column against the rules of [`super::time`], in place: `time` (in the
    /// plan's unit converted to s, time order) unwrapped where a counter wrapped and re-read in the
    /// unit the values show when none was stated. Returns the notes for the user.
    pub fn settle_time(
        &mut self,
        time: &mut [f64],
        file: &str,
        lines: &[usize],
    ) -> Result<Vec<String>, ImplausibleTime> {
        let to_si = self.scales[0];
        let mut notes = Vec::new();
        notes.extend(unwrap_counter(time, to_si, lines));
        let raw: std::borrow::Cow<'_, [f64]> = if to_si == 1.0 {
            std::borrow::Cow::Borrowed(&*time)
        } else {
            std::borrow::Cow::Owned(time.iter().map(|t| t / to_si).collect())
        };
        let settled = settle_unit(&raw, self.time_unit, self.time_source, file, &self.names[0])?;
        if settled.unit != self.time_unit {
            // Only an assumed second is replaced, so the values are the file's own.
            let factor = settled.unit.to_si() / to_si;
            time.iter_mut().for_each(|t| *t *= factor);
            self.time_unit = settled.unit;
            self.scales[0] = settled.unit.to_si();
        }
        notes.extend(settled.note);
        Ok(notes)
    }

    pub(super) fn targets(&self) -> Vec<(usize, f64)> {
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
