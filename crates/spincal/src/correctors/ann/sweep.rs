//! Architecture sweeps (the paper's Fig. 12): every grid entry × every restart, in parallel.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{best_run, AnnError, AnnProblem, LmSettings, Part, TrainingReport};
use crate::progress::{Observer, Progress};

/// The paper's grid: one hidden layer of 1–15 units, then two layers of 1–15 × 1–10 units
/// (165 architectures).
pub fn default_grid() -> Vec<Vec<usize>> {
    let mut grid: Vec<Vec<usize>> = (1..=15).map(|n| vec![n]).collect();
    for first in 1..=15 {
        for second in 1..=10 {
            grid.push(vec![first, second]);
        }
    }
    grid
}

/// The small grid used by `spincal demo` and by default: one layer of 1–8 units, two layers of
/// 2–8 × 2–6 (even sizes).
pub fn small_grid() -> Vec<Vec<usize>> {
    let mut grid: Vec<Vec<usize>> = (1..=8).map(|n| vec![n]).collect();
    for first in (2..=8).step_by(2) {
        for second in (2..=6).step_by(2) {
            grid.push(vec![first, second]);
        }
    }
    grid
}

/// A hidden-layer or grid text that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SizesError {
    #[error("'{0}': expected hidden-layer sizes such as 10,6 (or `none` for no hidden layer)")]
    Hidden(String),
    #[error("'{0}': expected grid entries such as 1-15;1-15,1-10 (`;` between entries, `,` between layers, sizes from 1)")]
    Grid(String),
}

/// Parses hidden-layer sizes `10,6`, or `none` for a network without hidden layers.
pub fn parse_hidden_sizes(text: &str) -> Result<Vec<usize>, SizesError> {
    if text.trim().eq_ignore_ascii_case("none") {
        return Ok(Vec::new());
    }
    text.split(',')
        .map(|s| s.trim().parse::<usize>().ok().filter(|&n| n > 0))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| SizesError::Hidden(text.to_string()))
}

/// Expands a grid such as `1-15;1-15,1-10`: `;`-separated entries, each the product of its
/// `,`-separated size ranges (`1-15,1-10` is every two-layer network of 1–15 × 1–10 units).
pub fn parse_grid(text: &str) -> Result<Vec<Vec<usize>>, SizesError> {
    let bad = || SizesError::Grid(text.to_string());
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
                return Err(bad());
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
        return Err(bad());
    }
    Ok(grid)
}

/// Samples of each epoch's JᵀJ when screening architectures ([`LmSettings::hessian_samples`]):
/// 32 blocks of 256. Recordings up to ~13,000 samples (training part ≤ 8,192) are unaffected.
pub const SWEEP_HESSIAN_SAMPLES: usize = 8192;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepSettings {
    pub grid: Vec<Vec<usize>>,
    pub restarts: usize,
    pub base_seed: u64,
    pub lm: LmSettings,
}

/// One architecture's result: its best restart on validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepRow {
    /// Hidden layer sizes joined by '-', e.g. "10-6".
    pub architecture: String,
    pub hidden: Vec<usize>,
    pub best_validation_mse: f64,
    /// Fit % of the best restart, mean over axes, original units.
    pub train_fit_percent: f64,
    pub validation_fit_percent: f64,
    pub test_fit_percent: f64,
    /// Epochs of the best restart.
    pub epochs: usize,
    pub best_restart: usize,
    /// Training time summed over all restarts of this architecture (CPU seconds on one thread).
    pub seconds: f64,
}

/// Trains every architecture of the grid `restarts` times on rayon's current thread pool (faer
/// runs sequentially inside each run). Results, including which restart is kept, do not depend
/// on the number of threads: every run has its own seed and is reduced in grid order.
pub fn sweep(
    problem: &AnnProblem,
    settings: &SweepSettings,
    observer: &Observer,
) -> Result<Vec<SweepRow>, AnnError> {
    if settings.restarts == 0 {
        return Err(AnnError::NoRestarts);
    }
    let layouts = settings
        .grid
        .iter()
        .map(|hidden| problem.layout(hidden))
        .collect::<Result<Vec<_>, _>>()?;
    let restarts = settings.restarts;
    let total = layouts.len() * restarts;
    let done = AtomicUsize::new(0);
    // Largest networks first so the last runs to finish are short ones.
    let mut order: Vec<usize> = (0..total).collect();
    order.sort_by_key(|&job| std::cmp::Reverse(layouts[job / restarts].n_params()));
    let mut runs: Vec<(usize, Vec<f64>, TrainingReport, f64)> = order
        .par_iter()
        .map(|&job| {
            let (arch, restart) = (job / restarts, job % restarts);
            // Reported before each run too, so an observer that stops the work (Ctrl-C in the
            // Python package) is heard before the next run starts rather than after it ends.
            observer(Progress::step(
                "network sweep",
                done.load(Ordering::Relaxed),
                Some(total),
            ));
            let started = Instant::now();
            let (weights, report) =
                problem.train_once(&layouts[arch], settings.base_seed, restart, &settings.lm);
            let seconds = started.elapsed().as_secs_f64();
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            observer(Progress::step("network sweep", finished, Some(total)));
            (job, weights, report, seconds)
        })
        .collect();
    runs.sort_by_key(|run| run.0);
    let mut rows = Vec::with_capacity(layouts.len());
    for (arch, chunk) in runs.chunks_exact_mut(restarts).enumerate() {
        let best = best_run(chunk.iter().map(|run| &run.2));
        let seconds = chunk.iter().map(|run| run.3).sum();
        let hidden = &settings.grid[arch];
        let (_, weights, report, _) = &mut chunk[best];
        let model = problem.model(
            hidden,
            std::mem::take(weights),
            report.clone(),
            restarts,
            best,
            settings.base_seed,
            &settings.lm,
        );
        let fits = &model.training.as_ref().expect("model() fills the summary").fits;
        rows.push(SweepRow {
            architecture: architecture_label(hidden),
            hidden: hidden.clone(),
            best_validation_mse: report.best_validation_mse(),
            train_fit_percent: fits.mean(Part::Train),
            validation_fit_percent: fits.mean(Part::Validation),
            test_fit_percent: fits.mean(Part::Test),
            epochs: report.epochs,
            best_restart: best,
            seconds,
        });
    }
    Ok(rows)
}

/// "10-6" for two hidden layers of 10 and 6 units; "none" without hidden layers.
pub fn architecture_label(hidden: &[usize]) -> String {
    if hidden.is_empty() {
        return "none".into();
    }
    hidden.iter().map(usize::to_string).collect::<Vec<_>>().join("-")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_grid_is_the_papers_and_parses_from_text() {
        let grid = parse_grid("1-15;1-15,1-10").unwrap();
        assert_eq!(grid.len(), 165);
        assert_eq!(grid, default_grid());
        assert_eq!(parse_grid("10,6").unwrap(), vec![vec![10, 6]]);
        assert!(parse_grid("0-3").is_err());
        assert_eq!(small_grid().len(), 20);
        assert_eq!(parse_hidden_sizes("10, 6"), Ok(vec![10, 6]));
        assert_eq!(parse_hidden_sizes("none"), Ok(vec![]));
        assert!(parse_hidden_sizes("10,0").is_err());
        assert!(parse_hidden_sizes("ten").is_err());
    }
}
