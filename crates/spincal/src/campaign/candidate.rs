//! The candidates a campaign compares: one trait, [`Candidate`] (a training set of runs and poses
//! in, a [`Trained`] corrector out, which corrects a recording and, when its kind can be, is
//! saved), and its implementations: the physical model's inverse (with and without the
//! nonlinearity), the 12-parameter linear map, the physical model with a network on its residual,
//! and ARX (scored, never saved).

// Per-axis arrays are indexed together.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::campaign::joint::{
    fit_joint, fit_joint_from, JointFit, JointSettings, PoseInput, RunInput, SensorCovariance, SensorTerms,
};
use crate::correctors::ann::{AnnProblem, LmSettings};
use crate::correctors::corrector::{Axis, Corrector};
use crate::correctors::division::DivisionMode;
use crate::correctors::linear::LinearModel;
use crate::correctors::model_file::CorrectorModel;
use crate::correctors::physical::{PhysicalCorrector, SensorModel};
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

/// A training set: the prepared runs and poses it may use, and its full joint fit (made once,
/// shared by the candidates that need it).
pub struct TrainingSet<'a> {
    pub runs: Vec<RunInput>,
    pub poses: Vec<PoseInput>,
    pub joint: &'a JointSettings,
    full_fit: std::sync::OnceLock<Result<JointFit, String>>,
}

impl<'a> TrainingSet<'a> {
    /// A training set of these runs and poses; the joint fit is made when a candidate first asks.
    pub fn new(runs: Vec<RunInput>, poses: Vec<PoseInput>, joint: &'a JointSettings) -> TrainingSet<'a> {
        TrainingSet {
            runs,
            poses,
            joint,
            full_fit: std::sync::OnceLock::new(),
        }
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
        let settings = JointSettings {
            terms,
            ..self.joint.clone()
        };
        // A nested model starts where the full one ended.
        let full = self.fit(self.joint.terms, observer).ok();
        fit_joint_from(&self.runs, &self.poses, &settings, full.as_deref(), observer)
            .map(std::borrow::Cow::Owned)
            .map_err(|e| e.to_string())
    }
}

/// A corrector kind: trained on a set of runs and poses. Every kind a campaign compares is one;
/// a new kind is a new implementation here and a `CandidateKind`, nothing else.
pub trait Candidate {
    fn kind(&self) -> CandidateKind;
    fn train(&self, training: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String>;
}

/// What a candidate's training gives: a corrector that can be saved (with the covariance of its
/// sensor parameters when it is the physical model's inverse), or a dynamic model per axis that
/// can only be scored.
pub enum Trained {
    Corrector {
        model: CorrectorModel,
        covariance: Option<Box<SensorCovariance>>,
    },
    Dynamic(Box<[crate::sysid::SysidModel; 3]>),
}

impl Trained {
    fn corrector(model: CorrectorModel) -> Trained {
        Trained::Corrector {
            model,
            covariance: None,
        }
    }

    /// The corrector to save, when the kind can be saved.
    pub fn saved(&self) -> Option<&CorrectorModel> {
        match self {
            Trained::Corrector { model, .. } => Some(model),
            Trained::Dynamic(_) => None,
        }
    }

    /// The sensor model of the physical family's correction (the whole corrector, or the part
    /// under a network) with its parameters' covariance, when the training gave one.
    pub fn physical_part(&self) -> Option<(&SensorModel, &SensorCovariance)> {
        let Trained::Corrector {
            model,
            covariance: Some(covariance),
        } = self
        else {
            return None;
        };
        match model {
            CorrectorModel::Physical(physical) => Some((&physical.sensor, covariance)),
            CorrectorModel::PhysicalAnn(both) => Some((&both.physical.sensor, covariance)),
            _ => None,
        }
    }

    /// The largest departure from the identity of a static corrector's gain, ∂output/∂input by
    /// central differences at each of `readings` (`None` for a dynamic model). A sensor's static
    /// errors are a few per cent: a gain far from one means the corrector discards (or amplifies)
    /// a measurement where its training data held that axis still, which no held-out recording
    /// that also holds it still can show.
    pub fn gain_error(&self, readings: &[[f64; 3]]) -> Option<f64> {
        let Trained::Corrector { model, .. } = self else {
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

    /// A recording's accelerometer after this candidate, and which samples it could correct.
    pub fn correct(&self, accel: &[Vec<f64>; 3]) -> Result<([Vec<f64>; 3], Vec<bool>), String> {
        let n = accel[0].len();
        match self {
            Trained::Corrector { model, .. } => {
                let mut stream = model.stream();
                let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
                let mut valid = vec![true; n];
                for s in 0..n {
                    let r = stream.correct_sample([accel[0][s], accel[1][s], accel[2][s]]);
                    for k in 0..3 {
                        out[k][s] = r.accel_mps2[k];
                    }
                    valid[s] = r.valid;
                }
                Ok((out, valid))
            }
            Trained::Dynamic(models) => {
                let ones = vec![1.0; n];
                let inputs: [&[f64]; 4] = [&accel[0], &accel[1], &accel[2], &ones];
                let mut out: [Vec<f64>; 3] = Default::default();
                for k in 0..3 {
                    out[k] = models[k]
                        .simulate(&inputs, crate::sysid::SimInit::Zero)
                        .map_err(|e| e.to_string())?;
                }
                let valid = (0..n).map(|s| (0..3).all(|k| out[k][s].is_finite())).collect();
                Ok((out, valid))
            }
        }
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

struct PhysicalCandidate(SensorTerms, CandidateKind);

impl Candidate for PhysicalCandidate {
    fn kind(&self) -> CandidateKind {
        self.1
    }
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        let fit = t.fit(self.0, observer)?;
        Ok(Trained::Corrector {
            model: CorrectorModel::Physical(Box::new(PhysicalCorrector {
                sensor: fit.sensor,
                gravity_mps2: t.joint.gravity_mps2,
                input_range_mps2: input_range(&t.runs, &t.poses),
            })),
            covariance: fit.sensor_covariance().map(Box::new),
        })
    }
}

/// Samples per run used to fit the 12-parameter map (evenly spaced); enough for 12 unknowns.
const LINEAR_SAMPLES_PER_RUN: usize = 4000;

struct LinearCandidate;

impl Candidate for LinearCandidate {
    fn kind(&self) -> CandidateKind {
        CandidateKind::Linear
    }
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        // The reference is the full physical fit's specific force.
        let fit = t.fit(t.joint.terms, observer)?;
        // Normal equations of f_k = c_k + Σ_j A_kj m_j, rows weighted equally per sample; a
        // pose's mean counts as many samples as it averages (capped like a run).
        let mut ata = [[0.0f64; 4]; 4];
        let mut atb = [[0.0f64; 4]; 3];
        let mut add = |m: [f64; 3], f: [f64; 3], w: f64| {
            let x = [m[0], m[1], m[2], 1.0];
            for a in 0..4 {
                for b in 0..4 {
                    ata[a][b] += w * x[a] * x[b];
                }
                for k in 0..3 {
                    atb[k][a] += w * x[a] * f[k];
                }
            }
        };
        for (i, run) in t.runs.iter().enumerate() {
            let reference = fit.run_reference(i, &run.time_s);
            let step = (run.time_s.len() / LINEAR_SAMPLES_PER_RUN).max(1);
            for s in (0..run.time_s.len()).step_by(step) {
                if run.keep[s] {
                    let m = [run.accel_mps2[0][s], run.accel_mps2[1][s], run.accel_mps2[2][s]];
                    add(m, [reference[0][s], reference[1][s], reference[2][s]], 1.0);
                }
            }
        }
        for (p, pose) in t.poses.iter().enumerate() {
            let w = pose.samples.min(LINEAR_SAMPLES_PER_RUN) as f64;
            add(pose.mean_mps2, fit.poses[p].specific_force_mps2, w);
        }
        let a = faer::Mat::from_fn(4, 4, |i, j| ata[i][j]);
        let lu = a.partial_piv_lu();
        let mut matrix = vec![vec![0.0; 3]; 3];
        let mut offset = vec![0.0; 3];
        for k in 0..3 {
            let rhs = faer::Mat::from_fn(4, 1, |i, _| atb[k][i]);
            let x = faer::prelude::Solve::solve(&lu, &rhs);
            for j in 0..3 {
                matrix[k][j] = x[(j, 0)];
            }
            offset[k] = x[(3, 0)];
        }
        if matrix.iter().flatten().chain(&offset).any(|v| !v.is_finite()) {
            return Err(
                "the 12-parameter map is singular on this training set (too few distinct orientations)"
                    .into(),
            );
        }
        Ok(Trained::corrector(CorrectorModel::Linear(Box::new(
            LinearModel {
                axes: Axis::ALL.to_vec(),
                offset_mps2: offset,
                matrix,
                training: None,
            },
        ))))
    }
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

impl Candidate for PhysicalAnnCandidate {
    fn kind(&self) -> CandidateKind {
        CandidateKind::PhysicalAnn
    }
    fn train(&self, t: &TrainingSet<'_>, observer: &Observer) -> Result<Trained, String> {
        let fit = t.fit(SensorTerms::ALL, observer)?;
        let physical = PhysicalCorrector {
            sensor: fit.sensor,
            gravity_mps2: t.joint.gravity_mps2,
            input_range_mps2: input_range(&t.runs, &t.poses),
        };
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
        let covariance = fit.sensor_covariance().map(Box::new);
        Ok(Trained::Corrector {
            model: CorrectorModel::PhysicalAnn(Box::new(PhysicalAnnCorrector {
                physical,
                network,
                coverage,
            })),
            covariance,
        })
    }
}

/// ARX orders of the dynamic candidate: two past outputs, the current and previous sample of each
/// measured axis, and a constant.
const ARX_NA: usize = 2;
const ARX_NB: usize = 2;

struct ArxCandidate;

impl Candidate for ArxCandidate {
    fn kind(&self) -> CandidateKind {
        CandidateKind::Arx
    }
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
        let models: [crate::sysid::SysidModel; 3] =
            models.try_into().map_err(|_| "three axes".to_string())?;
        Ok(Trained::Dynamic(Box::new(models)))
    }
}

/// The candidate of each kind.
pub fn candidate(kind: CandidateKind) -> Box<dyn Candidate + Sync> {
    match kind {
        CandidateKind::Physical => Box::new(PhysicalCandidate(SensorTerms::ALL, kind)),
        CandidateKind::PhysicalLinear => Box::new(PhysicalCandidate(SensorTerms::LINEAR, kind)),
        CandidateKind::Linear => Box::new(LinearCandidate),
        CandidateKind::PhysicalAnn => Box::new(PhysicalAnnCandidate),
        CandidateKind::Arx => Box::new(ArxCandidate),
    }
}
