//! Which free sensor terms the campaign leaves undetermined, and the recording that would fix each.

use super::input::PoseInput;
use super::result::JointFit;

impl JointFit {
    /// Free sensor parameters whose uncertainty matters: one standard error moves a reading at
    /// 1 g by more than `tolerance_mps2`. Each comes with the recording that would determine it;
    /// where the campaign already holds those poses (`poses`: their mean readings), the advice
    /// says so and names what limits them instead.
    pub fn undetermined(
        &self,
        gravity: f64,
        tolerance_mps2: f64,
        poses: &[PoseInput],
    ) -> Vec<(String, String)> {
        let axis = ["x", "y", "z"];
        // Whether some pose holds axis k within about 25° of up (sign +1) or down (−1).
        let held = |k: usize, sign: f64| {
            poses.iter().any(|p| {
                let m = p.mean_mps2;
                let norm = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                norm > 0.0 && sign * m[k] / norm > 0.9
            })
        };
        let mut out = Vec::new();
        for (k, p) in self.sensor_params.iter().enumerate() {
            if !p.free {
                continue;
            }
            let effect = match k {
                0..=2 => 1.0,
                3..=8 => gravity,
                _ => gravity * gravity,
            };
            let bad = p
                .std_error
                .is_none_or(|se| se.is_nan() || se * effect > tolerance_mps2);
            if !bad {
                continue;
            }
            let advice = match k {
                0..=5 if held(k % 3, 1.0) && held(k % 3, -1.0) => format!(
                    "the campaign already holds poses with the {} axis up and down; what limits it is the bias wandering between them and between recordings: hold each pose longer, take the up and down poses one after the other, or repeat them",
                    axis[k % 3]
                ),
                0..=5 => format!(
                    "still poses with the {} axis up and down",
                    axis[k % 3]
                ),
                6 => "still poses tilted about 45° between x and y, or a turntable run with z along the spindle".into(),
                7 => "still poses tilted about 45° between x and z, or a turntable run with y along the spindle".into(),
                8 => "still poses tilted about 45° between y and z, or a turntable run with x along the spindle".into(),
                _ => format!(
                    "still poses with the {0} axis up, down and level, or a turntable run with {0} pointing out at a higher speed",
                    axis[k - 9]
                ),
            };
            out.push((p.name.clone(), advice));
        }
        out
    }
}
