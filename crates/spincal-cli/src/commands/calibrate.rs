//! `spincal calibrate`: recordings in; model file, results.json and report.html out.

use std::path::{Path, PathBuf};

use clap::Args;
use spincal::calibrate::calibrate;
use spincal::campaign::params::{NetworkChoice, Params};
use spincal::campaign::select::CampaignOutput;
use spincal::correctors::ann::{default_grid, small_grid};
use spincal::correctors::corrector::Axis;
use spincal::input::recording::Recording;
use spincal::report::campaign::CAMPAIGN_FILE_NAMES;
use spincal::sysid::{ModelKind, ModelSpec};

use super::fit::TurntableArgs;
use super::train::{all_if_zero, parse_hidden};
use super::values::SweepArg;
use crate::ui::{self, Ui, UsageError};

#[derive(Args, Debug)]
#[command(
    after_help = "Examples:\n  spincal calibrate --campaign unit7/campaign.toml --out cal   # still poses + turntable runs, held-out selection\n  \
                        spincal calibrate rec33.csv rec45.csv --radius 0.10 --radius-tol 0.002 --out cal\n  \
                        spincal calibrate rec.csv --sweep full --out cal   # the paper's grid (the paper: --restarts 10)\n  \
                        spincal calibrate rec.csv --hidden 10,6 --correct-axes x,y --out cal\n  \
                        spincal calibrate --campaign warm7/campaign.toml --out warm7-cal   # still files with temp_c: corrected for temperature too"
)]
pub struct CalibrateArgs {
    /// The turntable fit's options (recordings, columns, rpm, radius, bounds, axes of the objective…).
    #[command(flatten)]
    pub fit: TurntableArgs,
    /// Output folder: model.json, results.json, report.html.
    #[arg(long, default_value = "spincal-calibration")]
    pub out: PathBuf,
    /// A campaign file (TOML) listing a unit's still poses and turntable runs: one sensor model is
    /// fitted jointly and correctors are chosen on held-out conditions. Replaces the recordings.
    #[arg(long, value_name = "FILE", conflicts_with = "recordings")]
    pub campaign: Option<PathBuf>,
    /// Network architecture search (default: small; none when --hidden is given).
    #[arg(long, value_enum)]
    pub sweep: Option<SweepArg>,
    /// Hidden layers of the one architecture to train, e.g. 10,6 (implies --sweep none; default
    /// with --sweep none: 10,6).
    #[arg(long, value_name = "SIZES")]
    pub hidden: Option<String>,
    /// Training runs per architecture from different initial weights.
    #[arg(long, default_value_t = 3)]
    pub restarts: usize,
    /// Samples each sweep epoch's JᵀJ is formed from (errors and gradient use all); 0 = all. The
    /// chosen architecture is then trained with every sample.
    #[arg(long, default_value_t = spincal::correctors::ann::SWEEP_HESSIAN_SAMPLES)]
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
    /// Also print the per-condition tables (held-out residuals, the gyro's runs, the paper's
    /// comparison); report.html always holds them.
    #[arg(long)]
    pub tables: bool,
}

fn parse_orders(text: &str, flag: &str) -> Result<Vec<usize>, UsageError> {
    text.split(',')
        .map(|s| s.trim().parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| UsageError(format!("--{flag} {text}: expected orders like 6,8,1")))
}

impl CalibrateArgs {
    /// The library's defaults with what the flags name changed (nothing else is decided here).
    pub fn params(&self) -> anyhow::Result<Params> {
        let mut params = Params::default();
        let sweep_over = |grid| NetworkChoice::Sweep {
            grid,
            restarts: self.restarts,
            hessian_samples: all_if_zero(self.sweep_hessian_samples),
        };
        params.network = match (self.sweep, &self.hidden) {
            (Some(SweepArg::Small | SweepArg::Full), Some(_)) => {
                return Err(UsageError(
                    "--hidden fixes the architecture, so it cannot be combined with --sweep small or full; drop one of them".into(),
                )
                .into())
            }
            (Some(SweepArg::Small), None) | (None, None) => sweep_over(small_grid()),
            (None | Some(SweepArg::None), hidden) => NetworkChoice::Fixed {
                hidden: parse_hidden(hidden.as_deref().unwrap_or("10,6"))?,
                restarts: self.restarts,
            },
            (Some(SweepArg::Full), None) => sweep_over(default_grid()),
        };
        params.correct_axes = Axis::parse_list(&self.correct_axes)
            .ok_or_else(|| UsageError(format!("--correct-axes {}: expected e.g. x,y", self.correct_axes)))?;
        let spec = |kind: ModelKind, text: &str, flag: &str| -> anyhow::Result<ModelSpec> {
            let orders = parse_orders(text, flag)?;
            Ok(ModelSpec::new(kind, &orders).map_err(|e| UsageError(format!("--{flag}: {e}")))?)
        };
        params.sysid = vec![
            spec(ModelKind::Arx, &self.arx, "arx")?,
            spec(ModelKind::Bj, &self.bj, "bj")?,
            spec(ModelKind::Narx, &self.narx, "narx")?,
            spec(ModelKind::Hw, &self.hw, "hw")?,
        ];
        params.fit = self.fit.options()?;
        params.delays = self.delays;
        params.seed = self.seed;
        Ok(params)
    }
}

/// Runs a calibration with progress bars and writes its files (those of a campaign: model.json
/// when saved, results.json, report.html, and the other tools' files when saved).
/// `read_seconds` is how long reading the recordings took, when they were read (a stage of its
/// own in results.json).
pub fn run_calibration(
    recordings: &[Recording],
    settings: &Params,
    out: &Path,
    read_seconds: Option<f64>,
    ui: Ui,
) -> anyhow::Result<(CampaignOutput, Vec<&'static str>)> {
    super::create_folder("--out", out)?;
    // A progress bar that names each stage.
    let bar = ui.progress(1, "calibrating");
    let mut output = calibrate(recordings, settings, &|p| crate::ui::show(&bar, p))?;
    bar.finish_and_clear();
    if let Some(seconds) = read_seconds {
        output.result.add_read_seconds(seconds);
    }
    let written = super::campaign::write_calibration(&output, out)?;
    Ok((output, written))
}

/// A short summary for the terminal: the campaign's (what was saved, where it can be trusted,
/// the verdict), then with `tables` the paper's figures.
pub fn summary(output: &CampaignOutput, out: &Path, written: &[&str], tables: bool) -> String {
    let mut text = super::campaign::summary(output, out, written, tables);
    if let Some(paper) = output.result.paper.as_ref().filter(|_| tables) {
        text.push_str("\nthe paper's protocol (60/20/20 on the first recording; reported, not what decided the saving):\n");
        text.push_str(
            "model        train fit %  validation fit %  test fit %   (simulation for dynamic models)\n",
        );
        for row in &paper.comparison {
            text.push_str(&format!(
                "{:<12} {:>11.2} {:>17.2} {:>11.2}\n",
                row.model,
                row.train.fit_percent_mean,
                row.validation.fit_percent_mean,
                row.test.fit_percent_mean
            ));
            text.push_str(&super::tables::row_notes(row));
        }
        text.push_str(&super::tables::cross_condition_text(&paper.cross_condition));
        text.push_str(&format!(
            "best on validation: {} (among correctors a file can hold, no worse than uncorrected on another recording); best overall without warnings: {}\n",
            paper.best_on_validation, paper.best_overall
        ));
    }
    text
}

pub fn run(args: CalibrateArgs, ui: Ui) -> anyhow::Result<()> {
    if let Some(file) = &args.campaign {
        return super::campaign::calibrate(file, &args.out, args.fit.json, args.tables, ui);
    }
    super::require_recordings(&args.fit.recordings)?;
    let settings = args.params()?;
    super::check_paths(
        &args.fit.inputs(),
        &CAMPAIGN_FILE_NAMES.map(|name| args.out.join(name)),
    )?;
    if args.out.exists() && !args.out.is_dir() {
        super::create_folder("--out", &args.out)?;
    }
    let clock = std::time::Instant::now();
    let recordings = args.fit.read_recordings()?;
    let read_seconds = clock.elapsed().as_secs_f64();
    let (output, written) = run_calibration(&recordings, &settings, &args.out, Some(read_seconds), ui)?;
    if args.fit.json {
        return ui::print_json(&output.result);
    }
    ui::print(&summary(&output, &args.out, &written, args.tables))
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Command {
        #[command(flatten)]
        args: CalibrateArgs,
    }

    fn params_of(words: &[&str]) -> Params {
        let line = std::iter::once("calibrate").chain(words.iter().copied());
        Command::try_parse_from(line).unwrap().args.params().unwrap()
    }

    /// `spincal calibrate REC` runs exactly what a Rust caller gets from `Params::default()`.
    #[test]
    fn the_commands_defaults_are_the_librarys() {
        let json = |p: &Params| serde_json::to_value(p).unwrap();
        assert_eq!(json(&params_of(&["rec.csv"])), json(&Params::default()));
        // And a flag changes only its own parameter.
        let expected = Params {
            seed: 9,
            delays: 2,
            ..Params::default()
        };
        assert_eq!(
            json(&params_of(&["rec.csv", "--seed", "9", "--delays", "2"])),
            json(&expected)
        );
    }
}
