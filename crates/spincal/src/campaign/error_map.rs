//! Where the saved corrector can be trusted: the standard deviation that its parameters'
//! covariance predicts for a still reading, over every direction of gravity in the sensor's
//! frame, against the readings' own noise. What the report draws and the verdict leads with.

use serde::{Deserialize, Serialize};

use crate::campaign::joint::PoseInput;
use crate::correctors::model_file::ErrorModel;

/// A direction is determined where, on every axis, the predicted standard deviation of the
/// correction is at most this share of one reading's noise: the corrected reading's error is then
/// within √(1 + 0.75²) = 1.25× what the true model would leave on the same sample.
pub const DETERMINED_SD_OVER_NOISE: f64 = 0.75;

/// The map's cells: latitude bands of 15° (rows, from −90° to 90°) by longitude sectors of 30°.
const LATITUDE_STEP_DEG: f64 = 15.0;
const LONGITUDE_STEP_DEG: f64 = 30.0;

/// Directions evenly spread over the sphere (a Fibonacci lattice) for the determined share.
const SHARE_POINTS: usize = 4000;

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
    /// The noise of one reading per axis, m/s² (the campaign's).
    pub noise_sd_mps2: [f64; 3],
    /// Every recorded still pose on the map.
    pub poses: Vec<PoseOnMap>,
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
        format!(
            "Trusted where the error its covariance predicts is at most {:.2}× the noise of one reading: {:.0} % of the directions of gravity{poses}.",
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
    let worst_sd_over_noise = latitude_deg
        .iter()
        .flat_map(|&lat| {
            longitude_deg
                .iter()
                .map(move |&lon| worst_ratio(model, noise, still(direction(lat, lon))))
        })
        .collect();
    let determined = (0..SHARE_POINTS)
        .filter(|&i| {
            let n = crate::geometry::lattice_direction(i, SHARE_POINTS);
            worst_ratio(model, noise, still(n)) <= DETERMINED_SD_OVER_NOISE
        })
        .count();
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
        share_determined: determined as f64 / SHARE_POINTS as f64,
        noise_sd_mps2: noise,
        poses,
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
