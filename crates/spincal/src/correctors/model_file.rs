//! The saved corrector file: JSON of the form
//! `{"format_version": 2, "spincal_version": "…", "corrector": {"kind": "ann", …}}`.
//!
//! Format 2 added the physical corrector's `uncertainty` (its parameters' covariance and the
//! readings' noise); format 1 files, which have none, still read. Format 3 added the kind
//! `uncorrected`: a file that saves a gyroscope part where no accelerometer correction was shown
//! to help (an older build refuses it by its version, not by an unknown kind). A `linear` map's
//! optional `uncertainty` (a campaign's linear-12) came within format 3: a file without it reads
//! as before, and an older build reading one with it ignores the field (`LinearModel` takes
//! unknown fields), so it is a compatible change and the version stands. Format 4 added the
//! thermal part's `uncertainty` (`ThermalUncertainty`: what the thermal coefficients' error moves
//! in a physical corrector, for the rows' standard deviations); `ThermalModel` refuses unknown
//! fields, so an older build must refuse such a file by its version.
//!
//! A new kind of corrector is one more variant of [`CorrectorModel`] and one more arm in its
//! `Corrector` impl and in [`CorrectorModel::validate`] (both matches have no wildcard, so the
//! compiler asks for them); the format version changes only when existing kinds change
//! incompatibly.
//!
//! Reading a file checks it completely before anything uses it: the format version, the shape
//! serde expects, then the model against its own structure ([`CorrectorModel::validate`]). Every
//! refusal names the file and the field, as a path such as `corrector.network.weights[3]`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::correctors::ann::AnnModel;
use crate::correctors::corrector::{
    join_field, Axis, CorrectedSample, Corrector, ModelError, SampleCorrector,
};
use crate::correctors::linear::LinearModel;
use crate::correctors::physical::{PhysicalCorrector, SensorUncertainty, SENSOR_PARAMS};
use crate::correctors::physical_ann::PhysicalAnnCorrector;
use crate::correctors::static_cal::StaticCalibration;

/// The corrector file format this build writes.
pub(crate) const FORMAT_VERSION: u32 = 4;
/// The oldest format this build still reads (every later one up to [`FORMAT_VERSION`] too).
const OLDEST_READABLE_VERSION: u32 = 1;

/// Every kind of saved corrector, tagged by `kind`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum CorrectorModel {
    Ann(Box<AnnModel>),
    Linear(Box<LinearModel>),
    /// Offsets, scale and misalignment from still poses (`spincal static`).
    Static(Box<StaticCalibration>),
    /// The inverse of a campaign's fitted sensor model (`spincal calibrate --campaign`).
    Physical(Box<PhysicalCorrector>),
    /// That inverse followed by a network on what it left (`spincal calibrate --campaign`).
    PhysicalAnn(Box<PhysicalAnnCorrector>),
    /// The accelerometer left as read, beside a gyroscope part (format 3).
    Uncorrected(Box<Uncorrected>),
}

/// The accelerometer left as read: what a campaign saves when it shows no accelerometer
/// correction to help but determines the gyroscope. `correct` then writes no corrected
/// accelerometer columns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Uncorrected {
    /// Why the accelerometer is not corrected (the campaign's verdict on it).
    pub reason: String,
}

impl Corrector for Uncorrected {
    fn corrected_axes(&self) -> Vec<Axis> {
        Vec::new()
    }

    fn warmup_samples(&self) -> usize {
        0
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        Box::new(AsRead)
    }
}

/// Every sample as read.
struct AsRead;

impl SampleCorrector for AsRead {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        CorrectedSample {
            accel_mps2,
            valid: true,
            outside_training_range: false,
        }
    }
}

/// What a trained network or linear map records of its training: the summary `train` shows.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingOutline<'a> {
    /// Hidden-layer sizes (networks only).
    pub hidden: Option<Vec<usize>>,
    /// Previous samples per axis fed to a network (0 for a linear map).
    pub delays: usize,
    /// LM epochs run and why training stopped (networks only).
    pub epochs: Option<usize>,
    pub stop: Option<String>,
    /// Fit per part (training, validation, test), corrected and uncorrected.
    pub fits: &'a crate::correctors::division::PartFits,
    pub uncorrected: &'a crate::correctors::division::PartFits,
    pub axes: Vec<Axis>,
}

impl CorrectorModel {
    /// The training summary of a network or linear map trained in this run; `None` for other
    /// kinds and for a model read from a file without one.
    pub fn training_outline(&self) -> Option<TrainingOutline<'_>> {
        match self {
            CorrectorModel::Ann(m) => m.training.as_ref().map(|t| TrainingOutline {
                hidden: Some(m.network.hidden.clone()),
                delays: m.delays,
                epochs: Some(t.report.epochs),
                stop: Some(t.report.stop.describe().to_string()),
                fits: &t.fits,
                uncorrected: &t.uncorrected,
                axes: m.axes.clone(),
            }),
            CorrectorModel::Linear(m) => m.training.as_ref().map(|t| TrainingOutline {
                hidden: None,
                delays: 0,
                epochs: None,
                stop: None,
                fits: &t.fits,
                uncorrected: &t.uncorrected,
                axes: m.axes.clone(),
            }),
            _ => None,
        }
    }

    fn inner(&self) -> &dyn Corrector {
        match self {
            CorrectorModel::Ann(m) => m.as_ref(),
            CorrectorModel::Linear(m) => m.as_ref(),
            CorrectorModel::Static(m) => m.as_ref(),
            CorrectorModel::Physical(m) => m.as_ref(),
            CorrectorModel::PhysicalAnn(m) => m.as_ref(),
            CorrectorModel::Uncorrected(m) => m.as_ref(),
        }
    }

    /// Checks the model against its own structure: everything applying it relies on (see each
    /// kind's `validate`). Fields are relative to the corrector object (`network.weights`). A
    /// model that passes never panics when applied.
    pub fn validate(&self) -> Result<(), ModelError> {
        // No wildcard: a new kind does not compile until it says how it is checked.
        match self {
            CorrectorModel::Ann(m) => m.validate(),
            CorrectorModel::Linear(m) => m.validate(),
            CorrectorModel::Static(m) => m.validate(),
            CorrectorModel::Physical(m) => m.validate(),
            CorrectorModel::PhysicalAnn(m) => m.validate(),
            CorrectorModel::Uncorrected(_) => Ok(()),
        }
    }

    /// The corrector whose error its parameters' covariance predicts: the physical kind and the
    /// linear map saved with an uncertainty. Other kinds predict none (a network's error has no
    /// covariance; the network on top of physics is not in its physical part's).
    pub fn error_model(&self) -> Option<ErrorModel<'_>> {
        match self {
            CorrectorModel::Physical(p) if p.uncertainty.is_some() => Some(ErrorModel::Physical(p)),
            CorrectorModel::Linear(l) if l.uncertainty.is_some() => Some(ErrorModel::Linear(l)),
            _ => None,
        }
    }

    /// The `kind` tag as written in the file.
    pub fn kind(&self) -> &'static str {
        match self {
            CorrectorModel::Ann(_) => "ann",
            CorrectorModel::Linear(_) => "linear",
            CorrectorModel::Static(_) => "static",
            CorrectorModel::Physical(_) => "physical",
            CorrectorModel::PhysicalAnn(_) => "physical_ann",
            CorrectorModel::Uncorrected(_) => "uncorrected",
        }
    }
}

/// A saved corrector whose parameters' covariance predicts the error of its correction (both
/// correct all three axes and have 12 parameters): what `correct`, Python and the firmware
/// export give an error bar for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ErrorModel<'a> {
    Physical(&'a PhysicalCorrector),
    Linear(&'a LinearModel),
}

impl<'a> ErrorModel<'a> {
    /// The covariance of its 12 parameters, the readings' noise and the sessions' spread.
    pub fn uncertainty(&self) -> &'a SensorUncertainty {
        let uncertainty = match self {
            ErrorModel::Physical(p) => p.uncertainty.as_ref(),
            ErrorModel::Linear(l) => l.uncertainty.as_ref(),
        };
        uncertainty.expect("an error model carries its uncertainty (CorrectorModel::error_model)")
    }

    /// The standard deviation per axis of the correction of reading `m` that the covariance
    /// predicts, √diag(J Σ Jᵀ); `None` where the model has no inverse.
    pub fn predicted_sd(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        match self {
            ErrorModel::Physical(p) => p.predicted_sd(m),
            ErrorModel::Linear(l) => l.predicted_sd(m),
        }
    }

    /// The corrected reading; `None` where the model has no inverse.
    pub fn corrected(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        match self {
            ErrorModel::Physical(p) => p.sensor.correct(m),
            ErrorModel::Linear(l) => Some(l.apply(m)),
        }
    }

    /// The reading a still sensor gives under specific force `f` (sensor frame, m/s²): the
    /// physical model's forward model, or the linear map's inverse; `None` where it has none.
    pub fn reading_of(&self, f: [f64; 3]) -> Option<[f64; 3]> {
        match self {
            ErrorModel::Physical(p) => Some(p.sensor.measure(f)),
            ErrorModel::Linear(l) => {
                let matrix: crate::geometry::M3 =
                    std::array::from_fn(|i| std::array::from_fn(|j| l.matrix[i][j]));
                let inverse = crate::geometry::inverse(&matrix)?;
                let v: [f64; 3] = std::array::from_fn(|i| f[i] - l.offset_mps2[i]);
                Some(crate::geometry::apply(&inverse, &v))
            }
        }
    }
}

impl Corrector for CorrectorModel {
    fn corrected_axes(&self) -> Vec<Axis> {
        self.inner().corrected_axes()
    }

    fn warmup_samples(&self) -> usize {
        self.inner().warmup_samples()
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        self.inner().stream()
    }
}

/// What can go wrong reading or writing a corrector file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CorrectorError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// Writing the file failed (the previous file, if any, is kept).
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("{file}: cannot write: {source}")]
    Write {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: not a spincal corrector file: {source}")]
    Parse {
        file: String,
        #[source]
        source: serde_json::Error,
    },
    /// A field that serde refused or that contradicts the model's own structure: `field` is its
    /// path in the file (`corrector.network.weights`).
    #[error("{file}: invalid corrector file: {field}: {reason}")]
    Invalid {
        file: String,
        field: String,
        reason: String,
    },
    #[error("{file}: no format_version field; not a spincal corrector file")]
    MissingVersion { file: String },
    #[error("{file}: corrector file format_version {found}, but this spincal reads format_version {oldest} to {supported}; retrain the corrector or use a matching spincal")]
    Version {
        file: String,
        found: u64,
        oldest: u32,
        supported: u32,
    },
}

/// A saved corrector: the format version, the writing spincal version, the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrectorFile {
    pub format_version: u32,
    pub spincal_version: String,
    pub corrector: CorrectorModel,
    /// The gyroscope's calibration (`spincal calibrate --campaign` with gyro columns), applied by
    /// `correct` to the gyro columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro: Option<crate::correctors::gyro::GyroModel>,
    /// The accelerometer's change with temperature (a campaign whose still recordings carry a
    /// temperature over a few degrees): `correct` takes each row to the reference temperature
    /// with it before the corrector.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<crate::thermal::ThermalModel>,
}

impl CorrectorFile {
    pub fn new(corrector: CorrectorModel) -> CorrectorFile {
        CorrectorFile {
            format_version: FORMAT_VERSION,
            spincal_version: env!("CARGO_PKG_VERSION").to_string(),
            corrector,
            gyro: None,
            thermal: None,
        }
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("corrector models serialise")
    }

    /// Checks the model against its own structure ([`CorrectorModel::validate`]); fields are
    /// paths in the file (`corrector.network.weights`).
    pub fn validate(&self) -> Result<(), ModelError> {
        self.corrector.validate().map_err(|e| e.within("corrector"))?;
        if matches!(self.corrector, CorrectorModel::Uncorrected(_))
            && self.gyro.is_none()
            && self.thermal.is_none()
        {
            return Err(ModelError::new(
                "corrector.kind",
                "uncorrected, with neither a gyro nor a thermal part: the file would correct nothing",
            ));
        }
        if let Some(thermal) = &self.thermal {
            if let Some(uncertainty) = &thermal.uncertainty {
                if !matches!(self.corrector, CorrectorModel::Physical(_)) {
                    return Err(ModelError::new(
                        "thermal.uncertainty",
                        format!(
                            "its directions change a physical corrector's sensor parameters, but the corrector is {}",
                            self.corrector.kind()
                        ),
                    ));
                }
                if let Some((d, direction)) = uncertainty
                    .directions
                    .iter()
                    .enumerate()
                    .find(|(_, d)| d.sensor.len() != SENSOR_PARAMS)
                {
                    return Err(ModelError::new(
                        format!("thermal.uncertainty.directions[{d}].sensor"),
                        format!(
                            "{} values: the physical corrector has {SENSOR_PARAMS} parameters",
                            direction.sensor.len()
                        ),
                    ));
                }
            }
            thermal
                .validate()
                .map_err(|e| ModelError::new(e.field, e.reason).within("thermal"))?;
        }
        match &self.gyro {
            Some(gyro) => gyro.validate().map_err(|e| e.within("gyro")),
            None => Ok(()),
        }
    }

    /// Parses a file's text; `file` names it in errors. The version is checked before anything
    /// else, so a file from another version is refused by version, not by a field error. Then
    /// serde reads the model and [`CorrectorFile::validate`] checks it: a file that loads can be
    /// applied without panicking. Every refusal after the version names the field.
    pub fn from_json(text: &str, file: &str) -> Result<CorrectorFile, CorrectorError> {
        let parse = |source| CorrectorError::Parse {
            file: file.to_string(),
            source,
        };
        let invalid = |field: String, reason: String| CorrectorError::Invalid {
            file: file.to_string(),
            field: if field.is_empty() {
                "(top level)".into()
            } else {
                field
            },
            reason,
        };
        let value: serde_json::Value = match serde_json::from_str(text) {
            Ok(value) => value,
            // 1e999 and the like: well-formed JSON, but no finite f64. Say where.
            Err(e) if message_of(&e) == "number out of range" => {
                return Err(invalid(
                    path_at(text, e.line(), e.column()),
                    "number out of range: not a finite 64-bit float".into(),
                ))
            }
            Err(e) => return Err(parse(e)),
        };
        let found = value
            .get("format_version")
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| CorrectorError::MissingVersion {
                file: file.to_string(),
            })?;
        if !(u64::from(OLDEST_READABLE_VERSION)..=u64::from(FORMAT_VERSION)).contains(&found) {
            return Err(CorrectorError::Version {
                file: file.to_string(),
                found,
                oldest: OLDEST_READABLE_VERSION,
                supported: FORMAT_VERSION,
            });
        }
        let parsed = match CorrectorFile::deserialize(&value) {
            Ok(parsed) => parsed,
            Err(e) => {
                let (field, reason) =
                    locate_serde_error(&value).unwrap_or_else(|| (String::new(), message_of(&e)));
                return Err(invalid(field, reason));
            }
        };
        parsed.validate().map_err(|e| invalid(e.field, e.reason))?;
        Ok(parsed)
    }

    pub fn read_path(path: &Path) -> Result<CorrectorFile, CorrectorError> {
        let file = path.display().to_string();
        let text = crate::input::limits::read_settings_text(path).map_err(|source| CorrectorError::Read {
            file: file.clone(),
            source,
        })?;
        CorrectorFile::from_json(&text, &file)
    }

    pub fn write_path(&self, path: &Path) -> Result<(), CorrectorError> {
        crate::output::write_bytes(path, (self.to_json() + "\n").as_bytes())?;
        Ok(())
    }
}

/// A serde_json error's message without the ` at line L column C` that Display appends.
fn message_of(e: &serde_json::Error) -> String {
    let text = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    text.strip_suffix(&suffix).unwrap_or(&text).to_string()
}

/// Where and why serde refuses `value` (a file whose typed reading failed), as (field path,
/// message). Reading from a `Value` gives no position, and the `kind`-tagged corrector is read
/// from a buffered copy that loses it too, so the failing part is read again from pretty-printed
/// text, the corrector by its own kind's type, and the error's position in that text is turned
/// into a path. `None` when it cannot be told (the caller then reports serde's message alone).
fn locate_serde_error(value: &serde_json::Value) -> Option<(String, String)> {
    fn read_again<T: serde::de::DeserializeOwned>(
        value: &serde_json::Value,
        prefix: &str,
    ) -> Option<(String, String)> {
        let text = serde_json::to_string_pretty(value).ok()?;
        let e = serde_json::from_str::<T>(&text).err()?;
        let field = join_field(prefix, &path_at(&text, e.line(), e.column()));
        Some((field, message_of(&e)))
    }
    let corrector = value.get("corrector");
    let kind = corrector
        .and_then(|c| c.get("kind"))
        .and_then(serde_json::Value::as_str);
    let by_kind = match (corrector, kind) {
        (Some(c), Some("ann")) => read_again::<AnnModel>(c, "corrector"),
        (Some(c), Some("linear")) => read_again::<LinearModel>(c, "corrector"),
        (Some(c), Some("static")) => read_again::<StaticCalibration>(c, "corrector"),
        _ => None,
    };
    by_kind.or_else(|| read_again::<CorrectorFile>(value, ""))
}

/// The path (`corrector.network.weights[3]`) of the value being read at `line`:`column` (as
/// serde_json counts them: from 1, and bytes from the line's start) of `text`, which is
/// well-formed JSON up to there. Keys stay current until the next comma, so a position just
/// after a value, or after the closing brace of an object value, still names that value.
fn path_at(text: &str, line: usize, column: usize) -> String {
    enum Frame {
        Object { key: Option<String>, expect_key: bool },
        Array { index: usize },
    }
    let bytes = text.as_bytes();
    let line_start = if line <= 1 {
        0
    } else {
        bytes
            .iter()
            .enumerate()
            .filter(|(_, &b)| b == b'\n')
            .nth(line - 2)
            .map_or(bytes.len(), |(i, _)| i + 1)
    };
    let end = (line_start + column).min(bytes.len());
    let mut stack: Vec<Frame> = Vec::new();
    let mut i = 0;
    while i < end {
        match bytes[i] {
            b'"' => {
                let start = i + 1;
                let mut j = start;
                while j < bytes.len() && bytes[j] != b'"' {
                    j += if bytes[j] == b'\\' { 2 } else { 1 };
                }
                let j = j.min(bytes.len());
                if let Some(Frame::Object { key, expect_key }) = stack.last_mut() {
                    if *expect_key {
                        *key = Some(String::from_utf8_lossy(&bytes[start..j]).into_owned());
                        *expect_key = false;
                    }
                }
                i = j + 1;
                continue;
            }
            b'{' => stack.push(Frame::Object {
                key: None,
                expect_key: true,
            }),
            b'[' => stack.push(Frame::Array { index: 0 }),
            b'}' | b']' => {
                stack.pop();
            }
            b',' => match stack.last_mut() {
                Some(Frame::Array { index }) => *index += 1,
                Some(Frame::Object { key, expect_key }) => {
                    *key = None;
                    *expect_key = true;
                }
                None => {}
            },
            _ => {}
        }
        i += 1;
    }
    let mut path = String::new();
    for frame in &stack {
        match frame {
            Frame::Object { key: Some(key), .. } => path = join_field(&path, key),
            Frame::Object { key: None, .. } => {}
            Frame::Array { index } => path.push_str(&format!("[{index}]")),
        }
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_become_paths() {
        let text = "{\n  \"corrector\": {\n    \"axes\": [\"x\", \"w\"],\n    \"network\": {\"weights\": [1, 2, null]}\n  }\n}";
        // Just after `"w"`, inside `null`, and just after the network object.
        assert_eq!(path_at(text, 3, 21), "corrector.axes[1]");
        assert_eq!(path_at(text, 4, 37), "corrector.network.weights[2]");
        assert_eq!(path_at(text, 4, 40), "corrector.network");
        assert_eq!(path_at(text, 6, 1), "");
    }

    #[test]
    fn other_format_version_is_refused_by_name() {
        let text = r#"{"format_version": 7, "corrector": {"kind": "future"}}"#;
        let err = CorrectorFile::from_json(text, "old.json").unwrap_err();
        let message = err.to_string();
        assert!(message.contains("old.json"), "{message}");
        assert!(message.contains("format_version 7"), "{message}");
        assert!(
            message.contains(&format!(
                "format_version {OLDEST_READABLE_VERSION} to {FORMAT_VERSION}"
            )),
            "{message}"
        );
    }

    /// A thermal part's uncertainty moves a physical corrector's parameters: beside another
    /// kind it is refused by its field.
    #[test]
    fn a_thermal_uncertainty_needs_a_physical_corrector() {
        let thermal = r#""thermal": {"reference_c": 25, "bias_mps2": [0, 0, 0], "scale_error": [0, 0, 0],
            "misalignment_rad": [0, 0, 0], "bias_per_c": [[0.001], [0.001], [0.001]], "scale_per_c": [[], [], []],
            "lag_s": 20, "smoothing_s": 60, "fitted_range_c": [10, 40], "uncertainty": {"directions": [
            {"bias_per_c": [[1e-5], [0], [0]], "scale_per_c": [[], [], []], "sensor": [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]}]}}"#;
        let physical = r#""kind": "physical", "sensor": {"bias_mps2": [0.1, 0, 0], "scale_error": [0, 0, 0],
            "misalignment_rad": [0, 0, 0], "quadratic_per_mps2": [0, 0, 0]}, "gravity_mps2": 9.81,
            "input_range_mps2": [[-10, 10], [-10, 10], [-10, 10]]"#;
        let linear = r#""kind": "linear", "axes": ["x", "y", "z"], "offset_mps2": [0.1, 0, 0],
            "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "training": null"#;
        let file = |corrector: &str| {
            format!(
                r#"{{"format_version": 4, "spincal_version": "0.2.0", "corrector": {{{corrector}}}, {thermal}}}"#
            )
        };
        let read = CorrectorFile::from_json(&file(physical), "physical.json").unwrap();
        assert_eq!(read.thermal.unwrap().uncertainty.unwrap().directions.len(), 1);
        let message = CorrectorFile::from_json(&file(linear), "linear.json")
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("linear.json") && message.contains("thermal.uncertainty"),
            "{message}"
        );
    }

    #[test]
    fn a_format_1_physical_file_reads_without_an_uncertainty() {
        let text = r#"{"format_version": 1, "spincal_version": "0.1.0", "corrector": {"kind": "physical",
            "sensor": {"bias_mps2": [0.1, 0, 0], "scale_error": [0, 0, 0], "misalignment_rad": [0, 0, 0],
            "quadratic_per_mps2": [0, 0, 0]}, "gravity_mps2": 9.81, "input_range_mps2": [[-10, 10], [-10, 10], [-10, 10]]}}"#;
        let file = CorrectorFile::from_json(text, "v1.json").unwrap();
        let CorrectorModel::Physical(physical) = &file.corrector else {
            panic!("{:?}", file.corrector);
        };
        assert!(physical.uncertainty.is_none());
        assert_eq!(physical.predicted_sd([9.81, 0.0, 0.0]), None);
    }

    #[test]
    fn a_linear_map_reads_with_and_without_its_covariance_and_only_on_three_axes() {
        let zeros = format!("[{}]", ["0"; 12].join(", "));
        let covariance = format!("[{}]", [zeros.as_str(); 12].join(", "));
        let three = r#""axes": ["x", "y", "z"], "offset_mps2": [0.1, 0, 0],
            "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "training": null"#;
        let two = r#""axes": ["x", "y"], "offset_mps2": [0.1, 0],
            "matrix": [[1, 0], [0, 1]], "training": null"#;
        let file = |map: &str, uncertainty: bool| {
            let u = if uncertainty {
                format!(
                    r#", "uncertainty": {{"covariance": {covariance}, "noise_sd_mps2": [0.02, 0.02, 0.02]}}"#
                )
            } else {
                String::new()
            };
            format!(
                r#"{{"format_version": 3, "spincal_version": "0.2.0", "corrector": {{"kind": "linear", {map}{u}}}}}"#
            )
        };
        let old = CorrectorFile::from_json(&file(three, false), "old.json").unwrap();
        assert!(old.corrector.error_model().is_none());
        let new = CorrectorFile::from_json(&file(three, true), "new.json").unwrap();
        let model = new
            .corrector
            .error_model()
            .expect("a linear map with a covariance");
        assert_eq!(model.predicted_sd([1.0, 2.0, 9.8]), Some([0.0; 3]));
        let err = CorrectorFile::from_json(&file(two, true), "two.json").unwrap_err();
        assert!(err.to_string().contains("corrector.uncertainty"), "{err}");
    }

    #[test]
    fn an_uncertainty_without_a_session_spread_reads_as_one_the_campaign_did_not_see() {
        let zeros = format!("[{}]", ["0"; 12].join(", "));
        let covariance = format!("[{}]", [zeros.as_str(); 12].join(", "));
        let text = format!(
            r#"{{"format_version": 2, "spincal_version": "0.2.0", "corrector": {{"kind": "physical",
            "sensor": {{"bias_mps2": [0.1, 0, 0], "scale_error": [0, 0, 0], "misalignment_rad": [0, 0, 0],
            "quadratic_per_mps2": [0, 0, 0]}}, "gravity_mps2": 9.81, "input_range_mps2": [[-10, 10], [-10, 10], [-10, 10]],
            "uncertainty": {{"covariance": {covariance}, "noise_sd_mps2": [0.02, 0.02, 0.02]}}}}}}"#
        );
        let file = CorrectorFile::from_json(&text, "v2.json").unwrap();
        let CorrectorModel::Physical(physical) = &file.corrector else {
            panic!("{:?}", file.corrector);
        };
        assert_eq!(physical.uncertainty.as_ref().unwrap().session_spread_mps2, None);
    }
}
