//! The thermal model as the parameter files two flight stacks read: ArduPilot's `INS_TCALn_*`
//! (a Mission Planner / MAVProxy `.param` file) and PX4's `TC_An_*` (a QGroundControl `.params`
//! file).
//!
//! **What the stacks apply** (read from their sources):
//! - ArduPilot (`libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp`, called from
//!   `AP_InertialSensor_Backend::_rotate_and_correct_accel` before the `INS_ACCn` offsets and
//!   scales, in the sensor frame): `a -= P(T − 35) − P(T_cal − 35)` with
//!   `P(x) = 1e-6 · (ACC1·x + ACC2·x² + ACC3·x³)` per axis, T the IMU's reported temperature and
//!   T_cal `INS_ACCn_CALTEMP` (the temperature of the stack's own accel calibration), both clamped
//!   to `[TMIN, TMAX]`; 35 °C is the fixed `TEMP_REFERENCE`. The readings are brought to T_cal,
//!   where the stack's offsets and scales were measured.
//! - PX4 (`src/modules/temperature_compensation/TemperatureCompensation.cpp`,
//!   `calc_thermal_offsets_3D`, subtracted in `calibration::Accelerometer::Correct` before the
//!   `CAL_ACCn` offset and scale): `a -= X0 + X1·d + X2·d² + X3·d³`, d = clamp(T, TMIN, TMAX) − TREF,
//!   in m/s² (no scale term in current PX4). The module recomputes at 1 Hz and publishes a new
//!   offset only when T has moved more than 1 °C since the last one. Its accel calibration
//!   subtracts the same offset while it runs, so `CAL_ACCn_OFF` is the bias at TREF.
//!
//! **What is converted.** Both hold a bias polynomial of order ≤ 3 in temperature, so β is
//! written exactly: for ArduPilot re-centred on 35 °C (a polynomial shift; the constant β(35 − T_ref)
//! cancels in P(T) − P(T_cal)), for PX4 with TREF = T_ref and X0 = 0. A β of higher order is
//! refused. **What is left out** (stated, with its size, in each file's header): the gain's change
//! with temperature ρ(ΔT), largest |ρ_k|·g over the fitted range; the bias, scale and
//! misalignment at T_ref, which the stack's ordinary accel calibration holds; the die-temperature
//! lag (the stacks use the reported temperature); gyro terms, which the model does not have.

use std::fmt::Write;

use super::ThermalModel;
use crate::input::recording::STANDARD_GRAVITY;

/// ArduPilot's fixed reference temperature (`TEMP_REFERENCE`), °C.
pub const ARDUPILOT_REFERENCE_C: f64 = 35.0;
/// ArduPilot stores each coefficient × 1e6 (`SCALE_FACTOR`), so parameter editors show plain
/// numbers.
pub(crate) const ARDUPILOT_SCALE: f64 = 1.0e6;
/// The highest power of temperature either stack holds.
pub(crate) const MAX_ORDER: usize = 3;
/// PX4 republishes the thermal offset only after the temperature moved this far, °C.
pub(crate) const PX4_REPUBLISH_C: f64 = 1.0;
/// Warm-up rate at which the lag's effect is stated in the files' headers, °C/s (1 °C/min).
const EXAMPLE_RATE_C_PER_S: f64 = 1.0 / 60.0;
/// Points on the fitted range where the left-out sizes are evaluated (their maxima).
const GRID: usize = 2001;

/// Why a thermal model cannot be written for a flight stack.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FlightStackError {
    #[error("parameter thermal.bias_per_c[{axis}][{index}] = {value} is a term in ΔT^{order}; {stack} holds a bias polynomial of order at most 3 (fit the thermal model with a bias order of 3 or less)")]
    BiasOrder {
        stack: &'static str,
        axis: usize,
        index: usize,
        order: usize,
        value: f64,
    },
    #[error("parameter thermal.{name} = {value}: {why}")]
    Invalid {
        name: String,
        value: String,
        why: &'static str,
    },
    /// The model breaks the plausibility limits that `spincal correct` also refuses
    /// ([`ThermalModel::check_plausible`]).
    #[error(
        "parameter thermal.{field}: {reason}; spincal correct refuses this model too, so it is not exported"
    )]
    Implausible { field: String, reason: String },
    #[error("{what} {value}: {why}")]
    Target {
        what: &'static str,
        value: u32,
        why: &'static str,
    },
}

/// MAVLink's type of a parameter (`MAV_PARAM_TYPE`), as QGroundControl's files give it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamType {
    /// `MAV_PARAM_TYPE_INT32` (6).
    Int32,
    /// `MAV_PARAM_TYPE_REAL32` (9).
    Real32,
}

impl ParamType {
    pub fn mavlink_code(self) -> u8 {
        match self {
            ParamType::Int32 => 6,
            ParamType::Real32 => 9,
        }
    }
}

/// One parameter as written.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: String,
    pub value: f64,
    pub kind: ParamType,
}

/// The sizes of what a stack's parameters cannot hold, over the model's fitted range.
#[derive(Debug, Clone, PartialEq)]
pub struct LeftOut {
    /// Largest |ρ_k(ΔT)|·g per axis, m/s²: the gain's change with temperature at 1 g.
    pub gain_change_mps2: [f64; 3],
    /// Largest |dβ_k/dT| per axis, m/s² per °C: what a temperature error of 1 °C costs.
    pub bias_slope_mps2_per_c: [f64; 3],
    /// τ of the reported temperature's lag, s (the stacks use the reported temperature).
    pub lag_s: f64,
}

impl LeftOut {
    /// The bias error of reading the die temperature through the lag during a warm-up at
    /// `rate_c_per_s`: |dβ/dT|·τ·rate, per axis, m/s².
    pub fn lag_error_mps2(&self, rate_c_per_s: f64) -> [f64; 3] {
        self.bias_slope_mps2_per_c.map(|s| s * self.lag_s * rate_c_per_s)
    }
}

/// A flight stack's parameter file: its parameters, its text, and what it leaves out.
#[derive(Debug, Clone, PartialEq)]
pub struct StackFile {
    pub params: Vec<Param>,
    pub text: String,
    pub left_out: LeftOut,
}

/// Which ArduPilot IMU the parameters are for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArduPilotTarget {
    /// n of `INS_TCALn_*`, 1 to 3.
    pub imu: u8,
}

/// Which PX4 accelerometer the parameters are for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Px4Target {
    /// n of `TC_An_*`, 0 to 3.
    pub accel: u8,
    /// The accelerometer's device id (`CAL_ACCn_ID`): PX4 applies `TC_An_*` only to the sensor
    /// whose id equals `TC_An_ID`.
    pub device_id: u32,
    /// The vehicle's MAVLink system id: QGroundControl refuses a file saved for another.
    pub system_id: u8,
    /// The autopilot's component id.
    pub component_id: u8,
}

/// The coefficients c_1, c_2, … of β(x + shift) = c_0 + Σ_{i≥1} c_i x^i, for β(y) = Σ_{j≥1}
/// `coefficients[j−1]`·y^j; the constant c_0 = β(shift) is dropped (both stacks' polynomials have
/// none). Exact up to rounding: each c_i = Σ_{j≥i} C(j, i)·shift^(j−i)·β_j.
pub(crate) fn shifted_polynomial(coefficients: &[f64], shift: f64) -> Vec<f64> {
    (1..=coefficients.len())
        .map(|i| {
            (i..=coefficients.len())
                .map(|j| binomial(j, i) * shift.powi((j - i) as i32) * coefficients[j - 1])
                .sum()
        })
        .collect()
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, m| acc * (n - m) as f64 / (m + 1) as f64)
}

fn polynomial(coefficients: &[f64], x: f64) -> f64 {
    coefficients.iter().rev().fold(0.0, |acc, c| (acc + c) * x)
}

fn derivative(coefficients: &[f64], x: f64) -> f64 {
    coefficients
        .iter()
        .enumerate()
        .rev()
        .fold(0.0, |acc, (j, c)| acc * x + (j + 1) as f64 * c)
}

/// Checks what both stacks need of a model: finite numbers, a range, a bias of order ≤ 3.
fn check(model: &ThermalModel, stack: &'static str) -> Result<(), FlightStackError> {
    let invalid = |name: String, value: f64, why: &'static str| FlightStackError::Invalid {
        name,
        value: value.to_string(),
        why,
    };
    if !model.reference_c.is_finite() {
        return Err(invalid(
            "reference_c".into(),
            model.reference_c,
            "not a finite temperature",
        ));
    }
    let [low, high] = model.fitted_range_c;
    if !(low.is_finite() && high.is_finite() && low < high) {
        return Err(FlightStackError::Invalid {
            name: "fitted_range_c".into(),
            value: format!("[{low}, {high}]"),
            why: "not a range of finite temperatures, lowest first",
        });
    }
    if !(model.lag_s.is_finite() && model.lag_s >= 0.0) {
        return Err(invalid("lag_s".into(), model.lag_s, "not a finite lag ≥ 0"));
    }
    for (field, sets) in [
        ("bias_per_c", &model.bias_per_c),
        ("scale_per_c", &model.scale_per_c),
    ] {
        for (axis, coefficients) in sets.iter().enumerate() {
            if let Some(j) = coefficients.iter().position(|c| !c.is_finite()) {
                return Err(invalid(
                    format!("{field}[{axis}][{j}]"),
                    coefficients[j],
                    "not finite",
                ));
            }
        }
    }
    // What `correct` would refuse is not exported either.
    model
        .check_plausible()
        .map_err(|e| FlightStackError::Implausible {
            field: e.field,
            reason: e.reason,
        })?;
    for (axis, coefficients) in model.bias_per_c.iter().enumerate() {
        // Zeros past the cubic are no term at all.
        if let Some(index) = coefficients
            .iter()
            .rposition(|&c| c != 0.0)
            .filter(|&i| i >= MAX_ORDER)
        {
            return Err(FlightStackError::BiasOrder {
                stack,
                axis,
                index,
                order: index + 1,
                value: coefficients[index],
            });
        }
    }
    Ok(())
}

/// The sizes of what neither stack holds (see [`LeftOut`]), on a fine grid over the fitted range.
pub fn left_out(model: &ThermalModel) -> LeftOut {
    let [low, high] = model.fitted_range_c;
    let mut gain = [0.0f64; 3];
    let mut slope = [0.0f64; 3];
    for i in 0..GRID {
        let dt = low + (high - low) * i as f64 / (GRID - 1) as f64 - model.reference_c;
        for k in 0..3 {
            gain[k] = gain[k].max(polynomial(&model.scale_per_c[k], dt).abs() * STANDARD_GRAVITY);
            slope[k] = slope[k].max(derivative(&model.bias_per_c[k], dt).abs());
        }
    }
    LeftOut {
        gain_change_mps2: gain,
        bias_slope_mps2_per_c: slope,
        lag_s: model.lag_s,
    }
}

/// The bias polynomial's coefficients β_1..β_3 per axis (zeros where the model has fewer).
fn cubic(model: &ThermalModel) -> [[f64; MAX_ORDER]; 3] {
    std::array::from_fn(|k| std::array::from_fn(|j| model.bias_per_c[k].get(j).copied().unwrap_or(0.0)))
}

fn triple(values: [f64; 3]) -> String {
    format!("x {:.3e}, y {:.3e}, z {:.3e}", values[0], values[1], values[2])
}

/// The header lines both files share: what is left out, with its size.
fn left_out_lines(model: &ThermalModel, left: &LeftOut, calibration: &str) -> Vec<String> {
    let [low, high] = model.fitted_range_c;
    vec![
        "Left out (the stack cannot hold it):".into(),
        format!(
            "  the gain's change with temperature: up to {} m/s^2 at 1 g over [{low}, {high}] degC",
            triple(left.gain_change_mps2)
        ),
        format!(
            "  the bias, scale and misalignment at T_ref = {} degC: the stack's own accel calibration holds them ({calibration})",
            model.reference_c
        ),
        format!(
            "  the die-temperature lag (tau = {} s): the stack uses the reported temperature; the bias moves up to {} m/s^2 per degC, so a warm-up at 1 degC/min leaves {} m/s^2",
            model.lag_s,
            triple(left.bias_slope_mps2_per_c),
            triple(left.lag_error_mps2(EXAMPLE_RATE_C_PER_S))
        ),
    ]
}

/// ArduPilot's `INS_TCALn_*` for `model`, as a `.param` file (`NAME,VALUE` lines, `#` comments,
/// which Mission Planner and MAVProxy skip). Values in ArduPilot's units: coefficients in
/// 1e-6 m/s² per °C^j, temperatures in °C.
pub fn ardupilot(model: &ThermalModel, target: ArduPilotTarget) -> Result<StackFile, FlightStackError> {
    if !(1..=3).contains(&target.imu) {
        return Err(FlightStackError::Target {
            what: "ArduPilot IMU",
            value: target.imu.into(),
            why: "INS_TCALn exists for n = 1, 2, 3",
        });
    }
    check(model, "ArduPilot")?;
    let n = target.imu;
    let shift = ARDUPILOT_REFERENCE_C - model.reference_c;
    let coefficients: [Vec<f64>; 3] = cubic(model).map(|c| shifted_polynomial(&c, shift));
    let [low, high] = model.fitted_range_c;
    let mut params = vec![
        Param {
            name: format!("INS_TCAL{n}_ENABLE"),
            value: 1.0,
            kind: ParamType::Int32,
        },
        Param {
            name: format!("INS_TCAL{n}_TMIN"),
            value: low,
            kind: ParamType::Real32,
        },
        Param {
            name: format!("INS_TCAL{n}_TMAX"),
            value: high,
            kind: ParamType::Real32,
        },
    ];
    for j in 0..MAX_ORDER {
        for (k, axis) in ["X", "Y", "Z"].iter().enumerate() {
            params.push(Param {
                name: format!("INS_TCAL{n}_ACC{}_{axis}", j + 1),
                value: coefficients[k][j] * ARDUPILOT_SCALE,
                kind: ParamType::Real32,
            });
        }
    }
    for j in 0..MAX_ORDER {
        for axis in ["X", "Y", "Z"] {
            params.push(Param {
                name: format!("INS_TCAL{n}_GYR{}_{axis}", j + 1),
                value: 0.0,
                kind: ParamType::Real32,
            });
        }
    }
    let left = left_out(model);
    let mut lines = vec![
        format!(
            "spincal {}: accelerometer temperature compensation for ArduPilot (INS_TCAL{n}_*)",
            env!("CARGO_PKG_VERSION")
        ),
        "Load with Mission Planner (Full Parameter List > Load from file) or MAVProxy (param load FILE), then reboot.".into(),
        format!(
            "ArduPilot subtracts P(T - 35) - P(INS_ACC{n}_CALTEMP - 35) from the accelerometer (sensor frame, m/s^2), both temperatures clamped to [TMIN, TMAX],"
        ),
        format!(
            "with P(x) = 1e-6 (ACC1 x + ACC2 x^2 + ACC3 x^3): spincal's bias change beta(T - {}) rewritten about 35 degC (exact; the constant cancels).",
            model.reference_c
        ),
        format!("Readings are brought to INS_ACC{n}_CALTEMP, where ArduPilot's own accel calibration was made."),
    ];
    lines.extend(left_out_lines(
        model,
        &left,
        &format!("INS_ACC{n}OFFS, INS_ACC{n}SCAL"),
    ));
    lines.push(
        "  gyro: spincal's thermal model has no gyro terms; the GYR coefficients are 0 (replacing any gyro temperature calibration learned before)".into(),
    );
    let mut text = String::new();
    for line in &lines {
        let _ = writeln!(text, "# {line}");
    }
    for p in &params {
        let _ = writeln!(text, "{},{}", p.name, p.value);
    }
    Ok(StackFile {
        params,
        text,
        left_out: left,
    })
}

/// PX4's `TC_A_ENABLE` and `TC_An_*` for `model`, as a QGroundControl `.params` file (`#`
/// comments, then `system component name value type` lines, tab separated). Coefficients in
/// m/s² per °C^j, temperatures in °C. Gyro thermal parameters (`TC_G*`) are not written.
pub fn px4(model: &ThermalModel, target: Px4Target) -> Result<StackFile, FlightStackError> {
    check_px4_target(&target)?;
    check(model, "PX4")?;
    let params = px4_params(model, &target);
    let left = left_out(model);
    let lines = px4_comments(model, &target, &left);
    let text = px4_text(&lines, &params, &target);
    Ok(StackFile {
        params,
        text,
        left_out: left,
    })
}

/// An accelerometer PX4 has thermal parameters for, and a device id it would match.
fn check_px4_target(target: &Px4Target) -> Result<(), FlightStackError> {
    if target.accel > 3 {
        return Err(FlightStackError::Target {
            what: "PX4 accelerometer",
            value: target.accel.into(),
            why: "TC_An exists for n = 0 to 3",
        });
    }
    if target.device_id == 0 {
        return Err(FlightStackError::Target {
            what: "PX4 device id",
            value: 0,
            why: "no sensor has id 0, so PX4 would apply nothing; give the accelerometer's CAL_ACCn_ID",
        });
    }
    Ok(())
}

/// `TC_A_ENABLE`, then accelerometer n's id, temperatures and coefficients.
fn px4_params(model: &ThermalModel, target: &Px4Target) -> Vec<Param> {
    let n = target.accel;
    let coefficients = cubic(model);
    let [low, high] = model.fitted_range_c;
    let mut params = vec![
        Param {
            name: "TC_A_ENABLE".into(),
            value: 1.0,
            kind: ParamType::Int32,
        },
        Param {
            name: format!("TC_A{n}_ID"),
            value: target.device_id.into(),
            kind: ParamType::Int32,
        },
        Param {
            name: format!("TC_A{n}_TREF"),
            value: model.reference_c,
            kind: ParamType::Real32,
        },
        Param {
            name: format!("TC_A{n}_TMIN"),
            value: low,
            kind: ParamType::Real32,
        },
        Param {
            name: format!("TC_A{n}_TMAX"),
            value: high,
            kind: ParamType::Real32,
        },
    ];
    for j in 0..=MAX_ORDER {
        for (k, coefficients) in coefficients.iter().enumerate() {
            params.push(Param {
                name: format!("TC_A{n}_X{j}_{k}"),
                // X0 is the bias at TREF, which CAL_ACCn_OFF holds.
                value: if j == 0 { 0.0 } else { coefficients[j - 1] },
                kind: ParamType::Real32,
            });
        }
    }
    params
}

/// The file's comments: how PX4 applies the parameters, and what the model leaves out.
fn px4_comments(model: &ThermalModel, target: &Px4Target, left: &LeftOut) -> Vec<String> {
    let n = target.accel;
    let staircase = left.bias_slope_mps2_per_c.map(|s| s * PX4_REPUBLISH_C);
    let mut lines = vec![
        format!(
            "spincal {}: accelerometer temperature compensation for PX4 (TC_A{n}_*)",
            env!("CARGO_PKG_VERSION")
        ),
        format!(
            "Load with QGroundControl (Parameters > Tools > Load from file) on the vehicle with system id {}, then reboot; recalibrate the accelerometer after.",
            target.system_id
        ),
        format!(
            "PX4 subtracts X0 + X1 d + X2 d^2 + X3 d^3, d = clamp(T, TMIN, TMAX) - TREF, from the accelerometer whose device id is TC_A{n}_ID (sensor frame, m/s^2),"
        ),
        format!("before CAL_ACC{n}_OFF and _SCALE; its accel calibration subtracts it too, so CAL_ACC{n}_OFF becomes the bias at TREF."),
        format!(
            "TREF is spincal's T_ref and X0 = 0. PX4 updates the offset only after T moves {PX4_REPUBLISH_C} degC: up to {} m/s^2 between updates.",
            triple(staircase)
        ),
    ];
    lines.extend(left_out_lines(
        model,
        left,
        &format!("CAL_ACC{n}_OFF, CAL_ACC{n}_SCALE"),
    ));
    lines.push("  gyro: spincal's thermal model has no gyro terms; TC_G* is not written".into());
    lines
}

/// The comments, then QGroundControl's tab-separated parameter lines.
fn px4_text(lines: &[String], params: &[Param], target: &Px4Target) -> String {
    let mut text = String::new();
    for line in lines {
        let _ = writeln!(text, "# {line}");
    }
    text.push_str("#\n# Vehicle-Id Component-Id Name Value Type\n");
    for p in params {
        let _ = writeln!(
            text,
            "{}\t{}\t{}\t{}\t{}",
            target.system_id,
            target.component_id,
            p.name,
            p.value,
            p.kind.mavlink_code()
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shifted_polynomial_is_the_same_curve_less_its_constant() {
        let beta = [0.01, -2e-4, 3e-6];
        for shift in [-12.5, 0.0, 10.0, 37.0] {
            let c = shifted_polynomial(&beta, shift);
            for x in [-30.0, -1.0, 0.0, 2.5, 41.0] {
                let want = polynomial(&beta, x + shift) - polynomial(&beta, shift);
                assert!((polynomial(&c, x) - want).abs() < 1e-12, "shift {shift}, x {x}");
            }
        }
        assert_eq!(shifted_polynomial(&beta, 0.0), beta.to_vec());
    }

    #[test]
    fn derivative_matches_a_difference_quotient() {
        let beta = [0.01, -2e-4, 3e-6];
        for x in [-20.0, 0.0, 15.0] {
            let h = 1e-5;
            let numeric = (polynomial(&beta, x + h) - polynomial(&beta, x - h)) / (2.0 * h);
            assert!((derivative(&beta, x) - numeric).abs() < 1e-9);
        }
    }
}
