//! A 3DM-GX1-like accelerometer on a record player, with known truth (SPEC §5).
//!
//! The platter turns at ω(t) = ω₀(1 + e)(1 + wow + flutter); the true specific force follows the
//! turntable model of [`crate::turntable::model`] with ω(t) in place of ω, plus the tangential
//! acceleration r·ω̇ of wow and flutter. The sensor then applies, in order: misalignment and scale
//! errors, bias with a slow bounded drift, nonlinearity, white noise, saturation at its range and
//! quantisation. Every random draw comes from one `ChaCha8Rng` seeded by the caller.

pub mod campaign;
pub mod fleet;
pub mod gyro_poses;
#[cfg(feature = "phone")]
pub mod phone;
pub mod thermal;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::input::recording::{Recording, Source, STANDARD_GRAVITY};
use crate::turntable::model::{Direction, Mounting, Session};

const G: f64 = STANDARD_GRAVITY;

/// The accelerometer. Defaults follow the 3DM-GX1 datasheet (SPEC §5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorProfile {
    /// Full-scale range ±, g.
    pub range_g: f64,
    /// A/D resolution, bits over the full ±range.
    pub bits: u32,
    /// Maximum deviation from a straight line, % of full scale (a quadratic term per axis).
    pub nonlinearity_pct_fs: f64,
    /// Constant bias per axis, g.
    pub bias_g: [f64; 3],
    /// Bound of the slow bias drift (an Ornstein–Uhlenbeck process clipped to ±this), g.
    pub bias_drift_g: f64,
    /// Correlation time of the bias drift, s.
    pub bias_drift_time_s: f64,
    /// Scale-factor error per axis, %.
    pub scale_error_pct: [f64; 3],
    /// Misalignment (small angles), deg: sensitivity of x to y and z, y to x and z, z to x and y.
    pub misalignment_deg: [f64; 6],
    /// White noise, g RMS per sample.
    pub noise_g: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
}

impl Default for SensorProfile {
    fn default() -> Self {
        SensorProfile {
            range_g: 5.0,
            bits: 16,
            nonlinearity_pct_fs: 0.2,
            bias_g: [0.004, -0.006, 0.008],
            bias_drift_g: 0.01,
            bias_drift_time_s: 300.0,
            scale_error_pct: [0.4, -0.6, 0.3],
            misalignment_deg: [0.5, -0.3, 0.4, 0.2, -0.6, 0.3],
            noise_g: 0.002,
            sample_rate_hz: 100.0,
        }
    }
}

impl SensorProfile {
    /// A simulator sensor profile that imitates the measured noise: the 3DM-GX1 defaults with the white
    /// noise, the bias drift and the sample rate replaced. White noise of density N gives a per-sample
    /// standard deviation N·√fs (σ(τ) = N/√τ at τ = 1/fs); the simulator's bounded drift process gets a
    /// standard deviation equal to the bias instability (its bound is three of them). The simulator has one
    /// noise level for all axes: the mean over the axes is used.
    pub fn from_noise(params: &crate::allan::NoiseParams, sample_rate_hz: f64) -> SensorProfile {
        let g = crate::input::recording::STANDARD_GRAVITY;
        let mean = |v: &[f64; 3]| (v[0] + v[1] + v[2]) / 3.0;
        SensorProfile {
            noise_g: mean(&params.noise_density) * sample_rate_hz.sqrt() / g,
            bias_drift_g: 3.0 * mean(&params.bias_instability) / g,
            sample_rate_hz,
            ..SensorProfile::default()
        }
    }

    /// A perfect sensor apart from bias, white noise and quantisation: the turntable model is then
    /// exact, which is what parameter-recovery tests need.
    pub fn ideal() -> SensorProfile {
        SensorProfile {
            nonlinearity_pct_fs: 0.0,
            bias_drift_g: 0.0,
            scale_error_pct: [0.0; 3],
            misalignment_deg: [0.0; 6],
            ..SensorProfile::default()
        }
    }
}

/// The turntable run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TurntableSetup {
    /// Sensor distance from the spindle, m.
    pub radius_m: f64,
    /// Nominal speed, rpm.
    pub rpm: f64,
    /// Platter tilt, deg.
    pub tilt_deg: f64,
    /// Platter angle (downhill direction relative to the sensor) at the first sample, deg.
    pub tilt_azimuth_deg: f64,
    /// Sensor x axis from the radial direction, deg.
    pub beta_deg: f64,
    pub direction: Direction,
    /// Steady speed error, % of nominal.
    pub speed_error_pct: f64,
    /// Wow: speed modulation, % peak, at `wow_hz` (once per revolution when 0).
    pub wow_pct: f64,
    pub wow_hz: f64,
    /// Flutter: speed modulation, % peak, at `flutter_hz`.
    pub flutter_pct: f64,
    pub flutter_hz: f64,
    /// Recording length, s.
    pub duration_s: f64,
    /// Local gravity, m/s².
    pub gravity_mps2: f64,
}

impl Default for TurntableSetup {
    /// A record player at 33⅓ rpm, sensor 10 cm out, 1° tilt, running 0.5 % fast, 60 s.
    fn default() -> Self {
        TurntableSetup {
            radius_m: 0.10,
            rpm: 100.0 / 3.0,
            tilt_deg: 1.0,
            tilt_azimuth_deg: 30.0,
            beta_deg: 3.0,
            direction: Direction::Cw,
            speed_error_pct: 0.5,
            wow_pct: 0.1,
            wow_hz: 0.0,
            flutter_pct: 0.05,
            flutter_hz: 6.0,
            duration_s: 60.0,
            gravity_mps2: G,
        }
    }
}

/// Everything the simulator was told and what the turntable model should recover.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    pub seed: u64,
    pub sensor: SensorProfile,
    pub turntable: TurntableSetup,
    /// The model parameters that describe this run exactly for an ideal sensor (mean speed,
    /// constant bias as offsets); with sensor errors they are the nearest model values.
    pub session: Session,
    pub mounting: Mounting,
    /// Samples clipped at the sensor's range.
    pub saturated_samples: usize,
}

/// The truth sidecar of a simulated recording as JSON: the truth's fields, `spincal_version`, and
/// `recording` naming the recording file it goes with (name, length and hash, see
/// `fingerprint`), by which a later run recognises both files as spincal's.
pub fn truth_json(truth: &Truth, recording: &std::path::Path) -> std::io::Result<String> {
    let mut value = serde_json::to_value(truth).map_err(std::io::Error::other)?;
    let fingerprint = crate::output::fingerprint(recording)?;
    if let serde_json::Value::Object(map) = &mut value {
        map.insert("spincal_version".into(), env!("CARGO_PKG_VERSION").into());
        map.insert(
            "recording".into(),
            serde_json::json!({
                "file": recording.file_name().map(|n| n.to_string_lossy().into_owned()),
                "bytes": fingerprint.bytes,
                "fnv1a64": fingerprint.fnv1a64,
            }),
        );
    }
    Ok(serde_json::to_string_pretty(&value).map_err(std::io::Error::other)? + "\n")
}

/// A simulated recording and its truth.
#[derive(Debug, Clone)]
pub struct Simulation {
    pub recording: Recording,
    pub truth: Truth,
    /// Noise-free true specific force per axis, m/s² (the ideal reference).
    pub true_accel_mps2: [Vec<f64>; 3],
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimulationError {
    #[error("simulation setting {name} = {value} is invalid: {why}")]
    Invalid {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
}

fn check(name: &'static str, value: f64, ok: bool, why: &'static str) -> Result<(), SimulationError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(SimulationError::Invalid { name, value, why })
    }
}

/// The platter's rate, angle (`angle0` at t = 0) and angular acceleration at `t` when its speed is
/// ω(t) = ω (1 + Σ m sin(2πft + p)) over `modulations` of (m, f, p); the angle is ω(t)'s exact
/// integral.
pub(crate) fn modulated_rotation(
    omega: f64,
    modulations: &[(f64, f64, f64)],
    t: f64,
    angle0: f64,
) -> (f64, f64, f64) {
    let (mut rate, mut angle, mut rate_dot) = (omega, omega * t + angle0, 0.0);
    for &(m, f, p) in modulations {
        if m == 0.0 || f <= 0.0 {
            continue;
        }
        let w = 2.0 * std::f64::consts::PI * f;
        rate += omega * m * (w * t + p).sin();
        angle += omega * m * (p.cos() - (w * t + p).cos()) / w;
        rate_dot += omega * m * w * (w * t + p).cos();
    }
    (rate, angle, rate_dot)
}

/// Simulates one session. Deterministic for a given seed.
pub fn simulate(
    sensor: &SensorProfile,
    table: &TurntableSetup,
    seed: u64,
) -> Result<Simulation, SimulationError> {
    check_settings(sensor, table)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = (table.duration_s * sensor.sample_rate_hz).round() as usize;
    let dt = 1.0 / sensor.sample_rate_hz;
    let time_s: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let omega = table.rpm * (1.0 + table.speed_error_pct / 100.0) * 2.0 * std::f64::consts::PI / 60.0;
    let modulations = draw_modulations(table, omega, &mut rng);
    let true_accel = platter_force(table, omega, &modulations, &time_s);
    let (accel, saturated) = read_sensor(sensor, &true_accel, dt, &mut rng);
    let (beta, tilt) = (table.beta_deg.to_radians(), table.tilt_deg.to_radians());
    let phase0 = table.tilt_azimuth_deg.to_radians();
    let truth = Truth {
        seed,
        sensor: sensor.clone(),
        turntable: table.clone(),
        session: Session {
            radius_m: table.radius_m,
            omega_radps: omega,
            tilt_rad: tilt,
            phase_rad: phase0,
            direction: table.direction,
            drift_mps2_per_s: [0.0; 3],
        },
        mounting: Mounting {
            beta_rad: beta,
            offset_mps2: sensor.bias_g.map(|b| b * G),
        },
        saturated_samples: saturated,
    };
    let recording = simulated_recording(seed, time_s, accel);
    Ok(Simulation {
        recording,
        truth,
        true_accel_mps2: true_accel,
    })
}

/// Refuses settings the simulation cannot run, by name.
fn check_settings(sensor: &SensorProfile, table: &TurntableSetup) -> Result<(), SimulationError> {
    check(
        "sample_rate_hz",
        sensor.sample_rate_hz,
        sensor.sample_rate_hz > 0.0,
        "must be positive",
    )?;
    check(
        "duration_s",
        table.duration_s,
        table.duration_s > 0.0,
        "must be positive",
    )?;
    check(
        "range_g",
        sensor.range_g,
        sensor.range_g > 0.0,
        "must be positive",
    )?;
    check(
        "bits",
        sensor.bits as f64,
        (2..=32).contains(&sensor.bits),
        "must be 2 to 32",
    )?;
    check(
        "radius_m",
        table.radius_m,
        table.radius_m >= 0.0,
        "cannot be negative",
    )?;
    check("rpm", table.rpm, table.rpm > 0.0, "must be positive")?;
    check(
        "tilt_deg",
        table.tilt_deg,
        (0.0..90.0).contains(&table.tilt_deg),
        "must be in [0, 90)",
    )?;
    check(
        "noise_g",
        sensor.noise_g,
        sensor.noise_g >= 0.0,
        "cannot be negative",
    )?;
    check(
        "bias_drift_time_s",
        sensor.bias_drift_time_s,
        sensor.bias_drift_time_s > 0.0,
        "must be positive",
    )?;
    Ok(())
}

/// Wow (at the platter's own rate unless set) and flutter, each with a random phase.
fn draw_modulations(table: &TurntableSetup, omega: f64, rng: &mut ChaCha8Rng) -> [(f64, f64, f64); 2] {
    let wow_hz = if table.wow_hz > 0.0 {
        table.wow_hz
    } else {
        omega / (2.0 * std::f64::consts::PI)
    };
    let wow_phase: f64 = 2.0 * std::f64::consts::PI * rand::Rng::r#gen::<f64>(rng);
    let flutter_phase: f64 = 2.0 * std::f64::consts::PI * rand::Rng::r#gen::<f64>(rng);
    [
        (table.wow_pct / 100.0, wow_hz, wow_phase),
        (table.flutter_pct / 100.0, table.flutter_hz, flutter_phase),
    ]
}

/// The true specific force on the platter per sample, sensor frame, m/s².
fn platter_force(
    table: &TurntableSetup,
    omega: f64,
    modulations: &[(f64, f64, f64)],
    time_s: &[f64],
) -> [Vec<f64>; 3] {
    let n = time_s.len();
    let g = table.gravity_mps2;
    let s = table.direction.sign();
    let beta = table.beta_deg.to_radians();
    let (sin_b, cos_b) = beta.sin_cos();
    let tilt = table.tilt_deg.to_radians();
    let amplitude = g * tilt.sin();
    let phase0 = table.tilt_azimuth_deg.to_radians();
    let mut true_accel = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for (i, &t) in time_s.iter().enumerate() {
        let (rate, angle, rate_dot) = modulated_rotation(omega, modulations, t, phase0);
        let centripetal = rate * rate * table.radius_m;
        let tangential = table.radius_m * rate_dot;
        let u = angle - beta;
        true_accel[0][i] = centripetal * cos_b + amplitude * u.sin() - s * tangential * sin_b;
        true_accel[1][i] = centripetal * sin_b + s * amplitude * u.cos() + s * tangential * cos_b;
        true_accel[2][i] = g * tilt.cos();
    }
    true_accel
}

/// The sensor's readings of `true_accel` (sensitivity, bias, drift, nonlinearity, noise,
/// quantisation), and how many samples saturated.
fn read_sensor(
    sensor: &SensorProfile,
    true_accel: &[Vec<f64>; 3],
    dt: f64,
    rng: &mut ChaCha8Rng,
) -> ([Vec<f64>; 3], usize) {
    let n = true_accel[0].len();
    let mis = sensor.misalignment_deg.map(f64::to_radians);
    let scale = sensor.scale_error_pct.map(|p| 1.0 + p / 100.0);
    let sensitivity = [
        [scale[0], scale[0] * mis[0], scale[0] * mis[1]],
        [scale[1] * mis[2], scale[1], scale[1] * mis[3]],
        [scale[2] * mis[4], scale[2] * mis[5], scale[2]],
    ];
    let full_scale = sensor.range_g * G;
    let quadratic =
        crate::correctors::physical::quadratic_from_datasheet(sensor.nonlinearity_pct_fs, sensor.range_g);
    let lsb = 2.0 * full_scale / 2f64.powi(sensor.bits as i32);
    let max_code = 2f64.powi(sensor.bits as i32 - 1) - 1.0;
    let drift_bound = sensor.bias_drift_g * G;
    // OU process whose stationary standard deviation is a third of the bound.
    let decay = (-dt / sensor.bias_drift_time_s).exp();
    let innovation = drift_bound / 3.0 * (1.0 - decay * decay).sqrt();
    let mut drift = [0.0; 3];
    let mut saturated = 0;
    let mut accel = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for i in 0..n {
        let f = [true_accel[0][i], true_accel[1][i], true_accel[2][i]];
        let mut sample_saturated = false;
        for k in 0..3 {
            if drift_bound > 0.0 {
                let z: f64 = StandardNormal.sample(rng);
                drift[k] = (decay * drift[k] + innovation * z).clamp(-drift_bound, drift_bound);
            }
            let sensed: f64 =
                (0..3).map(|j| sensitivity[k][j] * f[j]).sum::<f64>() + sensor.bias_g[k] * G + drift[k];
            let noise: f64 = StandardNormal.sample(rng);
            let analog = sensed + quadratic * sensed * sensed + sensor.noise_g * G * noise;
            let code = (analog / lsb).round();
            if code.abs() > max_code {
                sample_saturated = true;
            }
            accel[k][i] = code.clamp(-max_code - 1.0, max_code) * lsb;
        }
        saturated += usize::from(sample_saturated);
    }
    (accel, saturated)
}

/// The simulated readings as a recording of the usual columns.
fn simulated_recording(seed: u64, time_s: Vec<f64>, accel: [Vec<f64>; 3]) -> Recording {
    Recording {
        time_s,
        accel_mps2: accel,
        gyro_radps: None,
        temperature_c: None,
        source: Source {
            name: format!("simulated (seed {seed})"),
            format: "simulated".into(),
            columns: ["t_s", "ax_mps2", "ay_mps2", "az_mps2"]
                .map(String::from)
                .to_vec(),
            metadata: Vec::new(),
            lines: Vec::new(),
            incomplete_rows: Default::default(),
            time_notes: Vec::new(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_bits_other_seed_other_noise() {
        let a = simulate(&SensorProfile::default(), &TurntableSetup::default(), 7).unwrap();
        let b = simulate(&SensorProfile::default(), &TurntableSetup::default(), 7).unwrap();
        let c = simulate(&SensorProfile::default(), &TurntableSetup::default(), 8).unwrap();
        assert_eq!(a.recording, b.recording);
        assert_ne!(a.recording.accel_mps2, c.recording.accel_mps2);
        assert_eq!(a.recording.len(), 6000);
    }

    #[test]
    fn output_is_quantised_and_saturates_at_the_range() {
        let sensor = SensorProfile {
            range_g: 0.5,
            ..SensorProfile::ideal()
        };
        let sim = simulate(&sensor, &TurntableSetup::default(), 1).unwrap();
        let lsb = 2.0 * 0.5 * G / 65536.0;
        for v in &sim.recording.accel_mps2[0] {
            assert!(((v / lsb) - (v / lsb).round()).abs() < 1e-6);
        }
        // z carries ~1 g, above a 0.5 g range, on every sample.
        assert_eq!(sim.truth.saturated_samples, sim.recording.len());
    }

    #[test]
    fn ideal_sensor_reads_the_model_plus_noise() {
        let table = TurntableSetup {
            wow_pct: 0.0,
            flutter_pct: 0.0,
            ..TurntableSetup::default()
        };
        let sim = simulate(&SensorProfile::ideal(), &table, 3).unwrap();
        let mut model = [vec![], vec![], vec![]];
        crate::turntable::model::evaluate(
            &sim.truth.session,
            &sim.truth.mounting,
            table.gravity_mps2,
            &sim.recording.time_s,
            &mut model,
        );
        for k in 0..3 {
            let rms = crate::metrics::rmse(&model[k], &sim.recording.accel_mps2[k]);
            // White noise of 0.002 g plus quantisation (LSB²/12).
            assert!((rms / (0.002 * G) - 1.0).abs() < 0.05, "axis {k}: rms {rms}");
        }
    }

    #[test]
    fn refuses_impossible_settings_by_name() {
        let table = TurntableSetup {
            rpm: -1.0,
            ..TurntableSetup::default()
        };
        let e = simulate(&SensorProfile::default(), &table, 0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "simulation setting rpm = -1 is invalid: must be positive"
        );
    }
}
