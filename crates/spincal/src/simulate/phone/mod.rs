//! A phone on a record player, written as the phone apps export it (SPEC §7, issue 48).
//!
//! A session is still poses (the six faces up, then six about 45° between two faces) and turntable
//! runs at each speed in each placement of the phone; every recording is one app export with the
//! accelerometer and the gyroscope, each on its own jittered clock. The phone lies flat (its z up)
//! with its centre at a stated distance from the spindle and turned by a few degrees from the axis
//! the user names as `out`, tilted slightly on its camera bump; the chip sits off the phone's
//! centre. The platter turns clockwise at its nominal speed off by a steady error, with wow and
//! flutter, on a spindle tilted from vertical so that gravity swings through the platter's plane once
//! a turn.
//!
//! The accelerometer reads m = h(b + δ(t) + D(I + M) f) + noise, quantised (h, D, M and b as
//! [`SensorModel`] defines them: the frame of the phone is the accelerometer's body frame), δ a slow
//! bias wander; the gyroscope m = b + δ(t) + K ω + noise, quantised ([`GyroModel`]). Each sensor
//! samples on its own clock (its rate off by up to `clock_ppm`, each tick jittered) and the app
//! stamps each sample with its true time. Every random draw comes from one `ChaCha8Rng`.
//!
//! Behind the `phone` feature: its files are zips, which only that feature writes (and reads).

// Axis loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

mod files;
mod score;
mod setup;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::campaign::file::SignedAxis;
use crate::campaign::joint::mounting_matrix;
use crate::correctors::gyro::{GyroInputUnit, GyroModel};
use crate::correctors::physical::{quadratic_from_datasheet, SensorModel};
use crate::geometry::{apply, mul, transpose, M3};
use crate::input::recording::STANDARD_GRAVITY;
use crate::simulate::campaign::pose_directions;
use crate::simulate::{modulated_rotation, SimulationError};

pub use score::{GyroScaleScore, PhoneScore, RadiusScore};
pub use setup::{PhoneApp, PhoneSetup, PlacementSetup};

/// The Unix time of the first recording's start, s (2026-11-28 12:00 UTC).
const FIRST_START_UNIX_S: f64 = 1_795_867_200.0;

/// One sensor's samples: times on the phone's clock from the recording's start, s, and readings
/// per axis (m/s² or rad/s).
#[derive(Debug, Clone, PartialEq)]
pub struct SensorStream {
    pub time_s: Vec<f64>,
    pub values: [Vec<f64>; 3],
}

/// A turntable run's campaign entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunEntry {
    pub placement: String,
    /// Nominal speed, rpm.
    pub rpm: f64,
    /// The phone's axis away from the spindle, as the user states it.
    pub out: SignedAxis,
    /// The radius the campaign states (the phone's centre) and its tolerance, when asked for.
    pub stated_radius_m: Option<(f64, f64)>,
}

/// One recording of the session: one app export.
#[derive(Debug, Clone, PartialEq)]
pub struct PhoneRecording {
    /// The export's file name, e.g. `pose-01.zip` or `A-33rpm.zip`.
    pub file: String,
    /// `None` for a still pose.
    pub run: Option<RunEntry>,
    pub accel_mps2: SensorStream,
    pub gyro_radps: SensorStream,
    /// When the recording started, Unix time, s (phyphox's `meta/time.csv`, Sensor Logger's epoch
    /// stamps).
    pub start_unix_s: f64,
}

/// Where one placement put the chip, and what it means for the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacementTruth {
    pub label: String,
    /// The stated `out` axis.
    pub out: SignedAxis,
    /// How far the phone lies turned from `out` about the spindle, rad.
    pub yaw_rad: f64,
    /// The phone's tilt on the platter about its x and y axes, rad.
    pub tilt_rad: [f64; 2],
    /// Spindle to the phone's centre, m.
    pub centre_radius_m: f64,
    /// Spindle to the chip: what the fit should find, m.
    pub chip_radius_m: f64,
    /// The spindle's upward direction in the phone's (accelerometer's body) frame.
    pub spindle_in_body: [f64; 3],
    /// sᵀ K s: the gyroscope's scale about the spindle (s = `spindle_in_body`).
    pub gyro_spindle_scale: f64,
}

/// One turntable run's truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunTruth {
    pub file: String,
    pub placement: String,
    pub rpm: f64,
    /// The platter's mean rate over the run (wow and flutter included), rad/s.
    pub rate_radps: f64,
}

/// One still pose's truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseTruth {
    pub file: String,
    /// The true specific force, phone frame, m/s².
    pub force_mps2: [f64; 3],
}

/// Everything the simulation drew: what a calibration should recover (`truth.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhoneTruth {
    pub seed: u64,
    pub setup: PhoneSetup,
    /// The accelerometer in the fit's parametrisation (the phone's frame is its body frame).
    pub accelerometer: SensorModel,
    /// The gyroscope in that frame.
    pub gyroscope: GyroModel,
    /// The chip's position from the phone's centre along the phone's axes, m.
    pub chip_offset_m: [f64; 3],
    /// Each sensor clock's rate error, ppm (accelerometer, gyroscope).
    pub clock_ppm: [f64; 2],
    pub placements: Vec<PlacementTruth>,
    pub runs: Vec<RunTruth>,
    pub poses: Vec<PoseTruth>,
}

/// A simulated phone session.
#[derive(Debug, Clone, PartialEq)]
pub struct PhoneSession {
    pub recordings: Vec<PhoneRecording>,
    pub truth: PhoneTruth,
}

/// A bias wander: an Ornstein–Uhlenbeck process per axis, stepped exactly over any interval.
struct Wander {
    state: [f64; 3],
    sd: f64,
    time_s: f64,
}

impl Wander {
    fn start(sd: f64, time_s: f64, rng: &mut ChaCha8Rng) -> Wander {
        Wander {
            state: [0; 3].map(|_| sd * normal(rng)),
            sd,
            time_s,
        }
    }

    fn step(&mut self, dt: f64, rng: &mut ChaCha8Rng) -> [f64; 3] {
        let decay = (-dt.max(0.0) / self.time_s).exp();
        let innovation = self.sd * (1.0 - decay * decay).sqrt();
        for k in 0..3 {
            self.state[k] = decay * self.state[k] + innovation * normal(rng);
        }
        self.state
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

fn symmetric(rng: &mut ChaCha8Rng, bound: f64) -> f64 {
    bound * (2.0 * rng.gen::<f64>() - 1.0)
}

/// One sensor as it goes through the session: model, noise, quantum, clock and wander.
struct Channel {
    noise: f64,
    lsb: f64,
    max_code: f64,
    rate_hz: f64,
    clock: f64,
    jitter_s: f64,
    wander: Wander,
}

impl Channel {
    /// Sample times over `duration_s`: the first tick within one period of the start, then the
    /// clock's period, each tick jittered (clipped at ±3 sd: the samples stay in order).
    fn times(&self, duration_s: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
        let period = (1.0 + self.clock) / self.rate_hz;
        let first = period * rng.gen::<f64>();
        let n = ((duration_s - first) / period).floor().max(0.0) as usize + 1;
        (0..n)
            .map(|k| {
                let jitter = (self.jitter_s * normal(rng)).clamp(-3.0 * self.jitter_s, 3.0 * self.jitter_s);
                (first + k as f64 * period + jitter).max(0.0)
            })
            .collect()
    }

    /// Reads `ideal(t, wander)` at each of `times`: the wander stepped to each sample, noise added,
    /// quantised and clipped at the range.
    fn sample(
        &mut self,
        times: Vec<f64>,
        ideal: impl Fn(f64, [f64; 3]) -> [f64; 3],
        rng: &mut ChaCha8Rng,
    ) -> SensorStream {
        let mut values: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(times.len()));
        let mut previous = 0.0;
        for &t in &times {
            let drift = self.wander.step(t - previous, rng);
            previous = t;
            let clean = ideal(t, drift);
            for k in 0..3 {
                let code = ((clean[k] + self.noise * normal(rng)) / self.lsb).round();
                values[k].push(code.clamp(-self.max_code - 1.0, self.max_code) * self.lsb);
            }
        }
        SensorStream {
            time_s: times,
            values,
        }
    }
}

/// A placement's geometry: body → platter rotation (platter x away from the spindle through the
/// phone's centre, z up the spindle) and the chip's position in the platter frame.
struct Geometry {
    body_to_platter: M3,
    chip_in_platter: [f64; 3],
}

impl Geometry {
    fn new(placement: &PlacementSetup, yaw: f64, tilt: [f64; 2], chip_offset: [f64; 3]) -> Geometry {
        let up = SignedAxis { axis: 2, sign: 1 };
        // mounting_matrix maps platter coordinates to body ones; its transpose the other way.
        let nominal = transpose(&mounting_matrix(placement.out, up));
        let (sy, cy) = yaw.sin_cos();
        let turn = [[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]];
        let (sx, cx) = tilt[0].sin_cos();
        let (st, ct) = tilt[1].sin_cos();
        let about_x = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
        let about_y = [[ct, 0.0, st], [0.0, 1.0, 0.0], [-st, 0.0, ct]];
        let body_to_platter = mul(&mul(&turn, &nominal), &mul(&about_x, &about_y));
        let offset = apply(&body_to_platter, &chip_offset);
        Geometry {
            body_to_platter,
            chip_in_platter: [placement.centre_radius_m + offset[0], offset[1], offset[2]],
        }
    }

    fn chip_radius_m(&self) -> f64 {
        self.chip_in_platter[0].hypot(self.chip_in_platter[1])
    }

    fn to_body(&self, v: [f64; 3]) -> [f64; 3] {
        apply(&transpose(&self.body_to_platter), &v)
    }
}

/// The platter of one run: its mean rate, modulations, spindle tilt and starting angle.
struct Platter {
    omega: f64,
    modulations: [(f64, f64, f64); 2],
    tilt: f64,
    angle0: f64,
    /// −1: clockwise seen from above, as record players turn.
    sigma: f64,
    g: f64,
}

impl Platter {
    /// Specific force at the chip (platter frame) and the platter's angular rate about the
    /// spindle at `t`.
    fn at(&self, chip: &[f64; 3], t: f64) -> ([f64; 3], f64) {
        let (rate, angle, rate_dot) = modulated_rotation(self.omega, &self.modulations, t, 0.0);
        // World up seen from the turning platter turns the other way.
        let theta = self.angle0 - self.sigma * angle;
        let (s, c) = theta.sin_cos();
        let lean = self.g * self.tilt.sin();
        let (px, py) = (chip[0], chip[1]);
        let force = [
            -rate * rate * px - self.sigma * rate_dot * py + lean * c,
            -rate * rate * py + self.sigma * rate_dot * px + lean * s,
            self.g * self.tilt.cos(),
        ];
        (force, self.sigma * rate)
    }
}

/// Simulates the session. Deterministic for a given seed.
pub fn simulate_phone(setup: &PhoneSetup, seed: u64) -> Result<PhoneSession, SimulationError> {
    setup.check()?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let g = setup.gravity_mps2;
    let accelerometer = draw_accelerometer(setup, &mut rng);
    let gyroscope = draw_gyroscope(setup, &mut rng);
    let chip_offset_m = [
        symmetric(&mut rng, setup.chip_offset_m),
        symmetric(&mut rng, setup.chip_offset_m),
        setup.chip_height_m,
    ];
    let clock_ppm = [0; 2].map(|_| symmetric(&mut rng, setup.clock_ppm));
    let mut recorder = Recorder {
        accel: Channel {
            noise: setup.accel_noise_mps2,
            lsb: 2.0 * setup.accel_range_g * STANDARD_GRAVITY / 65536.0,
            max_code: 32767.0,
            rate_hz: setup.accel_rate_hz,
            clock: clock_ppm[0] * 1e-6,
            jitter_s: setup.jitter_s,
            wander: Wander::start(setup.accel_drift_mps2, setup.drift_time_s, &mut rng),
        },
        gyro: Channel {
            noise: setup.gyro_noise_radps,
            lsb: 2.0 * setup.gyro_range_dps.to_radians() / 65536.0,
            max_code: 32767.0,
            rate_hz: setup.gyro_rate_hz,
            clock: clock_ppm[1] * 1e-6,
            jitter_s: setup.jitter_s,
            wander: Wander::start(setup.gyro_drift_radps, setup.drift_time_s, &mut rng),
        },
        start_unix_s: FIRST_START_UNIX_S,
        gap_s: setup.gap_s,
    };
    let mut recordings = Vec::new();
    let mut poses = Vec::new();
    for (p, direction) in pose_directions(setup.poses, setup.pose_tilt_deg, &mut rng)
        .into_iter()
        .enumerate()
    {
        let force = direction.map(|v| g * v);
        let file = format!("pose-{:02}.zip", p + 1);
        recordings.push(recorder.record(
            file.clone(),
            None,
            setup.pose_s,
            |_, drift| accel_reading(&accelerometer, force, drift),
            |_, drift| add(gyroscope.measure([0.0; 3]), drift),
            &mut rng,
        ));
        poses.push(PoseTruth {
            file,
            force_mps2: force,
        });
    }

    let mut placements = Vec::new();
    let mut runs = Vec::new();
    for placement in &setup.placements {
        let yaw = symmetric(&mut rng, setup.yaw_deg.to_radians());
        let tilt = [0; 2].map(|_| setup.mount_tilt_deg.to_radians() * normal(&mut rng));
        let geometry = Geometry::new(placement, yaw, tilt, chip_offset_m);
        let spindle = geometry.to_body([0.0, 0.0, 1.0]);
        let k_spindle: f64 = (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| spindle[i] * gyroscope.sensitivity[i][j] * spindle[j])
                    .sum::<f64>()
            })
            .sum();
        placements.push(PlacementTruth {
            label: placement.label.clone(),
            out: placement.out,
            yaw_rad: yaw,
            tilt_rad: tilt,
            centre_radius_m: placement.centre_radius_m,
            chip_radius_m: geometry.chip_radius_m(),
            spindle_in_body: spindle,
            gyro_spindle_scale: k_spindle,
        });
        for &rpm in &setup.rpm {
            let omega = rpm * (1.0 + setup.speed_error_pct / 100.0) * std::f64::consts::PI / 30.0;
            let platter = Platter {
                omega,
                modulations: [
                    (
                        setup.wow_pct / 100.0,
                        omega / std::f64::consts::TAU,
                        std::f64::consts::TAU * rng.gen::<f64>(),
                    ),
                    (
                        setup.flutter_pct / 100.0,
                        6.0,
                        std::f64::consts::TAU * rng.gen::<f64>(),
                    ),
                ],
                tilt: setup.platter_tilt_deg.to_radians(),
                angle0: std::f64::consts::TAU * rng.gen::<f64>(),
                sigma: -1.0,
                g,
            };
            let file = format!("{}-{:.0}rpm.zip", placement.label, rpm);
            let chip = geometry.chip_in_platter;
            let entry = RunEntry {
                placement: placement.label.clone(),
                rpm,
                out: placement.out,
                stated_radius_m: setup
                    .stated_radius_tol_m
                    .map(|tol| (placement.centre_radius_m, tol)),
            };
            let force_at = |t: f64, drift: [f64; 3]| {
                let (force, _) = platter.at(&chip, t);
                accel_reading(&accelerometer, geometry.to_body(force), drift)
            };
            let rate_at = |t: f64, drift: [f64; 3]| {
                let (_, rate) = platter.at(&chip, t);
                add(gyroscope.measure(geometry.to_body([0.0, 0.0, rate])), drift)
            };
            let recording = recorder.record(
                file.clone(),
                Some(entry),
                setup.run_s,
                force_at,
                rate_at,
                &mut rng,
            );
            let times = &recording.accel_mps2.time_s;
            let rate_radps = times
                .iter()
                .map(|&t| modulated_rotation(omega, &platter.modulations, t, 0.0).0)
                .sum::<f64>()
                / times.len().max(1) as f64;
            recordings.push(recording);
            runs.push(RunTruth {
                file,
                placement: placement.label.clone(),
                rpm,
                rate_radps,
            });
        }
    }
    Ok(PhoneSession {
        recordings,
        truth: PhoneTruth {
            seed,
            setup: setup.clone(),
            accelerometer,
            gyroscope,
            chip_offset_m,
            clock_ppm,
            placements,
            runs,
            poses,
        },
    })
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| a[k] + b[k])
}

/// The accelerometer: bias, scale, misalignment and a quadratic within the stated bounds.
fn draw_accelerometer(setup: &PhoneSetup, rng: &mut ChaCha8Rng) -> SensorModel {
    let quadratic = quadratic_from_datasheet(setup.accel_nonlinearity_pct_fs, setup.accel_range_g);
    SensorModel {
        bias_mps2: [0; 3].map(|_| symmetric(rng, setup.accel_bias_mps2)),
        scale_error: [0; 3].map(|_| symmetric(rng, setup.accel_scale_pct / 100.0)),
        misalignment_rad: [0; 3].map(|_| symmetric(rng, setup.accel_misalignment_rad)),
        quadratic_per_mps2: [0; 3].map(|_| symmetric(rng, quadratic)),
    }
}

/// The gyroscope: bias, K with its scale errors on the diagonal and cross-axis terms off it.
fn draw_gyroscope(setup: &PhoneSetup, rng: &mut ChaCha8Rng) -> GyroModel {
    let bias_radps = [0; 3].map(|_| symmetric(rng, setup.gyro_bias_radps));
    let sensitivity = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            if i == j {
                1.0 + symmetric(rng, setup.gyro_scale_pct / 100.0)
            } else {
                symmetric(rng, setup.gyro_cross_axis)
            }
        })
    });
    GyroModel {
        bias_radps,
        sensitivity,
        input_unit: GyroInputUnit::RadPerS,
    }
}

/// The accelerometer's reading of force `f` with its bias moved by `drift`, before noise.
fn accel_reading(model: &SensorModel, f: [f64; 3], drift: [f64; 3]) -> [f64; 3] {
    let u = model.linear_response(f, drift);
    std::array::from_fn(|k| u[k] + model.quadratic_per_mps2[k] * u[k] * u[k])
}

/// Both sensors through the session: each recording after a gap in which the wanders go on.
struct Recorder {
    accel: Channel,
    gyro: Channel,
    start_unix_s: f64,
    gap_s: f64,
}

impl Recorder {
    fn record(
        &mut self,
        file: String,
        run: Option<RunEntry>,
        duration_s: f64,
        accel_ideal: impl Fn(f64, [f64; 3]) -> [f64; 3],
        gyro_ideal: impl Fn(f64, [f64; 3]) -> [f64; 3],
        rng: &mut ChaCha8Rng,
    ) -> PhoneRecording {
        let mut stream = |channel: &mut Channel, ideal: &dyn Fn(f64, [f64; 3]) -> [f64; 3]| {
            let times = channel.times(duration_s, rng);
            let end = times.last().copied().unwrap_or(0.0);
            let samples = channel.sample(times, ideal, rng);
            channel.wander.step(duration_s - end + self.gap_s, rng);
            samples
        };
        let accel_mps2 = stream(&mut self.accel, &accel_ideal);
        let gyro_radps = stream(&mut self.gyro, &gyro_ideal);
        let recording = PhoneRecording {
            file,
            run,
            accel_mps2,
            gyro_radps,
            start_unix_s: self.start_unix_s,
        };
        self.start_unix_s += (duration_s + self.gap_s).round();
        recording
    }
}

#[cfg(test)]
mod tests;
