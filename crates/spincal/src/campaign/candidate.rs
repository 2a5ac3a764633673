//! The one candidate trait, [`Candidate`]: a [`TrainingSet`] in, a [`Trained`] corrector out,
//! which corrects a recording and, when its kind can be, is saved. Here are the campaign's kinds
//! (trained on runs and poses through the joint fit): the physical model's inverse (with and
//! without the nonlinearity), the 12-parameter linear map, the physical model with a network on
//! its residual, and ARX (scored, never saved). The paper's kinds, which learn from one recording
//! and its reference, are in `campaign::series_candidates`.

// Per-axis arrays are indexed together.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::campaign::joint::{
    difference_noise, fit_joint, fit_joint_from, JointFit, JointSettings, PoseInput, RunInput, SensorTerms,
};
use crate::correctors::ann::{AnnProblem, LmSettings};
use crate::correctors::corrector::{Axis, Corrected, Corrector};
use crate::correctors::division::DivisionMode;
use crate::correctors::linear::LinearModel;
use crate::correctors::model_file::CorrectorModel;
use crate::correctors::physical::{
    PhysicalCorrector, SensorCovariance, SensorModel, SensorUncertainty, SENSOR_PARAMS,
};
use crate::correctors::physical_ann::{InputCoverage, PhysicalAnnCorrector};
use crate::input::recording::Recording;
use crate::progress::Observer;

/// The kinds of corrector a campaign compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CandidateKind {
    /// The inverse of the sensor model with every term (bias, scale, misalignment, nonlinearity).
    Physical,
    /// The inverse of the sensor model without the nonlinearity.
    PhysicalLinear,
    /// Offset plus a 3 × 3 matrix (12 parameters) from measured to the fitted reference.
    Linear,
    /// The full inverse sensor model, then a small network on the residual it leaves.
    PhysicalAnn,
    /// A dynamic ARX model per axis from the three measured axes and a constant to the reference:
    /// scored on held-out conditions, never saved (no corrector file holds a dynamic model).
    Arx,
}

impl CandidateKind {
    pub const ALL: [CandidateKind; 5] = [
        CandidateKind::Physical,
        CandidateKind::PhysicalLinear,
        CandidateKind::Linear,
        CandidateKind::PhysicalAnn,
        CandidateKind::Arx,
    ];

    /// Whether a trained corrector of this kind can be saved and applied by `correct`.
    pub fn savable(self) -> bool {
        !matches!(self, CandidateKind::Arx)
    }

    pub fn name(self) -> &'static str {
        match self {
            CandidateKind::Physical => "physical",
            CandidateKind::PhysicalLinear => "physical-linear",
            CandidateKind::Linear => "linear-12",
            CandidateKind::PhysicalAnn => "physical-ann",
            CandidateKind::Arx => "arx",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            CandidateKind::Physical => {
                "inverse sensor model: bias, scale, misalignment, quadratic nonlinearity"
            }
            CandidateKind::PhysicalLinear => "inverse sensor model: bias, scale, misalignment",
            CandidateKind::Linear => "offset + 3×3 matrix fitted from measured to reference (12 parameters)",
            CandidateKind::PhysicalAnn => {
                "inverse sensor model, then a network (3-6-3, tanh) on the residual it leaves; physics alone outside the network's training range"
            }
            CandidateKind::Arx => {
                "ARX [na nb nk] = [2 2 0] per axis from the three measured axes and a constant to the reference, fitted on the pooled training runs, simulated from rest; scored only (never saved)"
            }
        }
    }
}

/// A training set: the prepared runs and poses it may use with their full joint fit (made once,
/// shared by the candidates that need it), or one recording against its reference (the paper's
/// split). Each kind learns from one of the two and says so when given the other.
pub struct TrainingSet<'a> {
    pub runs: Vec<RunInput>,
    pub poses: Vec<PoseInput>,
    pub joint: &'a JointSettings,
    /// One recording and the reference it should read, for the kinds that learn a map from it.
    series: Option<ReferenceSeries<'a>>,
    full_fit: std::sync::OnceLock<Result<JointFit, String>>,
    /// The fit with q on every axis where the settings' terms hold some at zero: the fuller fit
    /// every physical kind's error bars take (`error_bar_covariance`), made once.
    every_q_fit: std::sync::OnceLock<Result<JointFit, String>>,
}

/// A recording, the reference it should read at the same samples, and how its samples divide
/// 60/20/20 into training, validation (a network stops on it) and test.
#[derive(Clone, Copy)]
pub struct ReferenceSeries<'a> {
    pub measured: &'a Recording,
    pub reference: &'a Recording,
    pub division: &'a crate::correctors::division::Division,
}

impl<'a> TrainingSet<'a> {
    /// A training set of these runs and poses; the joint fit is made when a candidate first asks.
    pub fn new(runs: Vec<RunInput>, poses: Vec<PoseInput>, joint: &'a JointSettings) -> TrainingSet<'a> {
        TrainingSet {
            runs,
            poses,
            joint,
            series: None,
            full_fit: std::sync::OnceLock::new(),
            every_q_fit: std::sync::OnceLock::new(),
        }
    }

    /// A training set of one recording against its reference, with no runs or poses.
    pub fn of_series(series: ReferenceSeries<'a>, joint: &'a JointSettings) -> TrainingSet<'a> {
        TrainingSet {
            series: Some(series),
            ..TrainingSet::new(Vec::new(), Vec::new(), joint)
        }
    }

    /// The recording and its reference, or why a kind that needs them cannot train here.
    pub fn series(&self) -> Result<ReferenceSeries<'a>, String> {
        self.series.ok_or_else(|| {
            "this kind learns from one recording and its reference (the paper's split); this training set holds runs and poses".into()
        })
    }

    /// A training set whose joint fit with the settings' terms is already made (`fit`).
    pub fn with_fit(
        runs: Vec<RunInput>,
        poses: Vec<PoseInput>,
        joint: &'a JointSettings,
        fit: JointFit,
    ) -> TrainingSet<'a> {
        let set = TrainingSet::new(runs, poses, joint);
        let _ = set.full_fit.set(Ok(fit));
        set
    }

    /// The joint fit with the settings' terms, or with `terms` when they differ.
    pub fn fit(
        &self,
        terms: SensorTerms,
        observer: &Observer,
    ) -> Result<std::borrow::Cow<'_, JointFit>, String> {
        if terms == self.joint.terms {
            let fit = self.full_fit.get_or_init(|| {
                fit_joint(&self.runs, &self.poses, self.joint, observer).map_err(|e| e.to_string())
            });
            return fit.as_ref().map(std::borrow::Cow::Borrowed).map_err(Clone::clone);
        }
        let refit = || {
            let settings = JointSettings {
                terms,
                ..self.joint.clone()
            };
            // A nested model starts where the full one ended.
            let full = self.fit(self.joint.terms, observer).ok();
            fit_joint_from(&self.runs, &self.poses, &settings, full.as_deref(), observer)
                .map_err(|e| e.to_string())
        };
        if terms == every_q(self.joint.terms) {
            let fit = self.every_q_fit.get_or_init(refit);
            return fit.as_ref().map(std::borrow::Cow::Borrowed).map_err(Clone::clone);
        }
        refit().map(std::borrow::Cow::Owned)
    }
}

/// A corrector kind, trained on a [`TrainingSet`]. Every kind either protocol compares is one:
/// a new campaign kind is an implementation here and a `CandidateKind`; a new paper kind, one in
/// `series_candidates`.
pub trait Candidate {
    /// The name its rows carry in results.json ("physical", "ANN", "BJ").
    fn name(&self) -> String;
    /// What it is, in words.
    fn describe(&self) -> String;
    /// Whether what it trains can be saved and applied by `correct` (a static corrector); a
    /// dynamic model is scored only.
    fn savable(&self) -> bool;
    fn train(&self, training: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String>;
}

/// What a candidate's training gives: a corrector that can be saved (the physical model's inverse
/// with its parameters' covariance inside), or a dynamic model that can only be scored.
pub enum Trained {
    Corrector(CorrectorModel),
    Dynamic(Box<DynamicModel>),
}

/// A dynamic model per corrected axis; the other axes pass through.
pub struct DynamicModel {
    /// (axis index, its model).
    pub axes: Vec<(usize, crate::sysid::SysidModel)>,
    pub input: DynamicInput,
    /// The fitted structure, in words.
    pub structure: String,
}

/// What each axis's dynamic model reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DynamicInput {
    /// The three measured axes and a constant (MISO).
    AxesAndConstant,
    /// Its own measured axis (SISO, the paper's).
    OwnAxis,
}

/// Where a dynamic model's simulation starts (static correctors have no state to start).
#[derive(Clone, Copy)]
pub enum SimulationStart<'a> {
    /// From rest: all a model applied to new data has.
    Rest,
    /// From the first `samples` of a reference's axes (the paper's scoring, SPEC §4).
    Reference {
        reference: &'a [Vec<f64>; 3],
        samples: usize,
    },
}

impl Trained {
    /// The corrector to save, when the kind can be saved.
    pub fn saved(&self) -> Option<&CorrectorModel> {
        match self {
            Trained::Corrector(model) => Some(model),
            Trained::Dynamic(_) => None,
        }
    }

    /// The sensor model of the physical family's correction (the whole corrector, or the part
    /// under a network) with its parameters' covariance, when the training gave one.
    pub fn physical_part(&self) -> Option<(&SensorModel, &SensorCovariance)> {
        let physical = match self {
            Trained::Corrector(CorrectorModel::Physical(physical)) => physical.as_ref(),
            Trained::Corrector(CorrectorModel::PhysicalAnn(both)) => &both.physical,
            _ => return None,
        };
        let uncertainty = physical.uncertainty.as_ref()?;
        Some((&physical.sensor, &uncertainty.covariance))
    }

    /// The largest departure from the identity of a static corrector's gain, ∂output/∂input by
    /// central differences at each of `readings` (`None` for a dynamic model). A sensor's static
    /// errors are a few per cent: a gain far from one means the corrector discards (or amplifies)
    /// a measurement where its training data held that axis still, which no held-out recording
    /// that also holds it still can show.
    pub fn gain_error(&self, readings: &[[f64; 3]]) -> Option<f64> {
        let Trained::Corrector(model) = self else {
            return None;
        };
        const STEP_MPS2: f64 = 1e-3;
        let mut stream = model.stream();
        let mut worst: f64 = 0.0;
        for reading in readings {
            for j in 0..3 {
                let mut at = |delta: f64| {
                    let mut input = *reading;
                    input[j] += delta;
                    stream.correct_sample(input).accel_mps2
                };
                let (high, low) = (at(STEP_MPS2), at(-STEP_MPS2));
                for i in 0..3 {
                    let gain = (high[i] - low[i]) / (2.0 * STEP_MPS2);
                    let identity = if i == j { 1.0 } else { 0.0 };
                    worst = worst.max((gain - identity).abs());
                }
            }
        }
        Some(worst)
    }

    /// A recording's accelerometer after this candidate, dynamic models simulated from rest.
    pub fn correct(&self, accel: &[Vec<f64>; 3]) -> Result<Corrected, String> {
        self.correct_from(accel, SimulationStart::Rest)
    }

    /// A recording's accelerometer after this candidate, which samples it could correct and how
    /// many lay outside a network's training range; a dynamic model's simulation starts at
    /// `start`.
    pub fn correct_from(
        &self,
        accel: &[Vec<f64>; 3],
        start: SimulationStart<'_>,
    ) -> Result<Corrected, String> {
        let n = accel[0].len();
        match self {
            Trained::Corrector(model) => Ok(model.correct_accel(accel)),
            Trained::Dynamic(dynamic) => {
                let ones = vec![1.0; n];
                let mut out = accel.clone();
                for (axis, model) in &dynamic.axes {
                    let inputs: Vec<&[f64]> = match dynamic.input {
                        DynamicInput::AxesAndConstant => vec![&accel[0], &accel[1], &accel[2], &ones],
                        DynamicInput::OwnAxis => vec![&accel[*axis]],
                    };
                    let init = match start {
                        SimulationStart::Rest => crate::sysid::SimInit::Zero,
                        SimulationStart::Reference { reference, samples } => {
                            crate::sysid::SimInit::Measured {
                                y: &reference[*axis],
                                n: samples,
                            }
                        }
                    };
                    out[*axis] = model.simulate(&inputs, init).map_err(|e| e.to_string())?;
                }
                let valid = (0..n)
                    .map(|s| dynamic.axes.iter().all(|(axis, _)| out[*axis][s].is_finite()))
                    .collect();
                Ok(Corrected {
                    accel_mps2: out,
                    valid,
                    outside_training_range: 0,
                })
            }
        }
    }
}

/// How a campaign kind trains; its name, words and savability are its [`CandidateKind`]'s.
trait Trainer {
    fn train(&self, training: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String>;
}

/// A campaign kind: a [`Trainer`] under its [`CandidateKind`].
struct OfKind<T> {
    kind: CandidateKind,
    trainer: T,
}

impl<T: Trainer> Candidate for OfKind<T> {
    fn name(&self) -> String {
        self.kind.name().into()
    }
    fn describe(&self) -> String {
        self.kind.describe().into()
    }
    fn savable(&self) -> bool {
        self.kind.savable()
    }
    fn train(&self, training: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        self.trainer.train(training, observer)
    }
}

fn input_range(runs: &[RunInput], poses: &[PoseInput]) -> [[f64; 2]; 3] {
    let mut range = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
    for run in runs {
        for k in 0..3 {
            for (s, &v) in run.accel_mps2[k].iter().enumerate() {
                if run.keep[s] {
                    range[k][0] = range[k][0].min(v);
                    range[k][1] = range[k][1].max(v);
                }
            }
        }
    }
    for pose in poses {
        for k in 0..3 {
            range[k][0] = range[k][0].min(pose.mean_mps2[k]);
            range[k][1] = range[k][1].max(pose.mean_mps2[k]);
        }
    }
    range.map(|r| if r[0] <= r[1] { r } else { [0.0, 0.0] })
}

/// The white noise of one reading per axis: the median over the runs (first differences) and the
/// poses (their within-pose noise, or their mean's spread times √samples).
fn reading_noise(runs: &[RunInput], poses: &[PoseInput]) -> [f64; 3] {
    let mut per_source: Vec<[f64; 3]> = runs
        .iter()
        .map(|r| difference_noise(&r.accel_mps2, &r.keep))
        .collect();
    per_source.extend(poses.iter().map(|p| match p.wander {
        Some(w) => w.noise_sd_mps2,
        None => p.sigma_mean_mps2.map(|s| s * (p.samples.max(1) as f64).sqrt()),
    }));
    std::array::from_fn(|k| {
        let mut values: Vec<f64> = per_source
            .iter()
            .map(|s| s[k])
            .filter(|v| v.is_finite())
            .collect();
        values.sort_by(f64::total_cmp);
        values.get(values.len() / 2).copied().unwrap_or(0.0)
    })
}

/// The physical model's inverse from a joint fit, with its parameters' covariance and the
/// readings' noise.
fn physical_corrector(t: &TrainingSet<'_>, fit: &JointFit) -> PhysicalCorrector {
    PhysicalCorrector {
        sensor: fit.sensor,
        gravity_mps2: t.joint.gravity_mps2,
        input_range_mps2: input_range(&t.runs, &t.poses),
        uncertainty: fit.sensor_covariance().map(|covariance| SensorUncertainty {
            covariance,
            noise_sd_mps2: reading_noise(&t.runs, &t.poses),
            // One offset cannot be told from the bias: a campaign of one session saw no spread.
            session_spread_mps2: (fit.bias_spread.offsets >= 2).then_some(fit.bias_spread.sd_mps2),
        }),
    }
}

/// The covariance that a correction from `fit` (made with `terms`) takes for its error bars, and
/// the sensor of the fuller fit it comes from (q on every axis, also where the terms rule holds it
/// at zero). A model that leaves terms out errs by the fuller fit's error plus the move its kept
/// terms made to absorb the left-out ones: the fuller fit's covariance plus d dᵀ, d the change of
/// every parameter from the fuller fit, shrunk by (1 − k/W)₊ (W the Wald statistic of the k
/// left-out terms jointly), the share of the move that noise alone would not make (E[W] = k where
/// they are zero). On bench/accuracy's twelve phone poses, where the rule drops a q at 2.8–3
/// standard errors, the fuller covariance alone left error/sd RMS 1.71; on seven one-file poses,
/// where q is barely seen, it was 0.74 (bench/accuracy/RESULTS.md).
fn error_bar_covariance(
    t: &TrainingSet<'_>,
    fit: &JointFit,
    terms: SensorTerms,
    observer: &Observer,
) -> Result<(Option<SensorCovariance>, SensorModel), String> {
    let full_terms = every_q(t.joint.terms);
    if terms == full_terms {
        return Ok((fit.sensor_covariance(), fit.sensor));
    }
    let full = t.fit(full_terms, observer)?;
    let covariance = match (fit.sensor_covariance(), full.sensor_covariance()) {
        (Some(_), Some(mut covariance)) => {
            let (kept, theta) = (fit.sensor.params(), full.sensor.params());
            let left_out: Vec<usize> = (0..SENSOR_PARAMS)
                .filter(|&k| !terms.free(k) && full_terms.free(k))
                .collect();
            let share = wald_statistic(&covariance, &theta, &left_out)
                .map_or(1.0, |w| crate::metrics::share_beyond_noise(w, left_out.len()));
            let d: [f64; SENSOR_PARAMS] = std::array::from_fn(|k| kept[k] - theta[k]);
            for a in 0..SENSOR_PARAMS {
                for b in 0..SENSOR_PARAMS {
                    covariance[a][b] += share * d[a] * d[b];
                }
            }
            Some(covariance)
        }
        (own, _) => own,
    };
    Ok((covariance, full.sensor))
}

/// `terms` with q on every axis (where they fit q at all).
fn every_q(terms: SensorTerms) -> SensorTerms {
    SensorTerms {
        nonlinearity_axes: [true; 3],
        ..terms
    }
}

/// θ_oᵀ Σ_oo⁻¹ θ_o over the parameters `o`; `None` where there are none or Σ_oo is singular.
pub(crate) fn wald_statistic(covariance: &SensorCovariance, theta: &[f64], o: &[usize]) -> Option<f64> {
    if o.is_empty() {
        return None;
    }
    use faer::prelude::Solve;
    let sigma = faer::Mat::from_fn(o.len(), o.len(), |a, b| covariance[o[a]][o[b]]);
    let llt = sigma.llt(faer::Side::Lower).ok()?;
    let x = llt.solve(faer::Mat::from_fn(o.len(), 1, |a, _| theta[o[a]]));
    let w: f64 = (0..o.len()).map(|a| theta[o[a]] * x[(a, 0)]).sum();
    (w.is_finite() && w > 0.0).then_some(w)
}

struct PhysicalCandidate(SensorTerms);

impl Trainer for PhysicalCandidate {
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        // q on the axes the campaign's terms rule keeps.
        let terms = SensorTerms {
            nonlinearity_axes: t.joint.terms.nonlinearity_axes,
            ..self.0
        };
        let fit = t.fit(terms, observer)?;
        let mut physical = physical_corrector(t, &fit);
        if let (Some(uncertainty), (Some(covariance), _)) = (
            physical.uncertainty.as_mut(),
            error_bar_covariance(t, &fit, terms, observer)?,
        ) {
            uncertainty.covariance = covariance;
        }
        Ok(Trained::Corrector(CorrectorModel::Physical(Box::new(physical))))
    }
}

/// Samples per run used to fit the 12-parameter map (evenly spaced); enough for 12 unknowns.
const LINEAR_SAMPLES_PER_RUN: usize = 4000;

struct LinearCandidate;

/// Directions of gravity (a Fibonacci lattice) over which the map's departure from the fuller
/// model is averaged.
const DEPARTURE_DIRECTIONS: usize = 500;

/// One sample of the 12-parameter map's least squares: the reading, the joint fit's reference
/// for it, and its weight.
struct MapPoint {
    m: [f64; 3],
    f: [f64; 3],
    w: f64,
}

/// `[m, 1]`: the map's regressors (the offset last).
fn regressors(m: [f64; 3]) -> [f64; 4] {
    [m[0], m[1], m[2], 1.0]
}

/// The index in `LinearModel::params` (offsets, then the matrix row by row) of corrected axis
/// `k`'s coefficient on regressor `a` of [`regressors`].
fn map_param(k: usize, a: usize) -> usize {
    if a == 3 {
        k
    } else {
        3 + 3 * k + a
    }
}

impl Trainer for LinearCandidate {
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        // The reference is the full physical fit's specific force.
        let fit = t.fit(t.joint.terms, observer)?;
        // Rows weighted equally per sample; a pose's mean counts as many samples as it averages
        // (capped like a run).
        let mut points = Vec::new();
        for (i, run) in t.runs.iter().enumerate() {
            let reference = fit.run_reference(i, &run.time_s);
            let step = (run.time_s.len() / LINEAR_SAMPLES_PER_RUN).max(1);
            for s in (0..run.time_s.len()).step_by(step) {
                if run.keep[s] {
                    points.push(MapPoint {
                        m: [run.accel_mps2[0][s], run.accel_mps2[1][s], run.accel_mps2[2][s]],
                        f: [reference[0][s], reference[1][s], reference[2][s]],
                        w: 1.0,
                    });
                }
            }
        }
        for (p, pose) in t.poses.iter().enumerate() {
            points.push(MapPoint {
                m: pose.mean_mps2,
                f: fit.poses[p].specific_force_mps2,
                w: pose.samples.min(LINEAR_SAMPLES_PER_RUN) as f64,
            });
        }
        // Normal equations of f_k = c_k + Σ_j A_kj m_j, one matrix for the three axes.
        let mut ata = [[0.0f64; 4]; 4];
        for point in &points {
            let x = regressors(point.m);
            for a in 0..4 {
                for b in 0..4 {
                    ata[a][b] += point.w * x[a] * x[b];
                }
            }
        }
        let lu = faer::Mat::from_fn(4, 4, |i, j| ata[i][j]).partial_piv_lu();
        let identity = faer::Mat::<f64>::identity(4, 4);
        let inverse = faer::prelude::Solve::solve(&lu, &identity);
        let n_inv: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| inverse[(i, j)]));
        let mut xtf = [[0.0f64; 4]; 3];
        for point in &points {
            let x = regressors(point.m);
            for k in 0..3 {
                for a in 0..4 {
                    xtf[k][a] += point.w * x[a] * point.f[k];
                }
            }
        }
        let solution: [[f64; 4]; 3] =
            std::array::from_fn(|k| std::array::from_fn(|a| (0..4).map(|b| n_inv[a][b] * xtf[k][b]).sum()));
        let matrix: Vec<Vec<f64>> = (0..3).map(|k| solution[k][..3].to_vec()).collect();
        let offset: Vec<f64> = (0..3).map(|k| solution[k][3]).collect();
        if matrix.iter().flatten().chain(&offset).any(|v| !v.is_finite()) {
            return Err(
                "the 12-parameter map is singular on this training set (too few distinct orientations)"
                    .into(),
            );
        }
        let mut model = LinearModel {
            axes: Axis::ALL.to_vec(),
            offset_mps2: offset,
            matrix,
            training: None,
            uncertainty: None,
        };
        let (sensor_covariance, fuller) = error_bar_covariance(t, &fit, t.joint.terms, observer)?;
        model.uncertainty = sensor_covariance.map(|covariance| SensorUncertainty {
            covariance: map_covariance(
                &model,
                &points,
                &n_inv,
                &fit.sensor,
                &covariance,
                &fuller,
                t.joint.gravity_mps2,
            ),
            noise_sd_mps2: reading_noise(&t.runs, &t.poses),
            // As the physical kind's (`physical_corrector`).
            session_spread_mps2: (fit.bias_spread.offsets >= 2).then_some(fit.bias_spread.sd_mps2),
        });
        Ok(Trained::Corrector(CorrectorModel::Linear(Box::new(model))))
    }
}

/// The covariance of the 12-parameter map (`LinearModel::params` order), as its error bars take
/// it. The map is least squares from the readings to a reference that the joint fit estimates:
/// a pose's reference is the gravity direction the sensor model fits to that pose's reading, so
/// the map follows the fitted model's inverse g_θ̂(m) and inherits its parameters' error, which
/// the map's own residuals cannot show. Three parts, added:
/// - the reference's error: the map as the least-squares projection of g_θ (over the training
///   readings, with their weights) moves with θ by G = (XᵀWX)⁻¹ XᵀW ∂g/∂θ, so G Σ_θ Gᵀ with Σ_θ
///   the physical kind's error-bar covariance (`error_bar_covariance`: the fuller fit's, a
///   left-out term's variance raised to its squared estimate);
/// - what a map cannot hold: the fuller fit's inverse is not affine where it has q, and a map
///   fitted where the training readings crowd (a run's, near one direction of gravity) follows
///   its tangent there. The mean square over every direction of gravity of the map's departure
///   from the fuller fit's inverse at a still reading (per axis) is added to that axis's offset
///   variance, so every row's sd carries it: an RMS over directions, not the departure at a
///   given reading;
/// - the map's sampling error: the heteroscedasticity-robust sandwich (XᵀWX)⁻¹ Σ w² r rᵀ x xᵀ
///   (XᵀWX)⁻¹ of its residuals r, a pose's mean one point.
///
/// Measured on the independent generator (tests/error_bars.rs, 12 units, RMS of error/sd at new
/// orientations; 24 one-file poses | 12 poses and two runs): the sandwich alone 3.1 | –, the
/// reference's error alone 9.6 | –, the departure alone 1.25 | 8.1, departure and reference
/// 1.05 | 2.0, all three 0.98 | 1.98 (the physical kind's own: 0.78 | 1.75); with the campaign
/// file's datasheet prior on q and the joint covariance's floor at the model's own (the physical
/// kind's 0.76 | 1.12), all three give 0.95 | 1.17. So the reference's
/// error matters where runs crowd the readings, the departure where poses spread them, and the
/// departure averaged over the training readings instead of the sphere erred narrow with runs
/// (2.3).
fn map_covariance(
    model: &LinearModel,
    points: &[MapPoint],
    n_inv: &[[f64; 4]; 4],
    sensor: &SensorModel,
    sensor_covariance: &SensorCovariance,
    fuller: &SensorModel,
    gravity_mps2: f64,
) -> SensorCovariance {
    // G: ∂(map parameter)/∂θ.
    let mut xtj = [[[0.0f64; SENSOR_PARAMS]; 4]; 3];
    for point in points {
        let Some((_, jac)) = sensor.correct_with_jacobian(point.m) else {
            continue;
        };
        let x = regressors(point.m);
        for k in 0..3 {
            for a in 0..4 {
                for q in 0..SENSOR_PARAMS {
                    xtj[k][a][q] += point.w * x[a] * jac[k][q];
                }
            }
        }
    }
    let mut g = [[0.0f64; SENSOR_PARAMS]; SENSOR_PARAMS];
    for k in 0..3 {
        for a in 0..4 {
            for q in 0..SENSOR_PARAMS {
                g[map_param(k, a)][q] = (0..4).map(|b| n_inv[a][b] * xtj[k][b][q]).sum();
            }
        }
    }
    let mut covariance = [[0.0f64; SENSOR_PARAMS]; SENSOR_PARAMS];
    for i in 0..SENSOR_PARAMS {
        for j in 0..SENSOR_PARAMS {
            let mut sum = 0.0;
            for a in 0..SENSOR_PARAMS {
                for b in 0..SENSOR_PARAMS {
                    sum += g[i][a] * sensor_covariance[a][b] * g[j][b];
                }
            }
            covariance[i][j] = sum;
        }
    }
    // The sandwich of the map's residuals.
    for point in points {
        let x = regressors(point.m);
        let nx: [f64; 4] = std::array::from_fn(|a| (0..4).map(|b| n_inv[a][b] * x[b]).sum());
        let fitted = model.apply(point.m);
        let r: [f64; 3] = std::array::from_fn(|k| point.f[k] - fitted[k]);
        for k in 0..3 {
            for l in 0..3 {
                for a in 0..4 {
                    for b in 0..4 {
                        covariance[map_param(k, a)][map_param(l, b)] +=
                            point.w * point.w * r[k] * r[l] * nx[a] * nx[b];
                    }
                }
            }
        }
    }
    // What the map leaves of the fuller model's inverse over every direction of gravity.
    let mut departure = [0.0f64; 3];
    for i in 0..DEPARTURE_DIRECTIONS {
        let n = crate::geometry::lattice_direction(i, DEPARTURE_DIRECTIONS);
        let m = fuller.measure(n.map(|v| gravity_mps2 * v));
        let (mapped, truth) = (model.apply(m), fuller.correct(m).unwrap_or(m));
        for k in 0..3 {
            departure[k] += (mapped[k] - truth[k]).powi(2) / DEPARTURE_DIRECTIONS as f64;
        }
    }
    for k in 0..3 {
        covariance[k][k] += departure[k];
    }
    // Symmetric to the last bit, as model.json's reader checks.
    for i in 0..SENSOR_PARAMS {
        for j in 0..i {
            let mean = 0.5 * (covariance[i][j] + covariance[j][i]);
            covariance[i][j] = mean;
            covariance[j][i] = mean;
        }
    }
    covariance
}

/// Samples per run pooled for the network on top of physics (evenly spaced).
const PHYSICAL_ANN_SAMPLES_PER_RUN: usize = 1000;
/// Each still pose's mean counts as this many samples in the pooled set.
const PHYSICAL_ANN_POSE_WEIGHT: usize = 50;
/// The network: one hidden layer of six tanh units, two restarts, a fixed seed.
const PHYSICAL_ANN_HIDDEN: [usize; 1] = [6];
const PHYSICAL_ANN_RESTARTS: usize = 2;
const PHYSICAL_ANN_SEED: u64 = 1;

struct PhysicalAnnCandidate;

impl Trainer for PhysicalAnnCandidate {
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        let terms = SensorTerms {
            nonlinearity_axes: t.joint.terms.nonlinearity_axes,
            ..SensorTerms::ALL
        };
        let fit = t.fit(terms, observer)?;
        let physical = physical_corrector(t, &fit);
        // Pooled samples: the physical correction as input, what it left against the joint
        // fit's reference as the target. Static (no delays): the samples are not one series.
        let mut input: [Vec<f64>; 3] = Default::default();
        let mut residual: [Vec<f64>; 3] = Default::default();
        let mut add = |m: [f64; 3], reference: [f64; 3]| {
            if let Some(p) = physical.sensor.correct(m) {
                for k in 0..3 {
                    input[k].push(p[k]);
                    residual[k].push(reference[k] - p[k]);
                }
            }
        };
        for (i, run) in t.runs.iter().enumerate() {
            let reference = fit.run_reference(i, &run.time_s);
            let step = (run.time_s.len() / PHYSICAL_ANN_SAMPLES_PER_RUN).max(1);
            for s in (0..run.time_s.len()).step_by(step) {
                if run.keep[s] {
                    let m = [run.accel_mps2[0][s], run.accel_mps2[1][s], run.accel_mps2[2][s]];
                    add(m, [reference[0][s], reference[1][s], reference[2][s]]);
                }
            }
        }
        for (p, pose) in t.poses.iter().enumerate() {
            for _ in 0..PHYSICAL_ANN_POSE_WEIGHT {
                add(pose.mean_mps2, fit.poses[p].specific_force_mps2);
            }
        }
        let coverage = InputCoverage::of(&input);
        let n = input[0].len();
        let as_recording = |accel: [Vec<f64>; 3]| Recording {
            time_s: (0..n).map(|i| i as f64).collect(),
            accel_mps2: accel,
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        let (measured, target) = (as_recording(input), as_recording(residual));
        // Small interleaved blocks: every run and pose group reaches training and validation.
        let problem = AnnProblem::new(
            &measured,
            &target,
            &Axis::ALL,
            0,
            DivisionMode::Interleaved { block_len: 20 },
        )
        .map_err(|e| format!("network on top of physics: {e}"))?;
        let network = problem
            .train(
                &PHYSICAL_ANN_HIDDEN,
                PHYSICAL_ANN_RESTARTS,
                PHYSICAL_ANN_SEED,
                &LmSettings {
                    max_epochs: 300,
                    ..LmSettings::default()
                },
            )
            .map_err(|e| format!("network on top of physics: {e}"))?;
        // Its physical part's uncertainty is what predicts its error off the network's range.
        Ok(Trained::Corrector(CorrectorModel::PhysicalAnn(Box::new(
            PhysicalAnnCorrector {
                physical,
                network,
                coverage,
            },
        ))))
    }
}

/// ARX orders of the dynamic candidate: two past outputs, the current and previous sample of each
/// measured axis, and a constant.
const ARX_NA: usize = 2;
const ARX_NB: usize = 2;

struct ArxCandidate;

impl Trainer for ArxCandidate {
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        let fit = t.fit(t.joint.terms, observer)?;
        if t.runs.is_empty() {
            return Err("no turntable run to train a dynamic model on".into());
        }
        // The training runs end to end (their few joint samples are part of the fit), the kept
        // samples only: measured axes and a constant in, the joint fit's reference out.
        let mut inputs: [Vec<f64>; 4] = Default::default();
        let mut target: [Vec<f64>; 3] = Default::default();
        for (i, run) in t.runs.iter().enumerate() {
            let reference = fit.run_reference(i, &run.time_s);
            for s in (0..run.time_s.len()).filter(|&s| run.keep[s]) {
                for k in 0..3 {
                    inputs[k].push(run.accel_mps2[k][s]);
                    target[k].push(reference[k][s]);
                }
                inputs[3].push(1.0);
            }
        }
        let u: Vec<&[f64]> = inputs.iter().map(Vec::as_slice).collect();
        let params = crate::sysid::ArxParams {
            na: ARX_NA,
            nb: vec![ARX_NB, ARX_NB, ARX_NB, 1],
            nk: vec![0; 4],
        };
        let mut models = Vec::with_capacity(3);
        for k in 0..3 {
            let arx = params
                .fit(&u, &target[k])
                .map_err(|e| format!("ARX on axis {k}: {e}"))?;
            models.push(crate::sysid::SysidModel::Poly(arx.model));
        }
        Ok(Trained::Dynamic(Box::new(DynamicModel {
            axes: models.into_iter().enumerate().collect(),
            input: DynamicInput::AxesAndConstant,
            structure: format!("[na nb nk] = [{ARX_NA} {ARX_NB} 0]"),
        })))
    }
}

/// The candidate of each kind.
pub fn candidate(kind: CandidateKind) -> Box<dyn Candidate + Sync> {
    fn of<T: Trainer + Sync + 'static>(kind: CandidateKind, trainer: T) -> Box<dyn Candidate + Sync> {
        Box::new(OfKind { kind, trainer })
    }
    match kind {
        CandidateKind::Physical => of(kind, PhysicalCandidate(SensorTerms::ALL)),
        CandidateKind::PhysicalLinear => of(kind, PhysicalCandidate(SensorTerms::LINEAR)),
        CandidateKind::Linear => of(kind, LinearCandidate),
        CandidateKind::PhysicalAnn => of(kind, PhysicalAnnCandidate),
        CandidateKind::Arx => of(kind, ArxCandidate),
    }
}
