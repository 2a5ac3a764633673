//! Classic accelerometer calibration from still poses: nonlinear least squares on |a| = g.
//!
//! Model (imu_tk's convention, sensor frame): with raw reading r (counts or file units),
//! d = r − b, u = K d (K = diag(s), m/s² per input unit), v_i = u_i + q_i u_i², a = T v,
//! T = [[1, −α_yz, α_zy], [0, 1, −α_zx], [0, 0, 1]] (non-orthogonality of the sensing axes).
//! - 6 parameters: b, s (T = I, q = 0)
//! - 9 parameters: b, s, α (imu_tk)
//! - 12 parameters: b, s, α, q (per-axis quadratic nonlinearity; the GX1 has 0.2 %)
//!
//! A full 3×3 matrix is not identifiable from norms alone (a rotation leaves every |a| unchanged),
//! which is why the triangular T is used. Each still pose contributes one residual |a(mean)| − g, so
//! a model needs at least as many poses as parameters; with poses that are all axis-aligned the
//! misalignment is still barely observable (its effect on the norm is second order).

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use faer::MatMut;
use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{
    check_finite, Axis, CorrectedSample, Corrector, ModelError, SampleCorrector,
};
use crate::correctors::static_detect::StillInterval;
use crate::geometry::M3;
use crate::optim::{levenberg_marquardt, LeastSquares, LmOptions, LmStop};

/// Which parameters are estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StaticModel {
    /// Bias and scale per axis (6).
    BiasScale,
    /// Bias, scale and axis non-orthogonality (9).
    Misalignment,
    /// As `Misalignment` plus per-axis quadratic nonlinearity (12).
    Nonlinear,
}

impl StaticModel {
    /// The model in words, with its parameter count.
    pub fn describe(self) -> &'static str {
        match self {
            StaticModel::BiasScale => "bias and scale (6 parameters)",
            StaticModel::Misalignment => "bias, scale and misalignment (9 parameters)",
            StaticModel::Nonlinear => "bias, scale, misalignment and quadratic nonlinearity (12 parameters)",
        }
    }
}

impl StaticModel {
    pub fn n_params(self) -> usize {
        match self {
            StaticModel::BiasScale => 6,
            StaticModel::Misalignment => 9,
            StaticModel::Nonlinear => 12,
        }
    }

    /// From a parameter count: 6, 9 or 12.
    pub fn from_n_params(n: usize) -> Option<StaticModel> {
        match n {
            6 => Some(StaticModel::BiasScale),
            9 => Some(StaticModel::Misalignment),
            12 => Some(StaticModel::Nonlinear),
            _ => None,
        }
    }
}

/// A fitted static calibration: maps raw readings to m/s² in the sensor frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StaticCalibration {
    pub model: StaticModel,
    /// b, input units.
    pub bias: [f64; 3],
    /// s, m/s² per input unit.
    pub scale: [f64; 3],
    /// [α_yz, α_zy, α_zx], rad (small-angle).
    pub misalignment: [f64; 3],
    /// q, 1/(m/s²).
    pub nonlinearity: [f64; 3],
    /// Local gravity the fit used, m/s².
    pub gravity_mps2: f64,
    /// Unit of the raw input (`counts` or `m/s^2`).
    pub input_unit: String,
}

impl StaticCalibration {
    /// The identity calibration for input already in m/s².
    pub fn identity(gravity_mps2: f64) -> StaticCalibration {
        StaticCalibration {
            model: StaticModel::BiasScale,
            bias: [0.0; 3],
            scale: [1.0; 3],
            misalignment: [0.0; 3],
            nonlinearity: [0.0; 3],
            gravity_mps2,
            input_unit: "m/s^2".into(),
        }
    }

    /// Checks the calibration against its own structure: every parameter finite, no zero scale
    /// (it would map an axis to a constant), a finite positive gravity, and no misalignment or
    /// nonlinearity that its `model` does not estimate (they would be applied all the same).
    /// Fields are relative to the calibration (`scale[2]`). The three-axis arrays have their
    /// length by type.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_finite("bias", &self.bias)?;
        check_finite("scale", &self.scale)?;
        check_finite("misalignment", &self.misalignment)?;
        check_finite("nonlinearity", &self.nonlinearity)?;
        if let Some(i) = self.scale.iter().position(|&s| s == 0.0) {
            return Err(ModelError::new(
                format!("scale[{i}]"),
                "0 maps every reading of the axis to 0",
            ));
        }
        let g = self.gravity_mps2;
        if !(g.is_finite() && g > 0.0) {
            return Err(ModelError::new(
                "gravity_mps2",
                format!("{g}: gravity must be finite and positive"),
            ));
        }
        let model = serde_json::to_value(self.model)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        let unused = |field: &str, values: &[f64; 3]| -> Result<(), ModelError> {
            match values.iter().position(|&v| v != 0.0) {
                Some(i) => Err(ModelError::new(
                    format!("{field}[{i}]"),
                    format!(
                        "{}, but model {model} estimates no {field} (it must be 0)",
                        values[i]
                    ),
                )),
                None => Ok(()),
            }
        };
        match self.model {
            StaticModel::BiasScale => {
                unused("misalignment", &self.misalignment)?;
                unused("nonlinearity", &self.nonlinearity)
            }
            StaticModel::Misalignment => unused("nonlinearity", &self.nonlinearity),
            StaticModel::Nonlinear => Ok(()),
        }
    }

    fn from_params(model: StaticModel, p: &[f64], gravity_mps2: f64, input_unit: &str) -> StaticCalibration {
        let get = |k: usize, default: f64| p.get(k).copied().unwrap_or(default);
        StaticCalibration {
            model,
            bias: [p[0], p[1], p[2]],
            scale: [p[3], p[4], p[5]],
            misalignment: [get(6, 0.0), get(7, 0.0), get(8, 0.0)],
            nonlinearity: [get(9, 0.0), get(10, 0.0), get(11, 0.0)],
            gravity_mps2,
            input_unit: input_unit.into(),
        }
    }

    fn params(&self) -> Vec<f64> {
        let mut p: Vec<f64> = self.bias.iter().chain(&self.scale).copied().collect();
        p.extend(self.misalignment);
        p.extend(self.nonlinearity);
        p.truncate(self.model.n_params());
        p
    }

    /// T, the non-orthogonality matrix.
    pub fn misalignment_matrix(&self) -> M3 {
        let [yz, zy, zx] = self.misalignment;
        [[1.0, -yz, zy], [0.0, 1.0, -zx], [0.0, 0.0, 1.0]]
    }

    /// Calibrated acceleration (m/s², sensor frame) of one raw reading (input units, sensor frame).
    pub fn apply(&self, raw: &[f64; 3]) -> [f64; 3] {
        let v: [f64; 3] = std::array::from_fn(|i| {
            let u = self.scale[i] * (raw[i] - self.bias[i]);
            u + self.nonlinearity[i] * u * u
        });
        let t = self.misalignment_matrix();
        std::array::from_fn(|r| t[r][0] * v[0] + t[r][1] * v[1] + t[r][2] * v[2])
    }

    /// Applies the calibration to whole axes.
    pub fn apply_axes(&self, raw: &[Vec<f64>; 3]) -> [Vec<f64>; 3] {
        let n = raw[0].len();
        let mut out: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
        for i in 0..n {
            let a = self.apply(&[raw[0][i], raw[1][i], raw[2][i]]);
            for k in 0..3 {
                out[k].push(a[k]);
            }
        }
        out
    }

    /// The linear part M = T·K (m/s² per input unit), as Kalibr writes it.
    pub fn linear_matrix(&self) -> M3 {
        let t = self.misalignment_matrix();
        std::array::from_fn(|r| std::array::from_fn(|c| t[r][c] * self.scale[c]))
    }

    /// A Kalibr-style YAML block (IMU intrinsics): a = M (r − b), written by hand.
    pub fn to_kalibr_yaml(&self, update_rate_hz: f64, noise_density: Option<[f64; 3]>) -> String {
        let m = self.linear_matrix();
        let row = |r: [f64; 3]| {
            format!(
                "[{}, {}, {}]",
                yaml_float(r[0]),
                yaml_float(r[1]),
                yaml_float(r[2])
            )
        };
        let mut s = String::new();
        s.push_str("# spincal static calibration, Kalibr-style IMU intrinsics.\n");
        s.push_str("# a [m/s^2] = M (r - b); r in ");
        s.push_str(&self.input_unit);
        s.push_str(". Quadratic terms (12-parameter model) are only in the spincal JSON.\n");
        s.push_str("imu0:\n");
        s.push_str(&format!(
            "  model: {}\n",
            serde_json::to_value(self.model)
                .unwrap_or_default()
                .as_str()
                .unwrap_or("")
        ));
        s.push_str(&format!("  update_rate: {}\n", yaml_float(update_rate_hz)));
        s.push_str(&format!(
            "  gravity_magnitude: {}\n",
            yaml_float(self.gravity_mps2)
        ));
        s.push_str("  accelerometers:\n");
        s.push_str(&format!(
            "    M: [{},\n        {},\n        {}]\n",
            row(m[0]),
            row(m[1]),
            row(m[2])
        ));
        s.push_str(&format!("    bias: {}\n", row(self.bias)));
        s.push_str(&format!("    scale: {}\n", row(self.scale)));
        s.push_str(&format!("    misalignment: {}\n", row(self.misalignment)));
        if let Some(n) = noise_density {
            let mean = (n[0] + n[1] + n[2]) / 3.0;
            s.push_str(&format!("  accelerometer_noise_density: {}\n", yaml_float(mean)));
        }
        s
    }
}

/// A float in the form YAML 1.1 readers (PyYAML) take as a number: a point in the mantissa and a
/// signed exponent (`3.3e4` and `0e0` would be read as strings).
fn yaml_float(v: f64) -> String {
    let text = format!("{v:.10e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) if !exponent.starts_with('-') => format!("{mantissa}e+{exponent}"),
        _ => text,
    }
}

/// Fit settings.
#[derive(Debug, Clone)]
pub struct StaticFitOptions {
    pub model: StaticModel,
    /// Local gravity, m/s².
    pub gravity_mps2: f64,
    /// `counts` or `m/s^2`, stored in the result.
    pub input_unit: String,
}

/// Fit result with the evidence.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StaticFit {
    pub calibration: StaticCalibration,
    /// |a| of each pose mean after calibration, m/s².
    pub pose_norms_mps2: Vec<f64>,
    /// RMS of |a| − g over the pose means, m/s².
    pub rms_mps2: f64,
    pub iterations: usize,
    pub stop: LmStop,
    /// 1-σ parameter uncertainties from the residual variance and (JᵀJ)⁻¹ (empty when poses = parameters).
    pub param_std: Vec<f64>,
}

/// A parameter whose 1-σ uncertainty moves a 1 g reading by more than this fraction of g is
/// reported as poorly determined by the poses.
pub const POORLY_DETERMINED_FRACTION_OF_G: f64 = 0.01;

impl StaticFit {
    /// The parameters the poses leave poorly determined: name and the 1-σ effect of its
    /// uncertainty on a 1 g reading, m/s² (bias: σ_b·s; scale: g·σ_s/s; misalignment: g·σ_α;
    /// nonlinearity: g²·σ_q). Empty when the fit is exact (no uncertainty to judge).
    pub fn poorly_determined(&self) -> Vec<(String, f64)> {
        let c = &self.calibration;
        let g = c.gravity_mps2;
        let axis = ["x", "y", "z"];
        let misalignment = ["yz", "zy", "zx"];
        self.param_std
            .iter()
            .enumerate()
            .map(|(k, &sd)| {
                let a = k % 3;
                match k / 3 {
                    0 => (format!("bias_{}", axis[a]), sd * c.scale[a].abs()),
                    1 => (format!("scale_{}", axis[a]), g * sd / c.scale[a].abs()),
                    2 => (format!("misalignment_{}", misalignment[a]), g * sd),
                    _ => (format!("nonlinearity_{}", axis[a]), g * g * sd),
                }
            })
            // A NaN effect (a singular fit) counts as poorly determined too.
            .filter(|(_, effect)| effect.is_nan() || *effect > POORLY_DETERMINED_FRACTION_OF_G * g)
            .collect()
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StaticCalError {
    #[error("the model of {} needs {needed} still poses or more, but only {found} still poses were found; record more poses or use a smaller `model` (6 parameters)", model.describe())]
    TooFewPoses {
        model: StaticModel,
        needed: usize,
        found: usize,
    },
    #[error("gravity must be finite and positive, got {0}")]
    BadGravity(f64),
    #[error("pose {index} has a non-finite mean")]
    NonFinitePose { index: usize },
    #[error("the fit diverged (non-finite parameters)")]
    Diverged,
}

struct Problem<'a> {
    model: StaticModel,
    means: &'a [[f64; 3]],
    gravity: f64,
}

impl Problem<'_> {
    fn calibration(&self, p: &[f64]) -> StaticCalibration {
        StaticCalibration::from_params(self.model, p, self.gravity, "")
    }
}

impl LeastSquares for Problem<'_> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }
    fn n_residuals(&self) -> usize {
        self.means.len()
    }
    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let c = self.calibration(p);
        for (o, m) in out.iter_mut().zip(self.means) {
            let a = c.apply(m);
            *o = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - self.gravity;
        }
    }
    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        let c = self.calibration(p);
        let t = c.misalignment_matrix();
        let np = self.n_params();
        for (j, m) in self.means.iter().enumerate() {
            let d: [f64; 3] = std::array::from_fn(|i| m[i] - c.bias[i]);
            let u: [f64; 3] = std::array::from_fn(|i| c.scale[i] * d[i]);
            let v: [f64; 3] = std::array::from_fn(|i| u[i] + c.nonlinearity[i] * u[i] * u[i]);
            let a: [f64; 3] = std::array::from_fn(|r| t[r][0] * v[0] + t[r][1] * v[1] + t[r][2] * v[2]);
            let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
                .sqrt()
                .max(f64::MIN_POSITIVE);
            let n: [f64; 3] = a.map(|x| x / norm);
            // w = Tᵀ n: sensitivity of |a| to v.
            let w: [f64; 3] = std::array::from_fn(|i| (0..3).map(|r| t[r][i] * n[r]).sum());
            let mut row = [0.0; 12];
            for i in 0..3 {
                let dv_du = 1.0 + 2.0 * c.nonlinearity[i] * u[i];
                row[i] = -w[i] * dv_du * c.scale[i];
                row[3 + i] = w[i] * dv_du * d[i];
                row[9 + i] = w[i] * u[i] * u[i];
            }
            row[6] = -n[0] * v[1];
            row[7] = n[0] * v[2];
            row[8] = -n[1] * v[2];
            for k in 0..np {
                out[(j, k)] = row[k];
            }
        }
    }
}

/// Initial guess: bias at the midpoint of the pose means, scale from their half-range when the poses
/// span an axis in both directions, otherwise one isotropic scale.
fn initial_guess(means: &[[f64; 3]], gravity: f64) -> Vec<f64> {
    let mut bias = [0.0; 3];
    let mut range = [0.0; 3];
    for a in 0..3 {
        let lo = means.iter().map(|m| m[a]).fold(f64::INFINITY, f64::min);
        let hi = means.iter().map(|m| m[a]).fold(f64::NEG_INFINITY, f64::max);
        bias[a] = 0.5 * (lo + hi);
        range[a] = hi - lo;
    }
    let mut norms: Vec<f64> = means
        .iter()
        .map(|m| ((m[0] - bias[0]).powi(2) + (m[1] - bias[1]).powi(2) + (m[2] - bias[2]).powi(2)).sqrt())
        .collect();
    norms.sort_by(f64::total_cmp);
    let iso = gravity / norms[norms.len() / 2].max(f64::MIN_POSITIVE);
    let scale: [f64; 3] = std::array::from_fn(|a| {
        // An axis counts as spanned when its range covers most of ±g.
        if range[a] * iso > 1.5 * gravity {
            2.0 * gravity / range[a]
        } else {
            iso
        }
    });
    bias.iter().chain(&scale).copied().collect()
}

/// Fits a calibration to still-pose means (input units, sensor frame).
pub fn fit_static(means: &[[f64; 3]], options: &StaticFitOptions) -> Result<StaticFit, StaticCalError> {
    let g = options.gravity_mps2;
    if !(g.is_finite() && g > 0.0) {
        return Err(StaticCalError::BadGravity(g));
    }
    if let Some(index) = means.iter().position(|m| m.iter().any(|x| !x.is_finite())) {
        return Err(StaticCalError::NonFinitePose { index });
    }
    let needed = options.model.n_params();
    if means.len() < needed {
        return Err(StaticCalError::TooFewPoses {
            model: options.model,
            needed,
            found: means.len(),
        });
    }
    let problem = Problem {
        model: options.model,
        means,
        gravity: g,
    };
    // Fit the 6-parameter model first: misalignment and nonlinearity start from zero at a good point.
    let mut p0 = initial_guess(means, g);
    let lm = LmOptions {
        max_iterations: 500,
        ..Default::default()
    };
    let first = Problem {
        model: StaticModel::BiasScale,
        ..problem
    };
    let report = levenberg_marquardt(&first, &p0, &lm, &crate::progress::silent);
    p0 = report.params;
    p0.resize(needed, 0.0);
    let report = levenberg_marquardt(&problem, &p0, &lm, &crate::progress::silent);
    if report.params.iter().any(|x| !x.is_finite()) {
        return Err(StaticCalError::Diverged);
    }
    let calibration = StaticCalibration::from_params(options.model, &report.params, g, &options.input_unit);
    let pose_norms_mps2: Vec<f64> = means
        .iter()
        .map(|m| {
            let a = calibration.apply(m);
            (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
        })
        .collect();
    let rms_mps2 = spread_about(&pose_norms_mps2, g);
    let dof = means.len() - needed;
    let param_std = if dof > 0 {
        let sigma2 = report.sse / dof as f64;
        covariance_diagonal(&report.jtj)
            .map_or_else(Vec::new, |d| d.iter().map(|v| (v * sigma2).sqrt()).collect())
    } else {
        Vec::new()
    };
    debug_assert_eq!(calibration.params().len(), needed);
    Ok(StaticFit {
        calibration,
        pose_norms_mps2,
        rms_mps2,
        iterations: report.iterations,
        stop: report.stop,
        param_std,
    })
}

fn covariance_diagonal(jtj: &faer::Mat<f64>) -> Option<Vec<f64>> {
    use faer::prelude::Solve;
    let n = jtj.nrows();
    let llt = jtj.llt(faer::Side::Lower).ok()?;
    let inv = llt.solve(faer::Mat::<f64>::identity(n, n));
    Some((0..n).map(|i| inv[(i, i)]).collect())
}

/// RMS of `values − reference`.
pub fn spread_about(values: &[f64], reference: f64) -> f64 {
    (values.iter().map(|v| (v - reference).powi(2)).sum::<f64>() / values.len() as f64).sqrt()
}

/// Pose means of still intervals.
pub fn pose_means(intervals: &[StillInterval]) -> Vec<[f64; 3]> {
    intervals.iter().map(|i| i.mean).collect()
}

/// A static calibration is a memoryless map of all three axes.
impl Corrector for StaticCalibration {
    fn corrected_axes(&self) -> Vec<Axis> {
        Axis::ALL.to_vec()
    }

    fn warmup_samples(&self) -> usize {
        0
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        Box::new(StaticStream(self))
    }
}

struct StaticStream<'a>(&'a StaticCalibration);

impl SampleCorrector for StaticStream<'_> {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        CorrectedSample {
            accel_mps2: self.0.apply(&accel_mps2),
            valid: true,
            outside_training_range: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Raw readings of a sensor with known errors at random orientations.
    fn simulate(truth: &StaticCalibration, n: usize, seed: u64) -> Vec<[f64; 3]> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let t = truth.misalignment_matrix();
        (0..n)
            .map(|_| {
                let mut d = [0.0f64; 3];
                for x in &mut d {
                    *x = rng.gen_range(-1.0..1.0);
                }
                let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let a = d.map(|x| x / norm * truth.gravity_mps2);
                // Invert a = T v (upper triangular), then v = u + q u², then u = s (r − b).
                let v2 = a[2];
                let v1 = a[1] + t[1][2] * -v2;
                let v0 = a[0] - t[0][1] * v1 - t[0][2] * v2;
                let v = [v0, v1, v2];
                std::array::from_fn(|i| {
                    let q = truth.nonlinearity[i];
                    let u = if q == 0.0 {
                        v[i]
                    } else {
                        (-1.0 + (1.0 + 4.0 * q * v[i]).sqrt()) / (2.0 * q)
                    };
                    u / truth.scale[i] + truth.bias[i]
                })
            })
            .collect()
    }

    fn truth(model: StaticModel) -> StaticCalibration {
        StaticCalibration {
            model,
            bias: [120.0, -80.0, 40.0],
            scale: [1.0 / 208.0, 1.0 / 205.0, 1.0 / 214.0],
            misalignment: if model == StaticModel::BiasScale {
                [0.0; 3]
            } else {
                [0.01, -0.02, 0.015]
            },
            nonlinearity: if model == StaticModel::Nonlinear {
                [0.001, -0.0005, 0.0008]
            } else {
                [0.0; 3]
            },
            gravity_mps2: 9.81,
            input_unit: "counts".into(),
        }
    }

    #[test]
    fn recovers_simulated_parameters_for_every_model() {
        for model in [
            StaticModel::BiasScale,
            StaticModel::Misalignment,
            StaticModel::Nonlinear,
        ] {
            let truth = truth(model);
            let means = simulate(&truth, 40, 3);
            let options = StaticFitOptions {
                model,
                gravity_mps2: 9.81,
                input_unit: "counts".into(),
            };
            let fit = fit_static(&means, &options).unwrap();
            let c = &fit.calibration;
            assert!(fit.rms_mps2 < 1e-8, "{model:?}: {}", fit.rms_mps2);
            for i in 0..3 {
                assert!((c.bias[i] - truth.bias[i]).abs() < 1e-4, "{model:?} {c:?}");
                assert!(
                    (c.scale[i] / truth.scale[i] - 1.0).abs() < 1e-8,
                    "{model:?} {c:?}"
                );
                assert!(
                    (c.misalignment[i] - truth.misalignment[i]).abs() < 1e-7,
                    "{model:?} {c:?}"
                );
                assert!(
                    (c.nonlinearity[i] - truth.nonlinearity[i]).abs() < 1e-7,
                    "{model:?} {c:?}"
                );
            }
        }
    }

    #[test]
    fn too_few_poses_is_an_error_and_yaml_names_the_matrix() {
        let means = simulate(&truth(StaticModel::Misalignment), 6, 1);
        let options = StaticFitOptions {
            model: StaticModel::Misalignment,
            gravity_mps2: 9.81,
            input_unit: "counts".into(),
        };
        let e = fit_static(&means, &options).unwrap_err();
        assert!(e.to_string().contains("only 6 still poses"), "{e}");
        let yaml = truth(StaticModel::Misalignment).to_kalibr_yaml(100.0, None);
        assert!(yaml.contains("imu0:\n  model: misalignment\n"), "{yaml}");
        assert!(yaml.contains("    M: [[4.8076923077e-3, "), "{yaml}");
        // Every number has the point and the signed exponent YAML 1.1 (PyYAML) needs to read it
        // as a float: `0e0` or `3.3e4` would come back as strings.
        for token in yaml
            .lines()
            .filter(|l| !l.trim_start().starts_with('#'))
            .flat_map(|l| l.split(['[', ']', ',', ' ', ':']))
            .filter(|t| t.starts_with(|c: char| c.is_ascii_digit() || c == '-'))
        {
            let (mantissa, exponent) = token.split_once('e').unwrap_or((token, "+0"));
            assert!(
                mantissa.contains('.') && exponent.starts_with(['+', '-']),
                "{token} in {yaml}"
            );
        }
    }

    #[test]
    fn json_round_trip_and_apply() {
        let c = truth(StaticModel::Nonlinear);
        let back: StaticCalibration = serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c);
        let a = c.apply(&c.bias);
        assert_eq!(a, [0.0; 3]);
    }
}
