//! A forward model of a consumer accelerometer written from first principles, sharing nothing
//! with `spincal::simulate` (whose assumptions the estimator shares): the sensor's frame defined
//! by its own axes (x along x, y in the x–y plane), so its axes in that frame form a lower
//! triangle; the reading of specific force f is b + δ + v + q∘v², v = diag(1 + s)(I + L) f, with
//! δ the bias offset of the power-on session. Still poses at orientations drawn uniformly.
#![allow(dead_code)]

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use spincal::campaign::joint::PoseInput;

pub const G: f64 = 9.80665;

/// A ±2 g consumer part: bias to ±0.2 m/s², scale to ±2 %, axes tilted to ±10 mrad, a
/// quadratic to 0.4 % of the reading at 1 g.
#[derive(Debug, Clone)]
pub struct Sensor {
    pub bias: [f64; 3],
    pub axes: [[f64; 3]; 3],
    pub quadratic: [f64; 3],
    pub noise_mps2: f64,
}

impl Sensor {
    pub fn draw(rng: &mut ChaCha8Rng) -> Sensor {
        let bias = [0; 3].map(|_| rng.gen_range(-0.2..0.2));
        let scale = [0; 3].map(|_| rng.gen_range(-0.02..0.02));
        let axes: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let tilt = if j < i { rng.gen_range(-0.01..0.01) } else { 0.0 };
                (1.0 + scale[i]) * (f64::from(u8::from(i == j)) + tilt)
            })
        });
        let quadratic = [0; 3].map(|_| rng.gen_range(-1.0..1.0) * 0.004 / G);
        Sensor {
            bias,
            axes,
            quadratic,
            noise_mps2: 0.02,
        }
    }

    /// The noiseless reading of `f` with the session's offset `offset`.
    pub fn read(&self, f: [f64; 3], offset: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| {
            let v: f64 = (0..3).map(|j| self.axes[i][j] * f[j]).sum();
            self.bias[i] + offset[i] + v + self.quadratic[i] * v * v
        })
    }
}

/// Gravity's direction in the frame of a body turned uniformly at random (a random unit
/// quaternion's rotation applied to "up"), times g.
pub fn random_gravity(rng: &mut ChaCha8Rng) -> [f64; 3] {
    let q: [f64; 4] = std::array::from_fn(|_| StandardNormal.sample(rng));
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let [w, x, y, z] = q.map(|v| v / n);
    // The third row of the rotation matrix: where the body's frame sees the world's z.
    [
        2.0 * (x * z - y * w),
        2.0 * (y * z + x * w),
        1.0 - 2.0 * (x * x + y * y),
    ]
    .map(|v| G * v)
}

/// One still pose as the joint fit takes it: the mean of `samples` readings at `rate_hz` and its
/// standard error, in power-on session `session`.
pub fn still_pose(
    sensor: &Sensor,
    f: [f64; 3],
    offset: [f64; 3],
    samples: usize,
    session: usize,
    time_s: f64,
    rng: &mut ChaCha8Rng,
) -> PoseInput {
    let clean = sensor.read(f, offset);
    let se = sensor.noise_mps2 / (samples as f64).sqrt();
    PoseInput {
        name: format!("pose at {time_s:.0} s"),
        mean_mps2: clean.map(|v| {
            let z: f64 = StandardNormal.sample(rng);
            v + se * z
        }),
        sigma_mean_mps2: [se; 3],
        samples,
        time_s,
        session,
        gyro_mean_radps: None,
        gyro_sigma_mean_radps: None,
        wander: None,
    }
}
