//! Temperature: the die temperature from a lagging, quantised sensor, and a thermal sensor model.
//!
//! ```text
//! m_k = b_k + β_k(ΔT) + (1 + s_k)(1 + ρ_k(ΔT)) · ((I + M) f)_k,    ΔT = T_die − T_ref
//! β_k(ΔT) = Σ_j β_kj ΔT^j,   ρ_k(ΔT) = Σ_j ρ_kj ΔT^j   (j ≥ 1: both vanish at T_ref)
//! ```
//! b, s and M are the sensor model's bias, scale errors and misalignment at the reference
//! temperature ([`crate::correctors::physical`]); β is the bias's change with temperature (m/s²),
//! ρ the relative change of each axis's gain. Misalignment is held constant: still poses at a few
//! temperatures determine it poorly, and datasheets give no thermal figure for it.
//!
//! **The die temperature.** A temperature sensor reports the die through a lag, often a first-order
//! one (dT_rep/dt = (T_die − T_rep)/τ), and in steps (1 °C on many boards). Inverting the lag,
//! T_die = T_rep + τ·dT_rep/dt, needs the rate of a stepped signal, so both the value and the rate
//! come from a local straight line fitted to the reported temperature over a centred window
//! ([`die_temperature`]); τ is chosen by the fit ([`fit_thermal`]). The window is 60 s, short against a
//! warm-up's time constant (minutes), whose curvature a longer one would flatten. A temperature
//! in whole degrees that barely moves holds still for many minutes, and no window can smooth that:
//! it is known only from when its steps happen, so such a temperature is first replaced by the line
//! through its steps' midpoints ([`dequantised`]).

pub mod causal;
pub mod checks;
mod fit;
pub mod flight_stacks;

use serde::{Deserialize, Serialize};

use crate::input::recording::Recording;

pub(crate) use fit::MIN_SPAN_C;
pub use fit::{
    fit_thermal, fit_thermal_in_sessions, TermTest, ThermalError, ThermalFit, ThermalSessions,
    ThermalSettings, ThermalTerms, LAG_RATE_MIN_BLOCKS, LAG_RATE_R2_LIMIT,
};

/// Sensor parameters at the reference temperature that the thermal model carries (no
/// nonlinearity: still poses at 1 g cannot tell it from bias and scale).
pub(crate) const REFERENCE_PARAMS: usize = 9;

/// The thermal sensor model (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalModel {
    /// T_ref, °C.
    pub reference_c: f64,
    /// b at T_ref, m/s².
    pub bias_mps2: [f64; 3],
    /// s at T_ref.
    pub scale_error: [f64; 3],
    /// [m_yx, m_zx, m_zy], rad.
    pub misalignment_rad: [f64; 3],
    /// β_kj for j = 1, 2, …: m/s² per °C^j, per axis.
    pub bias_per_c: [Vec<f64>; 3],
    /// ρ_kj for j = 1, 2, …: per °C^j, per axis.
    pub scale_per_c: [Vec<f64>; 3],
    /// τ of the reported temperature's first-order lag, s.
    pub lag_s: f64,
    /// Width of the window the reported temperature is smoothed over, s.
    pub smoothing_s: f64,
    /// The die temperatures the model was fitted on, °C (min, max).
    pub fitted_range_c: [f64; 2],
    /// What the thermal part leaves uncertain, where a campaign found it (format 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<ThermalUncertainty>,
}

/// A campaign's thermal part's uncertainty in square-root form. Each direction is one standard
/// deviation along a principal axis of the thermal fit's covariance of β and ρ, with the change
/// it makes in the saved physical corrector's sensor parameters when the campaign's readings are
/// taken to T_ref with it and the joint fit is solved again. A corrected row's variance gains
/// Σ_k (Δf_k)², Δf_k the row's change along direction k: the thermal coefficients' own error at
/// the row's temperature and what it moved in the static part, with their signs, so that the two
/// cancel where they do (at the training poses' temperatures) and add where they do not.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalUncertainty {
    pub directions: Vec<ThermalDirection>,
}

/// One direction of [`ThermalUncertainty`]: changes of β and ρ (the model's orders) and of the
/// corrector's sensor parameters (`SensorModel::params` order; the model file checks their
/// count against its corrector).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalDirection {
    pub bias_per_c: [Vec<f64>; 3],
    pub scale_per_c: [Vec<f64>; 3],
    pub sensor: Vec<f64>,
}

/// `value ≤ limit`, false for NaN: a limit check that refuses what is not a number.
fn at_most(value: f64, limit: f64) -> bool {
    value <= limit
}

/// `f(a, b)` per axis and power of ΔT, over the longer of the two (a missing order is zero):
/// coefficients of different orders combined.
pub(crate) fn coefficientwise(
    a: &[Vec<f64>; 3],
    b: &[Vec<f64>; 3],
    f: impl Fn(f64, f64) -> f64,
) -> [Vec<f64>; 3] {
    std::array::from_fn(|k| {
        (0..a[k].len().max(b[k].len()))
            .map(|j| {
                f(
                    a[k].get(j).copied().unwrap_or(0.0),
                    b[k].get(j).copied().unwrap_or(0.0),
                )
            })
            .collect()
    })
}

fn polynomial(coefficients: &[f64], dt: f64) -> f64 {
    coefficients.iter().rev().fold(0.0, |acc, c| (acc + c) * dt)
}

/// A field of a thermal model read from a file that cannot be used, by its name there.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct InvalidField {
    pub field: String,
    pub reason: String,
}

impl InvalidField {
    fn new(field: impl Into<String>, reason: impl Into<String>) -> InvalidField {
        InvalidField {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// The highest order of β and ρ a model may hold.
pub(crate) const MAX_ORDER: usize = 3;

/// The most a thermal model may move the bias over its fitted range, m/s² (half a g). Datasheet
/// offset drifts of MEMS accelerometers reach about 2 mg/°C at worst (consumer parts' z axis), a
/// quarter of a g over −40…85 °C; a larger change is a fit to something else, or an edited file.
pub const MAX_BIAS_CHANGE_MPS2: f64 = 0.5 * crate::input::recording::STANDARD_GRAVITY;

/// The most a thermal model may change an axis's gain over its fitted range (10 %): datasheet
/// sensitivity drifts are 0.01–0.03 %/°C, a few per cent over the whole operating range.
pub const MAX_GAIN_CHANGE: f64 = 0.1;

/// The largest bias at T_ref a thermal model may hold, m/s² (1 g; consumer parts' datasheets
/// allow up to about 0.15 g).
pub const MAX_BIAS_MPS2: f64 = crate::input::recording::STANDARD_GRAVITY;

/// The largest scale error at T_ref (20 %; datasheets give a few per cent).
pub const MAX_SCALE_ERROR: f64 = 0.2;

/// The largest misalignment, rad (0.1 rad, 5.7°; datasheet cross-axis sensitivities are 1–2 %).
pub const MAX_MISALIGNMENT_RAD: f64 = 0.1;

/// The longest lag of the reported temperature behind the die, s: a sensor on the die or beside
/// it follows within a minute or two; five minutes is a sensor somewhere else.
pub const MAX_LAG_S: f64 = 300.0;

/// Points on the fitted range where the plausibility limits are evaluated.
const PLAUSIBILITY_GRID: usize = 201;

impl ThermalModel {
    /// Checks a model read from a file: finite values, orders up to `MAX_ORDER`, a lag and a
    /// smoothing that are not negative, an ordered range, a gain that stays positive over it, and
    /// the plausibility limits ([`ThermalModel::check_plausible`]).
    /// Fields are named as in the file (`bias_per_c[2]`).
    pub fn validate(&self) -> Result<(), InvalidField> {
        let finite = |field: &str, values: &[f64]| match values.iter().find(|v| !v.is_finite()) {
            Some(v) => Err(InvalidField::new(field, format!("{v}: must be finite"))),
            None => Ok(()),
        };
        finite("reference_c", &[self.reference_c])?;
        finite("bias_mps2", &self.bias_mps2)?;
        finite("scale_error", &self.scale_error)?;
        finite("misalignment_rad", &self.misalignment_rad)?;
        finite("fitted_range_c", &self.fitted_range_c)?;
        for (name, terms) in [
            ("bias_per_c", &self.bias_per_c),
            ("scale_per_c", &self.scale_per_c),
        ] {
            for (k, c) in terms.iter().enumerate() {
                let field = format!("{name}[{k}]");
                finite(&field, c)?;
                if c.len() > MAX_ORDER {
                    return Err(InvalidField::new(
                        field,
                        format!("{} coefficients: at most {MAX_ORDER} (a cubic)", c.len()),
                    ));
                }
            }
        }
        if let Some(uncertainty) = &self.uncertainty {
            for (d, direction) in uncertainty.directions.iter().enumerate() {
                let field = |name: &str| format!("uncertainty.directions[{d}].{name}");
                finite(&field("sensor"), &direction.sensor)?;
                for (name, terms, model) in [
                    ("bias_per_c", &direction.bias_per_c, &self.bias_per_c),
                    ("scale_per_c", &direction.scale_per_c, &self.scale_per_c),
                ] {
                    for k in 0..3 {
                        finite(&field(&format!("{name}[{k}]")), &terms[k])?;
                        // The model's orders, or more where a left-out term's move adds one.
                        if !(model[k].len()..=MAX_ORDER).contains(&terms[k].len()) {
                            return Err(InvalidField::new(
                                field(&format!("{name}[{k}]")),
                                format!(
                                    "{} coefficients where the model has {} (at most {MAX_ORDER})",
                                    terms[k].len(),
                                    model[k].len()
                                ),
                            ));
                        }
                    }
                }
            }
        }
        for (name, v) in [("lag_s", self.lag_s), ("smoothing_s", self.smoothing_s)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(InvalidField::new(
                    name,
                    format!("{v}: must be finite and not negative"),
                ));
            }
        }
        let [lo, hi] = self.fitted_range_c;
        if lo > hi {
            return Err(InvalidField::new(
                "fitted_range_c",
                format!("[{lo}, {hi}]: the minimum exceeds the maximum"),
            ));
        }
        for t in (0..=20).map(|i| lo + (hi - lo) * i as f64 / 20.0) {
            let gain = self.scale_change(t).map(|r| 1.0 + r);
            if let Some(k) = (0..3).find(|&k| !(gain[k] > 0.5 && gain[k] < 2.0)) {
                return Err(InvalidField::new(
                    format!("scale_per_c[{k}]"),
                    format!(
                        "the gain change reaches {:.3} at {t} °C: must stay between 0.5 and 2",
                        gain[k]
                    ),
                ));
            }
        }
        self.check_plausible()
    }

    /// The plausibility limits of a thermal model, stated once ([`MAX_BIAS_CHANGE_MPS2`],
    /// [`MAX_GAIN_CHANGE`], [`MAX_BIAS_MPS2`], [`MAX_SCALE_ERROR`], [`MAX_MISALIGNMENT_RAD`],
    /// [`MAX_LAG_S`], the range and T_ref within [`checks::PLAUSIBLE_C`]): what `correct` (through
    /// [`ThermalModel::validate`]), the thermal fit and the flight-stack exports all refuse. The
    /// changes are evaluated over the fitted range and T_ref. Expects finite values (`validate`
    /// checks them first).
    pub fn check_plausible(&self) -> Result<(), InvalidField> {
        let [lo_c, hi_c] = checks::PLAUSIBLE_C;
        let [lo, hi] = self.fitted_range_c;
        if !(lo >= lo_c && hi <= hi_c) {
            return Err(InvalidField::new(
                "fitted_range_c",
                format!("[{lo}, {hi}] °C: a MEMS die's temperature lies within {lo_c}…{hi_c} °C"),
            ));
        }
        if !(lo_c..=hi_c).contains(&self.reference_c) {
            return Err(InvalidField::new(
                "reference_c",
                format!(
                    "{} °C: a MEMS die's temperature lies within {lo_c}…{hi_c} °C",
                    self.reference_c
                ),
            ));
        }
        let limits = [
            ("bias_mps2", self.bias_mps2, MAX_BIAS_MPS2, "m/s²"),
            ("scale_error", self.scale_error, MAX_SCALE_ERROR, ""),
            (
                "misalignment_rad",
                self.misalignment_rad,
                MAX_MISALIGNMENT_RAD,
                "rad",
            ),
        ];
        for (field, values, limit, unit) in limits {
            if let Some(k) = (0..3).find(|&k| !at_most(values[k].abs(), limit)) {
                return Err(InvalidField::new(
                    format!("{field}[{k}]"),
                    format!("{}{unit}: beyond ±{limit}{unit}, more than any MEMS accelerometer's datasheet allows", values[k]),
                ));
            }
        }
        if !at_most(self.lag_s, MAX_LAG_S) {
            return Err(InvalidField::new(
                "lag_s",
                format!("{} s: a temperature sensor lagging the die by more than {MAX_LAG_S} s is not measuring the die", self.lag_s),
            ));
        }
        let span = hi - lo;
        let grid = (0..PLAUSIBILITY_GRID)
            .map(|i| lo + span * i as f64 / (PLAUSIBILITY_GRID - 1) as f64)
            .chain(std::iter::once(self.reference_c));
        let (mut bias, mut gain) = ([(0.0f64, 0.0f64); 3], [(0.0f64, 0.0f64); 3]);
        for t in grid {
            let (b, g) = (self.bias_change(t), self.scale_change(t));
            for k in 0..3 {
                if !at_most(b[k].abs(), bias[k].0) {
                    bias[k] = (b[k].abs(), t);
                }
                if !at_most(g[k].abs(), gain[k].0) {
                    gain[k] = (g[k].abs(), t);
                }
            }
        }
        for k in 0..3 {
            let (change, at) = bias[k];
            if !at_most(change, MAX_BIAS_CHANGE_MPS2) {
                return Err(InvalidField::new(
                    format!("bias_per_c[{k}]"),
                    format!("the bias changes by {change:.3e} m/s² at {at} °C: at most {MAX_BIAS_CHANGE_MPS2:.2} m/s² (half a g) over the fitted range"),
                ));
            }
            let (change, at) = gain[k];
            if !at_most(change, MAX_GAIN_CHANGE) {
                return Err(InvalidField::new(
                    format!("scale_per_c[{k}]"),
                    format!("the gain changes by {change:.3e} (relative) at {at} °C: at most {MAX_GAIN_CHANGE} over the fitted range"),
                ));
            }
        }
        Ok(())
    }

    /// Whether `die_c` lies in the range the model was fitted on.
    pub fn covers(&self, die_c: f64) -> bool {
        die_c >= self.fitted_range_c[0] && die_c <= self.fitted_range_c[1]
    }

    /// β_k(ΔT) for each axis at die temperature `die_c`.
    pub fn bias_change(&self, die_c: f64) -> [f64; 3] {
        let dt = die_c - self.reference_c;
        std::array::from_fn(|k| polynomial(&self.bias_per_c[k], dt))
    }

    /// ρ_k(ΔT) for each axis at die temperature `die_c`.
    pub fn scale_change(&self, die_c: f64) -> [f64; 3] {
        let dt = die_c - self.reference_c;
        std::array::from_fn(|k| polynomial(&self.scale_per_c[k], dt))
    }

    /// The reading m of a true specific force `f` at die temperature `die_c`.
    pub fn reading(&self, f: [f64; 3], die_c: f64) -> [f64; 3] {
        let [m_yx, m_zx, m_zy] = self.misalignment_rad;
        let v = [f[0], f[1] + m_yx * f[0], f[2] + m_zx * f[0] + m_zy * f[1]];
        let (beta, rho) = (self.bias_change(die_c), self.scale_change(die_c));
        std::array::from_fn(|k| {
            self.bias_mps2[k] + beta[k] + (1.0 + self.scale_error[k]) * (1.0 + rho[k]) * v[k]
        })
    }

    /// The true specific force behind reading `m` at die temperature `die_c` (the model's inverse).
    pub fn correct(&self, m: [f64; 3], die_c: f64) -> [f64; 3] {
        let (beta, rho) = (self.bias_change(die_c), self.scale_change(die_c));
        let v: [f64; 3] = std::array::from_fn(|k| {
            (m[k] - self.bias_mps2[k] - beta[k]) / ((1.0 + self.scale_error[k]) * (1.0 + rho[k]))
        });
        let [m_yx, m_zx, m_zy] = self.misalignment_rad;
        let x = v[0];
        let y = v[1] - m_yx * x;
        [x, y, v[2] - m_zx * x - m_zy * y]
    }

    /// This model with β and ρ moved by `direction`'s changes (a direction of higher orders, a
    /// left-out term's move, adds them).
    pub fn moved_along(&self, direction: &ThermalDirection) -> ThermalModel {
        let add = |a: f64, b: f64| a + b;
        ThermalModel {
            bias_per_c: coefficientwise(&self.bias_per_c, &direction.bias_per_c, add),
            scale_per_c: coefficientwise(&self.scale_per_c, &direction.scale_per_c, add),
            ..self.clone()
        }
    }

    /// The change in [`ThermalModel::to_reference`]'s value `reference` at `die_c` when β and ρ
    /// change by `direction`'s (first order).
    pub fn reference_change(
        &self,
        reference: [f64; 3],
        die_c: f64,
        direction: &ThermalDirection,
    ) -> [f64; 3] {
        let dt = die_c - self.reference_c;
        let rho = self.scale_change(die_c);
        std::array::from_fn(|k| {
            let d_beta = polynomial(&direction.bias_per_c[k], dt);
            let d_rho = polynomial(&direction.scale_per_c[k], dt);
            -(d_beta + d_rho * (reference[k] - self.bias_mps2[k])) / (1.0 + rho[k])
        })
    }

    /// The reading the sensor would have given at the reference temperature: m with the thermal
    /// change removed, for a corrector fitted at T_ref to take over.
    pub fn to_reference(&self, m: [f64; 3], die_c: f64) -> [f64; 3] {
        let (beta, rho) = (self.bias_change(die_c), self.scale_change(die_c));
        std::array::from_fn(|k| self.bias_mps2[k] + (m[k] - self.bias_mps2[k] - beta[k]) / (1.0 + rho[k]))
    }

    /// The die temperature behind a recording's reported temperatures, with this model's lag and
    /// smoothing.
    pub fn die_temperature(&self, time_s: &[f64], reported_c: &[f64]) -> Vec<f64> {
        die_temperature(time_s, reported_c, self.lag_s, self.smoothing_s)
    }

    /// [`die_temperatures`] with this model's lag and smoothing.
    pub fn die_temperatures(&self, recordings: &[&Recording]) -> Vec<Option<Vec<f64>>> {
        die_temperatures(recordings, self.lag_s, self.smoothing_s)
    }
}

/// The die temperature behind each recording's reported temperature (`None` without one).
/// Recordings on one clock, each starting at most `smoothing_s` after the previous one ended, are
/// taken as one track: a temperature in whole degrees steps rarely, and a short pose alone may
/// hold no step at all. The gap is the smoothing window's (a line over `smoothing_s` can span
/// it), and it decides only the temperature's estimate: which recordings share a bias is their
/// power-on session's ([`fit_thermal_in_sessions`]).
pub fn die_temperatures(recordings: &[&Recording], lag_s: f64, smoothing_s: f64) -> Vec<Option<Vec<f64>>> {
    let mut order: Vec<usize> = (0..recordings.len())
        .filter(|&i| recordings[i].temperature_c.is_some() && !recordings[i].is_empty())
        .collect();
    order.sort_by(|&a, &b| recordings[a].time_s[0].total_cmp(&recordings[b].time_s[0]));
    let mut out = vec![None; recordings.len()];
    let mut track: Vec<usize> = Vec::new();
    let mut flush = |track: &mut Vec<usize>| {
        let time: Vec<f64> = track
            .iter()
            .flat_map(|&i| recordings[i].time_s.iter().copied())
            .collect();
        let reported: Vec<f64> = track
            .iter()
            .flat_map(|&i| recordings[i].temperature_c.iter().flatten().copied())
            .collect();
        let mut die = die_temperature(&time, &reported, lag_s, smoothing_s).into_iter();
        for &i in track.iter() {
            out[i] = Some(die.by_ref().take(recordings[i].len()).collect());
        }
        track.clear();
    };
    for &i in &order {
        let joins = track.last().is_some_and(|&last| {
            let gap = recordings[i].time_s[0] - recordings[last].time_s[recordings[last].len() - 1];
            gap > 0.0 && gap <= smoothing_s
        });
        if !joins && !track.is_empty() {
            flush(&mut track);
        }
        track.push(i);
    }
    if !track.is_empty() {
        flush(&mut track);
    }
    out
}

/// The die temperature from the reported one: T_s + τ·Ṫ_s, where T_s and Ṫ_s are the value and
/// slope of a straight line fitted by least squares to the reported temperatures within a centred
/// window `smoothing_s` wide (fewer samples at the ends). A temperature reported in coarse steps
/// ([`dequantised`]) is first replaced by the line through its steps. O(n).
pub fn die_temperature(time_s: &[f64], reported_c: &[f64], lag_s: f64, smoothing_s: f64) -> Vec<f64> {
    let n = time_s.len().min(reported_c.len());
    let (time_s, reported_c) = (&time_s[..n], &reported_c[..n]);
    let Some(&t0) = time_s.first() else {
        return Vec::new();
    };
    let stepped = dequantised(time_s, reported_c);
    let values = stepped.as_deref().unwrap_or(reported_c);
    // Prefix sums of 1, t, t², T, tT, with t relative to the first sample.
    let mut sums = vec![[0.0f64; 5]; n + 1];
    for i in 0..n {
        let (t, v) = (time_s[i] - t0, values[i]);
        let s = sums[i];
        sums[i + 1] = [s[0] + 1.0, s[1] + t, s[2] + t * t, s[3] + v, s[4] + t * v];
    }
    let half = smoothing_s / 2.0;
    let (mut lo, mut hi) = (0usize, 0usize);
    (0..n)
        .map(|i| {
            let ti = time_s[i];
            while time_s[lo] < ti - half {
                lo += 1;
            }
            while hi < n && time_s[hi] <= ti + half {
                hi += 1;
            }
            let [count, st, stt, sv, stv]: [f64; 5] = std::array::from_fn(|k| sums[hi][k] - sums[lo][k]);
            let mean_t = st / count;
            let var_t = stt / count - mean_t * mean_t;
            let mean_v = sv / count;
            let slope = if count >= 3.0 && var_t > 1e-12 {
                (stv / count - mean_t * mean_v) / var_t
            } else {
                0.0
            };
            mean_v + slope * (ti - t0 - mean_t) + lag_s * slope
        })
        .collect()
}

/// A temperature reported in coarse steps (it changes on fewer than one sample in ten), as the
/// line through the moments it stepped: the reported value crossed the midpoint of two levels
/// between the samples where it changed. Before the first and after the last step the line's
/// slope continues, held within half a step of the reported level. `None` for a finely resolved
/// (or constant) temperature, which smoothing alone handles.
pub fn dequantised(time_s: &[f64], reported_c: &[f64]) -> Option<Vec<f64>> {
    let n = time_s.len().min(reported_c.len());
    let changes: Vec<usize> = (1..n).filter(|&i| reported_c[i] != reported_c[i - 1]).collect();
    if changes.is_empty() || changes.len() * 10 > n {
        return None;
    }
    let knots: Vec<(f64, f64)> = changes
        .iter()
        .map(|&i| {
            (
                (time_s[i - 1] + time_s[i]) / 2.0,
                (reported_c[i - 1] + reported_c[i]) / 2.0,
            )
        })
        .collect();
    let step = changes
        .iter()
        .map(|&i| (reported_c[i] - reported_c[i - 1]).abs())
        .fold(f64::INFINITY, f64::min);
    let slope_of = |a: (f64, f64), b: (f64, f64)| {
        if b.0 > a.0 {
            (b.1 - a.1) / (b.0 - a.0)
        } else {
            0.0
        }
    };
    let first_slope = knots.get(1).map_or(0.0, |&b| slope_of(knots[0], b));
    let last_slope = knots
        .len()
        .checked_sub(2)
        .map_or(0.0, |a| slope_of(knots[a], knots[a + 1]));
    let mut k = 0;
    Some(
        (0..n)
            .map(|i| {
                let t = time_s[i];
                while k < knots.len() && knots[k].0 <= t {
                    k += 1;
                }
                let level = reported_c[i];
                let clamp = |v: f64| v.clamp(level - step / 2.0, level + step / 2.0);
                match k {
                    0 => clamp(knots[0].1 + first_slope * (t - knots[0].0)),
                    k if k == knots.len() => clamp(knots[k - 1].1 + last_slope * (t - knots[k - 1].0)),
                    k => {
                        let (a, b) = (knots[k - 1], knots[k]);
                        a.1 + slope_of(a, b) * (t - a.0)
                    }
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> ThermalModel {
        ThermalModel {
            reference_c: 25.0,
            bias_mps2: [0.05, -0.03, 0.08],
            scale_error: [0.004, -0.002, 0.006],
            misalignment_rad: [0.003, -0.002, 0.004],
            bias_per_c: [vec![0.01, -2e-4], vec![-0.008], vec![0.005, 1e-4, -3e-6]],
            scale_per_c: [vec![2e-4], vec![-1e-4, 3e-6], vec![]],
            lag_s: 20.0,
            smoothing_s: 60.0,
            fitted_range_c: [10.0, 40.0],
            uncertainty: None,
        }
    }

    fn direction(scale: f64) -> ThermalDirection {
        ThermalDirection {
            bias_per_c: [
                vec![2e-4 * scale, -3e-6 * scale],
                vec![1e-4 * scale],
                vec![-2e-4 * scale, 5e-6 * scale, 1e-7 * scale],
            ],
            scale_per_c: [vec![3e-5 * scale], vec![-2e-5 * scale, 1e-6 * scale], vec![]],
            sensor: vec![0.0; 12],
        }
    }

    /// `reference_change` is the first-order change of `to_reference` when β and ρ move along a
    /// direction: against a model with the coefficients actually moved, by a central difference.
    #[test]
    fn reference_change_is_to_reference_s_derivative_along_a_direction() {
        let m = model();
        let moved = |h: f64| m.moved_along(&direction(h));
        for (reading, t) in [
            ([1.0, -9.0, 2.5], 10.0),
            ([-7.0, 3.0, -5.0], 38.0),
            ([0.0, 0.0, 9.8], 25.0),
        ] {
            let reference = m.to_reference(reading, t);
            let change = m.reference_change(reference, t, &direction(1.0));
            let h = 1e-3;
            let (up, down) = (
                moved(h).to_reference(reading, t),
                moved(-h).to_reference(reading, t),
            );
            for k in 0..3 {
                let numeric = (up[k] - down[k]) / (2.0 * h);
                assert!(
                    (change[k] - numeric).abs() <= 1e-9 * numeric.abs().max(1e-6),
                    "axis {k} at {t} °C: {change:?} against {numeric}"
                );
            }
            if t == m.reference_c {
                assert_eq!(change, [0.0; 3], "nothing changes at T_ref");
            }
        }
    }

    /// A direction of fewer orders than the model's, or more than a cubic, is refused, naming the
    /// field; one order more (a left-out term's move) reads.
    #[test]
    fn an_uncertainty_direction_of_other_orders_is_refused_by_name() {
        let mut m = model();
        m.uncertainty = Some(ThermalUncertainty {
            directions: vec![ThermalDirection {
                bias_per_c: [vec![0.0, 0.0], vec![0.0], vec![0.0, 0.0, 0.0]],
                scale_per_c: [vec![0.0], vec![0.0, 0.0], vec![]],
                sensor: vec![0.0; 12],
            }],
        });
        m.validate().expect("the model's own orders");
        let directions = &mut m.uncertainty.as_mut().unwrap().directions;
        directions[0].scale_per_c[2] = vec![1e-6];
        m.validate().expect("a left-out term's move adds an order");
        let directions = &mut m.uncertainty.as_mut().unwrap().directions;
        directions[0].scale_per_c[1] = vec![1e-6];
        let error = m.validate().unwrap_err();
        assert_eq!(error.field, "uncertainty.directions[0].scale_per_c[1]", "{error}");
        let directions = &mut m.uncertainty.as_mut().unwrap().directions;
        directions[0].scale_per_c[1] = vec![0.0, 0.0];
        directions[0].bias_per_c[0] = vec![0.0; MAX_ORDER + 1];
        let error = m.validate().unwrap_err();
        assert_eq!(error.field, "uncertainty.directions[0].bias_per_c[0]", "{error}");
        let directions = &mut m.uncertainty.as_mut().unwrap().directions;
        directions[0].bias_per_c[0] = vec![0.0, 0.0];
        directions[0].scale_per_c[2] = vec![];
        directions[0].sensor[4] = f64::NAN;
        assert_eq!(
            m.validate().unwrap_err().field,
            "uncertainty.directions[0].sensor"
        );
    }

    #[test]
    fn correct_inverts_reading_at_any_temperature() {
        let m = model();
        for (f, t) in [
            ([1.0, -9.0, 2.5], 10.0),
            ([0.0, 0.0, 9.8], 25.0),
            ([-7.0, 3.0, -5.0], 47.0),
        ] {
            let back = m.correct(m.reading(f, t), t);
            for k in 0..3 {
                assert!((back[k] - f[k]).abs() < 1e-12, "{back:?} vs {f:?}");
            }
            // To the reference temperature and back through the model at T_ref: the same force.
            let at_reference = m.correct(m.to_reference(m.reading(f, t), t), m.reference_c);
            for k in 0..3 {
                assert!((at_reference[k] - f[k]).abs() < 1e-12);
            }
        }
        assert_eq!(m.bias_change(25.0), [0.0; 3]);
        assert!((m.bias_change(35.0)[0] - (0.1 - 0.02)).abs() < 1e-15);
    }

    #[test]
    fn a_model_from_a_file_is_checked_field_by_field() {
        model().validate().unwrap();
        let refused = |change: &dyn Fn(&mut ThermalModel)| {
            let mut m = model();
            change(&mut m);
            m.validate().unwrap_err().field
        };
        assert_eq!(refused(&|m| m.bias_mps2[1] = f64::NAN), "bias_mps2");
        assert_eq!(
            refused(&|m| m.bias_per_c[2] = vec![0.0, 0.0, 0.0, 1e-9]),
            "bias_per_c[2]"
        );
        assert_eq!(refused(&|m| m.lag_s = -1.0), "lag_s");
        assert_eq!(refused(&|m| m.fitted_range_c = [40.0, 10.0]), "fitted_range_c");
        // A gain that falls through zero within the range.
        assert_eq!(
            refused(&|m| m.scale_per_c[0] = vec![0.0, -0.009]),
            "scale_per_c[0]"
        );
    }

    /// The lag of [`lagging_warm_up`]'s temperature sensor, s.
    pub(super) const WARM_UP_LAG_S: f64 = 20.0;

    /// A warm-up T_die = 20 + 25(1 − e^(−t/600)) at 10 Hz for 3000 s, and the same seen through a
    /// first-order lag of [`WARM_UP_LAG_S`]: (time, die, reported).
    pub(super) fn lagging_warm_up() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let dt = 0.1;
        let time: Vec<f64> = (0..30_000).map(|i| i as f64 * dt).collect();
        let die: Vec<f64> = time
            .iter()
            .map(|t| 20.0 + 25.0 * (1.0 - (-t / 600.0).exp()))
            .collect();
        let mut reported = vec![die[0]; time.len()];
        for i in 1..time.len() {
            reported[i] = reported[i - 1] + dt / WARM_UP_LAG_S * (die[i - 1] - reported[i - 1]);
        }
        (time, die, reported)
    }

    #[test]
    fn die_temperature_undoes_a_first_order_lag_and_steps() {
        // The warm-up in 1 °C steps. Judged while steps still come (to 2100 s): after the last
        // one, the temperature is only known to within half a step.
        let (time, die, reported) = lagging_warm_up();
        let tau = WARM_UP_LAG_S;
        let stepped: Vec<f64> = reported.iter().map(|v| v.round()).collect();
        let worst = |estimate: &[f64]| {
            estimate[1000..21_000]
                .iter()
                .zip(&die[1000..21_000])
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        let lagging = worst(&reported);
        let smooth_only = worst(&die_temperature(&time, &stepped, 0.0, 60.0));
        let est = die_temperature(&time, &stepped, tau, 60.0);
        let estimated = worst(&est);
        assert!(lagging > 0.6, "the lag itself: {lagging}");
        assert!(smooth_only > 0.6, "smoothing alone keeps the lag: {smooth_only}");
        assert!(estimated < 0.2, "lag undone and steps smoothed: {estimated} °C");
        // No steps: the estimate moves by less than 0.01 °C between samples (10 Hz) where the
        // reported value jumps by 1 °C.
        let jump = est.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
        assert!(jump < 0.01, "largest jump {jump} °C");
    }
}
