//! `spincal sweep`: trains a grid of network architectures (the paper's Fig. 12) and writes the
//! table as CSV and JSON.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;
use spincal::ann::{sweep, AnnProblem, SweepProgress, SweepRow, SweepSettings};

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
    /// Output prefix: writes PREFIX.csv and PREFIX.json.
    #[arg(short, long, default_value = "sweep")]
    pub output: PathBuf,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the table as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Expands `1-15;1-15,1-10` into hidden-layer lists.
pub fn parse_grid(text: &str) -> anyhow::Result<Vec<Vec<usize>>> {
    let bad = || UsageError(format!("--grid {text}: expected entries such as 1-15;1-15,1-10"));
    let mut grid = Vec::new();
    for entry in text.split(';').filter(|e| !e.trim().is_empty()) {
        let mut layers: Vec<Vec<usize>> = vec![Vec::new()];
        for range in entry.split(',') {
            let (lo, hi) = match range.trim().split_once('-') {
                Some((a, b)) => (a.trim().parse::<usize>(), b.trim().parse::<usize>()),
                None => (range.trim().parse::<usize>(), range.trim().parse::<usize>()),
            };
            let (lo, hi) = (lo.map_err(|_| bad())?, hi.map_err(|_| bad())?);
            if lo == 0 || hi < lo {
                return Err(bad().into());
            }
            layers = layers
                .into_iter()
                .flat_map(|prefix| {
                    (lo..=hi).map(move |n| {
                        let mut p = prefix.clone();
                        p.push(n);
                        p
                    })
                })
                .collect();
        }
        grid.extend(layers);
    }
    if grid.is_empty() {
        return Err(bad().into());
    }
    Ok(grid)
}

#[derive(Serialize)]
struct SweepOutput<'a> {
    data: String,
    reference: String,
    axes: Vec<spincal::corrector::Axis>,
    delays: usize,
    restarts: usize,
    base_seed: u64,
    wall_seconds: f64,
    rows: &'a [SweepRow],
}

pub fn run(args: SweepArgs, ui: Ui) -> anyhow::Result<()> {
    let grid = parse_grid(&args.grid)?;
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
        lm: args.data.lm(),
    };
    let bar = ui.progress((settings.grid.len() * settings.restarts) as u64, "sweep");
    let observer = |p: SweepProgress| bar.set_position(p.done as u64);
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let started = std::time::Instant::now();
    let rows = pool.install(|| sweep(&problem, &settings, &observer))?;
    bar.finish_and_clear();
    let output = SweepOutput {
        data: args.data.data.display().to_string(),
        reference: args.data.reference.display().to_string(),
        axes,
        delays: args.data.delays,
        restarts: settings.restarts,
        base_seed: settings.base_seed,
        wall_seconds: started.elapsed().as_secs_f64(),
        rows: &rows,
    };
    let csv_path = args.output.with_extension("csv");
    let json_path = args.output.with_extension("json");
    std::fs::write(&csv_path, table_csv(&rows))
        .with_context(|| format!("{}: cannot write", csv_path.display()))?;
    std::fs::write(&json_path, serde_json::to_string_pretty(&output)? + "\n")
        .with_context(|| format!("{}: cannot write", json_path.display()))?;
    if args.json {
        return ui::print_json(&output);
    }
    ui::print(&summary(&output, &csv_path, &json_path))
}

fn table_csv(rows: &[SweepRow]) -> String {
    let mut out = String::from(
        "architecture,best_validation_mse,train_fit_percent,validation_fit_percent,test_fit_percent,epochs,best_restart,seconds\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{}",
            r.architecture,
            r.best_validation_mse,
            r.train_fit_percent,
            r.validation_fit_percent,
            r.test_fit_percent,
            r.epochs,
            r.best_restart,
            r.seconds
        );
    }
    out
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_grid_is_the_papers() {
        let grid = parse_grid("1-15;1-15,1-10").unwrap();
        assert_eq!(grid.len(), 165);
        assert_eq!(grid, spincal::ann::default_grid());
        assert_eq!(parse_grid("10,6").unwrap(), vec![vec![10, 6]]);
        assert!(parse_grid("0-3").is_err());
    }
}
