//! Heat maps: a grid of values with numbers in the cells and a colour bar, e.g. fit % over a sweep of
//! hidden-layer sizes.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

#[cfg(test)]
use super::svg_texts;
use super::{clear, format_tick, render_error, sealed, Figure, PlotError};
use crate::correctors::ann::SweepRow;

/// A `rows × cols` grid of values, row 0 at the bottom. NaN cells are left blank.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatMap {
    pub title: String,
    /// Describes the columns (horizontal axis), e.g. "hidden layer 2 size".
    pub x_label: String,
    /// Describes the rows (vertical axis), e.g. "hidden layer 1 size".
    pub y_label: String,
    /// One label per column and per row.
    pub col_labels: Vec<String>,
    pub row_labels: Vec<String>,
    /// Row-major: `values[r * cols + c]`.
    pub values: Vec<f64>,
    /// Colour bar title, e.g. "fit %".
    pub value_label: String,
    /// Decimals of the numbers printed in the cells.
    pub decimals: usize,
    /// Fixed colour scale; `None`: from the finite values.
    pub value_range: Option<(f64, f64)>,
    /// Pixel size used by [`Figure::to_svg`].
    pub size: (u32, u32),
    /// Cells (row, column) outlined, e.g. where a recording was made.
    pub marked: Vec<(usize, usize)>,
    /// Cells outlined in a second colour, e.g. where the next recording is advised.
    pub advised: Vec<(usize, usize)>,
}

impl HeatMap {
    /// A sweep's validation fit % over first × second hidden-layer sizes (the paper's Fig. 12), with one-layer
    /// networks in the first column; `None` when the grid has no one- or two-layer entries. Validation,
    /// not test: the picture is what one chooses an architecture from.
    pub fn of_sweep(rows: &[SweepRow]) -> Option<HeatMap> {
        let shallow: Vec<&SweepRow> = rows.iter().filter(|r| matches!(r.hidden.len(), 1 | 2)).collect();
        if shallow.is_empty() {
            return None;
        }
        let mut firsts: Vec<usize> = shallow.iter().map(|r| r.hidden[0]).collect();
        firsts.sort_unstable();
        firsts.dedup();
        let mut seconds: Vec<usize> = shallow.iter().filter_map(|r| r.hidden.get(1).copied()).collect();
        seconds.sort_unstable();
        seconds.dedup();
        // Column 0: a single hidden layer; then one column per second-layer size.
        let cols = seconds.len() + 1;
        let mut values = vec![f64::NAN; firsts.len() * cols];
        for r in &shallow {
            let row = firsts.binary_search(&r.hidden[0]).expect("collected above");
            let col = match r.hidden.get(1) {
                None => 0,
                Some(s) => 1 + seconds.binary_search(s).expect("collected above"),
            };
            values[row * cols + col] = r.validation_fit_percent;
        }
        let mut col_labels = vec!["none".to_string()];
        col_labels.extend(seconds.iter().map(usize::to_string));
        let row_labels = firsts.iter().map(usize::to_string).collect();
        Some(
            HeatMap::new(
                "Validation fit % by hidden-layer sizes (best of restarts)",
                "hidden layer 2 size (none: one hidden layer)",
                "hidden layer 1 size",
                col_labels,
                row_labels,
                values,
            )
            .value_label("fit %")
            .decimals(1),
        )
    }

    /// A heat map of `values` (row-major, `row_labels.len() × col_labels.len()`).
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        col_labels: Vec<String>,
        row_labels: Vec<String>,
        values: Vec<f64>,
    ) -> HeatMap {
        HeatMap {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            col_labels,
            row_labels,
            values,
            value_label: String::new(),
            decimals: 1,
            value_range: None,
            size: (760, 520),
            marked: Vec::new(),
            advised: Vec::new(),
        }
    }

    /// Outlines these cells (row, column).
    pub fn mark(mut self, cells: Vec<(usize, usize)>) -> HeatMap {
        self.marked = cells;
        self
    }

    /// Outlines these cells (row, column) in blue, inset within [`HeatMap::mark`]'s red.
    pub fn advise(mut self, cells: Vec<(usize, usize)>) -> HeatMap {
        self.advised = cells;
        self
    }

    pub fn value_label(mut self, label: impl Into<String>) -> HeatMap {
        self.value_label = label.into();
        self
    }

    pub fn decimals(mut self, decimals: usize) -> HeatMap {
        self.decimals = decimals;
        self
    }

    pub fn value_range(mut self, lo: f64, hi: f64) -> HeatMap {
        self.value_range = Some((lo, hi));
        self
    }

    pub fn size(mut self, width: u32, height: u32) -> HeatMap {
        self.size = (width, height);
        self
    }

    /// The value at row `r`, column `c`.
    pub fn get(&self, r: usize, c: usize) -> f64 {
        self.values[r * self.col_labels.len() + c]
    }

    fn range(&self) -> Result<(f64, f64), PlotError> {
        let (rows, cols) = (self.row_labels.len(), self.col_labels.len());
        if rows * cols != self.values.len() {
            return Err(PlotError::GridShape {
                figure: self.title.clone(),
                rows,
                cols,
                values: self.values.len(),
            });
        }
        if let Some(r) = self.value_range {
            return Ok(r);
        }
        let (lo, hi) = self
            .values
            .iter()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        if lo > hi {
            return Err(PlotError::Empty {
                figure: self.title.clone(),
                reason: "no finite value".into(),
            });
        }
        Ok(if hi > lo { (lo, hi) } else { (lo - 0.5, hi + 0.5) })
    }
}

/// Viridis, sampled at 9 stops and interpolated linearly; `t` in [0, 1].
pub(crate) fn viridis(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 } * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + f * (f64::from(b) - f64::from(a))).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Black on light cells, white on dark ones.
fn text_color(c: RGBColor) -> RGBColor {
    let luminance = 0.2126 * f64::from(c.0) + 0.7152 * f64::from(c.1) + 0.0722 * f64::from(c.2);
    if luminance > 140.0 {
        BLACK
    } else {
        WHITE
    }
}

impl sealed::Render for HeatMap {
    fn render<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let (lo, hi) = self.range()?;
        let (rows, cols) = (self.row_labels.len(), self.col_labels.len());
        clear(root)?;
        let (width, _) = root.dim_in_pixel();
        let titled = root
            .titled(&self.title, ("sans-serif", 18))
            .map_err(render_error)?;
        let (grid_area, bar_area) = titled.split_horizontally(width.saturating_sub(110));

        let longest = self
            .row_labels
            .iter()
            .map(|l| l.chars().count())
            .max()
            .unwrap_or(1) as u32;
        let mut chart = ChartBuilder::on(&grid_area)
            .margin(10)
            .x_label_area_size(44)
            .y_label_area_size(34 + 8 * longest)
            .build_cartesian_2d(0.0..cols as f64, 0.0..rows as f64)
            .map_err(render_error)?;
        // Category labels are drawn below at the cell centres, so the mesh draws axes and titles only.
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(0)
            .y_labels(0)
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(render_error)?;

        let label_font = ("sans-serif", 13).into_font();
        for (c, label) in self.col_labels.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(c as f64 + 0.5, 0.0));
            let style = label_font
                .clone()
                .color(&BLACK)
                .pos(Pos::new(HPos::Center, VPos::Top));
            root.draw(&Text::new(label.as_str(), (x, y + 6), style))
                .map_err(render_error)?;
        }
        for (r, label) in self.row_labels.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(0.0, r as f64 + 0.5));
            let style = label_font
                .clone()
                .color(&BLACK)
                .pos(Pos::new(HPos::Right, VPos::Center));
            root.draw(&Text::new(label.as_str(), (x - 6, y), style))
                .map_err(render_error)?;
        }

        let centred = Pos::new(HPos::Center, VPos::Center);
        for r in 0..rows {
            for c in 0..cols {
                let v = self.get(r, c);
                if !v.is_finite() {
                    continue;
                }
                let color = viridis((v - lo) / (hi - lo));
                let (x, y) = (c as f64, r as f64);
                let text = format!("{v:.*}", self.decimals);
                let style = label_font.clone().color(&text_color(color)).pos(centred);
                chart
                    .draw_series([Rectangle::new([(x, y), (x + 1.0, y + 1.0)], color.filled())])
                    .map_err(render_error)?;
                chart
                    .draw_series([Text::new(text, (x + 0.5, y + 0.5), style)])
                    .map_err(render_error)?;
            }
        }

        let outlines = self
            .marked
            .iter()
            .map(|cell| (cell, RED, 0.06))
            .chain(self.advised.iter().map(|cell| (cell, BLUE, 0.18)));
        for (&(r, c), colour, inset) in outlines.filter(|((r, c), ..)| *r < rows && *c < cols) {
            let (x, y) = (c as f64, r as f64);
            chart
                .draw_series([Rectangle::new(
                    [(x + inset, y + inset), (x + 1.0 - inset, y + 1.0 - inset)],
                    colour.stroke_width(3),
                )])
                .map_err(render_error)?;
        }

        // Colour bar: a vertical gradient with its own value axis.
        let mut bar = ChartBuilder::on(&bar_area)
            .margin_top(10)
            .margin_bottom(54)
            .margin_right(8)
            .caption(&self.value_label, ("sans-serif", 13))
            .y_label_area_size(48)
            .build_cartesian_2d(0.0..1.0, lo..hi)
            .map_err(render_error)?;
        let tick = |v: &f64| format_tick(*v, hi - lo);
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(6)
            .y_label_formatter(&tick)
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(render_error)?;
        let steps = 64;
        bar.draw_series((0..steps).map(|k| {
            let (a, b) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
            let color = viridis((a + b) / 2.0);
            Rectangle::new(
                [(0.0, lo + a * (hi - lo)), (1.0, lo + b * (hi - lo))],
                color.filled(),
            )
        }))
        .map_err(render_error)?;
        Ok(())
    }
}

impl Figure for HeatMap {
    fn size(&self) -> (u32, u32) {
        self.size
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heat_map_places_one_and_two_layer_rows() {
        let row = |hidden: Vec<usize>, fit: f64| SweepRow {
            architecture: crate::correctors::ann::architecture_label(&hidden),
            hidden,
            best_validation_mse: 0.1,
            train_fit_percent: fit,
            validation_fit_percent: fit,
            test_fit_percent: fit,
            epochs: 1,
            best_restart: 0,
            seconds: 0.0,
        };
        let map =
            HeatMap::of_sweep(&[row(vec![2], 50.0), row(vec![3, 4], 70.0), row(vec![3], 60.0)]).unwrap();
        assert_eq!(map.row_labels, vec!["2", "3"]);
        assert_eq!(map.col_labels, vec!["none", "4"]);
        assert_eq!(map.get(0, 0), 50.0);
        assert!(map.get(0, 1).is_nan());
        assert_eq!(map.get(1, 0), 60.0);
        assert_eq!(map.get(1, 1), 70.0);
    }

    fn sweep() -> HeatMap {
        let sizes = [2, 4, 6, 8, 10];
        let labels: Vec<String> = sizes.iter().map(|s| s.to_string()).collect();
        let mut values: Vec<f64> = (0..25).map(|i| 40.0 + i as f64).collect();
        values[3] = f64::NAN;
        values[17] = f64::NAN;
        HeatMap::new(
            "fit % by architecture",
            "hidden layer 2 size",
            "hidden layer 1 size",
            labels.clone(),
            labels,
            values,
        )
        .value_label("fit %")
    }

    #[test]
    fn nan_cells_are_blank_and_numbers_printed() {
        let svg = sweep().to_svg().unwrap();
        assert!(!svg.to_lowercase().contains("nan"));
        let texts = svg_texts(&svg);
        let cells: Vec<&String> = texts.iter().filter(|t| t.ends_with(".0")).collect();
        assert_eq!(cells.len(), 23, "{cells:?}");
        assert!(!texts.contains(&"43.0".to_string()) && !texts.contains(&"57.0".to_string()));
        for text in [
            "hidden layer 1 size",
            "hidden layer 2 size",
            "fit %",
            "fit % by architecture",
            "2",
            "10",
        ] {
            assert!(texts.iter().any(|t| t == text), "{text} missing in {texts:?}");
        }
        // The lowest and highest finite values take the ends of the colour map.
        assert_eq!(svg.matches("fill=\"#440154\"").count(), 1);
        assert_eq!(svg.matches("fill=\"#FDE725\"").count(), 1);
        // 23 cells + 64 colour-bar steps + background: NaN cells draw no rectangle.
        assert_eq!(svg.matches("<rect").count(), 23 + 64 + 1);
    }

    #[test]
    fn one_cell() {
        let h = HeatMap::new("one", "b", "a", vec!["x".into()], vec!["y".into()], vec![5.0]);
        let texts = svg_texts(&h.to_svg().unwrap());
        assert!(
            ["x", "y", "5.0"].iter().all(|t| texts.iter().any(|s| s == t)),
            "{texts:?}"
        );
    }

    #[test]
    fn png_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.png");
        sweep().to_png(&path, 500, 400).unwrap();
        let img = image::open(&path).unwrap();
        assert_eq!((img.width(), img.height()), (500, 400));
        let mut bad = sweep();
        bad.values.pop();
        assert!(matches!(
            bad.to_svg(),
            Err(PlotError::GridShape {
                rows: 5,
                cols: 5,
                values: 24,
                ..
            })
        ));
        let mut empty = sweep();
        empty.values.iter_mut().for_each(|v| *v = f64::NAN);
        assert!(matches!(empty.to_svg(), Err(PlotError::Empty { .. })));
    }

    #[test]
    fn colour_map_ends_and_contrast() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(2.0), viridis(1.0));
        assert_eq!(text_color(viridis(0.0)), WHITE);
        assert_eq!(text_color(viridis(1.0)), BLACK);
    }
}
