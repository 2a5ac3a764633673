//! `spincal static`: bias, scale and misalignment from still poses.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;
use spincal::correctors::gyro_poses::{GyroBiasSource, GyroPoseOptions};
use spincal::correctors::static_cal::StaticModel;
use spincal::correctors::static_detect::StaticOptions;
use spincal::input::gyro_file::gyro_columns;
use spincal::static_calibration::{calibrate_static, StaticCalibration, StaticSettings, StillRecording};

use super::values::StaticModelArg;
use super::{format_line, InputArgs};
use crate::ui;

#[derive(Args, Debug)]
pub struct StaticArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Local gravity, m/s².
    #[arg(long, default_value_t = spincal::input::recording::STANDARD_GRAVITY, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub gravity: f64,
    /// Parameters: 6 (bias, scale), 9 (+ misalignment, imu_tk) or 12 (+ quadratic nonlinearity).
    #[arg(long, value_enum, default_value = "9")]
    pub model: StaticModelArg,
    /// Write the calibration as JSON.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write the accelerometer calibration as YAML laid out like Kalibr's IMU intrinsics (imu0:
    /// M, bias, scale, misalignment). It is not Kalibr's imu.yaml (noise densities and random
    /// walks: `spincal allan --kalibr`), and Kalibr does not read it.
    #[arg(long)]
    pub yaml: Option<PathBuf>,
    /// Also write the calibration as other tools read it, into this folder (made if missing), as a
    /// campaign does: imucal.json (imucal's Ferraris JSON), imu_tk_acc.calib and, with a gyro,
    /// imu_tk_gyro.calib, in the reading's own units (a 12-parameter model's quadratic terms are
    /// left out, and imucal's comment says so).
    #[arg(long, value_name = "DIR")]
    pub exports: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Find still intervals by detection even when the file labels its sections.
    #[arg(long)]
    pub detect: bool,
    /// Initial still period that sets the noise level, s.
    #[arg(long, default_value_t = StaticOptions::default().init_s, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub init: f64,
    /// Still where the moving variance is below this many times the initial one.
    #[arg(long, default_value_t = StaticOptions::default().threshold_factor, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub threshold_factor: f64,
    /// Moving-variance window, s.
    #[arg(long, default_value_t = StaticOptions::default().window_s, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub window: f64,
    /// Shortest still interval used, s.
    #[arg(long, default_value_t = StaticOptions::default().min_interval_s, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub min_interval: f64,
    /// Also calibrate the gyroscope, read from this file (imu_tk's layout `t gx gy gz`, rad/s or
    /// raw counts; read with the same flags) from the still poses and the rotations between them:
    /// merged on time when it has a time column (the recording's samples outside its span dropped,
    /// with a note), sample for sample when it has none. Without it, the recording's own gyro
    /// columns are used when it has them.
    #[arg(long, value_name = "GYRO")]
    pub gyro_file: Option<PathBuf>,
    /// Starting guess of the gyro's scale, readings per rad/s (only its size is used: the fit
    /// finds each axis's sign and scale; default: from the rotation angles).
    #[arg(long, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub gyro_scale: Option<f64>,
    /// Still samples that give the gyro bias.
    #[arg(long, value_enum, default_value = "first")]
    pub gyro_bias_from: GyroBiasArg,
}

/// Which still samples give the gyro bias.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GyroBiasArg {
    /// The first still interval (the session's initial still period), as imu_tk does.
    First,
    /// Every still interval, weighted by its length.
    All,
}

#[derive(Serialize)]
struct Report<'a> {
    file: String,
    format: &'a spincal::input::formats::Loaded,
    #[serde(flatten)]
    calibration: &'a StaticCalibration,
}

/// The files `--exports` may write (the gyro's only with a gyro calibration).
const EXPORT_FILES: [&str; 3] = ["imucal.json", "imu_tk_acc.calib", "imu_tk_gyro.calib"];

pub fn run(args: &StaticArgs, ui: &ui::Ui) -> anyhow::Result<()> {
    let export_paths: Vec<PathBuf> = args
        .exports
        .iter()
        .flat_map(|dir| EXPORT_FILES.map(|name| dir.join(name)))
        .collect();
    let inputs: Vec<PathBuf> = std::iter::once(&args.input.rec)
        .chain(&args.gyro_file)
        .cloned()
        .collect();
    super::check_paths(&inputs, args.output.iter().chain(&args.yaml).chain(&export_paths))?;
    let mut loaded = args.input.load(ui)?;
    let name = args.input.rec.display().to_string();
    let options = args.input.read.options()?;
    let (gyro_columns, note) = gyro_columns(args.gyro_file.as_deref(), &mut loaded, &name, &options)?;
    super::gyro_file::print_gyro_note(note);
    let rec = &loaded.recording;
    let settings = StaticSettings {
        model: args.model.into(),
        gravity_mps2: args.gravity,
        detection: StaticOptions {
            init_s: args.init,
            window_s: args.window,
            threshold_factor: args.threshold_factor,
            min_interval_s: args.min_interval,
        },
        detect: args.detect,
        gyro: GyroPoseOptions {
            bias_from: match args.gyro_bias_from {
                GyroBiasArg::First => GyroBiasSource::FirstInterval,
                GyroBiasArg::All => GyroBiasSource::AllIntervals,
            },
            initial_scale: args.gyro_scale,
            ..Default::default()
        },
    };
    let calibration = calibrate_static(
        &StillRecording {
            recording: rec,
            raw_counts: loaded.raw_counts,
            labels: loaded.labels.as_deref(),
            gyro: gyro_columns.as_ref(),
            gyro_required: args.gyro_file.is_some(),
        },
        &settings,
    )?;
    let fit = &calibration.fit;
    if let Some(path) = &args.output {
        // The same versioned corrector file as every other corrector: `spincal correct` applies it.
        calibration.corrector_file().write_path(path)?;
    }
    if let Some(path) = &args.yaml {
        let yaml = fit.calibration.to_kalibr_yaml(rec.sample_rate_hz(), None);
        super::write_text(path, &yaml)?;
    }
    if let Some(dir) = &args.exports {
        let files = spincal::export::static_files(&fit.calibration, calibration.gyro_model())
            .context("the calibration's scale or misalignment cannot be inverted for imucal and imu_tk")?;
        super::create_folder("--exports", dir)?;
        for (name, text) in files {
            super::write_text(&dir.join(name), &text)?;
        }
    }
    if args.json {
        return ui::print_json(&Report {
            file: args.input.rec.display().to_string(),
            format: &loaded,
            calibration: &calibration,
        });
    }
    let (intervals, from) = (&calibration.intervals, &calibration.intervals_from);
    let c = &fit.calibration;
    let mut s = format!("{}\n{}\n", args.input.rec.display(), format_line(&loaded));
    s += &format!("still intervals: {} (from {from})\n", intervals.len());
    for (iv, norm) in intervals.iter().zip(&fit.pose_norms_mps2) {
        s += &format!(
            "  {:9.3} – {:9.3} s  {:6} samples  |a| = {:.5} m/s²\n",
            iv.t_start_s,
            iv.t_end_s,
            iv.len(),
            norm
        );
    }
    s += &format!("model: {}, g = {} m/s²\n", c.model.describe(), args.gravity);
    s += &format!("bias [{}]: {:?}\n", c.input_unit, c.bias);
    s += &format!("scale [m/s² per {}]: {:?}\n", c.input_unit, c.scale);
    s += &format!("misalignment [α_yz, α_zy, α_zx]: {:?}\n", c.misalignment);
    if c.model == StaticModel::Nonlinear {
        s += &format!("nonlinearity [1/(m/s²)]: {:?}\n", c.nonlinearity);
    }
    if fit.param_std.is_empty() {
        s += "parameter uncertainty: none (as many poses as parameters: the fit is exact, not checked)\n";
    } else {
        let std: Vec<String> = fit.param_std.iter().map(|v| format!("{v:.3e}")).collect();
        s += &format!("1-σ uncertainties [b, s, α, q]: [{}]\n", std.join(", "));
    }
    if let Some(reduced) = &calibration.reduced {
        eprintln!("note: {}", reduced.sentence(c.model));
    }
    if let Some(b) = calibration.rms_before_mps2 {
        s += &format!("RMS of |a| − g over the poses before: {b:.6} m/s²\n");
    }
    s += &format!(
        "RMS of |a| − g over the poses after: {:.6} m/s² ({} iterations, {})\n",
        fit.rms_mps2,
        fit.iterations,
        fit.stop.describe()
    );
    if let Some(report) = &calibration.gyro {
        s += &report.text();
    }
    ui::print(&s)
}
