//! `spincal train`: fits one corrector (network or linear) of measured against reference data.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use serde::Serialize;
use spincal::correctors::ann::{AnnProblem, LmSettings};
use spincal::correctors::corrector::Axis;
use spincal::correctors::division::{DivisionMode, Part, PartFits};
use spincal::correctors::linear::LinearModel;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::input::recording::Recording;

use super::input::ReadArgs;
use crate::ui::{self, Ui, UsageError};

#[derive(Clone, Copy, ValueEnum)]
pub enum Kind {
    /// Feed-forward network trained by Levenberg–Marquardt.
    Ann,
    /// Offset plus square matrix by least squares.
    Linear,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum DivisionArg {
    /// 60 % training, then 20 % validation, then 20 % test.
    Contiguous,
    /// Blocks of --block-len samples dealt 3:1:1 to training, validation, test.
    Interleaved,
}

/// Data, division and network options shared by `train` and `sweep`.
#[derive(Args)]
pub struct DataArgs {
    /// Measured recording, in any format spincal reads (see the reading flags).
    #[arg(long, value_name = "REC")]
    pub data: PathBuf,
    /// Reference acceleration for the same samples: `spincal fit REC --reference-csv REF.csv`
    /// writes it (t_s,ax_g,ay_g,az_g).
    #[arg(long, value_name = "REF.csv")]
    pub reference: PathBuf,
    /// How to read --data.
    #[command(flatten)]
    pub read: ReadArgs,
    /// Axes to correct, e.g. x or x,y (one axis: SISO; several: MIMO). Default x,y for the
    /// network, x,y,z for the linear corrector.
    #[arg(long, value_name = "AXES")]
    pub correct_axes: Option<String>,
    /// Previous samples of each axis given to the network besides the current one.
    #[arg(long, default_value_t = 0)]
    pub delays: usize,
    /// How to split samples 60/20/20 into training, validation and test.
    #[arg(long, value_enum, default_value = "contiguous")]
    pub division: DivisionArg,
    /// Block length in samples for --division interleaved.
    #[arg(long, default_value_t = 500)]
    pub block_len: usize,
    /// Training runs per architecture from different initial weights; the best on validation is kept.
    #[arg(long, default_value_t = 10)]
    pub restarts: usize,
    /// Base seed of the initial weights (each restart derives its own).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Upper limit on LM epochs per run.
    #[arg(long, default_value_t = 1000)]
    pub max_epochs: usize,
}

impl DataArgs {
    pub fn axes(&self, default: &str) -> anyhow::Result<Vec<Axis>> {
        let text = self.correct_axes.as_deref().unwrap_or(default);
        Axis::parse_list(text).ok_or_else(|| {
            UsageError(format!(
                "--correct-axes {text}: expected axes from x, y, z such as x,y"
            ))
            .into()
        })
    }

    pub fn division(&self) -> DivisionMode {
        match self.division {
            DivisionArg::Contiguous => DivisionMode::Contiguous,
            DivisionArg::Interleaved => DivisionMode::Interleaved {
                block_len: self.block_len,
            },
        }
    }

    /// LM settings; `hessian_samples` 0 forms JᵀJ from every training sample.
    pub fn lm(&self, hessian_samples: usize) -> LmSettings {
        LmSettings {
            max_epochs: self.max_epochs,
            hessian_samples: all_if_zero(hessian_samples),
            ..LmSettings::default()
        }
    }

    pub fn read(&self) -> anyhow::Result<(Recording, Recording)> {
        let measured = self.read.read(&self.data)?;
        let reference = ReadArgs::default().read(&self.reference)?;
        Ok((measured, reference))
    }
}

#[derive(Args)]
pub struct TrainArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Corrector kind.
    #[arg(long, value_enum, default_value = "ann")]
    pub kind: Kind,
    /// Hidden layer sizes, e.g. 10,6 (up to three layers), or `none` for a purely linear network.
    #[arg(long, default_value = "10,6")]
    pub hidden: String,
    /// Where to save the corrector (JSON).
    #[arg(short, long, value_name = "MODEL.json")]
    pub output: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// A `--…hessian-samples` count: 0 means every sample (`None`).
pub fn all_if_zero(samples: usize) -> Option<usize> {
    (samples > 0).then_some(samples)
}

/// Parses `--hidden` (`10,6` or `none`).
pub fn parse_hidden(text: &str) -> anyhow::Result<Vec<usize>> {
    spincal::correctors::ann::parse_hidden_sizes(text).map_err(|e| UsageError(format!("--hidden {e}")).into())
}

#[derive(Serialize)]
struct Summary<'a> {
    kind: &'a str,
    axes: Vec<Axis>,
    hidden: Option<Vec<usize>>,
    delays: usize,
    epochs: Option<usize>,
    stop: Option<String>,
    fits: &'a PartFits,
    uncorrected: &'a PartFits,
    model_file: Option<String>,
}

pub fn run(args: TrainArgs, ui: Ui) -> anyhow::Result<()> {
    let outputs: Vec<&std::path::Path> = args.output.iter().map(PathBuf::as_path).collect();
    super::check_outputs(&[&args.data.data, &args.data.reference], &outputs)?;
    let (measured, reference) = args.data.read()?;
    let division = args.data.division();
    let model = match args.kind {
        Kind::Ann => {
            let axes = args.data.axes("x,y")?;
            let hidden = parse_hidden(&args.hidden)?;
            let problem = AnnProblem::new(&measured, &reference, &axes, args.data.delays, division)?;
            let spinner = ui.spinner(&format!("training {} restarts", args.data.restarts));
            let model = problem.train(&hidden, args.data.restarts, args.data.seed, &args.data.lm(0))?;
            spinner.finish_and_clear();
            CorrectorModel::Ann(Box::new(model))
        }
        Kind::Linear => {
            if args.data.delays != 0 {
                return Err(UsageError("--delays applies to --kind ann only".into()).into());
            }
            let axes = args.data.axes("x,y,z")?;
            CorrectorModel::Linear(Box::new(LinearModel::fit(
                &measured, &reference, &axes, division,
            )?))
        }
    };
    spincal::correctors::excitation::check_inputs_used(&model, &measured).with_context(|| {
        format!(
            "{}: nothing saved (--correct-axes chooses the axes trained)",
            args.data.data.display()
        )
    })?;
    let file = CorrectorFile::new(model);
    if let Some(path) = &args.output {
        file.write_path(path)?;
    }
    let outline = file
        .corrector
        .training_outline()
        .context("a freshly trained model has its summary")?;
    let summary = Summary {
        kind: file.corrector.kind(),
        axes: outline.axes,
        hidden: outline.hidden,
        delays: outline.delays,
        epochs: outline.epochs,
        stop: outline.stop,
        fits: outline.fits,
        uncorrected: outline.uncorrected,
        model_file: args.output.as_ref().map(|p| p.display().to_string()),
    };
    if args.json {
        return ui::print_json(&summary);
    }
    ui::print(&render(&summary))
}

fn render(s: &Summary) -> String {
    let mut out = format!("corrector: {}", s.kind);
    if let Some(h) = &s.hidden {
        out += &format!(
            " [{}], delays {}",
            spincal::correctors::ann::architecture_label(h),
            s.delays
        );
    }
    out += "\n";
    if let (Some(e), Some(stop)) = (s.epochs, &s.stop) {
        out += &format!("epochs: {e} (stop: {stop})\n");
    }
    out += "fit %        corrected                 uncorrected\n";
    for (part, name) in [
        (Part::Train, "train"),
        (Part::Validation, "validation"),
        (Part::Test, "test"),
    ] {
        let join = |v: &[f64]| {
            v.iter()
                .zip(&s.axes)
                .map(|(f, a)| format!("{a} {f:6.2}"))
                .collect::<Vec<_>>()
                .join("  ")
        };
        out += &format!(
            "{name:<12} {:<25} {}\n",
            join(s.fits.get(part)),
            join(s.uncorrected.get(part))
        );
    }
    if let Some(f) = &s.model_file {
        out += &format!("saved: {f}\n");
    }
    out
}
