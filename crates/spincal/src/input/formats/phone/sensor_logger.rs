//! Sensor Logger (Kelvin Choi's app): its zip export or the unzipped folder, one CSV per sensor
//! plus `Metadata.csv`.
//!
//! The rules are from the app's documentation (the awesome-sensor-logger repository: README.md
//! "Understanding Timestamps" and "Accessing Recording Metadata", UNITS.md, CROSSPLATFORM.md,
//! COORDINATES.md); where it is silent this file says so.

use super::super::{Format, FormatError, Loaded, ReadOptions};
use super::pair::merge;
use super::text::{Members, PhoneCsv, Stream};
use super::PhoneError;
use crate::input::recording::STANDARD_GRAVITY;

/// The accelerometer files that include gravity, in the order they are preferred on Android.
/// UNITS.md: `TotalAcceleration.csv` "measures acceleration _with_ gravity included (raw
/// accelerometer readings)"; `AccelerometerUncalibrated.csv` is the raw stream (README "When to
/// Use Uncalibrated Data"). On iOS the uncalibrated file is preferred: UNITS.md says iOS logs only
/// `Accelerometer.csv` among the calibrated ones, so a `TotalAcceleration.csv` there is not documented.
pub(crate) const ACCEL_FILES: [&str; 2] = ["TotalAcceleration.csv", "AccelerometerUncalibrated.csv"];
/// UNITS.md: `Accelerometer.csv` "measures acceleration _without_ gravity (user-induced motion only)".
pub(crate) const GRAVITY_REMOVED: &str = "Accelerometer.csv";
/// The rotation rate: `Gyroscope.csv` (calibrated, always logged) or the raw
/// `GyroscopeUncalibrated.csv`, both in rad/s (UNITS.md).
pub(crate) const GYRO_FILES: [&str; 2] = ["Gyroscope.csv", "GyroscopeUncalibrated.csv"];

/// Every sensor file's header starts `time,seconds_elapsed`, then the axes by name: the app
/// writes `z,y,x` (README's JSON example; the same order in the CSV), so columns are found by name.
const TIME: &str = "time";
const ELAPSED: &str = "seconds_elapsed";

/// What Metadata.csv says, as far as the readings depend on it.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct Metadata {
    /// `platform`: `ios` or `android`, lowercase (README "Accessing Recording Metadata").
    pub(crate) platform: Option<String>,
    /// `standardisation`: whether "Standardise Units & Frames" was on (same section); older
    /// recordings lack the column.
    pub(crate) standardised: Option<bool>,
}

impl Metadata {
    /// Metadata.csv: a header row and one row of values, "read the file by header name rather than
    /// by column position" (README).
    pub(crate) fn read(bytes: &[u8]) -> Metadata {
        let text = String::from_utf8_lossy(bytes);
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = split_quoted(lines.next().unwrap_or(""));
        let values = split_quoted(lines.next().unwrap_or(""));
        let get = |key: &str| {
            header
                .iter()
                .position(|h| h.eq_ignore_ascii_case(key))
                .and_then(|i| values.get(i))
                .map(|v| v.trim().to_ascii_lowercase())
        };
        Metadata {
            platform: get("platform"),
            standardised: get("standardisation").map(|v| v == "true"),
        }
    }

    fn ios(&self) -> bool {
        self.platform.as_deref() == Some("ios")
    }

    /// Whether iOS's own conventions apply: iOS with "Standardise Units & Frames" off, the default
    /// (CROSSPLATFORM.md: "by default, it is off"; with it on, iOS values "conform to Android
    /// conventions"). A recording without the `standardisation` column is taken to be at the default.
    fn ios_conventions(&self) -> bool {
        self.ios() && self.standardised != Some(true)
    }
}

/// Splits one CSV line on commas outside double quotes.
fn split_quoted(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    for ch in line.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            c => out.last_mut().map_or((), |s| s.push(c)),
        }
    }
    out.into_iter().map(|s| s.trim().to_string()).collect()
}

/// Whether an export's files are Sensor Logger's (its Metadata.csv, or a sensor file with its
/// `time,seconds_elapsed` header).
#[cfg(feature = "phone")]
pub(crate) fn claims(members: &Members) -> bool {
    members.get("Metadata.csv").is_some()
        || ACCEL_FILES
            .iter()
            .chain(GYRO_FILES.iter())
            .chain([&GRAVITY_REMOVED])
            .filter_map(|f| members.get(f))
            .any(|b| is_sensor_file(&PhoneCsv::new(b, "").header))
}

/// The files that say an export is Sensor Logger's, for the detection's reason.
#[cfg(feature = "phone")]
pub(crate) fn evidence(members: &Members) -> String {
    let names: Vec<&str> = members
        .names()
        .filter(|n| {
            *n == "Metadata.csv" || ACCEL_FILES.contains(n) || GYRO_FILES.contains(n) || *n == GRAVITY_REMOVED
        })
        .collect();
    names.join(", ")
}

/// A header of Sensor Logger's sensor files: `time`, `seconds_elapsed`, then `x`, `y`, `z` in any order.
pub(crate) fn is_sensor_file(header: &[String]) -> bool {
    header.len() >= 5
        && header[0].eq_ignore_ascii_case(TIME)
        && header[1].eq_ignore_ascii_case(ELAPSED)
        && ["x", "y", "z"]
            .iter()
            .all(|a| header.iter().any(|h| h.eq_ignore_ascii_case(a)))
}

/// One sensor file's stream: times relative to `epoch_ns` (the accelerometer's first `time`), the
/// axes scaled by `to_si`. `time` is "the UNIX epoch timestamp of the measurement as reported by the
/// sensors in nanoseconds" (README "Understanding Timestamps"): about 1.7·10¹⁸, where an f64 steps
/// by 256 ns, so the difference is taken in integers and only then converted.
fn stream(csv: &PhoneCsv, to_si: f64, epoch_ns: Option<i64>) -> Result<(Stream, i64), FormatError> {
    let column = |name: &str| {
        csv.column(&[name]).ok_or_else(|| FormatError::MissingColumn {
            file: csv.file.clone(),
            name: name.into(),
            available: csv.columns_text(),
        })
    };
    let time = column(TIME)?;
    let mut s = csv.stream([time, column("x")?, column("y")?, column("z")?], 1.0, to_si)?;
    let text = String::from_utf8_lossy(&csv.text);
    let lines: Vec<&str> = text.lines().collect();
    let mut stamps = Vec::with_capacity(s.len());
    for &line in &s.lines {
        let field = lines
            .get(line - 1)
            .and_then(|l| l.split(csv.delimiter.as_char()).nth(time))
            .map(|f| f.trim().trim_matches('"'))
            .unwrap_or("");
        let ns = field.parse::<i64>().map_err(|_| PhoneError::BadEpoch {
            file: csv.file.clone(),
            line,
            text: field.into(),
        })?;
        stamps.push(ns);
    }
    let t0 = epoch_ns.or(stamps.first().copied()).unwrap_or(0);
    s.time_s = stamps
        .iter()
        .map(|&ns| (i128::from(ns) - i128::from(t0)) as f64 * 1e-9)
        .collect();
    Ok((s, t0))
}

/// Reads a Sensor Logger export: the accelerometer with gravity and the gyroscope, on the
/// accelerometer's time base (one clock: both `time` columns are epoch nanoseconds).
pub(crate) fn read(members: &Members, file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let _ = options;
    let meta = members
        .get("Metadata.csv")
        .map(Metadata::read)
        .unwrap_or_default();
    let mut notes = Vec::new();
    let order: [&str; 2] = if meta.ios() {
        [ACCEL_FILES[1], ACCEL_FILES[0]]
    } else {
        ACCEL_FILES
    };
    let Some((accel_name, accel_bytes)) = order.iter().find_map(|n| members.get(n).map(|b| (*n, b))) else {
        if members.get(GRAVITY_REMOVED).is_some() {
            return Err(gravity_removed(&members.display(GRAVITY_REMOVED)).into());
        }
        return Err(PhoneError::NoAccelerometer {
            file: file.into(),
            found: members.listing(),
            hint:
                "Sensor Logger's TotalAcceleration.csv (Android) or AccelerometerUncalibrated.csv is needed",
        }
        .into());
    };
    let (factor, why) = accel_convention(accel_name, &meta);
    notes.extend(why);
    let accel_csv = PhoneCsv::new(accel_bytes, &members.display(accel_name));
    let (accel, t0) = stream(&accel_csv, factor, None)?;
    let gyro = match GYRO_FILES.iter().find_map(|n| members.get(n).map(|b| (*n, b))) {
        // CROSSPLATFORM.md "Rotation Rate": iOS and Android report the same sign convention, and
        // "Standardise Units & Frames" has no effect; rad/s on both (UNITS.md).
        Some((name, bytes)) => {
            if meta.ios() && name == GYRO_FILES[0] {
                // Not confirmed: the documentation does not say which Core Motion rate the
                // calibrated iOS gyroscope is; the uncalibrated one is "the raw stream".
                notes.push("iOS Gyroscope.csv: Sensor Logger's docs do not say whether it is the raw gyroscope or Core Motion's bias-corrected rate; GyroscopeUncalibrated.csv is the raw one".into());
            }
            let csv = PhoneCsv::new(bytes, &members.display(name));
            Some(stream(&csv, 1.0, Some(t0))?.0)
        }
        None => None,
    };
    if meta.platform.is_none() {
        notes.push("no platform in Metadata.csv: Android's units and signs assumed".into());
    }
    notes.push(format!(
        "time: `time` (epoch ns) − its first value {t0} ns, exact in integers"
    ));
    merge(accel, gyro, file, Format::SensorLogger, notes)
}

/// The factor from an accelerometer file to m/s² in spincal's (Android's) sign convention, and
/// what it assumed.
fn accel_convention(name: &str, meta: &Metadata) -> (f64, Option<String>) {
    if !meta.ios_conventions() {
        return (1.0, None);
    }
    // COORDINATES.md: "there is a negative sign difference for all three axes between iOS and
    // Android"; CROSSPLATFORM.md: "The same applies to the uncalibrated acceleration".
    if name == ACCEL_FILES[1] {
        // UNITS.md "Accelerometer Uncalibrated": on iOS "in standard gravity (g), when
        // 'Standardise Units & Frames' is off (default)".
        (
            -STANDARD_GRAVITY,
            Some("iOS uncalibrated accelerometer: g with iOS's sign, turned into m/s² (× −9.80665)".into()),
        )
    } else {
        // Not documented: UNITS.md lists no TotalAcceleration.csv for iOS; the acceleration sign
        // rule of COORDINATES.md is applied, in m/s² as for every calibrated acceleration.
        (
            -1.0,
            Some("iOS TotalAcceleration.csv (not in Sensor Logger's docs for iOS): iOS's sign turned into Android's (× −1)".into()),
        )
    }
}

fn gravity_removed(file: &str) -> PhoneError {
    PhoneError::GravityRemoved {
        file: file.into(),
        app: "Sensor Logger",
        channel: "Accelerometer.csv".into(),
        instead: "TotalAcceleration.csv (Android) or AccelerometerUncalibrated.csv (turn on the uncalibrated accelerometer in Sensor Logger's settings)",
    }
}

/// One Sensor Logger CSV on its own (outside its zip or folder): an accelerometer with gravity,
/// named by its file name; without Metadata.csv its platform is unknown and Android's
/// conventions are assumed.
pub(crate) fn read_csv(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let base = file.rsplit(['/', '\\']).next().unwrap_or(file);
    if base.eq_ignore_ascii_case(GRAVITY_REMOVED) {
        return Err(gravity_removed(file).into());
    }
    if GYRO_FILES.iter().any(|g| base.eq_ignore_ascii_case(g)) {
        return Err(PhoneError::NoAccelerometer {
            file: file.into(),
            found: "a gyroscope file".into(),
            hint: "read the recording's zip or folder, which holds the accelerometer too",
        }
        .into());
    }
    let name = ACCEL_FILES
        .iter()
        .find(|n| base.eq_ignore_ascii_case(n))
        .copied()
        .unwrap_or(ACCEL_FILES[0]);
    let members = Members {
        source: file.into(),
        entries: vec![(name.to_string(), bytes.to_vec())],
        alone: Some(file.into()),
    };
    read(&members, file, options)
}
