//! The joint fit's settings: which sensor terms are free, priors and iteration limits.

use serde::{Deserialize, Serialize};

/// Which sensor terms are estimated (the others stay at zero).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SensorTerms {
    pub bias_scale: bool,
    pub misalignment: bool,
    pub nonlinearity: bool,
    /// With `nonlinearity`, the axes whose q is estimated (the campaign's terms rule keeps q only
    /// where the data show it).
    #[serde(default = "every_axis")]
    pub nonlinearity_axes: [bool; 3],
}

fn every_axis() -> [bool; 3] {
    [true; 3]
}

impl SensorTerms {
    pub const ALL: SensorTerms = SensorTerms {
        bias_scale: true,
        misalignment: true,
        nonlinearity: true,
        nonlinearity_axes: [true; 3],
    };
    pub const LINEAR: SensorTerms = SensorTerms {
        bias_scale: true,
        misalignment: true,
        nonlinearity: false,
        nonlinearity_axes: [true; 3],
    };
    pub const BIAS_SCALE: SensorTerms = SensorTerms {
        bias_scale: true,
        misalignment: false,
        nonlinearity: false,
        nonlinearity_axes: [true; 3],
    };
    /// The sensor held fixed (a perfect sensor): only the recordings' geometry is fitted.
    pub const NONE: SensorTerms = SensorTerms {
        bias_scale: false,
        misalignment: false,
        nonlinearity: false,
        nonlinearity_axes: [true; 3],
    };

    /// The terms in words.
    pub fn describe(self) -> &'static str {
        match (self.bias_scale, self.misalignment, self.nonlinearity) {
            (true, true, true) if self.nonlinearity_axes != [true; 3] => {
                "bias, scale, misalignment and nonlinearity on some axes"
            }
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
            _ => self.nonlinearity && self.nonlinearity_axes.get(k - 9).copied().unwrap_or(false),
        }
    }
}

/// Settings of the joint fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointSettings {
    pub gravity_mps2: f64,
    /// Standard deviation of a session's (or a run's) bias offset from the unit's bias, m/s²:
    /// the prior of the fit's first pass, and of the whole fit when not estimated.
    pub bias_instability_mps2: f64,
    /// Whether that spread is estimated from the recordings (by their marginal likelihood,
    /// [`super::BiasSpread`]) between the fit's two passes.
    pub estimate_bias_spread: bool,
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
            estimate_bias_spread: true,
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
