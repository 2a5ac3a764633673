//! spincal: turntable-referenced calibration and correction of IMU accelerometer data.
//!
//! The library does all the science and never prints; the `spincal` binary is a thin shell.
//! See ARCHITECTURE.md at the repository root for the map and the invariants.

pub mod allan;
pub mod formats;
pub mod inspect;
pub mod metrics;
pub mod optim;
pub mod plot;
pub mod recording;
pub mod static_cal;
pub mod static_detect;
pub mod strobe;
pub mod table;

pub use recording::{AccelUnit, ColumnMap, Recording, RecordingError, STANDARD_GRAVITY};
