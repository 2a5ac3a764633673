//! Which free sensor terms the campaign leaves undetermined, and for each the next still pose that
//! most reduces its variance, computed from the campaign's information (SPEC §7).
//!
//! A still pose with free direction (two nuisance angles) and its own bias offset δ ~ N(0, s²)
//! informs the sensor only along one reading direction w, the normal of the two directions the
//! angles move the reading: information a aᵀ with a = Jᵀw / √(wᵀΣw), J = ∂m/∂θ at f = g·u and
//! Σ = σ²/N + s² (per axis). With C the fit's covariance, Sherman–Morrison gives
//! var'_k = C_kk − (C a)_k² / (1 + aᵀC a). Turntable runs are not candidates: a run's centripetal
//! level rests on ω, which the fit takes from the platter's tilt modulation, whose size is not
//! known before the run is recorded; unmodelled and unvalidated, runs are left out.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Deserializer, Serialize};

use super::input::PoseInput;
use super::result::JointFit;
use crate::correctors::physical::{SensorModel, SENSOR_PARAMS};
use crate::geometry::{cross, dot, lattice_direction};

/// Candidate directions of gravity over the sphere.
pub(crate) const CANDIDATES: usize = 2000;
/// A candidate within this angle of a held pose's direction is not advised (it is that pose).
pub const HELD_POSE_DEG: f64 = 20.0;
/// Below this relative drop of the standard error, no single new pose is worth advising.
pub(crate) const WORTHWHILE_DROP: f64 = 0.05;
/// Without any still pose to copy, a new pose is taken as 10 s at 100 Hz.
const DEFAULT_POSE_SAMPLES: f64 = 1000.0;

/// The next recording advised for one poorly determined sensor parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Advice {
    /// The parameter, as in `JointFit::sensor_params`.
    pub parameter: String,
    /// Its robust standard error now; `None` when the fit did not determine it.
    pub std_error: Option<f64>,
    /// The still pose advised: gravity's direction in the sensor frame (unit; component k is the
    /// sine of axis k's elevation above level). `None` when no direction helps.
    pub pose_direction: Option<[f64; 3]>,
    /// How long to hold it (the campaign's median pose), s, when the poses say.
    pub hold_s: Option<f64>,
    /// The parameter's standard error predicted once that pose is recorded.
    pub predicted_std_error: Option<f64>,
    /// The new pose's bias offset from the others assumed (its own recording, the spread the
    /// campaign found), m/s²; NaN in advice read from an older results.json.
    pub offset_sd_mps2: f64,
    /// What to record, in words a user can follow.
    pub sentence: String,
}

/// Reads the current form and the older `[name, text]` pairs of results.json.
impl<'de> Deserialize<'de> for Advice {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        struct Current {
            parameter: String,
            std_error: Option<f64>,
            pose_direction: Option<[f64; 3]>,
            hold_s: Option<f64>,
            predicted_std_error: Option<f64>,
            // NaN (an older file's) is written as null.
            offset_sd_mps2: Option<f64>,
            sentence: String,
        }
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Either {
            Current(Current),
            Pair(String, String),
        }
        Ok(match Either::deserialize(deserializer)? {
            Either::Current(c) => Advice {
                parameter: c.parameter,
                std_error: c.std_error,
                pose_direction: c.pose_direction,
                hold_s: c.hold_s,
                predicted_std_error: c.predicted_std_error,
                offset_sd_mps2: c.offset_sd_mps2.unwrap_or(f64::NAN),
                sentence: c.sentence,
            },
            Either::Pair(parameter, sentence) => Advice {
                parameter,
                std_error: None,
                pose_direction: None,
                hold_s: None,
                predicted_std_error: None,
                offset_sd_mps2: f64::NAN,
                sentence,
            },
        })
    }
}

impl JointFit {
    /// Free sensor parameters whose uncertainty matters: one standard error moves a reading at
    /// 1 g by more than `tolerance_mps2`. Each comes with the still pose, away from the held
    /// ones (`poses`: their mean readings), that most reduces its variance.
    pub fn undetermined(&self, gravity: f64, tolerance_mps2: f64, poses: &[PoseInput]) -> Vec<Advice> {
        let bad: Vec<usize> = (0..self.sensor_params.len().min(SENSOR_PARAMS))
            .filter(|&k| {
                let p = &self.sensor_params[k];
                let effect = match k {
                    0..=2 => 1.0,
                    3..=8 => gravity,
                    _ => gravity * gravity,
                };
                p.free
                    && p.std_error
                        .is_none_or(|se| se.is_nan() || se * effect > tolerance_mps2)
            })
            .collect();
        if bad.is_empty() {
            return Vec::new();
        }
        let plan = PosePlan::of(self, poses);
        let best = self
            .sensor_covariance()
            .map(|c| best_poses(&c, &self.sensor, gravity, &plan, poses, &bad));
        bad.iter()
            .enumerate()
            .map(|(i, &k)| {
                let p = &self.sensor_params[k];
                let short = p.name.split(" (").next().unwrap_or(&p.name);
                let found = best.as_ref().and_then(|b| b[i]);
                let sentence = match (p.std_error.filter(|s| s.is_finite()), found) {
                    (_, None) if best.is_none() => {
                        "the fit has no covariance to plan from: record still poses at orientations spread over the sphere, away from those held".to_string()
                    }
                    (_, None) => format!(
                        "every direction of gravity lies within {HELD_POSE_DEG:.0}° of a held pose or none informs {short}: repeat the held poses in one power-on, each held longer"
                    ),
                    (None, Some((u, var))) => format!(
                        "{}: se of {short} → {:.2e}{}",
                        plan.describe(u),
                        var.max(0.0).sqrt(),
                        plan.assumption()
                    ),
                    (Some(se), Some((u, var))) => {
                        let after = var.max(0.0).sqrt();
                        let pose = plan.describe(u);
                        if after > (1.0 - WORTHWHILE_DROP) * se {
                            format!(
                                "no single new still pose brings se of {short} down by {:.0} % (the best, {pose}: {se:.2e} → {after:.2e}){}",
                                100.0 * WORTHWHILE_DROP,
                                plan.assumption()
                            )
                        } else {
                            format!("{pose}: se of {short} {se:.2e} → {after:.2e}{}", plan.assumption())
                        }
                    }
                };
                Advice {
                    parameter: p.name.clone(),
                    std_error: p.std_error,
                    pose_direction: found.map(|(u, _)| u),
                    hold_s: plan.hold_s,
                    predicted_std_error: found.map(|(_, v)| v.max(0.0).sqrt()),
                    offset_sd_mps2: plan.offset_sd,
                    sentence,
                }
            })
            .collect()
    }
}

/// How a new pose would be recorded: as long as the campaign's, in a power-on of its own.
pub(crate) struct PosePlan {
    /// σ²/N of its mean per axis, (m/s²)².
    mean_var: [f64; 3],
    pub(crate) hold_s: Option<f64>,
    pub(crate) offset_sd: f64,
}

impl PosePlan {
    pub(crate) fn of(fit: &JointFit, poses: &[PoseInput]) -> PosePlan {
        let median = |mut v: Vec<f64>| {
            v.retain(|x| x.is_finite() && *x > 0.0);
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied()
        };
        let mean_var = std::array::from_fn(|k| {
            median(poses.iter().map(|p| p.sigma_mean_mps2[k]).collect())
                .or_else(|| {
                    // A campaign of runs only: their residual RMS per sample over a default hold.
                    median(fit.runs.iter().map(|r| r.residual_rms_mps2[k]).collect())
                        .map(|s| s / DEFAULT_POSE_SAMPLES.sqrt())
                })
                .map_or(1e-6, |s| s * s)
        });
        let hold_s = median(
            poses
                .iter()
                .filter_map(|p| p.wander.map(|w| w.duration_s))
                .collect(),
        );
        PosePlan {
            mean_var,
            hold_s,
            offset_sd: fit.bias_spread.sd_mps2.max(0.0),
        }
    }

    /// The pose in user terms: each axis's elevation above level.
    pub(crate) fn describe(&self, u: [f64; 3]) -> String {
        let axes = ["x", "y", "z"];
        let elevations: Vec<String> = (0..3)
            .map(|k| {
                let e = u[k].clamp(-1.0, 1.0).asin().to_degrees();
                if e.abs() < 0.5 {
                    format!("{} level", axes[k])
                } else if e > 0.0 {
                    format!("{} {e:.0}° above level", axes[k])
                } else {
                    format!("{} {:.0}° below level", axes[k], -e)
                }
            })
            .collect();
        let hold = self
            .hold_s
            .map_or("as long as the campaign's poses".to_string(), |t| {
                format!("{t:.0} s")
            });
        format!(
            "a still pose with {} (gravity along ({:.2}, {:.2}, {:.2}) in the sensor frame), held {hold}",
            elevations.join(", "),
            u[0],
            u[1],
            u[2]
        )
    }

    pub(crate) fn assumption(&self) -> String {
        format!(
            " (as a file of its own: its bias offset from the others taken as {:.1e} m/s², the spread the campaign found)",
            self.offset_sd
        )
    }
}

/// For each parameter in `params`, the candidate direction that leaves it the smallest variance
/// and that variance; `None` where no candidate is allowed or informative.
fn best_poses(
    c: &[[f64; SENSOR_PARAMS]; SENSOR_PARAMS],
    sensor: &SensorModel,
    gravity: f64,
    plan: &PosePlan,
    poses: &[PoseInput],
    params: &[usize],
) -> Vec<Option<([f64; 3], f64)>> {
    let held: Vec<[f64; 3]> = poses.iter().filter_map(|p| unit(p.mean_mps2)).collect();
    let near = HELD_POSE_DEG.to_radians().cos();
    let mut best: Vec<Option<([f64; 3], f64)>> = vec![None; params.len()];
    for i in 0..CANDIDATES {
        let u = lattice_direction(i, CANDIDATES);
        if held.iter().any(|h| dot(h, &u) > near) {
            continue;
        }
        let Some(a) = pose_information(sensor, u, gravity, plan) else {
            continue;
        };
        let ca: [f64; SENSOR_PARAMS] =
            std::array::from_fn(|r| (0..SENSOR_PARAMS).map(|j| c[r][j] * a[j]).sum());
        let aca: f64 = (0..SENSOR_PARAMS).map(|j| a[j] * ca[j]).sum();
        if !(aca.is_finite() && aca >= 0.0) {
            continue;
        }
        for (slot, &k) in best.iter_mut().zip(params) {
            let var = c[k][k] - ca[k] * ca[k] / (1.0 + aca);
            if var.is_finite() && slot.is_none_or(|(_, v)| var < v) {
                *slot = Some((u, var));
            }
        }
    }
    best
}

/// The vector a of a still pose with gravity along `u` (information a aᵀ on the sensor's
/// parameters once its two angles and its bias offset are taken out); `None` where degenerate.
pub(crate) fn pose_information(
    sensor: &SensorModel,
    u: [f64; 3],
    gravity: f64,
    plan: &PosePlan,
) -> Option<[f64; SENSOR_PARAMS]> {
    let f = u.map(|v| gravity * v);
    let lin = sensor.linear_response(f, [0.0; 3]);
    let q = sensor.quadratic_per_mps2;
    let h: [f64; 3] = std::array::from_fn(|k| 1.0 + 2.0 * q[k] * lin[k]);
    // ∂m/∂f = diag(h′) D (I + M).
    let lm = sensor.linear_matrix();
    let dm_df: [[f64; 3]; 3] = std::array::from_fn(|k| std::array::from_fn(|j| h[k] * lm[k][j]));
    // ∂m/∂θ (3 × 12) from the correction's Jacobian: f̂(m(θ), θ) = f at fixed f gives
    // ∂m/∂θ = −(∂m/∂f) ∂f̂/∂θ.
    let (_, corrected) = sensor.correct_with_jacobian(sensor.measure(f))?;
    let jac: [[f64; SENSOR_PARAMS]; 3] = std::array::from_fn(|k| {
        std::array::from_fn(|p| -(0..3).map(|i| dm_df[k][i] * corrected[i][p]).sum::<f64>())
    });
    // The directions the pose's angles move the reading: ∂m/∂f along two tangents of the sphere.
    let moved = |t: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|k| (0..3).map(|j| dm_df[k][j] * t[j]).sum::<f64>())
    };
    let smallest = (0..3).min_by(|&a, &b| u[a].abs().total_cmp(&u[b].abs()))?;
    let mut e = [0.0; 3];
    e[smallest] = 1.0;
    let t1 = unit(cross(&u, &e))?;
    let t2 = cross(&u, &t1);
    let w = cross(&moved(t1), &moved(t2));
    // Reading noise of the mean and the pose's own offset (through h), per axis.
    let var: f64 = (0..3)
        .map(|k| w[k] * w[k] * (plan.mean_var[k] + (h[k] * plan.offset_sd).powi(2)))
        .sum();
    if !(var.is_finite() && var > 0.0) {
        return None;
    }
    let scale = var.sqrt();
    Some(std::array::from_fn(|j| {
        (0..3).map(|k| jac[k][j] * w[k]).sum::<f64>() / scale
    }))
}

pub(crate) fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(&v, &v).sqrt();
    (n.is_finite() && n > 0.0).then(|| v.map(|x| x / n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn advice_reads_back_and_older_pairs_still_read() {
        let a = Advice {
            parameter: "quadratic_x (1/(m/s²))".into(),
            std_error: Some(3e-4),
            pose_direction: Some([0.6, 0.0, 0.8]),
            hold_s: None,
            predicted_std_error: Some(1e-5),
            offset_sd_mps2: 1e-4,
            sentence: "a still pose".into(),
        };
        let back: Advice = serde_json::from_str(&serde_json::to_string(&a).unwrap()).unwrap();
        assert_eq!(back, a);
        let old: Vec<Advice> =
            serde_json::from_str(r#"[["bias_x (m/s²)", "still poses with the x axis up and down"]]"#)
                .unwrap();
        assert_eq!(old[0].parameter, "bias_x (m/s²)");
        assert!(old[0].pose_direction.is_none() && old[0].offset_sd_mps2.is_nan());
        // Written again (NaN as null) and read once more.
        let again: Vec<Advice> = serde_json::from_str(&serde_json::to_string(&old).unwrap()).unwrap();
        assert_eq!(again[0].sentence, old[0].sentence);
    }
}
