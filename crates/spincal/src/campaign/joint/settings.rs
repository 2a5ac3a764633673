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
    /// Prior widths of the sensor terms about zero: bias (m/s²), scale error, misalignment (rad),
    /// quadratic nonlinearity (1/(m/s²)). A campaign file's datasheet keys set them
    /// ([`crate::campaign::file::Datasheet`]); else 0.5 m/s², 0.02, 0.02 rad and 0.5 % FS over
    /// ±8 g (about 10⁻⁴), standard deviations of a typical consumer part. A wider prior on q lets
    /// it trade with the bias drift between poses.
    pub sensor_prior_sd: [f64; 4],
    /// Which of those are bounds (a datasheet's), not standard deviations. A bound's estimate is
    /// penalised as by a standard deviation of the bound, which pulls a term near the bound little
    /// (a flat prior inside it would not at all), and the covariance takes the bound's
    /// rectangular variance, bound²/3 (JCGM 100 §4.3.7). The penalty at bound/√3 instead let a
    /// new session's offset take a q near the bound (bench/accuracy/RESULTS.md).
    #[serde(default)]
    pub sensor_prior_is_bound: [bool; 4],
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
            sensor_prior_is_bound: [false; 4],
            terms: SensorTerms::ALL,
            block_s: 5.0,
            max_iterations: 100,
        }
    }
}

impl JointSettings {
    /// Sets the prior on each term the datasheet bounds to that bound
    /// ([`JointSettings::sensor_prior_is_bound`]); the others keep theirs.
    pub fn set_datasheet_priors(&mut self, datasheet: &crate::campaign::file::Datasheet) {
        let g0 = crate::input::recording::STANDARD_GRAVITY;
        let bounds = [
            datasheet.zero_g_offset_mg.map(|mg| mg * 1e-3 * g0),
            datasheet.sensitivity_tolerance_pct.map(|pct| pct / 100.0),
            datasheet.cross_axis_pct.map(|pct| pct / 100.0),
            datasheet.nonlinearity.map(|n| n.quadratic_per_mps2()),
        ];
        for (group, bound) in bounds.into_iter().enumerate() {
            if let Some(bound) = bound {
                self.sensor_prior_sd[group] = bound;
                self.sensor_prior_is_bound[group] = true;
            }
        }
    }
}

/// The nonlinearity prior when the campaign gives no datasheet: a typical MEMS part's 0.5 % of
/// full scale over ±8 g.
pub const DEFAULT_NONLINEARITY_PCT_FS: f64 = 0.5;
pub const DEFAULT_NONLINEARITY_RANGE_G: f64 = 8.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::file::Datasheet;
    use crate::input::recording::STANDARD_GRAVITY;

    #[test]
    fn a_datasheet_bounds_the_terms_it_gives_and_leaves_the_others() {
        let mut joint = JointSettings::default();
        let default = joint.sensor_prior_sd;
        joint.set_datasheet_priors(&Datasheet {
            zero_g_offset_mg: Some(50.0),
            cross_axis_pct: Some(2.0),
            ..Datasheet::default()
        });
        // 50 mg on the biases and 2 % on the misalignments, as bounds; the scale errors and q
        // keep the defaults, as standard deviations.
        assert!((joint.sensor_prior_sd[0] - 0.05 * STANDARD_GRAVITY).abs() < 1e-12);
        assert_eq!(joint.sensor_prior_sd[1], default[1]);
        assert!((joint.sensor_prior_sd[2] - 0.02).abs() < 1e-15);
        assert_eq!(joint.sensor_prior_sd[3], default[3]);
        assert_eq!(joint.sensor_prior_is_bound, [true, false, true, false]);
    }
}
