//! A still-poses-and-rotations session (imu_tk's protocol) with known truth, for the gyroscope
//! calibration of `correctors::gyro_poses`.
//!
//! The sensor starts still in a random orientation, then alternates rotations and still poses.
//! Each rotation turns about a random fixed body axis by a random angle with the smooth rate
//! profile θ̇(t) = (α/T)(1 − cos 2πt/T), which starts and ends at rest. The sensor sits at the
//! centre of rotation (no centripetal force). Readings:
//! - accelerometer: raw r with a = T·diag(s)·(r − b) (`StaticCalibration`'s model, no quadratic
//!   term), a the specific force (up, body frame) plus white noise in m/s²;
//! - gyroscope: m = b + K (ω + n), n white noise in rad/s.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::correctors::gyro::{GyroInputUnit, GyroModel};
use crate::correctors::static_cal::{StaticCalibration, StaticModel};
use crate::geometry::{inverse, quat_exp, quat_mul, rotate};

/// What the session and the sensor are like.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseSessionSetup {
    /// Still poses, the initial one included (rotations: one fewer).
    pub poses: usize,
    pub rate_hz: f64,
    pub initial_still_s: f64,
    /// Each later still pose lasts between these, s.
    pub still_s: [f64; 2],
    /// Each rotation's angle lies between these, deg.
    pub rotation_deg: [f64; 2],
    /// Each rotation lasts between these, s.
    pub rotation_s: [f64; 2],
    pub gravity_mps2: f64,
    /// The accelerometer's true calibration (raw readings to m/s²).
    pub accel: StaticCalibration,
    /// White noise on each accelerometer sample, m/s².
    pub accel_noise_mps2: f64,
    /// The gyroscope's true model.
    pub gyro: GyroModel,
    /// White noise on each gyro sample, rad/s (before K).
    pub gyro_noise_radps: f64,
}

impl PoseSessionSetup {
    /// A random sensor: an accelerometer in counts (offset about 33 000, about 415 counts per
    /// m/s², misalignment up to 1°), a gyro with bias up to 0.02 rad/s, scale errors up to ±5 %
    /// and cross-axis terms up to ±1 %, at 100 Hz with 30 poses.
    pub fn random(seed: u64) -> PoseSessionSetup {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut uniform = |lo: f64, hi: f64| rng.gen_range(lo..hi);
        let accel = StaticCalibration {
            model: StaticModel::Misalignment,
            bias: std::array::from_fn(|_| 33_000.0 + uniform(-300.0, 300.0)),
            scale: std::array::from_fn(|_| 1.0 / (415.0 * (1.0 + uniform(-0.02, 0.02)))),
            misalignment: std::array::from_fn(|_| uniform(-1.0, 1.0).to_radians()),
            nonlinearity: [0.0; 3],
            gravity_mps2: 9.81,
            input_unit: "counts".into(),
        };
        let gyro = GyroModel {
            bias_radps: std::array::from_fn(|_| uniform(-0.02, 0.02)),
            sensitivity: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    if i == j {
                        1.0 + uniform(-0.05, 0.05)
                    } else {
                        uniform(-0.01, 0.01)
                    }
                })
            }),
            input_unit: GyroInputUnit::RadPerS,
        };
        PoseSessionSetup {
            poses: 30,
            rate_hz: 100.0,
            initial_still_s: 30.0,
            still_s: [2.0, 4.0],
            rotation_deg: [30.0, 180.0],
            rotation_s: [1.0, 3.0],
            gravity_mps2: 9.81,
            accel,
            accel_noise_mps2: 0.02,
            gyro,
            gyro_noise_radps: 0.005,
        }
    }
}

/// A simulated session: raw readings sampled together, and the true still intervals.
#[derive(Debug, Clone)]
pub struct PoseSession {
    pub time_s: Vec<f64>,
    /// Raw accelerometer readings (the truth's input unit), body frame.
    pub accel: [Vec<f64>; 3],
    /// Raw gyro readings (the truth's input unit).
    pub gyro: [Vec<f64>; 3],
    /// True still samples `[start, end)` of each pose.
    pub still: Vec<(usize, usize)>,
}

/// Why a session cannot be simulated.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PoseSessionError {
    #[error("pose session: {name} = {value} is out of range")]
    BadSetting { name: &'static str, value: f64 },
    #[error("pose session: the true accelerometer or gyro matrix is singular")]
    Singular,
}

/// Simulates `setup` with the random stream `seed`.
pub fn simulate_pose_session(setup: &PoseSessionSetup, seed: u64) -> Result<PoseSession, PoseSessionError> {
    let positive = |name: &'static str, value: f64| {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(PoseSessionError::BadSetting { name, value })
        }
    };
    positive("rate_hz", setup.rate_hz)?;
    positive("initial_still_s", setup.initial_still_s)?;
    positive("poses", setup.poses as f64)?;
    for (name, range) in [
        ("still_s", setup.still_s),
        ("rotation_deg", setup.rotation_deg),
        ("rotation_s", setup.rotation_s),
    ] {
        positive(name, range[0])?;
        if !(range[1] >= range[0] && range[1].is_finite()) {
            return Err(PoseSessionError::BadSetting {
                name,
                value: range[1],
            });
        }
    }
    for (name, value) in [
        ("accel_noise_mps2", setup.accel_noise_mps2),
        ("gyro_noise_radps", setup.gyro_noise_radps),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(PoseSessionError::BadSetting { name, value });
        }
    }
    let accel_inverse = inverse(&setup.accel.misalignment_matrix()).ok_or(PoseSessionError::Singular)?;
    setup.gyro.corrector().ok_or(PoseSessionError::Singular)?;

    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dt = 1.0 / setup.rate_hz;
    let mut session = PoseSession {
        time_s: Vec::new(),
        accel: std::array::from_fn(|_| Vec::new()),
        gyro: std::array::from_fn(|_| Vec::new()),
        still: Vec::new(),
    };
    let push = |session: &mut PoseSession, rng: &mut ChaCha8Rng, q: &[f64; 4], w: [f64; 3]| {
        session.time_s.push(session.time_s.len() as f64 * dt);
        // Specific force: up in the world, seen in the body frame.
        let up = rotate(&[q[0], -q[1], -q[2], -q[3]], [0.0, 0.0, setup.gravity_mps2]);
        let a: [f64; 3] = std::array::from_fn(|k| up[k] + setup.accel_noise_mps2 * normal(rng));
        let v: [f64; 3] = std::array::from_fn(|r| (0..3).map(|c| accel_inverse[r][c] * a[c]).sum());
        let noisy: [f64; 3] = std::array::from_fn(|k| w[k] + setup.gyro_noise_radps * normal(rng));
        let m = setup.gyro.measure(noisy);
        for k in 0..3 {
            session.accel[k].push(setup.accel.bias[k] + v[k] / setup.accel.scale[k]);
            session.gyro[k].push(m[k]);
        }
    };
    let mut q = random_orientation(&mut rng);
    let still_samples = |s: f64| (s * setup.rate_hz).round().max(1.0) as usize;
    let hold = |session: &mut PoseSession, rng: &mut ChaCha8Rng, q: &[f64; 4], samples: usize| {
        let start = session.time_s.len();
        for _ in 0..samples {
            push(session, rng, q, [0.0; 3]);
        }
        session.still.push((start, session.time_s.len()));
    };
    hold(&mut session, &mut rng, &q, still_samples(setup.initial_still_s));
    for _ in 1..setup.poses {
        let axis = random_unit(&mut rng);
        let angle = rng
            .gen_range(setup.rotation_deg[0]..=setup.rotation_deg[1])
            .to_radians();
        let duration = rng.gen_range(setup.rotation_s[0]..=setup.rotation_s[1]);
        let steps = (duration / dt).round().max(2.0) as usize;
        let start = q;
        let period = steps as f64 * dt;
        // Samples at the ends are at rest; the orientation is exact at each sample.
        for k in 1..steps {
            let tau = k as f64 * dt / period;
            let theta =
                angle * (tau - (2.0 * std::f64::consts::PI * tau).sin() / (2.0 * std::f64::consts::PI));
            let rate = angle / period * (1.0 - (2.0 * std::f64::consts::PI * tau).cos());
            q = quat_mul(&start, &quat_exp(axis.map(|v| v * theta)));
            push(&mut session, &mut rng, &q, axis.map(|v| v * rate));
        }
        q = quat_mul(&start, &quat_exp(axis.map(|v| v * angle)));
        let still = rng.gen_range(setup.still_s[0]..=setup.still_s[1]);
        hold(&mut session, &mut rng, &q, still_samples(still));
    }
    Ok(session)
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

fn random_unit(rng: &mut ChaCha8Rng) -> [f64; 3] {
    loop {
        let v: [f64; 3] = std::array::from_fn(|_| normal(rng));
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 1e-6 {
            return v.map(|x| x / n);
        }
    }
}

fn random_orientation(rng: &mut ChaCha8Rng) -> [f64; 4] {
    loop {
        let v: [f64; 4] = std::array::from_fn(|_| normal(rng));
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 1e-6 {
            return v.map(|x| x / n);
        }
    }
}
