//! Architecture sweeps (the paper's Fig. 12): every grid entry × every restart, in parallel.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{best_run, AnnError, AnnProblem, Layout, LmSettings, StopReason, TrainingReport};
use crate::correctors::corrector::Axis;
use crate::correctors::division::Part;
use crate::correctors::division::{check_axes, DivisionMode};
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

/// The sweep's table as CSV (what `spincal sweep` writes): one row per architecture.
pub fn sweep_table_csv(rows: &[SweepRow]) -> String {
    use std::fmt::Write as _;
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

/// Trains every architecture of the grid `restarts` times on rayon's current thread pool (faer
/// runs sequentially inside each run). Results, including which restart is kept, do not depend
/// on the number of threads: every run has its own seed and is reduced in grid order. The same
/// runs made elsewhere ([`SweepJobs`], [`run_sweep_job`]) reduce to the same rows.
pub fn sweep(
    problem: &AnnProblem,
    settings: &SweepSettings,
    observer: &Observer,
) -> Result<Vec<SweepRow>, AnnError> {
    let runs = run_sweep_locally(problem, settings, observer)?;
    reduce_sweep(problem, settings, runs)
}

/// Every job of the sweep on rayon's current thread pool, largest networks first so the last
/// runs to finish are short ones.
pub fn run_sweep_locally(
    problem: &AnnProblem,
    settings: &SweepSettings,
    observer: &Observer,
) -> Result<Vec<SweepRun>, AnnError> {
    let layouts = sweep_layouts(problem, settings)?;
    let restarts = settings.restarts;
    let total = layouts.len() * restarts;
    let done = AtomicUsize::new(0);
    let mut order: Vec<usize> = (0..total).collect();
    order.sort_by_key(|&job| std::cmp::Reverse(layouts[job / restarts].n_params()));
    Ok(order
        .par_iter()
        .map(|&job| {
            // Reported before each run too, so an observer that stops the work (Ctrl-C in the
            // Python package) is heard before the next run starts rather than after it ends.
            observer(Progress::step(
                "network sweep",
                done.load(Ordering::Relaxed),
                Some(total),
            ));
            let run = train_job(problem, settings, &layouts, job);
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            observer(Progress::step("network sweep", finished, Some(total)));
            run
        })
        .collect())
}

/// One job of the sweep: architecture `job / restarts`, restart `job % restarts`. What a worker
/// of a distributed sweep runs; the result does not depend on where or when it runs.
pub fn run_sweep_job(
    problem: &AnnProblem,
    settings: &SweepSettings,
    job: usize,
) -> Result<SweepRun, AnnError> {
    let layouts = sweep_layouts(problem, settings)?;
    let total = layouts.len() * settings.restarts;
    if job >= total {
        return Err(AnnError::SweepExchange(format!(
            "job {job} does not exist: the sweep has {total} jobs (0..{total})"
        )));
    }
    Ok(train_job(problem, settings, &layouts, job))
}

fn sweep_layouts(problem: &AnnProblem, settings: &SweepSettings) -> Result<Vec<Layout>, AnnError> {
    if settings.restarts == 0 {
        return Err(AnnError::NoRestarts);
    }
    settings
        .grid
        .iter()
        .map(|hidden| problem.layout(hidden))
        .collect()
}

fn train_job(problem: &AnnProblem, settings: &SweepSettings, layouts: &[Layout], job: usize) -> SweepRun {
    let (arch, restart) = (job / settings.restarts, job % settings.restarts);
    let started = Instant::now();
    let (weights, report) = problem.train_once(&layouts[arch], settings.base_seed, restart, &settings.lm);
    SweepRun {
        job,
        weights,
        report,
        seconds: started.elapsed().as_secs_f64(),
    }
}

/// The sweep's rows from its runs, in any order, wherever they were made: each job must be
/// there exactly once. Each architecture keeps its best restart on validation.
pub fn reduce_sweep(
    problem: &AnnProblem,
    settings: &SweepSettings,
    mut runs: Vec<SweepRun>,
) -> Result<Vec<SweepRow>, AnnError> {
    let layouts = sweep_layouts(problem, settings)?;
    let restarts = settings.restarts;
    let total = layouts.len() * restarts;
    runs.sort_by_key(|run| run.job);
    let refuse = |why: String| Err(AnnError::SweepExchange(why));
    for (i, run) in runs.iter().enumerate() {
        if run.job >= total {
            return refuse(format!(
                "job {} does not exist: the sweep has {total} jobs",
                run.job
            ));
        }
        if i > 0 && runs[i - 1].job == run.job {
            return refuse(format!("job {} is there twice", run.job));
        }
        let expected = layouts[run.job / restarts].n_params();
        if run.weights.len() != expected {
            return refuse(format!(
                "job {} has {} weights, its architecture {} has {expected}",
                run.job,
                run.weights.len(),
                architecture_label(&settings.grid[run.job / restarts]),
            ));
        }
    }
    if runs.len() != total {
        let missing: Vec<String> = (0..total)
            .filter(|job| runs.binary_search_by_key(job, |run| run.job).is_err())
            .map(|job| job.to_string())
            .collect();
        return refuse(format!("job {} missing", missing.join(", ")));
    }
    let mut rows = Vec::with_capacity(layouts.len());
    for (arch, chunk) in runs.chunks_exact_mut(restarts).enumerate() {
        let best = best_run(chunk.iter().map(|run| &run.report));
        let seconds = chunk.iter().map(|run| run.seconds).sum();
        let hidden = &settings.grid[arch];
        let run = &mut chunk[best];
        let model = problem.model(
            hidden,
            std::mem::take(&mut run.weights),
            run.report.clone(),
            restarts,
            best,
            settings.base_seed,
            &settings.lm,
        );
        let report = &run.report;
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

/// One (architecture, restart) run of a sweep. `job` is its index in grid order:
/// architecture × restarts + restart.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRun {
    pub job: usize,
    pub weights: Vec<f64>,
    pub report: TrainingReport,
    /// Training time (s, one thread).
    pub seconds: f64,
}

/// The exchange form of a run: every float as its IEEE-754 bits, so NaN (an MSE without
/// validation data) and every last bit survive the trip.
#[derive(Serialize, Deserialize)]
struct SweepRunExchange {
    format: String,
    version: u32,
    job: usize,
    weights: Vec<u64>,
    epochs: usize,
    stop: StopReason,
    best_epoch: usize,
    train_mse: Vec<u64>,
    validation_mse: Vec<u64>,
    final_mu: u64,
    seconds: u64,
}

const RUN_FORMAT: &str = "spincal-sweep-run";
const JOBS_FORMAT: &str = "spincal-sweep-jobs";
const EXCHANGE_VERSION: u32 = 1;

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

fn floats(bits: &[u64]) -> Vec<f64> {
    bits.iter().map(|&b| f64::from_bits(b)).collect()
}

fn check_format(what: &str, format: &str, version: u32, expected: &str) -> Result<(), AnnError> {
    if format != expected || version != EXCHANGE_VERSION {
        return Err(AnnError::SweepExchange(format!(
            "{what} is {format:?} version {version}; this spincal ({}) reads {expected:?} version {EXCHANGE_VERSION}",
            env!("CARGO_PKG_VERSION")
        )));
    }
    Ok(())
}

impl SweepRun {
    /// JSON that [`SweepRun::from_json`] turns back into an equal run, bit for bit.
    pub fn to_json(&self) -> String {
        let r = &self.report;
        serde_json::to_string(&SweepRunExchange {
            format: RUN_FORMAT.into(),
            version: EXCHANGE_VERSION,
            job: self.job,
            weights: bits(&self.weights),
            epochs: r.epochs,
            stop: r.stop,
            best_epoch: r.best_epoch,
            train_mse: bits(&r.train_mse),
            validation_mse: bits(&r.validation_mse),
            final_mu: r.final_mu.to_bits(),
            seconds: self.seconds.to_bits(),
        })
        .expect("plain numbers serialise")
    }

    pub fn from_json(text: &str) -> Result<SweepRun, AnnError> {
        let x: SweepRunExchange = serde_json::from_str(text)
            .map_err(|e| AnnError::SweepExchange(format!("a run that cannot be read: {e}")))?;
        check_format("the run", &x.format, x.version, RUN_FORMAT)?;
        let epochs_seen = x.train_mse.len();
        if epochs_seen == 0 || x.validation_mse.len() != epochs_seen || x.best_epoch >= epochs_seen {
            return Err(AnnError::SweepExchange(format!(
                "run of job {}: {} training and {} validation MSEs with best epoch {}",
                x.job,
                epochs_seen,
                x.validation_mse.len(),
                x.best_epoch
            )));
        }
        Ok(SweepRun {
            job: x.job,
            weights: floats(&x.weights),
            report: TrainingReport {
                epochs: x.epochs,
                stop: x.stop,
                best_epoch: x.best_epoch,
                train_mse: floats(&x.train_mse),
                validation_mse: floats(&x.validation_mse),
                final_mu: f64::from_bits(x.final_mu),
            },
            seconds: f64::from_bits(x.seconds),
        })
    }
}

/// Bounds on exchanged settings that keep a damaged or hostile text from asking a worker for
/// more memory or time than any real sweep does (a refusal, never an abort).
fn check_exchanged_settings(settings: &SweepSettings) -> Result<(), AnnError> {
    let refuse = |why: String| Err(AnnError::SweepExchange(why));
    if settings.restarts == 0 || settings.restarts > 10_000 {
        return refuse(format!("restarts {}: must be 1 to 10000", settings.restarts));
    }
    if settings.grid.is_empty() || settings.grid.len() > 100_000 {
        return refuse(format!(
            "{} architectures: must be 1 to 100000",
            settings.grid.len()
        ));
    }
    if let Some(hidden) = settings
        .grid
        .iter()
        .find(|h| h.iter().any(|&n| n == 0 || n > 10_000))
    {
        return refuse(format!(
            "architecture {}: layer sizes must be 1 to 10000",
            architecture_label(hidden)
        ));
    }
    let lm = &settings.lm;
    if lm.block_samples > 1 << 20 || lm.max_epochs > 1_000_000 {
        return refuse(format!(
            "block_samples {} (at most 1048576) or max_epochs {} (at most 1000000)",
            lm.block_samples, lm.max_epochs
        ));
    }
    let positive = [lm.mu_initial, lm.mu_decrease, lm.mu_increase, lm.mu_max];
    if positive.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return refuse("the μ settings must be finite and positive".into());
    }
    Ok(())
}

/// Everything a worker needs to run any job of one sweep in another process or on another
/// machine: the problem's paired columns and the sweep's settings. Its JSON is exact (floats
/// round-trip), so a worker's [`AnnProblem`] equals the caller's and its runs are the ones the
/// local sweep makes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepJobs {
    format: String,
    version: u32,
    axes: Vec<Axis>,
    delays: usize,
    division: DivisionMode,
    /// Chosen axes of the measured recording and of its reference, m/s².
    measured: Vec<Vec<f64>>,
    reference: Vec<Vec<f64>>,
    pub settings: SweepSettings,
}

impl SweepJobs {
    pub fn new(problem: &AnnProblem, settings: &SweepSettings) -> SweepJobs {
        SweepJobs {
            format: JOBS_FORMAT.into(),
            version: EXCHANGE_VERSION,
            axes: problem.axes.clone(),
            delays: problem.delays,
            division: problem.division.mode,
            measured: problem.measured.clone(),
            reference: problem.reference.clone(),
            settings: settings.clone(),
        }
    }

    /// Number of jobs: architectures × restarts.
    pub fn len(&self) -> usize {
        self.settings.grid.len() * self.settings.restarts
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("finite numbers serialise")
    }

    /// Reads jobs made by [`SweepJobs::to_json`], checking what a damaged or foreign text could
    /// break: the format and version, one column per axis, equal lengths, finite values.
    pub fn from_json(text: &str) -> Result<SweepJobs, AnnError> {
        let jobs: SweepJobs = serde_json::from_str(text)
            .map_err(|e| AnnError::SweepExchange(format!("jobs that cannot be read: {e}")))?;
        check_format("the jobs", &jobs.format, jobs.version, JOBS_FORMAT)?;
        check_axes(&jobs.axes)?;
        let n = jobs.measured.first().map_or(0, Vec::len);
        let columns_fit = jobs.measured.len() == jobs.axes.len()
            && jobs.reference.len() == jobs.axes.len()
            && jobs.measured.iter().chain(&jobs.reference).all(|c| c.len() == n);
        if !columns_fit {
            return Err(AnnError::SweepExchange(format!(
                "{} measured and {} reference columns of unequal lengths for {} axes",
                jobs.measured.len(),
                jobs.reference.len(),
                jobs.axes.len()
            )));
        }
        if jobs
            .measured
            .iter()
            .chain(&jobs.reference)
            .flatten()
            .any(|v| !v.is_finite())
        {
            return Err(AnnError::SweepExchange("a value that is not finite".into()));
        }
        super::check_size(n, jobs.delays)?;
        check_exchanged_settings(&jobs.settings)?;
        Ok(jobs)
    }

    /// The problem the jobs were made from, rebuilt exactly.
    pub fn problem(&self) -> AnnProblem {
        AnnProblem::from_columns(
            self.measured.clone(),
            self.reference.clone(),
            &self.axes,
            self.delays,
            self.division,
        )
    }
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
