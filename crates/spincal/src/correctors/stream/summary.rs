//! What a finished correction saw beyond the rows it wrote, and what a user should be told.

use serde::Serialize;

use crate::correctors::model_file::CorrectorFile;
use crate::correctors::rows::{PredictedError, RowStatus};

/// Refused rows whose reasons are kept for the summary.
const LISTED_REFUSALS: usize = 5;

/// Counts of what a correction wrote, and the first row of each kind that needs a word.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct StreamSummary {
    /// The file as named in messages.
    pub file: String,
    /// Every row written (data rows of the input; nothing is left out).
    pub rows: usize,
    /// Rows with an input more than the margin outside the training range, and the first's line.
    pub outside_training_range: usize,
    pub first_outside_line: Option<usize>,
    /// Rows refused (written with status `refused` and empty corrected columns).
    pub refused: usize,
    /// The first refused rows: where and why.
    pub first_refusals: Vec<String>,
    /// Rows without a value in a column used (status `skipped`), and the first.
    pub skipped: usize,
    pub first_skipped: Option<String>,
    /// What was decided about the time column (a unit found from the values, a counter
    /// unwrapped).
    pub notes: Vec<String>,
    /// What the reader left out of a file read whole (rows without every value used).
    pub left_out: Option<String>,
    /// The model calibrates a gyroscope but the input has no gyro values.
    pub gyro_uncorrected: bool,
    /// The input's gyro values are in a unit the model's gyro calibration does not take.
    pub gyro_unit_mismatch: Option<String>,
    /// Rows corrected as at the reference temperature (none given, or outside the thermal
    /// model's range), and the first's line and status.
    pub thermal_fallback: usize,
    pub first_thermal_fallback: Option<(usize, &'static str)>,
    /// Rows whose correction the model's covariance does not predict to beat no correction
    /// (`predicted_better` 0), and the first's line.
    pub not_predicted_better: usize,
    pub first_not_predicted_better: Option<usize>,
    /// Rows outside the gyro file's span or in its gaps (status `no-gyro`: accelerometer
    /// corrected, gyro columns empty), and the first's reason.
    pub no_gyro: usize,
    pub first_no_gyro: Option<String>,
    /// Rows whose reported temperature broke the sample rules (status `suspect-temperature`),
    /// and the first's line.
    pub suspect_temperature: usize,
    pub first_suspect_temperature: Option<usize>,
    /// The model's spread of the bias between power-on sessions and its readings' noise (mean over
    /// the axes), m/s², when the model predicts its error and the campaign saw that spread.
    pub session_spread_and_noise_mps2: Option<(f64, f64)>,
}

impl StreamSummary {
    pub(super) fn new(file: &str, model: &CorrectorFile) -> Self {
        let session_spread_and_noise_mps2 = model
            .corrector
            .error_model()
            .map(|e| e.uncertainty())
            .and_then(|u| Some((u.session_spread_mps2?, u.noise_sd_mps2.iter().sum::<f64>() / 3.0)));
        StreamSummary {
            file: file.to_string(),
            session_spread_and_noise_mps2,
            ..StreamSummary::default()
        }
    }

    /// Counts a corrected row: its status, and whether its correction is predicted to beat none.
    pub(super) fn corrected(&mut self, line: usize, status: RowStatus, predicted: Option<PredictedError>) {
        if predicted.is_some_and(|p| !p.better) {
            self.not_predicted_better += 1;
            self.first_not_predicted_better.get_or_insert(line);
        }
        match status {
            RowStatus::Ok => {}
            RowStatus::SuspectTemperature => {
                self.suspect_temperature += 1;
                self.first_suspect_temperature.get_or_insert(line);
            }
            RowStatus::NoTemperature | RowStatus::OutsideTemperatureRange => {
                self.thermal_fallback += 1;
                self.first_thermal_fallback.get_or_insert((line, status.as_str()));
            }
            RowStatus::PhysicsOnly | RowStatus::OutsideRange => {
                self.outside_training_range += 1;
                self.first_outside_line.get_or_insert(line);
            }
        }
    }

    /// Counts a refused row and keeps its reason when it is among the first.
    pub(super) fn refuse(&mut self, reason: &str) {
        self.refused += 1;
        if self.first_refusals.len() < LISTED_REFUSALS {
            self.first_refusals.push(reason.to_string());
        }
    }

    /// Counts a row written without a gyro (its status says why).
    pub(super) fn no_gyro(&mut self, status: &str) {
        self.no_gyro += 1;
        self.first_no_gyro.get_or_insert_with(|| status.to_string());
    }

    /// Counts a skipped row.
    pub(super) fn skip(&mut self, reason: &str) {
        self.skipped += 1;
        self.first_skipped.get_or_insert_with(|| reason.to_string());
    }

    /// What the user should know about rows that were written but not corrected as trained, one
    /// sentence each, naming the file.
    pub fn warnings(&self) -> Vec<String> {
        let name = &self.file;
        let mut out = Vec::new();
        if let Some(left_out) = &self.left_out {
            out.push(format!("{name}: {left_out}"));
        }
        if self.gyro_uncorrected {
            out.push(format!(
                "{name}: the model calibrates the gyroscope, but no gyro columns were found (give `columns` as t,ax,ay,az,gx,gy,gz); only the accelerometer was corrected"
            ));
        }
        if let Some(why) = &self.gyro_unit_mismatch {
            out.push(format!("{name}: {why}; only the accelerometer was corrected"));
        }
        if let Some(line) = self.first_outside_line {
            out.push(format!(
                "{name}: {} of {} rows ({:.1} %) have an input more than {:.0} % of the training \
                 range outside it (first at line {line}): a network is not applied there (status \
                 `outside-range`, valid 0, the reading unchanged; `physics-only` where a physical \
                 model corrects it alone)",
                self.outside_training_range,
                self.rows,
                100.0 * self.outside_training_range as f64 / self.rows.max(1) as f64,
                100.0 * crate::correctors::ann::EXTRAPOLATION_MARGIN,
            ));
        }
        if let Some((line, status)) = self.first_thermal_fallback {
            out.push(format!(
                "{name}: {} of {} rows were corrected as at the thermal model's reference temperature, valid 0: \
                 status `no-temperature` (the row has no temperature: name the column `temp_c`, or list it last in `columns`) \
                 or `outside-temperature-range` (the die temperature lies outside the range the model was fitted on); the first, \
                 line {line}, is `{status}`",
                self.thermal_fallback, self.rows
            ));
        }
        if let Some(line) = self.first_not_predicted_better {
            out.push(format!(
                "{name}: on {} of {} rows (first at line {line}) the model's own covariance does not predict the correction to beat no correction on every axis (`predicted_better` 0: a correction smaller than √2 of its standard deviation, `<axis>_corrected_sd_<unit>`); there the campaign did not determine the sensor",
                self.not_predicted_better, self.rows
            ));
        }
        // Below half a reading's noise, a session's offset adds under 12 % to one reading's error.
        if let Some((spread, noise)) = self.session_spread_and_noise_mps2.filter(|(s, n)| *s >= 0.5 * n) {
            out.push(format!(
                "{name}: the campaign found the bias differing between power-on sessions by {spread:.3} m/s² (standard deviation; one reading's noise is {noise:.3}): a reading from a session the campaign did not hold is off by such an offset, which no correction can know and which `<axis>_corrected_sd_<unit>` (the correction's own error) leaves out; add it in quadrature for the corrected reading's error, or calibrate in the session you measure"
            ));
        }
        if let Some(line) = self.first_suspect_temperature {
            out.push(format!(
                "{name}: {} of {} rows have a reported temperature outside what a die reaches ({}…{} °C) or changing faster than a die can ({} °C/s: a glitch or a sensor reset); \
                 kept out of the die-temperature estimate, corrected at the last die temperature, status `suspect-temperature`, valid 0; the first at line {line}",
                self.suspect_temperature,
                self.rows,
                crate::thermal::checks::PLAUSIBLE_C[0],
                crate::thermal::checks::PLAUSIBLE_C[1],
                crate::thermal::checks::MAX_SLEW_C_PER_S,
            ));
        }
        if let Some(first) = &self.first_no_gyro {
            out.push(format!(
                "{name}: {} of {} rows lie outside the gyro file's span or in its gaps: written with the accelerometer corrected, empty gyro columns, valid 0; the first: {first}",
                self.no_gyro, self.rows
            ));
        }
        if let Some(first) = &self.first_skipped {
            out.push(format!(
                "{name}: {} of {} rows have no value in a column used (packets of another kind?) and were written with status `skipped` and empty corrected columns; the first: {first}",
                self.skipped, self.rows
            ));
        }
        out
    }

    /// When rows were refused: one sentence saying how many, and the first reasons.
    pub fn refusals(&self) -> Option<String> {
        (self.refused > 0).then(|| {
            format!(
                "{}: {} of {} rows refused (written in place with status `refused` and empty corrected columns); the first: {}",
                self.file,
                self.refused,
                self.rows,
                self.first_refusals.join("; ")
            )
        })
    }
}
