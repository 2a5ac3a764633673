//! The classic calibration from still poses, whole: still intervals (the file's section labels, or
//! moving-variance detection), the 6, 9 or 12-parameter fit, and, when a gyro samples beside the
//! recording, the gyroscope from those poses and the rotations between them. `spincal static` and
//! Python's `static_calibration` make this one call.

use serde::Serialize;

use crate::correctors::gyro::{GyroInputUnit, GyroModel};
use crate::correctors::gyro_poses::{fit_gyro_poses, still_poses, GyroPoseFit, GyroPoseOptions};
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::correctors::static_cal::{
    fit_static, pose_means, spread_about, StaticCalError, StaticFit, StaticFitOptions, StaticModel,
    POORLY_DETERMINED_FRACTION_OF_G,
};
use crate::correctors::static_detect::{
    detect_static, labelled_intervals, StaticDetectError, StaticOptions, StillInterval,
};
use crate::input::gyro_file::GyroColumns;
use crate::input::recording::Recording;

/// How a still recording is calibrated.
#[derive(Debug, Clone)]
pub struct StaticSettings {
    pub model: StaticModel,
    /// Local gravity, m/s².
    pub gravity_mps2: f64,
    /// Still intervals by moving-variance detection (used when the file has no section labels, or
    /// `detect` is set).
    pub detection: StaticOptions,
    /// Find still intervals by detection even when the file labels its sections.
    pub detect: bool,
    /// The gyro's fit (its `input_unit` is taken from the gyro columns).
    pub gyro: GyroPoseOptions,
}

impl Default for StaticSettings {
    fn default() -> Self {
        StaticSettings {
            model: StaticModel::Misalignment,
            gravity_mps2: crate::input::recording::STANDARD_GRAVITY,
            detection: StaticOptions::default(),
            detect: false,
            gyro: GyroPoseOptions::default(),
        }
    }
}

/// What is calibrated: a recording (raw counts or m/s²), its section labels when the file has
/// them, and the gyro sampled beside it.
#[derive(Debug, Clone, Copy)]
pub struct StillRecording<'a> {
    pub recording: &'a Recording,
    /// `accel_mps2` holds raw counts.
    pub raw_counts: bool,
    /// Per-sample section labels (imucal's `part`): every section but `*rot*` is still.
    pub labels: Option<&'a [String]>,
    pub gyro: Option<&'a GyroColumns>,
    /// The gyro was asked for (a file of its own): its failure is an error, not a note.
    pub gyro_required: bool,
}

/// The gyroscope's calibration, or why the recording's gyro could not be calibrated.
#[derive(Debug, Clone, Serialize)]
pub struct GyroCalibration {
    pub source: String,
    pub input_unit: String,
    /// The fit, when it succeeded.
    pub fit: Option<GyroPoseFit>,
    /// Why the recording's own gyro columns could not be calibrated.
    pub error: Option<String>,
}

/// Everything the calibration found.
#[derive(Debug, Clone, Serialize)]
pub struct StaticCalibration {
    /// `section labels (all but *rot*)` or `moving-variance detection`.
    pub intervals_from: String,
    pub intervals: Vec<StillInterval>,
    /// RMS of |mean| − g before calibration (only when the input is already m/s²).
    pub rms_before_mps2: Option<f64>,
    pub fit: StaticFit,
    /// Set when the poses left the model asked for poorly determined and a smaller one is saved.
    pub reduced: Option<ModelReduction>,
    /// The gyroscope's calibration, when there is a gyro.
    pub gyro: Option<GyroCalibration>,
}

impl GyroCalibration {
    /// The gyro's calibration as text (what `spincal static` prints): b and K with their
    /// standard errors, then each rotation.
    pub fn text(&self) -> String {
        let report = self;
        let unit = &report.input_unit;
        let Some(g) = &report.fit else {
            return format!(
                "gyro ({}): not calibrated: {}\n",
                report.source,
                report.error.as_deref().unwrap_or("")
            );
        };
        let m = &g.model;
        let triple = |v: &[f64; 3]| format!("[{:.6e}, {:.6e}, {:.6e}]", v[0], v[1], v[2]);
        let mut s = format!(
            "gyro ({}, {unit}): m = b + K ω from {} rotations between still poses; b from {}\n",
            report.source,
            g.rotations.len(),
            match g.bias_from {
                crate::correctors::gyro_poses::GyroBiasSource::FirstInterval => "the first still interval",
                crate::correctors::gyro_poses::GyroBiasSource::AllIntervals => "all still intervals",
            }
        );
        s += &format!(
            "  b [{unit}]: {} ± {}\n",
            triple(&m.bias_radps),
            triple(&g.bias_se)
        );
        s += &format!("  K [{unit} per rad/s], row per gyro axis, ± 1 SE:\n");
        for i in 0..3 {
            s += &format!(
                "    {} ± {}\n",
                triple(&m.sensitivity[i]),
                triple(&g.sensitivity_se[i])
            );
        }
        let worst = g.rotations.iter().map(|r| r.residual_deg).fold(0.0, f64::max);
        s += &format!(
            "  rotation residuals: RMS {:.3}°, largest {worst:.3}° ({} iterations, {})\n",
            g.rms_residual_deg,
            g.iterations,
            g.stop.describe()
        );
        for r in &g.rotations {
            s += &format!(
                "    {:9.3} – {:9.3} s  turned {:7.2}°  gravity moved {:7.2}°  residual {:.3}°\n",
                r.t_start_s, r.t_end_s, r.angle_deg, r.gravity_angle_deg, r.residual_deg
            );
        }
        s
    }
}

impl StaticCalibration {
    /// The gyro model, when the gyro was calibrated.
    pub fn gyro_model(&self) -> Option<&GyroModel> {
        self.gyro.as_ref()?.fit.as_ref().map(|f| &f.model)
    }

    /// The versioned corrector file `spincal correct` applies: the static calibration and the
    /// gyro's.
    pub fn corrector_file(&self) -> CorrectorFile {
        let mut file = CorrectorFile::new(CorrectorModel::Static(Box::new(self.fit.calibration.clone())));
        file.gyro = self.gyro_model().cloned();
        file
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StaticCalibrationError {
    #[error("detecting still intervals: {0}")]
    Detection(#[from] StaticDetectError),
    #[error("fitting {intervals} still intervals from {from}: {source}")]
    Fit {
        intervals: usize,
        from: String,
        #[source]
        source: StaticCalError,
    },
    #[error("calibrating the gyroscope of {source_name}: {reason}")]
    Gyro { source_name: String, reason: String },
    #[error("the {intervals} still poses from {from} leave {} poorly determined even in the model of {} (1-σ effect on a 1 g reading above {} % of g), so no model is saved; {}", named(poorly_determined), StaticModel::BiasScale.describe(), 100.0 * POORLY_DETERMINED_FRACTION_OF_G, advice(poorly_determined))]
    Undetermined {
        intervals: usize,
        from: String,
        poorly_determined: Vec<(String, f64)>,
    },
}

/// `name (± effect m/s²)`, comma-separated.
fn named(parameters: &[(String, f64)]) -> String {
    let named: Vec<String> = parameters
        .iter()
        .map(|(n, e)| format!("{n} (± {e:.3} m/s²)"))
        .collect();
    named.join(", ")
}

/// The poses that determine `parameters`: each axis up and down for a bias or a scale, tilts
/// between two axes for a misalignment or a nonlinearity (with an axis level, a pose says
/// nothing to first order about them).
fn advice(parameters: &[(String, f64)]) -> String {
    let axis_terms = parameters
        .iter()
        .any(|(n, _)| n.starts_with("bias") || n.starts_with("scale"));
    let tilt_terms = parameters
        .iter()
        .any(|(n, _)| n.starts_with("misalignment") || n.starts_with("nonlinearity"));
    let mut poses = Vec::new();
    if axis_terms {
        poses.push("poses with each axis pointing up and down");
    }
    if tilt_terms {
        poses.push("poses tilted about 45° between two axes");
    }
    format!(
        "record {}, each held still for a second or more",
        poses.join(" and ")
    )
}

/// A smaller model saved because the poses left the one asked for poorly determined.
#[derive(Debug, Clone, Serialize)]
pub struct ModelReduction {
    pub requested: StaticModel,
    /// The requested model's parameters the poses left poorly determined, with the 1-σ effect of
    /// each on a 1 g reading, m/s².
    pub poorly_determined: Vec<(String, f64)>,
}

impl ModelReduction {
    /// One line: what was asked, what the poses left undetermined, what was saved.
    pub fn sentence(&self, saved: StaticModel) -> String {
        format!(
            "the poses leave {} poorly determined in the model of {}, so the model of {} is saved (every parameter of it determined); to fit the larger one, {}",
            named(&self.poorly_determined),
            self.requested.describe(),
            saved.describe(),
            advice(&self.poorly_determined)
        )
    }
}

/// Calibrates a still recording (see the module's documentation).
pub fn calibrate_static(
    input: &StillRecording<'_>,
    settings: &StaticSettings,
) -> Result<StaticCalibration, StaticCalibrationError> {
    let rec = input.recording;
    let (intervals, from) = match (input.labels, settings.detect) {
        (Some(labels), false) => (
            labelled_intervals(&rec.time_s, &rec.accel_mps2, labels, |l| !l.contains("rot")),
            "section labels (all but *rot*)",
        ),
        _ => (
            detect_static(&rec.time_s, &rec.accel_mps2, &settings.detection)?.intervals,
            "moving-variance detection",
        ),
    };
    let means = pose_means(&intervals);
    let (fit, reduced) = fit_determined(&means, settings, input.raw_counts).map_err(|e| match e {
        Undetermined::Fit(source) => StaticCalibrationError::Fit {
            intervals: intervals.len(),
            from: from.to_string(),
            source,
        },
        Undetermined::Poorly(poorly_determined) => StaticCalibrationError::Undetermined {
            intervals: intervals.len(),
            from: from.to_string(),
            poorly_determined,
        },
    })?;
    let rms_before_mps2 = (!input.raw_counts).then(|| {
        let norms: Vec<f64> = means
            .iter()
            .map(|m| (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt())
            .collect();
        spread_about(&norms, settings.gravity_mps2)
    });
    let gyro = match input.gyro {
        Some(columns) => {
            let options = GyroPoseOptions {
                input_unit: if columns.counts {
                    GyroInputUnit::Counts
                } else {
                    GyroInputUnit::RadPerS
                },
                ..settings.gyro.clone()
            };
            let poses = still_poses(&intervals, &fit.calibration);
            let result = fit_gyro_poses(&rec.time_s, &columns.values, &poses, &options)
                .map_err(|e| e.to_string())
                .and_then(|g| match g.model.validate() {
                    Ok(()) => Ok(g),
                    Err(e) => Err(format!(
                        "the fitted gyro model is not usable: {}: {}",
                        e.field, e.reason
                    )),
                });
            if let (Err(reason), true) = (&result, input.gyro_required) {
                return Err(StaticCalibrationError::Gyro {
                    source_name: columns.source.clone(),
                    reason: reason.clone(),
                });
            }
            Some(GyroCalibration {
                source: columns.source.clone(),
                input_unit: options.input_unit.name().to_string(),
                fit: result.as_ref().ok().cloned(),
                error: result.err(),
            })
        }
        None => None,
    };
    Ok(StaticCalibration {
        intervals_from: from.to_string(),
        intervals,
        rms_before_mps2,
        fit,
        reduced,
        gyro,
    })
}

enum Undetermined {
    Fit(StaticCalError),
    Poorly(Vec<(String, f64)>),
}

/// The model asked for when the poses determine every parameter of it; else the next smaller
/// one that they do (misalignment before scale and bias), with what the larger left undetermined.
/// A model is never saved with a parameter the poses leave poorly determined.
fn fit_determined(
    means: &[[f64; 3]],
    settings: &StaticSettings,
    raw_counts: bool,
) -> Result<(StaticFit, Option<ModelReduction>), Undetermined> {
    let mut first_poor: Option<Vec<(String, f64)>> = None;
    let mut model = settings.model;
    loop {
        let fit = fit_static(
            means,
            &StaticFitOptions {
                model,
                gravity_mps2: settings.gravity_mps2,
                input_unit: if raw_counts { "counts" } else { "m/s^2" }.into(),
            },
        );
        let fit = match (fit, &first_poor) {
            (Ok(fit), _) => fit,
            // Too few poses for the smaller model: report what the larger left undetermined.
            (Err(_), Some(poor)) => return Err(Undetermined::Poorly(poor.clone())),
            (Err(e), None) => return Err(Undetermined::Fit(e)),
        };
        let poor = fit.poorly_determined();
        if poor.is_empty() {
            let reduced = first_poor.map(|poorly_determined| ModelReduction {
                requested: settings.model,
                poorly_determined,
            });
            return Ok((fit, reduced));
        }
        let smaller = match model {
            StaticModel::Nonlinear => StaticModel::Misalignment,
            StaticModel::Misalignment => StaticModel::BiasScale,
            StaticModel::BiasScale => return Err(Undetermined::Poorly(first_poor.unwrap_or(poor))),
        };
        first_poor.get_or_insert(poor);
        model = smaller;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::gyro_poses::{simulate_pose_session, PoseSessionSetup};

    fn session(seed: u64) -> (Recording, GyroColumns, PoseSessionSetup) {
        let setup = PoseSessionSetup::random(seed);
        let s = simulate_pose_session(&setup, seed).unwrap();
        let recording = Recording {
            time_s: s.time_s,
            accel_mps2: s.accel,
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        let gyro = GyroColumns {
            values: s.gyro,
            counts: false,
            source: "gyro.txt".into(),
        };
        (recording, gyro, setup)
    }

    /// Pose means of a sensor with bias, scale and a small misalignment, 1 mg of noise.
    fn means(directions: &[[f64; 3]], seed: u64) -> Vec<[f64; 3]> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.01).unwrap();
        let g = crate::input::recording::STANDARD_GRAVITY;
        directions
            .iter()
            .map(|d| {
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let u = d.map(|v| v / n);
                let tilted = [u[0] + 0.004 * u[1], u[1] - 0.003 * u[2], u[2] + 0.002 * u[0]];
                std::array::from_fn(|k| {
                    [1.02, 0.99, 1.01][k] * g * tilted[k] + [0.2, -0.1, 0.15][k] + noise.sample(&mut rng)
                })
            })
            .collect()
    }

    #[test]
    fn a_model_the_poses_do_not_determine_is_never_saved() {
        let faces = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let settings = StaticSettings::default();
        // Six faces twice: an axis level says nothing about the misalignments, so the 9-term
        // model gives way to bias and scale, and the reason is kept.
        let level: Vec<[f64; 3]> = faces.iter().chain(&faces).copied().collect();
        let (fit, reduced) = fit_determined(&means(&level, 1), &settings, false).ok().unwrap();
        assert_eq!(fit.calibration.model, StaticModel::BiasScale);
        let reduced = reduced.expect("the reduction is reported");
        assert_eq!(reduced.requested, StaticModel::Misalignment);
        let names: Vec<&str> = reduced
            .poorly_determined
            .iter()
            .map(|(n, _)| n.as_str())
            .collect();
        assert!(names.contains(&"misalignment_yz"), "{names:?}");
        assert!(reduced
            .sentence(fit.calibration.model)
            .contains("tilted about 45°"));
        // Tilts between the axes determine them: the 9-term model is kept.
        let tilted: Vec<[f64; 3]> = level
            .iter()
            .copied()
            .chain([
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 1.0],
                [1.0, 0.0, 1.0],
                [-1.0, 1.0, 0.0],
                [0.0, -1.0, 1.0],
                [1.0, 0.0, -1.0],
            ])
            .collect();
        let (fit, reduced) = fit_determined(&means(&tilted, 2), &settings, false).ok().unwrap();
        assert_eq!(fit.calibration.model, StaticModel::Misalignment);
        assert!(reduced.is_none());
        // Never +x or −x: bias_x and scale_x cannot be told apart in any model.
        let no_x: Vec<[f64; 3]> = (0..12)
            .map(|k| {
                let a = k as f64 * 0.5;
                [0.0, a.cos(), a.sin()]
            })
            .collect();
        match fit_determined(&means(&no_x, 3), &settings, false) {
            Err(Undetermined::Poorly(poor)) => {
                assert!(
                    poor.iter().any(|(n, _)| n == "bias_x" || n == "scale_x"),
                    "{poor:?}"
                )
            }
            Err(Undetermined::Fit(e)) => panic!("{e}"),
            Ok((fit, _)) => panic!("saved {:?}", fit.calibration.model),
        }
    }

    #[test]
    fn the_pipeline_recovers_the_accelerometer_and_the_gyro_and_saves_both() {
        let (recording, gyro, setup) = session(3);
        let input = StillRecording {
            recording: &recording,
            raw_counts: true,
            labels: None,
            gyro: Some(&gyro),
            gyro_required: true,
        };
        let settings = StaticSettings {
            gravity_mps2: setup.gravity_mps2,
            ..StaticSettings::default()
        };
        let cal = calibrate_static(&input, &settings).unwrap();
        assert_eq!(cal.intervals_from, "moving-variance detection");
        assert!(cal.intervals.len() >= 20, "{} intervals", cal.intervals.len());
        assert_eq!(cal.rms_before_mps2, None, "raw counts have no |a| before");
        for k in 0..3 {
            // 0.5 count of 33 000 is about 1 mg.
            let bias_error = cal.fit.calibration.bias[k] - setup.accel.bias[k];
            assert!(
                bias_error.abs() < 0.5,
                "accel bias {k} off by {bias_error} counts"
            );
            let gyro_error = cal.gyro_model().unwrap().bias_radps[k] - setup.gyro.bias_radps[k];
            assert!(gyro_error.abs() < 2e-3, "gyro bias {k} off by {gyro_error} rad/s");
        }
        let file = cal.corrector_file();
        assert!(matches!(file.corrector, CorrectorModel::Static(_)));
        assert_eq!(file.gyro.as_ref(), cal.gyro_model());
    }

    #[test]
    fn a_gyro_that_cannot_be_calibrated_is_an_error_only_when_asked_for() {
        let (recording, mut gyro, _) = session(4);
        // A gyro that never turns: no rotation to calibrate K from.
        gyro.values = std::array::from_fn(|_| vec![0.0; recording.len()]);
        let mut input = StillRecording {
            recording: &recording,
            raw_counts: true,
            labels: None,
            gyro: Some(&gyro),
            gyro_required: false,
        };
        let settings = StaticSettings::default();
        let noted = calibrate_static(&input, &settings).unwrap();
        let report = noted.gyro.as_ref().unwrap();
        assert!(report.fit.is_none() && report.error.is_some(), "{report:?}");
        assert!(noted.corrector_file().gyro.is_none());
        input.gyro_required = true;
        let err = calibrate_static(&input, &settings).unwrap_err().to_string();
        assert!(err.contains("calibrating the gyroscope of gyro.txt"), "{err}");
    }
}
