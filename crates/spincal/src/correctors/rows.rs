//! Row-by-row correction of values in a file's own units: what `spincal correct` and Python's
//! `Corrector.correct` do to every row, in one place.
//!
//! A row is corrected or refused with a reason; nothing is dropped. A row refused for its input
//! leaves the stream's history untouched, so the rows after it are corrected as if it were absent.

use crate::correctors::corrector::{Axis, Corrector, SampleCorrector};
use crate::correctors::gyro::GyroCorrector;
use crate::correctors::model_file::{CorrectorFile, ErrorModel};
use crate::correctors::physical::predicted_to_help;
use crate::thermal::causal::CausalDieTemperature;
use crate::thermal::checks::{SampleCheck, TemperatureTrack};
use crate::thermal::ThermalModel;

/// How far outside the thermal model's range a reported temperature still feeds the die estimate,
/// °C: enough for the lag near the range's ends, not for a glitch.
const FEED_MARGIN_C: f64 = 5.0;

/// The largest corrected acceleration a row may carry, m/s² (500 g): above the widest range of any
/// MEMS accelerometer (±400 g, H3LIS331DL), so a value beyond it is no reading but a model far
/// outside what it was made for (a weight edited to 1e308 gives 1.3e306).
pub const MAX_CORRECTED_ACCEL_MPS2: f64 = 500.0 * crate::input::recording::STANDARD_GRAVITY;
/// The largest corrected rate a row may carry, rad/s (40,000 °/s): twice the widest range of a MEMS
/// gyroscope (±20,000 °/s, ADXRS649), for the same reason.
pub const MAX_CORRECTED_GYRO_RADPS: f64 = 40_000.0 * std::f64::consts::PI / 180.0;

/// Factors that turn a file's values into SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitFactors {
    pub time_to_s: f64,
    pub accel_to_mps2: f64,
    pub gyro_to_radps: f64,
}

impl UnitFactors {
    /// Values already in SI units.
    pub const SI: UnitFactors = UnitFactors {
        time_to_s: 1.0,
        accel_to_mps2: 1.0,
        gyro_to_radps: 1.0,
    };
}

/// How a corrected row may be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowStatus {
    /// Corrected as trained.
    Ok,
    /// An input lay well outside the training range: the physical model corrected it, the
    /// network on top of it was not applied.
    PhysicsOnly,
    /// The same for a network alone: the reading goes through unchanged, `valid` false.
    OutsideRange,
    /// The model corrects for temperature but the row has none: corrected as at the reference
    /// temperature, `valid` false.
    NoTemperature,
    /// The die temperature lay outside the range the thermal model was fitted on: corrected as at
    /// the reference temperature, `valid` false.
    OutsideTemperatureRange,
    /// The reported temperature broke the sample rules of [`crate::thermal::checks`] (outside
    /// what a die reaches, or faster than a die can change: a glitch or a sensor reset): kept out
    /// of the die estimate, the row corrected at the last die temperature (at the reference
    /// before any), `valid` false.
    SuspectTemperature,
}

impl RowStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            RowStatus::Ok => "ok",
            RowStatus::PhysicsOnly => "physics-only",
            RowStatus::OutsideRange => "outside-range",
            RowStatus::NoTemperature => "no-temperature",
            RowStatus::OutsideTemperatureRange => "outside-temperature-range",
            RowStatus::SuspectTemperature => "suspect-temperature",
        }
    }
}

/// One row's result, in SI units (finite also when converted back to the file's units).
#[derive(Debug, Clone, PartialEq)]
pub enum RowOutcome {
    Corrected {
        /// All three axes, m/s² (the ones the model does not correct pass through).
        accel_mps2: [f64; 3],
        /// The corrected rate, rad/s, when the model calibrates the gyro and the row has it.
        gyro_radps: Option<[f64; 3]>,
        /// False for the first rows without a full delay history and outside the range.
        valid: bool,
        status: RowStatus,
        /// The standard deviation per axis (m/s²) of the correction that the model's parameter
        /// covariance predicts, and whether on every corrected axis the correction is predicted to
        /// beat no correction ([`predicted_to_help`]); `None` for a model without a covariance.
        predicted: Option<PredictedError>,
    },
    /// The row cannot be corrected; why, without its line (the caller knows where it was).
    Refused(String),
}

/// A row's correction error as its model's covariance predicts it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedError {
    /// Standard deviation per axis, m/s².
    pub sd_mps2: [f64; 3],
    /// On every corrected axis the correction's square exceeds twice its variance.
    pub better: bool,
}

/// Which value of a row a refusal is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowValue {
    Time,
    Accel(usize),
    Gyro(usize),
}

/// Corrects rows in order, keeping the stream's history and the previous time.
pub struct RowCorrector<'a> {
    stream: Box<dyn SampleCorrector + 'a>,
    gyro: Option<GyroCorrector>,
    axes: Vec<Axis>,
    units: UnitFactors,
    previous_time_s: Option<f64>,
    /// The correction depends on time (a delay history or a thermal lag): only then is a row whose
    /// time goes backwards refused.
    needs_time: bool,
    /// The thermal model and its die-temperature estimate, when the model file has one.
    thermal: Option<Thermal<'a>>,
    /// The model whose covariance predicts each row's error, when it has one.
    error_model: Option<ErrorModel<'a>>,
}

/// What a row corrector keeps to correct for temperature.
struct Thermal<'a> {
    model: &'a ThermalModel,
    die: CausalDieTemperature,
    /// The reported temperature's sample rules, the same as the thermal fit's.
    track: TemperatureTrack,
    /// The last die temperature estimated, °C.
    last_die_c: Option<f64>,
}

/// Why a finite corrected row is no reading at all: an axis beyond [`MAX_CORRECTED_ACCEL_MPS2`]
/// or [`MAX_CORRECTED_GYRO_RADPS`] (`None`: plausible).
fn implausible(axes: &[Axis], accel_mps2: &[f64; 3], rate_radps: Option<&[f64; 3]>) -> Option<String> {
    let beyond = |what: &str, v: f64, unit: &str, limit: f64, limit_text: &str| {
        format!(
            "the corrected {what} is {v:.3e} {unit}, beyond {limit_text} ({limit:.0} {unit}) that no sensor reads: the model is far outside what it was made for"
        )
    };
    if let Some(axis) = axes
        .iter()
        .find(|a| accel_mps2[a.index()].abs() > MAX_CORRECTED_ACCEL_MPS2)
    {
        return Some(beyond(
            &format!("a{}", axis.name()),
            accel_mps2[axis.index()],
            "m/s²",
            MAX_CORRECTED_ACCEL_MPS2,
            "±500 g",
        ));
    }
    let rate = rate_radps?;
    let k = (0..3).find(|&k| rate[k].abs() > MAX_CORRECTED_GYRO_RADPS)?;
    Some(beyond(
        &format!("g{}", ["x", "y", "z"][k]),
        rate[k],
        "rad/s",
        MAX_CORRECTED_GYRO_RADPS,
        "±40,000 °/s",
    ))
}

/// The gyro sensitivity in a model file cannot be inverted.
#[derive(Debug, thiserror::Error)]
#[error("the model's gyro sensitivity is singular")]
pub struct SingularGyro;

impl<'a> RowCorrector<'a> {
    /// `with_gyro`: the rows carry gyro values (they are corrected when the model calibrates the
    /// gyro).
    pub fn new(file: &'a CorrectorFile, units: UnitFactors, with_gyro: bool) -> Result<Self, SingularGyro> {
        let gyro = match (&file.gyro, with_gyro) {
            (Some(model), true) => Some(model.corrector().ok_or(SingularGyro)?),
            _ => None,
        };
        Ok(RowCorrector {
            stream: file.corrector.stream(),
            gyro,
            axes: file.corrector.corrected_axes(),
            units,
            previous_time_s: None,
            needs_time: file.corrector.warmup_samples() > 0 || file.thermal.is_some(),
            thermal: file.thermal.as_ref().map(|model| Thermal {
                model,
                die: CausalDieTemperature::new(model.lag_s, model.smoothing_s),
                track: TemperatureTrack::new(),
                last_die_c: None,
            }),
            error_model: file.corrector.error_model(),
        })
    }

    /// Whether each corrected row carries its predicted standard deviation and flag.
    pub fn predicts_error(&self) -> bool {
        self.error_model.is_some()
    }

    /// The accelerometer axes the model corrects.
    pub fn corrected_axes(&self) -> &[Axis] {
        &self.axes
    }

    /// Whether gyro rows are corrected.
    pub fn corrects_gyro(&self) -> bool {
        self.gyro.is_some()
    }

    /// Whether rows are corrected for temperature (their temperature is then needed).
    pub fn corrects_temperature(&self) -> bool {
        self.thermal.is_some()
    }

    /// Whether a row's time matters to its correction (a model with delays or a thermal lag).
    pub fn needs_time(&self) -> bool {
        self.needs_time
    }

    /// Corrects one row; `name` names a value in refusals (`ax`, `column 3 (ax)`). Values must be
    /// finite in the file and in SI units, and, where the correction needs time, time must not
    /// go backwards (a model without delays or thermal lag never refuses a row for its time). `temperature_c` is the
    /// reported temperature, °C (None or not finite: the row has none).
    pub fn correct(
        &mut self,
        time: Option<f64>,
        accel: [f64; 3],
        gyro: Option<[f64; 3]>,
        temperature_c: Option<f64>,
        name: impl Fn(RowValue) -> String,
    ) -> RowOutcome {
        let u = self.units;
        let gyro = gyro.filter(|_| self.gyro.is_some());
        let given = time
            .map(|t| (t, u.time_to_s, RowValue::Time))
            .into_iter()
            .chain((0..3).map(|a| (accel[a], u.accel_to_mps2, RowValue::Accel(a))))
            .chain(
                gyro.into_iter()
                    .flat_map(|g| (0..3).map(move |a| (g[a], u.gyro_to_radps, RowValue::Gyro(a)))),
            );
        for (v, factor, which) in given {
            if !v.is_finite() {
                return RowOutcome::Refused(format!(
                    "{}: the value is {v}; spincal needs finite numbers",
                    name(which)
                ));
            }
            // Finite in the file is not enough: a unit's factor can carry a value past f64's range.
            if !(v * factor).is_finite() {
                return RowOutcome::Refused(format!(
                    "{}: {v:e} is {} after conversion to SI units (× {factor}); spincal needs finite numbers",
                    name(which),
                    v * factor
                ));
            }
        }
        let t = time.map(|t| t * u.time_to_s);
        if let (Some(t), Some(p), true) = (t, self.previous_time_s, self.needs_time) {
            if t < p {
                return RowOutcome::Refused(format!("time {t} s goes backwards (previous row {p} s)"));
            }
        }
        self.previous_time_s = t.or(self.previous_time_s);
        let reading_mps2 = accel.map(|a| a * u.accel_to_mps2);
        let mut accel_mps2 = reading_mps2;
        let mut thermal_status = None;
        // The die temperature the reading was taken to T_ref from, when it was.
        let mut applied_die_c = None;
        if let Some(thermal) = &mut self.thermal {
            let model = thermal.model;
            let [lo, hi] = model.fitted_range_c;
            thermal_status = match temperature_c.filter(|v| v.is_finite()) {
                None => Some(RowStatus::NoTemperature),
                Some(v) => match thermal.track.check(t, v) {
                    // Kept out of the die estimate; the die is where it last was.
                    SampleCheck::Implausible | SampleCheck::Discontinuous => {
                        if let Some(d) = thermal.last_die_c.filter(|&d| model.covers(d)) {
                            accel_mps2 = model.to_reference(accel_mps2, d);
                            applied_die_c = Some(d);
                        }
                        Some(RowStatus::SuspectTemperature)
                    }
                    // A reading far outside the range (another sensor's value) is kept out
                    // of the die estimate, which it would spoil for a whole window.
                    SampleCheck::Trusted if v < lo - FEED_MARGIN_C || v > hi + FEED_MARGIN_C => {
                        Some(RowStatus::OutsideTemperatureRange)
                    }
                    SampleCheck::Trusted => {
                        if thermal.track.restarted() {
                            // The rows before were a glitch: the estimate starts again here.
                            thermal.die = CausalDieTemperature::new(model.lag_s, model.smoothing_s);
                        }
                        // Without a clock the lag cannot be undone: the reported value stands.
                        let d = t.map_or(v, |t| thermal.die.update(t, v));
                        thermal.last_die_c = Some(d);
                        if model.covers(d) {
                            accel_mps2 = model.to_reference(accel_mps2, d);
                            applied_die_c = Some(d);
                            None
                        } else {
                            Some(RowStatus::OutsideTemperatureRange)
                        }
                    }
                },
            };
        }
        let sample = self.stream.correct_sample(accel_mps2);
        let rate = gyro
            .zip(self.gyro.as_ref())
            .map(|(g, c)| c.correct(g.map(|w| w * u.gyro_to_radps)));
        let from_mps2 = 1.0 / u.accel_to_mps2;
        let finite = self
            .axes
            .iter()
            .map(|axis| sample.accel_mps2[axis.index()])
            .flat_map(|a| [a, a * from_mps2])
            .chain(rate.iter().flatten().flat_map(|&w| [w, w / u.gyro_to_radps]))
            .all(f64::is_finite);
        if !finite {
            return RowOutcome::Refused(
                "the corrected value is not finite (the input is far outside anything the model was made for)"
                    .to_string(),
            );
        }
        if let Some(why) = implausible(&self.axes, &sample.accel_mps2, rate.as_ref()) {
            return RowOutcome::Refused(why);
        }
        let thermal_directions = self
            .thermal
            .as_ref()
            .and_then(|t| Some((t.model, t.model.uncertainty.as_ref()?, applied_die_c?)));
        let predicted = self.error_model.and_then(|model| {
            let sd_mps2 = match (model, thermal_directions) {
                (ErrorModel::Physical(physical), Some((thermal, uncertainty, die_c))) => physical
                    .predicted_sd_with(
                        accel_mps2,
                        uncertainty
                            .directions
                            .iter()
                            .map(|d| (&d.sensor[..], thermal.reference_change(accel_mps2, die_c, d))),
                    )?,
                _ => model.predicted_sd(accel_mps2)?,
            };
            let better = self.axes.iter().all(|axis| {
                let k = axis.index();
                predicted_to_help(sample.accel_mps2[k] - reading_mps2[k], sd_mps2[k])
            });
            Some(PredictedError { sd_mps2, better })
        });
        let status = match (sample.valid, sample.outside_training_range) {
            (_, false) => RowStatus::Ok,
            (true, true) => RowStatus::PhysicsOnly,
            (false, true) => RowStatus::OutsideRange,
        };
        RowOutcome::Corrected {
            accel_mps2: sample.accel_mps2,
            gyro_radps: rate,
            valid: sample.valid && thermal_status.is_none(),
            status: thermal_status.unwrap_or(status),
            predicted,
        }
    }
}
