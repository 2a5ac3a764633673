//! The turntable: its model (SPEC §2), the fit, a recording's segments between logging gaps, and
//! the sensitivity table.

pub mod fit;
pub mod model;
pub mod moments;
pub mod segments;
pub mod sensitivity;
pub mod spectrum;
