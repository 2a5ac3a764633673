//! Phone apps' exports, read as the apps write them: phyphox (its CSV, its zip of one CSV per
//! sensor with `meta/`, its Excel workbook), Sensor Logger (its zip or the unzipped folder) and
//! Physics Toolbox Sensor Suite (its CSV).
//!
//! Each app's rules live in its own file (`phyphox.rs`, `sensor_logger.rs`, `physics_toolbox.rs`);
//! `text.rs` holds what their CSVs share (separator, decimal comma, the U+2212 minus) and one
//! sensor's stream; `pair.rs` puts an accelerometer and a gyroscope recorded on their own clocks
//! into one [`Recording`](crate::input::recording::Recording). The archive readers (`archive.rs`:
//! the `zip` crate; `excel.rs`: `calamine`) need the `phone` feature; without it a zip or a
//! workbook is still recognised and refused by name ([`PhoneError::NotBuilt`]).
//!
//! Channels that cannot calibrate an accelerometer or a gyro are refused by name with the export
//! to use instead: an acceleration with gravity removed ([`PhoneError::GravityRemoved`]),
//! phyphox's 2 Hz centripetal-acceleration export ([`PhoneError::Centripetal`]) and iOS's fused
//! rotation rate ([`PhoneError::FusedRotationRate`]).

// Axis loops index several parallel per-axis arrays at once.
#![allow(clippy::needless_range_loop)]
// Without the `phone` feature the sets' and meta files' readers serve only the CSV readers and
// the tests; the archive readers that also use them are not built.
#![cfg_attr(not(feature = "phone"), allow(dead_code))]

#[cfg(feature = "phone")]
mod archive;
#[cfg(feature = "phone")]
mod excel;
mod pair;
pub(crate) mod phyphox;
pub(crate) mod physics_toolbox;
pub(crate) mod sensor_logger;
mod text;

use std::path::Path;

use super::{Detection, Format, FormatError, Loaded, ReadOptions};

#[cfg(feature = "phone")]
pub use pair::read_pair;
pub use pair::PAIR_GAP_INTERVALS;

/// The first bytes of a zip archive (a local file header), which is also what an `.xlsx` is.
pub const ZIP_MAGIC: &[u8] = b"PK\x03\x04";
/// The first bytes of an OLE2 compound file: the legacy `.xls` workbook phyphox's iOS app writes.
pub const OLE_MAGIC: &[u8] = b"\xD0\xCF\x11\xE0\xA1\xB1\x1A\xE1";

/// Everything a phone export can be refused for, beyond the table and recording errors.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PhoneError {
    #[error("{file}: {what}, and this build of spincal lacks the `phone` feature that reads it")]
    NotBuilt { file: String, what: &'static str },
    #[error("{file}: {app}'s {channel} has gravity removed (the phone's own estimate subtracted), so it cannot calibrate an accelerometer; use {instead}")]
    GravityRemoved {
        file: String,
        app: &'static str,
        channel: String,
        instead: &'static str,
    },
    #[error("{file}: phyphox's \"Centripetal acceleration\" export holds 2 Hz averages of the magnitudes |ω| and |a|, not the three axes; record the \"Acceleration with g\" and \"Gyroscope\" sensors (or a simple experiment with both) and export those")]
    Centripetal { file: String },
    #[error("{file}: {what} is iOS's fused rotation rate (Core Motion's device motion, its bias removed by the attitude filter), not the gyroscope's own output; {instead}")]
    FusedRotationRate {
        file: String,
        what: &'static str,
        instead: &'static str,
    },
    #[error("{file}: no accelerometer with gravity among {found}; {hint}")]
    NoAccelerometer {
        file: String,
        found: String,
        hint: &'static str,
    },
    #[error("{file}: not a zip archive spincal can read: {why}")]
    Zip { file: String, why: String },
    #[error("{file}: member {member} inflates beyond {limit_bytes} bytes; spincal reads phone exports up to that size")]
    TooLarge {
        file: String,
        member: String,
        limit_bytes: u64,
    },
    #[error("{file}: not a workbook spincal can read: {why}")]
    Excel { file: String, why: String },
    #[error("{file}:{line}: {why}")]
    Metadata { file: String, line: usize, why: String },
    #[error("{file}:{line}: `time` '{text}' is not a whole number of epoch nanoseconds")]
    BadEpoch { file: String, line: usize, text: String },
    #[error("{accel} and {gyro}: the accelerometer ({accel_span}) and the gyroscope ({gyro_span}) do not overlap in time{why}")]
    NoOverlap {
        accel: String,
        gyro: String,
        accel_span: String,
        gyro_span: String,
        why: &'static str,
    },
    #[error("{file}: no meta/time.csv, so its clock cannot be put beside another export's; pair two exports of one phyphox session, or export both sensors from one simple experiment")]
    NoTimeReference { file: String },
}

/// Whether `path` is an unzipped Sensor Logger recording (a folder with `Metadata.csv` and an
/// accelerometer file of Sensor Logger's names).
pub fn is_sensor_logger_dir(path: &Path) -> bool {
    path.is_dir()
        && path.join("Metadata.csv").is_file()
        && sensor_logger::ACCEL_FILES
            .iter()
            .chain([&sensor_logger::GRAVITY_REMOVED])
            .any(|f| path.join(f).is_file())
}

/// The format a zip's or workbook's first bytes suggest (the members are checked when read).
pub(super) fn sniff(head: &[u8]) -> Option<Detection> {
    let found = |format, reason: &str| {
        Some(Detection {
            format,
            reason: reason.into(),
        })
    };
    if head.starts_with(OLE_MAGIC) {
        return found(
            Format::PhyphoxExcel,
            "OLE2 workbook magic (.xls, phyphox's iOS Excel export)",
        );
    }
    if !head.starts_with(ZIP_MAGIC) {
        return None;
    }
    // Member names from the local file headers in the head, not a search of every byte: a
    // phyphox zip's deflated CSV holds "xl/" by chance (seen once in 34 simulated zips).
    let names = local_names(head);
    let named = |test: &dyn Fn(&[u8]) -> bool| names.iter().any(|n| test(n));
    let has = |needle: &[u8]| head.windows(needle.len()).any(|w| w == needle);
    if named(&|n| n == b"[Content_Types].xml" || n.starts_with(b"xl/")) {
        found(
            Format::PhyphoxExcel,
            "zip holding an .xlsx workbook ([Content_Types].xml)",
        )
    } else if named(&|n| n.ends_with(b"Metadata.csv") || n.ends_with(b"TotalAcceleration.csv"))
        || has(b"seconds_elapsed")
    {
        found(
            Format::SensorLogger,
            "zip naming Sensor Logger's files (Metadata.csv, TotalAcceleration.csv)",
        )
    } else {
        found(
            Format::PhyphoxZip,
            "zip archive (a phone app's export; its members decide)",
        )
    }
}

/// The names of the zip members whose local file headers start within `head` (APPNOTE 4.3.7:
/// the signature, the name's length at byte 26, the extra field's at 28, the name from 30).
fn local_names(head: &[u8]) -> Vec<&[u8]> {
    let u16_at = |i: usize| usize::from(u16::from_le_bytes([head[i], head[i + 1]]));
    (0..head.len().saturating_sub(30))
        .filter(|&i| head[i..].starts_with(ZIP_MAGIC))
        .filter_map(|i| head.get(i + 30..i + 30 + u16_at(i + 26)))
        .collect()
}

/// Reads a phone archive (a zip or a workbook) held in memory, as `format` or as its members say.
pub(super) fn read_archive(
    bytes: &[u8],
    file: &str,
    options: &ReadOptions,
    given: Option<Format>,
    detected: Option<Detection>,
) -> Result<(Loaded, Option<Detection>), FormatError> {
    #[cfg(feature = "phone")]
    {
        let format = given.or(detected.as_ref().map(|d| d.format));
        if format == Some(Format::PhyphoxExcel) || bytes.starts_with(OLE_MAGIC) {
            let loaded = excel::read(bytes, file, options)?;
            return Ok((loaded, detected));
        }
        let members = archive::members(bytes, file)?;
        let is_sensor_logger = match given {
            Some(f) => f == Format::SensorLogger,
            None => sensor_logger::claims(&members),
        };
        if is_sensor_logger {
            let detection = detected.map(|_| Detection {
                format: Format::SensorLogger,
                reason: format!(
                    "zip holding Sensor Logger's {}",
                    sensor_logger::evidence(&members)
                ),
            });
            return Ok((sensor_logger::read(&members, file, options)?, detection));
        }
        let detection = detected.map(|_| Detection {
            format: Format::PhyphoxZip,
            reason: format!("zip holding phyphox's {}", phyphox::evidence(&members)),
        });
        Ok((phyphox::read_members(&members, file, options)?, detection))
    }
    #[cfg(not(feature = "phone"))]
    {
        let _ = (options, given, detected);
        let what = if bytes.starts_with(OLE_MAGIC) {
            "an Excel workbook (phyphox's iOS export)"
        } else {
            "a zip archive (a phone app's export, or an .xlsx workbook)"
        };
        Err(PhoneError::NotBuilt {
            file: file.into(),
            what,
        }
        .into())
    }
}

/// Reads an unzipped Sensor Logger folder.
pub(super) fn read_sensor_logger_dir(path: &Path, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let members = text::Members::from_dir(path)?;
    sensor_logger::read(&members, &path.display().to_string(), options)
}

#[cfg(test)]
mod tests;
