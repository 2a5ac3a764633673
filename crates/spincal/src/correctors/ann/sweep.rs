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
