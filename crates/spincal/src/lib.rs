//! spincal: turntable-referenced calibration and correction of IMU accelerometer data.
//!
//! The library does all the science and never prints; the `spincal` binary is a thin shell.
//! See ARCHITECTURE.md at the repository root for the map and the invariants.

// Index loops over several parallel arrays read better than zipped iterators in numerical code.
#![allow(clippy::needless_range_loop)]

// The README's library example runs as a doc test.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

pub mod allan;
pub mod ann;
pub mod calibrate;
pub mod checks;
pub mod corrector;
pub mod formats;
pub mod inspect;
pub mod linear;
pub mod metrics;
pub mod optim;
pub mod plot;
pub mod recording;
pub mod report;
pub mod simulate;
pub mod spectrum;
pub mod static_cal;
pub mod static_detect;
pub mod strobe;
pub mod sysid;
pub mod table;
pub mod turntable;

pub use recording::{AccelUnit, ColumnMap, Recording, RecordingError, STANDARD_GRAVITY};
