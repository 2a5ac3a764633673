//! The physical sensor error model shared by every recording of a unit (SPEC §7), and its inverse,
//! the `physical` corrector.
//!
//! ```text
//! m = h(u),   u = b + D (I + M) f,   h(u)_k = u_k + q_k u_k²
//! ```
//! - f: true specific force in the sensor's body frame, m/s²;
//! - b: bias, m/s²; D = diag(1 + s_k): scale errors;
//! - M: misalignment, strictly lower triangular (`[m_yx, m_zx, m_zy]`, rad, small-angle): the body
//!   frame's x is the sensor's x axis, its y lies in the plane of the sensor's x and y axes, z
//!   completes it. A full 3×3 matrix would add a rotation, which no set of still poses or turntable
//!   runs can tell from the mounting (the mounting's rotation is fitted per recording instead);
//! - q: per-axis quadratic nonlinearity, 1/(m/s²).

// Per-axis arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{
    check_finite, Axis, CorrectedSample, Corrector, ModelError, SampleCorrector,
};
use crate::geometry::M3;

/// Parameters of the sensor model, in the order the joint fit uses.
pub(crate) const SENSOR_PARAMS: usize = 12;

/// Names of the 12 sensor parameters, in fit order, with their units.
pub(crate) const SENSOR_PARAM_NAMES: [&str; SENSOR_PARAMS] = [
    "bias_x (m/s²)",
    "bias_y (m/s²)",
    "bias_z (m/s²)",
    "scale_error_x",
    "scale_error_y",
    "scale_error_z",
    "misalignment_yx (rad)",
    "misalignment_zx (rad)",
    "misalignment_zy (rad)",
    "quadratic_x (1/(m/s²))",
    "quadratic_y (1/(m/s²))",
    "quadratic_z (1/(m/s²))",
];

/// The sensor error model (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorModel {
    /// b, m/s².
    pub bias_mps2: [f64; 3],
    /// s_k (0.004 is a sensor reading 0.4 % high).
    pub scale_error: [f64; 3],
    /// [m_yx, m_zx, m_zy], rad: how much of the body x reaches the y axis, of x and of y the z axis.
    pub misalignment_rad: [f64; 3],
    /// q_k, 1/(m/s²).
    pub quadratic_per_mps2: [f64; 3],
}

impl Default for SensorModel {
    fn default() -> Self {
        SensorModel::IDEAL
    }
}

/// The quadratic coefficient q (1/(m/s²)) of a datasheet nonlinearity of `pct_fs` % of full scale
/// over ±`range_g`: q·u² then departs from its least-squares straight line over the range by at
/// most that fraction of full scale (at the ends), which q = 1.5 · NL / FS gives. The simulator's
/// sensor and the joint fit's prior use this one conversion.
pub fn quadratic_from_datasheet(pct_fs: f64, range_g: f64) -> f64 {
    1.5 * pct_fs / 100.0 / (range_g * crate::input::recording::STANDARD_GRAVITY)
}

impl SensorModel {
    /// A perfect sensor.
    pub const IDEAL: SensorModel = SensorModel {
        bias_mps2: [0.0; 3],
        scale_error: [0.0; 3],
        misalignment_rad: [0.0; 3],
        quadratic_per_mps2: [0.0; 3],
    };

    /// From the fit's parameter vector (first `SENSOR_PARAMS` values).
    pub fn from_params(p: &[f64]) -> SensorModel {
        SensorModel {
            bias_mps2: [p[0], p[1], p[2]],
            scale_error: [p[3], p[4], p[5]],
            misalignment_rad: [p[6], p[7], p[8]],
            quadratic_per_mps2: [p[9], p[10], p[11]],
        }
    }

    /// The fit's parameter vector.
    pub fn params(&self) -> [f64; SENSOR_PARAMS] {
        let mut p = [0.0; SENSOR_PARAMS];
        p[0..3].copy_from_slice(&self.bias_mps2);
        p[3..6].copy_from_slice(&self.scale_error);
        p[6..9].copy_from_slice(&self.misalignment_rad);
        p[9..12].copy_from_slice(&self.quadratic_per_mps2);
        p
    }

    /// D (I + M): the linear part of the response, u = b + D (I + M) f.
    pub fn linear_matrix(&self) -> M3 {
        let d = self.scale_error.map(|s| 1.0 + s);
        let [m_yx, m_zx, m_zy] = self.misalignment_rad;
        [
            [d[0], 0.0, 0.0],
            [d[1] * m_yx, d[1], 0.0],
            [d[2] * m_zx, d[2] * m_zy, d[2]],
        ]
    }

    /// (I + M) f: the specific force as the three non-orthogonal axes see it.
    pub fn skewed(&self, f: [f64; 3]) -> [f64; 3] {
        let [m_yx, m_zx, m_zy] = self.misalignment_rad;
        [f[0], f[1] + m_yx * f[0], f[2] + m_zx * f[0] + m_zy * f[1]]
    }

    /// The sensor's linear response u = b + D (I + M) f, before the nonlinearity.
    pub fn linear_response(&self, f: [f64; 3], extra_bias: [f64; 3]) -> [f64; 3] {
        let v = self.skewed(f);
        std::array::from_fn(|k| self.bias_mps2[k] + extra_bias[k] + (1.0 + self.scale_error[k]) * v[k])
    }

    /// What the sensor reads for a true specific force `f` (body frame, m/s²).
    pub fn measure(&self, f: [f64; 3]) -> [f64; 3] {
        let u = self.linear_response(f, [0.0; 3]);
        std::array::from_fn(|k| u[k] + self.quadratic_per_mps2[k] * u[k] * u[k])
    }

    /// The true specific force that reads `m`, or `None` where the nonlinearity has no inverse (a
    /// reading beyond the quadratic's turning point).
    pub fn correct(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        let mut v = [0.0; 3];
        for k in 0..3 {
            let q = self.quadratic_per_mps2[k];
            // The root of q u² + u − m = 0 nearest u = m, in the form without cancellation.
            let disc = 1.0 + 4.0 * q * m[k];
            if disc <= 0.0 {
                return None;
            }
            let u = 2.0 * m[k] / (1.0 + disc.sqrt());
            v[k] = (u - self.bias_mps2[k]) / (1.0 + self.scale_error[k]);
        }
        let [m_yx, m_zx, m_zy] = self.misalignment_rad;
        let fx = v[0];
        let fy = v[1] - m_yx * fx;
        let fz = v[2] - m_zx * fx - m_zy * fy;
        let f = [fx, fy, fz];
        f.iter().all(|x| x.is_finite()).then_some(f)
    }

    /// The corrected force (as [`SensorModel::correct`]) and its Jacobian with respect to the 12
    /// parameters (`params` order), by implicit differentiation of `m = h(b + D (I + M) f)`.
    pub fn correct_with_jacobian(&self, m: [f64; 3]) -> Option<([f64; 3], SensorJacobian)> {
        let f = self.correct(m)?;
        let mut jac = [[0.0; SENSOR_PARAMS]; 3];
        // ∂v/∂θ for v = (u − b)/(1 + s), u = h⁻¹(m): bias, scale and q act on their own axis.
        let mut dv = [[0.0; SENSOR_PARAMS]; 3];
        let v = self.skewed(f);
        for k in 0..3 {
            let d = 1.0 + self.scale_error[k];
            let u = self.bias_mps2[k] + d * v[k];
            let q = self.quadratic_per_mps2[k];
            dv[k][k] = -1.0 / d;
            dv[k][3 + k] = -v[k] / d;
            // q u² + u = m  ⇒  ∂u/∂q = −u² / (1 + 2 q u).
            let slope = 1.0 + 2.0 * q * u;
            if slope.abs() < f64::EPSILON {
                return None;
            }
            dv[k][9 + k] = -u * u / slope / d;
        }
        // f = (I + M)⁻¹ v: forward substitution carries v's derivatives, M's own enter directly.
        let [m_yx, m_zx, m_zy] = self.misalignment_rad;
        for j in 0..SENSOR_PARAMS {
            let fx = dv[0][j];
            let fy = dv[1][j] - m_yx * fx;
            let fz = dv[2][j] - m_zx * fx - m_zy * fy;
            jac[0][j] = fx;
            jac[1][j] = fy;
            jac[2][j] = fz;
        }
        jac[1][6] -= f[0];
        jac[2][6] += m_zy * f[0];
        jac[2][7] -= f[0];
        jac[2][8] -= f[1];
        Some((f, jac))
    }

    /// Checks that the model can be applied: finite values and no scale that maps an axis to 0.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_finite("bias_mps2", &self.bias_mps2)?;
        check_finite("scale_error", &self.scale_error)?;
        check_finite("misalignment_rad", &self.misalignment_rad)?;
        check_finite("quadratic_per_mps2", &self.quadratic_per_mps2)?;
        for k in 0..3 {
            if self.scale_error[k] <= -1.0 {
                return Err(ModelError::new(
                    format!("scale_error[{k}]"),
                    format!(
                        "{}: a scale of 1 + s ≤ 0 inverts or removes the axis",
                        self.scale_error[k]
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// ∂f_k/∂θ_j of a correction: three rows of the 12 sensor parameters.
pub type SensorJacobian = [[f64; SENSOR_PARAMS]; 3];

/// The covariance of the sensor parameters (`SensorModel::params` order), their units' products.
pub type SensorCovariance = [[f64; SENSOR_PARAMS]; SENSOR_PARAMS];

/// What a fitted sensor model's correction is uncertain by: its parameters' covariance (the joint
/// fit's robust sandwich; zero rows for terms held fixed) and the white noise of one reading. A
/// campaign's linear map carries the same, its covariance in its own parameters' order
/// (`LinearModel::params`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorUncertainty {
    pub covariance: SensorCovariance,
    /// White noise of one reading per axis, m/s² (first differences of the campaign's recordings).
    pub noise_sd_mps2: [f64; 3],
    /// The standard deviation of a power-on session's bias offset from the unit's bias, m/s², as
    /// the campaign found it between its sessions (`BiasSpread`); `None` when it held one session
    /// and so could not see it. A reading from a session the campaign did not hold is off by
    /// such an offset, which no correction can know: it adds in quadrature to the corrected
    /// reading's error, not to the correction's (the rows' sd and `predicted_better`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session_spread_mps2: Option<f64>,
}

/// A correction is predicted to beat no correction on an axis when its square exceeds twice its
/// variance: ĉ² − σ² estimates the true correction's square without bias, and applying ĉ leaves σ².
pub fn predicted_to_help(correction_mps2: f64, sd_mps2: f64) -> bool {
    correction_mps2 * correction_mps2 > 2.0 * sd_mps2 * sd_mps2
}

/// The variance per axis that `covariance` gives a correction with Jacobian `jac` (the diagonal
/// of J Σ Jᵀ, first order).
pub fn propagated_variance(jac: &SensorJacobian, covariance: &SensorCovariance) -> [f64; 3] {
    std::array::from_fn(|k| {
        let row = &jac[k];
        let mut sum = 0.0;
        for a in 0..SENSOR_PARAMS {
            if row[a] == 0.0 {
                continue;
            }
            let mut inner = 0.0;
            for b in 0..SENSOR_PARAMS {
                inner += covariance[a][b] * row[b];
            }
            sum += row[a] * inner;
        }
        sum.max(0.0)
    })
}

impl SensorUncertainty {
    /// Checks the covariance can be a covariance (finite, symmetric, non-negative variances, each
    /// correlation within ±1) and the noise is finite and non-negative.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_finite("noise_sd_mps2", &self.noise_sd_mps2)?;
        if let Some(spread) = self.session_spread_mps2 {
            if !(spread.is_finite() && spread >= 0.0) {
                return Err(ModelError::new(
                    "session_spread_mps2",
                    format!("{spread}: a standard deviation is finite and not negative"),
                ));
            }
        }
        if let Some(k) = (0..3).find(|&k| self.noise_sd_mps2[k] < 0.0) {
            return Err(ModelError::new(
                format!("noise_sd_mps2[{k}]"),
                format!("{}: a standard deviation is not negative", self.noise_sd_mps2[k]),
            ));
        }
        for a in 0..SENSOR_PARAMS {
            check_finite(&format!("covariance[{a}]"), &self.covariance[a])?;
            if self.covariance[a][a] < 0.0 {
                return Err(ModelError::new(
                    format!("covariance[{a}][{a}]"),
                    format!("{}: a variance is not negative", self.covariance[a][a]),
                ));
            }
        }
        for a in 0..SENSOR_PARAMS {
            for b in 0..a {
                let (ab, ba) = (self.covariance[a][b], self.covariance[b][a]);
                let bound = (self.covariance[a][a] * self.covariance[b][b]).sqrt();
                if (ab - ba).abs() > 1e-9 * bound.max(f64::MIN_POSITIVE) || ab.abs() > bound * (1.0 + 1e-9) {
                    return Err(ModelError::new(
                        format!("covariance[{a}][{b}]"),
                        format!(
                            "{ab} (and {ba} across the diagonal): a covariance is symmetric with |c_ab| ≤ √(c_aa c_bb) = {bound}"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The saved `physical` corrector: the inverse of a fitted [`SensorModel`], all three axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicalCorrector {
    pub sensor: SensorModel,
    /// Local gravity of the campaign, m/s² (for the record).
    pub gravity_mps2: f64,
    /// The range of readings the campaign covered per axis, m/s² ([min, max]); outside it the
    /// quadratic term is extrapolated and such samples are marked.
    pub input_range_mps2: [[f64; 2]; 3],
    /// The parameters' covariance and the readings' noise, when the fit gave them (format 2):
    /// `correct` then writes each row's predicted standard deviation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<SensorUncertainty>,
}

impl PhysicalCorrector {
    pub fn validate(&self) -> Result<(), ModelError> {
        self.sensor.validate().map_err(|e| e.within("sensor"))?;
        if let Some(uncertainty) = &self.uncertainty {
            uncertainty.validate().map_err(|e| e.within("uncertainty"))?;
        }
        let g = self.gravity_mps2;
        if !(g.is_finite() && g > 0.0) {
            return Err(ModelError::new(
                "gravity_mps2",
                format!("{g}: must be finite and positive"),
            ));
        }
        for (k, [lo, hi]) in self.input_range_mps2.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(ModelError::new(
                    format!("input_range_mps2[{k}]"),
                    format!("[{lo}, {hi}]: must be finite with min ≤ max"),
                ));
            }
        }
        Ok(())
    }

    /// The corrected force for reading `m` and the standard deviation per axis its parameters'
    /// covariance predicts (`None` without a covariance or where the model has no inverse).
    pub fn predicted_sd(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        let uncertainty = self.uncertainty.as_ref()?;
        let (_, jac) = self.sensor.correct_with_jacobian(m)?;
        Some(propagated_variance(&jac, &uncertainty.covariance).map(f64::sqrt))
    }

    /// As [`PhysicalCorrector::predicted_sd`], with the variance of further changes added, each
    /// one standard deviation and independent of the covariance's: of the sensor parameters and
    /// of the reading `m` itself (a thermal part's directions, [`crate::thermal::ThermalUncertainty`]).
    /// The reading enters the model as u in q u² + u = m, so its change acts as a bias change of
    /// −Δm/(1 + 2 q u), with u ≈ m (the difference is of order q², 1e-5 of it).
    pub fn predicted_sd_with<'p>(
        &self,
        m: [f64; 3],
        changes: impl Iterator<Item = (&'p [f64], [f64; 3])>,
    ) -> Option<[f64; 3]> {
        let uncertainty = self.uncertainty.as_ref()?;
        let (_, jac) = self.sensor.correct_with_jacobian(m)?;
        let mut variance = propagated_variance(&jac, &uncertainty.covariance);
        for (sensor, reading) in changes {
            let mut params = [0.0; SENSOR_PARAMS];
            params.iter_mut().zip(sensor).for_each(|(p, v)| *p = *v);
            for k in 0..3 {
                params[k] -= reading[k] / (1.0 + 2.0 * self.sensor.quadratic_per_mps2[k] * m[k]);
            }
            for k in 0..3 {
                let change: f64 = (0..SENSOR_PARAMS).map(|j| jac[k][j] * params[j]).sum();
                variance[k] += change * change;
            }
        }
        Some(variance.map(f64::sqrt))
    }

    /// Whether a reading lies beyond the covered range by more than 10 % of its width.
    pub fn outside_range(&self, m: [f64; 3]) -> bool {
        (0..3).any(|k| {
            let [lo, hi] = self.input_range_mps2[k];
            let margin = 0.1 * (hi - lo);
            m[k] < lo - margin || m[k] > hi + margin
        })
    }
}

struct PhysicalStream<'a>(&'a PhysicalCorrector);

impl SampleCorrector for PhysicalStream<'_> {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        match self.0.sensor.correct(accel_mps2) {
            Some(f) => CorrectedSample {
                accel_mps2: f,
                valid: true,
                outside_training_range: self.0.outside_range(accel_mps2),
            },
            None => CorrectedSample {
                accel_mps2,
                valid: false,
                outside_training_range: true,
            },
        }
    }
}

impl Corrector for PhysicalCorrector {
    fn corrected_axes(&self) -> Vec<Axis> {
        Axis::ALL.to_vec()
    }
    fn warmup_samples(&self) -> usize {
        0
    }
    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        Box::new(PhysicalStream(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With no further change `predicted_sd_with` is `predicted_sd`; a change of the reading alone
    /// adds, per axis, the square of what it moves the correction (against `correct` at the moved
    /// reading, a central difference), and a parameter change J·Δθ.
    #[test]
    fn predicted_sd_with_adds_each_change_s_move_of_the_correction() {
        let mut covariance = [[0.0; SENSOR_PARAMS]; SENSOR_PARAMS];
        for (a, row) in covariance.iter_mut().enumerate() {
            row[a] = [
                1e-6, 1e-6, 1e-6, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-10, 1e-10, 1e-10,
            ][a];
        }
        let corrector = PhysicalCorrector {
            sensor: sensor(),
            gravity_mps2: 9.81,
            input_range_mps2: [[-10.0, 10.0]; 3],
            uncertainty: Some(SensorUncertainty {
                covariance,
                noise_sd_mps2: [0.02; 3],
                session_spread_mps2: None,
            }),
        };
        let m = [3.0, -7.5, 5.0];
        let alone = corrector.predicted_sd(m).unwrap();
        assert_eq!(corrector.predicted_sd_with(m, std::iter::empty()), Some(alone));
        let reading = [2e-3, -1e-3, 3e-3];
        let with = corrector
            .predicted_sd_with(m, std::iter::once((&[0.0; SENSOR_PARAMS][..], reading)))
            .unwrap();
        let h = 1e-3;
        let at = |s: f64| {
            corrector
                .sensor
                .correct(std::array::from_fn(|k| m[k] + s * h * reading[k]))
                .unwrap()
        };
        let (up, down) = (at(1.0), at(-1.0));
        for k in 0..3 {
            let moved = (up[k] - down[k]) / (2.0 * h);
            let added = (with[k] * with[k] - alone[k] * alone[k]).sqrt();
            assert!(
                (added - moved.abs()).abs() < 1e-4 * moved.abs() + 1e-12,
                "axis {k}: {added} against {moved}"
            );
        }
        let mut params = [0.0; SENSOR_PARAMS];
        params[3] = 1e-3;
        let (_, jac) = corrector.sensor.correct_with_jacobian(m).unwrap();
        let with = corrector
            .predicted_sd_with(m, std::iter::once((&params[..], [0.0; 3])))
            .unwrap();
        for k in 0..3 {
            let added = (with[k] * with[k] - alone[k] * alone[k]).max(0.0).sqrt();
            assert!((added - (jac[k][3] * 1e-3).abs()).abs() < 1e-12, "axis {k}");
        }
    }

    fn sensor() -> SensorModel {
        SensorModel {
            bias_mps2: [0.04, -0.06, 0.08],
            scale_error: [0.004, -0.006, 0.003],
            misalignment_rad: [0.005, -0.003, 0.004],
            quadratic_per_mps2: [6e-4, -6e-4, 3e-4],
        }
    }

    #[test]
    fn correct_inverts_measure() {
        let s = sensor();
        for f in [
            [9.8, 0.0, 0.0],
            [-3.0, 7.0, -6.5],
            [0.0, 0.0, 0.0],
            [1.0, -9.8, 2.0],
        ] {
            let back = s.correct(s.measure(f)).unwrap();
            for k in 0..3 {
                assert!((back[k] - f[k]).abs() < 1e-12, "{f:?} → {back:?}");
            }
        }
    }

    #[test]
    fn the_jacobian_matches_central_differences() {
        let s = sensor();
        for m in [[9.9, 0.1, -0.2], [-3.0, 7.0, -6.5], [1.0, -9.7, 2.0]] {
            let (_, jac) = s.correct_with_jacobian(m).unwrap();
            let theta = s.params();
            for j in 0..SENSOR_PARAMS {
                let h = 1e-6;
                let at = |d: f64| {
                    let mut p = theta;
                    p[j] += d;
                    SensorModel::from_params(&p).correct(m).unwrap()
                };
                let (a, b) = (at(h), at(-h));
                for k in 0..3 {
                    let numeric = (a[k] - b[k]) / (2.0 * h);
                    assert!(
                        (numeric - jac[k][j]).abs() < 1e-6 * (1.0 + numeric.abs()),
                        "m {m:?}, f_{k} by θ_{j}: analytic {} numeric {numeric}",
                        jac[k][j]
                    );
                }
            }
        }
    }

    #[test]
    fn a_covariance_that_cannot_be_one_is_refused_by_its_entry() {
        let mut u = SensorUncertainty {
            covariance: [[0.0; SENSOR_PARAMS]; SENSOR_PARAMS],
            noise_sd_mps2: [0.02; 3],
            session_spread_mps2: None,
        };
        for a in 0..SENSOR_PARAMS {
            u.covariance[a][a] = 1e-6;
        }
        assert!(u.validate().is_ok());
        u.covariance[4][1] = 2e-6;
        u.covariance[1][4] = 2e-6;
        assert_eq!(u.validate().unwrap_err().field, "covariance[4][1]");
        u.covariance[1][4] = 0.0;
        u.covariance[4][1] = 0.0;
        u.covariance[3][3] = -1.0;
        assert_eq!(u.validate().unwrap_err().field, "covariance[3][3]");
        u.covariance[3][3] = 1e-6;
        for bad in [-0.01, f64::NAN] {
            u.session_spread_mps2 = Some(bad);
            assert_eq!(u.validate().unwrap_err().field, "session_spread_mps2");
        }
        u.session_spread_mps2 = Some(0.05);
        assert!(u.validate().is_ok());
    }

    #[test]
    fn a_correction_helps_when_its_square_exceeds_twice_its_variance() {
        assert!(predicted_to_help(0.15, 0.1));
        assert!(!predicted_to_help(0.14, 0.1));
        assert!(!predicted_to_help(0.0, 0.0));
    }

    #[test]
    fn a_reading_past_the_turning_point_is_refused() {
        let s = SensorModel {
            quadratic_per_mps2: [0.1, 0.0, 0.0],
            ..SensorModel::IDEAL
        };
        assert!(s.correct([-3.0, 0.0, 0.0]).is_none());
        assert!(s.correct([3.0, 0.0, 0.0]).is_some());
    }

    #[test]
    fn validation_names_the_field() {
        let mut s = sensor();
        s.scale_error[1] = -1.5;
        assert_eq!(s.validate().unwrap_err().field, "scale_error[1]");
        s.scale_error[1] = 0.0;
        s.bias_mps2[2] = f64::NAN;
        assert!(s.validate().unwrap_err().field.starts_with("bias_mps2"));
    }
}
