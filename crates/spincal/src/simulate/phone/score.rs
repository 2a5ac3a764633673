//! A calibration of a simulated phone session held against its truth: the chip's radius per
//! placement and the gyroscope's scale about the spindle.

use serde::{Deserialize, Serialize};

use super::PhoneTruth;
use crate::campaign::select::CampaignResult;

/// One placement's chip radius: fitted against true.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RadiusScore {
    pub label: String,
    pub true_m: f64,
    /// `None` when the calibration reported no such placement.
    pub fitted_m: Option<f64>,
    /// The fit's standard error, m.
    pub se_m: Option<f64>,
}

impl RadiusScore {
    /// Fitted − true, m.
    pub fn error_m(&self) -> Option<f64> {
        self.fitted_m.map(|f| f - self.true_m)
    }

    /// The error in standard errors.
    pub fn z(&self) -> Option<f64> {
        Some(self.error_m()? / self.se_m.filter(|s| *s > 0.0)?)
    }
}

/// The gyroscope's scale about the spindle, sᵀ K s with s the spindle in the phone's frame (the
/// placements' mean): fitted against true.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GyroScaleScore {
    pub true_scale: f64,
    pub fitted_scale: f64,
    /// The fit's standard error of K's entry along the spindle's axis (z: the phone lies flat).
    pub se: Option<f64>,
}

impl GyroScaleScore {
    /// fitted / true − 1, %.
    pub fn error_pct(&self) -> f64 {
        100.0 * (self.fitted_scale / self.true_scale - 1.0)
    }

    pub fn z(&self) -> Option<f64> {
        Some((self.fitted_scale - self.true_scale) / self.se.filter(|s| *s > 0.0)?)
    }
}

/// A calibration against the session's truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhoneScore {
    pub placements: Vec<RadiusScore>,
    /// `None` when the calibration has no gyroscope fit.
    pub gyro: Option<GyroScaleScore>,
}

impl PhoneScore {
    /// One line per placement and one for the gyroscope, for people.
    pub fn lines(&self) -> Vec<String> {
        let mut lines: Vec<String> = self
            .placements
            .iter()
            .map(|p| match (p.fitted_m, p.se_m) {
                (Some(f), se) => format!(
                    "placement {}: chip at {:.2}{} mm, true {:.2} mm (error {:+.2} mm{})",
                    p.label,
                    1e3 * f,
                    se.map_or(String::new(), |s| format!(" ± {:.2}", 1e3 * s)),
                    1e3 * p.true_m,
                    1e3 * (f - p.true_m),
                    p.z()
                        .map_or(String::new(), |z| format!(", {z:+.1} standard errors"))
                ),
                (None, _) => format!(
                    "placement {}: no radius fitted (true {:.2} mm)",
                    p.label,
                    1e3 * p.true_m
                ),
            })
            .collect();
        match &self.gyro {
            Some(g) => lines.push(format!(
                "gyroscope's scale about the spindle: {:.5}{}, true {:.5} (error {:+.3} %{})",
                g.fitted_scale,
                g.se.map_or(String::new(), |s| format!(" ± {s:.5}")),
                g.true_scale,
                g.error_pct(),
                g.z()
                    .map_or(String::new(), |z| format!(", {z:+.1} standard errors"))
            )),
            None => lines.push("gyroscope: not calibrated".into()),
        }
        lines
    }
}

impl PhoneTruth {
    /// Holds a calibration of this session (`calibrate --campaign` on its campaign.toml) against
    /// the truth.
    pub fn score(&self, result: &CampaignResult) -> PhoneScore {
        let placements = self
            .placements
            .iter()
            .map(|truth| {
                let fit = result.placements.iter().find(|p| p.label == truth.label);
                RadiusScore {
                    label: truth.label.clone(),
                    true_m: truth.chip_radius_m,
                    fitted_m: fit.map(|p| p.radius_m),
                    se_m: fit.and_then(|p| p.radius_se_m),
                }
            })
            .collect();
        let gyro = result.gyro.as_ref().map(|fit| {
            let n = self.placements.len().max(1) as f64;
            let mut s = [0.0; 3];
            for p in &self.placements {
                for k in 0..3 {
                    s[k] += p.spindle_in_body[k] / n;
                }
            }
            let norm = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt().max(1e-12);
            let s = s.map(|v| v / norm);
            let along = |k: &[[f64; 3]; 3]| -> f64 {
                (0..3)
                    .map(|i| (0..3).map(|j| s[i] * k[i][j] * s[j]).sum::<f64>())
                    .sum()
            };
            GyroScaleScore {
                true_scale: along(&self.gyroscope.sensitivity),
                fitted_scale: along(&fit.model.sensitivity),
                se: fit
                    .params
                    .iter()
                    .find(|p| p.name == "gyro_K_zz")
                    .and_then(|p| p.std_error),
            }
        });
        PhoneScore { placements, gyro }
    }
}
