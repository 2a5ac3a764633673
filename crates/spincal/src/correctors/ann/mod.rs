//! The neural-network corrector (SPEC §3, first bullet): a feed-forward network trained with
//! Levenberg–Marquardt on a 60/20/20 division, with restarts and architecture sweeps.
//!
//! [`AnnProblem`] holds the scaled, divided data once; [`AnnProblem::train`] trains one
//! architecture with restarts and returns an [`AnnModel`] (a [`crate::correctors::corrector::Corrector`]);
//! [`sweep`] trains a grid of architectures in parallel.

mod cholesky;
mod data;
mod factored;
mod gram;
mod lm;
pub(crate) mod network;
mod sweep;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use data::{Dataset, Scaling};
pub use lm::{full_jacobian, JtjConvention, LmSettings, LmWorkspace, StopReason, TrainingReport};
pub use network::{Layout, Network, MAX_HIDDEN_LAYERS};
pub use sweep::{
    architecture_label, default_grid, parse_grid, parse_hidden_sizes, reduce_sweep, run_sweep_job,
    run_sweep_locally, small_grid, sweep, sweep_table_csv, SizesError, SweepJobs, SweepRow, SweepRun,
    SweepSettings, SWEEP_HESSIAN_SAMPLES,
};

use crate::correctors::corrector::{
    axes_phrase, check_model_axes, Axis, CorrectedSample, Corrector, ModelError, SampleCorrector,
};
use crate::correctors::division::{
    check_axes, check_pairing, Division, DivisionMode, PairingError, Part, PartFits,
};
use crate::input::recording::Recording;
use crate::metrics::fit_percent;

/// What can be wrong with a network training request.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AnnError {
    /// The axes or the two recordings do not pair up (shared with every corrector).
    #[error(transparent)]
    Pairing(#[from] PairingError),
    #[error("{samples} samples with {delays} delays leave too few for a 60/20/20 division (need at least {needed})")]
    TooFewSamples {
        samples: usize,
        delays: usize,
        needed: usize,
    },
    #[error("{0} hidden layers asked for; at most {MAX_HIDDEN_LAYERS} are supported")]
    TooManyHiddenLayers(usize),
    #[error("hidden layer {layer} has no units")]
    EmptyLayer { layer: usize },
    #[error("restarts must be at least 1")]
    NoRestarts,
    #[error("{0} delays asked for; at most {MAX_DELAYS} are supported")]
    TooManyDelays(usize),
    /// A sweep's jobs or runs as exchanged with other processes ([`SweepJobs`], [`SweepRun`])
    /// that cannot be used.
    #[error("sweep exchange: {0}")]
    SweepExchange(String),
}

/// Largest number of delays a network may use, in training and in a saved file. Each delay adds
/// one network input per axis, and Levenberg–Marquardt forms a matrix of (number of weights)²:
/// at 1000 delays on three axes a single hidden unit already has over 3000 weights, and ten units
/// would need a 7 GB matrix, so no trainable network comes near the limit. A file beyond it is
/// damaged, and refusing it keeps the delay history of a stream small.
pub const MAX_DELAYS: usize = 1000;

/// Smallest usable sample count: each part needs a few samples.
const MIN_SAMPLES: usize = 10;

/// How far beyond its training range (as a fraction of that range) an input may go before a
/// corrected sample is flagged as an extrapolation ([`CorrectedSample::outside_training_range`]).
pub const EXTRAPOLATION_MARGIN: f64 = 0.1;

/// At most [`MAX_DELAYS`] delays, and enough of `n` samples left after them for a division.
fn check_size(n: usize, delays: usize) -> Result<(), AnnError> {
    if delays > MAX_DELAYS {
        return Err(AnnError::TooManyDelays(delays));
    }
    let needed = delays + MIN_SAMPLES;
    if n < needed {
        return Err(AnnError::TooFewSamples {
            samples: n,
            delays,
            needed,
        });
    }
    Ok(())
}

/// Measured and reference data of the chosen axes, divided and scaled, ready for training.
#[derive(Debug, Clone)]
pub struct AnnProblem {
    pub axes: Vec<Axis>,
    pub delays: usize,
    pub division: Division,
    pub input_scaling: Scaling,
    pub output_scaling: Scaling,
    pub train: Dataset,
    pub validation: Dataset,
    pub test: Dataset,
    /// Chosen axes, original units (m/s²).
    measured: Vec<Vec<f64>>,
    reference: Vec<Vec<f64>>,
}

impl AnnProblem {
    /// Pairs `measured` with `reference` sample by sample for the chosen axes. Scaling comes from
    /// the training part only, so the test part influences nothing.
    pub fn new(
        measured: &Recording,
        reference: &Recording,
        axes: &[Axis],
        delays: usize,
        mode: DivisionMode,
    ) -> Result<AnnProblem, AnnError> {
        check_axes(axes)?;
        check_pairing(measured, reference)?;
        check_size(measured.len(), delays)?;
        let pick = |r: &Recording| -> Vec<Vec<f64>> {
            axes.iter().map(|a| r.accel_mps2[a.index()].clone()).collect()
        };
        Ok(AnnProblem::from_columns(
            pick(measured),
            pick(reference),
            axes,
            delays,
            mode,
        ))
    }

    /// The problem from columns already paired and checked: one per axis, of equal length.
    fn from_columns(
        measured: Vec<Vec<f64>>,
        reference: Vec<Vec<f64>>,
        axes: &[Axis],
        delays: usize,
        mode: DivisionMode,
    ) -> AnnProblem {
        let n = measured[0].len();
        let division = Division::new(n, delays, mode);
        let m: Vec<&[f64]> = measured.iter().map(Vec::as_slice).collect();
        let r: Vec<&[f64]> = reference.iter().map(Vec::as_slice).collect();
        let input_scaling = Scaling::fit(&m, &division.train);
        let output_scaling = Scaling::fit(&r, &division.train);
        let build = |rows| Dataset::build(&m, &r, delays, &input_scaling, &output_scaling, rows);
        let train = build(&division.train);
        let validation = build(&division.validation);
        let test = build(&division.test);
        AnnProblem {
            axes: axes.to_vec(),
            delays,
            division,
            input_scaling,
            output_scaling,
            train,
            validation,
            test,
            measured,
            reference,
        }
    }

    /// The network shape for `hidden` on this problem.
    pub fn layout(&self, hidden: &[usize]) -> Result<Layout, AnnError> {
        if hidden.len() > MAX_HIDDEN_LAYERS {
            return Err(AnnError::TooManyHiddenLayers(hidden.len()));
        }
        if let Some(layer) = hidden.iter().position(|&h| h == 0) {
            return Err(AnnError::EmptyLayer { layer: layer + 1 });
        }
        Ok(Layout::new(self.train.n_inputs, hidden, self.train.n_outputs))
    }

    /// Nguyen–Widrow initial weights of restart `restart` (seeded by `restart_seed`).
    pub fn initial_weights(&self, layout: &Layout, base_seed: u64, restart: usize) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(restart_seed(base_seed, restart));
        layout.nguyen_widrow(&mut rng)
    }

    /// One LM run from the given restart's initial weights.
    pub fn train_once(
        &self,
        layout: &Layout,
        base_seed: u64,
        restart: usize,
        settings: &LmSettings,
    ) -> (Vec<f64>, TrainingReport) {
        let mut weights = self.initial_weights(layout, base_seed, restart);
        let mut workspace = LmWorkspace::new(layout, settings.block_samples);
        let report = workspace.train(&mut weights, &self.train, &self.validation, settings);
        (weights, report)
    }

    /// Trains `restarts` times from seeds derived from `base_seed` and keeps the run with the
    /// lowest validation MSE (earliest restart on ties). Restarts run in parallel on rayon's
    /// current pool; the result does not depend on the number of threads.
    pub fn train(
        &self,
        hidden: &[usize],
        restarts: usize,
        base_seed: u64,
        settings: &LmSettings,
    ) -> Result<AnnModel, AnnError> {
        if restarts == 0 {
            return Err(AnnError::NoRestarts);
        }
        let layout = self.layout(hidden)?;
        let runs: Vec<(Vec<f64>, TrainingReport)> = (0..restarts)
            .into_par_iter()
            .map(|r| self.train_once(&layout, base_seed, r, settings))
            .collect();
        let best = best_run(runs.iter().map(|(_, report)| report));
        let (weights, report) = runs.into_iter().nth(best).expect("best is an index of runs");
        Ok(self.model(hidden, weights, report, restarts, best, base_seed, settings))
    }

    /// Wraps trained weights into a saveable model with its training summary.
    #[allow(clippy::too_many_arguments)]
    pub fn model(
        &self,
        hidden: &[usize],
        weights: Vec<f64>,
        report: TrainingReport,
        restarts: usize,
        best_restart: usize,
        base_seed: u64,
        settings: &LmSettings,
    ) -> AnnModel {
        let network = Network {
            inputs: self.train.n_inputs,
            hidden: hidden.to_vec(),
            outputs: self.train.n_outputs,
            weights,
        };
        let mut model = AnnModel {
            axes: self.axes.clone(),
            delays: self.delays,
            input_scaling: self.input_scaling.clone(),
            output_scaling: self.output_scaling.clone(),
            network,
            training: None,
        };
        let fits = self.fits(&model);
        model.training = Some(AnnTrainingSummary {
            base_seed,
            restarts,
            best_restart,
            settings: settings.clone(),
            report,
            fits,
            uncorrected: self.uncorrected_fits(),
            division: self.division.clone(),
        });
        model
    }

    /// Fit % of a model on each part, per axis, in original units.
    pub fn fits(&self, model: &AnnModel) -> PartFits {
        let layout = model.network.layout();
        let fit_part = |part: Part, data: &Dataset| -> Vec<f64> {
            let predicted = model.predict_scaled(&layout, data);
            self.part_fit(part, |c, k| {
                model.output_scaling.reverse(c, predicted[k * data.n_outputs + c])
            })
        };
        PartFits {
            train: fit_part(Part::Train, &self.train),
            validation: fit_part(Part::Validation, &self.validation),
            test: fit_part(Part::Test, &self.test),
        }
    }

    /// Fit % of the measured signal itself against the reference (what correction must beat).
    pub fn uncorrected_fits(&self) -> PartFits {
        let samples = |part: Part| -> Vec<usize> {
            self.division
                .ranges(part)
                .iter()
                .flat_map(|r| r.clone())
                .collect()
        };
        let fit = |part: Part| -> Vec<f64> {
            let idx = samples(part);
            (0..self.axes.len())
                .map(|c| {
                    let y: Vec<f64> = idx.iter().map(|&i| self.reference[c][i]).collect();
                    let m: Vec<f64> = idx.iter().map(|&i| self.measured[c][i]).collect();
                    fit_percent(&y, &m)
                })
                .collect()
        };
        PartFits {
            train: fit(Part::Train),
            validation: fit(Part::Validation),
            test: fit(Part::Test),
        }
    }

    /// Fit % per axis of estimates `estimate(axis, k)` for the k-th sample of `part`.
    fn part_fit(&self, part: Part, estimate: impl Fn(usize, usize) -> f64) -> Vec<f64> {
        let idx: Vec<usize> = self
            .division
            .ranges(part)
            .iter()
            .flat_map(|r| r.clone())
            .collect();
        (0..self.axes.len())
            .map(|c| {
                let y: Vec<f64> = idx.iter().map(|&i| self.reference[c][i]).collect();
                let e: Vec<f64> = (0..idx.len()).map(|k| estimate(c, k)).collect();
                fit_percent(&y, &e)
            })
            .collect()
    }
}

/// Index of the run with the lowest validation MSE (training MSE when there is no validation
/// data); the earliest wins ties, so the choice never depends on scheduling.
fn best_run<'a>(reports: impl Iterator<Item = &'a TrainingReport>) -> usize {
    let mut best = (0, f64::INFINITY);
    for (i, report) in reports.enumerate() {
        let mut key = report.best_validation_mse();
        if !key.is_finite() {
            key = report.best_train_mse();
        }
        if key < best.1 {
            best = (i, key);
        }
    }
    best.0
}

/// The seed of restart `restart`: a SplitMix64 mix of the base seed and the restart index, so the
/// same architecture and restart get the same start in `train` and in `sweep`.
pub(crate) fn restart_seed(base_seed: u64, restart: usize) -> u64 {
    fn mix(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    mix(base_seed ^ mix(restart as u64))
}

/// How an [`AnnModel`] was trained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnnTrainingSummary {
    pub base_seed: u64,
    pub restarts: usize,
    pub best_restart: usize,
    pub settings: LmSettings,
    /// The kept run's report, with per-epoch training and validation MSE.
    pub report: TrainingReport,
    pub fits: PartFits,
    pub uncorrected: PartFits,
    pub division: Division,
}

impl AnnTrainingSummary {
    /// The summary agrees with a model of `n_axes` axes and `delays` delays: the kept restart
    /// is one of the restarts, the kept epoch one of the report's, one fit per axis, and the
    /// division starts after the delays. Fields relative to the summary.
    fn check(&self, n_axes: usize, delays: usize) -> Result<(), ModelError> {
        if self.best_restart >= self.restarts {
            return Err(ModelError::new(
                "best_restart",
                format!(
                    "{}, but there were {} restarts (counted from 0)",
                    self.best_restart, self.restarts
                ),
            ));
        }
        let report = &self.report;
        let epochs = report.train_mse.len();
        if report.validation_mse.len() != epochs {
            return Err(ModelError::new(
                "report.validation_mse",
                format!(
                    "{} values, but report.train_mse has {epochs} (one per epoch each)",
                    report.validation_mse.len()
                ),
            ));
        }
        if report.best_epoch >= epochs {
            return Err(ModelError::new(
                "report.best_epoch",
                format!(
                    "{}, but the report has {epochs} epochs (counted from 0)",
                    report.best_epoch
                ),
            ));
        }
        self.fits.check(n_axes).map_err(|e| e.within("fits"))?;
        self.uncorrected
            .check(n_axes)
            .map_err(|e| e.within("uncorrected"))?;
        self.division.check(delays).map_err(|e| e.within("division"))
    }
}

/// A trained network corrector: everything needed to apply it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnnModel {
    /// Axes read (in this order, each with its delays) and corrected.
    pub axes: Vec<Axis>,
    /// Previous samples of each axis used besides the current one.
    pub delays: usize,
    pub input_scaling: Scaling,
    pub output_scaling: Scaling,
    pub network: Network,
    pub training: Option<AnnTrainingSummary>,
}

impl AnnModel {
    /// Checks the model against its own structure, everything that applying it relies on:
    /// distinct axes, at most [`MAX_DELAYS`] delays, `network.inputs` = axes × (delays + 1) (the
    /// tapped-delay row: per axis the sample and `delays` before it), `network.outputs` = axes,
    /// the network itself ([`Network::check`]), one finite `min ≤ max` scaling per axis for the
    /// inputs and outputs, and a training summary (if any) that agrees with the model. Fields
    /// are relative to the model (`network.weights`). A model that passes never panics when
    /// applied.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_model_axes("axes", &self.axes)?;
        if self.delays > MAX_DELAYS {
            return Err(ModelError::new(
                "delays",
                format!("{} is above the limit of {MAX_DELAYS}", self.delays),
            ));
        }
        let n_axes = self.axes.len();
        // Both factors are small now (at most 3 axes, MAX_DELAYS): no overflow.
        let inputs = n_axes * (self.delays + 1);
        if self.network.inputs != inputs {
            return Err(ModelError::new(
                "network.inputs",
                format!(
                    "{} inputs, but axes × (delays + 1) = {n_axes} × ({} + 1) = {inputs}",
                    self.network.inputs, self.delays
                ),
            ));
        }
        if self.network.outputs != n_axes {
            return Err(ModelError::new(
                "network.outputs",
                format!(
                    "{}, but the model corrects {} and needs one output per axis",
                    self.network.outputs,
                    axes_phrase(n_axes)
                ),
            ));
        }
        self.network.check().map_err(|e| e.within("network"))?;
        self.input_scaling
            .check(n_axes)
            .map_err(|e| e.within("input_scaling"))?;
        self.output_scaling
            .check(n_axes)
            .map_err(|e| e.within("output_scaling"))?;
        if let Some(training) = &self.training {
            training
                .check(n_axes, self.delays)
                .map_err(|e| e.within("training"))?;
        }
        Ok(())
    }

    /// Network outputs (scaled) for every row of `data`, row-major.
    pub fn predict_scaled(&self, layout: &Layout, data: &Dataset) -> Vec<f64> {
        let (n_in, n_out) = (layout.inputs(), layout.outputs());
        let out_at = layout.n_activations() - n_out;
        let mut activations = vec![0.0; layout.n_activations()];
        let mut out = Vec::with_capacity(data.len() * n_out);
        for row in 0..data.len() {
            layout.forward(
                &self.network.weights,
                &data.inputs[row * n_in..(row + 1) * n_in],
                &mut activations,
            );
            out.extend_from_slice(&activations[out_at..]);
        }
        out
    }

    /// Batch correction of a whole recording through the training-time data path: corrected
    /// values of the chosen axes (original units) for samples `delays..`, per axis.
    pub fn correct_batch(&self, recording: &Recording) -> Vec<Vec<f64>> {
        let m: Vec<&[f64]> = self
            .axes
            .iter()
            .map(|a| recording.accel_mps2[a.index()].as_slice())
            .collect();
        let n = recording.len();
        if n <= self.delays {
            return vec![Vec::new(); self.axes.len()];
        }
        let rows = self.delays..n;
        let data = Dataset::build(
            &m,
            &m,
            self.delays,
            &self.input_scaling,
            &self.input_scaling,
            std::slice::from_ref(&rows),
        );
        let layout = self.network.layout();
        let predicted = self.predict_scaled(&layout, &data);
        (0..self.axes.len())
            .map(|c| {
                (0..data.len())
                    .map(|k| self.output_scaling.reverse(c, predicted[k * data.n_outputs + c]))
                    .collect()
            })
            .collect()
    }
}

/// Streaming state of an [`AnnModel`]: the scaled delay history of each axis.
struct AnnStream<'a> {
    model: &'a AnnModel,
    layout: Layout,
    /// Network input row in the training layout: per axis, lag 0 … `delays`.
    history: Vec<f64>,
    activations: Vec<f64>,
    seen: usize,
}

impl SampleCorrector for AnnStream<'_> {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        let model = self.model;
        let lags = model.delays + 1;
        let mut outside = false;
        for (c, axis) in model.axes.iter().enumerate() {
            let row = &mut self.history[c * lags..(c + 1) * lags];
            row.copy_within(0..lags - 1, 1);
            row[0] = model.input_scaling.apply(c, accel_mps2[axis.index()]);
            // The training range maps to [−1, 1], a width of 2.
            outside |= row[0].abs() > 1.0 + 2.0 * EXTRAPOLATION_MARGIN;
        }
        self.seen += 1;
        // Outside its training range a network extrapolates: the reading goes through
        // uncorrected and the sample is marked invalid, so a network never makes data it did
        // not see worse than no correction.
        let mut out = CorrectedSample {
            accel_mps2,
            valid: self.seen > model.delays && !outside,
            outside_training_range: outside,
        };
        if out.valid {
            self.layout
                .forward(&model.network.weights, &self.history, &mut self.activations);
            let out_at = self.activations.len() - model.axes.len();
            for (c, axis) in model.axes.iter().enumerate() {
                out.accel_mps2[axis.index()] = model.output_scaling.reverse(c, self.activations[out_at + c]);
            }
        }
        out
    }
}

impl Corrector for AnnModel {
    fn corrected_axes(&self) -> Vec<Axis> {
        self.axes.clone()
    }

    fn warmup_samples(&self) -> usize {
        self.delays
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        let layout = self.network.layout();
        Box::new(AnnStream {
            model: self,
            history: vec![0.0; layout.inputs()],
            activations: vec![0.0; layout.n_activations()],
            layout,
            seen: 0,
        })
    }
}
