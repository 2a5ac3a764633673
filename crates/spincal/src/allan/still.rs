//! The noise of a still recording, whole: a static calibration applied first (its gyro model to
//! the gyro), the longest still interval when asked, motion refused, then the Allan deviation and
//! its read-offs for the accelerometer and the gyroscope. `spincal allan` and Python's `allan`
//! make this one call.

use serde::Serialize;

use super::{allan_deviation, noise_params, AllanCurve, AllanError, NoiseParams};
use crate::correctors::gyro::{GyroInputUnit, GyroModel};
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::correctors::static_detect::{detect_static, StaticDetectError, StaticOptions};
use crate::input::gyro_file::GyroColumns;
use crate::input::recording::Recording;

/// A still sensor's spread is about its shortest-τ Allan deviation (white noise: equal; slow
/// drift: a few times more). Far above it, the recording holds motion, and its Allan deviation
/// would measure the motion, not the noise.
const MOTION_FACTOR: f64 = 10.0;

/// How the noise is measured.
#[derive(Debug, Clone)]
pub struct AllanSettings {
    /// Points per decade of τ.
    pub per_decade: usize,
    /// Use only the longest still interval instead of the whole recording (found as a static
    /// calibration finds them, with `detection`).
    pub longest_still: bool,
    pub detection: StaticOptions,
}

impl Default for AllanSettings {
    fn default() -> Self {
        AllanSettings {
            per_decade: 10,
            longest_still: false,
            detection: StaticOptions::default(),
        }
    }
}

/// The recording whose noise is measured, and what to apply to it first.
#[derive(Debug, Clone, Copy)]
pub struct StillNoise<'a> {
    pub recording: &'a Recording,
    /// Its name in messages (the file).
    pub name: &'a str,
    /// `accel_mps2` holds raw counts: a static calibration must be applied.
    pub raw_counts: bool,
    pub gyro: Option<&'a GyroColumns>,
    /// A static calibration (from `spincal static -o`) and its name in messages.
    pub calibration: Option<(&'a CorrectorFile, &'a str)>,
}

/// The noise figures.
#[derive(Debug, Clone, Serialize)]
pub struct AllanAnalysis {
    pub sample_rate_hz: f64,
    pub samples_used: usize,
    pub span_s: [f64; 2],
    pub params: NoiseParams,
    pub curve: AllanCurve,
    /// The gyroscope's figures (rad/s units), when there is a gyro.
    pub gyro_params: Option<NoiseParams>,
    pub gyro_curve: Option<AllanCurve>,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StillNoiseError {
    #[error(transparent)]
    Allan(#[from] AllanError),
    #[error("{file}: a {kind} corrector, not a static calibration (from `spincal static -o`)")]
    NotStatic { file: String, kind: String },
    #[error("{file}: the values are raw counts; give the accelerometer's scale, or a static calibration")]
    RawCounts { file: String },
    #[error("{source_name}: the gyro values are raw counts, not rad/s; calibrate the gyroscope first (a static calibration given the gyro file: still poses joined by rotations) and apply that calibration")]
    GyroCounts { source_name: String },
    #[error("{file}: the gyro calibration takes readings in {model_unit}, but {source_name} holds {held}")]
    GyroUnit {
        file: String,
        model_unit: String,
        source_name: String,
        held: String,
    },
    #[error("{file}: the gyro sensitivity is singular")]
    SingularGyro { file: String },
    #[error("detecting still intervals: {0}")]
    Detection(#[from] StaticDetectError),
    #[error("{file}: no still interval found")]
    NoStillInterval { file: String },
    #[error("{file}: the sensor moves: a{axis} spreads {spread:.3e} m/s², {ratio:.0}× its shortest-τ Allan deviation (a still sensor stays within about {MOTION_FACTOR}×); an Allan deviation needs the sensor at rest: record it still, or use only the longest still interval")]
    Moves {
        file: String,
        axis: char,
        spread: f64,
        ratio: f64,
    },
}

/// Measures the noise of a still recording (see the module's documentation).
pub fn analyse_still(
    input: &StillNoise<'_>,
    settings: &AllanSettings,
) -> Result<AllanAnalysis, StillNoiseError> {
    let rec = input.recording;
    let accel = match input.calibration {
        Some((file, name)) => {
            let CorrectorModel::Static(cal) = &file.corrector else {
                return Err(StillNoiseError::NotStatic {
                    file: name.to_string(),
                    kind: file.corrector.kind().to_string(),
                });
            };
            cal.apply_axes(&rec.accel_mps2)
        }
        None if input.raw_counts => {
            return Err(StillNoiseError::RawCounts {
                file: input.name.to_string(),
            })
        }
        None => rec.accel_mps2.clone(),
    };
    let gyro_model = input
        .calibration
        .and_then(|(file, name)| Some((file.gyro.as_ref()?, name)));
    let gyro = match input.gyro {
        Some(columns) => Some(calibrated_gyro(columns, gyro_model)?),
        None => None,
    };
    let (start, end) =
        if settings.longest_still {
            let d = detect_static(&rec.time_s, &accel, &settings.detection)?;
            let longest = d.intervals.iter().max_by_key(|i| i.len()).ok_or_else(|| {
                StillNoiseError::NoStillInterval {
                    file: input.name.to_string(),
                }
            })?;
            (longest.start, longest.end)
        } else {
            (0, rec.len())
        };
    let part: [Vec<f64>; 3] = std::array::from_fn(|a| accel[a][start..end].to_vec());
    let dt = 1.0 / rec.sample_rate_hz();
    let curve = allan_deviation(&part, dt, settings.per_decade)?;
    if !settings.longest_still {
        refuse_motion(&part, &curve, input.name)?;
    }
    let params = noise_params(&curve);
    let (gyro_curve, gyro_params) = match &gyro {
        Some(g) => {
            let part: [Vec<f64>; 3] = std::array::from_fn(|a| g[a][start..end].to_vec());
            let curve = allan_deviation(&part, dt, settings.per_decade)?;
            let params = noise_params(&curve);
            (Some(curve), Some(params))
        }
        None => (None, None),
    };
    Ok(AllanAnalysis {
        sample_rate_hz: 1.0 / dt,
        samples_used: end - start,
        span_s: [rec.time_s[start], rec.time_s[end - 1]],
        params,
        curve,
        gyro_params,
        gyro_curve,
    })
}

fn refuse_motion(part: &[Vec<f64>; 3], curve: &AllanCurve, file: &str) -> Result<(), StillNoiseError> {
    for (a, axis) in part.iter().enumerate() {
        let n = axis.len().max(1) as f64;
        let mean = axis.iter().sum::<f64>() / n;
        let spread = (axis.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
        let Some(&shortest) = curve.adev[a].first() else {
            continue;
        };
        if spread > MOTION_FACTOR * shortest {
            return Err(StillNoiseError::Moves {
                file: file.to_string(),
                axis: ['x', 'y', 'z'][a],
                spread,
                ratio: spread / shortest,
            });
        }
    }
    Ok(())
}

/// The gyro in rad/s: `columns` through the calibration's gyro model when there is one. Raw
/// counts without one are refused, as are a model and readings in different units.
fn calibrated_gyro(
    columns: &GyroColumns,
    model: Option<(&GyroModel, &str)>,
) -> Result<[Vec<f64>; 3], StillNoiseError> {
    let Some((model, file)) = model else {
        if columns.counts {
            return Err(StillNoiseError::GyroCounts {
                source_name: columns.source.clone(),
            });
        }
        return Ok(columns.values.clone());
    };
    let model_counts = model.input_unit == GyroInputUnit::Counts;
    if model_counts != columns.counts {
        return Err(StillNoiseError::GyroUnit {
            file: file.to_string(),
            model_unit: model.input_unit.name().to_string(),
            source_name: columns.source.clone(),
            held: if columns.counts { "raw counts" } else { "rad/s" }.to_string(),
        });
    }
    let corrector = model.corrector().ok_or_else(|| StillNoiseError::SingularGyro {
        file: file.to_string(),
    })?;
    let n = columns.values[0].len();
    let mut out: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
    for i in 0..n {
        let w = corrector.correct(std::array::from_fn(|k| columns.values[k][i]));
        for k in 0..3 {
            out[k].push(w[k]);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// White noise of `sd` at 100 Hz, with a 1 m/s² sine on x over `moving` (a span of samples).
    fn recording(n: usize, sd: f64, moving: std::ops::Range<usize>) -> Recording {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let normal = Normal::new(0.0, sd).unwrap();
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let accel_mps2 = std::array::from_fn(|k| {
            (0..n)
                .map(|i| {
                    let motion = if k == 0 && moving.contains(&i) {
                        (time_s[i] * 3.0).sin()
                    } else {
                        0.0
                    };
                    normal.sample(&mut rng) + motion + if k == 2 { 9.81 } else { 0.0 }
                })
                .collect()
        });
        Recording {
            time_s,
            accel_mps2,
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        }
    }

    fn input(rec: &Recording) -> StillNoise<'_> {
        StillNoise {
            recording: rec,
            name: "still.csv",
            raw_counts: false,
            gyro: None,
            calibration: None,
        }
    }

    #[test]
    fn white_noise_gives_its_density_and_motion_is_refused_unless_the_still_part_is_asked_for() {
        let sd = 0.01;
        let still = recording(60_000, sd, 0..0);
        let analysis = analyse_still(&input(&still), &AllanSettings::default()).unwrap();
        // σ = N/√τ for white noise: N = sd·√τ₀ = sd/√100.
        for k in 0..3 {
            let n = analysis.params.noise_density[k];
            assert!((n / (sd / 10.0) - 1.0).abs() < 0.05, "axis {k}: {n}");
        }
        assert_eq!(analysis.samples_used, 60_000);
        assert!(analysis.gyro_params.is_none());

        let moved = recording(60_000, sd, 40_000..60_000);
        let err = analyse_still(&input(&moved), &AllanSettings::default()).unwrap_err();
        assert!(matches!(err, StillNoiseError::Moves { axis: 'x', .. }), "{err}");
        let longest = AllanSettings {
            longest_still: true,
            ..AllanSettings::default()
        };
        let analysis = analyse_still(&input(&moved), &longest).unwrap();
        assert!(analysis.samples_used <= 40_000, "{}", analysis.samples_used);
        assert!(analysis.samples_used > 30_000, "{}", analysis.samples_used);
    }

    #[test]
    fn raw_counts_need_a_static_calibration_and_only_a_static_one() {
        let still = recording(6_000, 0.01, 0..0);
        let counts = StillNoise {
            raw_counts: true,
            ..input(&still)
        };
        let err = analyse_still(&counts, &AllanSettings::default()).unwrap_err();
        assert!(matches!(err, StillNoiseError::RawCounts { .. }), "{err}");
        let linear = CorrectorFile::new(CorrectorModel::Linear(Box::new(
            crate::correctors::linear::LinearModel {
                axes: crate::correctors::corrector::Axis::ALL.to_vec(),
                offset_mps2: vec![0.0; 3],
                matrix: vec![vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]],
                training: None,
                uncertainty: None,
            },
        )));
        let with_linear = StillNoise {
            calibration: Some((&linear, "lin.json")),
            ..counts
        };
        let err = analyse_still(&with_linear, &AllanSettings::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "lin.json: a linear corrector, not a static calibration (from `spincal static -o`)"
        );
    }
}
