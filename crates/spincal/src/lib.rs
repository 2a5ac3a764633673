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

// Modules in pipeline order: input, turntable, correctors, system identification, the whole
// calibration, report. Imports only point to modules above or beside, never back (tested in
// tests/architecture.rs).
pub mod allan;
pub mod calibrate;
pub mod campaign;
pub mod correctors;
pub mod export;
pub mod firmware;
pub mod fleet;
pub mod input;
pub mod metrics;
pub mod optim;
pub mod output;
pub mod progress;
#[cfg(feature = "plot")]
pub mod report;
pub mod simulate;
pub mod sysid;
pub mod thermal;
pub mod turntable;

// Paths of earlier releases, kept working (CHANGELOG.md lists the moves).
pub use correctors::model_file::{CorrectorFile, CorrectorModel};
pub use correctors::{ann, corrector, gyro_poses, linear, static_cal, static_detect};
pub use input::{formats, inspect, recording, table};
#[cfg(feature = "plot")]
pub use report::{plot, strobe};
pub use turntable::spectrum;

pub use input::recording::{AccelUnit, ColumnMap, ColumnPlan, Recording, RecordingError, STANDARD_GRAVITY};
