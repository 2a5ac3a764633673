//! A whole calibration campaign of one simulated unit: still poses and turntable runs on one
//! timeline (the bias drift carries on from one recording to the next), with the true specific
//! force per sample and the truth in the joint fit's own parametrisation.
//!
//! The sensor's 3×3 sensitivity diag(1 + s)(I + M₆) (six misalignment angles, [`SensorProfile`]) is
//! split as L·R, L lower triangular and R a rotation: L is the fit's D (I + M), and R only renames
//! the frame the true force is expressed in (the body frame of `correctors::physical`). The turntable
//! geometry follows `campaign::joint`'s model exactly, plus what it leaves out: wow, flutter, their
//! tangential acceleration r·ω̇, bias drift, quantisation and saturation.

// Axis loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::campaign::file::TurntableEntry;
use crate::campaign::joint::{mounting_matrix, RUN_PARAMS};
use crate::correctors::gyro::GyroModel;
use crate::correctors::physical::{quadratic_from_datasheet, SensorModel};
use crate::geometry::{cross, dot, norm, unit};
use crate::input::recording::{Recording, Source, STANDARD_GRAVITY};
use crate::simulate::{modulated_rotation, SensorProfile, SimulationError};

/// Seconds the simulated hand takes to turn the sensor from one still pose to the next.
const TURN_S: f64 = 2.0;

mod process;
mod setup;

use process::{GyroProcess, SampledRates, SensorProcess};
pub use setup::{CampaignSetup, GyroProfile, RunSetup};

/// A simulated recording of the campaign.
#[derive(Debug, Clone)]
pub struct SimulatedRecording {
    /// File stem, e.g. `pose-1` or `run-2-33rpm-r0.06`.
    pub name: String,
    /// `None` for a still pose.
    pub turntable: Option<TurntableEntry>,
    pub recording: Recording,
    /// The true specific force per sample, body frame, m/s².
    pub true_accel_mps2: [Vec<f64>; 3],
    /// The true angular rate per sample, body frame, rad/s (when the gyroscope is recorded).
    pub true_gyro_radps: Option<[Vec<f64>; 3]>,
    /// White noise plus bias drift per sample (before the nonlinearity): the error no corrector
    /// can predict, m/s².
    pub random_mps2: [Vec<f64>; 3],
}

impl SimulatedRecording {
    /// RMS per axis of the random error: the floor, m/s².
    pub fn floor_mps2(&self) -> [f64; 3] {
        self.random_mps2
            .each_ref()
            .map(|xs| (xs.iter().map(|v| v * v).sum::<f64>() / xs.len().max(1) as f64).sqrt())
    }
}

/// The truth in the joint fit's parametrisation.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CampaignTruth {
    pub seed: u64,
    pub setup: CampaignSetup,
    pub sensor: SensorModel,
    /// The gyroscope's constant bias and sensitivity (without its drift), when recorded.
    pub gyro: Option<GyroModel>,
    /// Per run: r, ω (mean over the run), α, ϑ₀ (at the run's middle), β, ε₁, ε₂, the wow (w_c,
    /// w_s) and the bias drift over the run as a line (value at the middle, slope), as
    /// `campaign::joint` orders them.
    pub runs: Vec<[f64; RUN_PARAMS]>,
    /// Per pose, the true specific force, m/s².
    pub poses: Vec<[f64; 3]>,
}

/// A simulated campaign.
#[derive(Debug, Clone)]
pub struct SimulatedCampaign {
    pub recordings: Vec<SimulatedRecording>,
    pub truth: CampaignTruth,
}

/// L of diag(1 + s)(I + M₆) = L·R, as the fit's sensor model (bias and nonlinearity from the
/// profile).
pub fn profile_sensor_model(profile: &SensorProfile) -> SensorModel {
    let mis = profile.misalignment_deg.map(f64::to_radians);
    let scale = profile.scale_error_pct.map(|p| 1.0 + p / 100.0);
    let s = [
        [scale[0], scale[0] * mis[0], scale[0] * mis[1]],
        [scale[1] * mis[2], scale[1], scale[1] * mis[3]],
        [scale[2] * mis[4], scale[2] * mis[5], scale[2]],
    ];
    // Gram–Schmidt on the rows: row k = Σ_{j≤k} L_kj q_j.
    let mut q = [[0.0; 3]; 3];
    let mut l = [[0.0; 3]; 3];
    for k in 0..3 {
        let mut v = s[k];
        for j in 0..k {
            let c: f64 = (0..3).map(|i| s[k][i] * q[j][i]).sum();
            l[k][j] = c;
            for i in 0..3 {
                v[i] -= c * q[j][i];
            }
        }
        let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        l[k][k] = norm;
        q[k] = v.map(|x| x / norm);
    }
    let g = STANDARD_GRAVITY;
    let quadratic = quadratic_from_datasheet(profile.nonlinearity_pct_fs, profile.range_g);
    SensorModel {
        bias_mps2: profile.bias_g.map(|b| b * g),
        scale_error: [l[0][0] - 1.0, l[1][1] - 1.0, l[2][2] - 1.0],
        misalignment_rad: [l[1][0] / l[1][1], l[2][0] / l[2][2], l[2][1] / l[2][2]],
        quadratic_per_mps2: [quadratic; 3],
    }
}

fn per_axis(values: &[[f64; 3]]) -> [Vec<f64>; 3] {
    std::array::from_fn(|k| values.iter().map(|v| v[k]).collect())
}

fn recording(name: &str, time_s: Vec<f64>, accel: [Vec<f64>; 3], gyro: Option<[Vec<f64>; 3]>) -> Recording {
    let mut columns = ["t_s", "ax_mps2", "ay_mps2", "az_mps2"]
        .map(String::from)
        .to_vec();
    if gyro.is_some() {
        columns.extend(["gx_radps", "gy_radps", "gz_radps"].map(String::from));
    }
    Recording {
        time_s,
        accel_mps2: accel,
        gyro_radps: gyro,
        temperature_c: None,
        source: Source {
            name: name.to_string(),
            format: "simulated".into(),
            columns,
            metadata: Vec::new(),
            lines: Vec::new(),
            incomplete_rows: Default::default(),
            time_notes: Vec::new(),
        },
    }
}

/// Simulates the campaign. Deterministic for a given seed.
pub fn simulate_campaign(setup: &CampaignSetup, seed: u64) -> Result<SimulatedCampaign, SimulationError> {
    check_setup(setup)?;
    let mut timeline = Timeline::start(setup, seed);
    let mut recordings = Vec::new();
    // The still poses: one recording, the sensor turned by hand from one pose to the next.
    let directions = pose_directions(setup.poses, setup.pose_tilt_deg, &mut timeline.rng);
    let mut true_poses = Vec::new();
    if !directions.is_empty() {
        let forces;
        (forces, true_poses) = pose_forces(setup, &directions);
        recordings.push(timeline.still_poses(&forces));
        timeline.idle();
    }
    let mut true_runs = Vec::new();
    for (index, run) in setup.runs.iter().enumerate() {
        let (recording, geometry) = timeline.turntable_run(index, run);
        true_runs.push(geometry);
        recordings.push(recording);
        timeline.idle();
    }
    Ok(SimulatedCampaign {
        recordings,
        truth: CampaignTruth {
            seed,
            setup: setup.clone(),
            sensor: timeline.model,
            gyro: timeline.gyro.as_ref().map(|g| g.model.clone()),
            runs: true_runs,
            poses: true_poses,
        },
    })
}

/// Refuses a setup the processes cannot run: rates, ranges and durations must be positive.
fn check_setup(setup: &CampaignSetup) -> Result<(), SimulationError> {
    let profile = &setup.sensor;
    let invalid = |name, value, why| Err(SimulationError::Invalid { name, value, why });
    if !(profile.sample_rate_hz > 0.0 && profile.sample_rate_hz.is_finite()) {
        return invalid("sample_rate_hz", profile.sample_rate_hz, "must be positive");
    }
    if !(2..=32).contains(&profile.bits) {
        return invalid("bits", profile.bits as f64, "must be 2 to 32");
    }
    if profile.range_g.is_nan() || profile.range_g <= 0.0 {
        return invalid("range_g", profile.range_g, "must be positive");
    }
    if profile.bias_drift_time_s.is_nan() || profile.bias_drift_time_s <= 0.0 {
        return invalid("bias_drift_time_s", profile.bias_drift_time_s, "must be positive");
    }
    if setup.pose_duration_s.is_nan() || setup.pose_duration_s <= 0.0 {
        return invalid("pose_duration_s", setup.pose_duration_s, "must be positive");
    }
    for run in &setup.runs {
        if !(run.rpm > 0.0 && run.duration_s > 0.0 && run.radius_m >= 0.0 && run.radius_tol_m > 0.0) {
            return invalid(
                "runs",
                run.rpm,
                "every run needs rpm, duration_s and radius_tol_m > 0 and radius_m ≥ 0",
            );
        }
        if run.out.axis == run.up.axis {
            return invalid("runs.up", run.up.axis as f64, "must be a different axis from out");
        }
    }
    let gyro_profile = &setup.gyro;
    if gyro_profile.recorded {
        if !(gyro_profile.range_dps > 0.0 && gyro_profile.range_dps.is_finite()) {
            return invalid("gyro.range_dps", gyro_profile.range_dps, "must be positive");
        }
        if !(gyro_profile.noise_dps >= 0.0 && gyro_profile.bias_drift_dps >= 0.0) {
            return invalid(
                "gyro.noise_dps",
                gyro_profile.noise_dps.min(gyro_profile.bias_drift_dps),
                "noise_dps and bias_drift_dps must be ≥ 0",
            );
        }
    }
    Ok(())
}

/// The unit as it goes through the campaign: its drifts carry on from one recording to the next,
/// and one random stream serves every recording in turn.
struct Timeline<'a> {
    setup: &'a CampaignSetup,
    model: SensorModel,
    sensor: SensorProcess<'a>,
    gyro: Option<GyroProcess>,
    rng: ChaCha8Rng,
    g: f64,
    dt: f64,
}

impl<'a> Timeline<'a> {
    /// The processes before the first recording, their drifts already stationary.
    fn start(setup: &'a CampaignSetup, seed: u64) -> Timeline<'a> {
        let profile = &setup.sensor;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let g = setup.gravity_mps2;
        let dt = 1.0 / profile.sample_rate_hz;
        let full_scale = profile.range_g * STANDARD_GRAVITY;
        let bound = profile.bias_drift_g * STANDARD_GRAVITY;
        let decay = (-dt / profile.bias_drift_time_s).exp();
        let model = profile_sensor_model(profile);
        let mut sensor = SensorProcess {
            profile,
            model,
            drift: [0.0; 3],
            decay,
            innovation: bound / 3.0 * (1.0 - decay * decay).sqrt(),
            bound,
            lsb: 2.0 * full_scale / 2f64.powi(profile.bits as i32),
            max_code: 2f64.powi(profile.bits as i32 - 1) - 1.0,
            dt,
        };
        // Start the drift from its stationary distribution.
        sensor.idle(10.0 * profile.bias_drift_time_s, &mut rng);
        let gyro_profile = &setup.gyro;
        let gyro = gyro_profile
            .recorded
            .then(|| GyroProcess::new(gyro_profile, decay, dt, seed));
        Timeline {
            setup,
            model,
            sensor,
            gyro,
            rng,
            g,
            dt,
        }
    }

    /// Gaps between recordings: both drifts go on.
    fn idle(&mut self) {
        self.sensor.idle(self.setup.gap_s, &mut self.rng);
        if let Some(gyro) = &mut self.gyro {
            gyro.idle(self.setup.gap_s);
        }
    }

    /// The still-poses recording of the true specific forces `forces`, one per sample.
    fn still_poses(&mut self, forces: &[[f64; 3]]) -> SimulatedRecording {
        let dt = self.dt;
        let n = forces.len();
        let mut accel = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut truth = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut rates = SampledRates::new(self.gyro.is_some(), n);
        let mut random = Vec::with_capacity(n);
        for (s, force) in forces.iter().enumerate() {
            let (a, e, _) = self.sensor.read(*force, &mut self.rng);
            for c in 0..3 {
                accel[c][s] = a[c];
                truth[c][s] = force[c];
            }
            random.push(e);
            if let Some(gyro) = self.gyro.as_mut() {
                // While the hand turns it, gravity's direction in the body frame moves along a
                // great circle: the body turns the other way about that circle's axis.
                let w = if s == 0 {
                    [0.0; 3]
                } else {
                    turn_rate(&forces[s - 1], force, dt)
                };
                rates.push(s, w, gyro.read(w));
            }
        }
        let name = "still-poses".to_string();
        let (gyro_read, gyro_true) = rates.finish();
        SimulatedRecording {
            turntable: None,
            recording: recording(&name, (0..n).map(|s| s as f64 * dt).collect(), accel, gyro_read),
            true_accel_mps2: truth,
            true_gyro_radps: gyro_true,
            random_mps2: per_axis(&random),
            name,
        }
    }

    /// One turntable run: its recording and its truth in the joint fit's parametrisation.
    fn turntable_run(&mut self, index: usize, run: &RunSetup) -> (SimulatedRecording, [f64; RUN_PARAMS]) {
        let drawn = DrawnRun::draw(run, &mut self.rng);
        let mut samples = self.sample_run(run, &drawn);
        let geometry = run_truth(&drawn, &mut samples);
        let entry = TurntableEntry {
            rpm: run.rpm,
            radius: Some(crate::turntable::fit::RadiusPrior {
                value_m: run.radius_m,
                tolerance_m: run.radius_tol_m,
            }),
            out: run.out,
            up: run.up,
            direction: None,
            placement: None,
            centre: None,
        };
        let name = format!(
            "run-{}-{}rpm-r{:.3}-out{}-up{}",
            index + 1,
            run.rpm.round(),
            run.radius_m,
            run.out.name(),
            run.up.name()
        );
        let (gyro_read, gyro_true) = samples.rates.finish();
        let recording = SimulatedRecording {
            turntable: Some(entry),
            recording: recording(&name, samples.time_s, samples.accel, gyro_read),
            true_accel_mps2: samples.truth,
            true_gyro_radps: gyro_true,
            random_mps2: per_axis(&samples.random),
            name,
        };
        (recording, geometry)
    }

    /// Reads the sensor (and gyroscope) sample by sample as the platter turns.
    fn sample_run(&mut self, run: &RunSetup, drawn: &DrawnRun) -> RunSamples {
        let g = self.g;
        let (radius, omega, tilt, sigma) = (drawn.radius, drawn.omega, drawn.tilt, drawn.sigma);
        let rotation = &drawn.rotation;
        let n = (run.duration_s * self.setup.sensor.sample_rate_hz).round() as usize;
        let time_s: Vec<f64> = (0..n).map(|s| s as f64 * self.dt).collect();
        let mut accel = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut truth = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut random = Vec::with_capacity(n);
        let mut drift = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut rates = SampledRates::new(self.gyro.is_some(), n);
        let mut theta = Vec::with_capacity(n);
        for (s, &t) in time_s.iter().enumerate() {
            let (rate, angle, rate_dot) = modulated_rotation(omega, &drawn.modulations, t, 0.0);
            let vartheta = drawn.azimuth - sigma * angle;
            theta.push(vartheta);
            let (sn, cs) = vartheta.sin_cos();
            let amplitude = g * tilt.sin();
            // The tangential acceleration r ω̇ along the direction of motion, σ ẑ × x̂.
            let platter = [
                -rate * rate * radius + amplitude * cs,
                amplitude * sn + sigma * radius * rate_dot,
                g * tilt.cos(),
            ];
            let force: [f64; 3] = std::array::from_fn(|r| (0..3).map(|c| rotation[r][c] * platter[c]).sum());
            let (a, e, _) = self.sensor.read(force, &mut self.rng);
            for c in 0..3 {
                accel[c][s] = a[c];
                truth[c][s] = force[c];
                drift[c][s] = self.sensor.drift[c];
            }
            random.push(e);
            if let Some(gyro) = self.gyro.as_mut() {
                // The platter turns at σ·rate about the spindle, the mounting frame's third axis.
                let w: [f64; 3] = std::array::from_fn(|r| sigma * rate * rotation[r][2]);
                rates.push(s, w, gyro.read(w));
            }
        }
        RunSamples {
            time_s,
            accel,
            truth,
            random,
            drift,
            rates,
            theta,
        }
    }
}

/// The pose directions (unit vectors of gravity in the body frame): a face (then an edge, 45°
/// between two axes), tilted at random up to `tilt_deg`. The phone simulation shares it.
pub(crate) fn pose_directions(poses: usize, tilt_deg: f64, rng: &mut ChaCha8Rng) -> Vec<[f64; 3]> {
    let faces: [[f64; 3]; 6] = [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
    ];
    let mut directions = Vec::with_capacity(poses);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let edges: [[f64; 3]; 6] = [
        [h, h, 0.0],
        [-h, -h, 0.0],
        [h, 0.0, -h],
        [-h, 0.0, h],
        [0.0, h, h],
        [0.0, -h, -h],
    ];
    for p in 0..poses {
        let face = if p % 12 < 6 { faces[p % 6] } else { edges[p % 6] };
        let tilt = tilt_deg.to_radians() * rng.gen::<f64>().sqrt();
        let azimuth = 2.0 * std::f64::consts::PI * rng.gen::<f64>();
        // Tilt `face` by `tilt` towards a random direction perpendicular to it.
        let any = if face[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let dot: f64 = (0..3).map(|k| any[k] * face[k]).sum();
        let e1 = unit(std::array::from_fn(|k| any[k] - dot * face[k]));
        let e2 = cross(&face, &e1);
        let dir: [f64; 3] = std::array::from_fn(|k| {
            face[k] * tilt.cos() + tilt.sin() * (azimuth.cos() * e1[k] + azimuth.sin() * e2[k])
        });
        directions.push(dir);
    }
    directions
}

/// The true specific force per sample of the still-poses recording (each pose held, the turns
/// between them), and the force of each pose.
fn pose_forces(setup: &CampaignSetup, directions: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let g = setup.gravity_mps2;
    let rate_hz = setup.sensor.sample_rate_hz;
    let hold = (setup.pose_duration_s * rate_hz).round() as usize;
    let turn = (TURN_S * rate_hz).round() as usize;
    let mut forces: Vec<[f64; 3]> = Vec::new();
    let mut true_poses = Vec::new();
    for (p, dir) in directions.iter().enumerate() {
        if p > 0 {
            // Along the great circle from the previous pose (normalised linear blend).
            let prev = directions[p - 1];
            for s in 1..=turn {
                let x = s as f64 / (turn + 1) as f64;
                let w: [f64; 3] = std::array::from_fn(|k| (1.0 - x) * prev[k] + x * dir[k]);
                let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt().max(1e-9);
                forces.push(w.map(|v| g * v / n));
            }
        }
        forces.extend(std::iter::repeat_n(dir.map(|v| g * v), hold));
        true_poses.push(dir.map(|v| g * v));
    }
    (forces, true_poses)
}

/// One run's random draws and the geometry that follows from them.
struct DrawnRun {
    radius: f64,
    omega: f64,
    tilt: f64,
    azimuth: f64,
    /// Sense of rotation, ±1.
    sigma: f64,
    /// Wow, then flutter: (depth, frequency Hz, phase).
    modulations: [(f64, f64, f64); 2],
    rotation: [[f64; 3]; 3],
    /// r, α, β, ε₁, ε₂ set; ω, ϑ₀, the wow and the drift come from the samples.
    geometry: [f64; RUN_PARAMS],
}

impl DrawnRun {
    fn draw(run: &RunSetup, rng: &mut ChaCha8Rng) -> DrawnRun {
        let radius = run.radius_m + run.radius_tol_m * (2.0 * rng.gen::<f64>() - 1.0) / 2.0;
        let omega = run.rpm * (1.0 + run.speed_error_pct / 100.0) * 2.0 * std::f64::consts::PI / 60.0;
        let tilt = run.tilt_deg.to_radians();
        let azimuth = 2.0 * std::f64::consts::PI * rng.gen::<f64>();
        let beta = 2.0 * std::f64::consts::PI * rng.gen::<f64>() - std::f64::consts::PI;
        let mount_tilt = run.mount_tilt_deg.to_radians();
        let eps1: f64 = mount_tilt * Distribution::<f64>::sample(&StandardNormal, rng);
        let eps2: f64 = mount_tilt * Distribution::<f64>::sample(&StandardNormal, rng);
        let wow_phase = 2.0 * std::f64::consts::PI * rng.gen::<f64>();
        let flutter_phase = 2.0 * std::f64::consts::PI * rng.gen::<f64>();
        let modulations = [
            (
                run.wow_pct / 100.0,
                omega / (2.0 * std::f64::consts::PI),
                wow_phase,
            ),
            (run.flutter_pct / 100.0, run.flutter_hz, flutter_phase),
        ];
        let sigma = run.direction.sign();
        let q = mounting_matrix(run.out, run.up);
        let mut geometry = [0.0; RUN_PARAMS];
        geometry[0] = radius;
        geometry[2] = tilt;
        geometry[4] = beta;
        geometry[5] = eps1;
        geometry[6] = eps2;
        // Only the rotation part of the geometry is used below (ω and ϑ come per sample).
        let rotation = crate::campaign::joint::rotation_of(&q, &geometry);
        DrawnRun {
            radius,
            omega,
            tilt,
            azimuth,
            sigma,
            modulations,
            rotation,
            geometry,
        }
    }
}

/// One run as sampled: the readings, the truth, and the angle and drift the fit's terms are
/// taken from.
struct RunSamples {
    time_s: Vec<f64>,
    accel: [Vec<f64>; 3],
    truth: [Vec<f64>; 3],
    random: Vec<[f64; 3]>,
    drift: [Vec<f64>; 3],
    rates: SampledRates,
    theta: Vec<f64>,
}

/// The run's truth in the fit's terms: ω and ϑ₀ of the angle less its wow (taken off `theta` in
/// place), the wow, and the drift as a line.
fn run_truth(drawn: &DrawnRun, samples: &mut RunSamples) -> [f64; RUN_PARAMS] {
    let (omega, sigma) = (drawn.omega, drawn.sigma);
    let time_s = &samples.time_s;
    let n = time_s.len();
    let mid = 0.5 * (time_s[0] + time_s[n.saturating_sub(1)]);
    let mut geometry = drawn.geometry;
    let theta = &mut samples.theta;
    // The wow in the fit's terms: m(τ) = w_c cos ωτ + w_s sin ωτ with τ from the middle.
    let (wow_m, wow_p) = (drawn.modulations[0].0, drawn.modulations[0].2);
    let wow_c = wow_m * (omega * mid + wow_p).sin();
    let wow_s = wow_m * (omega * mid + wow_p).cos();
    // ϑ without the wow's periodic part is a line: its value at the middle is ϑ₀.
    for (s, &t) in time_s.iter().enumerate() {
        let (s1, c1) = (omega * (t - mid)).sin_cos();
        theta[s] += sigma * (wow_c * s1 - wow_s * c1);
    }
    let (w_fit, phase_fit) = line_fit(time_s, theta, mid);
    geometry[1] = -sigma * w_fit;
    geometry[3] = phase_fit;
    geometry[7] = wow_c;
    geometry[8] = wow_s;
    // The drift as the fit sees it: a line through the run, its value at the middle and slope.
    for c in 0..3 {
        let (slope, at_mid) = line_fit(time_s, &samples.drift[c], mid);
        geometry[9 + c] = at_mid;
        geometry[12 + c] = slope;
    }
    geometry
}

/// Three axes of samples.
/// The body's angular rate that turns gravity's direction from `a` to `b` in `dt` about the great
/// circle through them (dĝ/dt = −ω × ĝ), rad/s.
fn turn_rate(a: &[f64; 3], b: &[f64; 3], dt: f64) -> [f64; 3] {
    let (a, b) = (unit(*a), unit(*b));
    let axis = cross(&a, &b);
    let sin = norm(&axis);
    if sin < 1e-15 {
        return [0.0; 3];
    }
    let angle = sin.atan2(dot(&a, &b));
    axis.map(|c| -angle / dt * c / sin)
}

/// Slope and value at `mid` of the least-squares line through (t, y).
fn line_fit(t: &[f64], y: &[f64], mid: f64) -> (f64, f64) {
    let n = t.len() as f64;
    let mean_y = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx, mut mean_t) = (0.0, 0.0, 0.0);
    for &ti in t {
        mean_t += ti;
    }
    mean_t /= n;
    for (ti, yi) in t.iter().zip(y) {
        sxy += (ti - mean_t) * (yi - mean_y);
        sxx += (ti - mean_t) * (ti - mean_t);
    }
    let slope = sxy / sxx;
    (slope, mean_y + slope * (mid - mean_t))
}

impl SimulatedCampaign {
    /// The campaign file for these recordings, with files named `<name>.csv` beside it.
    pub fn campaign_toml(&self) -> String {
        let mut text = format!(
            "# A simulated campaign (spincal simulate --campaign, seed {}).\nunit = \"{}\"\ngravity_mps2 = {}\n# The sensor's datasheet: range (± g) and nonlinearity (% of full scale).\nrange_g = {}\nnonlinearity_pct_fs = {}\n",
            self.truth.seed,
            self.truth.setup.unit,
            self.truth.setup.gravity_mps2,
            self.truth.setup.sensor.range_g,
            self.truth.setup.sensor.nonlinearity_pct_fs
        );
        for r in &self.recordings {
            text.push_str(&format!("\n[[recording]]\nfile = \"{}.csv\"\n", r.name));
            match &r.turntable {
                None => text.push_str("kind = \"static\"\n"),
                Some(t) => {
                    text.push_str(&format!("kind = \"turntable\"\nrpm = {}\n", t.rpm));
                    if let Some(stated) = t.radius {
                        text.push_str(&format!(
                            "radius_m = {}\nradius_tol_m = {}\n",
                            stated.value_m, stated.tolerance_m
                        ));
                    }
                    text.push_str(&format!("out = \"{}\"\nup = \"{}\"\n", t.out.name(), t.up.name()));
                }
            }
            let f = r.floor_mps2();
            text.push_str(&format!(
                "truth = \"{}.truth.csv\"\nnoise_floor_mps2 = [{}, {}, {}]\nrandom_error = \"{}.random.csv\"\n",
                r.name, f[0], f[1], f[2], r.name
            ));
        }
        text
    }

    /// Recording `i`'s unpredictable error per sample (drift + white noise) as a recording (for
    /// `<name>.random.csv`).
    pub fn random_recording(&self, i: usize) -> Recording {
        let r = &self.recordings[i];
        recording(
            &format!("{} (random error: bias drift + white noise)", r.name),
            r.recording.time_s.clone(),
            r.random_mps2.clone(),
            None,
        )
    }

    /// The recordings as a campaign calibration takes them, with the true specific force and the
    /// random error when `with_truth`.
    pub fn unit_recordings(&self, with_truth: bool) -> Vec<crate::campaign::prepare::UnitRecording> {
        self.recordings
            .iter()
            .map(|r| crate::campaign::prepare::UnitRecording {
                name: r.name.clone(),
                recording: r.recording.clone(),
                turntable: r.turntable.clone(),
                truth: with_truth.then(|| r.true_accel_mps2.clone()),
                floor_mps2: with_truth.then(|| r.floor_mps2()),
                random_mps2: with_truth.then(|| r.random_mps2.clone()),
                session: None,
            })
            .collect()
    }

    /// The true specific force of recording `i` as a recording (for `<name>.truth.csv`).
    pub fn truth_recording(&self, i: usize) -> Recording {
        let r = &self.recordings[i];
        recording(
            &format!("{} (true specific force and angular rate)", r.name),
            r.recording.time_s.clone(),
            r.true_accel_mps2.clone(),
            r.true_gyro_radps.clone(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_split_reproduces_the_sensitivity_up_to_a_rotation() {
        let profile = SensorProfile::default();
        let m = profile_sensor_model(&profile);
        // |L f| = |S Rᵀ f| for every f, so the row norms of L equal those of S.
        let mis = profile.misalignment_deg.map(f64::to_radians);
        let scale = profile.scale_error_pct.map(|p| 1.0 + p / 100.0);
        let s_row0 = scale[0] * (1.0 + mis[0] * mis[0] + mis[1] * mis[1]).sqrt();
        assert!(((1.0 + m.scale_error[0]) - s_row0).abs() < 1e-12);
        assert!(m.misalignment_rad.iter().all(|v| v.abs() < 0.03));
    }

    #[test]
    fn same_seed_same_campaign() {
        let setup = CampaignSetup {
            runs: vec![RunSetup {
                duration_s: 5.0,
                ..RunSetup::default()
            }],
            ..CampaignSetup::default()
        };
        let a = simulate_campaign(&setup, 3).unwrap();
        let b = simulate_campaign(&setup, 3).unwrap();
        assert_eq!(a.recordings.len(), 2);
        for (x, y) in a.recordings.iter().zip(&b.recordings) {
            assert_eq!(x.recording, y.recording);
        }
        // A still pose reads about g in magnitude.
        let r = &a.recordings[0].recording.accel_mps2;
        let norm = (r[0][0].powi(2) + r[1][0].powi(2) + r[2][0].powi(2)).sqrt();
        assert!((norm - STANDARD_GRAVITY).abs() < 0.2, "{norm}");
    }
}
