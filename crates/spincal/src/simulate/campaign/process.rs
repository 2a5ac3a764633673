//! The sensor and the gyroscope as sample-by-sample processes, and the rates sampled per recording.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::setup::GyroProfile;
use crate::correctors::gyro::GyroModel;
use crate::correctors::physical::SensorModel;
use crate::input::recording::STANDARD_GRAVITY;
use crate::simulate::SensorProfile;

/// The gyroscope as a sample-by-sample process (its own random stream, so that adding it leaves
/// the accelerometer's samples unchanged).
pub(super) struct GyroProcess {
    pub(super) model: GyroModel,
    pub(super) drift: [f64; 3],
    decay: f64,
    innovation: f64,
    bound: f64,
    noise: f64,
    lsb: f64,
    max_code: f64,
    dt: f64,
    rng: ChaCha8Rng,
}

impl GyroProcess {
    pub(super) fn new(profile: &GyroProfile, decay: f64, dt: f64, seed: u64) -> GyroProcess {
        let bound = profile.bias_drift_dps.to_radians();
        let full_scale = profile.range_dps.to_radians();
        let mut process = GyroProcess {
            model: profile.model(),
            drift: [0.0; 3],
            decay,
            innovation: bound / 3.0 * (1.0 - decay * decay).sqrt(),
            bound,
            noise: profile.noise_dps.to_radians(),
            lsb: 2.0 * full_scale / 65536.0,
            max_code: 32767.0,
            dt,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x6779_726f_5f73_696d),
        };
        process.rng.set_stream(1);
        process.idle(1e4);
        process
    }

    pub(super) fn idle(&mut self, seconds: f64) {
        if self.bound <= 0.0 {
            return;
        }
        let decay = self.decay.powf(seconds / self.dt);
        for k in 0..3 {
            let z: f64 = StandardNormal.sample(&mut self.rng);
            self.drift[k] = (decay * self.drift[k] + self.bound / 3.0 * (1.0 - decay * decay).sqrt() * z)
                .clamp(-self.bound, self.bound);
        }
    }

    /// One reading of true rate `w` (body frame, rad/s).
    pub(super) fn read(&mut self, w: [f64; 3]) -> [f64; 3] {
        let ideal = self.model.measure(w);
        std::array::from_fn(|k| {
            if self.bound > 0.0 {
                let z: f64 = StandardNormal.sample(&mut self.rng);
                self.drift[k] =
                    (self.decay * self.drift[k] + self.innovation * z).clamp(-self.bound, self.bound);
            }
            let z: f64 = StandardNormal.sample(&mut self.rng);
            let analog = ideal[k] + self.drift[k] + self.noise * z;
            (analog / self.lsb)
                .round()
                .clamp(-self.max_code - 1.0, self.max_code)
                * self.lsb
        })
    }
}

/// The sensor as a sample-by-sample process: drift state, noise and quantisation.
pub(super) struct SensorProcess<'a> {
    pub(super) profile: &'a SensorProfile,
    pub(super) model: SensorModel,
    pub(super) drift: [f64; 3],
    pub(super) decay: f64,
    pub(super) innovation: f64,
    pub(super) bound: f64,
    pub(super) lsb: f64,
    pub(super) max_code: f64,
    pub(super) dt: f64,
}

impl SensorProcess<'_> {
    /// Lets the drift run on through a gap of `seconds`.
    pub(super) fn idle(&mut self, seconds: f64, rng: &mut ChaCha8Rng) {
        if self.bound <= 0.0 {
            return;
        }
        let steps = seconds / self.dt;
        let decay = self.decay.powf(steps);
        let stationary = self.bound / 3.0;
        for k in 0..3 {
            let z: f64 = StandardNormal.sample(rng);
            self.drift[k] = (decay * self.drift[k] + stationary * (1.0 - decay * decay).sqrt() * z)
                .clamp(-self.bound, self.bound);
        }
    }

    /// One reading of true force `f`; returns the reading, the unpredictable error per axis
    /// (drift + white noise) and whether it saturated.
    pub(super) fn read(&mut self, f: [f64; 3], rng: &mut ChaCha8Rng) -> ([f64; 3], [f64; 3], bool) {
        let mut out = [0.0; 3];
        let mut random = [0.0; 3];
        let mut saturated = false;
        let u = self.model.linear_response(f, [0.0; 3]);
        for k in 0..3 {
            if self.bound > 0.0 {
                let z: f64 = StandardNormal.sample(rng);
                self.drift[k] =
                    (self.decay * self.drift[k] + self.innovation * z).clamp(-self.bound, self.bound);
            }
            let z: f64 = StandardNormal.sample(rng);
            let noise = self.profile.noise_g * STANDARD_GRAVITY * z;
            let uk = u[k] + self.drift[k];
            let analog = uk + self.model.quadratic_per_mps2[k] * uk * uk + noise;
            random[k] = self.drift[k] + noise;
            let code = (analog / self.lsb).round();
            saturated |= code.abs() > self.max_code;
            out[k] = code.clamp(-self.max_code - 1.0, self.max_code) * self.lsb;
        }
        (out, random, saturated)
    }
}

type Axes = [Vec<f64>; 3];

/// Gyro readings and true rates of one recording, filled sample by sample.
pub(super) struct SampledRates {
    read: Option<[Vec<f64>; 3]>,
    truth: Option<[Vec<f64>; 3]>,
}

impl SampledRates {
    pub(super) fn new(recorded: bool, n: usize) -> SampledRates {
        let zeros = || [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        SampledRates {
            read: recorded.then(zeros),
            truth: recorded.then(zeros),
        }
    }

    pub(super) fn push(&mut self, s: usize, truth: [f64; 3], read: [f64; 3]) {
        if let (Some(r), Some(t)) = (self.read.as_mut(), self.truth.as_mut()) {
            for c in 0..3 {
                r[c][s] = read[c];
                t[c][s] = truth[c];
            }
        }
    }

    pub(super) fn finish(self) -> (Option<Axes>, Option<Axes>) {
        (self.read, self.truth)
    }
}
