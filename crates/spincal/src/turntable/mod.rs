//! The turntable: its model (SPEC §2), the fit, and the sensitivity table.

pub mod fit;
pub mod model;
pub mod moments;
pub mod sensitivity;
pub mod spectrum;
