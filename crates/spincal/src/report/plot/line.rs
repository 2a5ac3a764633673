//! x–y line plots: time series, spectra with a marked peak, log-log Allan deviation, shaded spans.

use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{clear, decimate_min_max, format_tick, render_error, sealed, Figure, PlotError, Rgb};
#[cfg(test)]
use super::{svg_polylines, svg_texts};

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    #[default]
    Solid,
    Dashed,
    /// Small filled circles, no line.
    Markers,
}

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    #[default]
    Linear,
    /// Base 10; non-positive values are left out (they break the line).
    Log,
}

/// Where the legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    #[default]
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
    Hidden,
}

/// One named x–y series. Non-finite y values break the line.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text; an empty name leaves the series out of the legend.
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// `None`: the next palette colour.
    pub color: Option<Rgb>,
    pub style: LineStyle,
    /// Line width in pixels.
    pub width: u32,
}

impl Series {
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Series {
        Series {
            name: name.into(),
            x,
            y,
            color: None,
            style: LineStyle::Solid,
            width: 2,
        }
    }

    /// A series sampled at `x0, x0 + dx, …` (a recording at a fixed rate).
    pub fn sampled(name: impl Into<String>, x0: f64, dx: f64, y: Vec<f64>) -> Series {
        let x = (0..y.len()).map(|i| x0 + dx * i as f64).collect();
        Series::new(name, x, y)
    }

    pub fn color(mut self, color: Rgb) -> Series {
        self.color = Some(color);
        self
    }

    pub fn style(mut self, style: LineStyle) -> Series {
        self.style = style;
        self
    }

    pub fn width(mut self, width: u32) -> Series {
        self.width = width.max(1);
        self
    }
}

/// A labelled vertical line, e.g. a spectrum's peak.
#[derive(Debug, Clone, PartialEq)]
pub struct VLine {
    pub x: f64,
    pub label: String,
    pub color: Rgb,
}

/// A shaded labelled x interval drawn behind the series, e.g. the test part of a split.
#[derive(Debug, Clone, PartialEq)]
pub struct Span {
    pub x0: f64,
    pub x1: f64,
    pub label: String,
    pub color: Rgb,
}

/// An x–y plot of several series with a legend.
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub x_scale: Scale,
    pub y_scale: Scale,
    pub vlines: Vec<VLine>,
    pub spans: Vec<Span>,
    /// Fixed axis ranges; `None`: fit the data (and the spans and markers) with a small margin.
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    pub legend: Legend,
    /// Thin long series with [`decimate_min_max`] to two points per pixel column (default on).
    pub decimate: bool,
    /// Pixel size used by [`Figure::to_svg`].
    pub size: (u32, u32),
}

impl LinePlot {
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> LinePlot {
        LinePlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            vlines: Vec::new(),
            spans: Vec::new(),
            x_range: None,
            y_range: None,
            legend: Legend::UpperRight,
            decimate: true,
            size: (900, 420),
        }
    }

    pub fn series(mut self, series: Series) -> LinePlot {
        self.series.push(series);
        self
    }

    pub fn log_x(mut self) -> LinePlot {
        self.x_scale = Scale::Log;
        self
    }

    pub fn log_y(mut self) -> LinePlot {
        self.y_scale = Scale::Log;
        self
    }

    pub fn vline(mut self, x: f64, label: impl Into<String>) -> LinePlot {
        self.vlines.push(VLine {
            x,
            label: label.into(),
            color: Rgb(200, 0, 0),
        });
        self
    }

    pub fn span(mut self, x0: f64, x1: f64, label: impl Into<String>, color: Rgb) -> LinePlot {
        self.spans.push(Span {
            x0,
            x1,
            label: label.into(),
            color,
        });
        self
    }

    pub fn x_range(mut self, lo: f64, hi: f64) -> LinePlot {
        self.x_range = Some((lo, hi));
        self
    }

    pub fn y_range(mut self, lo: f64, hi: f64) -> LinePlot {
        self.y_range = Some((lo, hi));
        self
    }

    pub fn legend(mut self, legend: Legend) -> LinePlot {
        self.legend = legend;
        self
    }

    pub fn size(mut self, width: u32, height: u32) -> LinePlot {
        self.size = (width, height);
        self
    }

    fn check(&self) -> Result<(), PlotError> {
        let empty = |reason: &str| PlotError::Empty {
            figure: self.title.clone(),
            reason: reason.into(),
        };
        if self.series.is_empty() {
            return Err(empty("no series"));
        }
        for s in &self.series {
            if s.x.len() != s.y.len() {
                return Err(PlotError::LengthMismatch {
                    figure: self.title.clone(),
                    series: s.name.clone(),
                    x: s.x.len(),
                    y: s.y.len(),
                });
            }
        }
        Ok(())
    }

    /// Axis range over the values that the scale can show, widened by a margin.
    fn axis_range(
        &self,
        fixed: Option<(f64, f64)>,
        scale: Scale,
        axis: &'static str,
        values: impl Iterator<Item = f64>,
    ) -> Result<(f64, f64), PlotError> {
        if let Some(range) = fixed {
            return Ok(range);
        }
        let ok = |v: &f64| v.is_finite() && (scale == Scale::Linear || *v > 0.0);
        let (lo, hi) = values
            .filter(ok)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        if lo > hi {
            return Err(match scale {
                Scale::Log => PlotError::NoPositiveValues {
                    figure: self.title.clone(),
                    axis,
                },
                Scale::Linear => PlotError::Empty {
                    figure: self.title.clone(),
                    reason: format!("no finite {axis} value"),
                },
            });
        }
        Ok(match scale {
            Scale::Linear if hi == lo => (lo - lo.abs().max(1.0) * 0.1, hi + hi.abs().max(1.0) * 0.1),
            Scale::Linear if axis == "x" => (lo, hi),
            Scale::Linear => (lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)),
            Scale::Log if hi == lo => (lo / 2.0, hi * 2.0),
            Scale::Log => {
                let pad = (hi / lo).powf(0.04);
                (lo / pad, hi * pad)
            }
        })
    }

    fn draw_chart<DB, X, Y>(
        &self,
        root: &DrawingArea<DB, Shift>,
        x_axis: X,
        y_axis: Y,
    ) -> Result<(), PlotError>
    where
        DB: DrawingBackend,
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let (y_lo, y_hi) = {
            let r = y_axis.range();
            (r.start, r.end)
        };
        let x_span = {
            let r = x_axis.range();
            r.end - r.start
        };
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(68)
            .build_cartesian_2d(x_axis, y_axis)
            .map_err(render_error)?;
        let x_tick = |v: &f64| format_tick(*v, x_span);
        let y_tick = |v: &f64| format_tick(*v, y_hi - y_lo);
        chart
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&x_tick)
            .y_label_formatter(&y_tick)
            .max_light_lines(4)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .bold_line_style(RGBColor(0, 0, 0).mix(0.12))
            .light_line_style(RGBColor(0, 0, 0).mix(0.04))
            .draw()
            .map_err(render_error)?;

        let label_style = ("sans-serif", 13).into_font().color(&BLACK);
        for span in &self.spans {
            let fill = span.color.rgb().mix(0.18).filled();
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(span.x0, y_lo), (span.x1, y_hi)],
                    fill,
                )))
                .map_err(render_error)?;
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at((span.x0, y_hi))
                        + Text::new(span.label.clone(), (5, 5), label_style.clone()),
                ))
                .map_err(render_error)?;
        }

        let plot_width = chart.plotting_area().dim_in_pixel().0 as usize;
        let visible = |v: f64, scale: Scale| v.is_finite() && (scale == Scale::Linear || v > 0.0);
        for (i, s) in self.series.iter().enumerate() {
            let color = s.color.unwrap_or_else(|| Rgb::palette(i)).rgb();
            let style = color.stroke_width(s.width);
            let (x, y) = if self.decimate {
                decimate_min_max(&s.x, &s.y, plot_width.max(1))
            } else {
                (s.x.clone(), s.y.clone())
            };
            let mut labelled = false;
            // One path per unbroken run of points the axes can show.
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for (&a, &b) in x.iter().zip(&y) {
                if visible(a, self.x_scale) && visible(b, self.y_scale) {
                    runs.last_mut().expect("never empty").push((a, b));
                } else if !runs.last().expect("never empty").is_empty() {
                    runs.push(Vec::new());
                }
            }
            for run in runs.into_iter().filter(|r| !r.is_empty()) {
                let annotation = match s.style {
                    LineStyle::Solid => chart.draw_series(LineSeries::new(run, style)),
                    LineStyle::Dashed => chart.draw_series(DashedLineSeries::new(run, 8, 5, style)),
                    LineStyle::Markers => chart.draw_series(
                        run.into_iter()
                            .map(|p| Circle::new(p, s.width + 1, color.filled())),
                    ),
                }
                .map_err(render_error)?;
                if !labelled && !s.name.is_empty() {
                    labelled = true;
                    annotation.label(s.name.as_str()).legend(move |(lx, ly)| {
                        PathElement::new(vec![(lx, ly), (lx + 20, ly)], color.stroke_width(3))
                    });
                }
            }
        }

        for v in &self.vlines {
            let color = v.color.rgb();
            chart
                .draw_series(DashedLineSeries::new(
                    [(v.x, y_lo), (v.x, y_hi)],
                    6,
                    4,
                    color.stroke_width(2),
                ))
                .map_err(render_error)?;
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at((v.x, y_hi))
                        + Text::new(
                            v.label.clone(),
                            (6, 22),
                            ("sans-serif", 13).into_font().color(&color),
                        ),
                ))
                .map_err(render_error)?;
        }

        let position = match self.legend {
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
            Legend::Hidden => return Ok(()),
        };
        if self.series.iter().any(|s| !s.name.is_empty()) {
            chart
                .configure_series_labels()
                .position(position)
                .label_font(("sans-serif", 13))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(0, 0, 0).mix(0.3))
                .draw()
                .map_err(render_error)?;
        }
        Ok(())
    }
}

impl sealed::Render for LinePlot {
    fn render<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        self.check()?;
        clear(root)?;
        let xs = self.series.iter().flat_map(|s| s.x.iter().copied());
        let extra = self
            .spans
            .iter()
            .flat_map(|s| [s.x0, s.x1])
            .chain(self.vlines.iter().map(|v| v.x));
        let x = self.axis_range(self.x_range, self.x_scale, "x", xs.chain(extra))?;
        let ys = self.series.iter().flat_map(|s| s.y.iter().copied());
        let y = self.axis_range(self.y_range, self.y_scale, "y", ys)?;
        let lin = |(a, b): (f64, f64)| RangedCoordf64::from(a..b);
        let log = |(a, b): (f64, f64)| -> LogCoord<f64> { (a..b).log_scale().into() };
        match (self.x_scale, self.y_scale) {
            (Scale::Linear, Scale::Linear) => self.draw_chart(root, lin(x), lin(y)),
            (Scale::Linear, Scale::Log) => self.draw_chart(root, lin(x), log(y)),
            (Scale::Log, Scale::Linear) => self.draw_chart(root, log(x), lin(y)),
            (Scale::Log, Scale::Log) => self.draw_chart(root, log(x), log(y)),
        }
    }
}

impl Figure for LinePlot {
    fn size(&self) -> (u32, u32) {
        self.size
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(n: usize, f: f64, a: f64) -> Vec<f64> {
        (0..n).map(|i| a * (f * i as f64 * 0.01).sin()).collect()
    }

    #[test]
    fn time_series_svg_has_one_path_per_series_and_a_legend() {
        let plot = LinePlot::new("a_x: model vs measurement", "time (s)", "a_x (m/s²)")
            .series(Series::sampled("measured", 0.0, 0.01, sine(500, 3.5, 1.0)))
            .series(Series::sampled("model", 0.0, 0.01, sine(500, 3.5, 0.9)))
            .series(Series::sampled("residual", 0.0, 0.01, sine(500, 7.0, 0.1)));
        let svg = plot.to_svg().unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        for i in 0..3 {
            assert_eq!(
                svg_polylines(&svg, Rgb::palette(i)),
                1 + 1,
                "series {i}: one line and its legend key"
            );
        }
        let texts = svg_texts(&svg);
        for text in [
            "measured",
            "model",
            "residual",
            "time (s)",
            "a_x: model vs measurement",
            "a_x (m/s²)",
        ] {
            assert!(texts.iter().any(|t| t == text), "{text} missing in {texts:?}");
        }
        assert!(
            !svg.replace("http://www.w3.org/2000/svg", "").contains("://"),
            "refers to nothing outside"
        );
        assert!(!svg.contains("NaN"));
    }

    #[test]
    fn long_series_are_decimated_to_a_small_svg() {
        let y = sine(60_000, 1.0, 1.0);
        let plot = LinePlot::new("long", "t", "y").series(Series::sampled("y", 0.0, 0.01, y));
        let small = plot.to_svg().unwrap();
        let mut full = plot.clone();
        full.decimate = false;
        let big = full.to_svg().unwrap();
        assert!(small.len() < 60_000, "{} bytes", small.len());
        assert!(big.len() > 10 * small.len(), "{} vs {}", big.len(), small.len());
    }

    #[test]
    fn gaps_and_log_axes_split_paths() {
        let x: Vec<f64> = (1..=100).map(f64::from).collect();
        let mut y: Vec<f64> = x.iter().map(|t| 1.0 / t.sqrt()).collect();
        y[50] = f64::NAN;
        let other: Vec<f64> = x.iter().map(|t| if *t < 30.0 { 0.1 } else { -1.0 }).collect();
        let plot = LinePlot::new("Allan deviation", "τ (s)", "σ (m/s²)")
            .log_x()
            .log_y()
            .series(Series::new("x", x.clone(), y))
            .series(Series::new("y", x, other).style(LineStyle::Solid));
        let svg = plot.to_svg().unwrap();
        // x: two runs around the NaN; y: one run of positive values; each plus its legend key.
        assert_eq!(svg_polylines(&svg, Rgb::palette(0)), 2 + 1);
        assert_eq!(svg_polylines(&svg, Rgb::palette(1)), 1 + 1);
    }

    #[test]
    fn spectrum_peak_and_spans_are_labelled() {
        let f: Vec<f64> = (0..400).map(|i| i as f64 * 0.01).collect();
        let p: Vec<f64> = f
            .iter()
            .map(|v| 1.0 / (1.0 + 400.0 * (v - 0.56f64).powi(2)))
            .collect();
        let svg = LinePlot::new("spectrum", "f (Hz)", "power")
            .series(Series::new("", f, p))
            .vline(0.56, "0.56 Hz = 33.6 rpm")
            .to_svg()
            .unwrap();
        assert!(svg_texts(&svg).contains(&"0.56 Hz = 33.6 rpm".to_string()));

        let green = Rgb(0, 158, 115);
        let svg = LinePlot::new("split", "t (s)", "a (g)")
            .series(Series::sampled("a_x", 0.0, 0.1, sine(100, 30.0, 1.0)).color(Rgb(1, 2, 3)))
            .span(0.0, 6.0, "train", green)
            .span(6.0, 8.0, "validation", Rgb(230, 159, 0))
            .span(8.0, 10.0, "test", Rgb(213, 94, 0))
            .to_svg()
            .unwrap();
        let texts = svg_texts(&svg);
        for label in ["train", "validation", "test"] {
            assert!(texts.iter().any(|t| t == label), "{label}");
        }
        let fill = format!("fill=\"{}\"", green.hex().to_uppercase());
        assert!(svg.matches("<rect").count() >= 4, "background and three spans");
        assert!(svg.contains(&fill), "train span shaded");
        assert_eq!(svg_polylines(&svg, Rgb(1, 2, 3)), 1 + 1);
    }

    #[test]
    fn bad_input_is_named() {
        let empty = LinePlot::new("nothing", "x", "y");
        assert!(matches!(empty.to_svg(), Err(PlotError::Empty { .. })));
        let bad = LinePlot::new("f", "x", "y").series(Series::new("s", vec![1.0, 2.0], vec![1.0]));
        assert!(matches!(
            bad.to_svg(),
            Err(PlotError::LengthMismatch { x: 2, y: 1, .. })
        ));
        let neg =
            LinePlot::new("f", "x", "y")
                .log_y()
                .series(Series::new("s", vec![1.0, 2.0], vec![-1.0, 0.0]));
        assert!(matches!(
            neg.to_svg(),
            Err(PlotError::NoPositiveValues { axis: "y", .. })
        ));
        let ok = LinePlot::new("f", "x", "y").series(Series::new("s", vec![1.0], vec![1.0]));
        assert!(ok.to_svg().is_ok(), "a single point draws");
        let tiny = ok.clone().size(10, 10);
        assert!(matches!(tiny.to_svg(), Err(PlotError::TooSmall { .. })));
        let dir = tempfile::tempdir().unwrap();
        assert!(matches!(
            ok.to_png(&dir.path().join("f.svg"), 200, 100),
            Err(PlotError::NotPng { .. })
        ));
    }

    #[test]
    fn png_has_the_asked_size_and_text() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        let plot = LinePlot::new("title", "time (s)", "value")
            .series(Series::sampled("s", 0.0, 1.0, sine(300, 5.0, 1.0)))
            .span(10.0, 20.0, "test", Rgb(213, 94, 0));
        plot.to_png(&path, 640, 320).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        // IHDR: width and height, big-endian, at bytes 16..24.
        let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
        assert_eq!((w, h), (640, 320));
        // The title is drawn with the embedded font: dark pixels in the top band, centred.
        let img = image::open(&path).unwrap().to_rgb8();
        let dark = (250..390)
            .flat_map(|x| (8..30).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y)[0] < 128);
        assert!(dark.count() > 30, "no title text in the PNG");
    }
}
