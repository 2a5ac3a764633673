//! A unit whose bias and gain follow its die temperature, recorded through warm-ups from a cold
//! start, with a temperature sensor that lags the die and reports whole degrees.
//!
//! The die warms as T(t) = T₀ + A(1 − e^(−t/τ_w)) from power-on, with A such that it rises
//! `warmup_c` over the session; the sensor reports T through a first-order lag `sensor_lag_s`,
//! rounded to `resolution_c`. The reading follows [`crate::thermal::ThermalModel`] exactly, plus
//! white noise. Three sessions, each from a cold start:
//! - **warm-up**: one still recording, z up (tilted a little), through the whole warm-up;
//! - **poses**: still poses near the six axis-up orientations in turn, `pose_s` each, through a
//!   second warm-up;
//! - **held out**: still poses in random orientations through a third warm-up: the conditions a
//!   corrector is judged on, never fitted.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use std::path::{Path, PathBuf};

use crate::geometry::unit;
use crate::input::recording::{AccelUnit, Recording, Source, STANDARD_GRAVITY};
use crate::simulate::fleet::{create_folder_for, WriteError};
use crate::simulate::{check, SimulationError};
use crate::thermal::ThermalModel;

/// The thermal world's ranges, datasheet-like (standard deviations of zero-mean draws).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ThermalProfile {
    /// Bias at the reference temperature, g.
    pub bias_g: f64,
    /// Scale error at the reference temperature, %.
    pub scale_error_pct: f64,
    /// Misalignment angles, degrees.
    pub misalignment_deg: f64,
    /// Bias's first-order temperature coefficient, g/°C.
    pub bias_per_c_g: f64,
    /// Bias's second-order coefficient, g/°C².
    pub bias_per_c2_g: f64,
    /// Gain's first-order temperature coefficient, %/°C.
    pub scale_per_c_pct: f64,
    /// Gain's second-order coefficient, %/°C².
    pub scale_per_c2_pct: f64,
    /// White noise, m/s² per sample.
    pub noise_mps2: f64,
    pub sample_rate_hz: f64,
    /// Die temperature at power-on, °C.
    pub start_c: f64,
    /// Rise of the die temperature over each session, °C.
    pub warmup_c: f64,
    /// Time constant of the warm-up, s.
    pub warmup_time_s: f64,
    /// Length of each session, s.
    pub session_s: f64,
    /// First-order lag of the temperature sensor behind the die, s.
    pub sensor_lag_s: f64,
    /// Resolution of the reported temperature, °C (0: exact).
    pub resolution_c: f64,
    /// Length of each still pose, s (a further 10 s between poses is not recorded).
    pub pose_s: f64,
}

impl Default for ThermalProfile {
    fn default() -> Self {
        ThermalProfile {
            bias_g: 0.008,
            scale_error_pct: 0.5,
            misalignment_deg: 0.4,
            bias_per_c_g: 1e-3,
            bias_per_c2_g: 2e-5,
            scale_per_c_pct: 0.02,
            scale_per_c2_pct: 4e-4,
            noise_mps2: 0.02,
            sample_rate_hz: 50.0,
            start_c: 15.0,
            warmup_c: 25.0,
            warmup_time_s: 900.0,
            session_s: 2400.0,
            sensor_lag_s: 20.0,
            resolution_c: 1.0,
            pose_s: 30.0,
        }
    }
}

impl ThermalProfile {
    /// Every setting finite and in its range; the error names the setting.
    pub fn check(&self) -> Result<(), SimulationError> {
        let spreads = [
            ("bias_g", self.bias_g),
            ("scale_error_pct", self.scale_error_pct),
            ("misalignment_deg", self.misalignment_deg),
            ("bias_per_c_g", self.bias_per_c_g),
            ("bias_per_c2_g", self.bias_per_c2_g),
            ("scale_per_c_pct", self.scale_per_c_pct),
            ("scale_per_c2_pct", self.scale_per_c2_pct),
            ("noise_mps2", self.noise_mps2),
            ("sensor_lag_s", self.sensor_lag_s),
            ("resolution_c", self.resolution_c),
        ];
        for (name, value) in spreads {
            check(name, value, value >= 0.0, "must not be negative")?;
        }
        check("start_c", self.start_c, true, "must be finite")?;
        check("warmup_c", self.warmup_c, true, "must be finite")?;
        for (name, value) in [
            ("sample_rate_hz", self.sample_rate_hz),
            ("warmup_time_s", self.warmup_time_s),
            ("pose_s", self.pose_s),
        ] {
            check(name, value, value > 0.0, "must be positive")?;
        }
        check(
            "session_s",
            self.session_s,
            self.session_s >= self.pose_s + 10.0 && self.session_s * self.sample_rate_hz <= 1e8,
            "must hold one pose (pose_s + 10 s) and at most 10⁸ samples",
        )
    }
}

/// One simulated still recording with its truth.
#[derive(Debug, Clone)]
pub struct ThermalRecording {
    /// As a logger would write it: time, readings, the reported temperature.
    pub recording: Recording,
    /// The true specific force, m/s² (constant: the recording is still).
    pub true_force_mps2: [f64; 3],
    /// The true die temperature per sample, °C.
    pub die_c: Vec<f64>,
}

/// A simulated thermal campaign: the true model and the three sessions' recordings.
#[derive(Debug, Clone)]
pub struct ThermalCampaign {
    /// The unit's true thermal model (lag and reference as simulated).
    pub truth: ThermalModel,
    pub warmup: ThermalRecording,
    pub poses: Vec<ThermalRecording>,
    pub held_out: Vec<ThermalRecording>,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// The session's die temperature and the sensor's report of it, per sample.
fn temperatures(profile: &ThermalProfile, n: usize) -> (Vec<f64>, Vec<f64>) {
    let dt = 1.0 / profile.sample_rate_hz;
    let amplitude = profile.warmup_c / (1.0 - (-profile.session_s / profile.warmup_time_s).exp());
    let die: Vec<f64> = (0..n)
        .map(|i| profile.start_c + amplitude * (1.0 - (-(i as f64) * dt / profile.warmup_time_s).exp()))
        .collect();
    let reported = sensor_reports(&die, dt, profile.sensor_lag_s, profile.resolution_c);
    (die, reported)
}

/// What a temperature sensor reports of the die temperatures `die_c`, one every `dt_s`: a
/// first-order lag of `lag_s` (exact over each sample), rounded to `resolution_c` (0: not rounded).
pub fn sensor_reports(die_c: &[f64], dt_s: f64, lag_s: f64, resolution_c: f64) -> Vec<f64> {
    let keep = if lag_s > 0.0 { (-dt_s / lag_s).exp() } else { 0.0 };
    let mut lagged = die_c.first().copied().unwrap_or_default();
    die_c
        .iter()
        .map(|&t| {
            lagged = keep * lagged + (1.0 - keep) * t;
            if resolution_c > 0.0 {
                (lagged / resolution_c).round() * resolution_c
            } else {
                lagged
            }
        })
        .collect()
}

/// Still recordings cut from one session: `direction(k)` for the k-th, `pose_s` each with 10 s
/// unrecorded between; or one recording of the whole session when `pose_s` is `None`.
fn session(
    truth: &ThermalModel,
    profile: &ThermalProfile,
    name: &str,
    pose_s: Option<f64>,
    rng: &mut ChaCha8Rng,
    mut direction: impl FnMut(usize, &mut ChaCha8Rng) -> [f64; 3],
) -> Vec<ThermalRecording> {
    let n = (profile.session_s * profile.sample_rate_hz) as usize;
    let (die, reported) = temperatures(profile, n);
    let (length, gap) = match pose_s {
        Some(pose) => (
            (pose * profile.sample_rate_hz) as usize,
            (10.0 * profile.sample_rate_hz) as usize,
        ),
        None => (n, 0),
    };
    let mut out = Vec::new();
    let mut start = 0;
    while start + length <= n {
        let k = out.len();
        let force = unit(direction(k, rng)).map(|x| x * STANDARD_GRAVITY);
        let range = start..start + length;
        let mut accel: [Vec<f64>; 3] = Default::default();
        for i in range.clone() {
            let m = truth.reading(force, die[i]);
            for a in 0..3 {
                accel[a].push(m[a] + profile.noise_mps2 * normal(rng));
            }
        }
        out.push(ThermalRecording {
            recording: Recording {
                time_s: range.clone().map(|i| i as f64 / profile.sample_rate_hz).collect(),
                accel_mps2: accel,
                gyro_radps: None,
                temperature_c: Some(reported[range.clone()].to_vec()),
                source: Source {
                    name: format!("{name}-{k:02}.csv"),
                    format: "simulated".into(),
                    ..Default::default()
                },
            },
            true_force_mps2: force,
            die_c: die[range].to_vec(),
        });
        start += length + gap;
    }
    out
}

/// A unit drawn from `profile` and its three sessions, all from one seed.
pub fn simulate_thermal_campaign(profile: &ThermalProfile, seed: u64) -> ThermalCampaign {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let g = STANDARD_GRAVITY;
    let draw3 = |sd: f64, rng: &mut ChaCha8Rng| -> [f64; 3] { std::array::from_fn(|_| sd * normal(rng)) };
    let truth = ThermalModel {
        reference_c: profile.start_c + profile.warmup_c / 2.0,
        bias_mps2: draw3(profile.bias_g * g, &mut rng),
        scale_error: draw3(profile.scale_error_pct / 100.0, &mut rng),
        misalignment_rad: draw3(profile.misalignment_deg.to_radians(), &mut rng),
        bias_per_c: std::array::from_fn(|_| {
            vec![
                profile.bias_per_c_g * g * normal(&mut rng),
                profile.bias_per_c2_g * g * normal(&mut rng),
            ]
        }),
        scale_per_c: std::array::from_fn(|_| {
            vec![
                profile.scale_per_c_pct / 100.0 * normal(&mut rng),
                profile.scale_per_c2_pct / 100.0 * normal(&mut rng),
            ]
        }),
        lag_s: profile.sensor_lag_s,
        smoothing_s: 0.0,
        fitted_range_c: [profile.start_c, profile.start_c + profile.warmup_c],
        uncertainty: None,
    };
    let tilt = draw3(0.05, &mut rng);
    let warmup = session(&truth, profile, "warmup", None, &mut rng, |_, _| {
        [tilt[0], tilt[1], 1.0]
    })
    .remove(0);
    let axes: [[f64; 3]; 6] = [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
        [-1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
    ];
    let poses = session(
        &truth,
        profile,
        "pose",
        Some(profile.pose_s),
        &mut rng,
        |k, rng| {
            let a = axes[k % 6];
            std::array::from_fn(|i| a[i] + 0.1 * normal(rng))
        },
    );
    let held_out = session(&truth, profile, "held-out", Some(20.0), &mut rng, |_, rng| {
        std::array::from_fn(|_| normal(rng))
    });
    ThermalCampaign {
        truth,
        warmup,
        poses,
        held_out,
    }
}

/// What `truth.json` of a simulated thermal campaign holds.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThermalTruth {
    pub seed: u64,
    pub profile: ThermalProfile,
    /// The unit's true thermal model (reference temperature, lag of its temperature sensor).
    pub model: ThermalModel,
    /// Each recording's file and its true specific force, m/s².
    pub recordings: Vec<(String, [f64; 3])>,
}

impl ThermalCampaign {
    fn all(&self) -> impl Iterator<Item = &ThermalRecording> {
        std::iter::once(&self.warmup)
            .chain(&self.poses)
            .chain(&self.held_out)
    }

    /// The files [`ThermalCampaign::write_folder`] writes into `dir`.
    pub fn folder_files(&self, dir: &Path) -> Vec<PathBuf> {
        let mut files = vec![dir.join("truth.json"), dir.join("campaign.toml")];
        for r in self.all() {
            let name = &r.recording.source.name;
            files.push(dir.join(name));
            files.push(dir.join(name.replace(".csv", ".truth.csv")));
        }
        files
    }

    /// Writes each recording (`t_s, ax_mps2, ay_mps2, az_mps2, temp_c`: the temperature as the
    /// sensor reported it), its truth (`<name>.truth.csv`: the true specific force and, as
    /// `temp_c`, the true die temperature) and truth.json into `dir`. Refuses to replace a file.
    pub fn write_folder(&self, dir: &Path, seed: u64, profile: &ThermalProfile) -> Result<(), WriteError> {
        create_folder_for(dir, &self.folder_files(dir))?;
        for r in self.all() {
            let name = &r.recording.source.name;
            r.recording.write_csv_path(&dir.join(name), AccelUnit::Mps2)?;
            let truth = Recording {
                accel_mps2: std::array::from_fn(|k| vec![r.true_force_mps2[k]; r.recording.len()]),
                temperature_c: Some(r.die_c.clone()),
                ..r.recording.clone()
            };
            truth.write_csv_path(&dir.join(name.replace(".csv", ".truth.csv")), AccelUnit::Mps2)?;
        }
        let truth = ThermalTruth {
            seed,
            profile: profile.clone(),
            model: self.truth.clone(),
            recordings: self
                .all()
                .map(|r| (r.recording.source.name.clone(), r.true_force_mps2))
                .collect(),
        };
        let text = serde_json::to_string_pretty(&truth).expect("the truth serialises") + "\n";
        crate::output::write_bytes(&dir.join("truth.json"), text.as_bytes())?;
        crate::output::write_bytes(&dir.join("campaign.toml"), self.campaign_toml().as_bytes())?;
        Ok(())
    }

    /// The campaign a user would calibrate: the warm-up and the posed session as still entries
    /// (no truth keys: the held-out session is left for `correct`).
    pub fn campaign_toml(&self) -> String {
        let mut text = String::from(
            "# The thermal campaign: a still warm-up and still poses through a second warm-up, each\n# logging its temperature (temp_c). Calibrate with `spincal calibrate --campaign`; the\n# held-out-*.csv files are for `spincal correct`.\nunit = \"thermal-unit\"\n",
        );
        for r in std::iter::once(&self.warmup).chain(&self.poses) {
            text.push_str(&format!(
                "\n[[recording]]\nfile = \"{}\"\nkind = \"static\"\n",
                r.recording.source.name
            ));
        }
        text
    }
}
