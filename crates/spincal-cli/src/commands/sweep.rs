//! `spincal sweep`: trains a grid of network architectures (the paper's Fig. 12) and writes the
//! table as CSV and JSON.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;
use spincal::correctors::ann::{parse_grid, sweep, sweep_table_csv, AnnProblem, SweepRow, SweepSettings};
use spincal::progress::Progress;
use spincal::report::plot::{Figure, HeatMap};

use super::train::DataArgs;
use crate::ui::{self, Ui, UsageError};

#[derive(Args)]
pub struct SweepArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Architectures: `;`-separated entries of `,`-separated size ranges; each entry is the
    /// product of its ranges. Default: one layer of 1–15, two layers of 1–15 × 1–10.
    #[arg(long, default_value = "1-15;1-15,1-10")]
    pub grid: String,
    /// Output prefix: writes PREFIX.csv, PREFIX.json and the heat map PREFIX-heatmap.svg/.png.
    #[arg(short, long, default_value = "sweep")]
    pub output: PathBuf,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Samples each epoch's JᵀJ is formed from (blocks spread over the training part; errors and
    /// gradient use all of it); 0 = all. Screening with a subsampled JᵀJ keeps a full sweep on a
    /// long recording to minutes; `spincal train` then trains the chosen network exactly.
    #[arg(long, default_value_t = spincal::correctors::ann::SWEEP_HESSIAN_SAMPLES)]
    pub hessian_samples: usize,
    /// Print the table as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct SweepOutput<'a> {
    data: String,
    reference: String,
    axes: Vec<spincal::correctors::corrector::Axis>,
    delays: usize,
    restarts: usize,
    base_seed: u64,
    /// Samples of each epoch's JᵀJ (null: all).
    hessian_samples: Option<usize>,
    wall_seconds: f64,
    rows: &'a [SweepRow],
    spincal_version: &'static str,
    /// The table and heat maps written beside this file, so that a later run knows them as its own.
    outputs: Vec<spincal::output::NamedFingerprint>,
}

pub fn run(args: SweepArgs, ui: Ui) -> anyhow::Result<()> {
    let stem = args.output.display().to_string();
    let outputs = [
        args.output.with_extension("csv"),
        args.output.with_extension("json"),
        PathBuf::from(format!("{stem}-heatmap.svg")),
        PathBuf::from(format!("{stem}-heatmap.png")),
    ];
    super::check_outputs(
        &[&args.data.data, &args.data.reference],
        &outputs.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
    )?;
    let grid = parse_grid(&args.grid).map_err(|e| UsageError(format!("--grid {e}")))?;
    let axes = args.data.axes("x,y")?;
    let (measured, reference) = args.data.read()?;
    let problem = AnnProblem::new(
        &measured,
        &reference,
        &axes,
        args.data.delays,
        args.data.division(),
    )?;
    let settings = SweepSettings {
        grid,
        restarts: args.data.restarts,
        base_seed: args.data.seed,
        lm: args.data.lm(args.hessian_samples),
    };
    let bar = ui.progress((settings.grid.len() * settings.restarts) as u64, "sweep");
    let observer = |p: Progress| ui::show(&bar, p);
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let started = std::time::Instant::now();
    let rows = pool.install(|| sweep(&problem, &settings, &observer))?;
    bar.finish_and_clear();
    let mut output = SweepOutput {
        data: args.data.data.display().to_string(),
        reference: args.data.reference.display().to_string(),
        axes,
        delays: args.data.delays,
        restarts: settings.restarts,
        base_seed: settings.base_seed,
        hessian_samples: settings.lm.hessian_samples,
        wall_seconds: started.elapsed().as_secs_f64(),
        rows: &rows,
        spincal_version: env!("CARGO_PKG_VERSION"),
        outputs: Vec::new(),
    };
    let csv_path = args.output.with_extension("csv");
    let json_path = args.output.with_extension("json");
    super::write_text(&csv_path, &sweep_table_csv(&rows))?;
    let mut heatmap_paths = Vec::new();
    if let Some(map) = HeatMap::of_sweep(&rows) {
        let stem = args.output.display().to_string();
        let svg_path = PathBuf::from(format!("{stem}-heatmap.svg"));
        let png_path = PathBuf::from(format!("{stem}-heatmap.png"));
        super::write_text(&svg_path, &map.to_svg()?)?;
        map.to_png(&png_path, 1200, 820)?;
        heatmap_paths = vec![svg_path, png_path];
    }
    // The JSON comes last and names the others with their fingerprints.
    let written: Vec<&std::path::Path> = std::iter::once(csv_path.as_path())
        .chain(heatmap_paths.iter().map(PathBuf::as_path))
        .collect();
    output.outputs = spincal::output::named_fingerprints(&written)?;
    super::write_text(&json_path, &(serde_json::to_string_pretty(&output)? + "\n"))?;
    if args.json {
        return ui::print_json(&output);
    }
    let mut text = summary(&output, &csv_path, &json_path);
    for p in &heatmap_paths {
        let _ = writeln!(text, "wrote {}", p.display());
    }
    ui::print(&text)
}

fn summary(output: &SweepOutput, csv: &std::path::Path, json: &std::path::Path) -> String {
    let mut ranked: Vec<&SweepRow> = output.rows.iter().collect();
    ranked.sort_by(|a, b| a.best_validation_mse.total_cmp(&b.best_validation_mse));
    let mut out = format!(
        "{} architectures × {} restarts in {:.1} s\nbest on validation (fit % mean over axes):\n",
        output.rows.len(),
        output.restarts,
        output.wall_seconds
    );
    out += "architecture  val MSE      train   val     test    epochs\n";
    for r in ranked.iter().take(10) {
        let _ = writeln!(
            out,
            "{:<13} {:<12.4e} {:>6.2}  {:>6.2}  {:>6.2}  {:>6}",
            r.architecture,
            r.best_validation_mse,
            r.train_fit_percent,
            r.validation_fit_percent,
            r.test_fit_percent,
            r.epochs
        );
    }
    let _ = writeln!(out, "wrote {} and {}", csv.display(), json.display());
    out
}
