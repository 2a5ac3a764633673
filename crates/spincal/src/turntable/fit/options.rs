//! What can be asked of a turntable fit, and how it can fail.

use serde::{Deserialize, Serialize};

use super::start::MIN_PEAK_TO_MEDIAN;
use crate::input::recording::STANDARD_GRAVITY;
use crate::optim::{BoundsError, LmOptions, NelderMeadOptions};
use crate::turntable::spectrum::SpectrumError;

/// Which axes enter the objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxesObjective {
    Xyz,
    Xy,
    /// The paper's choice when y drifts.
    X,
}

impl AxesObjective {
    pub fn axes(self) -> &'static [usize] {
        match self {
            AxesObjective::Xyz => &[0, 1, 2],
            AxesObjective::Xy => &[0, 1],
            AxesObjective::X => &[0],
        }
    }
    pub fn parse(text: &str) -> Option<AxesObjective> {
        match text {
            "xyz" => Some(AxesObjective::Xyz),
            "xy" => Some(AxesObjective::Xy),
            "x" => Some(AxesObjective::X),
            _ => None,
        }
    }
}

/// Whether to fit a linear drift per axis and recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DriftMode {
    Off,
    /// Fit drift terms and report where they are significant (the default).
    Fit,
}

/// A radius measured with a ruler: a Gaussian prior of standard deviation `tolerance_m`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RadiusPrior {
    pub value_m: f64,
    pub tolerance_m: f64,
}

/// Everything that can be set about a fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitOptions {
    pub axes: AxesObjective,
    pub drift: DriftMode,
    pub gravity_mps2: f64,
    /// Nominal speed: narrows the spectral search to ±10 % of it.
    pub rpm_hint: Option<f64>,
    /// A measured radius (applies to every recording).
    pub radius: Option<RadiusPrior>,
    /// One radius for all recordings (the sensor was not moved between them).
    pub shared_radius: bool,
    /// Fit the sensor offsets (else they are held at zero, the paper's model).
    pub fit_offsets: bool,
    /// Replacement bounds by parameter name: (name, lower, upper), SI units.
    pub bounds: Vec<(String, f64, f64)>,
    /// Sensor range, m/s², for the saturation check.
    pub range_mps2: Option<f64>,
    pub nelder_mead: NelderMeadOptions,
    pub lm: LmOptions,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            axes: AxesObjective::Xyz,
            drift: DriftMode::Fit,
            gravity_mps2: STANDARD_GRAVITY,
            rpm_hint: None,
            radius: None,
            shared_radius: true,
            fit_offsets: true,
            bounds: Vec::new(),
            range_mps2: None,
            // fminsearch's TolX; the Levenberg–Marquardt polish takes it from there.
            nelder_mead: NelderMeadOptions {
                tol_x: 1e-4,
                tol_f: 0.0,
                max_iterations_per_param: 200,
            },
            // A relative cost change of 1e-12 moves the parameters by about 1e-6 of their
            // standard errors; below it the sums' rounding decides, and iterations only churn.
            lm: LmOptions {
                cost_tolerance: 1e-12,
                ..LmOptions::default()
            },
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    #[error("{file}: a{axis} is constant (a dead or disconnected channel): there is no rotation to fit on it; check the recording or leave the axis out of the objective (`axes`)")]
    ConstantAxis { file: String, axis: char },
    #[error("{file}: no rotation found: the strongest line in the search band ({rpm:.2} rpm) is only {peak_to_median:.1}× the spectrum's median (at least {MIN_PEAK_TO_MEDIAN} is needed); {advice}")]
    NoRotation {
        file: String,
        peak_to_median: f64,
        rpm: f64,
        /// What to check: the time column's flag when its stamps repeat, else whether the
        /// turntable was turning.
        advice: String,
    },
    #[error("{file}: {advice}")]
    Time { file: String, advice: String },
    #[error("{file}: {duration_s:.2} s is too short to measure the rotation rate (the spectrum holds fewer than 2 cycles of any line it finds, so a rate or rotation count read from it would be a guess); the turntable fit needs at least 3 rotations: record at least {:.1} s at 33⅓ rpm, {:.1} s at 45 rpm", 3.0 * 60.0 / (100.0 / 3.0), 3.0 * 60.0 / 45.0)]
    TooShortToMeasure { file: String, duration_s: f64 },
    #[error("no recordings to fit")]
    NoRecordings,
    #[error(transparent)]
    Spectrum(#[from] SpectrumError),
    #[error(transparent)]
    Bounds(#[from] BoundsError),
    #[error("{file}: only {rotations:.1} rotations ({basis}: {rpm:.2} rpm for {duration_s:.1} s); at least 3 are needed to fit the turntable")]
    TooFewRotations {
        file: String,
        /// Where the rate comes from: measured, or sought near the rate the user gave.
        basis: &'static str,
        rotations: f64,
        rpm: f64,
        duration_s: f64,
    },
    #[error("no parameter is called '{0}' (bounds can be set for: {1})")]
    UnknownParameter(String, String),
    #[error("radius prior {value_m} m ± {tolerance_m} m is invalid: the tolerance must be positive and the radius within [0, 2] m")]
    BadRadius { value_m: f64, tolerance_m: f64 },
    #[error(
        "{file}: the fit did not produce finite parameters (the data may not contain a turntable signal)"
    )]
    NotFinite { file: String },
    #[error("{file}: its {gaps} logging gaps leave no stretch of {} revolutions and {} samples, so no part of it can be fitted (the platter's angle across a gap is not known); record the run without gaps", crate::turntable::segments::MIN_SEGMENT_REVOLUTIONS, crate::turntable::segments::MIN_SEGMENT_SAMPLES)]
    NoSegment { file: String, gaps: usize },
}
