//! Physics Toolbox Sensor Suite (Vieyra Software): its CSV export.
//!
//! The app is closed source and its documentation found here does not describe the file, so these
//! rules are the files' own: a `time` column in seconds from the start, the g-Force Meter's
//! `gFx,gFy,gFz` (the ratio of the normal force to the weight: the accelerometer in g, +1 g on the
//! axis pointing up, as the app's g-Force Meter shows), the gyroscope's `wx,wy,wz` in rad/s, and
//! the Linear Accelerometer's `ax,ay,az` (m/s², gravity removed). Exports made in a locale with a
//! decimal comma separate fields with `;`, may print the minus as U+2212, and may start with a
//! blank line. Not confirmed by the vendor: which g the app divides by (standard gravity is
//! taken) and its sign convention on iOS (Android's is taken).

use super::super::{Format, FormatError, Loaded, ReadOptions};
use super::pair::merge;
use super::text::PhoneCsv;
use super::PhoneError;
use crate::input::recording::STANDARD_GRAVITY;

const TIME: &str = "time";
const G_FORCE: [&str; 3] = ["gFx", "gFy", "gFz"];
const GYRO: [&str; 3] = ["wx", "wy", "wz"];
const LINEAR: [&str; 3] = ["ax", "ay", "az"];

/// Whether a header is Physics Toolbox's: the g-Force Meter's columns, or the Linear
/// Accelerometer's with its total `aT`.
pub(crate) fn claims(header: &[String]) -> bool {
    let has = |n: &str| header.iter().any(|h| h.eq_ignore_ascii_case(n));
    G_FORCE.iter().all(|n| has(n)) || (LINEAR.iter().all(|n| has(n)) && has("aT"))
}

/// Reads a Physics Toolbox CSV: the g-force in g as the accelerometer, and the gyroscope when the
/// same rows hold it (a multi-sensor recording: one time column for both, nothing to resample).
pub(crate) fn read(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let _ = options;
    let csv = PhoneCsv::new(bytes, file);
    let column = |name: &str| {
        csv.column(&[name]).ok_or_else(|| FormatError::MissingColumn {
            file: file.into(),
            name: name.into(),
            available: csv.columns_text(),
        })
    };
    let time = column(TIME)?;
    if csv.column(&[G_FORCE[0]]).is_none() && csv.column(&[LINEAR[0]]).is_some() {
        return Err(PhoneError::GravityRemoved {
            file: file.into(),
            app: "Physics Toolbox",
            channel: "Linear Accelerometer (ax, ay, az)".into(),
            instead: "the g-Force Meter (gFx, gFy, gFz), or a multi-sensor recording with it",
        }
        .into());
    }
    let accel = csv.stream(
        [
            time,
            column(G_FORCE[0])?,
            column(G_FORCE[1])?,
            column(G_FORCE[2])?,
        ],
        1.0,
        STANDARD_GRAVITY,
    )?;
    let gyro = match (
        csv.column(&[GYRO[0]]),
        csv.column(&[GYRO[1]]),
        csv.column(&[GYRO[2]]),
    ) {
        (Some(x), Some(y), Some(z)) => Some(csv.stream([time, x, y, z], 1.0, 1.0)?),
        _ => None,
    };
    let mut notes = vec!["g-force (gFx, gFy, gFz) in g × 9.80665 m/s²".to_string()];
    if csv.decimal_comma {
        notes.push("decimal comma converted".into());
    }
    merge(accel, gyro, file, Format::PhysicsToolbox, notes)
}
