//! Figures as SVG strings (self-contained, to inline in HTML) and PNG files.
//!
//! Two figure kinds cover every plot spincal draws:
//! - [`LinePlot`]: x–y series with a legend, linear or logarithmic axes, vertical markers with labels
//!   (a spectrum's peak) and shaded labelled spans (the train/validation/test division). Long series
//!   are thinned to at most two points per pixel column with [`decimate_min_max`], keeping extremes.
//! - [`HeatMap`]: a rows × columns grid of values with per-cell numbers and a colour bar; NaN cells stay
//!   blank (an architecture sweep where some sizes were not trained).
//!
//! Both implement [`Figure`]: `to_svg()` and `to_png(path, width, height)`. Text in PNGs is drawn with
//! the DejaVu Sans font compiled into the library (no system fonts are read); SVG text names the
//! generic `sans-serif` family and refers to nothing outside the document.

mod decimate;
mod heatmap;
mod line;

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

pub use decimate::decimate_min_max;
pub use heatmap::HeatMap;
pub use line::{Legend, LinePlot, LineStyle, Scale, Series, Span, VLine};

/// Everything that can go wrong while drawing a figure.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    #[error("figure '{figure}': nothing to draw ({reason})")]
    Empty { figure: String, reason: String },
    #[error("figure '{figure}', series '{series}': {x} x values but {y} y values")]
    LengthMismatch {
        figure: String,
        series: String,
        x: usize,
        y: usize,
    },
    #[error("figure '{figure}': heat map has {rows} rows × {cols} columns but {values} values")]
    GridShape {
        figure: String,
        rows: usize,
        cols: usize,
        values: usize,
    },
    #[error("figure '{figure}': {axis} axis is logarithmic but has no positive finite value")]
    NoPositiveValues { figure: String, axis: &'static str },
    #[error("figure size {width}×{height} px is too small (at least 80×60)")]
    TooSmall { width: u32, height: u32 },
    #[error("{path}: a PNG file name must end in .png")]
    NotPng { path: String },
    #[error("{path}: cannot write: {reason}")]
    Write { path: String, reason: String },
    #[error("the embedded font could not be loaded")]
    Font,
    #[error("drawing failed: {0}")]
    Render(String),
}

/// An sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// The Okabe–Ito colour-blind-safe palette, reordered for lines on white (yellow last).
    pub const PALETTE: [Rgb; 8] = [
        Rgb(0, 114, 178),
        Rgb(213, 94, 0),
        Rgb(0, 158, 115),
        Rgb(230, 159, 0),
        Rgb(204, 121, 167),
        Rgb(86, 180, 233),
        Rgb(0, 0, 0),
        Rgb(240, 228, 66),
    ];

    /// The `i`-th palette colour, cycling.
    pub fn palette(i: usize) -> Rgb {
        Rgb::PALETTE[i % Rgb::PALETTE.len()]
    }

    /// `#rrggbb`, as in SVG and CSS.
    pub fn hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }

    fn rgb(self) -> RGBColor {
        RGBColor(self.0, self.1, self.2)
    }
}

/// A figure that can be drawn as SVG or PNG.
pub trait Figure: sealed::Render {
    /// Size in pixels used by [`Figure::to_svg`].
    fn size(&self) -> (u32, u32);

    /// The figure as a standalone `<svg>` element, with `width`/`height` in pixels and a `viewBox`.
    fn to_svg(&self) -> Result<String, PlotError> {
        let (width, height) = checked_size(self.size())?;
        fonts()?;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
            self.render(&root)?;
            root.present().map_err(render_error)?;
        }
        Ok(svg)
    }

    /// Draws the figure into a PNG file of `width` × `height` pixels.
    fn to_png(&self, path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
        let (width, height) = checked_size((width, height))?;
        let is_png = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png {
            return Err(PlotError::NotPng {
                path: path.display().to_string(),
            });
        }
        fonts()?;
        let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
        self.render(&root)?;
        root.present().map_err(|e| PlotError::Write {
            path: path.display().to_string(),
            reason: e.to_string(),
        })
    }
}

pub(crate) mod sealed {
    use plotters::coord::Shift;
    use plotters::prelude::*;

    /// Drawing onto any plotters backend; not part of the public API.
    pub trait Render {
        fn render<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), super::PlotError>;
    }
}

fn checked_size((width, height): (u32, u32)) -> Result<(u32, u32), PlotError> {
    if width < 80 || height < 60 {
        return Err(PlotError::TooSmall { width, height });
    }
    Ok((width, height))
}

/// Registers the embedded DejaVu Sans for the families plotters asks for, once per process.
fn fonts() -> Result<(), PlotError> {
    static LOADED: OnceLock<bool> = OnceLock::new();
    let ok = *LOADED.get_or_init(|| {
        use plotters::style::{register_font, FontStyle};
        let regular = dejavu::sans::regular();
        let bold = dejavu::sans::bold();
        ["sans-serif", "serif", "monospace"].iter().all(|family| {
            register_font(family, FontStyle::Normal, regular).is_ok()
                && register_font(family, FontStyle::Bold, bold).is_ok()
        })
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

fn render_error<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Render(e.to_string())
}

/// Text content of every `<text>` element of an SVG written by plotters (for tests).
#[cfg(test)]
pub(crate) fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| Some(t.split_once('>')?.1.split_once("</text>")?.0.trim().to_string()))
        .collect()
}

/// Number of `<polyline>` elements stroked in `color` (one per unbroken solid line).
#[cfg(test)]
pub(crate) fn svg_polylines(svg: &str, color: Rgb) -> usize {
    let stroke = format!("stroke=\"{}\"", color.hex()).to_lowercase();
    svg.split("<polyline")
        .skip(1)
        .filter(|p| p.split('>').next().unwrap_or("").to_lowercase().contains(&stroke))
        .count()
}

fn clear<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(render_error)
}

/// Axis tick text for an axis spanning `span`: at most 6 significant digits, no float noise, values
/// within 1e-9 · `span` of zero as 0, exponent form outside 1e-3..1e5.
pub fn format_tick(v: f64, span: f64) -> String {
    let v = if v.abs() <= 1e-9 * span.abs() { 0.0 } else { v };
    if v == 0.0 || !v.is_finite() {
        return if v.is_finite() { "0".into() } else { format!("{v}") };
    }
    let rounded: f64 = format!("{v:.5e}").parse().unwrap_or(v);
    let magnitude = rounded.abs();
    if (1e-3..1e5).contains(&magnitude) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_text() {
        assert_eq!(format_tick(0.1 + 0.2, 1.0), "0.3");
        assert_eq!(format_tick(0.0, 1.0), "0");
        assert_eq!(format_tick(2.2045e-16, 2.0), "0");
        assert_eq!(format_tick(-2.5, 1.0), "-2.5");
        assert_eq!(format_tick(1e-5, 1e-5), "1e-5");
        assert_eq!(format_tick(2.5e6, 1.0), "2.5e6");
        assert_eq!(format_tick(12345.0, 1.0), "12345");
    }

    #[test]
    fn palette_cycles() {
        assert_eq!(Rgb::palette(0), Rgb::palette(8));
        assert_eq!(Rgb(255, 0, 16).hex(), "#ff0010");
    }
}
