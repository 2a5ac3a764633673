//! What a simulated campaign is asked to be: its runs, the gyroscope and the whole campaign.

use serde::{Deserialize, Serialize};

use crate::campaign::file::SignedAxis;
use crate::correctors::gyro::GyroModel;
use crate::geometry::M3;
use crate::input::recording::STANDARD_GRAVITY;
use crate::simulate::SensorProfile;
use crate::turntable::model::Direction;

/// One turntable run of a simulated campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunSetup {
    pub rpm: f64,
    pub radius_m: f64,
    /// The ruler's tolerance written to the campaign file; the true radius is drawn within it.
    pub radius_tol_m: f64,
    pub out: SignedAxis,
    pub up: SignedAxis,
    pub direction: Direction,
    pub tilt_deg: f64,
    /// Steady speed error, % of nominal.
    pub speed_error_pct: f64,
    /// Once-per-revolution speed modulation, % peak.
    pub wow_pct: f64,
    pub flutter_pct: f64,
    pub flutter_hz: f64,
    /// Standard deviation of the sensor's tilt on its mount, deg.
    pub mount_tilt_deg: f64,
    pub duration_s: f64,
}

impl Default for RunSetup {
    fn default() -> Self {
        RunSetup {
            rpm: 100.0 / 3.0,
            radius_m: 0.10,
            radius_tol_m: 0.002,
            out: SignedAxis { axis: 0, sign: 1 },
            up: SignedAxis { axis: 2, sign: 1 },
            direction: Direction::Cw,
            tilt_deg: 2.0,
            speed_error_pct: 0.5,
            wow_pct: 0.1,
            flutter_pct: 0.05,
            flutter_hz: 6.0,
            mount_tilt_deg: 0.5,
            duration_s: 60.0,
        }
    }
}

/// The gyroscope: m = b + K ω + drift + noise, K = diag(1 + s)(I + M₆) in the accelerometer's
/// body frame (the frame the joint fit defines), ω the true angular rate, rad/s. The Earth's rotation
/// (≤ 7.3·10⁻⁵ rad/s) is left out: a still pose reads the bias alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GyroProfile {
    /// Whether the unit records a gyroscope at all.
    pub recorded: bool,
    /// Constant bias per axis, deg/s.
    pub bias_dps: [f64; 3],
    /// Scale-factor error per axis, %.
    pub scale_error_pct: [f64; 3],
    /// Cross-axis sensitivity (small angles), deg: x to y and z, y to x and z, z to x and y.
    pub misalignment_deg: [f64; 6],
    /// White noise, deg/s RMS per sample.
    pub noise_dps: f64,
    /// Bound of the slow bias drift (Ornstein–Uhlenbeck clipped to ±this, the accelerometer's
    /// correlation time), deg/s.
    pub bias_drift_dps: f64,
    /// Full-scale range ±, deg/s; 16-bit quantisation over it.
    pub range_dps: f64,
}

impl Default for GyroProfile {
    /// A consumer MEMS gyroscope (MPU-6050 class) at ±500 °/s.
    fn default() -> Self {
        GyroProfile {
            recorded: true,
            bias_dps: [0.8, -0.5, 0.3],
            scale_error_pct: [0.5, -0.8, 0.6],
            misalignment_deg: [0.4, -0.3, 0.5, 0.2, -0.4, 0.3],
            noise_dps: 0.05,
            bias_drift_dps: 0.02,
            range_dps: 500.0,
        }
    }
}

impl GyroProfile {
    /// K = diag(1 + s)(I + M₆), the reading per unit of true rate.
    pub fn sensitivity(&self) -> M3 {
        let m = self.misalignment_deg.map(f64::to_radians);
        let s = self.scale_error_pct.map(|p| 1.0 + p / 100.0);
        [
            [s[0], s[0] * m[0], s[0] * m[1]],
            [s[1] * m[2], s[1], s[1] * m[3]],
            [s[2] * m[4], s[2] * m[5], s[2]],
        ]
    }

    /// The profile as the calibration's model (bias in rad/s).
    pub fn model(&self) -> GyroModel {
        GyroModel {
            bias_radps: self.bias_dps.map(f64::to_radians),
            sensitivity: self.sensitivity(),
            input_unit: crate::correctors::gyro::GyroInputUnit::RadPerS,
        }
    }
}

/// A campaign: still poses, then turntable runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CampaignSetup {
    pub unit: String,
    pub sensor: SensorProfile,
    pub gyro: GyroProfile,
    /// Still poses, in one recording: the six faces up in turn (then six edges, 45° between two
    /// axes), each tilted at random by up to `pose_tilt_deg`, held `pose_duration_s`, turned from
    /// one to the next in 2 s.
    pub poses: usize,
    pub pose_tilt_deg: f64,
    pub pose_duration_s: f64,
    pub runs: Vec<RunSetup>,
    /// Time between recordings (the bias drift goes on), s.
    pub gap_s: f64,
    pub gravity_mps2: f64,
}

impl Default for CampaignSetup {
    /// One unit: twelve still poses (six faces, six edges) and turntable runs at 33⅓ and 45 rpm at
    /// two radii in three mountings (z up twice; on its side with x up, with y up), so that each
    /// gyro axis is along the spindle once, and holding out a speed or a radius leaves two
    /// mountings.
    fn default() -> Self {
        let axis = |t: &str| SignedAxis::parse(t).unwrap_or(SignedAxis { axis: 0, sign: 1 });
        let run = |rpm: f64, radius_m: f64, out: &str, up: &str| RunSetup {
            rpm,
            radius_m,
            out: axis(out),
            up: axis(up),
            ..RunSetup::default()
        };
        CampaignSetup {
            unit: "simulated-unit".into(),
            sensor: SensorProfile::default(),
            gyro: GyroProfile::default(),
            poses: 12,
            pose_tilt_deg: 25.0,
            pose_duration_s: 5.0,
            runs: vec![
                run(100.0 / 3.0, 0.06, "+x", "+z"),
                run(100.0 / 3.0, 0.12, "+z", "+x"),
                run(45.0, 0.06, "-z", "+y"),
                run(45.0, 0.12, "+y", "+z"),
            ],
            gap_s: 20.0,
            gravity_mps2: STANDARD_GRAVITY,
        }
    }
}
