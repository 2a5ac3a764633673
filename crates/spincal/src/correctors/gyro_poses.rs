//! A gyroscope's calibration from still poses and the rotations between them (the method of
//! Tedaldi, Pretto & Menegatti, ICRA 2014, which imu_tk implements; this is our own code).
//!
//! The model is [`GyroModel`]: m = b + K ω, ω the true rate in the accelerometer's calibrated body
//! frame. Two steps:
//! 1. b is the mean reading over still samples: the first still interval (imu_tk's choice, the
//!    long still period a session starts with) or every still interval
//!    ([`GyroBiasSource`]).
//! 2. K: for each motion between consecutive still intervals, the corrected rate
//!    ω = K⁻¹ (m − b) is integrated from the last sample of one interval to the first of the next,
//!    and the rotation must carry the gravity direction measured in the first pose onto the one
//!    measured in the next. Each step is the exact rotation (quaternion exponential) of the constant
//!    rate (ωₖ + ωₖ₊₁)/2 over one sample interval, composed in the body frame. The residual of a
//!    rotation is the predicted unit direction minus the measured one (three numbers, as imu_tk;
//!    its length 2 sin(θ/2) grows with the error angle θ all the way to 180°, which a projection
//!    onto the tangent plane would not). Levenberg–Marquardt on the 9
//!    entries of K, from the cheapest starts K = diag(±s) over the eight sign patterns and a grid
//!    of s about an estimate from the rotation angles, so the sign and size of each axis's scale
//!    need not be known (raw counts work).
//!
//! Standard errors of K are σ²(JᵀJ)⁻¹ with σ² = SSE / (2·rotations − 9) (a difference of unit
//! vectors has two degrees of freedom; along the direction it is second order): they assume
//! independent residuals of equal variance, b and the gravity directions known exactly. The bias's are the
//! sample standard deviation over √n (white noise; drift and flicker make them optimistic).

// 3×3 algebra reads best with indices.
#![allow(clippy::needless_range_loop)]

use faer::MatMut;
use serde::{Deserialize, Serialize};

use crate::correctors::gyro::{GyroInputUnit, GyroModel};
use crate::correctors::static_cal::StaticCalibration;
use crate::correctors::static_detect::StillInterval;
use crate::geometry::{
    apply, cross, dot, from_row_major, inverse, quat_exp, quat_mul, rotate_inverse, Quat, IDENTITY, M3,
};
use crate::optim::{levenberg_marquardt, LeastSquares, LmOptions, LmStop};

const AXES: [char; 3] = ['x', 'y', 'z'];

/// Which still samples give the gyro bias.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GyroBiasSource {
    /// The first still interval (the session's initial still period), as imu_tk does.
    #[default]
    FirstInterval,
    /// Every still interval, weighted by its length.
    AllIntervals,
}

/// A still pose: its samples `[start, end)` and the calibrated specific force's mean there
/// (accelerometer body frame, m/s²; it points up, against gravity).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StillPose {
    pub start: usize,
    pub end: usize,
    pub accel_mps2: [f64; 3],
}

/// The still poses of `intervals`, their means calibrated by `calibration`.
pub fn still_poses(intervals: &[StillInterval], calibration: &StaticCalibration) -> Vec<StillPose> {
    intervals
        .iter()
        .map(|i| StillPose {
            start: i.start,
            end: i.end,
            accel_mps2: calibration.apply(&i.mean),
        })
        .collect()
}

/// Fit settings.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GyroPoseOptions {
    pub bias_from: GyroBiasSource,
    /// |K|'s diagonal to start from (readings per rad/s); `None`: estimated from the rotations.
    /// The sign of each axis is found by the fit either way.
    pub initial_scale: Option<f64>,
    /// Fewest rotations accepted, never below 6 (each rotation gives two independent residuals; K
    /// has 9 entries, and the standard errors need some left over).
    pub min_rotations: usize,
    /// The weakest direction of the rotation axes must hold at least this share of the rotations
    /// (1/3 for axes spread evenly).
    pub min_axis_share: f64,
    /// A step between samples during motion longer than this many sample intervals is a gap
    /// (quantised clocks make steps of 2).
    pub max_step_intervals: f64,
    /// The unit of the readings, stored in the model.
    pub input_unit: GyroInputUnit,
}

impl Default for GyroPoseOptions {
    fn default() -> Self {
        GyroPoseOptions {
            bias_from: GyroBiasSource::FirstInterval,
            initial_scale: None,
            min_rotations: 6,
            min_axis_share: 0.03,
            max_step_intervals: 2.5,
            input_unit: GyroInputUnit::RadPerS,
        }
    }
}

/// One rotation between consecutive still poses, after the fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RotationCheck {
    /// Poses it joins (indices into the poses given).
    pub from_pose: usize,
    pub to_pose: usize,
    pub t_start_s: f64,
    pub t_end_s: f64,
    /// The calibrated gyro's rotation angle, deg.
    pub angle_deg: f64,
    /// Angle between the two poses' gravity directions, deg.
    pub gravity_angle_deg: f64,
    /// Angle between the predicted and the measured gravity direction of `to_pose`, deg.
    pub residual_deg: f64,
}

/// The fitted calibration with its evidence.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GyroPoseFit {
    pub model: GyroModel,
    pub bias_from: GyroBiasSource,
    /// Standard errors of b (input units) and of K's entries.
    pub bias_se: [f64; 3],
    pub sensitivity_se: M3,
    pub rotations: Vec<RotationCheck>,
    /// RMS of the rotations' residual angles, deg.
    pub rms_residual_deg: f64,
    /// The scale estimate the start grid is centred on, and the signs of the winning start.
    pub initial_scale: f64,
    pub initial_signs: [f64; 3],
    pub iterations: usize,
    pub stop: LmStop,
}

/// Why no gyroscope calibration could be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GyroPoseError {
    #[error("gyro calibration: the gyro has {found} samples, but the recording has {expected}")]
    LengthMismatch { found: usize, expected: usize },
    #[error(
        "gyro calibration: gyro axis {axis} at sample {sample} ({time_s} s) is {value}, not a finite number"
    )]
    NonFinite {
        axis: char,
        sample: usize,
        time_s: f64,
        value: f64,
    },
    #[error("gyro calibration: time at sample {sample} is {value}, not a finite number")]
    NonFiniteTime { sample: usize, value: f64 },
    #[error("gyro calibration: still pose {index} ([{start}, {end}) of {len} samples) is empty, out of range or out of order")]
    BadPose {
        index: usize,
        start: usize,
        end: usize,
        len: usize,
    },
    #[error(
        "gyro calibration: still pose {index}'s acceleration {accel_mps2:?} m/s² gives no gravity direction"
    )]
    NoGravity { index: usize, accel_mps2: [f64; 3] },
    #[error("gyro calibration needs {needed} rotations between still poses or more, but found {found}; record more poses")]
    TooFewRotations { needed: usize, found: usize },
    #[error("gyro calibration: rotation {rotation} (poses {from_pose} → {to_pose}) has a gap of {gap_s} s at {time_s} s ({intervals:.1} sample intervals); a rotation cannot be integrated across missing samples")]
    GapInMotion {
        rotation: usize,
        from_pose: usize,
        to_pose: usize,
        time_s: f64,
        gap_s: f64,
        intervals: f64,
    },
    #[error("gyro calibration: the sample interval {0} s is not positive and finite")]
    BadSampleInterval(f64),
    #[error("gyro calibration: the rotations do not span the three axes: their weakest direction [{:.2}, {:.2}, {:.2}] (gyro frame) holds {:.1} % of them, {:.1} % needed; add rotations about that direction", weakest[0], weakest[1], weakest[2], 100.0 * share, 100.0 * needed)]
    PoorlySpanned {
        weakest: [f64; 3],
        share: f64,
        needed: f64,
    },
    #[error("gyro calibration: option {name} = {value} is out of range")]
    BadOption { name: &'static str, value: f64 },
    #[error("gyro calibration: the fit failed (singular or non-finite sensitivity from every start)")]
    Diverged,
}

/// One motion: the raw half-sum increments ((mₖ + mₖ₊₁)/2 − b)·Δt and the two gravity directions.
struct Motion {
    increments: Vec<[f64; 3]>,
    up_before: [f64; 3],
    up_after: [f64; 3],
}

struct Problem<'a> {
    motions: &'a [Motion],
}

fn params_to_k(p: &[f64]) -> M3 {
    from_row_major(p)
}

/// The rotation of `m`'s increments under the corrector `a` = K⁻¹, as a unit quaternion taking
/// body-frame vectors at the end to the start's body frame.
fn integrate(a: &M3, increments: &[[f64; 3]]) -> Quat {
    let mut q = [1.0, 0.0, 0.0, 0.0];
    for d in increments {
        let phi = apply(a, d);
        q = quat_mul(&q, &quat_exp(phi));
    }
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    q.map(|v| v / n)
}

impl Problem<'_> {
    /// Predicted up direction after each motion, for K = `p`; `None` when K is singular.
    fn predictions(&self, p: &[f64]) -> Option<Vec<[f64; 3]>> {
        let a = inverse(&params_to_k(p))?;
        Some(
            self.motions
                .iter()
                .map(|m| rotate_inverse(&integrate(&a, &m.increments), m.up_before))
                .collect(),
        )
    }
}

impl LeastSquares for Problem<'_> {
    fn n_params(&self) -> usize {
        9
    }
    fn n_residuals(&self) -> usize {
        3 * self.motions.len()
    }
    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let Some(predicted) = self.predictions(p) else {
            out.fill(f64::NAN);
            return;
        };
        for (k, (m, u)) in self.motions.iter().zip(&predicted).enumerate() {
            for i in 0..3 {
                out[3 * k + i] = u[i] - m.up_after[i];
            }
        }
    }
    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        // Central differences, steps relative to each row of K (its entries share one unit).
        let n = self.n_residuals();
        let mut plus = vec![0.0; n];
        let mut minus = vec![0.0; n];
        let mut q = p.to_vec();
        for j in 0..9 {
            let row = j / 3;
            let size = (0..3).map(|c| p[3 * row + c].abs()).fold(0.0, f64::max);
            let h = 1e-6 * size.max(f64::MIN_POSITIVE);
            q[j] = p[j] + h;
            self.residuals(&q, &mut plus);
            q[j] = p[j] - h;
            self.residuals(&q, &mut minus);
            q[j] = p[j];
            for i in 0..n {
                out[(i, j)] = (plus[i] - minus[i]) / (2.0 * h);
            }
        }
    }
}

/// Fits the gyroscope's b and K to a session of still poses joined by rotations.
///
/// `time_s` and `gyro` (raw readings, gyro frame, input units) sample beside the accelerometer
/// whose still poses are `poses` (in time order, calibrated, [`still_poses`]).
pub fn fit_gyro_poses(
    time_s: &[f64],
    gyro: &[Vec<f64>; 3],
    poses: &[StillPose],
    options: &GyroPoseOptions,
) -> Result<GyroPoseFit, GyroPoseError> {
    check_options(options)?;
    check_readings(time_s, gyro)?;
    let ups = pose_ups(poses, time_s.len())?;
    let found = poses.len().saturating_sub(1);
    let needed = options.min_rotations.max(6);
    if found < needed {
        return Err(GyroPoseError::TooFewRotations { needed, found });
    }
    let dt = crate::input::recording::sample_interval(time_s);
    if !(dt.is_finite() && dt > 0.0) {
        return Err(GyroPoseError::BadSampleInterval(dt));
    }

    let (bias, bias_se) = still_bias(gyro, poses, options.bias_from);
    let motions = motions(time_s, gyro, poses, &ups, bias, dt, options.max_step_intervals)?;
    check_span(&motions, options.min_axis_share)?;

    let problem = Problem { motions: &motions };
    let initial_scale = match options.initial_scale {
        Some(s) => s.abs(),
        None => estimate_scale(&motions),
    };
    let (report, initial_signs) = problem.best_fit(initial_scale, options)?;
    let k = params_to_k(&report.params);
    let Some(predicted) = problem.predictions(&report.params) else {
        return Err(GyroPoseError::Diverged);
    };
    let a = inverse(&k).ok_or(GyroPoseError::Diverged)?;
    let dof = (2 * motions.len()).saturating_sub(9).max(1);
    let sigma2 = report.sse / dof as f64;
    let variances = covariance_diagonal(&report.jtj).unwrap_or_else(|| vec![f64::NAN; 9]);
    let sensitivity_se: M3 =
        std::array::from_fn(|i| std::array::from_fn(|j| (variances[3 * i + j] * sigma2).sqrt()));

    let rotations = rotation_checks(&motions, &predicted, &a, time_s, poses);
    let rms_residual_deg =
        (rotations.iter().map(|r| r.residual_deg.powi(2)).sum::<f64>() / rotations.len() as f64).sqrt();
    Ok(GyroPoseFit {
        model: GyroModel {
            bias_radps: bias,
            sensitivity: k,
            input_unit: options.input_unit,
        },
        bias_from: options.bias_from,
        bias_se,
        sensitivity_se,
        rotations,
        rms_residual_deg,
        initial_scale,
        initial_signs,
        iterations: report.iterations,
        stop: report.stop,
    })
}

fn check_options(options: &GyroPoseOptions) -> Result<(), GyroPoseError> {
    // The share may be 0 (no span check); the scale's sign is ignored but 0 would start nowhere.
    let checks = [
        (
            "min_axis_share",
            options.min_axis_share,
            options.min_axis_share >= 0.0,
        ),
        (
            "max_step_intervals",
            options.max_step_intervals,
            options.max_step_intervals > 0.0,
        ),
        (
            "initial_scale",
            options.initial_scale.unwrap_or(1.0),
            options.initial_scale != Some(0.0),
        ),
    ];
    for (name, value, in_range) in checks {
        if !(value.is_finite() && in_range) {
            return Err(GyroPoseError::BadOption { name, value });
        }
    }
    Ok(())
}

/// One gyro sample per time, every time and reading finite.
fn check_readings(time_s: &[f64], gyro: &[Vec<f64>; 3]) -> Result<(), GyroPoseError> {
    let n = time_s.len();
    if let Some(axis) = gyro.iter().find(|g| g.len() != n) {
        return Err(GyroPoseError::LengthMismatch {
            found: axis.len(),
            expected: n,
        });
    }
    if let Some(sample) = time_s.iter().position(|t| !t.is_finite()) {
        return Err(GyroPoseError::NonFiniteTime {
            sample,
            value: time_s[sample],
        });
    }
    for (a, axis) in gyro.iter().enumerate() {
        if let Some(sample) = axis.iter().position(|v| !v.is_finite()) {
            return Err(GyroPoseError::NonFinite {
                axis: AXES[a],
                sample,
                time_s: time_s[sample],
                value: axis[sample],
            });
        }
    }
    Ok(())
}

/// Each pose's gravity direction; the poses must lie in order within the `n` samples.
fn pose_ups(poses: &[StillPose], n: usize) -> Result<Vec<[f64; 3]>, GyroPoseError> {
    let mut previous_end = 0;
    let mut ups = Vec::with_capacity(poses.len());
    for (index, pose) in poses.iter().enumerate() {
        if pose.start >= pose.end || pose.end > n || pose.start < previous_end {
            return Err(GyroPoseError::BadPose {
                index,
                start: pose.start,
                end: pose.end,
                len: n,
            });
        }
        previous_end = pose.end;
        let norm = dot(&pose.accel_mps2, &pose.accel_mps2).sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(GyroPoseError::NoGravity {
                index,
                accel_mps2: pose.accel_mps2,
            });
        }
        ups.push(pose.accel_mps2.map(|v| v / norm));
    }
    Ok(ups)
}

/// The motion between each pair of consecutive poses, refused where a gap breaks it.
fn motions(
    time_s: &[f64],
    gyro: &[Vec<f64>; 3],
    poses: &[StillPose],
    ups: &[[f64; 3]],
    bias: [f64; 3],
    dt: f64,
    max_step_intervals: f64,
) -> Result<Vec<Motion>, GyroPoseError> {
    let found = poses.len().saturating_sub(1);
    let mut motions = Vec::with_capacity(found);
    for r in 0..found {
        let (first, last) = (poses[r].end - 1, poses[r + 1].start);
        for k in first..last {
            let step = time_s[k + 1] - time_s[k];
            if step > max_step_intervals * dt || step < 0.0 {
                return Err(GyroPoseError::GapInMotion {
                    rotation: r,
                    from_pose: r,
                    to_pose: r + 1,
                    time_s: time_s[k],
                    gap_s: step,
                    intervals: step / dt,
                });
            }
        }
        let increments = (first..last)
            .map(|k| std::array::from_fn(|a| (0.5 * (gyro[a][k] + gyro[a][k + 1]) - bias[a]) * dt))
            .collect();
        motions.push(Motion {
            increments,
            up_before: ups[r],
            up_after: ups[r + 1],
        });
    }
    Ok(motions)
}

impl Problem<'_> {
    /// The lowest-cost LM fit over the starts, with the signs of the start it came from.
    fn best_fit(
        &self,
        initial_scale: f64,
        options: &GyroPoseOptions,
    ) -> Result<(crate::optim::LmReport, [f64; 3]), GyroPoseError> {
        let lm = LmOptions {
            max_iterations: 200,
            ..Default::default()
        };
        // Each axis's sign is unknown and the cost has local minima (a rotation wrong by a turn
        // fits as well as a right one), so the starts are K = diag(±s) for the eight sign
        // patterns and a grid of s from a quarter to four times the estimate (and 1 for rad/s);
        // LM runs from the three cheapest, and the lowest cost wins.
        let mut scales: Vec<f64> = (0..=32)
            .map(|k| initial_scale * 16f64.powf(k as f64 / 32.0) / 4.0)
            .collect();
        if options.input_unit == GyroInputUnit::RadPerS && options.initial_scale.is_none() {
            scales.push(1.0);
        }
        let mut starts: Vec<(f64, Vec<f64>, [f64; 3])> = Vec::new();
        let mut r = vec![0.0; self.n_residuals()];
        for pattern in 0..8 {
            let signs: [f64; 3] = std::array::from_fn(|a| if pattern >> a & 1 == 1 { -1.0 } else { 1.0 });
            for &scale in &scales {
                let mut p0 = vec![0.0; 9];
                for a in 0..3 {
                    p0[4 * a] = signs[a] * scale;
                }
                self.residuals(&p0, &mut r);
                let sse: f64 = r.iter().map(|v| v * v).sum();
                if sse.is_finite() {
                    starts.push((sse, p0, signs));
                }
            }
        }
        starts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut best: Option<(crate::optim::LmReport, [f64; 3])> = None;
        for (_, p0, signs) in starts.into_iter().take(3) {
            let report = levenberg_marquardt(self, &p0, &lm, &crate::progress::silent);
            let usable = report.sse.is_finite() && report.params.iter().all(|v| v.is_finite());
            if usable && best.as_ref().is_none_or(|(b, _)| report.sse < b.sse) {
                best = Some((report, signs));
            }
        }
        best.ok_or(GyroPoseError::Diverged)
    }
}

/// Each rotation after the fit (`a` = K⁻¹, `predicted` the up directions it predicts).
fn rotation_checks(
    motions: &[Motion],
    predicted: &[[f64; 3]],
    a: &M3,
    time_s: &[f64],
    poses: &[StillPose],
) -> Vec<RotationCheck> {
    motions
        .iter()
        .zip(predicted)
        .enumerate()
        .map(|(r, (m, u))| {
            let q = integrate(a, &m.increments);
            RotationCheck {
                from_pose: r,
                to_pose: r + 1,
                t_start_s: time_s[poses[r].end - 1],
                t_end_s: time_s[poses[r + 1].start],
                angle_deg: (2.0 * q[0].abs().min(1.0).acos()).to_degrees(),
                gravity_angle_deg: angle_between(&m.up_before, &m.up_after).to_degrees(),
                residual_deg: angle_between(u, &m.up_after).to_degrees(),
            }
        })
        .collect()
}

/// The bias and its standard error from the still samples `source` names.
fn still_bias(gyro: &[Vec<f64>; 3], poses: &[StillPose], source: GyroBiasSource) -> ([f64; 3], [f64; 3]) {
    let used = match source {
        GyroBiasSource::FirstInterval => &poses[..1],
        GyroBiasSource::AllIntervals => poses,
    };
    let count: usize = used.iter().map(|p| p.end - p.start).sum();
    let mut mean = [0.0; 3];
    let mut se = [0.0; 3];
    for a in 0..3 {
        let samples = || used.iter().flat_map(|p| &gyro[a][p.start..p.end]);
        mean[a] = samples().sum::<f64>() / count as f64;
        let var = samples().map(|v| (v - mean[a]).powi(2)).sum::<f64>() / (count.max(2) - 1) as f64;
        se[a] = (var / count as f64).sqrt();
    }
    (mean, se)
}

/// The start's |K_ii|: the median over rotations of |∫(m − b) dt| over the angle between the
/// poses' gravity directions (rotations of 20° or more; for a rotation about a fixed axis
/// perpendicular to gravity the ratio is exactly the scale).
fn estimate_scale(motions: &[Motion]) -> f64 {
    let mut ratios: Vec<f64> = motions
        .iter()
        .filter_map(|m| {
            let angle = angle_between(&m.up_before, &m.up_after);
            let total = raw_total(m);
            (angle > 20f64.to_radians()).then(|| dot(&total, &total).sqrt() / angle)
        })
        .filter(|r| r.is_finite() && *r > 0.0)
        .collect();
    if ratios.is_empty() {
        return 1.0;
    }
    let mid = ratios.len() / 2;
    *ratios.select_nth_unstable_by(mid, f64::total_cmp).1
}

fn raw_total(m: &Motion) -> [f64; 3] {
    m.increments
        .iter()
        .fold([0.0; 3], |s, d| std::array::from_fn(|a| s[a] + d[a]))
}

/// Refuses rotations whose axes (raw gyro frame; an invertible K keeps whether they span) leave a
/// direction nearly unvisited: the smallest eigenvalue of Σ n nᵀ / count (n: each rotation's unit
/// axis) must be at least `min_share`.
fn check_span(motions: &[Motion], min_share: f64) -> Result<(), GyroPoseError> {
    let mut s = [[0.0; 3]; 3];
    let mut count = 0.0f64;
    for m in motions {
        let total = raw_total(m);
        let norm = dot(&total, &total).sqrt();
        if norm.is_nan() || norm <= 0.0 {
            continue;
        }
        let n = total.map(|v| v / norm);
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += n[i] * n[j];
            }
        }
        count += 1.0;
    }
    let s = s.map(|row| row.map(|v| v / count.max(1.0)));
    let (share, weakest) = smallest_eigen(&s);
    if share < min_share || count == 0.0 {
        return Err(GyroPoseError::PoorlySpanned {
            weakest,
            share: share.max(0.0),
            needed: min_share,
        });
    }
    Ok(())
}

/// The smallest eigenvalue of a symmetric 3×3 matrix and its unit eigenvector (Jacobi sweeps).
fn smallest_eigen(m: &M3) -> (f64, [f64; 3]) {
    let mut a = *m;
    let mut v: M3 = IDENTITY;
    for _ in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off < 1e-15 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = 0.5 * (a[q][q] - a[p][p]) / a[p][q];
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with the rotation J in the (p, q) plane.
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for k in 0..3 {
                let (vkp, vkq) = (v[k][p], v[k][q]);
                v[k][p] = c * vkp - s * vkq;
                v[k][q] = s * vkp + c * vkq;
            }
        }
    }
    let i = (0..3).min_by(|&x, &y| a[x][x].total_cmp(&a[y][y])).unwrap_or(0);
    (a[i][i], [v[0][i], v[1][i], v[2][i]])
}

fn covariance_diagonal(jtj: &faer::Mat<f64>) -> Option<Vec<f64>> {
    use faer::prelude::Solve;
    let n = jtj.nrows();
    let llt = jtj.llt(faer::Side::Lower).ok()?;
    let inv = llt.solve(faer::Mat::<f64>::identity(n, n));
    Some((0..n).map(|i| inv[(i, i)]).collect())
}

/// The angle between two vectors, rad (atan2: accurate near 0 and π).
fn angle_between(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let c = cross(a, b);
    dot(&c, &c).sqrt().atan2(dot(a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rotate;

    #[test]
    fn quaternion_steps_compose_to_the_rotation_about_one_axis() {
        // 90° about z in 100 steps: x goes to y, so in the end frame the start's x is −y.
        let steps = vec![[0.0, 0.0, std::f64::consts::FRAC_PI_2 / 100.0]; 100];
        let q = integrate(&IDENTITY, &steps);
        let moved = rotate(&q, [1.0, 0.0, 0.0]);
        assert!((moved[1] - 1.0).abs() < 1e-12, "{moved:?}");
        let seen = rotate_inverse(&q, [1.0, 0.0, 0.0]);
        assert!((seen[1] + 1.0).abs() < 1e-12, "{seen:?}");
    }

    #[test]
    fn smallest_eigen_finds_the_missing_axis() {
        let m = [[0.5, 0.1, 0.0], [0.1, 0.5, 0.0], [0.0, 0.0, 0.001]];
        let (value, vector) = smallest_eigen(&m);
        assert!((value - 0.001).abs() < 1e-12);
        assert!((vector[2].abs() - 1.0).abs() < 1e-12, "{vector:?}");
        let m = [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 3.0]];
        let (value, vector) = smallest_eigen(&m);
        assert!((value - 1.0).abs() < 1e-12, "{value}");
        assert!((vector[0] + vector[1]).abs() < 1e-12, "{vector:?}");
    }
}
