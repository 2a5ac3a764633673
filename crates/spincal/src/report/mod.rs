//! Everything drawn: the calibration report (HTML), line plots and heat maps (SVG and PNG, with an
//! embedded font), and the stroboscopic disc. Compiled with the default `plot` feature.

pub mod fleet;
pub mod html;
pub mod plot;
pub mod strobe;

pub use html::render_report;
