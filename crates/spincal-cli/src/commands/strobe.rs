//! `spincal strobe`: draws a printable stroboscopic disc for checking a turntable's speed.

use std::path::PathBuf;

use spincal::report::strobe::{Rounding, StrobeDisc};

use crate::ui::{self, UsageError};

#[derive(clap::Args)]
pub struct Args {
    /// Speed in rpm, one ring each, outermost first (repeat for more rings). Accepts 33.333, 100/3 or 33+1/3.
    #[arg(long, required = true, value_parser = parse_rpm)]
    rpm: Vec<f64>,
    /// Mains frequency in Hz (lights flicker at twice this).
    #[arg(long, default_value_t = 50.0)]
    mains: f64,
    /// Disc diameter in millimetres.
    #[arg(long, default_value_t = 120.0)]
    diameter_mm: f64,
    /// Where to write the SVG.
    #[arg(short, long, default_value = "strobe.svg")]
    output: PathBuf,
    /// Fail instead of rounding when a speed needs a non-integer number of bars. A count within
    /// 1 part in 10⁴ of an integer counts as exact, so 33.333 is taken as 33⅓ rpm (180 bars at
    /// 50 Hz) and passes; 45 rpm at 50 Hz (133.33 bars) fails.
    #[arg(long)]
    exact: bool,
    /// Print a JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Parses `33.333`, `100/3` or `33+1/3`.
fn parse_rpm(text: &str) -> Result<f64, String> {
    let fraction = |t: &str| -> Option<f64> {
        match t.split_once('/') {
            Some((n, d)) => Some(n.trim().parse::<f64>().ok()? / d.trim().parse::<f64>().ok()?),
            None => t.trim().parse().ok(),
        }
    };
    let value = match text.split_once('+') {
        Some((whole, frac)) => whole
            .trim()
            .parse::<f64>()
            .ok()
            .zip(fraction(frac))
            .map(|(w, f)| w + f),
        None => fraction(text),
    };
    match value {
        Some(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "'{text}' is not a positive speed (e.g. 33.333, 100/3, 33+1/3, 45)"
        )),
    }
}

#[derive(serde::Serialize)]
struct Report<'a> {
    output: String,
    #[serde(flatten)]
    disc: &'a StrobeDisc,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let rounding = if args.exact {
        Rounding::Exact
    } else {
        Rounding::Nearest
    };
    let disc = StrobeDisc::new(&args.rpm, args.mains, args.diameter_mm, rounding).map_err(|e| {
        use spincal::report::strobe::StrobeError as E;
        match e {
            E::NonIntegerBars { .. } => anyhow::Error::new(e),
            other => anyhow::Error::new(UsageError(other.to_string())),
        }
    })?;
    super::check_outputs(&[], &[args.output.as_path()])?;
    super::write_text(&args.output, &disc.to_svg())?;
    if args.json {
        return ui::print_json(&Report {
            output: args.output.display().to_string(),
            disc: &disc,
        });
    }
    let mut text = String::new();
    for ring in &disc.rings {
        text += &format!("{:.4} rpm at {} Hz: {} bars", ring.rpm, disc.mains_hz, ring.bars);
        if !ring.exact {
            text += &format!(
                " (exactly {:.4} needed; {} bars stand still at {:.4} rpm, {:+.3} %)",
                ring.exact_bars, ring.bars, ring.still_rpm, ring.rpm_error_percent
            );
        }
        text.push('\n');
    }
    text += &format!(
        "wrote {} ({} mm disc; print at 100 % scale)\n",
        args.output.display(),
        disc.diameter_mm
    );
    ui::print(&text)
}

#[cfg(test)]
mod tests {
    use super::parse_rpm;

    #[test]
    fn rpm_forms() {
        assert_eq!(parse_rpm("45"), Ok(45.0));
        assert!((parse_rpm("100/3").unwrap() - 100.0 / 3.0).abs() < 1e-12);
        assert!((parse_rpm("33+1/3").unwrap() - 100.0 / 3.0).abs() < 1e-12);
        assert!(parse_rpm("-3").is_err());
        assert!(parse_rpm("1/0").is_err());
        assert!(parse_rpm("fast").is_err());
    }
}
