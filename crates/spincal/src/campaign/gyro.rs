//! The gyroscope from a campaign: still poses give its bias and the bias's drift, turntable runs
//! its sensitivity. A record player is a rate table: the joint fit measures each run's rotation rate
//! from the accelerometer (the tilt's once-per-revolution gravity), and the rotation is about the
//! spindle, whose direction in the body frame the fit knows from the mounting and its tilts.
//!
//! ```text
//! m = b + K ω + δ_rec + d_rec τ + noise
//! ```
//! - m: gyro reading, ω: true angular rate in the accelerometer's body frame (the frame the joint
//!   fit defines, `correctors::physical`), rad/s;
//! - b: bias (3), K: sensitivity (9; diagonal 1 + scale error, off-diagonal cross-axis terms);
//! - δ_rec, d_rec: each recording's offset from b and its drift rate (τ: time from the recording's
//!   middle), with priors of the bias instability (per 100 s for the rate), as the accelerometer's.
//!
//! Given the joint fit, the model is linear and its axes separate: per axis one weighted least
//! squares, solved twice (the second pass weights each run by its residual RMS). Standard errors
//! are a block sandwich (5 s blocks of each run, each pose a block), plus what the joint fit's own
//! uncertainty in each run's rate, wow and mount tilts carries over (delta method). The Earth's
//! rotation (≤ 7.3·10⁻⁵ rad/s) is not modelled: it enters the bias.
//!
//! Only what the campaign determines is kept: a term whose standard error moves a reading at the
//! reference rate by more than the tolerance is fixed at its nominal value (the prior's centre:
//! bias 0, K's diagonal 1, off-diagonal 0) and the rest refitted with it fixed, until every free
//! term is determined; the columns no run spun are fixed first, alone, so that their leak does
//! not blur the spun column's terms. Flat runs alone, for instance, leave K's x and y columns to
//! the prior, and a term fitted from the prior and a leak through the spindle's small tilt made
//! the corrected gyro worse than raw during rotations about x or y.

// Per-axis arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use faer::prelude::Solve;
use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::campaign::joint::{mid_time, JointFit, JointParam, PoseInput, RunInput};
use crate::correctors::gyro::{GyroCorrector, GyroModel};
use crate::input::inspect::{gyro_rails_hit, gyro_saturated_mask, GYRO_SATURATED_SHARE};
use crate::metrics::{term_threshold, TERM_FALSE_ALARM};

/// Settings of the gyroscope fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GyroSettings {
    /// Standard deviation of a recording's gyro bias offset from the unit's bias, rad/s.
    pub bias_instability_radps: f64,
    /// Prior standard deviations about the ideal gyro: bias (rad/s) and each entry of K.
    pub prior_sd: [f64; 2],
    /// Length of the blocks whose scores form the robust covariance, s.
    pub block_s: f64,
    /// A parameter is "determined" when one standard error moves a reading at `reference_rate`
    /// by at most this, rad/s.
    pub determined_tolerance_radps: f64,
    /// The rate at which that is judged, rad/s (a 45 rpm platter: 4.7 rad/s).
    pub reference_rate_radps: f64,
}

impl Default for GyroSettings {
    fn default() -> Self {
        GyroSettings {
            bias_instability_radps: 0.01f64.to_radians(),
            // K within 5 % of the identity: wider than any MEMS datasheet (the MPU-6050's
            // sensitivity tolerance is ±3 %, its cross-axis ±2 %), yet narrow enough that the
            // columns flat runs cannot see (rotation about x and y) do not leak into the one
            // they can through the spindle's small tilt in the body frame.
            prior_sd: [0.2, 0.05],
            block_s: 5.0,
            determined_tolerance_radps: 0.005,
            reference_rate_radps: 4.7,
        }
    }
}

/// Per run: the rate the accelerometer measured against what the gyroscope reads.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GyroRateCheck {
    pub run: String,
    /// The joint fit's mean rotation rate (from the accelerometer), rad/s, and its standard error.
    pub accel_rate_radps: f64,
    pub accel_rate_se_radps: Option<f64>,
    /// The raw gyro reading along the spindle (mean over the run, no calibration), rad/s.
    pub raw_gyro_rate_radps: f64,
    /// The calibrated gyro's rate about the spindle (mean over the run), rad/s.
    pub calibrated_gyro_rate_radps: f64,
    /// Residual RMS per gyro axis after the fit, rad/s.
    pub residual_rms_radps: [f64; 3],
}

/// A run whose gyro is saturated (`input::inspect`'s rule): its pinned rows are left out, or,
/// when they are most of the run, its gyro is refused.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GyroRunSaturation {
    pub run: String,
    /// Samples with a pinned gyro axis, and the run's samples.
    pub samples: usize,
    pub of: usize,
    /// Each pinned axis and its rail, deg/s (the gyro's range is about ± this).
    pub axes: Vec<(char, f64)>,
    /// The run's gyro is not used at all (saturated in more than
    /// [`GYRO_SATURATED_SHARE`] of it).
    pub refused: bool,
}

impl GyroRunSaturation {
    /// The finding and what was done, in words.
    pub fn describe(&self) -> String {
        let axes: Vec<String> = self
            .axes
            .iter()
            .map(|(axis, dps)| format!("g{axis} pinned at {dps:.1} °/s"))
            .collect();
        format!(
            "{}: gyro saturated in {} of {} samples ({:.1} %; {}): {}",
            self.run,
            self.samples,
            self.of,
            100.0 * self.samples as f64 / self.of.max(1) as f64,
            axes.join(", "),
            if self.refused {
                "its gyro is not used (the platter turns faster than the gyro's range; record at a wider range or a slower speed)"
            } else {
                "those samples are left out of the gyro fit"
            }
        )
    }
}

/// The gyroscope's calibration from a campaign.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GyroFit {
    /// The refit: terms the campaign does not determine at their nominal values. Saved with
    /// the accelerometer's corrector unless no term is determined ([`GyroFit::saved_model`]).
    pub model: GyroModel,
    /// b (3) then K row by row (9) of the refit, with robust standard errors; a term left at
    /// nominal has `free: false` and no standard error.
    pub params: Vec<JointParam>,
    /// The same with every term free: the fit that decided which terms are determined.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub free_params: Vec<JointParam>,
    /// The rule that left terms at nominal, in words.
    #[serde(default)]
    pub nominal_rule: String,
    /// Per still recording (session): the bias drift rate per axis, rad/s per s.
    pub session_drift: Vec<JointParam>,
    pub rate_checks: Vec<GyroRateCheck>,
    /// Parameters this campaign does not determine, with what would.
    pub undetermined: Vec<(String, String)>,
    /// Those of them left at their nominal values (`nominal_rule`); the rest are kept, with
    /// their standard errors.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub left_at_nominal: Vec<String>,
    /// How the standard errors were formed, in words.
    pub covariance: String,
    /// Runs whose gyro saturated: rows left out, or the run's gyro refused.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub saturation: Vec<GyroRunSaturation>,
}

/// Why the gyroscope could not be calibrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GyroError {
    #[error("gyro fit setting {name} = {value}: {why}")]
    Setting {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
    #[error("{name}: the gyro columns have {found} samples but the recording {expected}")]
    Length {
        name: String,
        found: usize,
        expected: usize,
    },
    #[error("the gyro's normal equations are singular; the campaign needs still poses and turntable runs with gyro columns")]
    Singular,
    /// Every run with a gyro is saturated for most of it.
    #[error(
        "every turntable run's gyro is saturated for most of the run, so its scale cannot be measured: {0}"
    )]
    Saturated(String),
}

const AXES: [&str; 3] = ["x", "y", "z"];
/// b and the three entries of K's row, per axis.
const CORE: usize = 4;
/// A recording's drift rate prior: the bias instability per this many seconds.
const DRIFT_S: f64 = 100.0;
/// The joint fit's run parameters the platter's speed depends on (ω, w_c, w_s); the mount tilts
/// (ε₁, ε₂) enter the gyro fit as parameters with the joint fit's covariance as their prior.
const RATE_PARAMS: [usize; 3] = [1, 7, 8];
const TILT_PARAMS: [usize; 2] = [5, 6];
/// Gauss–Newton iterations (the model is linear but for K times the tilt correction).
const ITERATIONS: usize = 4;

/// The unknowns: per axis k a block of b, K row, per run (δ, d), per session (δ, d); then per run
/// the correction (Δ₁, Δ₂) to the joint fit's mount tilts, which moves the spindle in the body
/// frame and is shared by the three axes.
struct Layout {
    runs: usize,
    sessions: usize,
}

impl Layout {
    fn per_axis(&self) -> usize {
        CORE + 2 * (self.runs + self.sessions)
    }
    fn n(&self) -> usize {
        3 * self.per_axis() + 2 * self.runs
    }
    fn axis(&self, k: usize) -> usize {
        k * self.per_axis()
    }
    fn run(&self, k: usize, r: usize) -> usize {
        self.axis(k) + CORE + 2 * r
    }
    fn session(&self, k: usize, s: usize) -> usize {
        self.axis(k) + CORE + 2 * (self.runs + s)
    }
    fn tilt(&self, r: usize) -> usize {
        3 * self.per_axis() + 2 * r
    }
}

/// A run as the gyro fit sees it.
struct GyroRun<'a> {
    input: &'a RunInput,
    gyro: &'a [Vec<f64>; 3],
    /// Samples the gyro fit uses: the accelerometer's (`input.keep`) without saturated gyro rows.
    keep: Vec<bool>,
    mid: f64,
    /// Index among the joint fit's runs.
    index: usize,
    /// The joint fit's parameters of the run (possibly shifted, for the delta method).
    params: Vec<f64>,
    /// The rotation vector's direction and its derivatives with respect to the mount tilts.
    spindle: [f64; 3],
    d_spindle: [[f64; 3]; 2],
    /// The joint fit's information (inverse covariance) about the two mount tilts.
    tilt_information: [[f64; 2]; 2],
}

impl GyroRun<'_> {
    fn refresh(&mut self, joint: &JointFit) {
        self.spindle = joint.run_spindle(self.index, &self.params);
        let h = 1e-6;
        for (a, &param) in TILT_PARAMS.iter().enumerate() {
            let mut p = self.params.clone();
            p[param] += h;
            let plus = joint.run_spindle(self.index, &p);
            p[param] -= 2.0 * h;
            let minus = joint.run_spindle(self.index, &p);
            self.d_spindle[a] = std::array::from_fn(|j| (plus[j] - minus[j]) / (2.0 * h));
        }
    }

    /// The rotation vector's direction with tilt corrections `delta` (first order).
    fn direction(&self, delta: [f64; 2]) -> [f64; 3] {
        std::array::from_fn(|j| {
            self.spindle[j] + self.d_spindle[0][j] * delta[0] + self.d_spindle[1][j] * delta[1]
        })
    }
}

/// Dense normal equations over all unknowns.
struct System {
    h: Mat<f64>,
    g: Vec<f64>,
}

impl System {
    fn new(n: usize) -> System {
        System {
            h: Mat::zeros(n, n),
            g: vec![0.0; n],
        }
    }

    /// One weighted row: `(index, ∂prediction)` pairs, residual `e` (observed − predicted).
    fn add(&mut self, row: &[(usize, f64)], e: f64, inv_sigma: f64) {
        let w = inv_sigma * inv_sigma;
        for &(a, va) in row {
            self.g[a] += va * e * w;
            for &(b, vb) in row {
                self.h[(a, b)] += va * vb * w;
            }
        }
    }

    /// A Gaussian prior `mean ± sd` on unknown `k` at its current value.
    fn prior(&mut self, k: usize, value: f64, mean: f64, sd: f64) {
        self.h[(k, k)] += 1.0 / (sd * sd);
        self.g[k] += (mean - value) / (sd * sd);
    }
}

/// A pose: its session (renumbered), mean and standard error per axis, time from its session's
/// middle.
type PoseRow = (usize, [f64; 3], [f64; 3], f64);

/// Everything the fit needs.
struct Problem<'a> {
    runs: Vec<GyroRun<'a>>,
    poses: Vec<PoseRow>,
    layout: Layout,
    settings: &'a GyroSettings,
    joint: &'a JointFit,
    /// Per run and axis, the residual noise, rad/s.
    run_sigma: Vec<[f64; 3]>,
    /// Unknowns held at their current values (terms left at nominal).
    fixed: Vec<bool>,
}

impl Problem<'_> {
    /// Visits every kept sample of run `r` with its residual per axis and the derivatives of each
    /// axis's prediction (sparse rows), at unknowns `x`.
    fn run_rows(&self, r: usize, x: &[f64], mut each: impl FnMut(usize, [f64; 3], &[[(usize, f64); 8]; 3])) {
        let l = &self.layout;
        let run = &self.runs[r];
        let t0 = l.tilt(r);
        let delta = [x[t0], x[t0 + 1]];
        let u = run.direction(delta);
        for (s, &t) in run.input.time_s.iter().enumerate() {
            if !run.keep[s] {
                continue;
            }
            let tau = t - run.mid;
            let rate = self.joint.run_rate(run.index, &run.params, tau);
            let w = u.map(|v| rate * v);
            let mut rows = [[(0usize, 0.0f64); 8]; 3];
            let mut residual = [0.0; 3];
            for k in 0..3 {
                let a = l.axis(k);
                let o = l.run(k, r);
                let kr = [x[a + 1], x[a + 2], x[a + 3]];
                let predicted = x[a] + kr[0] * w[0] + kr[1] * w[1] + kr[2] * w[2] + x[o] + x[o + 1] * tau;
                residual[k] = run.gyro[k][s] - predicted;
                let d_tilt = |i: usize| rate * (0..3).map(|j| kr[j] * run.d_spindle[i][j]).sum::<f64>();
                rows[k] = [
                    (a, 1.0),
                    (a + 1, w[0]),
                    (a + 2, w[1]),
                    (a + 3, w[2]),
                    (o, 1.0),
                    (o + 1, tau),
                    (t0, d_tilt(0)),
                    (t0 + 1, d_tilt(1)),
                ];
            }
            each(s, residual, &rows);
        }
    }

    /// Visits every pose with its residual per axis and derivative rows.
    fn pose_rows(&self, x: &[f64], mut each: impl FnMut(usize, [f64; 3], &[[(usize, f64); 3]; 3])) {
        let l = &self.layout;
        for (p, &(session, mean, _, tau)) in self.poses.iter().enumerate() {
            let mut rows = [[(0usize, 0.0f64); 3]; 3];
            let mut residual = [0.0; 3];
            for k in 0..3 {
                let (a, o) = (l.axis(k), l.session(k, session));
                residual[k] = mean[k] - (x[a] + x[o] + x[o + 1] * tau);
                rows[k] = [(a, 1.0), (o, 1.0), (o + 1, tau)];
            }
            each(p, residual, &rows);
        }
    }

    /// The priors at `x`, into `sys`.
    fn priors(&self, sys: &mut System, x: &[f64]) {
        let l = &self.layout;
        let [bias_sd, k_sd] = self.settings.prior_sd;
        let sd = self.settings.bias_instability_radps;
        for k in 0..3 {
            let a = l.axis(k);
            sys.prior(a, x[a], 0.0, bias_sd);
            for j in 0..3 {
                sys.prior(a + 1 + j, x[a + 1 + j], if j == k { 1.0 } else { 0.0 }, k_sd);
            }
            for r in 0..l.runs {
                let o = l.run(k, r);
                sys.prior(o, x[o], 0.0, sd);
                sys.prior(o + 1, x[o + 1], 0.0, sd / DRIFT_S);
            }
            for s in 0..l.sessions {
                let o = l.session(k, s);
                sys.prior(o, x[o], 0.0, sd);
                sys.prior(o + 1, x[o + 1], 0.0, sd / DRIFT_S);
            }
        }
        for (r, run) in self.runs.iter().enumerate() {
            let t = l.tilt(r);
            let info = run.tilt_information;
            for a in 0..2 {
                for b in 0..2 {
                    sys.h[(t + a, t + b)] += info[a][b];
                    sys.g[t + a] -= info[a][b] * x[t + b];
                }
            }
        }
    }

    fn normal_equations(&self, x: &[f64]) -> System {
        let mut sys = System::new(self.layout.n());
        for r in 0..self.runs.len() {
            let sigma = self.run_sigma[r];
            self.run_rows(r, x, |_, e, rows| {
                for k in 0..3 {
                    sys.add(&rows[k], e[k], 1.0 / sigma[k]);
                }
            });
        }
        self.pose_rows(x, |p, e, rows| {
            let sigma = self.poses[p].2;
            for k in 0..3 {
                sys.add(&rows[k], e[k], 1.0 / sigma[k]);
            }
        });
        self.priors(&mut sys, x);
        sys
    }

    /// Gauss–Newton from `x`.
    fn solve(&self, mut x: Vec<f64>, iterations: usize) -> Result<(Vec<f64>, Mat<f64>), GyroError> {
        let n = self.layout.n();
        for _ in 0..iterations {
            let mut sys = self.normal_equations(&x);
            self.pin(&mut sys);
            let llt = sys.h.llt(faer::Side::Lower).map_err(|_| GyroError::Singular)?;
            let step = llt.solve(Mat::from_fn(n, 1, |i, _| sys.g[i]));
            for i in 0..n {
                x[i] += step[(i, 0)];
            }
            if !x.iter().all(|v| v.is_finite()) {
                return Err(GyroError::Singular);
            }
        }
        let mut sys = self.normal_equations(&x);
        self.pin(&mut sys);
        let llt = sys.h.llt(faer::Side::Lower).map_err(|_| GyroError::Singular)?;
        let mut h_inv = llt.solve(Mat::<f64>::identity(n, n));
        // A fixed unknown has no variance (its unit pivot is bookkeeping).
        for i in (0..n).filter(|&i| self.fixed[i]) {
            h_inv[(i, i)] = 0.0;
        }
        Ok((x, h_inv))
    }

    /// Fixed unknowns out of the normal equations: their step is zero and they inform no other.
    fn pin(&self, sys: &mut System) {
        let n = self.layout.n();
        for i in (0..n).filter(|&i| self.fixed[i]) {
            for j in 0..n {
                sys.h[(i, j)] = 0.0;
                sys.h[(j, i)] = 0.0;
            }
            sys.h[(i, i)] = 1.0;
            sys.g[i] = 0.0;
        }
    }

    /// The two passes from `x0` (white-noise weights, then each run weighted by its residual
    /// RMS, which includes drift and unmodelled motion) and the robust covariance.
    fn fit(&mut self, x0: Vec<f64>) -> Result<(Vec<f64>, Mat<f64>), GyroError> {
        self.run_sigma = self
            .runs
            .iter()
            .map(|run| crate::campaign::joint::difference_noise(run.gyro, &run.keep).map(|v| v.max(1e-9)))
            .collect();
        let (x, _) = self.solve(x0, ITERATIONS)?;
        self.run_sigma = self.residual_rms(&x);
        let (x, h_inv) = self.solve(x, ITERATIONS)?;
        let meat = self.meat(&x);
        let mut cov = &h_inv * &meat * &h_inv;
        self.add_rate_uncertainty(&x, &mut cov)?;
        Ok((x, cov))
    }

    /// Per run and axis, the residual RMS at `x`.
    fn residual_rms(&self, x: &[f64]) -> Vec<[f64; 3]> {
        (0..self.runs.len())
            .map(|r| {
                let (mut sums, mut count) = ([0.0f64; 3], 0.0f64);
                self.run_rows(r, x, |_, e, _| {
                    for k in 0..3 {
                        sums[k] += e[k] * e[k];
                    }
                    count += 1.0;
                });
                sums.map(|v| (v / count.max(1.0)).sqrt().max(1e-9))
            })
            .collect()
    }

    /// Σ over blocks of s sᵀ: runs in blocks of `block_s` (the three axes of a block together),
    /// each pose a block, each prior its stated information.
    fn meat(&self, x: &[f64]) -> Mat<f64> {
        let n = self.layout.n();
        let mut meat = Mat::zeros(n, n);
        let mut score = vec![0.0; n];
        let flush = |score: &mut Vec<f64>, meat: &mut Mat<f64>| {
            let nonzero: Vec<usize> = (0..n).filter(|&i| score[i] != 0.0).collect();
            for &a in &nonzero {
                for &b in &nonzero {
                    meat[(a, b)] += score[a] * score[b];
                }
            }
            score.iter_mut().for_each(|v| *v = 0.0);
        };
        for (r, run) in self.runs.iter().enumerate() {
            let dt = crate::input::recording::sample_interval(&run.input.time_s);
            let block = ((self.settings.block_s / dt).round() as usize).max(10);
            let sigma = self.run_sigma[r];
            let mut count = 0usize;
            self.run_rows(r, x, |_, e, rows| {
                for k in 0..3 {
                    let w = e[k] / (sigma[k] * sigma[k]);
                    for &(i, v) in &rows[k] {
                        score[i] += v * w;
                    }
                }
                count += 1;
                if count.is_multiple_of(block) {
                    flush(&mut score, &mut meat);
                }
            });
            flush(&mut score, &mut meat);
        }
        self.pose_rows(x, |p, e, rows| {
            let sigma = self.poses[p].2;
            for k in 0..3 {
                for &(i, v) in &rows[k] {
                    score[i] += v * e[k] / (sigma[k] * sigma[k]);
                }
            }
            flush(&mut score, &mut meat);
        });
        // A prior's information is its stated variance, not the realised score².
        let mut info = System::new(n);
        self.priors(&mut info, &vec![0.0; n]);
        for a in 0..n {
            for b in 0..n {
                meat[(a, b)] += info.h[(a, b)];
                if self.fixed[a] || self.fixed[b] {
                    meat[(a, b)] = 0.0;
                }
            }
        }
        meat
    }
}

/// Where reported parameter `i` (b_x, b_y, b_z, then K row by row) sits among the unknowns.
fn reported_index(layout: &Layout, i: usize) -> usize {
    if i < 3 {
        layout.axis(i)
    } else {
        let (k, j) = ((i - 3) / 3, (i - 3) % 3);
        layout.axis(k) + 1 + j
    }
}

/// Calibrates the gyroscope from the runs and poses that carry gyro readings, given the joint
/// fit of the same runs and poses (same order). `Ok(None)` when no run has gyro columns.
pub fn fit_gyro(
    runs: &[RunInput],
    poses: &[PoseInput],
    joint: &JointFit,
    settings: &GyroSettings,
) -> Result<Option<GyroFit>, GyroError> {
    check_settings(settings)?;
    let (gyro_runs, saturation) = gyro_runs(runs, joint)?;
    if gyro_runs.is_empty() {
        if saturation.is_empty() {
            return Ok(None);
        }
        let found: Vec<String> = saturation.iter().map(GyroRunSaturation::describe).collect();
        return Err(GyroError::Saturated(found.join("; ")));
    }
    let (pose_rows, sessions) = gyro_pose_rows(poses);
    let layout = Layout {
        runs: gyro_runs.len(),
        sessions,
    };
    let mut problem = Problem {
        fixed: vec![false; layout.n()],
        layout,
        run_sigma: Vec::new(),
        runs: gyro_runs,
        poses: pose_rows,
        settings,
        joint,
    };
    // Reported order: b, then K row by row.
    let nominal = |i: usize| match i {
        0..=2 => GyroModel::IDEAL.bias_radps[i],
        _ => GyroModel::IDEAL.sensitivity[(i - 3) / 3][(i - 3) % 3],
    };
    let mut x0 = vec![0.0; problem.layout.n()];
    for i in 0..12 {
        x0[reported_index(&problem.layout, i)] = nominal(i);
    }
    let (mut x, mut cov) = problem.fit(x0)?;
    let (free_params, _) = reported_params(&problem.layout, &x, &cov, &problem.fixed);
    let corrector = model_at(&problem.layout, &x)
        .corrector()
        .ok_or(GyroError::Singular)?;
    let (_, spun) = problem.rate_checks(&x, &corrector);
    let no_poses = problem.poses.is_empty();
    // Terms left at nominal and the rest refitted, until no free term is left that the rule fixes
    // (fixing one term can leave another, which leant on it, undetermined). The columns no run
    // spun go first, alone: they are the prior's and a leak through the spindle's small tilt,
    // which also blurs the spun column's terms (a phone's flat runs: K_zz 0.006 standard error
    // beside K_zy, 0.0003 without it), so the spun ones are judged only after.
    // The accelerometer's terms rule: a Wald test at `TERM_FALSE_ALARM`.
    let z = term_threshold();
    let mut undetermined_terms: Vec<(String, String)> = Vec::new();
    let mut left_at_nominal: Vec<String> = Vec::new();
    let mut params = free_params.clone();
    loop {
        let mut to_fix: Vec<(usize, String, String)> = Vec::new();
        for (name, advice) in undetermined(&params, no_poses, spun, settings) {
            let Some(i) = params.iter().position(|p| p.name == name) else {
                continue;
            };
            let p = &params[i];
            // A term the data put z standard errors from nominal is better known than nominal.
            let seen = i < 3 || spun[(i - 3) % 3];
            let away = p
                .std_error
                .is_some_and(|se| (p.value - nominal(i)).abs() >= z * se);
            if !(seen && away) {
                to_fix.push((i, name, advice));
            }
        }
        let unseen = |i: usize| i >= 3 && !spun[(i - 3) % 3];
        if to_fix.iter().any(|(i, _, _)| unseen(*i)) {
            to_fix.retain(|(i, _, _)| unseen(*i));
        }
        if to_fix.is_empty() {
            break;
        }
        for (i, name, advice) in to_fix {
            let at = reported_index(&problem.layout, i);
            problem.fixed[at] = true;
            x[at] = nominal(i);
            undetermined_terms.push((name.clone(), advice));
            left_at_nominal.push(name);
        }
        if left_at_nominal.len() == params.len() {
            break;
        }
        (x, cov) = problem.fit(x)?;
        params = reported_params(&problem.layout, &x, &cov, &problem.fixed).0;
    }
    // Terms short of the tolerance but kept (the Wald test above), with what would determine them.
    for (name, advice) in undetermined(&params, no_poses, spun, settings) {
        if !undetermined_terms.iter().any(|(n, _)| *n == name) {
            undetermined_terms.push((name, advice));
        }
    }
    let (params, session_drift) = reported_params(&problem.layout, &x, &cov, &problem.fixed);
    let model = model_at(&problem.layout, &x);
    let corrector = model.corrector().ok_or(GyroError::Singular)?;
    let (rate_checks, _) = problem.rate_checks(&x, &corrector);
    // Reported in the order of the parameters.
    let order = |name: &String| params.iter().position(|p| &p.name == name);
    undetermined_terms.sort_by_key(|(name, _)| order(name));
    left_at_nominal.sort_by_key(order);
    Ok(Some(GyroFit {
        model,
        params,
        free_params,
        nominal_rule: format!(
            "a term whose standard error moves a reading at {:.1} rad/s by more than {:.3} rad/s (a bias: a reading by more than that) is not determined; it is left at its nominal value (bias 0, sensitivity 1, cross-axis 0), and the other terms refitted with it fixed, unless some run turned about its column and its estimate lies at least {z:.2} standard errors from nominal (a Wald test at two-sided false-alarm probability {:e}), when the estimate is the better known and is kept",
            settings.reference_rate_radps, settings.determined_tolerance_radps, TERM_FALSE_ALARM
        ),
        session_drift,
        rate_checks,
        undetermined: undetermined_terms,
        left_at_nominal,
        covariance: format!(
            "robust sandwich (scores summed over {:.1} s blocks of each run, each still pose a block); each run's mount tilts refitted within the joint fit's covariance; the joint fit's uncertainty in each run's speed and wow carried over by the delta method; terms left at nominal held fixed",
            settings.block_s
        ),
        saturation,
    }))
}

impl GyroFit {
    /// The model to save: `None` when the campaign determines none of the gyro's terms.
    pub fn saved_model(&self) -> Option<&GyroModel> {
        let determined = self.params.iter().any(|p| p.free);
        (determined && self.model.validate().is_ok()).then_some(&self.model)
    }

    /// The gyro terms left at nominal and what would determine them, for a verdict: empty when
    /// every term is determined.
    pub fn nominal_sentence(&self) -> String {
        if self.undetermined.is_empty() {
            return String::new();
        }
        let left: Vec<&(String, String)> = self
            .undetermined
            .iter()
            .filter(|(n, _)| self.left_at_nominal.contains(n))
            .collect();
        let kept: Vec<&str> = self
            .undetermined
            .iter()
            .filter(|(n, _)| !self.left_at_nominal.contains(n))
            .map(|(n, _)| n.as_str())
            .collect();
        let mut advice: Vec<&str> = Vec::new();
        for (_, a) in &self.undetermined {
            if !advice.contains(&a.as_str()) {
                advice.push(a);
            }
        }
        if self.saved_model().is_none() {
            return format!(
                " No gyroscope part saved: the campaign determines none of its terms. Record next: {}.",
                advice.join("; ")
            );
        }
        let mut text = String::from(" Gyroscope:");
        if !left.is_empty() {
            let names: Vec<&str> = left.iter().map(|(n, _)| n.as_str()).collect();
            text += &format!(
                " {} not determined by this campaign, left at nominal (bias 0, sensitivity 1, cross-axis 0) and the rest refitted without them.",
                names.join(", ")
            );
        }
        if !kept.is_empty() {
            text += &format!(
                " {} not determined to the tolerance but kept, their estimates far from nominal.",
                kept.join(", ")
            );
        }
        text + &format!(" To determine them record {}.", advice.join("; "))
    }
}

/// The gyro model at unknowns `x`.
fn model_at(l: &Layout, x: &[f64]) -> GyroModel {
    GyroModel {
        bias_radps: std::array::from_fn(|k| x[l.axis(k)]),
        sensitivity: std::array::from_fn(|k| std::array::from_fn(|j| x[l.axis(k) + 1 + j])),
        input_unit: crate::correctors::gyro::GyroInputUnit::RadPerS,
    }
}

/// Every setting must be finite and positive.
fn check_settings(settings: &GyroSettings) -> Result<(), GyroError> {
    for (name, value) in [
        ("bias_instability_radps", settings.bias_instability_radps),
        ("prior_sd[0]", settings.prior_sd[0]),
        ("prior_sd[1]", settings.prior_sd[1]),
        ("block_s", settings.block_s),
        ("reference_rate_radps", settings.reference_rate_radps),
        ("determined_tolerance_radps", settings.determined_tolerance_radps),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(GyroError::Setting {
                name,
                value,
                why: "must be finite and positive",
            });
        }
    }
    Ok(())
}

/// The runs with gyro columns, each with the joint fit's parameters and tilt information, and
/// the runs whose gyro saturated (rows left out; a run saturated in more than
/// [`GYRO_SATURATED_SHARE`] of its samples is refused).
fn gyro_runs<'a>(
    runs: &'a [RunInput],
    joint: &JointFit,
) -> Result<(Vec<GyroRun<'a>>, Vec<GyroRunSaturation>), GyroError> {
    let mut gyro_runs = Vec::new();
    let mut saturation = Vec::new();
    for (index, run) in runs.iter().enumerate() {
        let Some(gyro) = &run.gyro_radps else { continue };
        if let Some(axis) = gyro.iter().find(|a| a.len() != run.time_s.len()) {
            return Err(GyroError::Length {
                name: run.name.clone(),
                found: axis.len(),
                expected: run.time_s.len(),
            });
        }
        let pinned = gyro_saturated_mask(gyro);
        let samples = pinned.iter().filter(|&&p| p).count();
        let mut keep = run.keep.clone();
        if samples > 0 {
            let refused = samples as f64 > GYRO_SATURATED_SHARE * run.time_s.len() as f64;
            saturation.push(GyroRunSaturation {
                run: run.name.clone(),
                samples,
                of: run.time_s.len(),
                axes: gyro_rails_hit(gyro),
                refused,
            });
            if refused {
                continue;
            }
            for (k, p) in keep.iter_mut().zip(&pinned) {
                *k &= !p;
            }
        }
        // Without a covariance from the joint fit, the tilt keeps the mounting's 2° prior.
        let fallback = 2f64.to_radians().powi(-2);
        let tilt_information = joint
            .run_covariance(index, &TILT_PARAMS)
            .and_then(|c| {
                let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
                (det > 0.0 && det.is_finite())
                    .then(|| [[c[1][1] / det, -c[0][1] / det], [-c[1][0] / det, c[0][0] / det]])
            })
            .unwrap_or([[fallback, 0.0], [0.0, fallback]]);
        let mut gyro_run = GyroRun {
            input: run,
            gyro,
            keep,
            mid: mid_time(&run.time_s),
            index,
            params: joint.run_params(index).to_vec(),
            spindle: [0.0; 3],
            d_spindle: [[0.0; 3]; 2],
            tilt_information,
        };
        gyro_run.refresh(joint);
        gyro_runs.push(gyro_run);
    }
    Ok((gyro_runs, saturation))
}

/// The poses with gyro readings as `Problem::poses` has them, and how many sessions they span.
fn gyro_pose_rows(poses: &[PoseInput]) -> (Vec<PoseRow>, usize) {
    let gyro_poses: Vec<_> = poses
        .iter()
        .filter_map(|p| Some((p, p.gyro_mean_radps?, p.gyro_sigma_mean_radps?)))
        .collect();
    // Sessions renumbered over the poses that have gyro readings.
    let mut session_ids: Vec<usize> = gyro_poses.iter().map(|(p, _, _)| p.session).collect();
    session_ids.sort_unstable();
    session_ids.dedup();
    let pose_rows = gyro_poses
        .iter()
        .map(|(pose, mean, sigma)| {
            let (lo, hi) = gyro_poses
                .iter()
                .filter(|(q, _, _)| q.session == pose.session)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (q, _, _)| {
                    (a.min(q.time_s), b.max(q.time_s))
                });
            (
                session_ids.iter().position(|&s| s == pose.session).unwrap_or(0),
                *mean,
                sigma.map(|v| v.max(1e-9)),
                pose.time_s - 0.5 * (lo + hi),
            )
        })
        .collect();
    (pose_rows, session_ids.len())
}

/// b and K (with names and standard errors from `cov`), then each session's drift rate per axis.
fn reported_params(
    l: &Layout,
    x: &[f64],
    cov: &Mat<f64>,
    fixed: &[bool],
) -> (Vec<JointParam>, Vec<JointParam>) {
    let se = |i: usize| {
        let v = cov[(i, i)];
        (!fixed[i] && v.is_finite() && v >= 0.0).then(|| v.sqrt())
    };
    let mut params = Vec::with_capacity(12);
    for i in 0..12 {
        let name = if i < 3 {
            format!("gyro_bias_{} (rad/s)", AXES[i])
        } else {
            format!("gyro_K_{}{}", AXES[(i - 3) / 3], AXES[(i - 3) % 3])
        };
        let at = reported_index(l, i);
        params.push(JointParam {
            name,
            value: x[at],
            std_error: se(at),
            free: !fixed[at],
        });
    }
    let mut session_drift = Vec::new();
    for s in 0..l.sessions {
        for k in 0..3 {
            let o = l.session(k, s) + 1;
            session_drift.push(JointParam {
                name: format!("still recording {} gyro_drift_{} (rad/s per s)", s + 1, AXES[k]),
                value: x[o],
                std_error: se(o),
                free: true,
            });
        }
    }
    (params, session_drift)
}

impl Problem<'_> {
    /// The joint fit's uncertainty in each run's speed (ω and wow), carried over into `cov` by
    /// the delta method: ∂x̂/∂φ by central differences of the whole solution.
    fn add_rate_uncertainty(&mut self, x: &[f64], cov: &mut Mat<f64>) -> Result<(), GyroError> {
        let joint = self.joint;
        let n = self.layout.n();
        for r in 0..self.runs.len() {
            let index = self.runs[r].index;
            let Some(phi_cov) = joint.run_covariance(index, &RATE_PARAMS) else {
                continue;
            };
            let mut jac = vec![[0.0f64; RATE_PARAMS.len()]; n];
            for (c, &param) in RATE_PARAMS.iter().enumerate() {
                let h = phi_cov[c][c].sqrt();
                if !(h > 0.0 && h.is_finite()) {
                    continue;
                }
                let original = self.runs[r].params[param];
                let mut sides = Vec::with_capacity(2);
                for sign in [1.0, -1.0] {
                    self.runs[r].params[param] = original + sign * h;
                    self.runs[r].refresh(joint);
                    sides.push(self.solve(x.to_vec(), 2)?.0);
                }
                self.runs[r].params[param] = original;
                self.runs[r].refresh(joint);
                for i in 0..n {
                    jac[i][c] = (sides[0][i] - sides[1][i]) / (2.0 * h);
                }
            }
            for i in 0..n {
                for j in 0..n {
                    let mut v = 0.0;
                    for a in 0..RATE_PARAMS.len() {
                        for b in 0..RATE_PARAMS.len() {
                            v += jac[i][a] * phi_cov[a][b] * jac[j][b];
                        }
                    }
                    cov[(i, j)] += v;
                }
            }
        }
        Ok(())
    }

    /// Per run, the accelerometer's rate against the raw and calibrated gyro about the spindle;
    /// and which body axes some run's spindle lay along.
    fn rate_checks(&self, x: &[f64], corrector: &GyroCorrector) -> (Vec<GyroRateCheck>, [bool; 3]) {
        let l = &self.layout;
        let mut spun = [false; 3];
        let rate_checks = self
            .runs
            .iter()
            .enumerate()
            .map(|(r, run)| {
                let t0 = l.tilt(r);
                let u = run.direction([x[t0], x[t0 + 1]]);
                for j in 0..3 {
                    spun[j] |= u[j].abs() > 0.9;
                }
                let (mut raw, mut calibrated, mut count) = (0.0, 0.0, 0.0);
                for (s, _) in run.input.time_s.iter().enumerate() {
                    if !run.keep[s] {
                        continue;
                    }
                    let m = [run.gyro[0][s], run.gyro[1][s], run.gyro[2][s]];
                    let c = corrector.correct(m);
                    raw += (0..3).map(|k| m[k] * u[k]).sum::<f64>();
                    calibrated += (0..3).map(|k| c[k] * u[k]).sum::<f64>();
                    count += 1.0;
                }
                let omega = self.joint.runs[run.index].params[1].clone();
                GyroRateCheck {
                    run: run.input.name.clone(),
                    accel_rate_radps: omega.value,
                    accel_rate_se_radps: omega.std_error,
                    raw_gyro_rate_radps: raw / f64::max(count, 1.0),
                    calibrated_gyro_rate_radps: calibrated / f64::max(count, 1.0),
                    residual_rms_radps: self.run_sigma[r],
                }
            })
            .collect();
        (rate_checks, spun)
    }
}

/// The free terms among `params` that the campaign does not determine, each with what would.
fn undetermined(
    params: &[JointParam],
    no_poses: bool,
    spun: [bool; 3],
    settings: &GyroSettings,
) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (i, p) in params.iter().enumerate().filter(|(_, p)| p.free) {
        let effect = if i < 3 { 1.0 } else { settings.reference_rate_radps };
        let bad = p
            .std_error
            .is_none_or(|se| se.is_nan() || se * effect > settings.determined_tolerance_radps);
        if !bad {
            continue;
        }
        let advice = if i < 3 {
            if no_poses {
                "still poses recorded with the gyroscope".to_string()
            } else {
                "longer still poses, or poses spread over the campaign".to_string()
            }
        } else {
            let column = (i - 3) % 3;
            if spun[column] {
                // The spindle's direction in the body frame comes from the accelerometer's fit of
                // the mount's tilt; a cross-axis term is no better known than that tilt.
                format!(
                    "limited by the mount's tilt on the runs about {}: longer runs, or a second run in the same mounting",
                    AXES[column]
                )
            } else {
                format!("a turntable run with the {} axis along the spindle", AXES[column])
            }
        };
        out.push((p.name.clone(), advice));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrector_inverts_the_model() {
        let model = GyroModel {
            bias_radps: [0.01, -0.02, 0.005],
            sensitivity: [[1.01, 0.004, -0.003], [0.002, 0.99, 0.006], [-0.005, 0.001, 1.02]],
            input_unit: Default::default(),
        };
        model.validate().unwrap();
        let c = model.corrector().unwrap();
        for w in [[1.0, 2.0, -3.0], [0.0, 0.0, 4.7], [-0.3, 0.1, 0.0]] {
            let back = c.correct(model.measure(w));
            for k in 0..3 {
                assert!((back[k] - w[k]).abs() < 1e-12, "{back:?} vs {w:?}");
            }
        }
    }

    #[test]
    fn validate_names_the_entry() {
        let mut model = GyroModel::IDEAL;
        model.sensitivity[1][1] = 0.1;
        let e = model.validate().unwrap_err();
        assert!(e.to_string().contains("sensitivity[1][1]"), "{e}");
        model.sensitivity[1][1] = f64::NAN;
        assert!(model
            .validate()
            .unwrap_err()
            .to_string()
            .contains("sensitivity[1]"));
    }
}
