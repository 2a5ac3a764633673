//! The joint fit of one sensor model and every recording of a campaign (SPEC §7).
//!
//! Turntable run i, sample at τ = t − t_mid (platter frame P: x radial outward through the sensor,
//! z along the spindle, upwards; the platter turns by σω, σ = +1 counter-clockwise from above):
//! ```text
//! ϑ = ϑ₀ − σ ω τ                                   (direction of the tilt in P)
//! f_P = [−ω² r + g sin α cos ϑ,  g sin α sin ϑ,  g cos α]
//! f_B = Q · Rx(ε₁) Ry(ε₂) Rz(β) · f_P               (Q: the nominal `out`/`up` mounting)
//! m   = h(b + δᵢ + D (I + M) f_B)                  (the sensor model, `sensor.rs`)
//! ```
//! β turns the sensor about the spindle (free over the circle, so either sign convention for
//! "outward" fits), ε₁, ε₂ tilt it on its mount, δᵢ is the run's bias offset from the unit's bias.
//! Still pose p: f_B = g · ŵ with ŵ = normalise(w₀ + a e₁ + b e₂) (two angles about the pose's
//! first estimate), m̄ = h(b + δ_s + D (I + M) f_B), δ_s the offset of its session (the still
//! recording it came from: one sitting, one bias).
//!
//! Every residual is divided by its noise (per run and axis; for a pose, the mean's standard error
//! and the bias's wander about its session's line, from the random walk measured within the poses
//! (`bias_random_walk`) or from what the first pass left, whichever is larger), and priors enter
//! as residuals: (r − r_nominal)/tolerance and δ/σ_bias (bias instability between recordings),
//! ε/σ_mount (how flat the sensor sits) and, for each free sensor term, its value over a
//! datasheet-sized width (bias 0.5 m/s², scale 0.02, misalignment 0.02 rad, nonlinearity from the
//! datasheet, about 10⁻⁴ /(m/s²)). The normal equations are accumulated per sample, never a
//! stored Jacobian, so memory is the recordings plus an n × n matrix.
//!
//! Standard errors are the sandwich H⁻¹ S H⁻¹ with S from scores summed over blocks of
//! consecutive samples (batch-means HAC): residuals coloured by wow, flutter or drift within a
//! block are accounted for; a pose and each prior are blocks of their own.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use faer::prelude::Solve;
use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use crate::campaign::file::{SignedAxis, TurntableEntry};
use crate::correctors::physical::{SensorModel, SENSOR_PARAMS, SENSOR_PARAM_NAMES};
use crate::geometry::{apply, cross, dot, mul, unit, M3};
use crate::optim::{golden_section_max, levenberg_marquardt_normal, LmOptions, LmStop, NormalEquations};
use crate::progress::Observer;
use crate::turntable::model::{for_each_rotation, Direction};

/// Parameters per turntable run: r, ω, α, ϑ₀, β, ε₁, ε₂, wow (2), δ (3), drift rate (3).
pub const RUN_PARAMS: usize = 15;
/// Geometric parameters per run (all but the offsets), which come first.
pub(crate) const GEOMETRY: usize = 9;
/// Names and units of a run's parameters.
pub const RUN_PARAM_NAMES: [&str; RUN_PARAMS] = [
    "radius (m)",
    "omega (rad/s)",
    "tilt (rad)",
    "tilt_direction (rad)",
    "beta (rad)",
    "mount_tilt_1 (rad)",
    "mount_tilt_2 (rad)",
    "wow_cos",
    "wow_sin",
    "offset_x (m/s²)",
    "offset_y (m/s²)",
    "offset_z (m/s²)",
    "drift_x (m/s² per s)",
    "drift_y (m/s² per s)",
    "drift_z (m/s² per s)",
];
/// Parameters per still pose: two angles of gravity's direction. The bias offset δ (3) belongs
/// to the pose's session (one still recording), shared by its poses.
pub const POSE_PARAMS: usize = 2;
const POSE_PARAM_NAMES: [&str; POSE_PARAMS] = ["direction_1 (rad)", "direction_2 (rad)"];

/// One turntable run, ready for the fit. Made by [`RunInput::new`]; its readings are not edited
/// afterwards (a corrected copy is [`RunInput::with_readings`]), because every fit of the run
/// shares the demodulation of those readings.
#[derive(Debug, Clone)]
pub struct RunInput {
    pub name: String,
    /// Seconds; any origin.
    pub time_s: Vec<f64>,
    pub accel_mps2: [Vec<f64>; 3],
    /// Samples the fit uses (false: saturated or otherwise unusable).
    pub keep: Vec<bool>,
    pub entry: TurntableEntry,
    /// Gyro x, y, z, rad/s, when recorded (`campaign::gyro` calibrates it; this fit ignores it).
    pub gyro_radps: Option<[Vec<f64>; 3]>,
    /// The demodulation behind the run's starting geometry, found by its first fit (a campaign's
    /// held-out folds fit each run many times).
    demodulated: std::sync::OnceLock<Demodulated>,
}

impl RunInput {
    pub fn new(
        name: String,
        time_s: Vec<f64>,
        accel_mps2: [Vec<f64>; 3],
        keep: Vec<bool>,
        entry: TurntableEntry,
        gyro_radps: Option<[Vec<f64>; 3]>,
    ) -> RunInput {
        RunInput {
            name,
            time_s,
            accel_mps2,
            keep,
            entry,
            gyro_radps,
            demodulated: std::sync::OnceLock::new(),
        }
    }

    /// The same run with other readings and samples kept (a corrector's output, say).
    pub fn with_readings(&self, accel_mps2: [Vec<f64>; 3], keep: Vec<bool>) -> RunInput {
        RunInput::new(
            self.name.clone(),
            self.time_s.clone(),
            accel_mps2,
            keep,
            self.entry.clone(),
            self.gyro_radps.clone(),
        )
    }

    /// The run's demodulation in the mounting frame of its entry, found once.
    fn demodulated(&self) -> Demodulated {
        let key = (self.entry.out, self.entry.up, self.entry.rpm.to_bits());
        match self.demodulated.get() {
            Some(found) if found.key == key => *found,
            Some(_) => Demodulated::of(self, key),
            None => *self.demodulated.get_or_init(|| Demodulated::of(self, key)),
        }
    }
}

/// What demodulating a run's horizontal readings (in its mounting frame) finds: the rate, the
/// rotation sense, the rotating part's amplitude and phase, and the constant part. `key`: the
/// entry's mounting and nominal rpm it was found with.
#[derive(Debug, Clone, Copy)]
struct Demodulated {
    key: (SignedAxis, SignedAxis, u64),
    rate_radps: f64,
    sigma: f64,
    amplitude: f64,
    phase: f64,
    constant: [f64; 2],
}

impl Demodulated {
    fn of(run: &RunInput, key: (SignedAxis, SignedAxis, u64)) -> Demodulated {
        let q = mounting_matrix(run.entry.out, run.entry.up);
        let mut time = Vec::with_capacity(run.time_s.len());
        let mut horizontal = Vec::with_capacity(run.time_s.len());
        for (s, &t) in run.time_s.iter().enumerate() {
            if !run.keep[s] {
                continue;
            }
            let a = [run.accel_mps2[0][s], run.accel_mps2[1][s], run.accel_mps2[2][s]];
            // Qᵀ a: the readings along out, up × out and up.
            let m: [f64; 3] = std::array::from_fn(|c| (0..3).map(|r| q[r][c] * a[r]).sum());
            time.push(t);
            horizontal.push([m[0], m[1]]);
        }
        let nominal = run.entry.rpm * 2.0 * std::f64::consts::PI / 60.0;
        let (rate_radps, sigma, amplitude, phase) = demodulate(&time, &horizontal, nominal);
        let n = horizontal.len().max(1) as f64;
        let constant = [0, 1].map(|c| horizontal.iter().map(|h| h[c]).sum::<f64>() / n);
        Demodulated {
            key,
            rate_radps,
            sigma,
            amplitude,
            phase,
            constant,
        }
    }
}

/// One still pose, ready for the fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoseInput {
    pub name: String,
    pub mean_mps2: [f64; 3],
    /// Standard error of the mean per axis, m/s².
    pub sigma_mean_mps2: [f64; 3],
    pub samples: usize,
    /// Middle of the pose on its recording's clock, s.
    pub time_s: f64,
    /// The still recording it came from (0, 1, …): poses of one recording share a bias offset.
    pub session: usize,
    /// The gyro's mean over the pose and its standard error, rad/s, when recorded.
    #[serde(default)]
    pub gyro_mean_radps: Option<[f64; 3]>,
    #[serde(default)]
    pub gyro_sigma_mean_radps: Option<[f64; 3]>,
    /// How the reading moved within the pose, when its samples were seen: the bias's random walk
    /// between poses is measured from it.
    #[serde(default)]
    pub wander: Option<PoseWander>,
}

/// Within one still pose: its length, the second half's mean minus the first's, and the white
/// noise per sample (from first differences).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseWander {
    pub duration_s: f64,
    pub half_difference_mps2: [f64; 3],
    pub noise_sd_mps2: [f64; 3],
    pub samples: usize,
}

/// The bias's random-walk rate, (m/s²)²/s, from the poses' half-to-half differences: for a random
/// walk of rate D the halves' means of a window of length 2h differ with variance 2Dh/3 (twice the
/// Allan variance at h), and white noise adds 4σ²/n. Pooled over the three axes (one die's bias
/// wanders alike on each; 3 differences per pose instead of 1). `None` from fewer than three poses
/// with their samples.
pub fn bias_random_walk(poses: &[PoseInput]) -> Option<f64> {
    let seen: Vec<&PoseWander> = poses.iter().filter_map(|p| p.wander.as_ref()).collect();
    if seen.len() < 3 {
        return None;
    }
    // Each pose adds 2h/3 per axis with h half its length: its whole length over the three axes.
    let weight: f64 = seen.iter().map(|w| w.duration_s).sum();
    if !weight.is_finite() || weight <= 0.0 {
        return None;
    }
    let excess: f64 = seen
        .iter()
        .flat_map(|w| {
            (0..3).map(|k| {
                w.half_difference_mps2[k].powi(2) - 4.0 * w.noise_sd_mps2[k].powi(2) / w.samples.max(1) as f64
            })
        })
        .sum();
    Some((excess / weight).max(0.0))
}

/// Which sensor terms are estimated (the others stay at zero).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SensorTerms {
    pub bias_scale: bool,
    pub misalignment: bool,
    pub nonlinearity: bool,
}

impl SensorTerms {
    pub const ALL: SensorTerms = SensorTerms {
        bias_scale: true,
        misalignment: true,
        nonlinearity: true,
    };
    pub const LINEAR: SensorTerms = SensorTerms {
        bias_scale: true,
        misalignment: true,
        nonlinearity: false,
    };
    pub const BIAS_SCALE: SensorTerms = SensorTerms {
        bias_scale: true,
        misalignment: false,
        nonlinearity: false,
    };
    /// The sensor held fixed (a perfect sensor): only the recordings' geometry is fitted.
    pub const NONE: SensorTerms = SensorTerms {
        bias_scale: false,
        misalignment: false,
        nonlinearity: false,
    };

    /// The terms in words.
    pub fn describe(self) -> &'static str {
        match (self.bias_scale, self.misalignment, self.nonlinearity) {
            (true, true, true) => "bias, scale, misalignment and nonlinearity",
            (true, true, false) => "bias, scale and misalignment",
            (true, false, false) => "bias and scale",
            (false, false, false) => "none (a perfect sensor)",
            _ => "a partial set of terms",
        }
    }

    pub fn free(self, k: usize) -> bool {
        match k {
            0..=5 => self.bias_scale,
            6..=8 => self.misalignment,
            _ => self.nonlinearity,
        }
    }
}

/// Settings of the joint fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointSettings {
    pub gravity_mps2: f64,
    /// Standard deviation of a recording's bias offset from the unit's bias, m/s².
    pub bias_instability_mps2: f64,
    /// Standard deviation of the sensor's tilt on its mount (how flat it sits), rad.
    pub mount_tilt_rad: f64,
    /// Prior standard deviations of the sensor terms about zero: bias (m/s²), scale error,
    /// misalignment (rad), quadratic nonlinearity (1/(m/s²)). The last is a datasheet's: a
    /// campaign file's `range_g` and `nonlinearity_pct_fs` set it, else 0.5 % FS over ±8 g
    /// (about 10⁻⁴). A wider prior lets q trade with the bias drift between poses.
    pub sensor_prior_sd: [f64; 4],
    pub terms: SensorTerms,
    /// Length of the blocks whose scores form the robust covariance, s.
    pub block_s: f64,
    pub max_iterations: usize,
}

impl Default for JointSettings {
    fn default() -> Self {
        JointSettings {
            gravity_mps2: crate::input::recording::STANDARD_GRAVITY,
            bias_instability_mps2: 0.003 * crate::input::recording::STANDARD_GRAVITY,
            mount_tilt_rad: 2f64.to_radians(),
            sensor_prior_sd: [
                0.5,
                0.02,
                0.02,
                crate::correctors::physical::quadratic_from_datasheet(
                    DEFAULT_NONLINEARITY_PCT_FS,
                    DEFAULT_NONLINEARITY_RANGE_G,
                ),
            ],
            terms: SensorTerms::ALL,
            block_s: 5.0,
            max_iterations: 100,
        }
    }
}

/// The nonlinearity prior when the campaign gives no datasheet: a typical MEMS part's 0.5 % of
/// full scale over ±8 g.
pub const DEFAULT_NONLINEARITY_PCT_FS: f64 = 0.5;
pub const DEFAULT_NONLINEARITY_RANGE_G: f64 = 8.0;

/// A fitted parameter with its robust standard error.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointParam {
    pub name: String,
    pub value: f64,
    /// Robust (block HAC) standard error; `None` when fixed or not determined.
    pub std_error: Option<f64>,
    /// Whether the parameter was estimated (false: held at its nominal value).
    pub free: bool,
}

/// One run's fitted geometry.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFit {
    pub name: String,
    pub direction: Direction,
    pub params: Vec<JointParam>,
    /// Residual RMS per axis, m/s².
    pub residual_rms_mps2: [f64; 3],
    pub samples_used: usize,
}

/// The covariance of the sensor parameters, in `SensorModel::params` order.
pub type SensorCovariance = [[f64; SENSOR_PARAMS]; SENSOR_PARAMS];

/// One pose's fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoseFit {
    pub name: String,
    pub params: Vec<JointParam>,
    /// Fitted specific force in the body frame, m/s².
    pub specific_force_mps2: [f64; 3],
}

/// The joint fit's result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointFit {
    pub sensor: SensorModel,
    pub sensor_params: Vec<JointParam>,
    pub runs: Vec<RunFit>,
    pub poses: Vec<PoseFit>,
    pub terms: SensorTerms,
    /// Weighted sum of squares and its degrees of freedom.
    pub chi2: f64,
    pub dof: usize,
    pub iterations: usize,
    pub stop: LmStop,
    /// How the standard errors were formed, in words.
    pub covariance: String,
    #[serde(skip)]
    pub(crate) state: FitState,
}

/// What the corrector selection needs besides the numbers shown.
#[derive(Debug, Clone, Default)]
pub(crate) struct FitState {
    pub params: Vec<f64>,
    pub directions: Vec<f64>,
    pub mountings: Vec<M3>,
    pub gravity: f64,
    /// The robust covariance over the free parameters `free_index` (in that order).
    pub covariance: Option<Mat<f64>>,
    pub free_index: Vec<usize>,
}

impl JointFit {
    /// The fitted true specific force of run `i` at the given times (body frame, m/s²): the
    /// reference correctors learn from. `time_s` on the run's own clock.
    pub fn run_reference(&self, i: usize, time_s: &[f64]) -> [Vec<f64>; 3] {
        let st = &self.state;
        let o = run_offset(i);
        let geo = RunGeometry::new(
            &st.mountings[i],
            &st.params[o..o + RUN_PARAMS],
            st.directions[i],
            st.gravity,
        );
        let mid = mid_time(time_s);
        let mut out = [
            vec![0.0; time_s.len()],
            vec![0.0; time_s.len()],
            vec![0.0; time_s.len()],
        ];
        for (s, &t) in time_s.iter().enumerate() {
            let f = geo.force(t - mid);
            for k in 0..3 {
                out[k][s] = f[k];
            }
        }
        out
    }

    /// Run `i`'s fitted parameters (r, ω, α, ϑ₀, β, ε₁, ε₂, w_c, w_s, δ, drift).
    pub fn run_params(&self, i: usize) -> &[f64] {
        let o = run_offset(i);
        &self.state.params[o..o + RUN_PARAMS]
    }

    /// The platter's speed ω(τ) at τ (seconds from the run's middle) with run parameters `run`
    /// (as [`JointFit::run_params`]), rad/s.
    pub fn run_rate(&self, i: usize, run: &[f64], tau: f64) -> f64 {
        self.geometry_of(i, run).kinematics(tau).rate
    }

    /// The direction of run `i`'s rotation vector in the body frame (the spindle, signed by the
    /// direction of rotation), a unit vector.
    pub fn run_spindle(&self, i: usize, run: &[f64]) -> [f64; 3] {
        self.geometry_of(i, run).angular_rate_direction()
    }

    fn geometry_of(&self, i: usize, run: &[f64]) -> RunGeometry {
        let st = &self.state;
        RunGeometry::new(&st.mountings[i], run, st.directions[i], st.gravity)
    }

    /// The robust covariance of the sensor parameters (`SensorModel::params` order), zero for
    /// those held fixed; `None` when the fit had no covariance.
    pub fn sensor_covariance(&self) -> Option<SensorCovariance> {
        let cov = self.state.covariance.as_ref()?;
        let pos: Vec<Option<usize>> = (0..SENSOR_PARAMS)
            .map(|k| self.state.free_index.iter().position(|&i| i == k))
            .collect();
        Some(std::array::from_fn(|a| {
            std::array::from_fn(|b| match (pos[a], pos[b]) {
                (Some(a), Some(b)) => cov[(a, b)],
                _ => 0.0,
            })
        }))
    }

    /// The robust covariance of run `i`'s parameters `params` (indices into the run's own), zero
    /// for parameters held fixed; `None` when the fit had no covariance.
    pub fn run_covariance(&self, i: usize, params: &[usize]) -> Option<Vec<Vec<f64>>> {
        let cov = self.state.covariance.as_ref()?;
        let o = run_offset(i);
        let pos: Vec<Option<usize>> = params
            .iter()
            .map(|&p| self.state.free_index.iter().position(|&k| k == o + p))
            .collect();
        Some(
            pos.iter()
                .map(|a| {
                    pos.iter()
                        .map(|b| match (a, b) {
                            (Some(a), Some(b)) => cov[(*a, *b)],
                            _ => 0.0,
                        })
                        .collect()
                })
                .collect(),
        )
    }

    /// Free sensor parameters whose uncertainty matters: one standard error moves a reading at
    /// 1 g by more than `tolerance_mps2`. Each comes with the recording that would determine it;
    /// where the campaign already holds those poses (`poses`: their mean readings), the advice
    /// says so and names what limits them instead.
    pub fn undetermined(
        &self,
        gravity: f64,
        tolerance_mps2: f64,
        poses: &[PoseInput],
    ) -> Vec<(String, String)> {
        let axis = ["x", "y", "z"];
        // Whether some pose holds axis k within about 25° of up (sign +1) or down (−1).
        let held = |k: usize, sign: f64| {
            poses.iter().any(|p| {
                let m = p.mean_mps2;
                let norm = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                norm > 0.0 && sign * m[k] / norm > 0.9
            })
        };
        let mut out = Vec::new();
        for (k, p) in self.sensor_params.iter().enumerate() {
            if !p.free {
                continue;
            }
            let effect = match k {
                0..=2 => 1.0,
                3..=8 => gravity,
                _ => gravity * gravity,
            };
            let bad = p
                .std_error
                .is_none_or(|se| se.is_nan() || se * effect > tolerance_mps2);
            if !bad {
                continue;
            }
            let advice = match k {
                0..=5 if held(k % 3, 1.0) && held(k % 3, -1.0) => format!(
                    "the campaign already holds poses with the {} axis up and down; what limits it is the bias wandering between them and between recordings: hold each pose longer, take the up and down poses one after the other, or repeat them",
                    axis[k % 3]
                ),
                0..=5 => format!(
                    "still poses with the {} axis up and down",
                    axis[k % 3]
                ),
                6 => "still poses tilted about 45° between x and y, or a turntable run with z along the spindle".into(),
                7 => "still poses tilted about 45° between x and z, or a turntable run with y along the spindle".into(),
                8 => "still poses tilted about 45° between y and z, or a turntable run with x along the spindle".into(),
                _ => format!(
                    "still poses with the {0} axis up, down and level, or a turntable run with {0} pointing out at a higher speed",
                    axis[k - 9]
                ),
            };
            out.push((p.name.clone(), advice));
        }
        out
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum JointError {
    #[error("the campaign has no recordings the fit can use")]
    Empty,
    #[error("{name}: {why}")]
    Run { name: String, why: String },
    #[error("joint fit setting {name} = {value}: {why}")]
    Setting {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
}

/// Body ← mounting-frame rotation: columns are `out`, `up × out` and `up` in sensor axes.
pub fn mounting_matrix(out: SignedAxis, up: SignedAxis) -> M3 {
    let o = out.vector();
    let u = up.vector();
    let y = cross(&u, &o);
    std::array::from_fn(|r| [o[r], y[r], u[r]])
}

fn rot_x(e: f64) -> (M3, M3) {
    let (s, c) = e.sin_cos();
    (
        [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        [[0.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]],
    )
}

fn rot_y(e: f64) -> (M3, M3) {
    let (s, c) = e.sin_cos();
    (
        [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        [[-s, 0.0, c], [0.0, 0.0, 0.0], [-c, 0.0, -s]],
    )
}

fn rot_z(e: f64) -> (M3, M3) {
    let (s, c) = e.sin_cos();
    (
        [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        [[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]],
    )
}

/// The once-per-revolution terms at one instant (see [`RunGeometry::kinematics`]).
struct Kinematics {
    /// sin and cos of ωτ.
    s1: f64,
    c1: f64,
    /// Relative speed change and its quadrature part.
    m: f64,
    m_quad: f64,
    rate: f64,
    rate_dot: f64,
    /// sin and cos of ϑ.
    s: f64,
    c: f64,
    platter: [f64; 3],
}

/// A run's geometry at given parameters: f_B and its derivatives per sample.
///
/// Wow (a once-per-revolution speed change) is modelled because it shares the rotation's
/// frequency with the tilt's gravity term: ω(τ) = ω (1 + w_c cos ωτ + w_s sin ωτ). It moves the
/// platter angle, the centripetal level and adds the tangential acceleration r ω̇.
pub(crate) struct RunGeometry {
    qr: M3,
    d_beta: M3,
    d_eps1: M3,
    d_eps2: M3,
    radius: f64,
    omega: f64,
    sin_tilt: f64,
    cos_tilt: f64,
    /// sin and cos of the phase ϑ₀.
    sin_phase: f64,
    cos_phase: f64,
    wow: [f64; 2],
    direction: f64,
    gravity: f64,
}

impl RunGeometry {
    pub(crate) fn new(q: &M3, run: &[f64], direction: f64, gravity: f64) -> RunGeometry {
        let (rx, drx) = rot_x(run[5]);
        let (ry, dry) = rot_y(run[6]);
        let (rz, drz) = rot_z(run[4]);
        let qrx = mul(q, &rx);
        let qdrx = mul(q, &drx);
        RunGeometry {
            qr: mul(&mul(&qrx, &ry), &rz),
            d_beta: mul(&mul(&qrx, &ry), &drz),
            d_eps1: mul(&mul(&qdrx, &ry), &rz),
            d_eps2: mul(&mul(&qrx, &dry), &rz),
            radius: run[0],
            omega: run[1],
            sin_tilt: run[2].sin(),
            cos_tilt: run[2].cos(),
            sin_phase: run[3].sin(),
            cos_phase: run[3].cos(),
            wow: [run[7], run[8]],
            direction,
            gravity,
        }
    }

    /// The platter turns at σ ω(τ) about the spindle, the mounting frame's third axis (β turns
    /// about it and so leaves it alone): this is σ times that axis in the body frame.
    fn angular_rate_direction(&self) -> [f64; 3] {
        std::array::from_fn(|r| self.direction * self.qr[r][2])
    }

    /// True specific force in the body frame at τ (seconds from the run's middle).
    pub(crate) fn force(&self, tau: f64) -> [f64; 3] {
        apply(&self.qr, &self.kinematics(tau).platter)
    }

    /// [`RunGeometry::force`] given sin ωτ and cos ωτ.
    #[inline(always)]
    fn force_at(&self, s1: f64, c1: f64) -> [f64; 3] {
        apply(&self.qr, &self.kinematics_at(s1, c1).platter)
    }

    /// The platter's motion at τ and the specific force in the platter frame.
    fn kinematics(&self, tau: f64) -> Kinematics {
        let (s1, c1) = (self.omega * tau).sin_cos();
        self.kinematics_at(s1, c1)
    }

    /// [`RunGeometry::kinematics`] given sin ωτ and cos ωτ (from a recurrence over the samples).
    #[inline(always)]
    fn kinematics_at(&self, s1: f64, c1: f64) -> Kinematics {
        let (g, w, r, sigma) = (self.gravity, self.omega, self.radius, self.direction);
        let [wc, ws] = self.wow;
        let m = wc * c1 + ws * s1;
        let m_quad = -wc * s1 + ws * c1;
        let rate = w * (1.0 + m);
        let rate_dot = w * w * m_quad;
        // The platter angle ϑ₀ − σ(ωτ + w_c sin ωτ − w_s cos ωτ), from sin ωτ and cos ωτ and a
        // rotation by the wow term, which is small: no second sine and cosine of a large angle
        // per sample (they were a fifth of the joint fit's time).
        let (s0, c0) = (
            self.sin_phase * c1 - sigma * self.cos_phase * s1,
            self.cos_phase * c1 + sigma * self.sin_phase * s1,
        );
        let (sd, cd) = small_sin_cos(-sigma * (wc * s1 - ws * c1));
        let (s, c) = (s0 * cd + c0 * sd, c0 * cd - s0 * sd);
        let amplitude = g * self.sin_tilt;
        Kinematics {
            s1,
            c1,
            m,
            m_quad,
            rate,
            rate_dot,
            s,
            c,
            platter: [
                -rate * rate * r + amplitude * c,
                amplitude * s + sigma * r * rate_dot,
                g * self.cos_tilt,
            ],
        }
    }

    /// f_B and ∂f_B/∂(r, ω, α, ϑ₀, β, ε₁, ε₂, w_c, w_s).
    #[cfg(test)]
    fn force_and_derivatives(&self, tau: f64) -> ([f64; 3], [[f64; 3]; GEOMETRY]) {
        let (s1, c1) = (self.omega * tau).sin_cos();
        self.force_and_derivatives_at(tau, s1, c1)
    }

    /// [`RunGeometry::force_and_derivatives`] given sin ωτ and cos ωτ.
    #[inline(always)]
    fn force_and_derivatives_at(&self, tau: f64, s1: f64, c1: f64) -> ([f64; 3], [[f64; 3]; GEOMETRY]) {
        let (g, w, r, sigma) = (self.gravity, self.omega, self.radius, self.direction);
        let Kinematics {
            s1,
            c1,
            m,
            m_quad,
            rate,
            rate_dot,
            s,
            c,
            platter: fp,
        } = self.kinematics_at(s1, c1);
        let amplitude = g * self.sin_tilt;
        // ∂/∂ω through the rate, the angle and ω̇.
        let d_rate = (1.0 + m) + w * tau * m_quad;
        let d_angle = tau * (1.0 + m);
        let d_rate_dot = 2.0 * w * m_quad - w * w * tau * m;
        let dp = [
            [-rate * rate, sigma * rate_dot, 0.0],
            [
                -2.0 * rate * r * d_rate + amplitude * s * sigma * d_angle,
                -amplitude * c * sigma * d_angle + sigma * r * d_rate_dot,
                0.0,
            ],
            [g * self.cos_tilt * c, g * self.cos_tilt * s, -g * self.sin_tilt],
            [-amplitude * s, amplitude * c, 0.0],
            [
                -2.0 * rate * r * w * c1 + amplitude * s * sigma * s1,
                -amplitude * c * sigma * s1 - sigma * r * w * w * s1,
                0.0,
            ],
            [
                -2.0 * rate * r * w * s1 - amplitude * s * sigma * c1,
                amplitude * c * sigma * c1 + sigma * r * w * w * c1,
                0.0,
            ],
        ];
        let mut d = [[0.0; 3]; GEOMETRY];
        for k in 0..4 {
            d[k] = apply(&self.qr, &dp[k]);
        }
        d[4] = apply(&self.d_beta, &fp);
        d[5] = apply(&self.d_eps1, &fp);
        d[6] = apply(&self.d_eps2, &fp);
        d[7] = apply(&self.qr, &dp[4]);
        d[8] = apply(&self.qr, &dp[5]);
        (apply(&self.qr, &fp), d)
    }
}

/// sin and cos of `x`: by their Taylor series to x⁶ when |x| < 1e-3 (the next terms are below
/// 1e-22, far under a double's rounding), by `sin_cos` otherwise.
#[inline(always)]
fn small_sin_cos(x: f64) -> (f64, f64) {
    if x.abs() < 1e-3 {
        let x2 = x * x;
        (
            x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0)),
            1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0)),
        )
    } else {
        x.sin_cos()
    }
}

/// A pose's gravity direction: w₀ and a tangent basis.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PoseFrame {
    w0: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
}

impl PoseFrame {
    fn new(mean: [f64; 3]) -> PoseFrame {
        let norm = (mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]).sqrt();
        let w0 = if norm > 0.0 {
            mean.map(|v| v / norm)
        } else {
            [0.0, 0.0, 1.0]
        };
        // The axis least aligned with w₀ makes a well-conditioned tangent basis.
        let k = (0..3)
            .min_by(|&a, &b| w0[a].abs().total_cmp(&w0[b].abs()))
            .unwrap_or(0);
        let mut a = [0.0; 3];
        a[k] = 1.0;
        let along = dot(&a, &w0);
        let e1 = unit([a[0] - along * w0[0], a[1] - along * w0[1], a[2] - along * w0[2]]);
        let e2 = cross(&w0, &e1);
        PoseFrame { w0, e1, e2 }
    }

    /// g ŵ and its derivatives with respect to the two angles.
    fn force(&self, a: f64, b: f64, g: f64) -> ([f64; 3], [[f64; 3]; 2]) {
        let w: [f64; 3] = std::array::from_fn(|k| self.w0[k] + a * self.e1[k] + b * self.e2[k]);
        let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let hat = w.map(|v| v / norm);
        let d = |e: &[f64; 3]| -> [f64; 3] {
            let dot = hat[0] * e[0] + hat[1] * e[1] + hat[2] * e[2];
            std::array::from_fn(|k| g * (e[k] - dot * hat[k]) / norm)
        };
        (hat.map(|v| g * v), [d(&self.e1), d(&self.e2)])
    }
}

/// The problem as the optimiser sees it.
pub(crate) struct JointProblem<'a> {
    pub runs: &'a [RunInput],
    pub poses: &'a [PoseInput],
    pub gravity: f64,
    pub bias_sigma: f64,
    pub mount_tilt_sigma: f64,
    /// Prior widths of bias, scale, misalignment and nonlinearity.
    pub sensor_prior_sd: [f64; 4],
    pub sensor_free: [bool; SENSOR_PARAMS],
    pub directions: Vec<f64>,
    pub mountings: Vec<M3>,
    pub pose_frames: Vec<PoseFrame>,
    /// Per pose and axis, the standard error of its mean (after the variance component), m/s².
    pub pose_sigma: Vec<[f64; 3]>,
    /// Per pose, its time from the middle of its session, s.
    pub pose_tau: Vec<f64>,
    /// Per run and axis, the residual noise, m/s².
    pub run_sigma: Vec<[f64; 3]>,
    pub block_samples: Vec<usize>,
}

/// Where a run's or a pose's parameters start in the parameter vector.
pub(crate) fn run_offset(i: usize) -> usize {
    SENSOR_PARAMS + i * RUN_PARAMS
}

fn pose_offset(n_runs: usize, p: usize) -> usize {
    SENSOR_PARAMS + n_runs * RUN_PARAMS + p * POSE_PARAMS
}

/// Samples between exact re-anchorings of the demodulation scan's phasor.
const SCAN_BLOCK: usize = 64;

/// Parameters per still session: bias offset δ (3) and drift rate (3) about its middle.
const SESSION_PARAMS: usize = 6;
/// The least share of a pose residual's variance taken as left by the fit (its leverage at most
/// 0.95), so that a pose the fit nearly interpolates does not inflate the component without bound.
const MIN_KEPT_VARIANCE: f64 = 0.05;

/// A still session's drift rate has a prior of the bias instability per this many seconds.
const SESSION_DRIFT_S: f64 = 100.0;

fn session_offset(n_runs: usize, n_poses: usize, session: usize) -> usize {
    SENSOR_PARAMS + n_runs * RUN_PARAMS + n_poses * POSE_PARAMS + SESSION_PARAMS * session
}

/// A run's bias offset at τ: δ + d τ.
fn run_offset_at(p: &[f64], o: usize, tau: f64) -> [f64; 3] {
    std::array::from_fn(|k| p[o + GEOMETRY + k] + p[o + GEOMETRY + 3 + k] * tau)
}

/// Each pose's time from the middle of its session.
fn session_times(poses: &[PoseInput]) -> Vec<f64> {
    poses
        .iter()
        .map(|pose| {
            let times = poses
                .iter()
                .filter(|q| q.session == pose.session)
                .map(|q| q.time_s);
            let (lo, hi) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
            pose.time_s - 0.5 * (lo + hi)
        })
        .collect()
}

fn sessions(poses: &[PoseInput]) -> usize {
    poses.iter().map(|p| p.session + 1).max().unwrap_or(0)
}

/// Accumulates rows into a local dense system, then scatters it into the global one.
struct LocalSystem {
    index: Vec<usize>,
    /// The local JᵀJ, full (both triangles).
    gram: Mat<f64>,
    grad: Vec<f64>,
    sse: f64,
    /// Rows not yet added to `gram`: `filled` of [`BATCH_ROWS`].
    batch: Mat<f64>,
    residuals: Vec<f64>,
    filled: usize,
}

/// Rows are gathered this many at a time and their Gram matrix added by one matrix product
/// (faer's SIMD kernels): a rank-1 update per row was half of the joint fit's time.
const BATCH_ROWS: usize = 64;

impl LocalSystem {
    fn new(index: Vec<usize>) -> LocalSystem {
        let n = index.len();
        LocalSystem {
            index,
            gram: Mat::zeros(n, n),
            grad: vec![0.0; n],
            sse: 0.0,
            batch: Mat::zeros(BATCH_ROWS, n),
            residuals: vec![0.0; BATCH_ROWS],
            filled: 0,
        }
    }

    fn add_row(&mut self, row: &[f64], residual: f64) {
        for (a, v) in row.iter().enumerate() {
            self.batch[(self.filled, a)] = *v;
        }
        self.residuals[self.filled] = residual;
        self.filled += 1;
        self.sse += residual * residual;
        if self.filled == BATCH_ROWS {
            self.flush();
        }
    }

    /// Adds the gathered rows to JᵀJ and Jᵀr.
    fn flush(&mut self) {
        if self.filled == 0 {
            return;
        }
        let rows = self.batch.as_ref().subrows(0, self.filled);
        faer::linalg::matmul::matmul(
            self.gram.as_mut(),
            faer::Accum::Add,
            rows.transpose(),
            rows,
            1.0,
            faer::Par::Seq,
        );
        for (a, g) in self.grad.iter_mut().enumerate() {
            let column = rows.col(a);
            *g += (0..self.filled)
                .map(|i| column[i] * self.residuals[i])
                .sum::<f64>();
        }
        self.filled = 0;
    }

    fn scatter(&mut self, jtj: &mut Mat<f64>, jtr: &mut [f64]) {
        self.flush();
        let n = self.index.len();
        for a in 0..n {
            jtr[self.index[a]] += self.grad[a];
            for b in a..n {
                let v = self.gram[(a, b)];
                let (i, j) = (self.index[a], self.index[b]);
                jtj[(i, j)] += v;
                if i != j {
                    jtj[(j, i)] += v;
                }
            }
        }
    }
}

/// A weighted row of axis `k` up to the recording's own offsets: ∂m_k/∂(b, s, M, q) given u_k
/// and f_B, then the recording's parameters through `derivatives` (∂f_B per parameter, in the
/// order they follow the sensor's). `slope` is h'(u_k)·weight.
#[allow(clippy::too_many_arguments)]
fn model_row(
    row: &mut [f64],
    k: usize,
    sensor: &SensorModel,
    slope: f64,
    weight: f64,
    u: f64,
    force: &[f64; 3],
    derivatives: &[[f64; 3]],
) {
    row.fill(0.0);
    let scale = 1.0 + sensor.scale_error[k];
    row[k] = slope;
    row[3 + k] = slope * sensor.skewed(*force)[k];
    match k {
        1 => row[6] = slope * scale * force[0],
        2 => {
            row[7] = slope * scale * force[0];
            row[8] = slope * scale * force[1];
        }
        _ => {}
    }
    row[9 + k] = weight * u * u;
    for (j, dj) in derivatives.iter().enumerate() {
        row[SENSOR_PARAMS + j] = slope * scale * sensor.skewed(*dj)[k];
    }
}

/// What one evaluation of the problem produces.
pub(crate) enum Want<'a> {
    Sse,
    Normal(&'a mut Mat<f64>, &'a mut [f64]),
    /// Σ over blocks of s sᵀ (s: the block's score Jᵀr), into the matrix.
    Meat(&'a mut Mat<f64>),
}

impl Want<'_> {
    /// A prior `value / sigma` as one more residual on parameter `param`; returns its square.
    fn add_prior(&mut self, param: usize, value: f64, sigma: f64) -> f64 {
        let r = value / sigma;
        match self {
            Want::Sse => {}
            Want::Normal(jtj, jtr) => {
                jtj[(param, param)] += 1.0 / (sigma * sigma);
                jtr[param] += r / sigma;
            }
            // A prior's information is its stated variance, not the realised score².
            Want::Meat(meat) => meat[(param, param)] += 1.0 / (sigma * sigma),
        }
        r * r
    }
}

impl JointProblem<'_> {
    pub(crate) fn n_params(&self) -> usize {
        SENSOR_PARAMS
            + self.runs.len() * RUN_PARAMS
            + self.poses.len() * POSE_PARAMS
            + SESSION_PARAMS * sessions(self.poses)
    }

    pub(crate) fn geometry(&self, p: &[f64], i: usize) -> RunGeometry {
        let o = run_offset(i);
        RunGeometry::new(
            &self.mountings[i],
            &p[o..o + RUN_PARAMS],
            self.directions[i],
            self.gravity,
        )
    }

    /// The parameters a still pose's residuals depend on: the sensor's, its two angles and its
    /// session's offset and drift rate (the order of [`JointProblem::pose_rows`]' entries).
    fn pose_index(&self, pi: usize) -> Vec<usize> {
        let o = pose_offset(self.runs.len(), pi);
        let so = session_offset(self.runs.len(), self.poses.len(), self.poses[pi].session);
        (0..SENSOR_PARAMS)
            .chain(o..o + POSE_PARAMS)
            .chain(so..so + SESSION_PARAMS)
            .collect()
    }

    /// Pose `pi`'s weighted residual rows, one per axis: `visit(axis, row over pose_index, r)`.
    fn pose_rows(
        &self,
        p: &[f64],
        sensor: &SensorModel,
        pi: usize,
        mut visit: impl FnMut(usize, &[f64], f64),
    ) {
        let pose = &self.poses[pi];
        let o = pose_offset(self.runs.len(), pi);
        let so = session_offset(self.runs.len(), self.poses.len(), pose.session);
        let (force, d) = self.pose_frames[pi].force(p[o], p[o + 1], self.gravity);
        let dt = self.pose_tau[pi];
        let delta: [f64; 3] = std::array::from_fn(|k| p[so + k] + p[so + 3 + k] * dt);
        let u = sensor.linear_response(force, delta);
        let mut row = vec![0.0; SENSOR_PARAMS + POSE_PARAMS + SESSION_PARAMS];
        for k in 0..3 {
            let q = sensor.quadratic_per_mps2[k];
            let w = 1.0 / self.pose_sigma[pi][k];
            let r = (u[k] + q * u[k] * u[k] - pose.mean_mps2[k]) * w;
            let slope = (1.0 + 2.0 * q * u[k]) * w;
            model_row(&mut row, k, sensor, slope, w, u[k], &force, &d);
            row[SENSOR_PARAMS + POSE_PARAMS + k] = slope;
            row[SENSOR_PARAMS + POSE_PARAMS + 3 + k] = slope * dt;
            visit(k, &row, r);
        }
    }

    /// Leverage of each pose's residual per axis: h = jᵀ (JᵀJ)⁻¹ j over the free parameters, with
    /// `jtj` the weighted normal matrix at `p`. The share of that residual the fit itself
    /// absorbs; `None` when `jtj` is singular.
    fn pose_leverage(&self, p: &[f64], jtj: &Mat<f64>, free: &[bool]) -> Option<Vec<[f64; 3]>> {
        let index: Vec<usize> = (0..p.len()).filter(|&k| free[k]).collect();
        let covariance = inverse_on(jtj, &index)?;
        let position: Vec<Option<usize>> = {
            let mut position = vec![None; p.len()];
            for (a, &k) in index.iter().enumerate() {
                position[k] = Some(a);
            }
            position
        };
        let sensor = SensorModel::from_params(p);
        let mut out = Vec::with_capacity(self.poses.len());
        for pi in 0..self.poses.len() {
            let columns = self.pose_index(pi);
            let mut h = [0.0; 3];
            self.pose_rows(p, &sensor, pi, |k, row, _| {
                let mut sum = 0.0;
                for (a, &ka) in columns.iter().enumerate() {
                    let Some(ia) = position[ka] else { continue };
                    for (b, &kb) in columns.iter().enumerate() {
                        if let Some(ib) = position[kb] {
                            sum += row[a] * covariance[(ia, ib)] * row[b];
                        }
                    }
                }
                h[k] = sum;
            });
            out.push(h);
        }
        Some(out)
    }

    /// Model − measured mean of pose `i`, m/s².
    pub(crate) fn pose_residual(&self, p: &[f64], i: usize) -> [f64; 3] {
        let sensor = SensorModel::from_params(p);
        let o = pose_offset(self.runs.len(), i);
        let so = session_offset(self.runs.len(), self.poses.len(), self.poses[i].session);
        let (force, _) = self.pose_frames[i].force(p[o], p[o + 1], self.gravity);
        let dt = self.pose_tau[i];
        let u = sensor.linear_response(force, std::array::from_fn(|k| p[so + k] + p[so + 3 + k] * dt));
        std::array::from_fn(|k| {
            u[k] + sensor.quadratic_per_mps2[k] * u[k] * u[k] - self.poses[i].mean_mps2[k]
        })
    }

    /// Residuals of run i, per sample and axis (unweighted, model − measured), with a callback.
    pub(crate) fn run_residuals(&self, p: &[f64], i: usize, mut f: impl FnMut(usize, [f64; 3])) {
        let sensor = SensorModel::from_params(p);
        let geo = self.geometry(p, i);
        let run = &self.runs[i];
        let o = run_offset(i);
        let mid = mid_time(&run.time_s);
        for (s, &t) in run.time_s.iter().enumerate() {
            if !run.keep[s] {
                continue;
            }
            let delta = run_offset_at(p, o, t - mid);
            let u = sensor.linear_response(geo.force(t - mid), delta);
            let r: [f64; 3] = std::array::from_fn(|k| {
                u[k] + sensor.quadratic_per_mps2[k] * u[k] * u[k] - run.accel_mps2[k][s]
            });
            f(s, r);
        }
    }

    pub(crate) fn evaluate(&self, p: &[f64], mut want: Want<'_>) -> f64 {
        let sensor = SensorModel::from_params(p);
        let mut sse = 0.0;
        if let Want::Normal(jtj, jtr) = &mut want {
            jtj.fill(0.0);
            jtr.fill(0.0);
        }
        if let Want::Meat(meat) = &mut want {
            meat.fill(0.0);
        }
        let scale = sensor.scale_error.map(|s| 1.0 + s);
        for i in 0..self.runs.len() {
            let run = &self.runs[i];
            let o = run_offset(i);
            let geo = self.geometry(p, i);
            let mid = mid_time(&run.time_s);
            let index: Vec<usize> = (0..SENSOR_PARAMS).chain(o..o + RUN_PARAMS).collect();
            let mut local = LocalSystem::new(index.clone());
            let mut block = vec![0.0; index.len()];
            let mut in_block = 0;
            let mut row = vec![0.0; index.len()];
            let sigma = self.run_sigma[i];
            let want_rows = !matches!(want, Want::Sse);
            // sin ωτ and cos ωτ by the turntable model's block recurrence (exact sin_cos every 64
            // samples, or every sample off a uniform grid).
            for_each_rotation(&run.time_s, mid, geo.omega, 0.0, |s, s1, c1| {
                if !run.keep[s] {
                    return;
                }
                let tau = run.time_s[s] - mid;
                let delta = run_offset_at(p, o, tau);
                if !want_rows {
                    let u = sensor.linear_response(geo.force_at(s1, c1), delta);
                    for k in 0..3 {
                        let r = (u[k] + sensor.quadratic_per_mps2[k] * u[k] * u[k] - run.accel_mps2[k][s])
                            / sigma[k];
                        sse += r * r;
                    }
                    return;
                }
                let (force, d) = geo.force_and_derivatives_at(tau, s1, c1);
                let skewed = sensor.skewed(force);
                let u: [f64; 3] =
                    std::array::from_fn(|k| sensor.bias_mps2[k] + delta[k] + scale[k] * skewed[k]);
                for k in 0..3 {
                    let q = sensor.quadratic_per_mps2[k];
                    let w = 1.0 / sigma[k];
                    let r = (u[k] + q * u[k] * u[k] - run.accel_mps2[k][s]) * w;
                    let slope = (1.0 + 2.0 * q * u[k]) * w;
                    model_row(&mut row, k, &sensor, slope, w, u[k], &force, &d);
                    row[SENSOR_PARAMS + GEOMETRY + k] = slope;
                    row[SENSOR_PARAMS + GEOMETRY + 3 + k] = slope * tau;
                    match &mut want {
                        Want::Meat(_) => {
                            for (b, v) in block.iter_mut().zip(&row) {
                                *b += v * r;
                            }
                        }
                        _ => local.add_row(&row, r),
                    }
                }
                in_block += 1;
                if in_block == self.block_samples[i] {
                    if let Want::Meat(meat) = &mut want {
                        add_outer(meat, &index, &block);
                    }
                    block.fill(0.0);
                    in_block = 0;
                }
            });
            if in_block > 0 {
                if let Want::Meat(meat) = &mut want {
                    add_outer(meat, &index, &block);
                }
            }
            // Priors: radius within its tolerance, the run's bias offset within the instability.
            let entry = &run.entry;
            sse += want.add_prior(o, p[o] - entry.radius_m, entry.radius_tol_m);
            sse += want.add_prior(o + 5, p[o + 5], self.mount_tilt_sigma);
            sse += want.add_prior(o + 6, p[o + 6], self.mount_tilt_sigma);
            for k in 0..3 {
                sse += want.add_prior(o + GEOMETRY + k, p[o + GEOMETRY + k], self.bias_sigma);
            }
            if let Want::Normal(jtj, jtr) = &mut want {
                local.scatter(jtj, jtr);
                sse += local.sse;
            }
        }
        let n_runs = self.runs.len();
        let n_poses = self.poses.len();
        for pi in 0..self.poses.len() {
            if matches!(want, Want::Sse) {
                sse += self
                    .pose_residual(p, pi)
                    .iter()
                    .zip(&self.pose_sigma[pi])
                    .map(|(r, sigma)| (r / sigma).powi(2))
                    .sum::<f64>();
                continue;
            }
            let index = self.pose_index(pi);
            let mut local = LocalSystem::new(index.clone());
            let mut block = vec![0.0; index.len()];
            self.pose_rows(p, &sensor, pi, |_, row, r| {
                local.add_row(row, r);
                for (b, v) in block.iter_mut().zip(row) {
                    *b += v * r;
                }
            });
            match &mut want {
                Want::Normal(jtj, jtr) => {
                    local.scatter(jtj, jtr);
                    sse += local.sse;
                }
                Want::Meat(meat) => add_outer(meat, &index, &block),
                Want::Sse => {}
            }
        }
        // Weak priors on the sensor's terms (0 ± a datasheet-sized width): where the campaign says
        // nothing they keep a term near zero instead of wandering; where it speaks they are
        // negligible.
        for k in 0..SENSOR_PARAMS {
            if !self.sensor_free[k] {
                continue;
            }
            sse += want.add_prior(k, p[k], self.sensor_prior_sd[k / 3]);
        }
        // Each still session's bias offset within the instability, and its drift rate within the
        // instability per SESSION_DRIFT_S (poses alone say little about a slope).
        for session in 0..sessions(self.poses) {
            let so = session_offset(n_runs, n_poses, session);
            for k in 0..SESSION_PARAMS {
                let param = so + k;
                let sigma = if k < 3 {
                    self.bias_sigma
                } else {
                    self.bias_sigma / SESSION_DRIFT_S
                };
                sse += want.add_prior(param, p[param], sigma);
            }
        }
        sse
    }
}

fn add_outer(meat: &mut Mat<f64>, index: &[usize], score: &[f64]) {
    for (a, &i) in index.iter().enumerate() {
        if score[a] == 0.0 {
            continue;
        }
        for (b, &j) in index.iter().enumerate() {
            meat[(i, j)] += score[a] * score[b];
        }
    }
}

pub(crate) fn mid_time(t: &[f64]) -> f64 {
    match (t.first(), t.last()) {
        (Some(a), Some(b)) => 0.5 * (a + b),
        _ => 0.0,
    }
}

impl NormalEquations for JointProblem<'_> {
    fn n_params(&self) -> usize {
        JointProblem::n_params(self)
    }
    fn sse(&self, p: &[f64]) -> f64 {
        self.evaluate(p, Want::Sse)
    }
    fn normal_equations(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64 {
        self.evaluate(p, Want::Normal(jtj, jtr))
    }
}

/// The rotation rate and sense that best demodulate the horizontal readings (mounting frame
/// m_x + i m_y = G e^{i(ψ − σωτ)} + constant), scanned within ±25 % of the nominal rate and then
/// refined by golden section. Returns (ω, σ, amplitude G, ψ).
pub(crate) fn demodulate(
    time_s: &[f64],
    horizontal: &[[f64; 2]],
    nominal_radps: f64,
) -> (f64, f64, f64, f64) {
    let n = horizontal.len().max(1) as f64;
    let mid = mid_time(time_s);
    let mean = [0, 1].map(|c| horizontal.iter().map(|h| h[c]).sum::<f64>() / n);
    let amplitude = |w: f64, sigma: f64| -> (f64, f64) {
        let (mut re, mut im) = (0.0, 0.0);
        for (h, &t) in horizontal.iter().zip(time_s) {
            let (x, y) = (h[0] - mean[0], h[1] - mean[1]);
            let (sn, cs) = (sigma * w * (t - mid)).sin_cos();
            re += x * cs - y * sn;
            im += x * sn + y * cs;
        }
        ((re * re + im * im).sqrt() / n, im.atan2(re))
    };
    let span = match (time_s.first(), time_s.last()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => 1.0,
    };
    let step = 0.5 / span;
    let (lo, hi) = (0.75 * nominal_radps, 1.25 * nominal_radps);
    // The coarse scan advances the phasor by the median step and re-anchors it exactly every
    // SCAN_BLOCK samples (one sin_cos per block, not per sample), and sums both senses at once;
    // the refinement below is exact.
    let dt = crate::input::recording::sample_interval(time_s);
    let centred: Vec<[f64; 2]> = horizontal
        .iter()
        .map(|h| [h[0] - mean[0], h[1] - mean[1]])
        .collect();
    let scan = |w: f64| -> [f64; 2] {
        let (step_s, step_c) = (w * dt).sin_cos();
        let (mut pos, mut neg) = ([0.0f64; 2], [0.0f64; 2]);
        for (block, chunk) in centred.chunks(SCAN_BLOCK).enumerate() {
            let (mut sn, mut cs) = (w * (time_s[block * SCAN_BLOCK] - mid)).sin_cos();
            for h in chunk {
                let (x, y) = (h[0], h[1]);
                pos[0] += x * cs - y * sn;
                pos[1] += x * sn + y * cs;
                neg[0] += x * cs + y * sn;
                neg[1] += y * cs - x * sn;
                (sn, cs) = (sn * step_c + cs * step_s, cs * step_c - sn * step_s);
            }
        }
        [pos[0].hypot(pos[1]) / n, neg[0].hypot(neg[1]) / n]
    };
    let mut best = (0.0, nominal_radps, 1.0);
    let mut w = lo;
    while w <= hi {
        let [a_pos, a_neg] = if dt.is_finite() && dt > 0.0 {
            scan(w)
        } else {
            [amplitude(w, 1.0).0, amplitude(w, -1.0).0]
        };
        for (a, sigma) in [(a_pos, 1.0), (a_neg, -1.0)] {
            if a > best.0 {
                best = (a, w, sigma);
            }
        }
        w += step;
    }
    let (_, w0, sigma) = best;
    let w = golden_section_max(|w| amplitude(w, sigma).0, w0 - step, w0 + step, 40);
    let (g, psi) = amplitude(w, sigma);
    (w, sigma, g, psi)
}

/// Starting values of a run's geometry from its readings in its mounting frame, and the rotation
/// sense σ (given, or found by demodulation).
pub fn run_start(run: &RunInput, gravity: f64) -> ([f64; RUN_PARAMS], f64) {
    let found = run.demodulated();
    let sigma = run.entry.direction.map_or(found.sigma, Direction::sign);
    let [cx, cy] = found.constant;
    let tilt = (found.amplitude / gravity).clamp(0.0, 0.5).asin();
    // The constant is −ω² r turned by β; with no centripetal level β is left at 0.
    let beta = if (cx * cx + cy * cy).sqrt() > 1e-3 {
        (-cy).atan2(-cx)
    } else {
        0.0
    };
    let mut start = [0.0; RUN_PARAMS];
    start[0] = run.entry.radius_m;
    start[1] = found.rate_radps;
    start[2] = tilt.max(1e-4);
    start[3] = found.phase - beta;
    start[4] = beta;
    (start, sigma)
}

/// The body ← platter rotation Q·Rx(ε₁)Ry(ε₂)Rz(β) of a run's parameters.
pub(crate) fn rotation_of(q: &M3, run: &[f64]) -> M3 {
    RunGeometry::new(q, run, 1.0, 1.0).qr
}

/// Noise per axis from first differences (white noise survives differencing; slow motion does
/// not), m/s².
pub fn difference_noise(accel: &[Vec<f64>; 3], keep: &[bool]) -> [f64; 3] {
    std::array::from_fn(|k| {
        let a = &accel[k];
        let (mut sum, mut n) = (0.0f64, 0.0f64);
        for s in 1..a.len() {
            if keep[s] && keep[s - 1] {
                let d = a[s] - a[s - 1];
                sum += d * d;
                n += 1.0;
            }
        }
        (sum / n.max(1.0) / 2.0).sqrt().max(1e-6)
    })
}

/// Fits the sensor model and every run and pose jointly.
pub fn fit_joint(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    observer: &Observer,
) -> Result<JointFit, JointError> {
    fit_joint_from(runs, poses, settings, None, observer)
}

/// As [`fit_joint`], starting from another fit of the same runs and poses (its parameters, with
/// the terms this fit does not estimate set to zero): a nested model then starts in the basin the
/// larger one found.
pub fn fit_joint_from(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    start: Option<&JointFit>,
    observer: &Observer,
) -> Result<JointFit, JointError> {
    fit_joint_with(runs, poses, settings, start, true, observer)
}

/// One run's geometry alone, as a rigid platter would move a perfect sensor: radius within its
/// tolerance, rate, platter tilt, mount rotation within its prior, wow, and no bias offset or
/// drift (held at zero). What this fit cannot explain is a sensor error it could not absorb:
/// the truth-free check of a corrected run.
pub(crate) fn fit_run_geometry(run: &RunInput, settings: &JointSettings) -> Result<JointFit, JointError> {
    let settings = JointSettings {
        terms: SensorTerms::NONE,
        ..settings.clone()
    };
    fit_joint_with(
        std::slice::from_ref(run),
        &[],
        &settings,
        None,
        false,
        &crate::progress::silent,
    )
}

fn fit_joint_with(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    start: Option<&JointFit>,
    run_offsets_free: bool,
    observer: &Observer,
) -> Result<JointFit, JointError> {
    if runs.is_empty() && poses.is_empty() {
        return Err(JointError::Empty);
    }
    for (name, value, ok, why) in [
        (
            "gravity_mps2",
            settings.gravity_mps2,
            settings.gravity_mps2 > 0.0,
            "must be positive",
        ),
        (
            "bias_instability_mps2",
            settings.bias_instability_mps2,
            settings.bias_instability_mps2 > 0.0,
            "must be positive",
        ),
        (
            "mount_tilt_rad",
            settings.mount_tilt_rad,
            settings.mount_tilt_rad > 0.0,
            "must be positive",
        ),
        (
            "block_s",
            settings.block_s,
            settings.block_s > 0.0,
            "must be positive",
        ),
    ] {
        if !(ok && value.is_finite()) {
            return Err(JointError::Setting { name, value, why });
        }
    }
    for run in runs {
        let used = run.keep.iter().filter(|&&k| k).count();
        if used < 100 {
            return Err(JointError::Run {
                name: run.name.clone(),
                why: format!("{used} usable samples; a turntable run needs at least 100"),
            });
        }
    }
    let g = settings.gravity_mps2;
    let mountings: Vec<M3> = runs
        .iter()
        .map(|r| mounting_matrix(r.entry.out, r.entry.up))
        .collect();
    let mut p = vec![
        0.0;
        SENSOR_PARAMS
            + runs.len() * RUN_PARAMS
            + poses.len() * POSE_PARAMS
            + SESSION_PARAMS * sessions(poses)
    ];
    let mut directions = Vec::with_capacity(runs.len());
    if let Some(previous) = start.filter(|f| f.state.params.len() == p.len()) {
        // A nested model starts where the full one ended (the runs' own starts are not needed).
        p.copy_from_slice(&previous.state.params);
        directions.clone_from(&previous.state.directions);
        for k in 0..SENSOR_PARAMS {
            if !settings.terms.free(k) {
                p[k] = 0.0;
            }
        }
    } else {
        for (i, run) in runs.iter().enumerate() {
            let (start, direction) = run_start(run, g);
            p[run_offset(i)..run_offset(i) + RUN_PARAMS].copy_from_slice(&start);
            directions.push(direction);
        }
    }
    let block_samples = runs
        .iter()
        .map(|r| {
            let rate = crate::input::recording::sample_interval(&r.time_s);
            ((settings.block_s / rate).round() as usize).max(10)
        })
        .collect();
    let mut problem = JointProblem {
        runs,
        poses,
        gravity: g,
        bias_sigma: settings.bias_instability_mps2,
        mount_tilt_sigma: settings.mount_tilt_rad,
        sensor_prior_sd: settings.sensor_prior_sd,
        sensor_free: std::array::from_fn(|k| settings.terms.free(k)),
        directions,
        mountings,
        pose_frames: poses.iter().map(|p| PoseFrame::new(p.mean_mps2)).collect(),
        pose_sigma: poses.iter().map(|p| p.sigma_mean_mps2).collect(),
        pose_tau: session_times(poses),
        run_sigma: runs
            .iter()
            .map(|r| difference_noise(&r.accel_mps2, &r.keep))
            .collect(),
        block_samples,
    };
    let run_params_end = run_offset(runs.len());
    let is_run_offset = |k: usize| {
        (SENSOR_PARAMS..run_params_end).contains(&k) && (k - SENSOR_PARAMS) % RUN_PARAMS >= GEOMETRY
    };
    let free: Vec<bool> = (0..p.len())
        .map(|k| {
            if k < SENSOR_PARAMS {
                settings.terms.free(k)
            } else {
                run_offsets_free || !is_run_offset(k)
            }
        })
        .collect();
    let options = LmOptions {
        max_iterations: settings.max_iterations,
        cost_tolerance: 1e-12,
        step_tolerance: 1e-10,
        gradient_tolerance: 0.0,
        ..LmOptions::default()
    };
    // First pass with the white-noise weights, then reweight each run by its residual RMS (which
    // includes drift and unmodelled motion) and solve again from there.
    let first = levenberg_marquardt_normal(&problem, &p, Some(&free), &options, observer);
    p = first.params;
    for i in 0..runs.len() {
        let mut sums = [0.0f64; 3];
        let mut n = 0.0f64;
        problem.run_residuals(&p, i, |_, r| {
            for k in 0..3 {
                sums[k] += r[k] * r[k];
            }
            n += 1.0;
        });
        problem.run_sigma[i] = sums.map(|s| (s / n.max(1.0)).sqrt().max(1e-6));
    }
    // Poses scatter by more than their means' noise when the bias wanders between them: a variance
    // component per session and axis, from the residuals divided by the share of their variance
    // the fit leaves them (1 − leverage; about 1/3 when only a pose's own two angles took theirs,
    // far less when the poses alone determine the sensor).
    let leverage = problem.pose_leverage(&p, &first.jtj, &free);
    let walk = bias_random_walk(poses);
    for session in 0..sessions(poses) {
        let members: Vec<usize> = (0..poses.len())
            .filter(|&i| poses[i].session == session)
            .collect();
        if members.len() < 2 {
            continue;
        }
        // A random walk of rate D leaves, about the session's fitted line over its span T, a
        // mean squared deviation of D·T/15 at the poses.
        let span = members
            .iter()
            .map(|&i| poses[i].time_s)
            .fold(f64::NEG_INFINITY, f64::max)
            - members
                .iter()
                .map(|&i| poses[i].time_s)
                .fold(f64::INFINITY, f64::min);
        let walked = walk.map_or(0.0, |d| d * span / 15.0);
        let mut extra = [0.0f64; 3];
        for &i in &members {
            let r = problem.pose_residual(&p, i);
            for k in 0..3 {
                // A residual keeps 1 − h of its variance; the rest went into the fit.
                let kept = match &leverage {
                    Some(h) => (1.0 - h[i][k]).max(MIN_KEPT_VARIANCE),
                    None => 1.0 / 3.0,
                };
                extra[k] += r[k] * r[k] / kept - poses[i].sigma_mean_mps2[k].powi(2);
            }
        }
        for &i in &members {
            for k in 0..3 {
                let component = (extra[k] / members.len() as f64).max(walked);
                problem.pose_sigma[i][k] = (poses[i].sigma_mean_mps2[k].powi(2) + component).sqrt();
            }
        }
    }
    // The second pass starts at the first one's minimum: little damping, or the strongly
    // correlated bias, offset and drift directions crawl.
    let second = LmOptions {
        initial_damping: 1e-6,
        // The residuals are now weighted to about unit variance, so these are standard errors:
        // stop where no Gauss–Newton step would move a parameter by 1e-8 of its own. (The first
        // pass only sets the weights, which its last 1e-5 SE hardly move.)
        polish_se_tolerance: 1e-8,
        ..options.clone()
    };
    let report = levenberg_marquardt_normal(&problem, &p, Some(&free), &second, observer);
    let p = report.params;

    // Robust covariance over the free parameters.
    let n = p.len();
    let mut meat = Mat::<f64>::zeros(n, n);
    problem.evaluate(&p, Want::Meat(&mut meat));
    let index: Vec<usize> = (0..n).filter(|&k| free[k]).collect();
    let cov = sandwich(&report.jtj, &meat, &index);
    let m_rows: usize = runs
        .iter()
        .map(|r| 3 * r.keep.iter().filter(|&&k| k).count())
        .sum::<usize>()
        + 3 * poses.len();
    let dof = m_rows.saturating_sub(index.len());
    let se = |k: usize| -> Option<f64> {
        let pos = index.iter().position(|&i| i == k)?;
        let v = cov.as_ref()?[(pos, pos)];
        (v.is_finite() && v >= 0.0).then(|| v.sqrt())
    };
    let param = |name: &str, k: usize| JointParam {
        name: name.to_string(),
        value: p[k],
        std_error: se(k),
        free: free[k],
    };
    let sensor_params = (0..SENSOR_PARAMS)
        .map(|k| param(SENSOR_PARAM_NAMES[k], k))
        .collect();
    let run_fits = runs
        .iter()
        .enumerate()
        .map(|(i, run)| {
            let o = run_offset(i);
            let mut sums = [0.0f64; 3];
            let mut count = 0usize;
            problem.run_residuals(&p, i, |_, r| {
                for k in 0..3 {
                    sums[k] += r[k] * r[k];
                }
                count += 1;
            });
            RunFit {
                name: run.name.clone(),
                direction: Direction::from_sign(problem.directions[i]),
                params: (0..RUN_PARAMS)
                    .map(|j| param(RUN_PARAM_NAMES[j], o + j))
                    .collect(),
                residual_rms_mps2: sums.map(|s| (s / count.max(1) as f64).sqrt()),
                samples_used: count,
            }
        })
        .collect();
    let pose_fits = poses
        .iter()
        .enumerate()
        .map(|(pi, pose)| {
            let o = pose_offset(runs.len(), pi);
            PoseFit {
                name: pose.name.clone(),
                params: (0..POSE_PARAMS)
                    .map(|j| param(POSE_PARAM_NAMES[j], o + j))
                    .collect(),
                specific_force_mps2: problem.pose_frames[pi].force(p[o], p[o + 1], g).0,
            }
        })
        .collect();
    let blocks = problem.block_samples.first().copied().unwrap_or(0);
    Ok(JointFit {
        sensor: SensorModel::from_params(&p),
        sensor_params,
        runs: run_fits,
        poses: pose_fits,
        terms: settings.terms,
        chi2: report.sse,
        dof,
        iterations: first.iterations + report.iterations,
        stop: report.stop,
        covariance: format!(
            "robust sandwich H⁻¹SH⁻¹, S from scores summed over blocks of {:.1} s ({} samples) of each run, each still pose and each prior a block of its own (batch-means HAC); each pose weighted by its mean's error and the bias's wander between poses ({})",
            settings.block_s,
            blocks,
            match walk {
                Some(d) => format!("random walk {d:.2e} (m/s²)²/s, measured within the poses"),
                None => "from the first pass's pose residuals".into(),
            }
        ),
        state: FitState {
            params: p,
            directions: problem.directions.clone(),
            mountings: problem.mountings.clone(),
            gravity: g,
            covariance: cov,
            free_index: index,
        },
    })
}

/// H⁻¹ S H⁻¹ over the given parameters, with the small-sample factor G/(G − 1) omitted (blocks
/// are many); `None` when H is singular there.
fn sandwich(h: &Mat<f64>, s: &Mat<f64>, index: &[usize]) -> Option<Mat<f64>> {
    let n = index.len();
    let ss = Mat::from_fn(n, n, |a, b| s[(index[a], index[b])]);
    let h_inv = inverse_on(h, index)?;
    let left = &h_inv * &ss;
    Some(&left * &h_inv)
}

/// The inverse of the symmetric positive definite `h` restricted to `index` (rows and columns);
/// `None` when it is singular.
fn inverse_on(h: &Mat<f64>, index: &[usize]) -> Option<Mat<f64>> {
    let n = index.len();
    let hs = Mat::from_fn(n, n, |a, b| h[(index[a], index[b])]);
    // Scale to unit diagonal for a well-conditioned factorisation.
    let d: Vec<f64> = (0..n).map(|a| hs[(a, a)].max(f64::MIN_POSITIVE).sqrt()).collect();
    let scaled = Mat::from_fn(n, n, |a, b| hs[(a, b)] / (d[a] * d[b]));
    let llt = scaled.llt(Side::Lower).ok()?;
    let inv = llt.solve(Mat::<f64>::identity(n, n));
    Some(Mat::from_fn(n, n, |a, b| inv[(a, b)] / (d[a] * d[b])))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mounting_matrix_is_a_right_handed_rotation() {
        for out in ["+x", "-x", "+y", "-y", "+z", "-z"] {
            for up in ["+x", "-x", "+y", "-y", "+z", "-z"] {
                let (o, u) = (SignedAxis::parse(out).unwrap(), SignedAxis::parse(up).unwrap());
                if o.axis == u.axis {
                    continue;
                }
                let q = mounting_matrix(o, u);
                let det = q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1])
                    - q[0][1] * (q[1][0] * q[2][2] - q[1][2] * q[2][0])
                    + q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
                assert_eq!(det, 1.0, "{out} {up}");
                assert_eq!(apply(&q, &[1.0, 0.0, 0.0]), o.vector());
                assert_eq!(apply(&q, &[0.0, 0.0, 1.0]), u.vector());
            }
        }
    }

    /// The platter angle's sine and cosine, built from sin ωτ, cos ωτ and the small wow rotation,
    /// equal a direct `sin_cos` of the whole angle, for small and large wow, both senses and long
    /// recordings (large ωτ).
    #[test]
    fn platter_angle_from_the_rotation_equals_direct_trigonometry() {
        let q = mounting_matrix(SignedAxis::parse("+x").unwrap(), SignedAxis::parse("+z").unwrap());
        for (wc, ws) in [(0.0, 0.0), (2e-4, -3e-4), (7e-4, 6e-4), (0.02, -0.01), (0.3, 0.2)] {
            for sigma in [1.0, -1.0] {
                for phase in [-2.9, 0.0, 0.4, 3.1] {
                    let run = [0.1, 4.71, 0.01, phase, 0.0, 0.0, 0.0, wc, ws, 0.0, 0.0, 0.0];
                    let geo = RunGeometry::new(&q, &run, sigma, 9.81);
                    for tau in [-3600.0, -61.3, -0.01, 0.0, 0.37, 59.9, 7200.5] {
                        let k = geo.kinematics(tau);
                        let w = 4.71;
                        let (s1, c1) = (w * tau).sin_cos();
                        let angle = w * tau + wc * s1 - ws * c1;
                        let (s, c) = (phase - sigma * angle).sin_cos();
                        // The direct form rounds ωτ (up to 3e4 rad) before its sine: ~1e-12.
                        let tolerance = 1e-15 * (w * tau).abs().max(1.0) * 4.0;
                        assert!(
                            (k.s - s).abs() < tolerance && (k.c - c).abs() < tolerance,
                            "{wc} {ws} {sigma} {phase} {tau}: {} {} vs {s} {c}",
                            k.s,
                            k.c
                        );
                    }
                }
            }
        }
        for x in [-9.99e-4, -1e-5, 0.0, 3e-7, 5e-4, 9.99e-4] {
            let (s, c) = small_sin_cos(x);
            assert!(
                (s - x.sin()).abs() <= 2.3e-16 * x.abs() && (c - x.cos()).abs() <= 2.3e-16,
                "{x}"
            );
        }
    }

    #[test]
    fn run_derivatives_match_finite_differences() {
        let q = mounting_matrix(SignedAxis::parse("-y").unwrap(), SignedAxis::parse("+x").unwrap());
        let base = [
            0.09, 3.5, 0.02, 0.7, 0.3, 0.01, -0.02, 0.002, -0.001, 0.0, 0.0, 0.0,
        ];
        let tau = 3.7;
        let (_, d) = RunGeometry::new(&q, &base, -1.0, 9.81).force_and_derivatives(tau);
        for j in 0..GEOMETRY {
            let h = 1e-6;
            let mut plus = base;
            let mut minus = base;
            plus[j] += h;
            minus[j] -= h;
            let fp = RunGeometry::new(&q, &plus, -1.0, 9.81).force(tau);
            let fm = RunGeometry::new(&q, &minus, -1.0, 9.81).force(tau);
            for k in 0..3 {
                let numeric = (fp[k] - fm[k]) / (2.0 * h);
                assert!(
                    (numeric - d[j][k]).abs() < 1e-6,
                    "param {j} axis {k}: {numeric} vs {}",
                    d[j][k]
                );
            }
        }
    }

    #[test]
    fn pose_derivatives_match_finite_differences() {
        let frame = PoseFrame::new([0.3, -9.7, 1.1]);
        let (_, d) = frame.force(0.02, -0.01, 9.81);
        for j in 0..2 {
            let h = 1e-7;
            let at = |x: f64| {
                let (a, b) = if j == 0 {
                    (0.02 + x, -0.01)
                } else {
                    (0.02, -0.01 + x)
                };
                frame.force(a, b, 9.81).0
            };
            let (fp, fm) = (at(h), at(-h));
            for k in 0..3 {
                assert!(((fp[k] - fm[k]) / (2.0 * h) - d[j][k]).abs() < 1e-6);
            }
        }
    }
}
