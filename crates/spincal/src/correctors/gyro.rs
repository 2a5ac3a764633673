//! A gyroscope's calibration m = b + K ω (ω: true rate in the accelerometer's body frame, rad/s)
//! and its inverse, applied by `correct` to the gyro columns. `campaign::gyro` fits it.

// 3×3 algebra reads best with indices.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{check_finite, ModelError};
use crate::geometry::{determinant, inverse, M3};

/// What a gyroscope's readings m are in: rad/s (the model corrects small errors) or raw counts
/// (the model also carries the conversion: b in counts, K in counts per rad/s).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GyroInputUnit {
    #[default]
    RadPerS,
    Counts,
}

impl GyroInputUnit {
    pub fn is_rad_per_s(&self) -> bool {
        *self == GyroInputUnit::RadPerS
    }

    /// The unit as written after a number.
    pub fn name(self) -> &'static str {
        match self {
            GyroInputUnit::RadPerS => "rad/s",
            GyroInputUnit::Counts => "counts",
        }
    }
}

/// A gyroscope's bias and sensitivity: m = b + K ω.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroModel {
    /// b, rad/s (counts when `input_unit` is counts).
    pub bias_radps: [f64; 3],
    /// K, row per gyro axis: reading per unit of true rate about each body axis.
    pub sensitivity: M3,
    /// The unit of the readings m; absent in files means rad/s.
    #[serde(default, skip_serializing_if = "GyroInputUnit::is_rad_per_s")]
    pub input_unit: GyroInputUnit,
}

impl GyroModel {
    pub const IDEAL: GyroModel = GyroModel {
        bias_radps: [0.0; 3],
        sensitivity: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        input_unit: GyroInputUnit::RadPerS,
    };

    /// The reading for true rate `w` (body frame, rad/s).
    pub fn measure(&self, w: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| {
            self.bias_radps[i] + (0..3).map(|j| self.sensitivity[i][j] * w[j]).sum::<f64>()
        })
    }

    /// The corrector: K⁻¹ and b, so that ω = K⁻¹ (m − b). `None` when K is singular.
    pub fn corrector(&self) -> Option<GyroCorrector> {
        Some(GyroCorrector {
            bias: self.bias_radps,
            inverse: inverse(&self.sensitivity)?,
        })
    }

    /// Checks what applying the model relies on: finite values, each axis's own scale between
    /// 0.5 and 2 (rad/s input), K well-conditioned. For counts the scale is free, but each row's
    /// own entry must dominate it and K must stay well-conditioned relative to its size.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_finite("bias_radps", &self.bias_radps)?;
        for i in 0..3 {
            check_finite(&format!("sensitivity[{i}]"), &self.sensitivity[i])?;
        }
        if self.input_unit == GyroInputUnit::Counts {
            return self.validate_counts();
        }
        for i in 0..3 {
            let k = self.sensitivity[i][i];
            if !(0.5..=2.0).contains(&k) {
                return Err(ModelError::new(
                    format!("sensitivity[{i}][{i}]"),
                    format!("{k}: an axis's own sensitivity must lie between 0.5 and 2"),
                ));
            }
        }
        let det = determinant(&self.sensitivity);
        if det.abs() < 0.1 {
            return Err(ModelError::new(
                "sensitivity",
                format!("determinant {det}: the axes are nearly dependent, the inverse would amplify noise"),
            ));
        }
        Ok(())
    }

    fn validate_counts(&self) -> Result<(), ModelError> {
        let k = &self.sensitivity;
        let row_norm = |i: usize| (0..3).map(|j| k[i][j] * k[i][j]).sum::<f64>().sqrt();
        for i in 0..3 {
            let own = k[i][i].abs();
            if !(own > 0.0 && own >= 0.5 * row_norm(i)) {
                return Err(ModelError::new(
                    format!("sensitivity[{i}][{i}]"),
                    format!("{}: an axis's own sensitivity must dominate its row", k[i][i]),
                ));
            }
        }
        // Hadamard's ratio: 1 for orthogonal rows, 0 for dependent ones.
        let ratio = determinant(k).abs() / (row_norm(0) * row_norm(1) * row_norm(2));
        if ratio.is_nan() || ratio < 0.1 {
            return Err(ModelError::new(
                "sensitivity",
                format!("|det| / product of row norms {ratio}: the axes are nearly dependent"),
            ));
        }
        Ok(())
    }
}

/// The inverse of a [`GyroModel`], ready to apply.
#[derive(Debug, Clone, Copy)]
pub struct GyroCorrector {
    bias: [f64; 3],
    inverse: M3,
}

impl GyroCorrector {
    /// The true rate for reading `m`, rad/s.
    pub fn correct(&self, m: [f64; 3]) -> [f64; 3] {
        let d: [f64; 3] = std::array::from_fn(|k| m[k] - self.bias[k]);
        std::array::from_fn(|i| (0..3).map(|j| self.inverse[i][j] * d[j]).sum())
    }
}
