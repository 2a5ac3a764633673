//! What a simulated phone session is asked to be: the phone's sensors, their clocks, where it lies
//! on the platter and what is recorded.

use serde::{Deserialize, Serialize};

use crate::campaign::file::SignedAxis;
use crate::input::recording::STANDARD_GRAVITY;
use crate::simulate::SimulationError;

/// The app whose export the session is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PhoneApp {
    /// phyphox (Android): one "simple experiment" zip per recording with the accelerometer and
    /// the gyroscope (`Accelerometer.csv`, `Gyroscope.csv`, `meta/device.csv`, `meta/time.csv`).
    Phyphox,
    /// Sensor Logger (Android): one zip per recording with `TotalAcceleration.csv`,
    /// `Gyroscope.csv`, the gravity-removed `Accelerometer.csv` and `Metadata.csv`.
    SensorLogger,
}

/// One placement of the phone on the platter: the runs made without moving it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlacementSetup {
    /// The campaign's `placement` label.
    pub label: String,
    /// The phone's axis pointing away from the spindle (as the user states it).
    pub out: SignedAxis,
    /// Distance from the spindle to the phone's centre (the point a user can measure), m.
    pub centre_radius_m: f64,
}

impl Default for PlacementSetup {
    fn default() -> Self {
        PlacementSetup {
            label: "A".into(),
            out: SignedAxis { axis: 1, sign: 1 },
            centre_radius_m: 0.10,
        }
    }
}

/// A phone session: still poses and turntable runs, every recording one app export. Sensor errors
/// are drawn per seed within the stated bounds (uniformly); noise is normal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhoneSetup {
    pub unit: String,
    pub app: PhoneApp,
    /// Accelerometer sample rate, Hz (nominal: the sensor's clock is off by up to `clock_ppm`).
    pub accel_rate_hz: f64,
    /// Gyroscope sample rate, Hz, on its own clock.
    pub gyro_rate_hz: f64,
    /// Bound of each sensor clock's rate error, parts per million.
    pub clock_ppm: f64,
    /// Standard deviation of each sample's time about its clock's tick (clipped at ±3), s.
    pub jitter_s: f64,
    /// Accelerometer: full-scale range ±, g (16-bit quantisation over it).
    pub accel_range_g: f64,
    /// Accelerometer: bound of the bias per axis, m/s².
    pub accel_bias_mps2: f64,
    /// Accelerometer: bound of the scale error per axis, %.
    pub accel_scale_pct: f64,
    /// Accelerometer: bound of each misalignment angle, rad.
    pub accel_misalignment_rad: f64,
    /// Accelerometer: nonlinearity, % of full scale (a quadratic per axis within it).
    pub accel_nonlinearity_pct_fs: f64,
    /// Accelerometer white noise per sample, m/s².
    pub accel_noise_mps2: f64,
    /// Accelerometer bias wander: stationary standard deviation of an Ornstein–Uhlenbeck drift
    /// (time constant `drift_time_s`), m/s².
    pub accel_drift_mps2: f64,
    /// Gyroscope: full-scale range ±, deg/s (16-bit quantisation over it).
    pub gyro_range_dps: f64,
    /// Gyroscope: bound of the bias per axis, rad/s.
    pub gyro_bias_radps: f64,
    /// Gyroscope: bound of the scale error per axis, %.
    pub gyro_scale_pct: f64,
    /// Gyroscope: bound of each cross-axis term of K.
    pub gyro_cross_axis: f64,
    /// Gyroscope white noise per sample, rad/s.
    pub gyro_noise_radps: f64,
    /// Gyroscope bias wander (as the accelerometer's), rad/s.
    pub gyro_drift_radps: f64,
    /// Time constant of both drifts, s.
    pub drift_time_s: f64,
    /// Bound of the chip's offset from the phone's centre along the phone's x and y, m.
    pub chip_offset_m: f64,
    /// The chip's height above the phone's centre plane, m (no effect on the radius).
    pub chip_height_m: f64,
    /// The placements; each gets a run at every speed of `rpm`.
    pub placements: Vec<PlacementSetup>,
    /// Bound of how far the phone lies turned from its stated `out`, deg.
    pub yaw_deg: f64,
    /// Standard deviation of the phone's tilt on the platter (a camera bump), per axis, deg.
    pub mount_tilt_deg: f64,
    /// The nominal speeds, rpm.
    pub rpm: Vec<f64>,
    /// The platter's steady speed error, % of nominal (the same at every speed).
    pub speed_error_pct: f64,
    /// Wow: once-per-revolution speed modulation, % peak.
    pub wow_pct: f64,
    /// Flutter, % peak, at 6 Hz.
    pub flutter_pct: f64,
    /// The platter's tilt from level, deg.
    pub platter_tilt_deg: f64,
    /// Each turntable run's length, s.
    pub run_s: f64,
    /// Still poses: the six faces up, then six 45° between two faces (edges), each tilted at
    /// random by up to `pose_tilt_deg`.
    pub poses: usize,
    pub pose_tilt_deg: f64,
    /// Each still pose's length, s (one recording per pose).
    pub pose_s: f64,
    /// Time between two recordings (the drifts go on), s.
    pub gap_s: f64,
    /// When given, each run states the phone's centre as its radius with this tolerance, m;
    /// otherwise no radius is stated and the fit finds the chip's.
    pub stated_radius_tol_m: Option<f64>,
    pub gravity_mps2: f64,
}

impl Default for PhoneSetup {
    /// A phone on a record player as phyphox records it: accelerometer at 100 Hz and gyroscope at
    /// 200 Hz on their own clocks, errors of a consumer MEMS part, the chip up to 3 cm off the
    /// phone's centre, twelve still poses (six at about 45°) of 4 s, and 30-s runs at 33⅓ and 45 rpm
    /// in two placements (the phone turned 180° between them), the platter 1 % fast, no radius
    /// stated.
    fn default() -> Self {
        PhoneSetup {
            unit: "phone".into(),
            app: PhoneApp::Phyphox,
            accel_rate_hz: 100.0,
            gyro_rate_hz: 200.0,
            clock_ppm: 500.0,
            jitter_s: 0.0005,
            accel_range_g: 8.0,
            accel_bias_mps2: 0.2,
            accel_scale_pct: 2.0,
            accel_misalignment_rad: 0.01,
            accel_nonlinearity_pct_fs: 0.2,
            accel_noise_mps2: 0.02,
            accel_drift_mps2: 0.002,
            gyro_range_dps: 2000.0,
            gyro_bias_radps: 0.01,
            gyro_scale_pct: 1.0,
            gyro_cross_axis: 0.005,
            gyro_noise_radps: 0.003,
            gyro_drift_radps: 0.0002,
            drift_time_s: 300.0,
            chip_offset_m: 0.03,
            chip_height_m: 0.003,
            placements: vec![
                PlacementSetup::default(),
                PlacementSetup {
                    label: "B".into(),
                    out: SignedAxis { axis: 1, sign: -1 },
                    centre_radius_m: 0.10,
                },
            ],
            yaw_deg: 5.0,
            mount_tilt_deg: 0.5,
            rpm: vec![100.0 / 3.0, 45.0],
            speed_error_pct: 1.0,
            wow_pct: 0.1,
            flutter_pct: 0.05,
            platter_tilt_deg: 0.5,
            run_s: 30.0,
            poses: 12,
            pose_tilt_deg: 10.0,
            pose_s: 4.0,
            gap_s: 10.0,
            stated_radius_tol_m: None,
            gravity_mps2: STANDARD_GRAVITY,
        }
    }
}

impl PhoneSetup {
    /// Refuses what the simulation cannot run, naming the setting.
    pub fn check(&self) -> Result<(), SimulationError> {
        let invalid = |name, value, why| Err(SimulationError::Invalid { name, value, why });
        for (name, value) in [
            ("accel_rate_hz", self.accel_rate_hz),
            ("gyro_rate_hz", self.gyro_rate_hz),
            ("accel_range_g", self.accel_range_g),
            ("gyro_range_dps", self.gyro_range_dps),
            ("drift_time_s", self.drift_time_s),
            ("run_s", self.run_s),
            ("pose_s", self.pose_s),
            ("gravity_mps2", self.gravity_mps2),
        ] {
            if !(value > 0.0 && value.is_finite()) {
                return invalid(name, value, "must be positive");
            }
        }
        for (name, value) in [
            ("clock_ppm", self.clock_ppm),
            ("jitter_s", self.jitter_s),
            ("accel_bias_mps2", self.accel_bias_mps2),
            ("accel_scale_pct", self.accel_scale_pct),
            ("accel_misalignment_rad", self.accel_misalignment_rad),
            ("accel_nonlinearity_pct_fs", self.accel_nonlinearity_pct_fs),
            ("accel_noise_mps2", self.accel_noise_mps2),
            ("accel_drift_mps2", self.accel_drift_mps2),
            ("gyro_bias_radps", self.gyro_bias_radps),
            ("gyro_scale_pct", self.gyro_scale_pct),
            ("gyro_cross_axis", self.gyro_cross_axis),
            ("gyro_noise_radps", self.gyro_noise_radps),
            ("gyro_drift_radps", self.gyro_drift_radps),
            ("chip_offset_m", self.chip_offset_m),
            ("yaw_deg", self.yaw_deg),
            ("mount_tilt_deg", self.mount_tilt_deg),
            ("wow_pct", self.wow_pct),
            ("flutter_pct", self.flutter_pct),
            ("platter_tilt_deg", self.platter_tilt_deg),
            ("gap_s", self.gap_s),
            ("pose_tilt_deg", self.pose_tilt_deg),
        ] {
            if !(value >= 0.0 && value.is_finite()) {
                return invalid(name, value, "must be zero or positive");
            }
        }
        if !self.chip_height_m.is_finite()
            || !self.speed_error_pct.is_finite()
            || self.speed_error_pct <= -50.0
        {
            return invalid(
                "speed_error_pct",
                self.speed_error_pct,
                "chip_height_m and speed_error_pct must be finite, the speed error above −50 %",
            );
        }
        // Samples must stay in order: the jitter's ±3 sd within half the shorter period.
        let period = 1.0 / self.accel_rate_hz.max(self.gyro_rate_hz);
        if 6.0 * self.jitter_s >= period || self.clock_ppm >= 1e5 {
            return invalid(
                "jitter_s",
                self.jitter_s,
                "6 × jitter_s must be under the shorter sample period and clock_ppm under 10⁵",
            );
        }
        if self.rpm.is_empty() || self.rpm.iter().any(|r| !(*r > 0.0 && r.is_finite())) {
            return invalid(
                "rpm",
                self.rpm.first().copied().unwrap_or(0.0),
                "needs positive speeds",
            );
        }
        if self
            .placements
            .iter()
            .any(|p| !(p.centre_radius_m >= 0.0 && p.centre_radius_m.is_finite()))
        {
            return invalid("placements.centre_radius_m", 0.0, "must be zero or positive");
        }
        if self.placements.iter().any(|p| p.out.axis == 2) {
            return invalid("placements.out", 2.0, "a phone lies flat: out is ±x or ±y");
        }
        if let Some(tol) = self.stated_radius_tol_m {
            if !(tol > 0.0 && tol.is_finite()) {
                return invalid("stated_radius_tol_m", tol, "must be positive");
            }
        }
        let unsafe_label = |l: &str| {
            l.is_empty()
                || !l
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        };
        if self.placements.iter().any(|p| unsafe_label(&p.label)) {
            return invalid(
                "placements.label",
                0.0,
                "labels are letters, digits, - or _ (they name files)",
            );
        }
        if self.placements.is_empty() {
            return invalid("placements", 0.0, "needs at least one placement");
        }
        // Each run's file is named after its placement and its speed in whole rpm.
        let mut names: Vec<String> = self
            .placements
            .iter()
            .flat_map(|p| self.rpm.iter().map(move |r| format!("{}-{:.0}", p.label, r)))
            .collect();
        let runs = names.len();
        names.sort();
        names.dedup();
        if names.len() < runs {
            return invalid(
                "placements.label",
                0.0,
                "two runs would share a file: labels must differ, and speeds by at least 1 rpm",
            );
        }
        if self.poses > 60 {
            return invalid("poses", self.poses as f64, "at most 60");
        }
        Ok(())
    }
}
