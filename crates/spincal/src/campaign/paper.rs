//! The paper protocol's figures (its Tables 1–3 and what stands behind them), as the one result
//! of a calibration ([`crate::campaign::select::CampaignResult`]) carries them under `paper`:
//! `crate::calibrate` computes them beside the campaign spine, which decides what is saved.

use serde::{Deserialize, Serialize};

use crate::campaign::params::NetworkChoice;
use crate::campaign::verdict::Comparison;
use crate::correctors::ann::SweepRow;
use crate::correctors::corrector::Axis;
use crate::correctors::division::Division;
use crate::input::recording::Recording;
use crate::progress::StageTime;
use crate::turntable::fit::TurntableFit;
use crate::turntable::sensitivity::SensitivityRow;

/// Fit % and RMSE of one prediction kind on one part, per corrected axis and their mean.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PartScore {
    pub fit_percent: Vec<f64>,
    pub fit_percent_mean: f64,
    pub rmse_mps2: Vec<f64>,
    pub rmse_mps2_mean: f64,
}

impl PartScore {
    pub(crate) fn new(fit: Vec<f64>, rmse: Vec<f64>) -> PartScore {
        PartScore {
            fit_percent_mean: fit.iter().sum::<f64>() / fit.len() as f64,
            rmse_mps2_mean: rmse.iter().sum::<f64>() / rmse.len() as f64,
            fit_percent: fit,
            rmse_mps2: rmse,
        }
    }
}

/// One row of the comparison (the paper's Table 2, extended).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ComparisonRow {
    pub model: String,
    pub structure: String,
    /// `static` (network, linear, uncorrected: simulation and one-step coincide) or `dynamic`.
    pub kind: String,
    pub train: PartScore,
    pub validation: PartScore,
    pub test: PartScore,
    /// One-step-prediction scores (dynamic models only).
    pub train_one_step: Option<PartScore>,
    pub test_one_step: Option<PartScore>,
    pub seconds: f64,
    /// Whether this corrector can be saved and applied to new data by `spincal correct`.
    pub savable: bool,
    /// Why the model could not be fitted (its scores are then NaN).
    pub failed: Option<String>,
    /// Why the scores should not be taken at face value: a simulation that diverges, or a model
    /// that fits the validation part above 50 % with its input held constant (it generates the
    /// turntable's sine instead of correcting the sensor). Such rows are not "best overall".
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A corrector trained on the first recording, applied to another one.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CrossRow {
    pub model: String,
    pub trained_on: String,
    pub tested_on: String,
    pub score: PartScore,
    /// Networks only: the share of samples whose input lay more than
    /// [`crate::correctors::ann::EXTRAPOLATION_MARGIN`] of the training range outside it (%).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outside_training_range_percent: Option<f64>,
    /// Against no correction on the same samples, with the campaign verdict's significance rule
    /// (`campaign::verdict`): blocks of `joint.block_s` seconds; no offset term, since each
    /// recording's reference carries its own fitted offset. `None` for the uncorrected row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against_uncorrected: Option<Comparison>,
}

/// Where a recording stood, for the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordingSummary {
    pub name: String,
    pub samples: usize,
    pub duration_s: f64,
    pub sample_rate_hz: f64,
    pub rpm_from_spectrum: f64,
    pub omega_from_spectrum_radps: f64,
    pub gaps: usize,
    pub saturated_samples: usize,
    pub warnings: Vec<String>,
}

/// The paper's own figures (its Tables 1–3 and what stands behind them): the turntable fit, the
/// 60/20/20 comparison on the first recording and the cross-condition scores. They name the best
/// on validation; what is saved is decided on held-out conditions by the campaign spine, whose
/// result ([`crate::campaign::select::CampaignResult`]) carries these figures as `paper`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PaperProtocol {
    pub results_version: u32,
    pub seed: u64,
    pub axes: Vec<Axis>,
    pub recordings: Vec<RecordingSummary>,
    pub turntable: TurntableFit,
    pub sensitivity: Vec<SensitivityRow>,
    pub division: Division,
    pub network: NetworkChoice,
    pub sweep: Vec<SweepRow>,
    pub network_architecture: String,
    pub comparison: Vec<ComparisonRow>,
    pub cross_condition: Vec<CrossRow>,
    /// The best validation fit % among correctors a file can hold that are not significantly
    /// worse than uncorrected on another recording ("none" when there is none): the paper's
    /// choice, reported; not what is saved.
    pub best_on_validation: String,
    /// The best on validation overall (may be a compare-only model), among rows without warnings.
    pub best_overall: String,
    /// Which of the turntable fit's parameters the recordings determine, and the fit's remedy.
    pub determined: String,
    /// Where the time went: turntable fit, network sweep, each corrector, cross-condition scoring.
    #[serde(default)]
    pub stage_seconds: Vec<StageTime>,
}

/// The paper protocol's signals, for the report's plots (not numbers shown as text).
#[derive(Debug, Clone)]
pub struct PaperSignals {
    pub recordings: Vec<Recording>,
    /// Reference (the turntable's physical acceleration, without sensor offsets) per recording.
    pub references: Vec<Recording>,
    /// The fitted model including offsets and drift (what the sensor should read) per recording.
    pub models: Vec<Recording>,
    /// The saved corrector applied to the first recording (the recording itself when nothing
    /// was saved).
    pub corrected: [Vec<f64>; 3],
}
