//! spincal: turntable-referenced calibration and correction of IMU accelerometer data.
//!
//! The library does all the science and never prints; the `spincal` binary is a thin shell.
//! See ARCHITECTURE.md at the repository root for the map and the invariants.

// Index loops over several parallel arrays read better than zipped iterators in numerical code.
#![allow(clippy::needless_range_loop)]
// Every unsafe operation, inside an unsafe fn too, sits in a block with its SAFETY comment.
#![deny(unsafe_op_in_unsafe_fn)]

// The README's library example runs as a doc test.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

// The modules, alphabetically. Their imports form no cycle (tested in tests/architecture.rs).
pub mod allan;
pub mod calibrate;
pub mod campaign;
pub mod correctors;
pub mod export;
pub mod firmware;
pub mod fleet;
pub(crate) mod geometry;
pub mod input;
pub mod metrics;
pub mod optim;
pub mod output;
pub mod progress;
#[cfg(feature = "plot")]
pub mod report;
mod simd;
pub mod simulate;
pub mod static_calibration;
pub mod sysid;
pub mod thermal;
pub mod turntable;

// Every public item has one path, its module's own (tests/architecture.rs); the prelude is the
// one deliberate second path, for the common flow.
/// The common flow in one import (`use spincal::prelude::*;`): read a recording, calibrate one
/// recording or a campaign, load a model and correct rows with it.
pub mod prelude {
    pub use crate::calibrate::calibrate;
    pub use crate::campaign::load::load_campaign;
    pub use crate::campaign::params::Params;
    pub use crate::campaign::select::calibrate_campaign;
    pub use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
    pub use crate::correctors::rows::{RowCorrector, RowOutcome, RowStatus, UnitFactors};
    pub use crate::input::formats::read_path;
    pub use crate::input::recording::{ColumnMap, Recording};
    pub use crate::progress::silent;
}
