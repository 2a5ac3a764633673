//! Calibrations in the files other tools read: Kalibr's `imu.yaml` (noise figures), imu_tk's
//! `.calib` (misalignment, scale, bias) and imucal's calibration JSON (Ferraris format 2.0).
//!
//! spincal's accelerometer model is m = b + D (I + M) f (+ a quadratic term none of these formats
//! holds), its gyroscope model m = b_g + K ω, both in the accelerometer's body frame
//! (`correctors::physical`, `campaign::gyro`).

// 3×3 algebra reads best with indices.
#![allow(clippy::needless_range_loop)]

use std::fmt::Write as _;

use crate::correctors::gyro::GyroModel;
use crate::correctors::physical::SensorModel;
use crate::geometry::{from_row_major, inverse, mul, transpose, M3};

/// The noise figures Kalibr's IMU model takes (one value per sensor, continuous time).
#[derive(Debug, Clone, PartialEq)]
pub struct KalibrImu {
    /// m/s²/√Hz.
    pub accelerometer_noise_density: f64,
    /// m/s³/√Hz.
    pub accelerometer_random_walk: f64,
    /// rad/s/√Hz.
    pub gyroscope_noise_density: f64,
    /// rad/s²/√Hz.
    pub gyroscope_random_walk: f64,
    pub rostopic: String,
    pub update_rate_hz: f64,
}

impl KalibrImu {
    /// From per-axis Allan figures: Kalibr takes one value per sensor, so the largest axis is used
    /// (the conservative choice).
    pub fn from_axes(
        accel: &crate::allan::NoiseParams,
        gyro: &crate::allan::NoiseParams,
        rostopic: &str,
        update_rate_hz: f64,
    ) -> KalibrImu {
        let max = |v: &[f64; 3]| v.iter().copied().fold(0.0, f64::max);
        KalibrImu {
            accelerometer_noise_density: max(&accel.noise_density),
            accelerometer_random_walk: max(&accel.random_walk),
            gyroscope_noise_density: max(&gyro.noise_density),
            gyroscope_random_walk: max(&gyro.random_walk),
            rostopic: rostopic.to_string(),
            update_rate_hz,
        }
    }

    /// The `imu.yaml` text, with Kalibr's keys.
    pub fn to_yaml(&self) -> String {
        let mut s = String::new();
        s.push_str(
            "# IMU noise model for Kalibr (spincal allan --kalibr): continuous-time densities from the\n",
        );
        s.push_str("# Allan deviation, the largest axis of each sensor.\n");
        let _ = writeln!(
            s,
            "accelerometer_noise_density: {:.6e}  # m/s^2/sqrt(Hz)",
            self.accelerometer_noise_density
        );
        let _ = writeln!(
            s,
            "accelerometer_random_walk: {:.6e}  # m/s^3/sqrt(Hz)",
            self.accelerometer_random_walk
        );
        let _ = writeln!(
            s,
            "gyroscope_noise_density: {:.6e}  # rad/s/sqrt(Hz)",
            self.gyroscope_noise_density
        );
        let _ = writeln!(
            s,
            "gyroscope_random_walk: {:.6e}  # rad/s^2/sqrt(Hz)",
            self.gyroscope_random_walk
        );
        let _ = writeln!(s, "rostopic: {}", self.rostopic);
        let _ = writeln!(s, "update_rate: {}  # Hz", self.update_rate_hz);
        s
    }
}

/// One imu_tk calibration: corrected = T K (raw − b), T unit-diagonal misalignment, K diagonal scale.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuTkCalib {
    pub misalignment: M3,
    pub scale: [f64; 3],
    pub bias: [f64; 3],
}

/// A `.calib` file that does not hold the 21 numbers imu_tk writes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: not an imu_tk calibration: {why}")]
pub struct ImuTkError {
    pub file: String,
    pub why: String,
}

impl ImuTkCalib {
    /// The text imu_tk reads: the 3×3 misalignment, the 3×3 (diagonal) scale, the 3×1 bias.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for r in 0..3 {
            let _ = writeln!(
                s,
                "{:.12e} {:.12e} {:.12e}",
                self.misalignment[r][0], self.misalignment[r][1], self.misalignment[r][2]
            );
        }
        s.push('\n');
        for r in 0..3 {
            let row: [f64; 3] = std::array::from_fn(|c| if c == r { self.scale[r] } else { 0.0 });
            let _ = writeln!(s, "{:.12e} {:.12e} {:.12e}", row[0], row[1], row[2]);
        }
        s.push('\n');
        for b in self.bias {
            let _ = writeln!(s, "{b:.12e}");
        }
        s
    }

    /// Reads imu_tk's text: 21 whitespace-separated numbers (the scale matrix must be diagonal).
    pub fn parse(text: &str, file: &str) -> Result<ImuTkCalib, ImuTkError> {
        let err = |why: String| ImuTkError {
            file: file.to_string(),
            why,
        };
        let mut values = Vec::with_capacity(21);
        for (line_no, line) in text.lines().enumerate() {
            for token in line.split_whitespace() {
                let v: f64 = token
                    .parse()
                    .map_err(|_| err(format!("line {}: '{token}' is not a number", line_no + 1)))?;
                if !v.is_finite() {
                    return Err(err(format!("line {}: '{token}' is not finite", line_no + 1)));
                }
                values.push(v);
            }
        }
        if values.len() != 21 {
            return Err(err(format!(
                "{} numbers, but a calibration has 21 (3×3 misalignment, 3×3 scale, 3 biases)",
                values.len()
            )));
        }
        let m = |o: usize| from_row_major(&values[o..]);
        let scale = m(9);
        for r in 0..3 {
            for c in 0..3 {
                if r != c && scale[r][c] != 0.0 {
                    return Err(err(format!(
                        "the scale matrix has {} at row {}, column {}; imu_tk's is diagonal",
                        scale[r][c],
                        r + 1,
                        c + 1
                    )));
                }
            }
        }
        Ok(ImuTkCalib {
            misalignment: m(0),
            scale: [scale[0][0], scale[1][1], scale[2][2]],
            bias: [values[18], values[19], values[20]],
        })
    }

    /// Applies it: T K (raw − b).
    pub fn apply(&self, raw: [f64; 3]) -> [f64; 3] {
        let d: [f64; 3] = std::array::from_fn(|k| self.scale[k] * (raw[k] - self.bias[k]));
        std::array::from_fn(|r| (0..3).map(|c| self.misalignment[r][c] * d[c]).sum())
    }

    /// From a map corrected = G (raw − b): K = diag(G), T = G K⁻¹.
    fn from_map(g: &M3, bias: [f64; 3]) -> ImuTkCalib {
        let scale = [g[0][0], g[1][1], g[2][2]];
        ImuTkCalib {
            misalignment: std::array::from_fn(|r| std::array::from_fn(|c| g[r][c] / scale[c])),
            scale,
            bias,
        }
    }
}

/// The accelerometer and gyroscope as imu_tk files. imu_tk's accelerometer misalignment is upper
/// triangular, spincal's lower triangular: the two body frames differ by a rotation, which is
/// applied to the gyroscope too so that both files share imu_tk's frame. The quadratic terms are
/// left out.
pub fn imu_tk_calibs(
    sensor: &SensorModel,
    gyro: Option<&GyroModel>,
) -> Option<(ImuTkCalib, Option<ImuTkCalib>)> {
    // f = A (m − b), A = (D (I + M))⁻¹; A = Q U (Gram–Schmidt on A's columns), imu_tk's frame is Qᵀ f.
    let a = inverse(&sensor.linear_matrix())?;
    let mut q = [[0.0; 3]; 3];
    let mut u = [[0.0; 3]; 3];
    for j in 0..3 {
        let mut v: [f64; 3] = std::array::from_fn(|r| a[r][j]);
        for i in 0..j {
            let dot: f64 = (0..3).map(|r| q[r][i] * a[r][j]).sum();
            u[i][j] = dot;
            for r in 0..3 {
                v[r] -= dot * q[r][i];
            }
        }
        let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if norm < 1e-12 {
            return None;
        }
        u[j][j] = norm;
        for r in 0..3 {
            q[r][j] = v[r] / norm;
        }
    }
    let accel = ImuTkCalib::from_map(&u, sensor.bias_mps2);
    let gyro = match gyro {
        Some(g) => {
            let k_inv = inverse(&g.sensitivity)?;
            let qt_k_inv = mul(&transpose(&q), &k_inv);
            Some(ImuTkCalib::from_map(&qt_k_inv, g.bias_radps))
        }
        None => None,
    };
    Some((accel, gyro))
}

/// imucal's `FerrarisCalibrationInfo` JSON (format 2.0): acc = R_a⁻¹ K_a⁻¹ (acc_raw − b_a),
/// gyr = R_g⁻¹ K_g⁻¹ (gyr_raw − K_ga acc − b_g), in m/s² and rad/s from m/s² and rad/s. Here
/// K_a = D, R_a = I + M, K_g = diag(K), R_g = K K_g⁻¹, K_ga = 0. The quadratic terms are left out
/// (the comment says so).
pub fn imucal_json(sensor: &SensorModel, gyro: Option<&GyroModel>) -> serde_json::Value {
    let d = sensor.scale_error.map(|s| 1.0 + s);
    let diag = |v: [f64; 3]| -> M3 {
        std::array::from_fn(|r| std::array::from_fn(|c| if r == c { v[r] } else { 0.0 }))
    };
    let m = sensor.misalignment_rad;
    let r_a: M3 = [[1.0, 0.0, 0.0], [m[0], 1.0, 0.0], [m[1], m[2], 1.0]];
    let (k_g, r_g, b_g) = match gyro {
        Some(g) => {
            let k = [g.sensitivity[0][0], g.sensitivity[1][1], g.sensitivity[2][2]];
            let r: M3 = std::array::from_fn(|r| std::array::from_fn(|c| g.sensitivity[r][c] / k[r]));
            (diag(k), r, g.bias_radps)
        }
        None => (diag([1.0; 3]), diag([1.0; 3]), [0.0; 3]),
    };
    let quadratic = sensor.quadratic_per_mps2.iter().any(|&q| q != 0.0);
    serde_json::json!({
        "acc_unit": "m/s^2",
        "gyr_unit": "rad/s",
        "from_acc_unit": "m/s^2",
        "from_gyr_unit": "rad/s",
        "comment": format!(
            "spincal {} campaign calibration{}{}",
            env!("CARGO_PKG_VERSION"),
            if quadratic { "; the accelerometer's quadratic nonlinearity is not representable here and is left out" } else { "" },
            if gyro.is_none() { "; no gyroscope calibration (identity)" } else { "" }
        ),
        "K_a": diag(d),
        "R_a": r_a,
        "b_a": sensor.bias_mps2,
        "K_g": k_g,
        "R_g": r_g,
        "K_ga": diag([0.0; 3]),
        "b_g": b_g,
        "cal_type": "Ferraris",
        "_format_version": "2.0",
    })
}

/// A static calibration (`spincal static`) as imucal's JSON and imu_tk's files, in the reading's
/// own units (counts or m/s²): the same model, a = T K (r − b), so the files hold it exactly
/// (imucal: K_a = K⁻¹, R_a = T⁻¹, b_a = b; imu_tk: T, K, b), except a 12-parameter model's
/// quadratic terms, which are left out and said so in imucal's comment. The gyroscope, when
/// calibrated, goes beside it as in [`imucal_json`].
pub fn static_files(
    calibration: &crate::correctors::static_cal::StaticCalibration,
    gyro: Option<&GyroModel>,
) -> Option<Vec<(&'static str, String)>> {
    let t = calibration.misalignment_matrix();
    let t_inverse = inverse(&t)?;
    let k_a: M3 = std::array::from_fn(|r| {
        std::array::from_fn(|c| if r == c { 1.0 / calibration.scale[r] } else { 0.0 })
    });
    if k_a.iter().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    let quadratic = calibration.nonlinearity.iter().any(|&q| q != 0.0);
    let mut imucal = imucal_json(
        &SensorModel {
            bias_mps2: calibration.bias,
            ..SensorModel::default()
        },
        gyro,
    );
    imucal["K_a"] = serde_json::json!(k_a);
    imucal["R_a"] = serde_json::json!(t_inverse);
    imucal["from_acc_unit"] = serde_json::json!(calibration.input_unit);
    if let Some(g) = gyro {
        imucal["from_gyr_unit"] = serde_json::json!(if g.input_unit.is_rad_per_s() {
            "rad/s"
        } else {
            "counts"
        });
    }
    imucal["comment"] = serde_json::json!(format!(
        "spincal {} static calibration{}{}",
        env!("CARGO_PKG_VERSION"),
        if quadratic {
            "; the accelerometer's quadratic nonlinearity is not representable here and is left out"
        } else {
            ""
        },
        if gyro.is_none() {
            "; no gyroscope calibration (identity)"
        } else {
            ""
        }
    ));
    let mut files = vec![("imucal.json", pretty(&imucal))];
    let accel = ImuTkCalib {
        misalignment: t,
        scale: calibration.scale,
        bias: calibration.bias,
    };
    files.push(("imu_tk_acc.calib", accel.to_text()));
    if let Some(g) = gyro {
        let k_inv = inverse(&g.sensitivity)?;
        files.push((
            "imu_tk_gyro.calib",
            ImuTkCalib::from_map(&k_inv, g.bias_radps).to_text(),
        ));
    }
    Some(files)
}

/// A value as pretty JSON with a final newline, as every JSON file spincal writes.
pub(crate) fn pretty<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_string_pretty(value).expect("results serialise") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sensor() -> SensorModel {
        SensorModel {
            bias_mps2: [0.04, -0.06, 0.08],
            scale_error: [0.004, -0.006, 0.003],
            misalignment_rad: [0.01, -0.005, 0.007],
            quadratic_per_mps2: [0.0; 3],
        }
    }

    fn gyro() -> GyroModel {
        GyroModel {
            bias_radps: [0.01, -0.02, 0.005],
            sensitivity: [
                [1.005, 0.007, -0.005],
                [0.008, 0.992, 0.003],
                [-0.007, 0.005, 1.006],
            ],
            input_unit: Default::default(),
        }
    }

    #[test]
    fn imu_tk_files_round_trip_and_reproduce_the_correction_up_to_one_rotation() {
        let (s, g) = (sensor(), gyro());
        let (acc, gyr) = imu_tk_calibs(&s, Some(&g)).unwrap();
        let gyr = gyr.unwrap();
        // imu_tk's accelerometer misalignment is unit upper triangular.
        for r in 0..3 {
            assert!((acc.misalignment[r][r] - 1.0).abs() < 1e-12);
            for c in 0..r {
                assert!(acc.misalignment[r][c].abs() < 1e-12);
            }
        }
        let back = ImuTkCalib::parse(&acc.to_text(), "a.calib").unwrap();
        for r in 0..3 {
            for c in 0..3 {
                assert!((back.misalignment[r][c] - acc.misalignment[r][c]).abs() < 1e-12);
            }
        }
        // Both files give spincal's corrected vectors in one common rotated frame: lengths and
        // the angle between a specific force and a rate agree.
        let corrector = crate::correctors::physical::PhysicalCorrector {
            sensor: s,
            gravity_mps2: 9.81,
            input_range_mps2: [[-20.0, 20.0]; 3],
            uncertainty: None,
        };
        let gc = g.corrector().unwrap();
        for (f, w) in [
            ([1.0, 2.0, 9.0], [0.3, -1.0, 3.5]),
            ([-9.0, 0.5, 1.0], [4.0, 0.2, -0.1]),
        ] {
            let m = s.measure(f);
            let ours = corrector.sensor.correct(m).unwrap();
            let theirs = acc.apply(m);
            let wm = g.measure(w);
            let ours_w = gc.correct(wm);
            let theirs_w = gyr.apply(wm);
            let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            assert!((dot(ours, ours).sqrt() - dot(theirs, theirs).sqrt()).abs() < 1e-9);
            assert!((dot(ours, ours_w) - dot(theirs, theirs_w)).abs() < 1e-9);
            assert!((dot(ours_w, ours_w) - dot(theirs_w, theirs_w)).abs() < 1e-9);
        }
    }

    #[test]
    fn imu_tk_parse_names_what_is_wrong() {
        let e = ImuTkCalib::parse("1 0 0\n0 1 x\n", "t.calib").unwrap_err();
        assert!(e.to_string().contains("line 2: 'x'"), "{e}");
        let e = ImuTkCalib::parse("1 2 3", "t.calib").unwrap_err();
        assert!(e.to_string().contains("3 numbers"), "{e}");
    }

    #[test]
    fn kalibr_yaml_has_kalibrs_keys() {
        let k = KalibrImu {
            accelerometer_noise_density: 1.86e-3,
            accelerometer_random_walk: 4.33e-4,
            gyroscope_noise_density: 1.87e-4,
            gyroscope_random_walk: 2.66e-5,
            rostopic: "/imu0".into(),
            update_rate_hz: 200.0,
        };
        let y = k.to_yaml();
        for key in [
            "accelerometer_noise_density: 1.86",
            "accelerometer_random_walk: 4.33",
            "gyroscope_noise_density: 1.87",
            "gyroscope_random_walk: 2.66",
            "rostopic: /imu0",
            "update_rate: 200",
        ] {
            assert!(y.contains(key), "{key} missing in\n{y}");
        }
    }
}
