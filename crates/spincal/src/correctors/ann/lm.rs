//! Levenberg–Marquardt training with MATLAB `trainlm`'s rules.
//!
//! Each epoch forms the normal equations at the current weights a block of samples at a time:
//! a forward pass and the outputs' sensitivities by backpropagation, a layer at a time over the
//! whole block (with a vectorised tanh), then JᵀJ and Jᵀe from their Kronecker factors
//! (`factored`: one small matrix product per pair of layers, run by `gram`), so J is
//! never formed. Then (JᵀJ + μI)·Δ = Jᵀe is solved by Cholesky (`cholesky`), retrying
//! with μ×10 until the training error falls. All buffers live in [`LmWorkspace`]: an epoch
//! allocates nothing.
//!
//! Convention: J is the derivative of the network outputs (scaled to [−1, 1]) with respect to the
//! weights and e = target − output, over every training sample and output. By default
//! ([`JtjConvention::Sum`]) JᵀJ and Jᵀe are plain sums, as in the original `trainlm` (Hagan &
//! Menhaj 1994) and pyrenn; [`JtjConvention::Mean`] divides both by the number of error elements,
//! as recent MATLAB versions do, which is the same as multiplying μ by that number.

use faer::{Mat, MatMut, MatRef};
use pulp::{Arch, Simd, WithSimd};
use serde::{Deserialize, Serialize};

use super::cholesky::Cholesky;
use super::data::Dataset;
use super::factored::FactoredPlan;
use super::network::Layout;

/// Whether JᵀJ and Jᵀe are sums or means over the error elements (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JtjConvention {
    Sum,
    Mean,
}

/// Training settings; the defaults are trainlm's and the paper's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LmSettings {
    pub mu_initial: f64,
    pub mu_decrease: f64,
    pub mu_increase: f64,
    pub mu_max: f64,
    /// Stop when the gradient of the training sum of squared errors, 2‖Jᵀe‖, is below this.
    pub min_gradient: f64,
    /// Stop when an epoch lowers the training error by less than this fraction (1 ppm).
    pub min_relative_decrease: f64,
    /// Stop when the validation error has not improved for this many epochs.
    pub max_validation_failures: usize,
    pub max_epochs: usize,
    pub convention: JtjConvention,
    /// Samples per Jacobian block (256 by default: one output's J of a block, ~0.23 MB at 110
    /// weights, stays in L2; 192 and 384 measured 1–3 % slower).
    pub block_samples: usize,
    /// Form JᵀJ from about this many training samples per epoch (whole blocks spread evenly over
    /// the training part, scaled to the full sum) instead of all; the errors, Jᵀe and the accepted
    /// step still use every sample. `None` uses all. A subsampled Gauss–Newton matrix: each epoch
    /// costs ~N/S times less when N ≫ S, and LM's step acceptance on the full error keeps training
    /// monotone. The sweep screens architectures this way.
    pub hessian_samples: Option<usize>,
}

impl Default for LmSettings {
    fn default() -> Self {
        LmSettings {
            mu_initial: 1e-3,
            mu_decrease: 0.1,
            mu_increase: 10.0,
            mu_max: 1e10,
            min_gradient: 1e-7,
            min_relative_decrease: 1e-6,
            max_validation_failures: 15,
            max_epochs: 1000,
            convention: JtjConvention::Sum,
            block_samples: 256,
            hessian_samples: None,
        }
    }
}

/// Why training ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The training error fell by less than `min_relative_decrease` in an epoch.
    MinRelativeDecrease,
    /// The validation error did not improve for `max_validation_failures` epochs.
    ValidationStop,
    MaxEpochs,
    /// μ exceeded `mu_max`: no step lowered the training error.
    MuMax,
    MinGradient,
    /// The training error reached zero.
    PerfectFit,
}

impl StopReason {
    /// Why training stopped, for people.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::MinRelativeDecrease => "the training error stopped falling",
            StopReason::ValidationStop => "early stop: the validation error stopped improving",
            StopReason::MaxEpochs => "the epoch limit",
            StopReason::MuMax => "the damping limit: no step lowers the training error",
            StopReason::MinGradient => "the gradient vanished",
            StopReason::PerfectFit => "a perfect fit",
        }
    }
}

/// What happened during one training run. MSEs are over the scaled outputs ([−1, 1]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingReport {
    /// Epochs with an accepted step.
    pub epochs: usize,
    pub stop: StopReason,
    /// The epoch whose weights were kept (lowest validation MSE; 0 = the initial weights).
    pub best_epoch: usize,
    /// Training MSE after each epoch, starting with the initial weights.
    pub train_mse: Vec<f64>,
    /// Validation MSE after each epoch (NaN when there is no validation data).
    pub validation_mse: Vec<f64>,
    pub final_mu: f64,
}

impl TrainingReport {
    pub fn best_train_mse(&self) -> f64 {
        self.train_mse[self.best_epoch]
    }

    pub fn best_validation_mse(&self) -> f64 {
        self.validation_mse[self.best_epoch]
    }
}

/// Which blocks enter JᵀJ (every `stride`-th, starting with the first) and the factor that scales
/// their sum to all `n` samples, for at most about `target` samples.
fn hessian_subsample(n: usize, block: usize, target: Option<usize>) -> (usize, f64) {
    let blocks = n.div_ceil(block.max(1));
    let stride = match target {
        Some(t) if t > 0 => blocks.div_ceil(t.div_ceil(block.max(1))).max(1),
        _ => 1,
    };
    if stride == 1 {
        return (1, 1.0);
    }
    let used: usize = (0..blocks)
        .step_by(stride)
        .map(|b| block.min(n - b * block))
        .sum();
    (stride, n as f64 / used as f64)
}

/// The most memory a workspace keeps for a trial pass's activations (64 MiB: a 2-[10, 6]-2
/// network's for 400,000 samples); larger training sets recompute the forward pass.
pub(crate) const ACTIVATION_CACHE_BYTES: usize = 64 << 20;

/// How each epoch's damped steps are tried: the damping's scale (1, or the element count for
/// the mean convention) and whether a trial pass keeps its activations for the next epoch.
#[derive(Clone, Copy)]
struct Trial {
    mu_scale: f64,
    reuse_activations: bool,
}

/// Every buffer an LM run needs, sized for one network shape and block length.
pub struct LmWorkspace {
    layout: Layout,
    block_samples: usize,
    /// How JᵀJ and Jᵀe are formed from factor products, and the products' sums over the blocks.
    plan: FactoredPlan,
    sums: Vec<f64>,
    /// One block's buffer of `plan.block_columns()` columns of its sample count: the values the
    /// products read (forward pass, sensitivities, errors) and the factor columns formed from
    /// them. Starts at `block_at` (32-byte aligned, for whole-vector loads).
    block: Vec<f64>,
    block_at: usize,
    /// A trial pass's activations when they are not kept for the whole training set.
    activations: Vec<f64>,
    /// Every unit's values over the whole training set, block after block (each laid out as
    /// [`Layout::forward_block`] writes it), from the last trial pass that ran to the end. An
    /// accepted step's trial pass is the next epoch's forward pass, so it is kept instead of
    /// recomputed; empty when the training set would need more than `activation_budget` bytes.
    trial_activations: Vec<f64>,
    activation_budget: usize,
    jtj: Mat<f64>,
    jte: Mat<f64>,
    cholesky: Cholesky,
    step: Vec<f64>,
    trial: Vec<f64>,
    best: Vec<f64>,
}

impl LmWorkspace {
    pub fn new(layout: &Layout, block_samples: usize) -> LmWorkspace {
        let n_p = layout.n_params();
        let block_samples = block_samples.max(1);
        let plan = FactoredPlan::new(layout);
        let block = vec![0.0; plan.block_columns().total * block_samples + 3];
        let block_at = (32 - block.as_ptr() as usize % 32) % 32 / 8;
        LmWorkspace {
            layout: layout.clone(),
            block_samples,
            sums: vec![0.0; plan.sums_len()],
            plan,
            block,
            block_at,
            activations: vec![0.0; layout.n_activations() * block_samples],
            trial_activations: Vec::new(),
            activation_budget: ACTIVATION_CACHE_BYTES,
            jtj: Mat::zeros(n_p, n_p),
            jte: Mat::zeros(n_p, 1),
            cholesky: Cholesky::new(n_p),
            step: vec![0.0; n_p],
            trial: vec![0.0; n_p],
            best: vec![0.0; n_p],
        }
    }

    /// Forms JᵀJ (lower triangle) and Jᵀe at `weights` over `data`; returns the sum of squared
    /// errors. `hessian_samples` as in [`LmSettings::hessian_samples`].
    pub fn normal_equations(
        &mut self,
        weights: &[f64],
        data: &Dataset,
        hessian_samples: Option<usize>,
    ) -> f64 {
        self.normal_equations_from(weights, data, hessian_samples, false)
    }

    /// [`LmWorkspace::normal_equations`]; with `reuse_trial`, the forward pass is read from
    /// `trial_activations`, which the caller knows to hold `weights` over `data`.
    fn normal_equations_from(
        &mut self,
        weights: &[f64],
        data: &Dataset,
        hessian_samples: Option<usize>,
        reuse_trial: bool,
    ) -> f64 {
        self.sums.fill(0.0);
        let (hessian_stride, hessian_scale) =
            hessian_subsample(data.len(), self.block_samples, hessian_samples);
        let sse = Arch::new().dispatch(Blocks {
            workspace: self,
            weights,
            data,
            hessian_stride,
            reuse_trial,
        });
        self.plan
            .unpack(&self.sums, hessian_scale, &mut self.jtj, &mut self.jte);
        sse
    }

    /// The block loop of [`LmWorkspace::normal_equations`], inlined into [`Blocks`]: every
    /// `hessian_stride`-th block adds to the Gram matrices, the others only to Jᵀe.
    #[inline(always)]
    fn accumulate_blocks(
        &mut self,
        weights: &[f64],
        data: &Dataset,
        hessian_stride: usize,
        reuse_trial: bool,
    ) -> f64 {
        let layout = &self.layout;
        let (n_in, n_out) = (layout.inputs(), layout.outputs());
        let n_act = layout.n_activations();
        let out_at = n_act - n_out;
        let block = self.block_samples;
        let columns = self.plan.block_columns();
        let hidden_units = layout.hidden_units();
        let mut sse = 0.0;
        let n = data.len();
        let mut start = 0;
        while start < n {
            let count = block.min(n - start);
            let buffer = &mut self.block[self.block_at..][..columns.total * count];
            // Each region is `count` values a column, where the products read it.
            let (constants, rest) = buffer.split_at_mut(columns.activations * count);
            let (activations, rest) = rest.split_at_mut(n_act * count);
            let (sensitivities, rest) = rest.split_at_mut(n_out * hidden_units * count);
            let errors = &mut rest[..n_out * count];
            let (zeros, ones) = constants.split_at_mut(count);
            zeros.fill(0.0);
            ones.fill(1.0);
            if reuse_trial {
                activations.copy_from_slice(&self.trial_activations[start * n_act..(start + count) * n_act]);
            } else {
                layout.forward_block(
                    weights,
                    &data.inputs[start * n_in..(start + count) * n_in],
                    count,
                    activations,
                );
            }
            let outputs = &activations[out_at * count..(out_at + n_out) * count];
            add_block_errors(data, outputs, start, count, &mut sse, |at, e| errors[at] = e);
            if hidden_units > 0 {
                for (k, sensitivities) in sensitivities.chunks_exact_mut(hidden_units * count).enumerate() {
                    layout.sensitivities_block(weights, activations, count, k, sensitivities);
                }
            }
            let in_hessian = (start / block).is_multiple_of(hessian_stride);
            self.plan.add_block(buffer, count, in_hessian, &mut self.sums);
            start += count;
        }
        sse
    }

    /// At most `bytes` kept for a trial pass's activations (`ACTIVATION_CACHE_BYTES` by
    /// default; 0 recomputes every forward pass). Results do not depend on it, bit for bit.
    pub fn set_activation_budget(&mut self, bytes: usize) {
        self.activation_budget = bytes;
        self.trial_activations = Vec::new();
    }

    /// Multiply-adds per sample in the factor products that form JᵀJ and Jᵀe: as run (tiles
    /// padded with zero columns) and without the padding.
    pub fn multiply_adds_per_sample(&self) -> (usize, usize) {
        self.plan.multiply_adds_per_sample()
    }

    /// JᵀJ's lower triangle and Jᵀe from the last [`LmWorkspace::normal_equations`].
    pub fn jtj(&self) -> MatRef<'_, f64> {
        self.jtj.as_ref()
    }

    pub fn jte(&self) -> MatRef<'_, f64> {
        self.jte.as_ref()
    }

    /// Solves (JᵀJ + μI)·step = Jᵀe into `self.step`; false when the matrix is not positive
    /// definite at this μ.
    fn solve_damped(&mut self, mu: f64) -> bool {
        let jtj = &self.jtj;
        if !self.cholesky.factor(|j| jtj.col_as_slice(j), mu) {
            return false;
        }
        for (s, g) in self.step.iter_mut().zip(self.jte.col(0).iter()) {
            *s = *g;
        }
        self.cholesky.solve_in_place(&mut self.step);
        self.step.iter().all(|s| s.is_finite())
    }

    /// Trains from `weights` and leaves there the weights of the best validation epoch (or the
    /// last epoch when `validation` is empty).
    pub fn train(
        &mut self,
        weights: &mut [f64],
        train: &Dataset,
        validation: &Dataset,
        settings: &LmSettings,
    ) -> TrainingReport {
        let n_p = self.layout.n_params();
        assert_eq!(weights.len(), n_p, "weights do not fit the workspace's network");
        let elements = (train.len() * train.n_outputs).max(1) as f64;
        let mu_scale = match settings.convention {
            JtjConvention::Sum => 1.0,
            JtjConvention::Mean => elements,
        };
        let mut train_mse = Vec::with_capacity(settings.max_epochs + 1);
        let mut validation_mse = Vec::with_capacity(settings.max_epochs + 1);
        let has_validation = !validation.is_empty();
        let mut mu = settings.mu_initial;
        let reuse_trial = self.make_room_for_trial_activations(train);
        let trial = Trial {
            mu_scale,
            reuse_activations: reuse_trial,
        };

        let mut sse = self.normal_equations(weights, train, settings.hessian_samples);
        train_mse.push(sse / elements);
        let mut best_validation = self.mse(weights, validation);
        validation_mse.push(best_validation);
        self.best.copy_from_slice(weights);
        let mut best_epoch = 0;
        let mut failures = 0;
        let mut epoch = 0;
        let stop = loop {
            if sse == 0.0 {
                break StopReason::PerfectFit;
            }
            if epoch >= settings.max_epochs {
                break StopReason::MaxEpochs;
            }
            let gradient = 2.0 * self.jte.norm_l2();
            if gradient < settings.min_gradient {
                break StopReason::MinGradient;
            }
            let Some(new_sse) = self.damped_step(weights, train, sse, &mut mu, trial, settings) else {
                break StopReason::MuMax;
            };
            weights.copy_from_slice(&self.trial);
            epoch += 1;
            let relative_decrease = (sse - new_sse) / sse;
            train_mse.push(new_sse / elements);
            let validation_now = self.mse(weights, validation);
            validation_mse.push(validation_now);
            if !has_validation || validation_now < best_validation {
                best_validation = validation_now;
                best_epoch = epoch;
                self.best.copy_from_slice(weights);
                failures = 0;
            } else {
                failures += 1;
            }
            if relative_decrease < settings.min_relative_decrease {
                break StopReason::MinRelativeDecrease;
            }
            if has_validation && failures >= settings.max_validation_failures {
                break StopReason::ValidationStop;
            }
            // Checked here too so that the last epoch does not form unused normal equations.
            if epoch >= settings.max_epochs {
                break StopReason::MaxEpochs;
            }
            // The accepted trial pass ran over every block (its sum stayed below `sse`), so its
            // activations are these weights' forward pass.
            sse = self.normal_equations_from(weights, train, settings.hessian_samples, reuse_trial);
        };
        weights.copy_from_slice(&self.best);
        TrainingReport {
            epochs: epoch,
            stop,
            best_epoch,
            train_mse,
            validation_mse,
            final_mu: mu,
        }
    }

    /// Room to keep a trial pass's activations, when they fit the budget (once per workspace and
    /// training-set size: epochs allocate nothing). Whether there is.
    fn make_room_for_trial_activations(&mut self, train: &Dataset) -> bool {
        let kept = train.len() * self.layout.n_activations();
        if kept * std::mem::size_of::<f64>() <= self.activation_budget {
            self.trial_activations.resize(kept, 0.0);
        } else {
            self.trial_activations.clear();
        }
        !self.trial_activations.is_empty()
    }

    /// trainlm: damp harder until a step lowers the training error. The step's weights are left
    /// in `self.trial` and its error returned; None once `mu` passes its maximum.
    fn damped_step(
        &mut self,
        weights: &[f64],
        train: &Dataset,
        sse: f64,
        mu: &mut f64,
        trial: Trial,
        settings: &LmSettings,
    ) -> Option<f64> {
        while *mu <= settings.mu_max {
            if self.solve_damped(*mu * trial.mu_scale) {
                for (i, (t, w)) in self.trial.iter_mut().zip(weights.iter()).enumerate() {
                    *t = w + self.step[i];
                }
                // A rejected step's error is not used: stop summing once it reaches `sse`.
                let activations = if trial.reuse_activations {
                    &mut self.trial_activations
                } else {
                    &mut self.activations
                };
                let trial_sse = sse_of(
                    &self.layout,
                    &self.trial,
                    train,
                    activations,
                    self.block_samples,
                    sse,
                );
                if trial_sse < sse {
                    *mu *= settings.mu_decrease;
                    return Some(trial_sse);
                }
            }
            *mu *= settings.mu_increase;
        }
        None
    }

    /// Mean squared error over all samples and outputs (NaN for no data).
    pub fn mse(&mut self, weights: &[f64], data: &Dataset) -> f64 {
        if data.is_empty() {
            return f64::NAN;
        }
        sse_of(
            &self.layout,
            weights,
            data,
            &mut self.activations,
            self.block_samples,
            f64::INFINITY,
        ) / (data.len() * data.n_outputs) as f64
    }

    /// Where the best weights of the last run are kept (for callers that reuse buffers).
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
}

/// Sum of squared errors of the network over `data`, `block` samples at a time; the same sum, bit
/// for bit, as per-sample [`Layout::forward`] calls. `activations` holds `n_activations() × block`
/// values, reused for every block, or `n_activations()` values per sample of `data`, which then
/// keeps every block's. Stops after the block where the sum reaches `limit` (the sum only grows),
/// returning that partial sum.
fn sse_of(
    layout: &Layout,
    weights: &[f64],
    data: &Dataset,
    activations: &mut [f64],
    block: usize,
    limit: f64,
) -> f64 {
    Arch::new().dispatch(TrialError {
        layout,
        weights,
        data,
        activations,
        block,
        limit,
    })
}

/// [`LmWorkspace::accumulate_blocks`] as a `pulp` operation. (A closure would not be inlined into
/// the dispatched function, which would then run without the vector extension.)
struct Blocks<'a> {
    workspace: &'a mut LmWorkspace,
    weights: &'a [f64],
    data: &'a Dataset,
    hessian_stride: usize,
    reuse_trial: bool,
}

impl WithSimd for Blocks<'_> {
    type Output = f64;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> f64 {
        self.workspace
            .accumulate_blocks(self.weights, self.data, self.hessian_stride, self.reuse_trial)
    }
}

/// [`sse_of`] as a `pulp` operation.
struct TrialError<'a> {
    layout: &'a Layout,
    weights: &'a [f64],
    data: &'a Dataset,
    activations: &'a mut [f64],
    block: usize,
    limit: f64,
}

impl WithSimd for TrialError<'_> {
    type Output = f64;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> f64 {
        let TrialError {
            layout,
            weights,
            data,
            activations,
            block,
            limit,
        } = self;
        let (n_in, n_out, n_act) = (layout.inputs(), layout.outputs(), layout.n_activations());
        let out_at = n_act - n_out;
        let mut sse = 0.0;
        let n = data.len();
        let keep = activations.len() >= n * n_act;
        let mut start = 0;
        while start < n {
            let count = block.min(n - start);
            let activations = if keep {
                &mut activations[start * n_act..(start + count) * n_act]
            } else {
                &mut *activations
            };
            layout.forward_block(
                weights,
                &data.inputs[start * n_in..(start + count) * n_in],
                count,
                activations,
            );
            let outputs = &activations[out_at * count..(out_at + n_out) * count];
            add_block_errors(data, outputs, start, count, &mut sse, |_, _| {});
            start += count;
            if sse >= limit {
                break;
            }
        }
        sse
    }
}

/// Adds the squared errors of the block of `count` samples from `start` to `sse`, sample after
/// sample and output after output (the order every error sum here uses), and hands each error to
/// `record` with its place `k·count + s` in an output-major block.
#[inline(always)]
fn add_block_errors(
    data: &Dataset,
    outputs: &[f64],
    start: usize,
    count: usize,
    sse: &mut f64,
    mut record: impl FnMut(usize, f64),
) {
    let n_out = outputs.len() / count;
    let targets = &data.targets[start * n_out..(start + count) * n_out];
    for s in 0..count {
        for k in 0..n_out {
            let e = targets[s * n_out + k] - outputs[k * count + s];
            record(k * count + s, e);
            *sse += e * e;
        }
    }
}

/// The whole Jacobian of the outputs over `data` (rows: sample-major, then output), for tests
/// and peer checks; training never stores it.
pub fn full_jacobian(layout: &Layout, weights: &[f64], data: &Dataset) -> Mat<f64> {
    let (n_p, n_in, n_out) = (layout.n_params(), layout.inputs(), layout.outputs());
    let mut activations = vec![0.0; layout.n_activations()];
    let mut delta = vec![0.0; layout.n_delta()];
    let mut columns = vec![0.0; n_out * n_p];
    let mut jacobian = Mat::zeros(data.len() * n_out, n_p);
    for row in 0..data.len() {
        layout.forward(
            weights,
            &data.inputs[row * n_in..(row + 1) * n_in],
            &mut activations,
        );
        layout.output_gradients(weights, &activations, &mut columns, &mut delta);
        write_rows(jacobian.as_mut(), row * n_out, &columns, n_p);
    }
    jacobian
}

fn write_rows(mut jacobian: MatMut<'_, f64>, first_row: usize, columns: &[f64], n_p: usize) {
    for (k, column) in columns.chunks_exact(n_p).enumerate() {
        for (p, v) in column.iter().enumerate() {
            jacobian[(first_row + k, p)] = *v;
        }
    }
}
