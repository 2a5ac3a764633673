//! `spincal calibrate`: recordings in; model file, results.json and report.html out.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use spincal::ann::default_grid;
use spincal::calibrate::{calibrate, CalibrateSettings, CalibrationOutput, NetworkChoice};
use spincal::corrector::Axis;
use spincal::report::render_report;
use spincal::sysid::{ModelKind, ModelSpec};
use spincal::Recording;

use super::fit::FitArgs;
use super::train::all_if_zero;
use crate::ui::{self, Ui, UsageError};

#[derive(Args, Debug)]
#[command(
    after_help = "Examples:\n  spincal calibrate rec33.csv rec45.csv --radius 0.10 --radius-tol 0.002 --out cal\n  \
                        spincal calibrate rec.csv --sweep full --restarts 10 --out cal   # the paper's full grid\n  \
                        spincal calibrate rec.csv --hidden 10,6 --axes x,y --out cal"
)]
pub struct CalibrateArgs {
    /// The turntable fit's options (recordings, columns, rpm, radius, bounds, axes of the objective…).
    #[command(flatten)]
    pub fit: FitArgs,
    /// Output folder: model.json, results.json, report.html.
    #[arg(long, default_value = "spincal-calibration")]
    pub out: PathBuf,
    /// Network architecture search: none (use --hidden), small (1–8 units, one and two layers) or full
    /// (1–15 and 1–15 × 1–10, the paper's grid).
    #[arg(long, default_value = "small")]
    pub sweep: String,
    /// Hidden layers when --sweep none, e.g. 10,6.
    #[arg(long, default_value = "10,6")]
    pub hidden: String,
    /// Training runs per architecture from different initial weights.
    #[arg(long, default_value_t = 3)]
    pub restarts: usize,
    /// Samples each sweep epoch's JᵀJ is formed from (errors and gradient use all); 0 = all. The
    /// chosen architecture is then trained with every sample.
    #[arg(long, default_value_t = spincal::ann::SWEEP_HESSIAN_SAMPLES)]
    pub sweep_hessian_samples: usize,
    /// Axes to correct, e.g. x,y.
    #[arg(long, default_value = "x,y")]
    pub correct_axes: String,
    /// Previous samples per axis fed to the network.
    #[arg(long, default_value_t = 0)]
    pub delays: usize,
    /// Seed of every random choice (initial weights, NARX start).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// ARX orders na,nb,nk.
    #[arg(long, default_value = "6,8,1")]
    pub arx: String,
    /// Box–Jenkins orders nb,nc,nd,nf,nk.
    #[arg(long, default_value = "4,4,4,4,1")]
    pub bj: String,
    /// Nonlinear ARX orders na,nb,nk.
    #[arg(long, default_value = "2,2,1")]
    pub narx: String,
    /// Hammerstein–Wiener orders nb,nf,nk.
    #[arg(long, default_value = "2,3,1")]
    pub hw: String,
}

/// The small grid used by `demo` and by default: one layer 1–8, two layers 2–8 × 2–6 (even).
pub fn small_grid() -> Vec<Vec<usize>> {
    let mut grid: Vec<Vec<usize>> = (1..=8).map(|n| vec![n]).collect();
    for first in (2..=8).step_by(2) {
        for second in (2..=6).step_by(2) {
            grid.push(vec![first, second]);
        }
    }
    grid
}

fn parse_sizes(text: &str) -> Result<Vec<usize>, UsageError> {
    text.split(',')
        .map(|s| s.trim().parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| UsageError(format!("--hidden {text}: expected sizes like 10,6")))
}

impl CalibrateArgs {
    pub fn settings(&self) -> anyhow::Result<CalibrateSettings> {
        let network = match self.sweep.as_str() {
            "none" => NetworkChoice::Fixed {
                hidden: parse_sizes(&self.hidden)?,
                restarts: self.restarts,
            },
            "small" => NetworkChoice::Sweep {
                grid: small_grid(),
                restarts: self.restarts,
                hessian_samples: all_if_zero(self.sweep_hessian_samples),
            },
            "full" => NetworkChoice::Sweep {
                grid: default_grid(),
                restarts: self.restarts,
                hessian_samples: all_if_zero(self.sweep_hessian_samples),
            },
            other => return Err(UsageError(format!("--sweep {other}: expected none, small or full")).into()),
        };
        let axes = Axis::parse_list(&self.correct_axes)
            .ok_or_else(|| UsageError(format!("--correct-axes {}: expected e.g. x,y", self.correct_axes)))?;
        let spec = |kind: ModelKind, text: &str, flag: &str| -> anyhow::Result<ModelSpec> {
            let orders = parse_sizes(text)
                .map_err(|_| UsageError(format!("--{flag} {text}: expected orders like 6,8,1")))?;
            let mut spec = ModelSpec::new(kind, &orders).map_err(|e| UsageError(format!("--{flag}: {e}")))?;
            spec.seed = self.seed;
            Ok(spec)
        };
        Ok(CalibrateSettings {
            fit: self.fit.options()?,
            axes,
            network,
            delays: self.delays,
            seed: self.seed,
            sysid: vec![
                spec(ModelKind::Arx, &self.arx, "arx")?,
                spec(ModelKind::Bj, &self.bj, "bj")?,
                spec(ModelKind::Narx, &self.narx, "narx")?,
                spec(ModelKind::Hw, &self.hw, "hw")?,
            ],
            ..CalibrateSettings::default()
        })
    }
}

/// Runs the library's calibration with a progress bar that names each stage.
pub fn calibrate_with_progress(
    recordings: &[Recording],
    settings: &CalibrateSettings,
    ui: Ui,
    label: &str,
) -> anyhow::Result<CalibrationOutput> {
    let bar = ui.progress(1, label);
    let output = calibrate(recordings, settings, &|p| crate::ui::show(&bar, p))?;
    bar.finish_and_clear();
    Ok(output)
}

/// Runs a calibration with progress bars and writes the three output files.
pub fn run_calibration(
    recordings: &[Recording],
    settings: &CalibrateSettings,
    out: &Path,
    ui: Ui,
) -> anyhow::Result<CalibrationOutput> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let output = calibrate_with_progress(recordings, settings, ui, "calibrating")?;
    output.saved.write_path(&out.join("model.json"))?;
    let results = serde_json::to_string_pretty(&output.result)? + "\n";
    std::fs::write(out.join("results.json"), results).context("writing results.json")?;
    let html = render_report(&output, recordings)?;
    std::fs::write(out.join("report.html"), html).context("writing report.html")?;
    Ok(output)
}

/// A short summary for the terminal.
pub fn summary(output: &CalibrationOutput, out: &Path) -> String {
    let r = &output.result;
    let mut text = String::from(
        "model        train fit %  validation fit %  test fit %   (simulation for dynamic models)\n",
    );
    for row in &r.comparison {
        text.push_str(&format!(
            "{:<12} {:>11.2} {:>17.2} {:>11.2}\n",
            row.model, row.train.fit_percent_mean, row.validation.fit_percent_mean, row.test.fit_percent_mean
        ));
        text.push_str(&super::tables::row_notes(row));
    }
    text.push_str(&super::tables::cross_condition_text(&r.cross_condition));
    let dir = out.display();
    text.push_str(&format!(
        "\nchosen: {} (best on validation among savable correctors; best overall without warnings: {})\n\
         wrote {dir}/model.json, {dir}/results.json, {dir}/report.html\n",
        r.chosen, r.best_overall,
    ));
    text
}

pub fn run(args: CalibrateArgs, ui: Ui) -> anyhow::Result<()> {
    let settings = args.settings()?;
    let recordings = args
        .fit
        .recordings
        .iter()
        .map(|p| args.fit.read.read(p))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let output = run_calibration(&recordings, &settings, &args.out, ui)?;
    if args.fit.json {
        return ui::print_json(&output.result);
    }
    ui::print(&summary(&output, &args.out))
}
