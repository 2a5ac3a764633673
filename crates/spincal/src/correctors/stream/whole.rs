//! A recording read whole by the common reader: every sample out with its line, time, values in
//! unit-named columns, and the corrected columns.

use std::fmt::Write as _;

use super::gyro::{without_gyro, GyroMerge};
use super::sink::{field, RowSink};
use super::text::CorrectedColumns;
use super::{unit_check, CorrectError, StreamSummary};
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::correctors::rows::{RowCorrector, RowOutcome, RowValue, UnitFactors};
use crate::input::formats::Loaded;
use crate::thermal::checks::{check_unit, temperature_column, unit_of_column};

/// Refuses a file of raw counts for a model that takes SI values, and the other way round.
fn check_counts(model: &CorrectorFile, loaded: &Loaded, name: &str) -> Result<(), CorrectError> {
    let counts_expected = match &model.corrector {
        CorrectorModel::Static(s) => s.input_unit == "counts",
        _ => false,
    };
    if loaded.raw_counts == counts_expected {
        return Ok(());
    }
    Err(CorrectError::CountsMismatch {
        file: name.to_string(),
        format: loaded.format,
        holds: if loaded.raw_counts { "raw counts" } else { "m/s²" },
        takes: if counts_expected {
            "raw counts (it was calibrated from them)"
        } else {
            "m/s² or g"
        },
        advice: if loaded.raw_counts {
            "give `accel_scale` (and `accel_offset`) to convert the counts, or correct it with a static calibration made from counts (`spincal static`)"
        } else {
            "correct the counts file the calibration was made from, or make the calibration from this file"
        },
    })
}

/// Corrects every sample of `loaded` (with the gyro of `merged`, when given, at each sample's
/// time) into `sink`: `line` (for text), `t_s`, the values under unit-named columns, `temp_c` and
/// `label` where present, then the corrected columns, `valid` and `status`.
pub(super) fn correct_loaded(
    model: &CorrectorFile,
    loaded: &Loaded,
    name: &str,
    merged: Option<GyroMerge>,
    sink: &mut dyn RowSink,
) -> Result<StreamSummary, CorrectError> {
    check_counts(model, loaded, name)?;
    let rec = &loaded.recording;
    if rec.gyro_radps.is_some() && merged.is_some() {
        return Err(super::text::gyro_twice(name, merged));
    }
    if let Some(expected) = unit_check::expected_gravity_mps2(&model.corrector).filter(|_| !loaded.raw_counts)
    {
        let a = &rec.accel_mps2;
        let mut magnitudes: Vec<f64> = (0..rec.len())
            .map(|s| (a[0][s] * a[0][s] + a[1][s] * a[1][s] + a[2][s] * a[2][s]).sqrt())
            .filter(|m| m.is_finite())
            .take(unit_check::UNIT_CHECK_ROWS)
            .collect();
        unit_check::check_accel_unit(name, &mut magnitudes, expected)?;
    }
    // The gyro is corrected when the model's calibration takes the file's unit (counts or rad/s).
    let gyro_counts = merged.as_ref().map_or(loaded.gyro_counts, |m| m.counts);
    let gyro_unit_fits = model
        .gyro
        .as_ref()
        .is_some_and(|g| g.input_unit.is_rad_per_s() != gyro_counts);
    let gyro = rec.gyro_radps.as_ref().filter(|_| gyro_unit_fits);
    let mut merged = merged.filter(|_| gyro_unit_fits);
    if let (Some(_), Some(temperature)) = (&model.thermal, &rec.temperature_c) {
        let column = temperature_column(rec);
        check_unit(name, &column, temperature, unit_of_column(&column))?;
    }
    let units = UnitFactors::SI;
    let mut corrector = RowCorrector::new(model, units, gyro.is_some() || merged.is_some())?;
    let gyro = gyro.filter(|_| corrector.corrects_gyro());
    merged = merged.filter(|_| corrector.corrects_gyro());
    let accel_unit = if loaded.raw_counts { "counts" } else { "mps2" };
    let gyro_unit = if gyro_counts { "counts" } else { "radps" };
    let lines = (rec.source.lines.len() == rec.len()).then_some(&rec.source.lines);
    let mut header: Vec<String> = Vec::new();
    if lines.is_some() {
        header.push("line".into());
    }
    header.push("t_s".into());
    header.extend(["x", "y", "z"].map(|a| format!("a{a}_{accel_unit}")));
    if rec.gyro_radps.is_some() {
        header.extend(["x", "y", "z"].map(|a| format!("g{a}_{gyro_unit}")));
    }
    if rec.temperature_c.is_some() {
        header.push("temp_c".into());
    }
    if loaded.labels.is_some() {
        header.push("label".into());
    }
    // One naming with the streamed path (`corrected_column_names`), in the unit the corrected
    // values are in: SI here (a calibration of counts gives m/s² and rad/s).
    let added = CorrectedColumns::new(&corrector, gyro.is_some() || merged.is_some());
    header.extend(added.names("mps2", "radps"));
    header.extend(["valid".to_string(), "status".to_string()]);
    sink.header(&header)?;
    let mut summary = StreamSummary::new(name, model);
    summary.left_out = rec.source.incomplete_rows.describe();
    summary.notes = rec.source.time_notes.clone();
    let with_gyro = rec.gyro_radps.is_some() || merged.is_some();
    summary.gyro_uncorrected = model.gyro.is_some() && !with_gyro;
    if model.gyro.is_some() && with_gyro && !gyro_unit_fits {
        let (file, wanted) = if gyro_counts {
            ("raw counts", "rad/s")
        } else {
            ("rad/s", "raw counts")
        };
        summary.gyro_unit_mismatch = Some(format!(
            "the gyro columns hold {file} but the model's gyro calibration takes {wanted}"
        ));
    }
    let value_name = |v: RowValue| match v {
        RowValue::Time => "t_s".to_string(),
        RowValue::Accel(a) => format!("a{}", ["x", "y", "z"][a]),
        RowValue::Gyro(a) => format!("g{}", ["x", "y", "z"][a]),
    };
    let sep = sink.separator();
    let mut input = String::new();
    for i in 0..rec.len() {
        summary.rows += 1;
        let line_no = lines.map_or(i + 1, |l| l[i]);
        input.clear();
        // Writing into a String cannot fail.
        if lines.is_some() {
            let _ = write!(input, "{line_no}{sep}");
        }
        let _ = write!(input, "{}", rec.time_s[i]);
        for a in &rec.accel_mps2 {
            let _ = write!(input, "{sep}{}", a[i]);
        }
        for g in rec.gyro_radps.iter().flatten() {
            let _ = write!(input, "{sep}{}", g[i]);
        }
        if let Some(t) = &rec.temperature_c {
            let _ = write!(input, "{sep}{}", t[i]);
        }
        if let Some(labels) = &loaded.labels {
            let _ = write!(input, "{sep}{}", field(&labels[i], sep));
        }
        let (mut gyro_values, mut no_gyro) = (gyro.map(|g| std::array::from_fn(|a| g[a][i])), None);
        if let Some(m) = merged.as_mut() {
            match m.at(rec.time_s[i])? {
                Ok(w) => gyro_values = Some(w),
                Err(why) => no_gyro = Some(why),
            }
        }
        let outcome = corrector.correct(
            Some(rec.time_s[i]),
            std::array::from_fn(|a| rec.accel_mps2[a][i]),
            gyro_values,
            rec.temperature_c.as_ref().map(|t| t[i]),
            value_name,
        );
        let corrected = added.values(&outcome, units);
        match outcome {
            RowOutcome::Corrected {
                valid,
                status,
                predicted,
                ..
            } => {
                summary.corrected(line_no, status, predicted);
                match no_gyro {
                    Some(why) => {
                        let status = without_gyro(status.as_str(), line_no, why);
                        summary.no_gyro(&status);
                        sink.row(&input, &corrected, false, &status)?;
                    }
                    None => sink.row(&input, &corrected, valid, status.as_str())?,
                }
            }
            RowOutcome::Refused(reason) => {
                let where_ = if lines.is_some() { "line" } else { "sample" };
                let reason = format!("{where_} {line_no}, {reason}");
                summary.refuse(&reason);
                sink.row(&input, &corrected, false, &format!("refused: {reason}"))?;
            }
        }
    }
    if let Some(m) = merged {
        summary.notes.extend(m.finish()?);
    }
    sink.flush()?;
    Ok(summary)
}
