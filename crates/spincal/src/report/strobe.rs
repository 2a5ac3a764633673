//! Stroboscopic speed-check discs for record players (SPEC §2).
//!
//! Mains light flickers at twice the mains frequency, so a disc with N equal bars looks still when it
//! turns by one bar pitch per flash: N = 2 · f_mains · 60 / rpm (180 bars for 33⅓ rpm at 50 Hz). When
//! N is not an integer (45 rpm at 50 Hz gives 133.33) the disc gets the nearest integer and the ring
//! reports the speed at which that disc stands still, or, with [`Rounding::Exact`], building fails.
//!
//! The SVG is true to size: its width and height are in millimetres and user units are millimetres,
//! so it prints at the right size at 100 % scale.

use std::fmt::Write as _;

/// Diameter of the centre hole: a standard 7.24 mm (0.285 in) turntable spindle.
pub const SPINDLE_DIAMETER_MM: f64 = 7.24;

/// A bar count is taken as an integer when it is this close to one (relative): typing 33.333 for
/// 33⅓ rpm gives 180.0018 bars, which is 180.
pub const INTEGER_TOLERANCE: f64 = 1e-4;

/// Narrowest bar, at a ring's inner edge, that a home printer draws cleanly.
pub const MIN_BAR_WIDTH_MM: f64 = 0.2;

/// What to do when N = 2·f·60/rpm is not an integer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rounding {
    /// Use the nearest integer and report the speed error that follows.
    #[default]
    Nearest,
    /// Fail with [`StrobeError::NonIntegerBars`].
    Exact,
}

/// Everything that can be wrong with a disc request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StrobeError {
    #[error("rpm must be positive and finite, got {0}")]
    BadRpm(f64),
    #[error("mains frequency must be positive and finite, got {0} Hz")]
    BadMains(f64),
    #[error(
        "disc diameter {diameter_mm} mm is too small: at least {min_mm} mm is needed for {rings} ring(s)"
    )]
    BadDiameter {
        diameter_mm: f64,
        min_mm: f64,
        rings: usize,
    },
    #[error("no rpm given")]
    NoRings,
    #[error(
        "{rpm} rpm at {mains_hz} Hz needs {exact:.4} bars, not an integer; {nearest} bars stand still at \
         {nearest_rpm:.4} rpm ({error_percent:+.3} %)"
    )]
    NonIntegerBars {
        rpm: f64,
        mains_hz: f64,
        exact: f64,
        nearest: u32,
        nearest_rpm: f64,
        error_percent: f64,
    },
    #[error("{rpm} rpm at {mains_hz} Hz needs {bars} bars, fewer than 2")]
    TooFewBars { rpm: f64, mains_hz: f64, bars: u32 },
    #[error(
        "{rpm} rpm needs {bars} bars: {width_mm:.3} mm wide at the ring's inner edge, narrower than \
         {min_mm} mm; use a larger diameter"
    )]
    BarsTooThin {
        rpm: f64,
        bars: u32,
        width_mm: f64,
        min_mm: f64,
    },
}

/// Exact (real) number of bars that stand still at `rpm` under light flickering at 2·`mains_hz`.
pub fn exact_bar_count(rpm: f64, mains_hz: f64) -> f64 {
    2.0 * mains_hz * 60.0 / rpm
}

/// Speed in rpm at which a disc of `bars` bars stands still under `mains_hz` light.
pub fn still_rpm(bars: u32, mains_hz: f64) -> f64 {
    2.0 * mains_hz * 60.0 / f64::from(bars)
}

/// One ring of bars, for one nominal speed.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StrobeRing {
    /// The speed asked for.
    pub rpm: f64,
    /// 2·f·60/rpm, before rounding.
    pub exact_bars: f64,
    /// Bars drawn.
    pub bars: u32,
    /// Speed at which the drawn ring stands still.
    pub still_rpm: f64,
    /// 100 · (still_rpm − rpm) / rpm: tiny when `exact_bars` was an integer (33.333 typed for 33⅓).
    pub rpm_error_percent: f64,
    /// Whether `exact_bars` was an integer (within [`INTEGER_TOLERANCE`]).
    pub exact: bool,
    /// Inner and outer radius of the ring on the disc.
    pub inner_radius_mm: f64,
    pub outer_radius_mm: f64,
    /// Width of one bar at the ring's inner edge.
    pub bar_width_mm: f64,
}

/// A printable disc with one ring per speed, outermost ring first.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StrobeDisc {
    pub mains_hz: f64,
    pub diameter_mm: f64,
    pub rings: Vec<StrobeRing>,
}

/// Gap between neighbouring rings and at the rim.
const RING_GAP_MM: f64 = 1.5;
/// Radial width of a ring at most.
const MAX_RING_WIDTH_MM: f64 = 12.0;
/// Radius kept free around the spindle for the printed text.
const TEXT_RADIUS_MM: f64 = 24.0;

impl StrobeDisc {
    /// Lays out a disc of `diameter_mm` with one ring per entry of `rpms` (outermost first).
    pub fn new(
        rpms: &[f64],
        mains_hz: f64,
        diameter_mm: f64,
        rounding: Rounding,
    ) -> Result<Self, StrobeError> {
        if rpms.is_empty() {
            return Err(StrobeError::NoRings);
        }
        if !(mains_hz.is_finite() && mains_hz > 0.0) {
            return Err(StrobeError::BadMains(mains_hz));
        }
        let min_mm = 2.0 * (TEXT_RADIUS_MM + rpms.len() as f64 * (4.0 + RING_GAP_MM) + RING_GAP_MM);
        if !(diameter_mm.is_finite() && diameter_mm >= min_mm) {
            return Err(StrobeError::BadDiameter {
                diameter_mm,
                min_mm,
                rings: rpms.len(),
            });
        }
        let outer = diameter_mm / 2.0 - RING_GAP_MM;
        let width =
            ((outer - TEXT_RADIUS_MM) / rpms.len() as f64 - RING_GAP_MM).clamp(4.0, MAX_RING_WIDTH_MM);
        let mut rings = Vec::with_capacity(rpms.len());
        for (i, &rpm) in rpms.iter().enumerate() {
            if !(rpm.is_finite() && rpm > 0.0) {
                return Err(StrobeError::BadRpm(rpm));
            }
            let exact_bars = exact_bar_count(rpm, mains_hz);
            let nearest = exact_bars.round();
            if nearest < 2.0 {
                return Err(StrobeError::TooFewBars {
                    rpm,
                    mains_hz,
                    bars: nearest as u32,
                });
            }
            let bars = nearest as u32;
            let exact = (exact_bars - nearest).abs() <= INTEGER_TOLERANCE * exact_bars;
            let still = still_rpm(bars, mains_hz);
            let rpm_error_percent = 100.0 * (still - rpm) / rpm;
            if !exact && rounding == Rounding::Exact {
                return Err(StrobeError::NonIntegerBars {
                    rpm,
                    mains_hz,
                    exact: exact_bars,
                    nearest: bars,
                    nearest_rpm: still,
                    error_percent: rpm_error_percent,
                });
            }
            let outer_radius_mm = outer - i as f64 * (width + RING_GAP_MM);
            let inner_radius_mm = outer_radius_mm - width;
            let bar_width_mm = std::f64::consts::PI * inner_radius_mm / f64::from(bars);
            if bar_width_mm < MIN_BAR_WIDTH_MM {
                return Err(StrobeError::BarsTooThin {
                    rpm,
                    bars,
                    width_mm: bar_width_mm,
                    min_mm: MIN_BAR_WIDTH_MM,
                });
            }
            rings.push(StrobeRing {
                rpm,
                exact_bars,
                bars,
                still_rpm: still,
                rpm_error_percent,
                exact,
                inner_radius_mm,
                outer_radius_mm,
                bar_width_mm,
            });
        }
        Ok(StrobeDisc {
            mains_hz,
            diameter_mm,
            rings,
        })
    }

    /// The disc as a standalone SVG document, sized in millimetres. Every bar is one
    /// `<path class="bar">`; the rim, the spindle hole and the text are drawn too.
    pub fn to_svg(&self) -> String {
        let r = self.diameter_mm / 2.0;
        let side = self.diameter_mm + 2.0;
        let mut s = String::with_capacity(200 * self.rings.iter().map(|g| g.bars as usize).sum::<usize>());
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" data-generator="spincal" width="{side}mm" height="{side}mm" viewBox="{o} {o} {side} {side}">"#,
            o = -side / 2.0
        );
        let _ = writeln!(
            s,
            "<title>Stroboscopic disc, {} Hz mains, {}</title>",
            fmt_num(self.mains_hz),
            self.rings
                .iter()
                .map(|g| format!("{} rpm", fmt_rpm(g.rpm)))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let _ = writeln!(
            s,
            r##"<circle cx="0" cy="0" r="{r}" fill="#fff" stroke="#000" stroke-width="0.3"/>"##
        );
        for ring in &self.rings {
            let _ = writeln!(
                s,
                r##"<g class="ring" data-rpm="{}" data-bars="{}" fill="#000">"##,
                ring.rpm, ring.bars
            );
            let pitch = std::f64::consts::TAU / f64::from(ring.bars);
            let (ri, ro) = (ring.inner_radius_mm, ring.outer_radius_mm);
            for b in 0..ring.bars {
                let a0 = f64::from(b) * pitch;
                let a1 = a0 + pitch / 2.0;
                let p = |rad: f64, a: f64| (rad * a.sin(), -rad * a.cos());
                let (x0, y0) = p(ro, a0);
                let (x1, y1) = p(ro, a1);
                let (x2, y2) = p(ri, a1);
                let (x3, y3) = p(ri, a0);
                let _ = writeln!(
                    s,
                    r#"<path class="bar" d="M{x0:.4} {y0:.4}A{ro:.4} {ro:.4} 0 0 1 {x1:.4} {y1:.4}L{x2:.4} {y2:.4}A{ri:.4} {ri:.4} 0 0 0 {x3:.4} {y3:.4}Z"/>"#
                );
            }
            s.push_str("</g>\n");
        }
        // Spindle hole with a cross to centre the punch.
        let h = SPINDLE_DIAMETER_MM / 2.0;
        let _ = writeln!(
            s,
            r##"<circle cx="0" cy="0" r="{h}" fill="#fff" stroke="#000" stroke-width="0.25"/><path d="M{a} 0H{b}M0 {a}V{b}" stroke="#000" stroke-width="0.15"/>"##,
            a = -h - 1.5,
            b = h + 1.5
        );
        let mut lines = vec![format!("{} Hz mains", fmt_num(self.mains_hz))];
        for (k, ring) in self.rings.iter().enumerate() {
            let n = self.rings.len();
            let place = match k {
                _ if n == 1 => String::new(),
                0 => "outer: ".to_string(),
                k if k + 1 == n => "inner: ".to_string(),
                k => format!("ring {}: ", k + 1),
            };
            let mut line = format!("{place}{} rpm, {} bars", fmt_rpm(ring.rpm), ring.bars);
            if !ring.exact {
                let _ = write!(
                    line,
                    " (still at {:.3}, {:+.2} %)",
                    ring.still_rpm, ring.rpm_error_percent
                );
            }
            lines.push(line);
        }
        lines.push(format!(
            "\u{2300} {} mm: print at 100 %",
            fmt_num(self.diameter_mm)
        ));
        let size = 2.4;
        let top = -h - 2.5 - size * 1.25 * (lines.len() as f64 - 1.0);
        for (i, line) in lines.iter().enumerate() {
            let y = if i + 1 == lines.len() {
                h + 2.5 + size
            } else {
                top + size * 1.25 * i as f64
            };
            let _ = writeln!(
                s,
                r#"<text x="0" y="{y:.3}" font-family="sans-serif" font-size="{size}" text-anchor="middle">{}</text>"#,
                xml_escape(line)
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

/// 33.333…, 33.33 and 100/3 print as 33⅓; 16.67 as 16⅔; others with up to 3 decimals.
fn fmt_rpm(rpm: f64) -> String {
    let thirds = rpm * 3.0;
    if (thirds - thirds.round()).abs() < 0.02 && thirds.round() % 3.0 != 0.0 {
        let whole = (thirds.round() / 3.0).floor();
        let frac = if thirds.round() % 3.0 == 1.0 {
            "\u{2153}"
        } else {
            "\u{2154}"
        };
        return format!("{whole}{frac}");
    }
    fmt_num(rpm)
}

fn fmt_num(v: f64) -> String {
    let t = format!("{v:.3}");
    t.trim_end_matches('0').trim_end_matches('.').to_string()
}

fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(rpm: f64, mains: f64) -> StrobeRing {
        StrobeDisc::new(&[rpm], mains, 120.0, Rounding::Nearest)
            .unwrap()
            .rings
            .remove(0)
    }

    #[test]
    fn bar_counts_of_the_usual_speeds() {
        let r = one(100.0 / 3.0, 50.0);
        assert_eq!((r.bars, r.exact), (180, true));
        assert!(r.rpm_error_percent.abs() < 1e-9);
        assert_eq!(one(33.333, 50.0).bars, 180);
        assert!(one(33.333, 50.0).exact);
        assert_eq!(one(100.0 / 3.0, 60.0).bars, 216);
        let r = one(45.0, 60.0);
        assert_eq!((r.bars, r.exact), (160, true));
    }

    #[test]
    fn non_integer_count_rounds_and_reports_the_speed_error() {
        let r = one(45.0, 50.0);
        assert!((r.exact_bars - 133.3333).abs() < 1e-3);
        assert_eq!(r.bars, 133);
        assert!(!r.exact);
        assert!((r.still_rpm - 6000.0 / 133.0).abs() < 1e-9);
        assert!(
            (r.rpm_error_percent - 0.2506).abs() < 1e-3,
            "{}",
            r.rpm_error_percent
        );
        let err = StrobeDisc::new(&[45.0], 50.0, 120.0, Rounding::Exact).unwrap_err();
        assert!(
            matches!(err, StrobeError::NonIntegerBars { nearest: 133, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("133.3333"), "{err}");
    }

    #[test]
    fn svg_has_one_wedge_per_bar_and_true_size() {
        let disc = StrobeDisc::new(&[100.0 / 3.0, 45.0], 50.0, 120.0, Rounding::Nearest).unwrap();
        let svg = disc.to_svg();
        assert_eq!(svg.matches(r#"<path class="bar""#).count(), 180 + 133);
        assert_eq!(svg.matches("<g class=\"ring\"").count(), 2);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains(r#"width="122mm""#), "{}", &svg[..200]);
        assert!(svg.contains("outer: 33\u{2153} rpm, 180 bars"));
        assert!(svg.contains("inner: 45 rpm, 133 bars (still at 45.113"));
        assert!(svg.contains("50 Hz mains"));
        // Rings do not overlap and stay on the disc, outside the text area.
        let (a, b) = (&disc.rings[0], &disc.rings[1]);
        assert!(a.outer_radius_mm <= 60.0 && b.outer_radius_mm < a.inner_radius_mm);
        assert!(b.inner_radius_mm >= TEXT_RADIUS_MM);
    }

    #[test]
    fn bad_requests_are_named() {
        assert_eq!(
            StrobeDisc::new(&[], 50.0, 120.0, Rounding::Nearest),
            Err(StrobeError::NoRings)
        );
        assert_eq!(
            StrobeDisc::new(&[-3.0], 50.0, 120.0, Rounding::Nearest),
            Err(StrobeError::BadRpm(-3.0))
        );
        assert!(matches!(
            StrobeDisc::new(&[33.3], 0.0, 120.0, Rounding::Nearest),
            Err(StrobeError::BadMains(_))
        ));
        assert!(matches!(
            StrobeDisc::new(&[33.3], 50.0, 30.0, Rounding::Nearest),
            Err(StrobeError::BadDiameter { .. })
        ));
        assert!(matches!(
            StrobeDisc::new(&[1.0], 50.0, 70.0, Rounding::Nearest),
            Err(StrobeError::BarsTooThin { bars: 6000, .. })
        ));
        assert!(matches!(
            StrobeDisc::new(&[10000.0], 50.0, 120.0, Rounding::Nearest),
            Err(StrobeError::TooFewBars { .. })
        ));
    }

    #[test]
    fn rpm_labels() {
        assert_eq!(fmt_rpm(33.333), "33\u{2153}");
        assert_eq!(fmt_rpm(100.0 / 6.0), "16\u{2154}");
        assert_eq!(fmt_rpm(45.0), "45");
        assert_eq!(fmt_rpm(78.26), "78.26");
    }
}
