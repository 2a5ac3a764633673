//! `spincal fit`: the turntable model fitted to one or more recordings.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use spincal::input::recording::STANDARD_GRAVITY;
use spincal::turntable::fit::{fit_turntable, FitOptions, RadiusPrior, TurntableFit};

use super::input::ReadArgs;
use super::values::{DriftArg, ObjectiveAxesArg};
use crate::ui::{self, Ui, UsageError};

/// The turntable fit's inputs and options: shared by `fit`, `calibrate` and `compare`.
#[derive(Args, Debug)]
pub struct TurntableArgs {
    /// Recordings (CSV); several are fitted jointly with shared sensor offsets.
    pub recordings: Vec<PathBuf>,
    #[command(flatten)]
    pub read: ReadArgs,
    /// The gyroscope from a second file, one per recording in order (read with the same flags):
    /// merged on time when it has a time column (interpolated onto the recording's times, the
    /// recording's samples outside its span dropped with a note; refused under half overlap),
    /// sample for sample when it has none (then as long as the recording).
    #[arg(long, value_name = "GYRO")]
    pub gyro_file: Vec<PathBuf>,
    /// Nominal speed, rpm: the spectral search looks within ±10 % of it.
    #[arg(long, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub rpm: Option<f64>,
    /// Radius measured with a ruler, m.
    #[arg(long, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub radius: Option<f64>,
    /// Standard uncertainty of --radius, m.
    #[arg(long, default_value_t = 0.002, requires = "radius", value_parser = super::values::positive, allow_negative_numbers = true)]
    pub radius_tol: f64,
    /// Fit a radius per recording (the sensor was moved between them).
    #[arg(long)]
    pub separate_radii: bool,
    /// Axes in the fit's objective (the paper uses x alone under drift). Not the axes a
    /// corrector corrects (`--correct-axes`).
    #[arg(long, value_enum, default_value = "xyz", alias = "axes")]
    pub objective_axes: ObjectiveAxesArg,
    /// Linear drift per axis.
    #[arg(long, value_enum, default_value = "fit")]
    pub drift: DriftArg,
    /// Hold the sensor offsets at zero (the paper's model).
    #[arg(long)]
    pub no_offsets: bool,
    /// Bounds to replace, SI units: name=lower:upper,… (names as printed).
    #[arg(long, value_name = "NAME=LO:HI,...")]
    pub bounds: Option<String>,
    /// Local gravity, m/s².
    #[arg(long, default_value_t = STANDARD_GRAVITY, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub gravity: f64,
    /// Sensor range, g (for the saturation check).
    #[arg(long, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub range_g: Option<f64>,
    /// Print the result as JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  spincal fit rec33.csv\n  \
                        spincal fit rec33.csv rec45.csv --radius 0.10 --radius-tol 0.005 -o fit.json\n  \
                        spincal fit rec.csv --radius 0.10 --reference-csv ref.csv   # then: spincal train --data rec.csv --reference ref.csv\n  \
                        spincal fit rec.csv --objective-axes x --bounds tilt=0:0.1,radius=0.05:0.15")]
pub struct FitArgs {
    #[command(flatten)]
    pub turntable: TurntableArgs,
    /// Write the full result as JSON here.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write the fitted reference acceleration (the turntable's physics, no sensor errors) as CSV
    /// (t_s,ax_g,ay_g,az_g), one file per recording in order: the input of `train` and `sweep`.
    #[arg(long, value_name = "REF.csv", num_args = 1..)]
    pub reference_csv: Vec<PathBuf>,
}

/// Parses `name=lo:hi,name=lo:hi` (the library's reader, worded for the flag).
pub fn parse_bounds(text: &str) -> Result<Vec<(String, f64, f64)>, UsageError> {
    spincal::turntable::fit::parse_bounds(text).map_err(|e| {
        UsageError(format!(
            "--bounds '{}': expected name=lower:upper, e.g. radius=0.05:0.15",
            e.item
        ))
    })
}

impl TurntableArgs {
    pub fn options(&self) -> anyhow::Result<FitOptions> {
        Ok(FitOptions {
            axes: self.objective_axes.into(),
            drift: self.drift.into(),
            gravity_mps2: self.gravity,
            rpm_hint: self.rpm,
            radius: self.radius.map(|value_m| RadiusPrior {
                value_m,
                tolerance_m: self.radius_tol,
            }),
            shared_radius: !self.separate_radii,
            fit_offsets: !self.no_offsets,
            bounds: match &self.bounds {
                Some(text) => parse_bounds(text)?,
                None => Vec::new(),
            },
            range_mps2: self.range_g.map(|g| g * STANDARD_GRAVITY),
            ..FitOptions::default()
        })
    }
}

pub fn run(args: FitArgs, ui: Ui) -> anyhow::Result<()> {
    super::require_recordings(&args.turntable.recordings)?;
    let options = args.turntable.options()?;
    super::check_paths(
        &args.turntable.inputs(),
        args.output.iter().chain(&args.reference_csv),
    )?;
    if !args.reference_csv.is_empty() && args.reference_csv.len() != args.turntable.recordings.len() {
        return Err(UsageError(format!(
            "--reference-csv names {} file(s) for {} recording(s): give one per recording, in order",
            args.reference_csv.len(),
            args.turntable.recordings.len()
        ))
        .into());
    }
    let recordings = args.turntable.read_recordings()?;
    let refs: Vec<_> = recordings.iter().collect();
    let spinner = ui.spinner("fitting");
    let fit = fit_turntable(&refs, &options, &|p| {
        spinner.set_message(ui::iteration_message(&p))
    })?;
    spinner.finish_and_clear();
    for (k, path) in args.reference_csv.iter().enumerate() {
        let rec = &recordings[k];
        fit.reference_recording(k, rec)
            .write_csv_path(path, spincal::input::recording::AccelUnit::G)
            .with_context(|| format!("writing the reference of {}", rec.source.name))?;
    }
    if let Some(path) = &args.output {
        // Marked as spincal's, so that a later run replaces it (and keeps anyone else's file).
        super::write_text(path, &fit.to_json_file()?)?;
    }
    if args.turntable.json {
        return ui::print_json(&fit);
    }
    ui::print(&render(&fit))
}

fn text_note_units(text: &mut String) {
    text.push_str("(angles in degrees; drift as the change in g over its recording, g/rec; SI otherwise)\n");
}

/// The human-readable report of a fit.
pub fn render(fit: &TurntableFit) -> String {
    let mut text = String::new();
    for (k, r) in fit.recordings.iter().enumerate() {
        text.push_str(&format!(
            "recording {}: {} — {} samples, {:.1} s at {:.2} Hz\n  rotation from the spectrum: {:.3} rpm = {:.5} rad/s (peak {:.0}× the median)\n",
            k + 1,
            r.name,
            r.inspection.samples,
            r.inspection.duration_s,
            r.inspection.sample_rate_hz,
            r.rate.rpm,
            r.rate.omega_radps,
            r.rate.peak_to_median
        ));
        for w in r.inspection.warnings(&r.name) {
            text.push_str(&format!("  warning: {}\n", crate::ui::in_flags(&w)));
        }
    }
    for cut in fit.split_recordings.iter().filter_map(|s| s.sentence()) {
        text.push_str(&format!("note: {cut}\n"));
    }
    text.push_str(&format!(
        "\nparameter        value          std. error     unit    bound hit\n{}\n",
        "-".repeat(66)
    ));
    text_note_units(&mut text);
    for p in &fit.params {
        let (value, se, unit) = fit.display_value(p);
        let se = match se {
            Some(se) => format!("{se:<14.6e}"),
            None => format!("{:<14}", "not determined"),
        };
        text.push_str(&format!(
            "{:<16} {:<14.8} {} {:<7} {}\n",
            p.name,
            value,
            se,
            unit,
            if p.at_bound { "yes" } else { "no" }
        ));
    }
    for (k, r) in fit.recordings.iter().enumerate() {
        let rpm = r.session.omega_radps * 60.0 / (2.0 * std::f64::consts::PI);
        text.push_str(&format!(
            "\nrecording {}: fitted ω = {:.4} rpm, {}; model fit x {:.2} %, y {:.2} %, z {:.2} %; residual RMS {:.2e} {:.2e} {:.2e} m/s²",
            k + 1,
            rpm,
            r.session.direction.describe(),
            r.fit_percent[0],
            r.fit_percent[1],
            r.fit_percent[2],
            r.residual_rms_mps2[0],
            r.residual_rms_mps2[1],
            r.residual_rms_mps2[2]
        ));
    }
    text.push('\n');
    for d in fit.drift.iter().filter(|d| d.significant) {
        text.push_str(&format!(
            "drift detected: recording {} axis {} moves {:+.4} g (± {:.4} g) over the recording\n",
            d.recording + 1,
            d.axis,
            d.change_mps2 / STANDARD_GRAVITY,
            d.std_error_mps2 / STANDARD_GRAVITY
        ));
    }
    if let Some(remedy) = &fit.remedy {
        text.push_str(&format!("\nnote: {remedy}\n"));
    }
    text.push_str(&format!(
        "\nweighted SSE: {:.6e} after Nelder–Mead ({} iterations), {:.6e} after Levenberg–Marquardt ({} iterations, {})\n",
        fit.cost_nelder_mead, fit.nelder_mead_iterations, fit.cost_final, fit.lm_iterations, fit.lm_stop.describe()
    ));
    text
}
