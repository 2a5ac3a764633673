//! The paper's candidates (SPEC §3–§4): kinds of the one [`Candidate`] trait that learn a map
//! from one recording to its reference ([`TrainingSet::series`]) on the training part of its
//! 60/20/20 division: the network (which stops on the validation part), the offset-plus-matrix
//! linear map, and one SISO system-identification model per axis (scored only).

use crate::campaign::candidate::{Candidate, DynamicInput, DynamicModel, Trained, TrainingSet};
use crate::campaign::params::Params;
use crate::correctors::ann::{architecture_label, AnnProblem, LmSettings};
use crate::correctors::corrector::Axis;
use crate::correctors::linear::LinearModel;
use crate::correctors::model_file::CorrectorModel;
use crate::progress::Observer;
use crate::sysid::ModelSpec;

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
        Ok(Trained::Corrector(CorrectorModel::Ann(Box::new(network))))
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
        Ok(Trained::Corrector(CorrectorModel::Linear(Box::new(linear))))
    }
}

/// One SISO system-identification model per corrected axis, fitted on the division's first
/// training block (a dynamic model needs one unbroken series).
struct SysidCandidate {
    spec: ModelSpec,
    axes: Vec<usize>,
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
            .filter(|b| !b.is_empty())
            .ok_or("the division has no training samples")?;
        let mut axes = Vec::with_capacity(self.axes.len());
        for &a in &self.axes {
            let (Some(u), Some(y)) = (
                series.measured.accel_mps2[a].get(block.clone()),
                series.reference.accel_mps2[a].get(block.clone()),
            ) else {
                return Err("the division's training part lies beyond the recording".into());
            };
            let fitted = self
                .spec
                .fit(&[u], y, &crate::progress::silent)
                .map_err(|e| e.to_string())?;
            axes.push((a, fitted.model));
        }
        Ok(Trained::Dynamic(Box::new(DynamicModel {
            axes,
            input: DynamicInput::OwnAxis,
            structure: self.spec.structure(),
        })))
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
        }));
    }
    candidates
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::candidate::{candidate, CandidateKind, ReferenceSeries, SimulationStart};
    use crate::campaign::joint::JointSettings;
    use crate::correctors::division::{Division, DivisionMode};
    use crate::input::recording::Recording;
    use crate::progress::silent;

    /// A platter's x and y readings with a 2 % scale error and an offset on x, and their reference.
    fn measured_and_reference() -> (Recording, Recording) {
        let n = 3000;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let x: Vec<f64> = time_s.iter().map(|t| (3.5 * t).sin()).collect();
        let y: Vec<f64> = time_s.iter().map(|t| (3.5 * t).cos()).collect();
        let z = vec![9.81; n];
        let reference = Recording {
            time_s: time_s.clone(),
            accel_mps2: [x.clone(), y.clone(), z.clone()],
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        let measured = Recording {
            accel_mps2: [x.iter().map(|v| 1.02 * v + 0.05).collect(), y, z],
            ..reference.clone()
        };
        (measured, reference)
    }

    /// Each family of kinds says what it learns from when handed the other's training set, and the
    /// paper's kinds learn the map: the linear one undoes the scale and offset, a dynamic one
    /// starts its simulation from the reference's first samples when told to.
    #[test]
    fn each_kind_learns_from_its_own_training_set_and_names_the_other() {
        let joint = JointSettings::default();
        let settings = Params {
            correct_axes: vec![Axis::X, Axis::Y],
            ..Params::default()
        };
        let paper = paper_candidates(&settings, &[3], 1);
        let campaign_set = TrainingSet::new(Vec::new(), Vec::new(), &joint);
        for cand in &paper {
            let Err(why) = cand.train(&campaign_set, &silent) else {
                panic!("{} trained on runs and poses it cannot use", cand.name());
            };
            assert!(
                why.contains("one recording and its reference"),
                "{}: {why}",
                cand.name()
            );
        }

        let (measured, reference) = measured_and_reference();
        let division = Division::new(measured.len(), settings.delays, DivisionMode::Contiguous);
        let series = ReferenceSeries {
            measured: &measured,
            reference: &reference,
            division: &division,
        };
        let series_set = TrainingSet::of_series(series, &joint);
        for kind in [CandidateKind::Physical, CandidateKind::Linear] {
            assert!(
                candidate(kind).train(&series_set, &silent).is_err(),
                "{} trained without runs or poses",
                kind.name()
            );
        }

        let linear = paper.iter().find(|c| c.name() == "linear").unwrap();
        let corrected = linear
            .train(&series_set, &silent)
            .unwrap()
            .correct(&measured.accel_mps2)
            .unwrap();
        let worst = (0..measured.len())
            .map(|s| (corrected.accel_mps2[0][s] - reference.accel_mps2[0][s]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "linear leaves {worst} m/s² on x");

        let arx = paper.iter().find(|c| c.name() == "ARX").unwrap();
        let trained = arx.train(&series_set, &silent).unwrap();
        let start = SimulationStart::Reference {
            reference: &reference.accel_mps2,
            samples: settings.init_samples,
        };
        let simulated = trained.correct_from(&measured.accel_mps2, start).unwrap();
        for a in 0..2 {
            assert_eq!(
                simulated.accel_mps2[a][..settings.init_samples],
                reference.accel_mps2[a][..settings.init_samples]
            );
        }
        // z is not a corrected axis: it passes through.
        assert_eq!(simulated.accel_mps2[2], measured.accel_mps2[2]);
    }
}
