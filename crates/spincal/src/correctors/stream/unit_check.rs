//! The acceleration unit held against gravity before any row is written: a file in g read as
//! m/s² (a plain `t,ax,ay,az` header) reads |a| ≈ 1 where the model expects 9.81, and every
//! row it corrects is wrong while looking ordinary.

use super::CorrectError;
use crate::correctors::model_file::CorrectorModel;
use crate::input::recording::STANDARD_GRAVITY;

/// Rows at the start of a recording whose median |a| is checked: 2 s at 100 Hz, enough for a
/// median that one jolt does not move, few enough to be read ahead in constant memory.
pub(crate) const UNIT_CHECK_ROWS: usize = 200;

/// How far (a factor either way) the ratio of the gravity the model expects to the first rows'
/// median |a| may lie from 9.81 (or 1/9.81) and still be taken for a unit mix-up. Within it a
/// file reads 0.67–1.5 m/s² (or 6.5–15 g) where it should read 1 g, which no recording does that
/// starts at rest or in ordinary motion (a hand or a vehicle stays within 0.5–2 g over two
/// seconds); only free fall through the whole first rows, or a sustained 6.5 g, would be
/// refused, and an m/s²/g mix-up lies at a factor 1.0 from 9.81.
pub(crate) const UNIT_RATIO_BAND: f64 = 1.5;

/// The magnitude of gravity the model's input reads at rest, m/s²: networks and linear maps are
/// trained in m/s² (standard gravity), the physical kinds and a static calibration of m/s² state
/// their gravity; a static calibration of raw counts has no unit to check (`None`).
pub(crate) fn expected_gravity_mps2(model: &CorrectorModel) -> Option<f64> {
    match model {
        CorrectorModel::Ann(_) | CorrectorModel::Linear(_) => Some(STANDARD_GRAVITY),
        CorrectorModel::Physical(p) => Some(p.gravity_mps2),
        CorrectorModel::PhysicalAnn(p) => Some(p.physical.gravity_mps2),
        CorrectorModel::Static(s) => (s.input_unit == "m/s^2").then_some(s.gravity_mps2),
        // The accelerometer passes as read: nothing of it is applied.
        CorrectorModel::Uncorrected(_) => None,
    }
}

/// Refuses a file whose first rows' median |a| (`magnitudes_mps2`, as the model will read them,
/// finite ones only) is about g/9.81 or g·9.81 of `expected_mps2`.
pub(crate) fn check_accel_unit(
    file: &str,
    magnitudes_mps2: &mut [f64],
    expected_mps2: f64,
) -> Result<(), CorrectError> {
    if magnitudes_mps2.is_empty() {
        return Ok(());
    }
    let middle = magnitudes_mps2.len() / 2;
    let median = *magnitudes_mps2.select_nth_unstable_by(middle, f64::total_cmp).1;
    let ratio = expected_mps2 / median;
    let near = |target: f64| ratio > target / UNIT_RATIO_BAND && ratio < target * UNIT_RATIO_BAND;
    let (looks_like, read_as, fix) = if near(STANDARD_GRAVITY) {
        (
            "g",
            "m/s²",
            "give `accel_unit` g, or name the columns with their unit (ax_g, ay_g, az_g)",
        )
    } else if near(1.0 / STANDARD_GRAVITY) {
        (
            "m/s²",
            "g",
            "give `accel_unit` mps2 (the column names or `accel_unit` say g)",
        )
    } else {
        return Ok(());
    };
    Err(CorrectError::AccelUnit {
        file: file.to_string(),
        rows: magnitudes_mps2.len(),
        median_mps2: median,
        expected_mps2,
        looks_like,
        read_as,
        fix,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(values: &[f64]) -> Result<(), CorrectError> {
        check_accel_unit("f.csv", &mut values.to_vec(), STANDARD_GRAVITY)
    }

    #[test]
    fn g_read_as_mps2_and_the_reverse_are_refused_and_motion_is_not() {
        let err = check(&[1.009, 1.0, 0.99, 1.02]).unwrap_err().to_string();
        assert!(err.contains("look like g, read as m/s²"), "{err}");
        assert!(err.contains("`accel_unit` g"), "{err}");
        let err = check(&[96.2, 96.0, 96.3]).unwrap_err().to_string();
        assert!(err.contains("look like m/s², read as g"), "{err}");
        assert!(err.contains("`accel_unit` mps2"), "{err}");
        // At rest, moving at 0.5–2 g, in free fall: not a unit.
        for level in [9.8, 4.9, 19.6, 0.05] {
            assert!(check(&[level; 5]).is_ok(), "{level}");
        }
        // The band's edges: 0.67–1.5 m/s² is a unit mix-up, 0.6 and 1.6 are not.
        assert!(check(&[0.7]).is_err() && check(&[1.45]).is_err());
        assert!(check(&[0.6]).is_ok() && check(&[1.6]).is_ok());
        assert!(check(&[]).is_ok());
    }
}
