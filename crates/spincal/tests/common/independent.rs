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

/// A device on a turntable, from first principles: its centre at `centre_radius_m` from the
/// spindle, its axes `out` and `up` (sensor axis index, sign) along the platter's radial and
/// spindle directions but turned by `yaw_rad` about the spindle, and the chip `chip_offset_m`
/// from the centre along the sensor's own axes. The platter turns counter-clockwise at
/// `rate_radps` on a spindle tilted by `tilt_rad`.
#[derive(Debug, Clone, Copy)]
pub struct Placement {
    pub centre_radius_m: f64,
    pub out: (usize, f64),
    pub up: (usize, f64),
    pub yaw_rad: f64,
    pub chip_offset_m: [f64; 3],
}

impl Placement {
    /// The sensor axes of the platter's radial (x), tangential (y) and spindle (z) directions at
    /// the device's centre, as rows: platter vector v is Σ v_j row_j in sensor coordinates.
    fn platter_in_sensor(&self) -> [[f64; 3]; 3] {
        let unit = |(axis, sign): (usize, f64)| {
            let mut v = [0.0; 3];
            v[axis] = sign;
            v
        };
        let (out, up) = (unit(self.out), unit(self.up));
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let tangential = cross(up, out);
        // The device turned by ψ about the spindle: the platter's radial direction, seen from
        // the device, is turned by −ψ.
        let (s, c) = self.yaw_rad.sin_cos();
        let x: [f64; 3] = std::array::from_fn(|k| c * out[k] - s * tangential[k]);
        let y: [f64; 3] = std::array::from_fn(|k| s * out[k] + c * tangential[k]);
        [x, y, up]
    }

    /// The spindle's upward direction in sensor coordinates.
    pub fn spindle_in_sensor(&self) -> [f64; 3] {
        self.platter_in_sensor()[2]
    }

    /// The chip's distance from the spindle, m.
    pub fn chip_radius_m(&self) -> f64 {
        let (px, py) = self.chip_in_platter_plane();
        px.hypot(py)
    }

    /// The chip's position in the platter plane, radial and tangential from the spindle, m.
    fn chip_in_platter_plane(&self) -> (f64, f64) {
        let [x, y, _] = self.platter_in_sensor();
        let d = self.chip_offset_m;
        let along = |axis: [f64; 3]| (0..3).map(|k| axis[k] * d[k]).sum::<f64>();
        (self.centre_radius_m + along(x), along(y))
    }

    /// The specific force at the chip in sensor coordinates at time `t` (s).
    pub fn specific_force(&self, rate_radps: f64, tilt_rad: f64, phase_rad: f64, t: f64) -> [f64; 3] {
        let [x, y, z] = self.platter_in_sensor();
        // The chip's acceleration is −ω² times its position in the platter plane.
        let (px, py) = self.chip_in_platter_plane();
        // World up seen from the turning platter turns backwards.
        let theta = phase_rad - rate_radps * t;
        let up = [
            tilt_rad.sin() * theta.cos(),
            tilt_rad.sin() * theta.sin(),
            tilt_rad.cos(),
        ];
        let w2 = rate_radps * rate_radps;
        let platter = [-w2 * px + G * up[0], -w2 * py + G * up[1], G * up[2]];
        std::array::from_fn(|k| platter[0] * x[k] + platter[1] * y[k] + platter[2] * z[k])
    }
}

/// One run of `duration_s` at `rate_hz` as the joint fit takes it: the device placed as
/// `placement`, the platter at `rate_radps` (its nominal `rpm` is what the user states), tilted
/// 2 mrad, white noise, bias offset `offset`.
#[allow(clippy::too_many_arguments)]
pub fn turntable_run(
    sensor: &Sensor,
    placement: &Placement,
    entry: spincal::campaign::file::TurntableEntry,
    rate_radps: f64,
    offset: [f64; 3],
    duration_s: f64,
    rate_hz: f64,
    name: &str,
    rng: &mut ChaCha8Rng,
) -> spincal::campaign::joint::RunInput {
    let phase = rng.gen_range(0.0..std::f64::consts::TAU);
    let samples = (duration_s * rate_hz) as usize;
    let time_s: Vec<f64> = (0..samples).map(|s| s as f64 / rate_hz).collect();
    let mut accel: [Vec<f64>; 3] = Default::default();
    for &t in &time_s {
        let clean = sensor.read(placement.specific_force(rate_radps, 2e-3, phase, t), offset);
        for k in 0..3 {
            let z: f64 = StandardNormal.sample(rng);
            accel[k].push(clean[k] + sensor.noise_mps2 * z);
        }
    }
    spincal::campaign::joint::RunInput::new(name.to_string(), time_s, accel, vec![true; samples], entry, None)
}
