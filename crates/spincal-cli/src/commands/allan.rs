//! `spincal allan`: Allan deviation, noise density and bias instability of a still recording.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;
use spincal::allan::{
    allan_deviation, allan_figure, noise_params, simulator_profile, write_curve_csv, AllanCurve, NoiseParams,
};
use spincal::correctors::static_detect::{detect_static, StaticOptions};
use spincal::report::plot::Figure;

use super::{format_line, input, InputArgs};
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
    /// The gyroscope from a second file (imu_tk's layout: `t gx gy gz`), sample for sample beside
    /// the recording, when the recording has no gyro columns. Raw counts need a --calibration
    /// with a gyro model (`spincal static ACC --gyro-file GYRO -o cal.json`).
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
    sample_rate_hz: f64,
    samples_used: usize,
    span_s: [f64; 2],
    params: &'a NoiseParams,
    curve: &'a AllanCurve,
    /// The gyroscope's figures (rad/s units), when the recording has gyro columns.
    gyro_params: Option<&'a NoiseParams>,
    gyro_curve: Option<&'a AllanCurve>,
}

/// A still sensor's spread is about its shortest-τ Allan deviation (white noise: equal; slow
/// drift: a few times more). Far above it, the recording holds motion, and its Allan deviation
/// would measure the motion, not the noise.
const MOTION_FACTOR: f64 = 10.0;

fn refuse_motion(
    part: &[Vec<f64>; 3],
    curve: &spincal::allan::AllanCurve,
    file: &std::path::Path,
) -> anyhow::Result<()> {
    for (a, axis) in part.iter().enumerate() {
        let n = axis.len().max(1) as f64;
        let mean = axis.iter().sum::<f64>() / n;
        let spread = (axis.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
        let Some(&shortest) = curve.adev[a].first() else {
            continue;
        };
        if spread > MOTION_FACTOR * shortest {
            anyhow::bail!(
                "{}: the sensor moves: a{} spreads {:.3e} m/s², {:.0}× its shortest-τ Allan deviation (a still sensor stays within about {MOTION_FACTOR}×); an Allan deviation needs the sensor at rest: record it still, or pass --still to use the longest still interval",
                file.display(),
                ['x', 'y', 'z'][a],
                spread,
                spread / shortest
            );
        }
    }
    Ok(())
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
    let loaded = args.input.load(ui)?;
    let rec = &loaded.recording;
    let calibration = match &args.calibration {
        Some(path) => Some((path, spincal::CorrectorFile::read_path(path)?)),
        None => None,
    };
    let accel = match &calibration {
        Some((path, file)) => {
            let spincal::CorrectorModel::Static(cal) = &file.corrector else {
                return Err(UsageError(format!(
                    "{}: a {} corrector, not a static calibration (from `spincal static -o`)",
                    path.display(),
                    file.corrector.kind()
                ))
                .into());
            };
            cal.apply_axes(&rec.accel_mps2)
        }
        None if loaded.raw_counts => {
            return Err(UsageError(format!(
                "{}: the values are raw counts; pass --accel-scale or --calibration cal.json",
                args.input.rec.display()
            ))
            .into())
        }
        None => rec.accel_mps2.clone(),
    };
    let gyro_model = calibration
        .as_ref()
        .and_then(|(path, file)| Some((*path, file.gyro.as_ref()?)));
    let gyro_rec = match input::gyro_columns(
        args.gyro_file.as_deref(),
        &loaded,
        &args.input.rec,
        args.input.read.retime,
    )? {
        Some(columns) => Some(calibrated_gyro(columns, gyro_model)?),
        None => None,
    };
    let (start, end) = if args.still {
        let d = detect_static(&rec.time_s, &accel, &StaticOptions::default())
            .context("detecting still intervals")?;
        let longest = d
            .intervals
            .iter()
            .max_by_key(|i| i.len())
            .ok_or_else(|| anyhow::anyhow!("no still interval found"))?;
        (longest.start, longest.end)
    } else {
        (0, rec.len())
    };
    let part: [Vec<f64>; 3] = std::array::from_fn(|a| accel[a][start..end].to_vec());
    let dt = 1.0 / rec.sample_rate_hz();
    let bar = ui.progress(1, "allan");
    let curve = allan_deviation(&part, dt, args.per_decade)?;
    bar.finish_and_clear();
    if !args.still {
        refuse_motion(&part, &curve, &args.input.rec)?;
    }
    let params = noise_params(&curve);
    let gyro = match &gyro_rec {
        Some(g) => {
            let part: [Vec<f64>; 3] = std::array::from_fn(|a| g[a][start..end].to_vec());
            let curve = allan_deviation(&part, dt, args.per_decade)?;
            let params = noise_params(&curve);
            Some((curve, params))
        }
        None => None,
    };
    if let Some(path) = &args.kalibr {
        let Some((_, gyro_params)) = &gyro else {
            return Err(UsageError(format!(
                "{}: no gyro columns, and Kalibr's file needs the gyroscope's noise too (pass --columns t,ax,ay,az,gx,gy,gz)",
                args.input.rec.display()
            ))
            .into());
        };
        let kalibr =
            spincal::export::KalibrImu::from_axes(&params, gyro_params, &args.kalibr_topic, 1.0 / dt);
        super::write_text(path, &kalibr.to_yaml())?;
    }
    if let Some(path) = &args.curve {
        spincal::output::write_file(path, |out| write_curve_csv(&curve, out))?;
    }
    if let Some(path) = &args.plot {
        let figure = allan_figure(
            &curve,
            &params,
            &format!("Allan deviation: {}", args.input.rec.display()),
        );
        let svg = figure.to_svg().context("drawing the Allan plot")?;
        super::write_text(path, &svg)?;
        let png = path.with_extension("png");
        figure.to_png(&png, 1000, 700).context("drawing the Allan plot")?;
    }
    if let Some(path) = &args.profile {
        let profile = simulator_profile(&params, 1.0 / dt);
        super::write_text(path, &(serde_json::to_string_pretty(&profile)? + "\n"))?;
    }
    let span_s = [rec.time_s[start], rec.time_s[end - 1]];
    if args.json {
        return ui::print_json(&Report {
            file: args.input.rec.display().to_string(),
            sample_rate_hz: 1.0 / dt,
            samples_used: end - start,
            span_s,
            params: &params,
            curve: &curve,
            gyro_params: gyro.as_ref().map(|g| &g.1),
            gyro_curve: gyro.as_ref().map(|g| &g.0),
        });
    }
    let mut s = format!("{}\n{}\n", args.input.rec.display(), format_line(&loaded));
    s += &format!(
        "samples used: {} ({:.3} – {:.3} s), τ₀ = {:.6} s\n",
        end - start,
        span_s[0],
        span_s[1],
        dt
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
    if let Some((_, g)) = &gyro {
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

/// The gyro in rad/s: `columns` through the calibration's gyro model when there is one. Raw
/// counts without one are refused, as are a model and readings in different units.
fn calibrated_gyro(
    columns: input::GyroColumns,
    model: Option<(&PathBuf, &spincal::correctors::gyro::GyroModel)>,
) -> anyhow::Result<[Vec<f64>; 3]> {
    use spincal::correctors::gyro::GyroInputUnit;
    let Some((path, model)) = model else {
        if columns.counts {
            return Err(UsageError(format!(
                "{}: the gyro values are raw counts, not rad/s; calibrate the gyroscope first (`spincal static ACC --gyro-file GYRO -o cal.json`, from still poses joined by rotations) and pass --calibration cal.json",
                columns.source
            ))
            .into());
        }
        return Ok(columns.values);
    };
    let model_counts = model.input_unit == GyroInputUnit::Counts;
    if model_counts != columns.counts {
        return Err(UsageError(format!(
            "{}: the gyro calibration takes readings in {}, but {} holds {}",
            path.display(),
            model.input_unit.name(),
            columns.source,
            if columns.counts { "raw counts" } else { "rad/s" }
        ))
        .into());
    }
    let corrector = model
        .corrector()
        .ok_or_else(|| anyhow::anyhow!("{}: the gyro sensitivity is singular", path.display()))?;
    let n = columns.values[0].len();
    let mut out: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
    for i in 0..n {
        let w = corrector.correct(std::array::from_fn(|k| columns.values[k][i]));
        for k in 0..3 {
            out[k].push(w[k]);
        }
    }
    Ok(out)
}
