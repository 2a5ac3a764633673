//! phyphox (RWTH Aachen): its CSV, its zip (one CSV per export set plus `meta/device.csv` and
//! `meta/time.csv`) and its workbook (one sheet per set plus "Metadata Device" and "Metadata
//! Time", turned into the same members by `excel.rs`).
//!
//! Every rule below is from phyphox's sources; the header names are the `<data name=…>` of the
//! experiments' export sets.

use super::super::{Format, FormatError, Loaded, ReadOptions};
use super::pair::merge;
use super::text::{Members, PhoneCsv, Stream};
use super::PhoneError;

/// What one export set holds, read from its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SetKind {
    /// Acceleration with g, Android's names (`"Acceleration x (m/s^2)"`).
    Accelerometer,
    /// Acceleration with g, iOS's simple experiment (`"X (m/s^2)"`).
    AccelerometerIos,
    /// Rotation rate, Android's names (`"Gyroscope x (rad/s)"`), also the built-in Gyroscope
    /// experiment on either platform.
    Gyroscope,
    /// Rotation rate, iOS's simple experiment (`"X (rad/s)"`).
    GyroscopeIos,
    /// Gravity removed: `"Linear Acceleration x (m/s^2)"`, or iOS's "Linear Accelerometer" set.
    LinearAcceleration,
    /// The built-in "Centripetal acceleration" experiment's `"Angular velocity (rad/s)"` and
    /// `"Acceleration (m/s^2)"` magnitudes.
    Centripetal,
    /// Anything else (location, magnetometer, …), ignored.
    Other,
}

// Android simple experiments (phyphox-android SimpleExperimentCreator.java, writeExportDefinitions)
// and the built-in "Acceleration with g", "Gyroscope" and "Acceleration (without g)" experiments
// (phyphox-experiments accelerometer.phyphox, gyroscope.phyphox, linear_accelerometer.phyphox).
const ANDROID_ACCEL: [&str; 3] = [
    "Acceleration x (m/s^2)",
    "Acceleration y (m/s^2)",
    "Acceleration z (m/s^2)",
];
const ANDROID_GYRO: [&str; 3] = [
    "Gyroscope x (rad/s)",
    "Gyroscope y (rad/s)",
    "Gyroscope z (rad/s)",
];
const ANDROID_LINEAR: &str = "Linear Acceleration x (m/s^2)";
// iOS simple experiments (phyphox-ios SimpleExperimentTemplete.swift, getExports): sets
// "Accelerometer", "Gyroscope" and "Linear Accelerometer" with columns "X (m/s^2)" … or "X (rad/s)".
const IOS_ACCEL: [&str; 3] = ["X (m/s^2)", "Y (m/s^2)", "Z (m/s^2)"];
const IOS_GYRO: [&str; 3] = ["X (rad/s)", "Y (rad/s)", "Z (rad/s)"];
const IOS_LINEAR_SET: &str = "Linear Accelerometer";
// The built-in "Centripetal acceleration" experiment (phyphox-experiments
// centripetal_acceleration.phyphox: linear_acceleration and gyroscope at rate="2" average="true",
// exported as set "Data").
const CENTRIPETAL: [&str; 2] = ["Angular velocity (rad/s)", "Acceleration (m/s^2)"];
// Every set's first column (all the export definitions above).
const TIME: &str = "Time (s)";

/// The set's kind from its name (the file name without `.csv`, or the sheet's name) and header.
pub(crate) fn classify(set: &str, header: &[String]) -> SetKind {
    let has = |name: &str| header.iter().any(|h| h.eq_ignore_ascii_case(name));
    if has(ANDROID_LINEAR) || (set.eq_ignore_ascii_case(IOS_LINEAR_SET) && has(IOS_ACCEL[0])) {
        SetKind::LinearAcceleration
    } else if ANDROID_ACCEL.iter().all(|n| has(n)) {
        SetKind::Accelerometer
    } else if ANDROID_GYRO.iter().all(|n| has(n)) {
        SetKind::Gyroscope
    } else if IOS_ACCEL.iter().all(|n| has(n)) {
        SetKind::AccelerometerIos
    } else if IOS_GYRO.iter().all(|n| has(n)) {
        SetKind::GyroscopeIos
    } else if CENTRIPETAL.iter().all(|n| has(n)) {
        SetKind::Centripetal
    } else {
        SetKind::Other
    }
}

/// Reads one set's stream. phyphox writes SI units (m/s², rad/s, s) and Android's sign
/// convention on both platforms: the iOS app multiplies Core Motion's accelerometer (in g, the
/// opposite sign) by −9.81 (phyphox-ios ExperimentSensorInput.swift, `kG = -9.81`).
fn stream(csv: &PhoneCsv, kind: SetKind) -> Result<Stream, FormatError> {
    let names: [&str; 3] = match kind {
        SetKind::Accelerometer => ANDROID_ACCEL,
        SetKind::Gyroscope => ANDROID_GYRO,
        SetKind::AccelerometerIos => IOS_ACCEL,
        _ => IOS_GYRO,
    };
    let column = |name: &str| {
        csv.column(&[name]).ok_or_else(|| FormatError::MissingColumn {
            file: csv.file.clone(),
            name: name.into(),
            available: csv.columns_text(),
        })
    };
    let columns = [
        column(TIME)?,
        column(names[0])?,
        column(names[1])?,
        column(names[2])?,
    ];
    csv.stream(columns, 1.0, 1.0)
}

/// The refusal for a set that cannot calibrate anything, if it is one.
fn refusal(file: &str, set: &str, kind: SetKind, ios: bool) -> Option<PhoneError> {
    match kind {
        SetKind::LinearAcceleration => Some(PhoneError::GravityRemoved {
            file: file.into(),
            app: "phyphox",
            channel: format!("\"{set}\" set"),
            instead: "the \"Acceleration with g\" experiment, or the Accelerometer sensor of a simple experiment",
        }),
        SetKind::Centripetal => Some(PhoneError::Centripetal { file: file.into() }),
        // phyphox's iOS gyroscope input is CMDeviceMotion.rotationRate (phyphox-ios
        // ExperimentSensorInput.swift, case .gyroscope); Apple's CMGyroData documentation calls
        // CMDeviceMotion's rate the one "whose bias has been removed by Core Motion algorithms".
        SetKind::Gyroscope | SetKind::GyroscopeIos if ios => Some(PhoneError::FusedRotationRate {
            file: file.into(),
            what: "phyphox's iOS gyroscope",
            instead: "calibrate the accelerometer from an export without the gyroscope set, or record the raw gyroscope with Sensor Logger's Gyroscope Uncalibrated",
        }),
        _ => None,
    }
}

/// One phyphox CSV (a single set, as the CSV export writes it outside a zip).
pub(crate) fn read_csv(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let csv = PhoneCsv::new(bytes, file);
    let set = set_name(file);
    let kind = classify(&set, &csv.header);
    if let Some(refused) = refusal(file, &set, kind, false) {
        return Err(refused.into());
    }
    let mut notes = Vec::new();
    if csv.decimal_comma {
        notes.push("decimal comma converted".to_string());
    }
    let (accel, gyro) = match kind {
        SetKind::Accelerometer | SetKind::AccelerometerIos => (stream(&csv, kind)?, None),
        SetKind::Gyroscope | SetKind::GyroscopeIos => {
            return Err(PhoneError::NoAccelerometer {
                file: file.into(),
                found: "a gyroscope set".into(),
                hint: "read it beside its session's accelerometer (the zip of a simple experiment with both sensors)",
            }
            .into())
        }
        // Any other phyphox-like CSV: the generic column rules, as before this reader existed.
        _ => return read_generic(&csv, file, options),
    };
    merge(accel, gyro, file, Format::Phyphox, notes)
}

/// A phyphox-looking CSV with columns of other names: the generic column rules on the
/// normalised text (separator and decimal comma as phyphox writes them).
fn read_generic(csv: &PhoneCsv, file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    use crate::input::recording::Recording;
    let mut map = options.columns.clone();
    map.table.delimiter = Some(map.table.delimiter.unwrap_or(csv.delimiter));
    let recording = Recording::parse_csv_timed(&csv.text, file, &map, options.sample_rate_hz)?;
    let mut l = Loaded::new(recording, Format::Phyphox, false);
    if csv.decimal_comma {
        l.notes.push("decimal comma converted".into());
    }
    Ok(l)
}

/// A set's name from its file name: `dir/Accelerometer.csv` → `Accelerometer`.
fn set_name(file: &str) -> String {
    let base = file.rsplit(['/', '\\']).next().unwrap_or(file);
    base.strip_suffix(".csv").unwrap_or(base).to_string()
}

/// The sets of an export that spincal uses, with the refusal of any that must not be used.
pub(crate) struct Sets {
    pub(crate) accel: Option<Stream>,
    pub(crate) gyro: Option<Stream>,
    /// Whether the export came from phyphox's iOS app (meta/device.csv, or iOS's column names).
    pub(crate) ios: bool,
    pub(crate) decimal_comma: bool,
    /// Every set's name and kind, for messages.
    pub(crate) seen: Vec<(String, SetKind)>,
}

/// Reads the sets of a zip or workbook. A gravity-removed or centripetal set is refused only when
/// no accelerometer with gravity is there to use instead; an iOS gyroscope is always refused.
pub(crate) fn sets(members: &Members) -> Result<Sets, FormatError> {
    let ios = device(members).is_some_and(|d| d.brand.eq_ignore_ascii_case("Apple"));
    let mut out = Sets {
        accel: None,
        gyro: None,
        ios,
        decimal_comma: false,
        seen: Vec::new(),
    };
    let mut refused = None;
    for (name, bytes) in &members.entries {
        if name.starts_with("meta/") || !name.to_ascii_lowercase().ends_with(".csv") {
            continue;
        }
        let file = members.display(name);
        let csv = PhoneCsv::new(bytes, &file);
        let set = set_name(name);
        let kind = classify(&set, &csv.header);
        out.seen.push((set.clone(), kind));
        let ios_set = ios || matches!(kind, SetKind::AccelerometerIos | SetKind::GyroscopeIos);
        match kind {
            SetKind::Accelerometer | SetKind::AccelerometerIos if out.accel.is_none() => {
                out.decimal_comma |= csv.decimal_comma;
                out.accel = Some(stream(&csv, kind)?);
            }
            SetKind::Gyroscope | SetKind::GyroscopeIos if ios_set => {
                if let Some(refused) = refusal(&file, &set, kind, true) {
                    return Err(refused.into());
                }
            }
            SetKind::Gyroscope | SetKind::GyroscopeIos if out.gyro.is_none() => {
                out.gyro = Some(stream(&csv, kind)?);
            }
            SetKind::LinearAcceleration | SetKind::Centripetal => {
                refused = refused.or(refusal(&file, &set, kind, ios));
            }
            _ => {}
        }
    }
    if out.accel.is_none() {
        if let Some(r) = refused {
            return Err(r.into());
        }
    }
    Ok(out)
}

/// The zip's (or workbook's) phyphox evidence, for the detection's reason.
#[cfg(feature = "phone")]
pub(crate) fn evidence(members: &Members) -> String {
    let sets: Vec<&str> = members.names().filter(|n| !n.starts_with("meta/")).collect();
    let meta: Vec<&str> = members.names().filter(|n| n.starts_with("meta/")).collect();
    format!(
        "{} with {}",
        sets.join(", "),
        if meta.is_empty() {
            "no meta/".into()
        } else {
            meta.join(", ")
        }
    )
}

/// Reads a phyphox zip's (or workbook's) members: the accelerometer, and the gyroscope of the same
/// experiment when there is one, merged on the accelerometer's time base.
pub(crate) fn read_members(
    members: &Members,
    file: &str,
    options: &ReadOptions,
) -> Result<Loaded, FormatError> {
    let _ = options;
    let sets = sets(members)?;
    let Some(accel) = sets.accel else {
        let found = if sets.seen.is_empty() {
            members.listing()
        } else {
            sets.seen
                .iter()
                .map(|(n, k)| format!("{n} ({k:?})"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        return Err(PhoneError::NoAccelerometer {
            file: file.into(),
            found,
            hint: "export the \"Acceleration with g\" experiment or a simple experiment with the Accelerometer (a gyroscope-only export pairs with its session's accelerometer export)",
        }
        .into());
    };
    let mut notes = Vec::new();
    if sets.decimal_comma {
        notes.push("decimal comma converted".to_string());
    }
    if sets.ios {
        notes.push("phyphox iOS: its accelerometer is Core Motion's, in g, times −9.81 (phyphox's g, not standard gravity 9.80665)".into());
    }
    merge(accel, sets.gyro, file, Format::PhyphoxZip, notes)
}

/// What meta/device.csv says (the parts spincal uses).
pub(crate) struct Device {
    /// `deviceBrand`: "Apple" on iOS (phyphox-ios Metadata.swift).
    pub(crate) brand: String,
}

/// Reads meta/device.csv: `"property","value"` rows (phyphox DataExport.java / ExperimentExport.swift).
pub(crate) fn device(members: &Members) -> Option<Device> {
    let bytes = members.get("meta/device.csv")?;
    let csv = PhoneCsv::new(bytes, "meta/device.csv");
    let text = String::from_utf8_lossy(&csv.text);
    let brand = text.lines().find_map(|line| {
        let mut fields = line
            .split(csv.delimiter.as_char())
            .map(|f| f.trim().trim_matches('"'));
        (fields.next() == Some("deviceBrand")).then(|| fields.next().unwrap_or("").to_string())
    })?;
    Some(Device { brand })
}

/// One row of meta/time.csv: an event (`START`, `PAUSE`) at an experiment time and a system time.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TimeMapping {
    pub(crate) event: String,
    pub(crate) experiment_s: f64,
    /// Unix time, s (phyphox writes milliseconds / 1000).
    pub(crate) system_s: f64,
}

/// meta/time.csv: `"event","experiment time","system time","system time text"`, one row per START
/// and PAUSE (phyphox-android DataExport.java and ExperimentTimeReference.java; phyphox-ios
/// ExperimentExport.swift), in the export's separator and decimal mark.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TimeReference {
    pub(crate) file: String,
    pub(crate) mappings: Vec<TimeMapping>,
}

impl TimeReference {
    pub(crate) fn read(members: &Members) -> Result<Option<TimeReference>, FormatError> {
        let Some(bytes) = members.get("meta/time.csv") else {
            return Ok(None);
        };
        let file = members.display("meta/time.csv");
        let csv = PhoneCsv::new(bytes, &file);
        let text = String::from_utf8_lossy(&csv.text).into_owned();
        let mut mappings = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let fields: Vec<&str> = line
                .split(csv.delimiter.as_char())
                .map(|f| f.trim().trim_matches('"'))
                .collect();
            if i == 0 || line.trim().is_empty() {
                continue;
            }
            let number = |k: usize| {
                fields
                    .get(k)
                    .and_then(|f| f.parse::<f64>().ok())
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| PhoneError::Metadata {
                        file: file.clone(),
                        line: i + 1,
                        why: format!(
                            "column {} ('{}') is not a number",
                            k + 1,
                            fields.get(k).copied().unwrap_or("")
                        ),
                    })
            };
            mappings.push(TimeMapping {
                event: fields[0].to_string(),
                experiment_s: number(1)?,
                system_s: number(2)?,
            });
        }
        if !mappings.iter().any(|m| m.event == "START") {
            return Err(PhoneError::Metadata {
                file,
                line: 1,
                why: "no START event".into(),
            }
            .into());
        }
        Ok(Some(TimeReference { file, mappings }))
    }

    /// The running stretches: (experiment time at START, system time at START, system time at
    /// the following PAUSE or +∞). Experiment time stands still while paused
    /// (ExperimentTimeReference.getExperimentTimeFromEvent).
    fn segments(&self) -> Vec<(f64, f64, f64)> {
        let mut out = Vec::new();
        for (i, m) in self.mappings.iter().enumerate() {
            if m.event != "START" {
                continue;
            }
            let end = self.mappings[i + 1..]
                .iter()
                .find(|n| n.event == "PAUSE")
                .map_or(f64::INFINITY, |n| n.system_s);
            out.push((m.experiment_s, m.system_s, end));
        }
        out
    }

    /// Unix time of an experiment time.
    pub(crate) fn unix_time_of(&self, t: f64) -> f64 {
        let segments = self.segments();
        let (e, s, _) = segments
            .iter()
            .rev()
            .find(|(e, _, _)| *e <= t)
            .or(segments.first())
            .copied()
            .unwrap_or((0.0, 0.0, 0.0));
        s + (t - e)
    }

    /// The experiment time of a Unix time, when the experiment was running then.
    pub(crate) fn experiment_time_at(&self, s: f64) -> Option<f64> {
        self.segments()
            .into_iter()
            .find(|&(_, start, end)| start <= s && s <= end)
            .map(|(e, start, _)| e + (s - start))
    }
}
