//! Everything drawn: the calibration report (HTML), line plots and heat maps (SVG and PNG, with an
//! embedded font), and the stroboscopic disc. Compiled with the default `plot` feature.

pub mod allan;
pub mod campaign;
pub mod fleet;
pub mod html;
pub mod plot;
pub mod strobe;

/// Text made safe inside HTML elements and attribute values.
pub(crate) fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
