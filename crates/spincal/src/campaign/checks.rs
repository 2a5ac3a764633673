//! A campaign's recordings checked against physics before any fit, so that a wrong key gives an
//! error that names the recording, the key and the fix instead of a fit that believes it:
//! - a still pose must read gravity's magnitude in the declared unit (`accel_unit`);
//! - a turntable run must read gravity along its declared `up` and its constant magnitude in the
//!   declared unit;
//! - a `static` recording must not turn: its gyro, where it has one, and the accelerometer's own
//!   spectrum across gravity in each still pose cut from it (a platter's sharp line);
//! - a turntable run's measured rotation rate must be within `RPM_TOLERANCE` of its nominal `rpm`;
//! - no recording may be listed twice (the same samples under two entries).

use crate::campaign::file::SignedAxis;
use crate::campaign::joint::{mounting_matrix, RunInput};
use crate::campaign::prepare::{pose_samples, still_intervals, PrepareError, Prepared, UnitRecording};
use crate::geometry::{cross, norm, unit};
use crate::input::recording::{Recording, STANDARD_GRAVITY};
use crate::turntable::spectrum::{estimate_rotation_rate, RateEstimate, RateSearch};

/// A reading's magnitude may differ from what physics requires by this fraction before it is
/// refused: beyond what a faulty but calibratable part shows (a fleet's outlier with 0.1 g bias
/// and 5 % scale error reads 10 % high), far below a unit mix-up's factor 9.8.
pub(crate) const MAGNITUDE_TOLERANCE: f64 = 0.25;
/// The angle between the mean reading of a run and its declared `up`, deg, beyond which the
/// mounting is refused (sensors sit within a few degrees of how they are declared).
pub(crate) const UP_TOLERANCE_DEG: f64 = 30.0;
/// A still recording whose gyro reads more than this, deg/s, is turning (MEMS gyro biases stay
/// within ±20 °/s).
pub(crate) const STILL_GYRO_DPS: f64 = 30.0;
/// Where a still pose is searched for a platter's line, rpm: 12–120 rpm (0.2–2 Hz) holds record
/// players' 16⅔–78 rpm with margin and stays below a desk's or a fan's vibrations.
pub const STILL_LINE_RPM: [f64; 2] = [12.0, 120.0];
/// Cycles of the line a pose must hold for its spectrum to be searched at that rate (the band's
/// lower edge rises for short poses; a pose too short for the upper edge is not searched).
pub const STILL_LINE_CYCLES: f64 = 3.0;
/// A still pose whose spectrum across gravity has a line this many times the band's median power
/// is turning. Measured (tests/still_labels.rs): simulated still poses with noise and bias drift
/// stay below 16 over 120 seeds (5 and 30 s poses), a thermal warm-up below 8, the real still
/// recordings of ../shared/data (Xsens, T265, MPU-6050, imucal) below 7; the simulated runs'
/// line (33⅓ and 45 rpm, 0.06 and 0.12 m) stands above 1.8·10⁵. The power goes as the swing's
/// square: a swing 13× smaller than those runs' (about 0.06 m/s², a chip near the spindle of a
/// platter level within 0.3°) is let through, and such a run reads gravity within that much.
pub const STILL_LINE_PEAK_TO_MEDIAN: f64 = 1000.0;
/// The largest relative difference between a run's nominal and measured rate.
pub(crate) const RPM_TOLERANCE: f64 = 0.05;

/// One input that physics contradicts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{recording}: `{key}`: {why}")]
pub struct InputError {
    pub recording: String,
    /// The campaign key at fault.
    pub key: &'static str,
    /// What the data show and the fix.
    pub why: String,
}

/// The checks on whole recordings (before they are cut into poses): duplicates, and a `static`
/// recording whose gyro turns.
pub(crate) fn check_recordings(units: &[UnitRecording]) -> Result<(), InputError> {
    check_duplicates(units)?;
    for unit in units.iter().filter(|u| u.turntable.is_none()) {
        let Some(gyro) = &unit.recording.gyro_radps else {
            continue;
        };
        let mut magnitudes: Vec<f64> = (0..gyro[0].len())
            .map(|s| norm(&[gyro[0][s], gyro[1][s], gyro[2][s]]))
            .filter(|v| v.is_finite())
            .collect();
        if magnitudes.is_empty() {
            continue;
        }
        let middle = magnitudes.len() / 2;
        let median = *magnitudes.select_nth_unstable_by(middle, f64::total_cmp).1;
        let dps = median.to_degrees();
        if dps > STILL_GYRO_DPS {
            return Err(InputError {
                recording: unit.name.clone(),
                key: "kind",
                why: format!(
                    "listed as `static`, but its gyro reads {dps:.1} °/s ({:.1} rpm) for most of the recording: if it is a turntable run, give kind = \"turntable\" with its rpm, radius_m, out and up",
                    dps / 6.0
                ),
            });
        }
    }
    Ok(())
}

/// Still poses that turn: each pose cut from a `static` recording (`prepared.pose_origin` into
/// `units`) is searched for a platter's line across gravity ([`still_pose_line`]); one above
/// [`STILL_LINE_PEAK_TO_MEDIAN`] names the recording (the gyro's check needs a gyro, this none).
pub(crate) fn check_poses_still(units: &[UnitRecording], prepared: &Prepared) -> Result<(), InputError> {
    for origin in &prepared.pose_origin {
        let Some(unit) = units.get(origin.recording) else {
            continue;
        };
        let Some(line) = still_pose_line(&unit.recording, origin.start, origin.end) else {
            continue;
        };
        if line.peak_to_median > STILL_LINE_PEAK_TO_MEDIAN {
            let rec = &unit.recording;
            return Err(InputError {
                recording: unit.name.clone(),
                key: "kind",
                why: format!(
                    "listed as `static`, but its readings across gravity turn at {:.2} rpm from {:.1} to {:.1} s (a sharp line in the accelerometer's spectrum, {:.0}× the median of {}–{} rpm; a still pose has none): if it is a turntable run, give kind = \"turntable\" with its rpm, radius_m, out and up",
                    line.rpm,
                    rec.time_s[origin.start] - rec.time_s[0],
                    rec.time_s[origin.end - 1] - rec.time_s[0],
                    line.peak_to_median,
                    STILL_LINE_RPM[0],
                    STILL_LINE_RPM[1],
                ),
            });
        }
    }
    Ok(())
}

/// A still pose's strongest line across gravity ([`still_pose_lines`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseLine {
    /// The pose's samples `[start, end)` in its recording.
    pub start: usize,
    pub end: usize,
    /// The line's rate, rpm.
    pub rpm: f64,
    /// Its power over the band's median power; above [`STILL_LINE_PEAK_TO_MEDIAN`] the pose turns.
    pub peak_to_median: f64,
}

/// The strongest line across gravity of each still pose a `static` recording is cut into (as a
/// campaign cuts it); poses too short for the band are left out. What the campaign's check
/// measures, for a caller to see how far a recording is from a refusal.
pub fn still_pose_lines(rec: &Recording, name: &str) -> Result<Vec<PoseLine>, PrepareError> {
    let intervals = still_intervals(rec, name)?;
    Ok(intervals
        .iter()
        .filter_map(|interval| {
            let (start, end) = pose_samples(interval);
            still_pose_line(rec, start, end).map(|line| PoseLine {
                start,
                end,
                rpm: line.rpm,
                peak_to_median: line.peak_to_median,
            })
        })
        .collect())
}

/// The strongest line of samples `[start, end)` across their mean reading (gravity, for a still
/// pose), in [`STILL_LINE_RPM`] raised to [`STILL_LINE_CYCLES`] over the pose; `None` when the pose
/// is too short for the band or has no direction.
fn still_pose_line(rec: &Recording, start: usize, end: usize) -> Option<RateEstimate> {
    let end = end.min(rec.len());
    if end < start + 64 {
        return None;
    }
    let duration_s = rec.time_s[end - 1] - rec.time_s[start];
    let min_rpm = STILL_LINE_RPM[0].max(60.0 * STILL_LINE_CYCLES / duration_s);
    if !(duration_s > 0.0 && min_rpm < STILL_LINE_RPM[1]) {
        return None;
    }
    let a = &rec.accel_mps2;
    let n = (end - start) as f64;
    let mean: [f64; 3] = std::array::from_fn(|k| a[k][start..end].iter().sum::<f64>() / n);
    let length = norm(&mean);
    if length.is_nan() || length <= 0.0 {
        return None;
    }
    let down = unit(mean);
    // The axis least along gravity gives the first direction across it.
    let k = (0..3).min_by(|&i, &j| down[i].abs().total_cmp(&down[j].abs()))?;
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let across = unit(cross(&down, &e));
    let third = cross(&down, &across);
    let project = |d: &[f64; 3]| -> Vec<f64> {
        (start..end)
            .map(|s| d[0] * a[0][s] + d[1] * a[1][s] + d[2] * a[2][s])
            .collect()
    };
    let flat = Recording {
        time_s: rec.time_s[start..end].to_vec(),
        accel_mps2: [project(&across), project(&third), vec![0.0; end - start]],
        gyro_radps: None,
        temperature_c: None,
        source: Default::default(),
    };
    let search = RateSearch {
        min_rpm,
        max_rpm: STILL_LINE_RPM[1],
    };
    estimate_rotation_rate(&flat, search).ok()
}

/// The checks on the poses and runs cut from the recordings; the first failure is returned.
pub(crate) fn check_prepared(prepared: &Prepared, gravity: f64) -> Result<(), InputError> {
    for pose in &prepared.poses {
        check_magnitude(&pose.name, norm(&pose.mean_mps2), gravity, "still pose")?;
    }
    for run in &prepared.runs {
        check_run(run, gravity)?;
    }
    Ok(())
}

fn check_magnitude(name: &str, magnitude: f64, expected: f64, what: &str) -> Result<(), InputError> {
    let ratio = magnitude / expected;
    if (ratio - 1.0).abs() <= MAGNITUDE_TOLERANCE {
        return Ok(());
    }
    let fix = if (ratio * STANDARD_GRAVITY - 1.0).abs() < 0.15 {
        "the values look like g read as m/s²: give accel_unit = \"g\"".to_string()
    } else if (ratio / STANDARD_GRAVITY - 1.0).abs() < 0.15 {
        "the values look like m/s² read as g: remove accel_unit = \"g\"".to_string()
    } else {
        "check the unit (accel_unit) and the columns (columns)".to_string()
    };
    Err(InputError {
        recording: name.to_string(),
        key: "accel_unit",
        why: format!(
            "the {what} reads {magnitude:.4} m/s² where physics requires {expected:.4} m/s² ({ratio:.3}×): {fix}"
        ),
    })
}

/// A run: gravity along `up`, the constant magnitude √(g² + (ω²r)²) (tilt aside), and the rate.
fn check_run(run: &RunInput, gravity: f64) -> Result<(), InputError> {
    let kept: Vec<usize> = (0..run.time_s.len()).filter(|&s| run.keep[s]).collect();
    if kept.is_empty() {
        return Ok(());
    }
    let n = kept.len() as f64;
    let mean: [f64; 3] = std::array::from_fn(|k| kept.iter().map(|&s| run.accel_mps2[k][s]).sum::<f64>() / n);
    let entry = &run.entry;
    let q = mounting_matrix(entry.out, entry.up);
    let up: [f64; 3] = std::array::from_fn(|r| q[r][2]);
    let along = (0..3).map(|k| mean[k] * up[k]).sum::<f64>();
    let magnitude = norm(&mean);
    let omega = entry.rpm * std::f64::consts::PI / 30.0;
    // Without a stated radius the centripetal level is the fit's to find: gravity along the
    // spindle is what physics fixes.
    match entry.radius {
        Some(stated) => {
            let expected = (gravity * gravity + (omega * omega * stated.value_m).powi(2)).sqrt();
            check_magnitude(&run.name, magnitude, expected, "turntable run's mean")?;
        }
        None => check_magnitude(&run.name, along.abs(), gravity, "turntable run's mean along `up`")?,
    }
    let angle = (along / magnitude.max(f64::MIN_POSITIVE))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees();
    if angle > UP_TOLERANCE_DEG {
        let nearest = SignedAxis::nearest(mean).name();
        return Err(InputError {
            recording: run.name.clone(),
            key: "up",
            why: format!(
                "gravity lies {angle:.0}° from the declared up = \"{}\"; the mean reading points along {nearest}: give up = \"{nearest}\" (and an `out` across it)",
                entry.up.name(),
            ),
        });
    }
    // The rate from the readings across the spindle (the declared mounting's out and up × out).
    let across: [Vec<f64>; 2] = std::array::from_fn(|c| {
        (0..run.time_s.len())
            .map(|s| (0..3).map(|r| q[r][c] * run.accel_mps2[r][s]).sum())
            .collect()
    });
    let flat = Recording {
        time_s: run.time_s.clone(),
        accel_mps2: [across[0].clone(), across[1].clone(), vec![0.0; run.time_s.len()]],
        gyro_radps: None,
        temperature_c: None,
        source: Default::default(),
    };
    if let Ok(rate) = estimate_rotation_rate(&flat, RateSearch::default()) {
        let off = rate.rpm / entry.rpm - 1.0;
        if off.abs() > RPM_TOLERANCE && rate.peak_to_median > 100.0 {
            return Err(InputError {
                recording: run.name.clone(),
                key: "rpm",
                why: format!(
                    "the platter turns at {:.2} rpm (measured from the readings), {:+.0} % from the nominal {:.2} rpm: give rpm = {:.2}",
                    rate.rpm,
                    100.0 * off,
                    entry.rpm,
                    rate.rpm
                ),
            });
        }
    }
    Ok(())
}

/// The same samples under two entries would count one recording twice (and shrink the standard
/// errors by √2).
fn check_duplicates(units: &[UnitRecording]) -> Result<(), InputError> {
    for (i, a) in units.iter().enumerate() {
        for b in &units[..i] {
            let same = a.recording.len() == b.recording.len()
                && a.recording.time_s == b.recording.time_s
                && a.recording.accel_mps2 == b.recording.accel_mps2;
            if same {
                return Err(InputError {
                    recording: a.name.clone(),
                    key: "file",
                    why: format!(
                        "holds the same samples as {}: each recording may be listed once",
                        b.name
                    ),
                });
            }
        }
    }
    Ok(())
}
