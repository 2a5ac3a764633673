//! `spincal allan`: Allan deviation, noise density and bias instability of a still recording.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;
use spincal::allan::{
    analyse_still, write_curve_csv, AllanAnalysis, AllanSettings, StillNoise, StillNoiseError,
};
use spincal::input::gyro_file::gyro_columns;
use spincal::report::allan::allan_figure;
use spincal::report::plot::Figure;

use super::{format_line, InputArgs};
use crate::ui::{self, UsageError};

#[derive(Args, Debug)]
pub struct AllanArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Apply this static calibration (from `spincal static -o`) to raw readings first, and its
    /// gyro model, when it has one, to the gyro.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Use only the longest still interval (found as `spincal static` does) instead of the whole file.
    #[arg(long)]
    pub still: bool,
    /// Draw the log-log curve: SVG at this path and a PNG beside it (same name, .png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write the curve as CSV (tau_s, adev_x, adev_y, adev_z).
    #[arg(long)]
    pub curve: Option<PathBuf>,
    /// Write a simulator sensor profile (JSON).
    #[arg(long)]
    pub profile: Option<PathBuf>,
    /// Write Kalibr's IMU noise file (imu.yaml: noise densities and random walks of the
    /// accelerometer and the gyroscope, the rate, the topic). Needs gyro columns.
    #[arg(long)]
    pub kalibr: Option<PathBuf>,
    /// The gyroscope from a second file (imu_tk's layout `t gx gy gz`, or gyro columns), read with
    /// the same flags, when the recording has no gyro columns: merged on time when it has a time
    /// column (the recording's samples outside its span dropped, with a note), sample for sample
    /// when it has none. Raw counts need a --calibration with a gyro model (`spincal static ACC
    /// --gyro-file GYRO -o cal.json`).
    #[arg(long)]
    pub gyro_file: Option<PathBuf>,
    /// The ROS topic written into the Kalibr file.
    #[arg(long, default_value = "/imu0")]
    pub kalibr_topic: String,
    /// Points per decade of τ.
    #[arg(long, default_value_t = 10)]
    pub per_decade: usize,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Report<'a> {
    file: String,
    #[serde(flatten)]
    analysis: &'a AllanAnalysis,
}

pub fn run(args: &AllanArgs, ui: &ui::Ui) -> anyhow::Result<()> {
    let png = args.plot.as_ref().map(|p| p.with_extension("png"));
    let outputs: Vec<&std::path::Path> = [&args.plot, &png, &args.curve, &args.profile, &args.kalibr]
        .into_iter()
        .flatten()
        .map(|p| p.as_path())
        .collect();
    let mut inputs = vec![args.input.rec.as_path()];
    inputs.extend(args.gyro_file.as_deref());
    inputs.extend(args.calibration.as_deref());
    super::check_outputs(&inputs, &outputs)?;
    let mut loaded = args.input.load(ui)?;
    let name = args.input.rec.display().to_string();
    let calibration = match &args.calibration {
        Some(path) => Some((
            spincal::correctors::model_file::CorrectorFile::read_path(path)?,
            path.display().to_string(),
        )),
        None => None,
    };
    let options = args.input.read.options()?;
    let (gyro, note) = gyro_columns(args.gyro_file.as_deref(), &mut loaded, &name, &options)?;
    super::gyro_file::print_gyro_note(note);
    if let (Some(_), None) = (&args.kalibr, &gyro) {
        return Err(UsageError(format!(
            "{name}: no gyro columns, and Kalibr's file needs the gyroscope's noise too (pass --columns t,ax,ay,az,gx,gy,gz)"
        ))
        .into());
    }
    let settings = AllanSettings {
        per_decade: args.per_decade,
        longest_still: args.still,
        ..AllanSettings::default()
    };
    let bar = ui.progress(1, "allan");
    let analysis = analyse_still(
        &StillNoise {
            recording: &loaded.recording,
            name: &name,
            raw_counts: loaded.raw_counts,
            gyro: gyro.as_ref(),
            calibration: calibration.as_ref().map(|(file, path)| (file, path.as_str())),
        },
        &settings,
    )
    .map_err(|e| match e {
        StillNoiseError::Moves { .. } => anyhow::anyhow!("{e} (--still)"),
        StillNoiseError::RawCounts { .. } => {
            UsageError(format!("{e}: pass --accel-scale or --calibration cal.json")).into()
        }
        StillNoiseError::NotStatic { .. }
        | StillNoiseError::GyroCounts { .. }
        | StillNoiseError::GyroUnit { .. } => UsageError(e.to_string()).into(),
        e => e.into(),
    })?;
    bar.finish_and_clear();
    let AllanAnalysis {
        params,
        curve,
        gyro_params,
        ..
    } = &analysis;
    let dt = 1.0 / analysis.sample_rate_hz;
    if let (Some(path), Some(gyro_params)) = (&args.kalibr, gyro_params) {
        let kalibr = spincal::export::KalibrImu::from_axes(
            params,
            gyro_params,
            &args.kalibr_topic,
            analysis.sample_rate_hz,
        );
        super::write_text(path, &kalibr.to_yaml())?;
    }
    if let Some(path) = &args.curve {
        spincal::output::write_file(path, |out| write_curve_csv(curve, out))?;
    }
    if let Some(path) = &args.plot {
        let figure = allan_figure(curve, params, &format!("Allan deviation: {name}"));
        let svg = figure.to_svg().context("drawing the Allan plot")?;
        super::write_text(path, &svg)?;
        let png = path.with_extension("png");
        figure.to_png(&png, 1000, 700).context("drawing the Allan plot")?;
    }
    if let Some(path) = &args.profile {
        let profile = spincal::simulate::SensorProfile::from_noise(params, analysis.sample_rate_hz);
        super::write_text(path, &(serde_json::to_string_pretty(&profile)? + "\n"))?;
    }
    let span_s = analysis.span_s;
    if args.json {
        return ui::print_json(&Report {
            file: name,
            analysis: &analysis,
        });
    }
    let mut s = format!("{}\n{}\n", args.input.rec.display(), format_line(&loaded));
    s += &format!(
        "samples used: {} ({:.3} – {:.3} s), τ₀ = {:.6} s\n",
        analysis.samples_used, span_s[0], span_s[1], dt
    );
    for a in 0..3 {
        s += &format!(
            "{}: noise density {:.4e} m/s²/√Hz ({} points of slope −½), bias instability {}{:.4e} m/s² at τ = {:.3} s\n",
            ["x", "y", "z"][a],
            params.noise_density[a],
            params.white_points[a],
            if params.floor_reached[a] { "" } else { "≤ " },
            params.bias_instability[a],
            params.bias_instability_tau_s[a]
        );
    }
    for a in 0..3 {
        s += &format!(
            "{}: rate random walk {}{:.4e} m/s³/√Hz\n",
            ["x", "y", "z"][a],
            if params.random_walk_points[a] > 0 {
                ""
            } else {
                "≤ "
            },
            params.random_walk[a]
        );
    }
    if let Some(g) = gyro_params {
        for a in 0..3 {
            s += &format!(
                "gyro {}: noise density {:.4e} rad/s/√Hz, bias instability {}{:.4e} rad/s, rate random walk {}{:.4e} rad/s²/√Hz\n",
                ["x", "y", "z"][a],
                g.noise_density[a],
                if g.floor_reached[a] { "" } else { "≤ " },
                g.bias_instability[a],
                if g.random_walk_points[a] > 0 { "" } else { "≤ " },
                g.random_walk[a]
            );
        }
    }
    if params.floor_reached.iter().any(|r| !r) {
        s += "≤: no flat part within τ ≤ T/10; a longer still recording is needed for the floor\n";
    }
    ui::print(&s)
}
