//! Units of the values in a file (acceleration, time, angular rate, temperature) and their
//! factors to SI.

use serde::{Deserialize, Serialize};

/// Standard gravity, m/s² (the default local g).
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// Unit of acceleration values in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AccelUnit {
    /// Metres per second squared.
    Mps2,
    /// Multiples of standard gravity (9.80665 m/s²).
    G,
}

impl AccelUnit {
    pub fn to_si(self) -> f64 {
        match self {
            AccelUnit::Mps2 => 1.0,
            AccelUnit::G => STANDARD_GRAVITY,
        }
    }
    pub fn parse(text: &str) -> Option<AccelUnit> {
        match text.to_ascii_lowercase().as_str() {
            "g" => Some(AccelUnit::G),
            "mps2" | "m/s2" | "m/s^2" | "m/s²" | "si" => Some(AccelUnit::Mps2),
            _ => None,
        }
    }
    pub fn suffix(self) -> &'static str {
        match self {
            AccelUnit::Mps2 => "mps2",
            AccelUnit::G => "g",
        }
    }
}

/// Unit of time values in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeUnit {
    S,
    Ms,
    Us,
    /// Nanoseconds: ROS stamps and Linux loggers, often since the epoch (an f64 holds such a stamp
    /// to about 0.25 µs).
    Ns,
}

impl TimeUnit {
    pub fn to_si(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
            TimeUnit::Ns => 1e-9,
        }
    }
    pub fn parse(text: &str) -> Option<TimeUnit> {
        match text.to_ascii_lowercase().as_str() {
            "s" => Some(TimeUnit::S),
            "ms" => Some(TimeUnit::Ms),
            "us" | "µs" => Some(TimeUnit::Us),
            "ns" => Some(TimeUnit::Ns),
            _ => None,
        }
    }
}

/// Unit of angular-rate values in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GyroUnit {
    Radps,
    Dps,
}

impl GyroUnit {
    pub fn to_si(self) -> f64 {
        match self {
            GyroUnit::Radps => 1.0,
            GyroUnit::Dps => std::f64::consts::PI / 180.0,
        }
    }
    /// The unit as a column-name suffix (`gx_dps`).
    pub fn suffix(self) -> &'static str {
        match self {
            GyroUnit::Radps => "radps",
            GyroUnit::Dps => "dps",
        }
    }
    pub fn parse(text: &str) -> Option<GyroUnit> {
        match text.to_ascii_lowercase().as_str() {
            "radps" | "rad/s" => Some(GyroUnit::Radps),
            "dps" | "deg/s" => Some(GyroUnit::Dps),
            _ => None,
        }
    }
}

/// Unit of a temperature column in a file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TemperatureUnit {
    /// Degrees Celsius.
    C,
    /// Kelvin.
    K,
    /// Degrees Fahrenheit.
    F,
    /// The MPU-6000/6050 family's TEMP_OUT register, raw counts: °C = counts / 340 + 36.53
    /// (InvenSense MPU-6000/MPU-6050 Register Map, rev. 4.2, register 65–66).
    Mpu6050Counts,
}

impl TemperatureUnit {
    /// The value in °C.
    pub fn to_celsius(self, value: f64) -> f64 {
        match self {
            TemperatureUnit::C => value,
            TemperatureUnit::K => value - 273.15,
            TemperatureUnit::F => (value - 32.0) * 5.0 / 9.0,
            TemperatureUnit::Mpu6050Counts => value / 340.0 + 36.53,
        }
    }
    /// The value in this unit of `celsius` °C (the inverse of [`TemperatureUnit::to_celsius`]).
    pub fn from_celsius(self, celsius: f64) -> f64 {
        match self {
            TemperatureUnit::C => celsius,
            TemperatureUnit::K => celsius + 273.15,
            TemperatureUnit::F => celsius * 9.0 / 5.0 + 32.0,
            TemperatureUnit::Mpu6050Counts => (celsius - 36.53) * 340.0,
        }
    }

    /// Its name for people (`kelvin`, `°F`).
    pub fn describe(self) -> &'static str {
        match self {
            TemperatureUnit::C => "°C",
            TemperatureUnit::K => "kelvin",
            TemperatureUnit::F => "°F",
            TemperatureUnit::Mpu6050Counts => "MPU-6050 counts",
        }
    }

    /// Its name as [`TemperatureUnit::parse`] reads it (and as serde writes it).
    pub fn name(self) -> &'static str {
        match self {
            TemperatureUnit::C => "c",
            TemperatureUnit::K => "k",
            TemperatureUnit::F => "f",
            TemperatureUnit::Mpu6050Counts => "mpu6050counts",
        }
    }
    pub fn parse(text: &str) -> Option<TemperatureUnit> {
        match text.to_ascii_lowercase().as_str() {
            "c" | "degc" | "°c" | "celsius" => Some(TemperatureUnit::C),
            "k" | "kelvin" => Some(TemperatureUnit::K),
            "f" | "degf" | "°f" => Some(TemperatureUnit::F),
            "mpu6050" | "mpu6050counts" | "counts" => Some(TemperatureUnit::Mpu6050Counts),
            _ => None,
        }
    }
}
