//! Where the saved corrector can be trusted: the standard deviation that its parameters'
//! covariance predicts for a still reading, over every direction of gravity in the sensor's
//! frame, against the readings' own noise. What the report draws and the verdict leads with.

use serde::{Deserialize, Serialize};

use crate::campaign::candidate::wald_statistic;
use crate::campaign::joint::advice::{pose_information, unit, PosePlan, CANDIDATES, WORTHWHILE_DROP};
use crate::campaign::joint::{JointFit, PoseInput, HELD_POSE_DEG};
use crate::correctors::model_file::ErrorModel;
use crate::correctors::physical::{PhysicalCorrector, SensorCovariance, SENSOR_PARAMS};
use crate::geometry::{dot, lattice_direction};
use crate::metrics::{share_beyond_noise, term_threshold};

/// A direction is determined where, on every axis, the predicted standard deviation of the
/// correction is at most this share of one reading's noise: the corrected reading's error is then
/// within √(1 + 0.75²) = 1.25× what the true model would leave on the same sample.
pub const DETERMINED_SD_OVER_NOISE: f64 = 0.75;

/// The map's cells: latitude bands of 15° (rows, from −90° to 90°) by longitude sectors of 30°.
const LATITUDE_STEP_DEG: f64 = 15.0;
const LONGITUDE_STEP_DEG: f64 = 30.0;

/// Directions evenly spread over the sphere (a Fibonacci lattice) for the determined share.
const SHARE_POINTS: usize = 4000;

/// Directions over which each candidate for the next pose is judged (coarser than the share's:
/// every one of `CANDIDATES` is tried against each).
const OBJECTIVE_POINTS: usize = 500;

/// The predicted error over the directions of gravity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorMap {
    /// Row centres: gravity's elevation above the sensor's x–y plane, degrees (+90: along +z).
    pub latitude_deg: Vec<f64>,
    /// Column centres: its azimuth from +x towards +y, degrees.
    pub longitude_deg: Vec<f64>,
    /// Row-major (`row * columns + column`): the largest over the axes of the predicted standard
    /// deviation over that axis's noise, at the cell's centre.
    pub worst_sd_over_noise: Vec<f64>,
    /// [`DETERMINED_SD_OVER_NOISE`].
    pub threshold: f64,
    /// The share of all directions of gravity where every axis is within the threshold.
    pub share_determined: f64,
    /// The median over all directions of gravity of the worst axis's predicted sd over the noise
    /// (`None` in a results.json from before it was reported).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median_sd_over_noise: Option<f64>,
    /// The noise of one reading per axis, m/s² (the campaign's).
    pub noise_sd_mps2: [f64; 3],
    /// Every recorded still pose on the map.
    pub poses: Vec<PoseOnMap>,
    /// The still pose that would most widen the trusted region ([`next_pose`]); `None` where
    /// every direction is trusted, no single pose helps, or the model is not the physical one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_pose: Option<NextPose>,
}

/// The still pose advised to widen where a saved physical model is trusted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NextPose {
    /// Gravity's direction in the sensor frame (unit; component k is the sine of axis k's
    /// elevation above level).
    pub pose_direction: [f64; 3],
    /// How long to hold it (the campaign's median pose), s, when the poses say.
    pub hold_s: Option<f64>,
    /// The share of the directions of gravity trusted once it is recorded, as predicted.
    pub share_determined_after: f64,
    /// The median over the directions of gravity of the worst axis's predicted sd over the noise:
    /// now, and predicted once the pose is recorded.
    pub median_sd_over_noise: [f64; 2],
    /// The new pose's bias offset from the others assumed (a file of its own, the spread the
    /// campaign found), m/s².
    pub offset_sd_mps2: f64,
    /// What to record, in words a user can follow.
    pub sentence: String,
}

/// A recorded still pose on the error map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseOnMap {
    pub name: String,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub worst_sd_over_noise: f64,
}

impl ErrorMap {
    /// The recorded poses outside the determined region.
    pub fn poses_outside(&self) -> Vec<&PoseOnMap> {
        self.poses
            .iter()
            // NaN counts as outside.
            .filter(|p| {
                !matches!(
                    p.worst_sd_over_noise.partial_cmp(&self.threshold),
                    Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
                )
            })
            .collect()
    }

    /// The map's cell (row, column) that holds a direction.
    pub fn cell_of(&self, latitude_deg: f64, longitude_deg: f64) -> (usize, usize) {
        let row = ((latitude_deg + 90.0) / LATITUDE_STEP_DEG).floor() as usize;
        let column = ((longitude_deg + 180.0) / LONGITUDE_STEP_DEG).floor() as usize;
        (
            row.min(self.latitude_deg.len() - 1),
            column.min(self.longitude_deg.len() - 1),
        )
    }

    /// One sentence: the share of directions where the correction can be trusted and whether
    /// every recorded pose lies there.
    pub fn sentence(&self) -> String {
        let outside = self.poses_outside();
        let poses = if self.poses.is_empty() {
            String::new()
        } else if outside.is_empty() {
            format!(
                ", every one of the {} recorded poses among them",
                self.poses.len()
            )
        } else {
            format!(
                "; {} of the {} recorded poses lie outside it ({})",
                outside.len(),
                self.poses.len(),
                outside
                    .iter()
                    .map(|p| p.name.as_str())
                    .take(4)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        let next = self
            .next_pose
            .as_ref()
            .map_or(String::new(), |n| format!(" {}.", n.sentence));
        format!(
            "Trusted where the error its covariance predicts is at most {:.2}× the noise of one reading: {:.0} % of the directions of gravity{poses}.{next}",
            self.threshold,
            100.0 * self.share_determined
        )
    }
}

/// A unit vector from latitude and longitude in degrees.
fn direction(latitude_deg: f64, longitude_deg: f64) -> [f64; 3] {
    let (lat, lon) = (latitude_deg.to_radians(), longitude_deg.to_radians());
    [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

/// The largest over the axes of the predicted sd over the noise, for the still reading that
/// gravity `g` along `n` gives; infinite where the model has no inverse or no covariance.
fn worst_ratio(model: ErrorModel<'_>, noise: [f64; 3], reading: Option<[f64; 3]>) -> f64 {
    match reading.and_then(|m| model.predicted_sd(m)) {
        Some(sd) => (0..3)
            .map(|k| sd[k] / noise[k].max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max),
        None => f64::INFINITY,
    }
}

/// The error map of a corrector saved with its uncertainty (physical or linear-12) under local
/// gravity `gravity_mps2`, with the campaign's still poses placed on it.
pub fn error_map(model: ErrorModel<'_>, gravity_mps2: f64, poses: &[PoseInput]) -> ErrorMap {
    let noise = model.uncertainty().noise_sd_mps2;
    let still = |n: [f64; 3]| model.reading_of(n.map(|v| gravity_mps2 * v));
    let rows = (180.0 / LATITUDE_STEP_DEG) as usize;
    let columns = (360.0 / LONGITUDE_STEP_DEG) as usize;
    let latitude_deg: Vec<f64> = (0..rows)
        .map(|r| -90.0 + (r as f64 + 0.5) * LATITUDE_STEP_DEG)
        .collect();
    let longitude_deg: Vec<f64> = (0..columns)
        .map(|c| -180.0 + (c as f64 + 0.5) * LONGITUDE_STEP_DEG)
        .collect();
    let (share_determined, median_sd_over_noise) = over_the_sphere(model, gravity_mps2);
    let worst_sd_over_noise = latitude_deg
        .iter()
        .flat_map(|&lat| {
            longitude_deg
                .iter()
                .map(move |&lon| worst_ratio(model, noise, still(direction(lat, lon))))
        })
        .collect();
    let poses = poses
        .iter()
        .map(|pose| {
            let f = model.corrected(pose.mean_mps2).unwrap_or(pose.mean_mps2);
            let norm = f.iter().map(|v| v * v).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
            PoseOnMap {
                name: pose.name.clone(),
                latitude_deg: (f[2] / norm).clamp(-1.0, 1.0).asin().to_degrees(),
                longitude_deg: f[1].atan2(f[0]).to_degrees(),
                worst_sd_over_noise: worst_ratio(model, noise, Some(pose.mean_mps2)),
            }
        })
        .collect();
    ErrorMap {
        latitude_deg,
        longitude_deg,
        worst_sd_over_noise,
        threshold: DETERMINED_SD_OVER_NOISE,
        share_determined,
        median_sd_over_noise: Some(median_sd_over_noise),
        noise_sd_mps2: noise,
        poses,
        next_pose: None,
    }
}

/// Over directions evenly spread over the sphere: the share where every axis's predicted sd is
/// within the threshold, and the median of the worst axis's.
fn over_the_sphere(model: ErrorModel<'_>, gravity_mps2: f64) -> (f64, f64) {
    let noise = model.uncertainty().noise_sd_mps2;
    let mut worst: Vec<f64> = (0..SHARE_POINTS)
        .map(|i| {
            let n = lattice_direction(i, SHARE_POINTS);
            worst_ratio(model, noise, model.reading_of(n.map(|v| gravity_mps2 * v)))
        })
        .collect();
    let determined = worst.iter().filter(|&&r| r <= DETERMINED_SD_OVER_NOISE).count();
    worst.sort_by(f64::total_cmp);
    (determined as f64 / SHARE_POINTS as f64, worst[SHARE_POINTS / 2])
}

/// The still pose, at least `HELD_POSE_DEG` from every held one, that most widens where
/// `corrector` is trusted (`map`: its error map, whose median is the "now" of the prediction).
/// `fuller` is the fit the terms rule judged (q on every axis): the saved
/// covariance is its covariance C plus the share (1 − k/W)₊ of the move d dᵀ that holding the
/// left-out q at zero made (`candidate::error_bar_covariance`). Each candidate direction's
/// information a (as the per-parameter advice has it: a file of its own, held as long as the
/// campaign's poses, the campaign's bias spread) updates C by Sherman–Morrison; where every
/// left-out q would then pass the terms rule the move goes, else it stays with the share its new
/// Wald statistic gives. The candidate that most lowers the mean over the directions of gravity of
/// max(worst sd / noise, threshold) is taken: a measure that counts directions brought inside the
/// region and, where none can be, the error left outside it. `None` where every direction is
/// trusted already or no candidate lowers that mean by `WORTHWHILE_DROP`.
pub fn next_pose(
    map: &ErrorMap,
    corrector: &PhysicalCorrector,
    fuller: &JointFit,
    poses: &[PoseInput],
) -> Option<NextPose> {
    let uncertainty = corrector.uncertainty.as_ref()?;
    let noise = uncertainty.noise_sd_mps2;
    let g = corrector.gravity_mps2;
    let sensor = &corrector.sensor;
    let left = LeftOut::of(corrector, fuller);
    let c = &left.covariance;
    // Each direction's Jacobian of the correction per axis, over that axis's noise.
    let rows: Vec<[[f64; SENSOR_PARAMS]; 3]> = (0..OBJECTIVE_POINTS)
        .filter_map(|i| {
            let n = lattice_direction(i, OBJECTIVE_POINTS);
            let (_, jac) = sensor.correct_with_jacobian(sensor.measure(n.map(|v| g * v)))?;
            Some(std::array::from_fn(|k| {
                std::array::from_fn(|p| jac[k][p] / noise[k].max(f64::MIN_POSITIVE))
            }))
        })
        .collect();
    if rows.is_empty() {
        return None;
    }
    let dot12 = |x: &[f64; SENSOR_PARAMS], y: &[f64; SENSOR_PARAMS]| -> f64 {
        (0..SENSOR_PARAMS).map(|p| x[p] * y[p]).sum()
    };
    let times_c =
        |x: &[f64; SENSOR_PARAMS]| -> [f64; SENSOR_PARAMS] { std::array::from_fn(|r| dot12(&c[r], x)) };
    // Per direction and axis: J C Jᵀ and J d.
    let base: Vec<[(f64, f64); 3]> = rows
        .iter()
        .map(|j| std::array::from_fn(|k| (dot12(&j[k], &times_c(&j[k])), dot12(&j[k], &left.change))))
        .collect();
    // Worst axis's sd over the noise per direction, C updated by (C a, aᵀ C a), the move's share.
    let worst = |update: Option<(&[f64; SENSOR_PARAMS], f64)>, share: f64| -> Vec<f64> {
        rows.iter()
            .zip(&base)
            .map(|(j, v)| {
                (0..3)
                    .map(|k| {
                        let drop = update.map_or(0.0, |(ca, aca)| dot12(&j[k], ca).powi(2) / (1.0 + aca));
                        (v[k].0 - drop + share * v[k].1 * v[k].1).max(0.0).sqrt()
                    })
                    .fold(0.0, f64::max)
            })
            .collect()
    };
    let measure = |w: &[f64]| -> f64 {
        w.iter()
            .map(|r| r.max(DETERMINED_SD_OVER_NOISE) / DETERMINED_SD_OVER_NOISE)
            .sum::<f64>()
            / w.len() as f64
    };
    let before = measure(&worst(None, left.share(None)));
    if before <= 1.0 + 1e-12 {
        return None;
    }
    let plan = PosePlan::of(fuller, poses);
    let held: Vec<[f64; 3]> = poses.iter().filter_map(|p| unit(p.mean_mps2)).collect();
    let near = HELD_POSE_DEG.to_radians().cos();
    // (measure after, direction, C a, aᵀ C a, the move's share)
    type Scored = (f64, [f64; 3], [f64; SENSOR_PARAMS], f64, f64);
    let mut best: Option<Scored> = None;
    for i in 0..CANDIDATES {
        let u = lattice_direction(i, CANDIDATES);
        if held.iter().any(|h| dot(h, &u) > near) {
            continue;
        }
        let Some(a) = pose_information(sensor, u, g, &plan) else {
            continue;
        };
        let ca = times_c(&a);
        let aca = dot12(&a, &ca);
        if !(aca.is_finite() && aca >= 0.0) {
            continue;
        }
        let share = left.share(Some((&ca, aca)));
        let after = measure(&worst(Some((&ca, aca)), share));
        if after.is_finite() && best.is_none_or(|(b, ..)| after < b) {
            best = Some((after, u, ca, aca, share));
        }
    }
    let (after, u, ca, aca, share) = best?;
    if after > (1.0 - WORTHWHILE_DROP) * before {
        return None;
    }
    let mut with_pose = corrector.clone();
    if let Some(w) = with_pose.uncertainty.as_mut() {
        w.covariance = std::array::from_fn(|r| {
            std::array::from_fn(|p| {
                c[r][p] - ca[r] * ca[p] / (1.0 + aca) + share * left.change[r] * left.change[p]
            })
        });
    }
    let (share_after, median_after) = over_the_sphere(ErrorModel::Physical(&with_pose), g);
    let median_sd_over_noise = [map.median_sd_over_noise?, median_after];
    Some(NextPose {
        pose_direction: u,
        hold_s: plan.hold_s,
        share_determined_after: share_after,
        median_sd_over_noise,
        offset_sd_mps2: plan.offset_sd,
        sentence: format!(
            "To widen it, record next {}: predicted trusted over {:.0} % of the directions of gravity, the median predicted error {:.2} → {:.2}× the noise{}",
            plan.describe(u),
            100.0 * share_after,
            median_sd_over_noise[0],
            median_sd_over_noise[1],
            plan.assumption()
        ),
    })
}

/// The saved model's covariance taken apart: the fuller fit's covariance, and the move its
/// left-out q made (none where it leaves none out, or the fuller fit has no covariance: then the
/// saved covariance alone, updated as if every term were free).
struct LeftOut {
    covariance: SensorCovariance,
    /// θ_fuller, whose left-out q the terms rule tests.
    theta: [f64; SENSOR_PARAMS],
    /// The q the saved model holds at zero and the fuller fit estimates.
    terms: Vec<usize>,
    /// d = θ_saved − θ_fuller.
    change: [f64; SENSOR_PARAMS],
    /// The terms rule's |q̂/se| threshold, solved once (every candidate pose is tested against it).
    threshold: f64,
}

impl LeftOut {
    fn of(corrector: &PhysicalCorrector, fuller: &JointFit) -> LeftOut {
        let saved = corrector.sensor.params();
        let theta = fuller.sensor.params();
        let terms: Vec<usize> = (9..SENSOR_PARAMS)
            .filter(|&k| {
                saved[k] == 0.0 && theta[k] != 0.0 && fuller.sensor_params.get(k).is_some_and(|p| p.free)
            })
            .collect();
        match fuller.sensor_covariance() {
            Some(covariance) if !terms.is_empty() => LeftOut {
                covariance,
                theta,
                terms,
                change: std::array::from_fn(|k| saved[k] - theta[k]),
                threshold: term_threshold(),
            },
            _ => LeftOut {
                covariance: corrector
                    .uncertainty
                    .as_ref()
                    .map_or([[0.0; SENSOR_PARAMS]; SENSOR_PARAMS], |u| u.covariance),
                theta,
                terms: Vec::new(),
                change: [0.0; SENSOR_PARAMS],
                threshold: term_threshold(),
            },
        }
    }

    /// The share of the move d dᵀ in the covariance after the update (C a, aᵀ C a), or now: none
    /// where every left-out q would pass the terms rule, else (1 − k/W)₊.
    fn share(&self, update: Option<(&[f64; SENSOR_PARAMS], f64)>) -> f64 {
        if self.terms.is_empty() {
            return 0.0;
        }
        let c: SensorCovariance = std::array::from_fn(|r| {
            std::array::from_fn(|p| {
                self.covariance[r][p] - update.map_or(0.0, |(ca, aca)| ca[r] * ca[p] / (1.0 + aca))
            })
        });
        if update.is_some()
            && self
                .terms
                .iter()
                .all(|&k| self.theta[k].abs() >= self.threshold * c[k][k].max(0.0).sqrt())
        {
            return 0.0;
        }
        wald_statistic(&c, &self.theta, &self.terms).map_or(1.0, |w| share_beyond_noise(w, self.terms.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::correctors::physical::{PhysicalCorrector, SensorModel, SensorUncertainty, SENSOR_PARAMS};

    fn corrector(variances: [f64; SENSOR_PARAMS]) -> PhysicalCorrector {
        let mut covariance = [[0.0; SENSOR_PARAMS]; SENSOR_PARAMS];
        for (a, v) in variances.iter().enumerate() {
            covariance[a][a] = *v;
        }
        PhysicalCorrector {
            sensor: SensorModel::IDEAL,
            gravity_mps2: 9.81,
            input_range_mps2: [[-10.0, 10.0]; 3],
            uncertainty: Some(SensorUncertainty {
                covariance,
                noise_sd_mps2: [0.02; 3],
                session_spread_mps2: None,
            }),
        }
    }

    #[test]
    fn a_loose_z_scale_leaves_only_directions_near_level_determined() {
        // The sd of f_z is |f_z| · sd(s_z), so only directions near level are within 0.75 × 0.02.
        let mut v = [0.0; SENSOR_PARAMS];
        v[5] = 0.01f64.powi(2);
        let physical = corrector(v);
        let map = error_map(ErrorModel::Physical(&physical), 9.81, &[]);
        // |sin lat| · 9.81 · 0.01 ≤ 0.015 ⇔ |sin lat| ≤ 0.153: that share of the sphere.
        assert!(
            (map.share_determined - 0.153).abs() < 0.01,
            "{}",
            map.share_determined
        );
        let (equator, pole) = (map.cell_of(1.0, 0.0), map.cell_of(89.0, 0.0));
        let at = |(r, c): (usize, usize)| map.worst_sd_over_noise[r * map.longitude_deg.len() + c];
        assert!(
            at(equator) < 0.75 && at(pole) > 4.0,
            "{} {}",
            at(equator),
            at(pole)
        );
    }

    /// The linear map's A_zz plays the physical model's 1 + s_z: the same loose term gives the
    /// same map.
    #[test]
    fn a_linear_map_with_a_loose_zz_gives_the_physical_map() {
        let mut v = [0.0; SENSOR_PARAMS];
        v[5] = 0.01f64.powi(2);
        let physical = corrector(v);
        let mut linear = crate::correctors::linear::LinearModel {
            axes: crate::correctors::corrector::Axis::ALL.to_vec(),
            offset_mps2: vec![0.0; 3],
            matrix: vec![vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]],
            training: None,
            uncertainty: physical.uncertainty.clone(),
        };
        // A_zz is parameter 3 + 3·2 + 2 = 11.
        let u = linear.uncertainty.as_mut().unwrap();
        u.covariance[5][5] = 0.0;
        u.covariance[11][11] = v[5];
        let (a, b) = (
            error_map(ErrorModel::Physical(&physical), 9.81, &[]),
            error_map(ErrorModel::Linear(&linear), 9.81, &[]),
        );
        assert_eq!(a.share_determined, b.share_determined);
        for (x, y) in a.worst_sd_over_noise.iter().zip(&b.worst_sd_over_noise) {
            assert!((x - y).abs() < 1e-9 * x.max(1.0), "{x} {y}");
        }
    }

    #[test]
    fn poses_outside_the_region_are_named() {
        let mut v = [0.0; SENSOR_PARAMS];
        v[5] = 0.01f64.powi(2);
        let pose = |name: &str, m: [f64; 3]| PoseInput {
            name: name.into(),
            mean_mps2: m,
            sigma_mean_mps2: [1e-3; 3],
            samples: 100,
            time_s: 0.0,
            session: 0,
            gyro_mean_radps: None,
            gyro_sigma_mean_radps: None,
            wander: None,
        };
        let physical = corrector(v);
        let map = error_map(
            ErrorModel::Physical(&physical),
            9.81,
            &[pose("level", [9.81, 0.0, 0.0]), pose("up", [0.0, 0.0, 9.81])],
        );
        let outside: Vec<&str> = map.poses_outside().iter().map(|p| p.name.as_str()).collect();
        assert_eq!(outside, ["up"]);
        assert!(
            map.sentence()
                .contains("1 of the 2 recorded poses lie outside it (up)"),
            "{}",
            map.sentence()
        );
    }
}
