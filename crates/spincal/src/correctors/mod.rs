//! Correctors: what they share (the [`corrector::Corrector`] trait, pairing and the 60/20/20
//! division), the kinds (network, linear, static, physical, physical + network), and the saved file that holds any of them.
//!
//! Imports only go downward: `corrector` and `division` import no kind; the kinds import them;
//! `model_file` imports the kinds.

pub mod ann;
pub mod corrector;
pub mod division;
pub mod excitation;
pub mod gyro;
pub mod gyro_poses;
pub mod linear;
pub mod model_file;
pub mod physical;
pub mod physical_ann;
pub mod rows;
pub mod static_cal;
pub mod static_detect;
pub mod stream;
