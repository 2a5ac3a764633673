//! Every closed set of flag values, as clap `ValueEnum`s mapped onto the library's types. The
//! library stays free of clap; each mirror converts with `From`.

use clap::ValueEnum;
use spincal::correctors::static_cal::StaticModel;
use spincal::input::formats::Format;
use spincal::input::recording::{AccelUnit, GyroUnit, TimeUnit};
use spincal::input::table::Delimiter;
use spincal::sysid::ModelKind;
use spincal::turntable::fit::{AxesObjective, DriftMode};
use spincal::turntable::model::Direction;

/// Maps a mirror enum onto the library's, variant for variant.
macro_rules! mirror {
    ($arg:ident => $lib:ty { $($variant:ident => $target:expr),+ $(,)? }) => {
        impl From<$arg> for $lib {
            fn from(value: $arg) -> $lib {
                match value {
                    $($arg::$variant => $target),+
                }
            }
        }
    };
}

/// File formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// Delimited text with a header naming time and acceleration columns.
    Csv,
    /// imu_tk's whitespace-separated `t ax ay az` rows.
    #[value(alias = "imu-tk")]
    Whitespace,
    /// imucal's labelled CSV (raw counts).
    Imucal,
    /// MPU-6050 logger CSV (int16 counts).
    Mpu6050,
    /// phyphox's CSV export.
    Phyphox,
    /// Microstrain 3DM-GX1 binary stream.
    #[value(name = "3dm-gx1", alias = "gx1")]
    Gx1,
    /// MATLAB v5 MAT-file (numeric variables as columns).
    #[value(alias = "matlab")]
    Mat,
    /// ROS bag: ROS 2 (MCAP or sqlite3; a file or the bag directory) or ROS 1 (format 2.0).
    #[value(name = "rosbag", alias = "bag")]
    RosBag,
    /// phyphox's zip export (one CSV per sensor with meta/).
    PhyphoxZip,
    /// phyphox's Excel export (.xlsx, .xls).
    PhyphoxExcel,
    /// Sensor Logger's zip, folder or CSV.
    SensorLogger,
    /// Physics Toolbox Sensor Suite's CSV.
    PhysicsToolbox,
    /// PX4 ULog flight log (.ulg): sensor_accel + sensor_gyro, else sensor_combined.
    #[value(alias = "ulg")]
    Ulog,
    /// ArduPilot DataFlash flight log (.bin): IMU messages.
    #[value(name = "dataflash", alias = "bin")]
    DataFlash,
}
mirror!(FormatArg => Format {
    Csv => Format::Csv,
    Whitespace => Format::Whitespace,
    Imucal => Format::Imucal,
    Mpu6050 => Format::Mpu6050,
    Phyphox => Format::Phyphox,
    Gx1 => Format::Gx1,
    Mat => Format::Mat,
    RosBag => Format::RosBag,
    PhyphoxZip => Format::PhyphoxZip,
    PhyphoxExcel => Format::PhyphoxExcel,
    SensorLogger => Format::SensorLogger,
    PhysicsToolbox => Format::PhysicsToolbox,
    Ulog => Format::Ulog,
    DataFlash => Format::DataFlash,
});

/// Units of angular rate in a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GyroUnitArg {
    /// rad/s.
    Radps,
    /// Degrees per second.
    Dps,
}
mirror!(GyroUnitArg => GyroUnit { Radps => GyroUnit::Radps, Dps => GyroUnit::Dps });

/// Units of acceleration in a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AccelUnitArg {
    /// Multiples of standard gravity, 9.80665 m/s².
    G,
    /// m/s².
    Mps2,
}
mirror!(AccelUnitArg => AccelUnit { G => AccelUnit::G, Mps2 => AccelUnit::Mps2 });

/// Units of time in a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TimeUnitArg {
    S,
    Ms,
    Us,
    /// Nanoseconds (ROS stamps, Linux loggers; since the epoch is fine).
    Ns,
}
mirror!(TimeUnitArg => TimeUnit { S => TimeUnit::S, Ms => TimeUnit::Ms, Us => TimeUnit::Us, Ns => TimeUnit::Ns });

/// Field separators.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DelimiterArg {
    Comma,
    Semicolon,
    Tab,
    /// One or more spaces or tabs.
    Whitespace,
}
mirror!(DelimiterArg => Delimiter {
    Comma => Delimiter::Comma,
    Semicolon => Delimiter::Semicolon,
    Tab => Delimiter::Tab,
    Whitespace => Delimiter::Whitespace,
});

/// Axes in the turntable fit's objective (not the axes a corrector corrects).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ObjectiveAxesArg {
    Xyz,
    Xy,
    /// The paper's choice when y drifts.
    X,
}
mirror!(ObjectiveAxesArg => AxesObjective {
    Xyz => AxesObjective::Xyz,
    Xy => AxesObjective::Xy,
    X => AxesObjective::X,
});

/// Linear drift per axis in the turntable fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DriftArg {
    /// Fit drift terms and report them where significant.
    Fit,
    /// No drift terms.
    Off,
}
mirror!(DriftArg => DriftMode { Fit => DriftMode::Fit, Off => DriftMode::Off });

/// Sense of rotation seen from above.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DirectionArg {
    /// Clockwise, as record players turn.
    Cw,
    /// Counter-clockwise.
    Ccw,
}
mirror!(DirectionArg => Direction { Cw => Direction::Cw, Ccw => Direction::Ccw });

/// The network architecture search of a calibration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SweepArg {
    /// No search: train the architecture given by --hidden.
    None,
    /// One layer of 1–8 units; two layers of 2–8 × 2–6 (even).
    Small,
    /// The paper's grid: 1–15, and 1–15 × 1–10.
    Full,
}

/// Static calibration models, by their number of parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StaticModelArg {
    /// Bias and scale per axis.
    #[value(name = "6")]
    BiasScale,
    /// Bias, scale and misalignment (imu_tk's model).
    #[value(name = "9")]
    Misalignment,
    /// Bias, scale, misalignment and a quadratic nonlinearity per axis.
    #[value(name = "12")]
    Nonlinear,
}
mirror!(StaticModelArg => StaticModel {
    BiasScale => StaticModel::BiasScale,
    Misalignment => StaticModel::Misalignment,
    Nonlinear => StaticModel::Nonlinear,
});

/// System-identification model structures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SysidModelArg {
    /// ARX [na nb nk], least squares.
    Arx,
    /// Output error [nb nf nk].
    Oe,
    /// ARMAX [na nb nc nk].
    Armax,
    /// Box–Jenkins [nb nc nd nf nk].
    Bj,
    /// Nonlinear ARX with sigmoid units [na nb nk].
    Narx,
    /// Hammerstein–Wiener [nb nf nk].
    Hw,
}
mirror!(SysidModelArg => ModelKind {
    Arx => ModelKind::Arx,
    Oe => ModelKind::Oe,
    Armax => ModelKind::Armax,
    Bj => ModelKind::Bj,
    Narx => ModelKind::Narx,
    Hw => ModelKind::Hw,
});

/// A finite number that `accept` allows; `expected` says what that is, for the message.
fn number(text: &str, accept: fn(f64) -> bool, expected: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && accept(v) => Ok(v),
        Ok(v) => Err(format!("{v} is not allowed here: expected {expected}")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// A finite number greater than zero (a rate, a length, a speed, gravity).
pub fn positive(text: &str) -> Result<f64, String> {
    number(text, |v| v > 0.0, "a finite number greater than 0")
}

/// A finite number, zero or more (a noise level, a percentage of error).
pub fn non_negative(text: &str) -> Result<f64, String> {
    number(text, |v| v >= 0.0, "a finite number, 0 or more")
}

/// Any finite number (an angle, an offset).
pub fn finite(text: &str) -> Result<f64, String> {
    number(text, |_| true, "a finite number")
}

/// A settings file (`--setup`, `--sensor`) read as JSON; errors name the file and what it should
/// have been (`sim.json: not a campaign setup`).
pub fn read_json_file<T: serde::de::DeserializeOwned>(
    path: &std::path::Path,
    what: &str,
) -> anyhow::Result<T> {
    use anyhow::Context;
    let text = spincal::input::limits::read_settings_text(path)
        .with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str::<T>(&text).with_context(|| format!("{}: not {what}", path.display()))
}

/// [`read_json_file`] when a file is named, else the default.
pub fn read_json_or_default<T: serde::de::DeserializeOwned + Default>(
    path: Option<&std::path::Path>,
    what: &str,
) -> anyhow::Result<T> {
    path.map_or_else(|| Ok(T::default()), |path| read_json_file(path, what))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_flags_are_checked_for_range() {
        assert_eq!(positive("0.1"), Ok(0.1));
        assert!(positive("0").unwrap_err().contains("greater than 0"));
        assert!(positive("-0.1").is_err());
        assert!(positive("nan").unwrap_err().contains("finite"));
        assert!(positive("inf").is_err());
        assert!(positive("ten").unwrap_err().contains("not a number"));
        assert_eq!(non_negative("0"), Ok(0.0));
        assert!(non_negative("-1").is_err());
        assert_eq!(finite("-3"), Ok(-3.0));
        assert!(finite("NaN").is_err());
    }
}
