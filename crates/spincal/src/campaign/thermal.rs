//! A campaign's thermal stage, before everything else: when its still recordings carry a
//! temperature that spans at least `thermal::fit::MIN_SPAN_C` (fit_thermal's own check), the
//! thermal model is fitted to their poses (`thermal::fit_thermal_in_sessions`: each pose in its
//! recording's power-on session as the joint fit has it, a `session` label or the file's own, the
//! spread between sessions estimated from the windows; orders by the terms rule, a Wald test at
//! `TERM_FALSE_ALARM` on the fit's robust covariance; each axis's nonlinearity q fitted first and
//! taken out of the readings, `ThermalSettings::fit_nonlinearity`) and every recording with a temperature,
//! runs included, is taken to the reference temperature. The joint fit, the candidates and the
//! held-out verdict then run unchanged on those readings, and the saved model.json carries the
//! thermal model for `correct` to apply first.
//!
//! The temperatures are checked first (`check_temperatures`, `thermal::checks`, the rules
//! `correct` runs): implausible samples, glitches and resets are held at the last trusted value
//! (masked: kept out of the die estimate, the fit and the fitted range, the rows kept), a stuck
//! sensor's recording is used without its temperature, and every finding is named with its file
//! and line in results.json (`temperature_findings`). A column in the wrong unit is refused
//! before (`check_temperature_units`).
//!
//! What it cannot see: the thermal coefficients are fitted on every still pose, so the
//! temperature bands held out by the campaign (`temperature_bands`) test the static
//! correctors across temperature, not the thermal coefficients themselves.

use serde::{Deserialize, Serialize};

use crate::campaign::joint::{fit_joint_from, JointFit, JointSettings};
use crate::campaign::prepare::prepare;
use crate::campaign::prepare::{session_indices, still_intervals, Prepared, UnitRecording};
use crate::input::recording::Recording;
use crate::progress::silent;
use crate::thermal::checks::{
    check_track, check_unit, is_stuck, temperature_column, unit_of_column, FindingKind, TemperatureError,
    TemperatureFinding,
};
use crate::thermal::{
    fit_thermal_in_sessions, ThermalDirection, ThermalFit, ThermalModel, ThermalSettings, ThermalUncertainty,
    MIN_SPAN_C,
};
use faer::{Mat, Side};
use rayon::prelude::*;

/// What the thermal stage did (results.json `thermal`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CampaignThermal {
    pub fit: ThermalFit,
    /// Recordings taken to the reference temperature.
    pub normalised: Vec<String>,
    /// Recordings without a temperature, used as they are.
    pub without_temperature: Vec<String>,
    /// Samples whose die temperature lay outside the fitted range, taken to the reference from
    /// the nearest end of it.
    pub clamped_samples: usize,
    /// The die temperature per sample of each recording, °C (None without a temperature).
    #[serde(skip)]
    pub die_c: Vec<Option<Vec<f64>>>,
    /// What the thermal coefficients' error moves in the joint fit's sensor (the campaign refitted
    /// along each principal axis of their covariance), the saved model's `thermal.uncertainty`;
    /// `None` without the coefficients' covariance or where a refit failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<ThermalUncertainty>,
    /// The recordings as checked, before they were taken to T_ref.
    #[serde(skip)]
    checked: Vec<UnitRecording>,
}

/// The stage's outcome: the recordings to calibrate on, and what was fitted or why nothing was.
pub(crate) struct ThermalStage {
    /// The recordings taken to the reference temperature; `None`: calibrate on them as they are.
    pub normalised_units: Option<Vec<UnitRecording>>,
    pub thermal: Option<CampaignThermal>,
    /// Why no thermal model was fitted, when the campaign has a temperature at all.
    pub note: Option<String>,
    /// What the temperature checks found, and how many samples they masked.
    pub findings: Vec<TemperatureFinding>,
    pub masked_samples: usize,
}

/// Every temperature column's unit checked from its values ([`check_unit`]): a column in the
/// wrong unit is refused, naming the file, the column and the likely unit.
pub(crate) fn check_temperature_units(units: &[UnitRecording]) -> Result<(), TemperatureError> {
    for unit in units {
        let rec = &unit.recording;
        if let Some(temperature) = &rec.temperature_c {
            let column = temperature_column(rec);
            check_unit(&unit.name, &column, temperature, unit_of_column(&column))?;
        }
    }
    Ok(())
}

/// The recordings with their temperatures checked, and what was found.
pub(crate) struct CheckedTemperatures {
    /// Masked samples held at the last trusted value; a stuck recording without temperature.
    pub units: Vec<UnitRecording>,
    pub findings: Vec<TemperatureFinding>,
    pub masked_samples: usize,
}

/// Each recording's temperature through the sample rules ([`check_track`]); a recording whose
/// temperature never changes for [`crate::thermal::checks::STUCK_AFTER_S`] while the other
/// recordings' (trusted) temperatures span at least [`MIN_SPAN_C`] (the campaign records
/// temperature change, so its sensor should show some) is stuck, and used without temperature.
pub(crate) fn check_temperatures(units: &[UnitRecording]) -> CheckedTemperatures {
    let checks: Vec<_> = units
        .iter()
        .map(|u| {
            let rec = &u.recording;
            rec.temperature_c
                .as_ref()
                .map(|t| check_track(&u.name, &rec.source.lines, &rec.time_s, t))
        })
        .collect();
    let spans: Vec<Option<[f64; 2]>> = units
        .iter()
        .zip(&checks)
        .map(|(u, check)| {
            let (t, check) = (u.recording.temperature_c.as_ref()?, check.as_ref()?);
            let trusted = t.iter().zip(&check.masked).filter(|(_, &m)| !m).map(|(&v, _)| v);
            trusted.fold(None, |span: Option<[f64; 2]>, v| {
                Some(span.map_or([v, v], |[lo, hi]| [lo.min(v), hi.max(v)]))
            })
        })
        .collect();
    let mut out = units.to_vec();
    let (mut findings, mut masked_samples) = (Vec::new(), 0);
    for (i, (unit, check)) in out.iter_mut().zip(checks).enumerate() {
        let Some(mut check) = check else {
            continue;
        };
        let rec = &mut unit.recording;
        let Some(temperature) = rec.temperature_c.take() else {
            continue;
        };
        let others = spans
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .filter_map(|(_, s)| *s)
            .fold(None, |acc: Option<[f64; 2]>, [lo, hi]| {
                Some(acc.map_or([lo, hi], |[a, b]| [a.min(lo), b.max(hi)]))
            });
        let changes_elsewhere = others.is_some_and(|[lo, hi]| hi - lo >= MIN_SPAN_C);
        if let Some(value_c) =
            is_stuck(&rec.time_s, &temperature, &check.masked).filter(|_| changes_elsewhere)
        {
            findings.push(TemperatureFinding {
                file: unit.name.clone(),
                line: rec.source.lines.first().copied().unwrap_or(1),
                kind: FindingKind::Stuck,
                samples: rec.len(),
                value_c,
                duration_s: rec.duration_s(),
            });
            masked_samples += rec.len();
            continue;
        }
        masked_samples += check.masked_samples();
        rec.temperature_c = check.held(&temperature);
        findings.append(&mut check.findings);
    }
    CheckedTemperatures {
        units: out,
        findings,
        masked_samples,
    }
}

/// The still poses of every still recording that has a temperature, each as its own recording
/// (fit_thermal takes one orientation per recording), on the recording's clock, with its power-on
/// session (the joint fit's: [`session_indices`]); a recording of one pose whole.
fn still_poses(units: &[UnitRecording]) -> (Vec<Recording>, Vec<usize>) {
    let sessions = session_indices(units);
    let (mut out, mut out_sessions) = (Vec::new(), Vec::new());
    for (unit, session) in units.iter().zip(sessions) {
        let (Some(session), None) = (session, &unit.turntable) else {
            continue;
        };
        let rec = &unit.recording;
        let Some(temperature) = &rec.temperature_c else {
            continue;
        };
        let intervals = still_intervals(rec, &unit.name).unwrap_or_default();
        // One pose: the whole recording (its temperature track unbroken, the lag seen whole).
        if intervals.len() == 1 {
            out.push(Recording {
                gyro_radps: None,
                ..rec.clone()
            });
            out_sessions.push(session);
            continue;
        }
        for interval in intervals {
            let (a, b) = (interval.start, interval.end);
            out.push(Recording {
                time_s: rec.time_s[a..b].to_vec(),
                accel_mps2: std::array::from_fn(|k| rec.accel_mps2[k][a..b].to_vec()),
                gyro_radps: None,
                temperature_c: Some(temperature[a..b].to_vec()),
                source: rec.source.clone(),
            });
            out_sessions.push(session);
        }
    }
    (out, out_sessions)
}

/// Fits the thermal model where the campaign allows and takes every recording with a temperature
/// to its reference temperature. A thermal fit that cannot be made leaves the recordings as they
/// are, with a note saying why (the rest of the campaign does not need it).
pub(crate) fn thermal_stage(
    units: &[UnitRecording],
    settings: &ThermalSettings,
    gravity_mps2: f64,
) -> ThermalStage {
    if units.iter().all(|u| u.recording.temperature_c.is_none()) {
        return ThermalStage {
            normalised_units: None,
            thermal: None,
            note: None,
            findings: Vec::new(),
            masked_samples: 0,
        };
    }
    let checked = check_temperatures(units);
    let (findings, masked_samples) = (checked.findings, checked.masked_samples);
    let units = &checked.units[..];
    let unchanged = |note: Option<String>| ThermalStage {
        normalised_units: None,
        thermal: None,
        note,
        findings: findings.clone(),
        masked_samples,
    };
    let (poses, sessions) = still_poses(units);
    if poses.is_empty() {
        return unchanged(Some(
            "no thermal model: no still recording with a temperature column".into(),
        ));
    }
    let refs: Vec<&Recording> = poses.iter().collect();
    // The joint fit carries q; the thermal fit takes it out first (ThermalSettings docs).
    let settings = ThermalSettings {
        fit_nonlinearity: true,
        ..settings.clone()
    };
    let fit = match fit_thermal_in_sessions(&refs, &sessions, &settings, gravity_mps2) {
        Ok(fit) => fit,
        // Too narrow a span of temperature among them (`ThermalError::NarrowRange`) included.
        Err(e) => return unchanged(Some(format!("no thermal model: {e}"))),
    };
    let recordings: Vec<&Recording> = units.iter().map(|u| &u.recording).collect();
    let die_c = fit.model.die_temperatures(&recordings);
    let (out, clamped_samples) = to_reference(units, &die_c, &fit.model);
    let (normalised, without_temperature) = units
        .iter()
        .zip(&die_c)
        .map(|(u, d)| (u.name.clone(), d.is_some()))
        .partition::<Vec<_>, _>(|(_, has)| *has);
    let names = |v: Vec<(String, bool)>| v.into_iter().map(|(n, _)| n).collect();
    ThermalStage {
        normalised_units: Some(out),
        thermal: Some(CampaignThermal {
            fit,
            normalised: names(normalised),
            without_temperature: names(without_temperature),
            clamped_samples,
            die_c,
            uncertainty: None,
            checked: units.to_vec(),
        }),
        note: None,
        findings,
        masked_samples,
    }
}

/// `units` taken to `model`'s reference temperature at their die temperatures `die_c` (a
/// sample outside the fitted range from the nearest end of it), and how many samples lay outside.
fn to_reference(
    units: &[UnitRecording],
    die_c: &[Option<Vec<f64>>],
    model: &ThermalModel,
) -> (Vec<UnitRecording>, usize) {
    let [lo, hi] = model.fitted_range_c;
    let mut clamped_samples = 0;
    let mut out = units.to_vec();
    for (unit, die) in out.iter_mut().zip(die_c) {
        let Some(die) = die else { continue };
        let accel = &mut unit.recording.accel_mps2;
        for (s, &d) in die.iter().enumerate() {
            clamped_samples += usize::from(!model.covers(d));
            let m = model.to_reference([accel[0][s], accel[1][s], accel[2][s]], d.clamp(lo, hi));
            for k in 0..3 {
                accel[k][s] = m[k];
            }
        }
    }
    (out, clamped_samples)
}

/// The thermal coefficients' error carried into the joint fit's sensor: along each principal
/// axis of their covariance (one standard deviation, `ThermalFit::coefficient_covariance`), the
/// recordings are taken to T_ref again with the coefficients changed, and the joint fit is solved
/// again from `joint` with `settings` (its own, the spread of the offsets held at what it found).
/// The readings it normalised carry the coefficients' error into every pose together, which the
/// joint fit's covariance, made as if they were exact, cannot hold (on bench/thermal/campaign.sh
/// it moves the biases by at most 5e-4 m/s²: what leaves that bench's bars narrow is the terms
/// the campaign cannot determine, bench/thermal/RESULTS.md). The same for each term the rule
/// dropped that the windows still saw (`ThermalFit::left_out_moves`). `None` without either, or
/// where a changed campaign no longer prepares into the same poses and runs or does not fit.
pub(crate) fn propagated_uncertainty(
    thermal: &CampaignThermal,
    joint: &JointFit,
    settings: &JointSettings,
) -> Option<ThermalUncertainty> {
    let fit = &thermal.fit;
    let model = &fit.model;
    let covariance = &fit.coefficient_covariance;
    let n = covariance.len();
    if n == 0 && fit.left_out_moves.is_empty() {
        return None;
    }
    let mut axes: Vec<Vec<f64>> = Vec::new();
    if n > 0 {
        let matrix = Mat::from_fn(n, n, |a, b| 0.5 * (covariance[a][b] + covariance[b][a]));
        let eigen = matrix.self_adjoint_eigen(Side::Lower).ok()?;
        let (u, lambda) = (eigen.U(), eigen.S());
        let largest = (0..n).map(|k| lambda[k]).fold(0.0, f64::max);
        axes = (0..n)
            .filter(|&k| lambda[k] > 1e-12 * largest)
            .map(|k| (0..n).map(|a| lambda[k].sqrt() * u[(a, k)]).collect())
            .collect();
    }
    // Each principal axis as a change of the coefficients, then each left-out term's move.
    let moves: Vec<ThermalDirection> = axes
        .iter()
        .map(|delta| {
            let mut values = delta.iter().copied();
            let mut take = |orders: &[Vec<f64>; 3]| -> [Vec<f64>; 3] {
                std::array::from_fn(|k| orders[k].iter().map(|_| values.next().unwrap_or(0.0)).collect())
            };
            ThermalDirection {
                bias_per_c: take(&model.bias_per_c),
                scale_per_c: take(&model.scale_per_c),
                sensor: Vec::new(),
            }
        })
        .chain(fit.left_out_moves.iter().cloned())
        .collect();
    let base = joint.sensor.params();
    // From `joint`'s minimum a change this small is all but linear: one Gauss–Newton step per pass
    // (on bench/thermal/campaign.sh's seed 10 within 4 % of full refits, a third of their time).
    let settings = &JointSettings {
        max_iterations: REFIT_ITERATIONS,
        ..settings.clone()
    };
    let directions: Option<Vec<ThermalDirection>> = moves
        .into_par_iter()
        .map(|mut direction| {
            let (units, _) = to_reference(&thermal.checked, &thermal.die_c, &model.moved_along(&direction));
            let prepared = prepare(&units).ok()?;
            let same_shape =
                prepared.poses.len() == joint.poses.len() && prepared.runs.len() == joint.runs.len();
            let refit = same_shape
                .then(|| fit_joint_from(&prepared.runs, &prepared.poses, settings, Some(joint), &silent).ok())
                .flatten()?;
            let moved = refit.sensor.params();
            direction.sensor = moved.iter().zip(&base).map(|(a, b)| a - b).collect();
            Some(direction)
        })
        .collect();
    Some(ThermalUncertainty {
        directions: directions?,
    })
}

/// The most steps of each refit of [`propagated_uncertainty`].
const REFIT_ITERATIONS: usize = 1;

/// Fraction of the poses held out at each end of the temperature range.
const BAND_FRACTION: f64 = 0.2;

/// The coldest and the hottest fifth of the still poses by mean die temperature, each as a label
/// and its poses (indices into the prepared poses), to be held out (with at least five poses that
/// have a temperature).
pub(crate) fn temperature_bands(
    prepared: &Prepared,
    die_c: &[Option<Vec<f64>>],
) -> Vec<(String, Vec<usize>)> {
    let mut poses: Vec<(f64, usize)> = prepared
        .pose_origin
        .iter()
        .enumerate()
        .filter_map(|(p, origin)| {
            let die = die_c.get(origin.recording)?.as_ref()?;
            let window = die.get(origin.start..origin.end)?;
            (!window.is_empty()).then(|| (window.iter().sum::<f64>() / window.len() as f64, p))
        })
        .collect();
    if poses.len() < 5 {
        return Vec::new();
    }
    poses.sort_by(|a, b| a.0.total_cmp(&b.0));
    let take = ((poses.len() as f64 * BAND_FRACTION).round() as usize).max(1);
    let band = |name: &str, members: &[(f64, usize)]| {
        let (lo, hi) = members
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
                (lo.min(m.0), hi.max(m.0))
            });
        let mut indices: Vec<usize> = members.iter().map(|m| m.1).collect();
        indices.sort_unstable();
        (format!("{name} poses ({lo:.1}–{hi:.1} °C)"), indices)
    };
    vec![
        band("coldest", &poses[..take]),
        band("hottest", &poses[poses.len() - take..]),
    ]
}
