//! The paper's candidates (SPEC §3–§4): kinds of the one [`Candidate`] trait that learn a map
//! from one recording to its reference ([`TrainingSet::series`]) on the training part of its
//! 60/20/20 division: the network (which stops on the validation part), the offset-plus-matrix
//! linear map, and one SISO system-identification model per axis (scored only).

use crate::campaign::candidate::{Candidate, Trained, TrainingSet};
use crate::campaign::params::Params;
use crate::correctors::ann::{architecture_label, AnnProblem, LmSettings};
use crate::correctors::corrector::Axis;
use crate::correctors::linear::LinearModel;
use crate::correctors::model_file::CorrectorModel;
use crate::progress::Observer;
use crate::sysid::{fit_and_score, ModelSpec};

/// The paper's network of a chosen architecture (`hidden`), trained from `restarts` starts.
struct NetworkCandidate {
    axes: Vec<Axis>,
    delays: usize,
    hidden: Vec<usize>,
    restarts: usize,
    seed: u64,
    lm: LmSettings,
}

impl Candidate for NetworkCandidate {
    fn name(&self) -> String {
        "ANN".into()
    }
    fn savable(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        format!(
            "{}-input [{}] {}-output, {} delays, {} restarts",
            self.axes.len() * (self.delays + 1),
            architecture_label(&self.hidden),
            self.axes.len(),
            self.delays,
            self.restarts
        )
    }
    fn train(&self, training: &TrainingSet<'_>, _: &Observer) -> Result<Trained, String> {
        let series = training.series()?;
        let problem = AnnProblem::new(
            series.measured,
            series.reference,
            &self.axes,
            self.delays,
            series.division.mode,
        )
        .map_err(|e| e.to_string())?;
        let network = problem
            .train(&self.hidden, self.restarts, self.seed, &self.lm)
            .map_err(|e| e.to_string())?;
        Ok(Trained::Corrector {
            model: CorrectorModel::Ann(Box::new(network)),
            covariance: None,
        })
    }
}

/// The paper's linear corrector: an offset and a matrix over the corrected axes.
struct AxesLinearCandidate {
    axes: Vec<Axis>,
}

impl Candidate for AxesLinearCandidate {
    fn name(&self) -> String {
        "linear".into()
    }
    fn savable(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        format!("offset + {0}×{0} matrix", self.axes.len())
    }
    fn train(&self, training: &TrainingSet<'_>, _: &Observer) -> Result<Trained, String> {
        let series = training.series()?;
        let linear = LinearModel::fit(
            series.measured,
            series.reference,
            &self.axes,
            series.division.mode,
        )
        .map_err(|e| e.to_string())?;
        Ok(Trained::Corrector {
            model: CorrectorModel::Linear(Box::new(linear)),
            covariance: None,
        })
    }
}

/// One SISO system-identification model per corrected axis, fitted on the division's first
/// training block (a dynamic model needs one unbroken series).
struct SysidCandidate {
    spec: ModelSpec,
    axes: Vec<usize>,
    init_samples: usize,
}

impl Candidate for SysidCandidate {
    fn name(&self) -> String {
        self.spec.kind.name().into()
    }
    fn describe(&self) -> String {
        format!("{:?}", self.spec.orders)
    }
    fn savable(&self) -> bool {
        false
    }
    fn train(&self, training: &TrainingSet<'_>, _: &Observer) -> Result<Trained, String> {
        let series = training.series()?;
        let block = series
            .division
            .train
            .first()
            .cloned()
            .ok_or("the division has no training block")?;
        let mut axes = Vec::with_capacity(self.axes.len());
        let mut structure = String::new();
        for &a in &self.axes {
            let scored = fit_and_score(
                &self.spec,
                &[&series.measured.accel_mps2[a]],
                &series.reference.accel_mps2[a],
                block.clone(),
                None,
                self.init_samples,
                &crate::progress::silent,
            )
            .map_err(|e| e.to_string())?;
            structure = scored.structure;
            axes.push((a, scored.fitted.model));
        }
        Ok(Trained::siso(axes, structure))
    }
}

/// The paper's candidates from the settings: the network of architecture `hidden` trained from
/// `restarts` starts, the linear map, and each system-identification model of `settings.sysid`
/// (started from the settings' seed).
pub(crate) fn paper_candidates(
    settings: &Params,
    hidden: &[usize],
    restarts: usize,
) -> Vec<Box<dyn Candidate + Sync>> {
    let mut candidates: Vec<Box<dyn Candidate + Sync>> = vec![
        Box::new(NetworkCandidate {
            axes: settings.correct_axes.clone(),
            delays: settings.delays,
            hidden: hidden.to_vec(),
            restarts,
            seed: settings.seed,
            lm: settings.lm.clone(),
        }),
        Box::new(AxesLinearCandidate {
            axes: settings.correct_axes.clone(),
        }),
    ];
    for spec in &settings.sysid {
        candidates.push(Box::new(SysidCandidate {
            spec: ModelSpec {
                seed: settings.seed,
                ..spec.clone()
            },
            axes: settings.correct_axes.iter().map(|a| a.index()).collect(),
            init_samples: settings.init_samples,
        }));
    }
    candidates
}
