//! Readers for the formats IMU users log, chosen by [`Format`] or detected from the first bytes.
//!
//! Every reader returns a [`Loaded`]: the [`Recording`] plus what the reader learned (format and why
//! it was chosen, whether the accelerometer values are still raw counts, section labels, 3DM-GX1
//! stream faults). Raw-count formats keep counts in `accel_mps2` unless a scale is given
//! ([`ReadOptions::accel_scale`]); [`Loaded::raw_counts`] says which.

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

// The ROS bag readers (and the SQLite and compressors they need) with the `bags` feature;
// without it a bag is still detected, and refused.
#[cfg(feature = "bags")]
pub mod bag;
pub mod bag_detect;
mod detect;
// Flight-controller logs: PX4 ULog (`ulog` feature), ArduPilot DataFlash (`dataflash` feature);
// both detected and refused by name without their feature.
pub mod flight;
pub mod gx1;
pub mod mat;
pub mod phone;
mod shared;
pub mod streamed;
mod text;

use std::path::Path;

use serde::Serialize;

use crate::input::recording::{ColumnMap, Recording, RecordingError};
use crate::input::table::TableError;

use shared::{check_options, finish, read_mat, table_options};
pub(crate) use text::whitespace_map;
use text::{read_imucal, read_mpu6050, read_whitespace, RAW_COUNTS_MPS2};

pub use detect::{delimited_text_format, detect, Detection, DETECT_BYTES};
use gx1::{Gx1Error, Gx1Options, Gx1Report};
pub use shared::read_table;
pub use text::IMUCAL_SAMPLE_RATE_HZ;

/// The file formats spincal reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Format {
    /// Delimited text with a header naming time and acceleration columns (spincal's own files).
    Csv,
    /// imu_tk's whitespace-separated `t ax ay az` rows, no header.
    Whitespace,
    /// imucal's CSV with a text `part` column labelling sections, raw counts, a `samples` index.
    Imucal,
    /// MPU-6050 logger CSV: metadata lines (`Fs,100`), header `ax,ay,az,gx,gy,gz`, int16 counts.
    Mpu6050,
    /// phyphox's CSV export (`"Time (s)","Acceleration x (m/s^2)"`, …), any separator, decimal comma.
    Phyphox,
    /// Microstrain 3DM-GX1 binary serial stream.
    Gx1,
    /// MATLAB v5 MAT-file: numeric variables become columns (see [`mat`]).
    Mat,
    /// ROS bag: ROS 2 (MCAP or sqlite3 storage, file or bag directory) or ROS 1 (format 2.0);
    /// `sensor_msgs/Imu` or `geometry_msgs/Vector3Stamped` accelerometer (+ gyro) topics.
    RosBag,
    /// phyphox's zip export: one CSV per sensor (Android's or iOS's column names) with `meta/`;
    /// accelerometer and gyroscope merged (see [`phone`]).
    PhyphoxZip,
    /// phyphox's Excel export (.xlsx from Android, .xls from iOS), one sheet per sensor.
    PhyphoxExcel,
    /// Sensor Logger's zip, its unzipped folder, or one of its CSVs (`time,seconds_elapsed,z,y,x`).
    SensorLogger,
    /// Physics Toolbox Sensor Suite's CSV (`time,gFx,gFy,gFz`, g).
    PhysicsToolbox,
    /// PX4 ULog (`.ulg`): `sensor_accel` + `sensor_gyro`, else `sensor_combined` (see [`flight`]).
    Ulog,
    /// ArduPilot DataFlash log (`.bin`): `IMU` messages (see [`flight`]).
    DataFlash,
}

impl Format {
    pub const ALL: [Format; 14] = [
        Format::Csv,
        Format::Whitespace,
        Format::Imucal,
        Format::Mpu6050,
        Format::Phyphox,
        Format::Gx1,
        Format::Mat,
        Format::RosBag,
        Format::PhyphoxZip,
        Format::PhyphoxExcel,
        Format::SensorLogger,
        Format::PhysicsToolbox,
        Format::Ulog,
        Format::DataFlash,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Whitespace => "whitespace",
            Format::Imucal => "imucal",
            Format::Mpu6050 => "mpu6050",
            Format::Phyphox => "phyphox",
            Format::Gx1 => "3dm-gx1",
            Format::Mat => "mat",
            Format::RosBag => "rosbag",
            Format::PhyphoxZip => "phyphox-zip",
            Format::PhyphoxExcel => "phyphox-excel",
            Format::SensorLogger => "sensor-logger",
            Format::PhysicsToolbox => "physics-toolbox",
            Format::Ulog => "ulog",
            Format::DataFlash => "dataflash",
        }
    }

    /// Parses a format name (`csv`, `whitespace`/`imu-tk`, `imucal`, `mpu6050`, `phyphox`, `3dm-gx1`/`gx1`,
    /// `rosbag`/`bag`, `phyphox-zip`, `phyphox-excel`/`xlsx`, `sensor-logger`, `physics-toolbox`,
    /// `ulog`/`ulg`/`px4`, `dataflash`/`bin`/`ardupilot`).
    pub fn parse(text: &str) -> Option<Format> {
        match text.to_ascii_lowercase().as_str() {
            "imu-tk" | "imu_tk" | "imutk" => Some(Format::Whitespace),
            "gx1" | "3dmgx1" => Some(Format::Gx1),
            "mpu-6050" => Some(Format::Mpu6050),
            "matlab" => Some(Format::Mat),
            "bag" | "ros" | "ros-bag" | "mcap" | "db3" => Some(Format::RosBag),
            "xlsx" | "xls" => Some(Format::PhyphoxExcel),
            "ulg" | "px4" => Some(Format::Ulog),
            "bin" | "ardupilot" | "data-flash" => Some(Format::DataFlash),
            t => Format::ALL.into_iter().find(|f| f.name() == t),
        }
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Full scale of a signed 16-bit reading: a part set to ±R reads R at this many counts (the
/// MPU-6050's, MPU-9250's, ICM-20948's and BMI160's registers alike).
const SIXTEEN_BIT_FULL_SCALE: f64 = 32768.0;

/// The accelerometer ranges, ± g, that such parts' configuration registers offer (the MPU-6050's
/// AFS_SEL 0–3: ±2, 4, 8, 16 g).
pub const ACCEL_RANGES_G: [f64; 4] = [2.0, 4.0, 8.0, 16.0];
/// The gyro ranges, ± °/s (the MPU-6050's FS_SEL 0–3: ±250 … 2000 °/s; ±125 on the BMI160).
pub const GYRO_RANGES_DPS: [f64; 5] = [125.0, 250.0, 500.0, 1000.0, 2000.0];

/// A range that no 16-bit part's registers offer (give the scale itself then).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{range}: a 16-bit part's ranges are {offered}")]
pub struct UnknownRange {
    pub range: f64,
    /// The ranges there are, listed.
    pub offered: String,
}

/// The SI value of one count of a 16-bit part set to ±`range`, one of `ranges`, whose full
/// scale is `range` · `si_per_unit`.
fn scale_of_range(range: f64, ranges: &[f64], si_per_unit: f64) -> Result<f64, UnknownRange> {
    if ranges.contains(&range) {
        return Ok(range * si_per_unit / SIXTEEN_BIT_FULL_SCALE);
    }
    let offered: Vec<String> = ranges.iter().map(f64::to_string).collect();
    Err(UnknownRange {
        range,
        offered: offered.join(", "),
    })
}

/// m/s² per count of a 16-bit accelerometer set to ±`range_g` (one of [`ACCEL_RANGES_G`]).
pub fn accel_scale_of_range_g(range_g: f64) -> Result<f64, UnknownRange> {
    scale_of_range(
        range_g,
        &ACCEL_RANGES_G,
        crate::input::recording::STANDARD_GRAVITY,
    )
}

/// rad/s per count of a 16-bit gyro set to ±`range_dps` (one of [`GYRO_RANGES_DPS`]).
pub fn gyro_scale_of_range_dps(range_dps: f64) -> Result<f64, UnknownRange> {
    scale_of_range(range_dps, &GYRO_RANGES_DPS, 1f64.to_radians())
}

/// How to read a file.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Format; detected when `None`.
    pub format: Option<Format>,
    /// Column choice and units for `csv` (and separators for every text format).
    pub columns: ColumnMap,
    /// m/s² per count (or per file unit): a = (value − offset) · scale. Turns raw counts into SI.
    pub accel_scale: Option<f64>,
    /// Per-axis offset subtracted before scaling, in file units.
    pub accel_offset: Option<[f64; 3]>,
    /// rad/s per count (or per file unit): gyro = value · scale. Turns raw gyro counts into SI
    /// ([`gyro_scale_of_range_dps`]).
    pub gyro_scale: Option<f64>,
    /// Sample rate for formats without a time column (overrides `Fs` metadata; imucal: 204.8 Hz).
    pub sample_rate_hz: Option<f64>,
    pub gx1: Gx1Options,
    /// ROS bags: the topic to read (`accel,gyro` for two `Vector3Stamped` topics); without it a
    /// bag with one IMU topic is read and one with several is refused with the list.
    /// Flight logs: the IMU instance (`1`, `sensor_accel_1`, `sensor_combined`, `IMU[1]`);
    /// instance 0 without it.
    pub topic: Option<String>,
    /// Replace the timestamps by t₀ + i·Δt, Δt from all the timestamps (for coarse, repeated or
    /// jittered stamps). Dropped samples are not restored: use it on recordings without gaps.
    pub retime: bool,
    /// ROS bags: a file whose end is damaged (cut, its footer or index lost) gives the messages
    /// before the damage, with a note, instead of an error naming how many are intact.
    /// Flight logs: damage gives the samples before it, with a note naming its byte offset.
    pub salvage: bool,
}

/// A recording and what its reader learned.
#[derive(Debug, Clone, Serialize)]
pub struct Loaded {
    #[serde(skip)]
    pub recording: Recording,
    pub format: Format,
    /// Present when the format was detected rather than given.
    pub detection: Option<Detection>,
    /// `accel_mps2` holds raw counts (no scale was given for a raw-count format).
    pub raw_counts: bool,
    /// `gyro_radps` holds the file's raw counts, not rad/s (MPU-6050, imucal: no gyro scale is
    /// known); a consumer that needs rad/s must not use it as such.
    pub gyro_counts: bool,
    /// Per-sample section labels (imucal's `part`).
    #[serde(skip)]
    pub labels: Option<Vec<String>>,
    /// Decoder statistics for the 3DM-GX1 stream.
    pub gx1: Option<Gx1Report>,
    /// A flight-controller log's instance and the accelerometer's device id.
    pub flight: Option<flight::FlightLog>,
    /// Things the user should know (synthesised time, dropped gyro counts, linear acceleration …).
    pub notes: Vec<String>,
}

/// Everything that can go wrong reading a file in any format.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Recording(#[from] RecordingError),
    #[error(transparent)]
    Gx1(#[from] Gx1Error),
    #[error(transparent)]
    Mat(#[from] mat::MatError),
    #[error(transparent)]
    Flight(#[from] flight::FlightError),
    #[cfg(feature = "bags")]
    #[error(transparent)]
    Bag(#[from] bag::BagError),
    #[cfg(not(feature = "bags"))]
    #[error("{file}: a ROS bag, and this build of spincal lacks the `bags` feature that reads them")]
    BagsNotBuilt { file: String },
    #[error(
        "{file}: no sample rate: the file has no time column and no `Fs,<Hz>` line; give `sample_rate_hz`"
    )]
    NoSampleRate { file: String },
    #[error("{file}:{line}: sample rate '{text}' is not a positive number")]
    BadSampleRate { file: String, line: usize, text: String },
    #[error("{file}: no column '{name}' (columns: {available})")]
    MissingColumn {
        file: String,
        name: String,
        available: String,
    },
    #[error("{file}:{line}: the `{column}` index {value} repeats or is not a whole number")]
    BadIndex {
        file: String,
        line: usize,
        column: String,
        value: f64,
    },
    #[error(transparent)]
    Phone(#[from] phone::PhoneError),
    #[error("accel scale must be finite and non-zero, got {0}")]
    BadScale(f64),
    #[error("read option {name} = {value}: {why}")]
    BadOption {
        name: &'static str,
        value: String,
        why: &'static str,
    },
}

/// Reads a file in the given or detected format.
/// Only a regular file under [`crate::input::limits::LARGEST_RECORDING_BYTES`], a ROS 2 bag
/// folder or a Sensor Logger folder is read; anything else (a FIFO, a device, another folder) is
/// refused by name before it is opened.
pub fn read_path(path: &Path, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let file = path.display().to_string();
    check_input(path)?;
    // A ROS 2 bag directory, or a bag file.
    if bag_detect::is_bag_dir(path)
        || options.format == Some(Format::RosBag)
        || (options.format.is_none() && sniff_bag(path))
    {
        check_options(options)?;
        return read_bag_path(path, options);
    }
    // An unzipped Sensor Logger recording.
    if phone::is_sensor_logger_dir(path) {
        check_options(options)?;
        let loaded = phone::read_sensor_logger_dir(path, options)?;
        let detection = options.format.is_none().then(|| Detection {
            format: Format::SensorLogger,
            reason: "folder with Sensor Logger's Metadata.csv and accelerometer".into(),
        });
        return finish(loaded, detection, options);
    }
    let bytes = crate::input::table::read_file(path).map_err(|source| FormatError::Io {
        file: file.clone(),
        source,
    })?;
    read_bytes(&bytes, &file, options)
}

/// A recording's path before anything opens it: a regular file within the size limit, or a
/// folder that is a ROS 2 bag or a Sensor Logger recording.
pub(crate) fn check_input(path: &Path) -> Result<(), FormatError> {
    use crate::input::limits::{check_file, InputFileError, LARGEST_RECORDING_BYTES};
    let io = |source| FormatError::Io {
        file: path.display().to_string(),
        source,
    };
    let folder = check_file(path, Some((LARGEST_RECORDING_BYTES, "a recording's limit"))).map_err(io)?;
    if folder && !bag_detect::is_bag_dir(path) && !phone::is_sensor_logger_dir(path) {
        return Err(io(InputFileError::Folder.into_io()));
    }
    Ok(())
}

/// Reads an in-memory file; `file` names it in errors.
pub fn read_bytes(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    check_options(options)?;
    let detection = match options.format {
        Some(_) => None,
        None => Some(detect(bytes)),
    };
    let format = options
        .format
        .or(detection.as_ref().map(|d| d.format))
        .unwrap_or(Format::Csv);
    let loaded = match format {
        Format::Csv => {
            let recording =
                Recording::parse_csv_timed(bytes, file, &options.columns, options.sample_rate_hz)?;
            Loaded::new(recording, format, false)
        }
        Format::Whitespace => read_whitespace(bytes, file, options)?,
        Format::Imucal => read_imucal(bytes, file, options)?,
        Format::Mpu6050 => read_mpu6050(bytes, file, options)?,
        Format::Phyphox => phone::phyphox::read_csv(bytes, file, options)?,
        Format::PhysicsToolbox => phone::physics_toolbox::read(bytes, file, options)?,
        Format::SensorLogger if !bytes.starts_with(phone::ZIP_MAGIC) => {
            phone::sensor_logger::read_csv(bytes, file, options)?
        }
        Format::PhyphoxZip | Format::PhyphoxExcel | Format::SensorLogger => {
            let (loaded, detection) = phone::read_archive(bytes, file, options, options.format, detection)?;
            return finish(loaded, detection, options);
        }
        Format::Gx1 => {
            let (recording, report) = gx1::decode(bytes, file, &options.gx1)?;
            let mut l = Loaded::new(recording, format, false);
            if !report.faults.is_empty() {
                l.notes.push(format!(
                    "{} damaged stretches skipped, first at byte {}",
                    report.faults.len(),
                    report.faults[0].offset
                ));
            }
            l.gx1 = Some(report);
            l
        }
        Format::Mat => read_mat(bytes, file, options)?,
        #[cfg(feature = "bags")]
        Format::RosBag => bag_loaded(bag::read_bytes(
            bytes,
            file,
            options.topic.as_deref(),
            options.salvage,
        )?),
        #[cfg(not(feature = "bags"))]
        Format::RosBag => return Err(FormatError::BagsNotBuilt { file: file.into() }),
        Format::Ulog | Format::DataFlash => flight::read(format, bytes, file, options)?,
    };
    finish(loaded, detection, options)
}

/// Whether the file at `path` starts with a bag's magic.
fn sniff_bag(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 16];
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    let mut n = 0;
    while n < head.len() {
        match f.read(&mut head[n..]) {
            Ok(0) | Err(_) => break,
            Ok(k) => n += k,
        }
    }
    bag_detect::Storage::sniff(&head[..n]).is_some()
}

/// Reads a bag file or a ROS 2 bag directory (an sqlite3 bag is opened in place, not copied).
#[cfg(feature = "bags")]
fn read_bag_path(path: &Path, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let read = bag::read_path(path, options.topic.as_deref(), options.salvage)?;
    let detection = options.format.is_none().then(|| Detection {
        format: Format::RosBag,
        reason: if path.is_dir() {
            format!("directory with metadata.yaml ({})", read.storage.name())
        } else {
            format!("{} magic at byte 0", read.storage.name())
        },
    });
    finish(bag_loaded(read), detection, options)
}

#[cfg(not(feature = "bags"))]
fn read_bag_path(path: &Path, _: &ReadOptions) -> Result<Loaded, FormatError> {
    Err(FormatError::BagsNotBuilt {
        file: path.display().to_string(),
    })
}

#[cfg(feature = "bags")]
fn bag_loaded(read: bag::BagRead) -> Loaded {
    let mut l = Loaded::new(read.recording, Format::RosBag, false);
    l.notes = read.notes;
    l
}
#[cfg(test)]
mod tests;
