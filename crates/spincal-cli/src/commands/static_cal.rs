//! `spincal static`: bias, scale and misalignment from still poses.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;
use spincal::static_cal::{fit_static, pose_means, spread_about, StaticFit, StaticFitOptions, StaticModel};
use spincal::static_detect::{detect_static, labelled_intervals, StaticOptions, StillInterval};

use super::values::StaticModelArg;
use super::{format_line, InputArgs};
use crate::ui;

#[derive(Args, Debug)]
pub struct StaticArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Local gravity, m/s².
    #[arg(long, default_value_t = spincal::STANDARD_GRAVITY, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub gravity: f64,
    /// Parameters: 6 (bias, scale), 9 (+ misalignment, imu_tk) or 12 (+ quadratic nonlinearity).
    #[arg(long, value_enum, default_value = "9")]
    pub model: StaticModelArg,
    /// Write the calibration as JSON.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write a Kalibr-style YAML.
    #[arg(long)]
    pub yaml: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Find still intervals by detection even when the file labels its sections.
    #[arg(long)]
    pub detect: bool,
    /// Initial still period that sets the noise level, s.
    #[arg(long, default_value_t = 3.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub init: f64,
    /// Still where the moving variance is below this many times the initial one.
    #[arg(long, default_value_t = 3.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub threshold_factor: f64,
    /// Moving-variance window, s.
    #[arg(long, default_value_t = 1.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub window: f64,
    /// Shortest still interval used, s.
    #[arg(long, default_value_t = 2.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub min_interval: f64,
}

#[derive(Serialize)]
struct Report<'a> {
    file: String,
    format: &'a spincal::formats::Loaded,
    intervals_from: &'a str,
    intervals: &'a [StillInterval],
    /// RMS of |mean| − g before calibration (only when the input is already m/s²).
    rms_before_mps2: Option<f64>,
    fit: &'a StaticFit,
}

pub fn run(args: &StaticArgs, ui: &ui::Ui) -> anyhow::Result<()> {
    let outputs: Vec<&std::path::Path> = args
        .output
        .iter()
        .chain(&args.yaml)
        .map(|p| p.as_path())
        .collect();
    super::check_outputs(&[&args.input.rec], &outputs)?;
    let model: StaticModel = args.model.into();
    let loaded = args.input.load(ui)?;
    let rec = &loaded.recording;
    let (intervals, from) = match (&loaded.labels, args.detect) {
        (Some(labels), false) => (
            labelled_intervals(&rec.time_s, &rec.accel_mps2, labels, |l| !l.contains("rot")),
            "section labels (all but *rot*)",
        ),
        _ => {
            let options = StaticOptions {
                init_s: args.init,
                window_s: args.window,
                threshold_factor: args.threshold_factor,
                min_interval_s: args.min_interval,
            };
            let d =
                detect_static(&rec.time_s, &rec.accel_mps2, &options).context("detecting still intervals")?;
            (d.intervals, "moving-variance detection")
        }
    };
    let means = pose_means(&intervals);
    let fit = fit_static(
        &means,
        &StaticFitOptions {
            model,
            gravity_mps2: args.gravity,
            input_unit: if loaded.raw_counts { "counts" } else { "m/s^2" }.into(),
        },
    )
    .with_context(|| format!("fitting {} still intervals from {from}", intervals.len()))?;
    let rms_before = (!loaded.raw_counts).then(|| {
        let norms: Vec<f64> = means
            .iter()
            .map(|m| (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt())
            .collect();
        spread_about(&norms, args.gravity)
    });
    if let Some(path) = &args.output {
        // The same versioned corrector file as every other corrector: `spincal correct` applies it.
        let file =
            spincal::CorrectorFile::new(spincal::CorrectorModel::Static(Box::new(fit.calibration.clone())));
        file.write_path(path)?;
    }
    if let Some(path) = &args.yaml {
        let yaml = fit.calibration.to_kalibr_yaml(rec.sample_rate_hz(), None);
        super::write_text(path, &yaml)?;
    }
    if args.json {
        return ui::print_json(&Report {
            file: args.input.rec.display().to_string(),
            format: &loaded,
            intervals_from: from,
            intervals: &intervals,
            rms_before_mps2: rms_before,
            fit: &fit,
        });
    }
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
    if model == StaticModel::Nonlinear {
        s += &format!("nonlinearity [1/(m/s²)]: {:?}\n", c.nonlinearity);
    }
    if fit.param_std.is_empty() {
        s += "parameter uncertainty: none (as many poses as parameters: the fit is exact, not checked)\n";
    } else {
        let std: Vec<String> = fit.param_std.iter().map(|v| format!("{v:.3e}")).collect();
        s += &format!("1-σ uncertainties [b, s, α, q]: [{}]\n", std.join(", "));
    }
    if let Some(b) = rms_before {
        s += &format!("RMS of |a| − g over the poses before: {b:.6} m/s²\n");
    }
    s += &format!(
        "RMS of |a| − g over the poses after: {:.6} m/s² ({} iterations, {})\n",
        fit.rms_mps2,
        fit.iterations,
        fit.stop.describe()
    );
    ui::print(&s)
}
