//! A turntable fit's result: the fitted parameters, per-recording outcomes and drift found.

use serde::{Deserialize, Serialize};

use super::options::AxesObjective;
use crate::input::inspect::Inspection;
use crate::input::recording::{Recording, Source, STANDARD_GRAVITY};
use crate::optim::LmStop;
use crate::turntable::model::{evaluate, for_each_sample_about, Mounting, Session};
use crate::turntable::segments::PhaseSegments;
use crate::turntable::spectrum::RateEstimate;

/// One fitted parameter as reported.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FittedParam {
    pub name: String,
    pub value: f64,
    /// One standard error; `None` when the data do not determine the parameter.
    pub std_error: Option<f64>,
    pub unit: String,
    pub lower: f64,
    pub upper: f64,
    pub at_bound: bool,
    pub determined: bool,
}

/// Drift found on one axis of one recording.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DriftFinding {
    pub recording: usize,
    pub axis: char,
    /// Change over the whole recording, m/s².
    pub change_mps2: f64,
    pub std_error_mps2: f64,
    pub significant: bool,
}

/// One stretch of a recording cut at its logging gaps: its own phase, referred to its first
/// sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SegmentPhase {
    pub start_s: f64,
    pub end_s: f64,
    pub phase_rad: f64,
}

/// Per-recording outcome.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordingFit {
    pub name: String,
    pub rate: RateEstimate,
    pub inspection: Inspection,
    pub session: Session,
    /// Model fit % per axis x, y, z (SPEC §4).
    pub fit_percent: [f64; 3],
    /// RMS of measured − model per axis, m/s².
    pub residual_rms_mps2: [f64; 3],
    /// A recording cut at its logging gaps: each segment's phase (`session` holds the first's);
    /// empty for a recording fitted whole.
    #[serde(default)]
    pub segments: Vec<SegmentPhase>,
    /// A cut recording's drift origin (its middle), s; `None`: the middle of the times given.
    #[serde(default)]
    pub drift_origin_s: Option<f64>,
}

/// The complete result of a turntable fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TurntableFit {
    pub gravity_mps2: f64,
    pub axes: AxesObjective,
    pub mounting: Mounting,
    pub recordings: Vec<RecordingFit>,
    /// Free parameters in fit order, with errors.
    pub params: Vec<FittedParam>,
    /// Correlation matrix of the free parameters (NaN rows for undetermined ones).
    pub correlation: Vec<Vec<f64>>,
    /// Names of parameters the data did not determine, and what to do about it.
    pub undetermined: Vec<String>,
    pub remedy: Option<String>,
    pub drift: Vec<DriftFinding>,
    /// Weighted squared error after Nelder–Mead and after Levenberg–Marquardt.
    pub cost_nelder_mead: f64,
    pub cost_final: f64,
    pub nelder_mead_iterations: usize,
    pub lm_iterations: usize,
    pub lm_stop: LmStop,
    /// Noise standard deviation per recording and axis used as weights, m/s².
    pub noise_mps2: Vec<[f64; 3]>,
    /// Starting values handed to Nelder–Mead (free parameters, SI), for reproduction by peers.
    pub start: Vec<f64>,
    /// The recordings cut at logging gaps, with where.
    #[serde(default)]
    pub split_recordings: Vec<PhaseSegments>,
}

impl TurntableFit {
    /// The fitted model at the samples of recording `k`, m/s², including the sensor's offsets and
    /// drift: what the sensor should read (used for the model-against-measurement fit).
    pub fn model(&self, k: usize, time_s: &[f64]) -> [Vec<f64>; 3] {
        self.evaluate(k, &self.recordings[k].session, &self.mounting, time_s)
    }

    /// The reference acceleration at the samples of recording `k`, m/s²: the turntable's physical
    /// specific force alone. Offsets and drift are sensor errors, so they are left out; the
    /// correctors learn to remove them.
    pub fn reference(&self, k: usize, time_s: &[f64]) -> [Vec<f64>; 3] {
        let session = Session {
            drift_mps2_per_s: [0.0; 3],
            ..self.recordings[k].session
        };
        let mounting = Mounting {
            offset_mps2: [0.0; 3],
            ..self.mounting
        };
        self.evaluate(k, &session, &mounting, time_s)
    }

    /// Recording `k`'s model at `time_s`: whole, or segment by segment with each segment's phase
    /// (a sample before the first segment, or in a stretch too short to fit, takes the phase of
    /// the segment before it, or the first).
    fn evaluate(&self, k: usize, session: &Session, mounting: &Mounting, time_s: &[f64]) -> [Vec<f64>; 3] {
        let mut out = [Vec::new(), Vec::new(), Vec::new()];
        let fit = &self.recordings[k];
        if fit.segments.is_empty() {
            evaluate(session, mounting, self.gravity_mps2, time_s, &mut out);
            return out;
        }
        for axis in out.iter_mut() {
            axis.resize(time_s.len(), 0.0);
        }
        let segment_of = |t: f64| fit.segments.iter().rposition(|s| s.start_s <= t).unwrap_or(0);
        let mut start = 0;
        while start < time_s.len() {
            let j = segment_of(time_s[start]);
            let end = (start..time_s.len())
                .find(|&i| segment_of(time_s[i]) != j)
                .unwrap_or(time_s.len());
            let segment = &fit.segments[j];
            // The phase refers to the segment's first sample; these times may start elsewhere.
            let here = Session {
                phase_rad: segment.phase_rad + session.omega_radps * (time_s[start] - segment.start_s),
                ..*session
            };
            let times = &time_s[start..end];
            for_each_sample_about(
                &here,
                mounting,
                self.gravity_mps2,
                times,
                fit.drift_origin_s,
                |i, a| {
                    for axis in 0..3 {
                        out[axis][start + i] = a[axis];
                    }
                },
            );
            start = end;
        }
        out
    }

    /// Recording `k`'s [`reference`](Self::reference) as a recording of its own (its times, no
    /// gyro or temperature): what `train` and `sweep` take as the truth.
    pub fn reference_recording(&self, k: usize, recording: &Recording) -> Recording {
        Recording {
            time_s: recording.time_s.clone(),
            accel_mps2: self.reference(k, &recording.time_s),
            gyro_radps: None,
            temperature_c: None,
            source: Source::default(),
        }
    }

    /// The fit as the JSON file spincal writes (pretty, newline-terminated), marked with
    /// `spincal_version` so that a later run recognises it as spincal's and replaces it.
    pub fn to_json_file(&self) -> serde_json::Result<String> {
        let mut json = serde_json::to_value(self)?;
        if let Some(map) = json.as_object_mut() {
            map.insert("spincal_version".into(), env!("CARGO_PKG_VERSION").into());
        }
        Ok(serde_json::to_string_pretty(&json)? + "\n")
    }

    /// Parameter `p` in the units the reports use: angles in degrees, drift as the change in g
    /// over its recording (`g/rec`), everything else in SI. Returns (value, standard error, unit).
    pub fn display_value(&self, p: &FittedParam) -> (f64, Option<f64>, String) {
        if p.unit == "rad" {
            return (
                p.value.to_degrees(),
                p.std_error.map(f64::to_degrees),
                "deg".into(),
            );
        }
        if p.name.starts_with("drift_") {
            // `drift_x` (one recording) or `drift_x[k]` (1-based).
            let k = p
                .name
                .split_once('[')
                .and_then(|(_, rest)| rest.trim_end_matches(']').parse::<usize>().ok())
                .map_or(0, |k| k - 1);
            if let Some(r) = self.recordings.get(k) {
                let factor = r.inspection.duration_s / STANDARD_GRAVITY;
                return (
                    p.value * factor,
                    p.std_error.map(|se| se * factor),
                    "g/rec".into(),
                );
            }
        }
        (p.value, p.std_error, p.unit.clone())
    }
}

/// A `--bounds`-style list `name=lower:upper,…` that cannot be read: the item that is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("bounds item '{item}': expected name=lower:upper, e.g. radius=0.05:0.15")]
pub struct BoundsError {
    pub item: String,
}

/// Parses bounds to replace, `name=lower:upper,…` (SI, names as the fit reports them); empty
/// items are skipped.
pub fn parse_bounds(text: &str) -> Result<Vec<(String, f64, f64)>, BoundsError> {
    text.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|item| {
            let bad = || BoundsError {
                item: item.to_string(),
            };
            let (name, range) = item.split_once('=').ok_or_else(bad)?;
            let (lo, hi) = range.split_once(':').ok_or_else(bad)?;
            let lo: f64 = lo.trim().parse().map_err(|_| bad())?;
            let hi: f64 = hi.trim().parse().map_err(|_| bad())?;
            Ok((name.trim().to_string(), lo, hi))
        })
        .collect()
}
