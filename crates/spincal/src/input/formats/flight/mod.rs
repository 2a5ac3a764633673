//! Flight-controller logs: PX4's ULog (`.ulg`, behind the `ulog` feature) and ArduPilot's
//! DataFlash (`.bin`, behind the `dataflash` feature). Both are detected by their first bytes
//! whatever the features, so a build without a reader refuses the file by name.
//!
//! A log holds several IMUs (instances); one is read, instance 0 unless
//! [`ReadOptions::topic`](super::ReadOptions::topic) names another (`1`, `sensor_accel_1`,
//! `IMU[1]`). Time counts from the first sample in whole microseconds (the logs' own unit);
//! temperature is the sensor's own, in °C, where the log has it; the accelerometer's device id
//! (what PX4's `TC_An_ID` must equal) is in [`FlightLog::device_id`].

#[cfg(feature = "dataflash")]
mod dataflash;
#[cfg(feature = "ulog")]
mod ulog;

use serde::Serialize;

use super::{Format, FormatError, Loaded, ReadOptions};
use crate::input::recording::{Recording, Source};

/// The first bytes of a ULog file: `ULog`, then 0x01 0x12 0x35 (the format's magic).
pub const ULOG_MAGIC: &[u8; 7] = b"ULog\x01\x12\x35";
/// The first bytes of an ArduPilot DataFlash log: a message header (0xA3 0x95) of type 128, the
/// FMT message that describes FMT itself, always first.
pub const DATAFLASH_MAGIC: &[u8; 3] = &[0xA3, 0x95, 0x80];

/// The flight stack that wrote a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FlightStack {
    Px4,
    ArduPilot,
}

/// What a flight-controller log's reader learned besides the samples.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightLog {
    pub stack: FlightStack,
    /// What the samples came from: `sensor_accel + sensor_gyro`, `sensor_combined` or `IMU`.
    pub source: String,
    /// The IMU instance read.
    pub instance: u8,
    /// Every instance the log holds.
    pub instances: Vec<u8>,
    /// The accelerometer's device id where the log holds one (PX4: `sensor_accel.device_id`, or
    /// `sensor_selection.accel_device_id` beside `sensor_combined`; ArduPilot: its `INS_ACCn_ID`
    /// parameter in a PARM message).
    pub device_id: Option<u32>,
    /// Where [`FlightLog::device_id`] came from, or where to find it when the log has none.
    pub device_id_from: String,
}

/// Everything that can be wrong with a flight-controller log.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FlightError {
    /// The file's bytes do not follow the format at this offset.
    #[error("{file}: byte {offset}: {what}")]
    Corrupt { file: String, offset: u64, what: String },
    /// The log holds no IMU samples that can be read.
    #[error("{file}: {what}")]
    NoImu { file: String, what: String },
    /// The instance asked for is not in the log.
    #[error("{file}: no IMU instance '{asked}' (the log has: {available})")]
    NoInstance {
        file: String,
        asked: String,
        available: String,
    },
    /// A sample holds a value spincal cannot use (NaN or infinite acceleration or rate).
    #[error("{file}: byte {offset} ({what}): {value} is not a finite number")]
    NotFinite {
        file: String,
        offset: u64,
        what: String,
        value: f64,
    },
    #[error("{file}: only {found} IMU samples in {what}; at least 2 are needed")]
    TooFew {
        file: String,
        what: String,
        found: usize,
    },
    /// The reader of this format was left out of the build.
    #[error("{file}: a {what}, and this build of spincal lacks the `{feature}` feature that reads it")]
    NotBuilt {
        file: String,
        what: &'static str,
        feature: &'static str,
    },
}

/// The flight-log format whose magic `head` starts with, and the words for it.
pub(super) fn sniff(head: &[u8]) -> Option<(Format, &'static str)> {
    if head.starts_with(ULOG_MAGIC) {
        Some((Format::Ulog, "ULog magic 'ULog' 01 12 35 at byte 0"))
    } else if head.starts_with(DATAFLASH_MAGIC) {
        Some((Format::DataFlash, "DataFlash FMT message (A3 95 80) at byte 0"))
    } else {
        None
    }
}

/// Reads a ULog or DataFlash log.
pub(super) fn read(
    format: Format,
    bytes: &[u8],
    file: &str,
    options: &ReadOptions,
) -> Result<Loaded, FormatError> {
    let read = read_format(format, bytes, file, options)?;
    let mut loaded = Loaded::new(read.recording, format, false);
    loaded.notes = read.notes;
    loaded.flight = Some(read.log);
    Ok(loaded)
}

/// The reader of `format`, or the feature it needs.
fn read_format(
    format: Format,
    bytes: &[u8],
    file: &str,
    options: &ReadOptions,
) -> Result<FlightRead, FlightError> {
    let _ = (bytes, options);
    match format {
        #[cfg(feature = "ulog")]
        Format::Ulog => ulog::read(bytes, file, options),
        #[cfg(not(feature = "ulog"))]
        Format::Ulog => Err(FlightError::NotBuilt {
            file: file.into(),
            what: "PX4 ULog",
            feature: "ulog",
        }),
        #[cfg(feature = "dataflash")]
        Format::DataFlash => dataflash::read(bytes, file, options),
        #[cfg(not(feature = "dataflash"))]
        Format::DataFlash => Err(FlightError::NotBuilt {
            file: file.into(),
            what: "ArduPilot DataFlash log",
            feature: "dataflash",
        }),
        _ => Err(FlightError::NoImu {
            file: file.into(),
            what: format!("{format} is not a flight-controller log format"),
        }),
    }
}

/// A reader's result.
#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
pub(super) struct FlightRead {
    pub(super) recording: Recording,
    pub(super) log: FlightLog,
    pub(super) notes: Vec<String>,
}

/// One sensor's samples as the log holds them: stamps in µs, values, each message's byte offset.
#[derive(Debug, Default, Clone)]
#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
pub(super) struct Series {
    pub(super) us: Vec<u64>,
    pub(super) v: [Vec<f64>; 3],
    /// °C, one per sample, or empty when the messages carry none.
    pub(super) temperature: Vec<f64>,
    pub(super) offset: Vec<u64>,
}

#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
impl Series {
    pub(super) fn len(&self) -> usize {
        self.us.len()
    }

    /// The samples in time order (stable: equal stamps keep the log's order), with values
    /// `beside` them (a gyro from the same messages) moved alike; whether they had to be sorted.
    pub(super) fn sort_with(&mut self, beside: &mut [Vec<f64>; 3]) -> bool {
        if self.us.windows(2).all(|w| w[0] <= w[1]) {
            return false;
        }
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.sort_by_key(|&k| self.us[k]);
        let pick = |x: &mut Vec<f64>| {
            if !x.is_empty() {
                *x = order.iter().map(|&k| x[k]).collect();
            }
        };
        self.v.iter_mut().chain(beside.iter_mut()).for_each(&pick);
        pick(&mut self.temperature);
        self.us = order.iter().map(|&k| self.us[k]).collect();
        self.offset = order.iter().map(|&k| self.offset[k]).collect();
        true
    }

    /// [`Series::sort_with`] with nothing beside.
    pub(super) fn sort(&mut self) -> bool {
        self.sort_with(&mut Default::default())
    }

    /// The first non-finite value, as an error naming its message.
    pub(super) fn check_finite(&self, file: &str, what: &str) -> Result<(), FlightError> {
        for (axis, values) in self.v.iter().enumerate() {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(FlightError::NotFinite {
                    file: file.into(),
                    offset: self.offset[i],
                    what: format!("{what}, axis {}", ["x", "y", "z"][axis]),
                    value: values[i],
                });
            }
        }
        Ok(())
    }
}

/// Gyro samples onto the accelerometer's stamps: equal stamps taken as they are, others linearly
/// interpolated between the neighbouring gyro samples; accelerometer samples outside the gyro's
/// span are dropped. Both series time-sorted. Returns the kept accelerometer samples' indices and
/// the gyro on them, with counts for a note (equal, interpolated, dropped).
#[cfg_attr(not(feature = "ulog"), allow(dead_code))]
pub(super) fn gyro_on_accel_stamps(
    accel_us: &[u64],
    gyro: &Series,
) -> (Vec<usize>, [Vec<f64>; 3], [usize; 3]) {
    let mut kept = Vec::with_capacity(accel_us.len());
    let mut out: [Vec<f64>; 3] = Default::default();
    let mut counts = [0usize; 3];
    if gyro.us.is_empty() {
        counts[2] = accel_us.len();
        return (kept, out, counts);
    }
    let mut j = 0usize;
    for (i, &t) in accel_us.iter().enumerate() {
        while j + 1 < gyro.us.len() && gyro.us[j + 1] <= t {
            j += 1;
        }
        let w = if gyro.us[j] == t {
            counts[0] += 1;
            [0, 1, 2].map(|k| gyro.v[k][j])
        } else if gyro.us[j] < t && j + 1 < gyro.us.len() {
            counts[1] += 1;
            let f = (t - gyro.us[j]) as f64 / (gyro.us[j + 1] - gyro.us[j]) as f64;
            [0, 1, 2].map(|k| gyro.v[k][j] + f * (gyro.v[k][j + 1] - gyro.v[k][j]))
        } else {
            counts[2] += 1;
            continue;
        };
        kept.push(i);
        for k in 0..3 {
            out[k].push(w[k]);
        }
    }
    (kept, out, counts)
}

/// Seconds from the first stamp: whole microseconds, divided once (exact to the µs).
#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
pub(super) fn seconds_from_first(us: &[u64]) -> Vec<f64> {
    let first = us.first().copied().unwrap_or(0);
    us.iter().map(|&t| t.saturating_sub(first) as f64 / 1e6).collect()
}

/// The recording of accelerometer samples (kept ones), a gyro on them and a temperature.
#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
pub(super) fn recording(
    file: &str,
    us: &[u64],
    accel: [Vec<f64>; 3],
    gyro: Option<[Vec<f64>; 3]>,
    temperature: Option<Vec<f64>>,
    columns: Vec<String>,
    metadata: Vec<String>,
) -> Recording {
    Recording {
        time_s: seconds_from_first(us),
        accel_mps2: accel,
        gyro_radps: gyro,
        temperature_c: temperature,
        source: Source {
            name: file.into(),
            format: String::new(),
            columns,
            metadata,
            lines: Vec::new(),
            incomplete_rows: Default::default(),
            time_notes: Vec::new(),
        },
    }
}

/// What `topic` asks for: an optional name and an optional instance (`1`, `name`, `name[1]`,
/// `name_1`).
#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
pub(super) fn parse_topic(topic: &str) -> (Option<&str>, Option<u8>) {
    let topic = topic.trim();
    if let Ok(n) = topic.parse::<u8>() {
        return (None, Some(n));
    }
    if let Some(inner) = topic.strip_suffix(']') {
        if let Some((name, n)) = inner.split_once('[') {
            if let Ok(n) = n.trim().parse::<u8>() {
                return (Some(name.trim()), Some(n));
            }
        }
    }
    if let Some((name, n)) = topic.rsplit_once('_') {
        if let Ok(n) = n.parse::<u8>() {
            return (Some(name), Some(n));
        }
    }
    (Some(topic), None)
}

/// Temperature kept only when every sample has a finite one; otherwise left out with a note.
#[cfg_attr(not(any(feature = "ulog", feature = "dataflash")), allow(dead_code))]
pub(super) fn finite_temperature(values: Vec<f64>, what: &str, notes: &mut Vec<String>) -> Option<Vec<f64>> {
    let bad = values.iter().filter(|v| !v.is_finite()).count();
    if values.is_empty() {
        None
    } else if bad == 0 {
        Some(values)
    } else {
        notes.push(format!(
            "temperature left out: {what} is not a finite number in {bad} of {} samples (the driver reports none)",
            values.len()
        ));
        None
    }
}

#[cfg(test)]
mod tests;
