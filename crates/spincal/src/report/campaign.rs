//! The calibration report (`spincal calibrate`, with or without `--campaign`, `spincal fleet`, the
//! Python package): the verdict, every corrector on held-out conditions (table and plot), the
//! sensor model, the gyroscope, time per stage, and the paper's sections where its protocol ran.
//! Self-contained HTML.

use std::fmt::Write as _;

use super::escape;
use super::html::{figure, paper_sections};
use super::plot::{HeatMap, Legend, LinePlot, LineStyle, Series};
use super::plot::{PlotError, Rgb};
use crate::campaign::paper::PaperSignals;
use crate::campaign::select::CampaignResult;
use crate::campaign::verdict::combined;
use crate::correctors::model_file::CorrectorFile;
use crate::export::{imu_tk_calibs, imucal_json, pretty};

/// A self-contained HTML report: the verdict, held-out errors per corrector, the sensor model;
/// then the paper's sections where its protocol ran.
pub fn campaign_report(r: &CampaignResult, paper: Option<&PaperSignals>) -> Result<String, PlotError> {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><meta name=\"generator\" content=\"spincal\"><title>spincal calibration: {unit}</title>\
         <style>body{{font-family:sans-serif;max-width:70em;margin:2em auto}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}th{{background:#eee}}.bad{{color:#b00}}</style></head><body>\
         <h1>Calibration: {unit}</h1><h2>Verdict</h2><p>{verdict}</p>",
        unit = escape(&r.unit),
        verdict = escape(&r.verdict)
    );
    error_map_section(r, &mut h)?;
    candidates_section(r, &mut h);
    held_out_section(r, &mut h)?;
    sensor_section(r, &mut h)?;
    thermal_section(r, &mut h)?;
    undetermined_section(r, &mut h);
    if let Some(g) = &r.gyro {
        gyro_section(g, &mut h)?;
    }
    timing_and_recordings_section(r, &mut h);
    if let (Some(paper), Some(signals)) = (&r.paper, paper) {
        h.push_str(&paper_sections(paper, signals, r.saved.as_deref())?);
    }
    h.push_str("</body></html>\n");
    Ok(h)
}

/// Where the saved correction can be trusted: its predicted error over the directions of
/// gravity, recorded poses outlined.
fn error_map_section(r: &CampaignResult, h: &mut String) -> Result<(), PlotError> {
    let Some(map) = &r.error_map else {
        return Ok(());
    };
    let _ = write!(
        h,
        "<h2>Where the correction can be trusted</h2><p>{}</p>",
        escape(&map.sentence())
    );
    let cells = map
        .poses
        .iter()
        .map(|p| map.cell_of(p.latitude_deg, p.longitude_deg))
        .collect();
    let plot = HeatMap::new(
        "Predicted error of the corrected still reading over the noise of one reading (worst axis)",
        "azimuth of gravity from +x towards +y (°)",
        "elevation of gravity above the x–y plane (°)",
        map.longitude_deg.iter().map(|v| format!("{v:.0}")).collect(),
        map.latitude_deg.iter().map(|v| format!("{v:.1}")).collect(),
        map.worst_sd_over_noise.iter().map(|v| v.min(9.9)).collect(),
    )
    .value_label("sd / noise")
    .decimals(1)
    .value_range(0.0, (2.0 * map.threshold).max(1.0))
    .mark(cells)
    .advise(
        map.next_pose
            .iter()
            .map(|n| {
                let u = n.pose_direction;
                map.cell_of(
                    u[2].clamp(-1.0, 1.0).asin().to_degrees(),
                    u[1].atan2(u[0]).to_degrees(),
                )
            })
            .collect(),
    )
    .size(900, 560);
    h.push_str(&figure(
        &plot,
        &format!(
            "Each cell: the standard deviation that the saved model's parameter covariance predicts for the corrected reading of a still sensor with gravity along the cell's direction, over the noise of one reading, largest over the three axes (capped at 9.9). At most {:.2} the corrected reading's error is within 1.25× what the true model would leave. Outlined in red: cells holding a recorded still pose; in blue, inside: the still pose advised next. Noise of one reading: {:.4}, {:.4}, {:.4} m/s².",
            map.threshold, map.noise_sd_mps2[0], map.noise_sd_mps2[1], map.noise_sd_mps2[2]
        ),
    )?);
    Ok(())
}

/// A number to `digits` places, or a dash.
fn value(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}

/// Each candidate over every held-out condition, and how they were judged.
fn candidates_section(r: &CampaignResult, h: &mut String) {
    h.push_str("<h2>Correctors on held-out conditions</h2><table><tr><th>corrector</th><th>what it is</th><th>mean residual RMS against physics, m/s²</th><th>worst ratio to uncorrected</th><th>mean RMS against truth, m/s²</th><th>eligible</th><th>why not</th></tr>");
    for c in &r.candidates {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            c.candidate,
            escape(&c.description),
            value(c.mean_rms_mps2, 4),
            value(c.worst_ratio_to_uncorrected, 2),
            value(c.mean_truth_rms_mps2, 4),
            if c.eligible { "yes" } else { "no" },
            escape(c.why_not.as_deref().unwrap_or(""))
        );
    }
    h.push_str("</table><p>Each corrector is trained on every condition but one and judged on the one left out, by physics alone: a still pose's specific force must have gravity's magnitude; a turntable run must move as a rigid platter moves a perfect sensor (rate measured from the data, radius within the ruler's tolerance, platter tilt, mount rotation within its prior, no bias, scale or drift freedom). The uncorrected signal gets the same check on the same samples; <em>ratio</em> is the corrector's residual RMS over the uncorrected one's; <em>predicted</em> (the physical model only) adds the error its parameters' covariance predicts and measures the uncorrected signal against the corrected one's physics reference, the figure comparable with the truth ratio; and a corrector is <em>significantly worse</em> when its excess mean square exceeds Student's t at one-sided 0.1 % times its batch-means standard error. Against truth (simulations only) is the same on the true specific force, which the verdict never uses. The <em>floor</em> is the RMS of the error no static corrector can remove (white noise and bias drift) on those samples.</p>");
}

/// The held-out plots, then each candidate on each held-out condition.
fn held_out_section(r: &CampaignResult, h: &mut String) -> Result<(), PlotError> {
    for (against_truth, caption) in [
        (false, "Residual RMS against physics over the three axes on each held-out condition (numbered as in the table below): each corrector and the uncorrected signal."),
        (true, "RMS error against the simulation's truth on the same samples: each corrector, the uncorrected signal and the floor."),
    ] {
        if let Some((plot, off_scale)) = held_out_plot(r, against_truth) {
            let note = if off_scale.is_empty() {
                String::new()
            } else {
                format!(
                    " Off the scale (above {OFF_SCALE}× the uncorrected signal), in the table only: {}.",
                    off_scale.join(", ")
                )
            };
            h.push_str(&figure(&plot, &format!("{caption}{note}"))?);
        }
    }
    h.push_str("<table><tr><th>#</th><th>held out</th><th>corrector</th><th>RMS x</th><th>RMS y</th><th>RMS z</th><th>uncorrected x</th><th>y</th><th>z</th><th>ratio</th><th>predicted</th><th>truth ratio</th><th>floor x</th><th>y</th><th>z</th><th>note</th></tr>");
    let mut labels: Vec<&str> = Vec::new();
    for s in &r.held_out {
        if !labels.contains(&s.condition.as_str()) {
            labels.push(&s.condition);
        }
        let cells = |v: Option<[f64; 3]>| {
            v.map_or("<td>–</td><td>–</td><td>–</td>".to_string(), |v| {
                v.iter().map(|x| format!("<td>{x:.4}</td>")).collect()
            })
        };
        let worse = s.physics.as_ref().is_some_and(|p| p.worse);
        let _ = write!(
            h,
            "<tr{}><td>{}</td><td>{}</td><td>{}</td>{}{}<td>{}</td><td>{}</td><td>{}</td>{}<td>{}</td></tr>",
            if worse { " class=\"bad\"" } else { "" },
            labels.len(),
            escape(&s.condition),
            s.candidate,
            cells(s.physics.as_ref().map(|p| p.rms_mps2)),
            cells(s.physics.as_ref().map(|p| p.uncorrected_rms_mps2)),
            s.physics
                .as_ref()
                .map_or("–".into(), |p| format!("{:.2} ± {:.2}", p.ratio, p.ratio_se)),
            value(s.predicted.as_ref().map(|p| p.ratio), 2),
            value(s.truth.as_ref().map(|t| t.ratio), 2),
            cells(s.floor_mps2),
            escape(s.note.as_deref().unwrap_or(""))
        );
    }
    Ok(())
}

/// The joint fit's sensor parameters, with their plots.
fn sensor_section(r: &CampaignResult, h: &mut String) -> Result<(), PlotError> {
    h.push_str("</table><h2>Sensor model (joint fit of every recording)</h2>");
    let _ = write!(
        h,
        "<p>The nonlinearity q was decided by the {}: {}.</p>",
        escape(&r.nonlinearity.decided_by),
        escape(&r.nonlinearity.rule)
    );
    let _ = write!(h, "<p>Terms: {}. Standard errors: {}.</p><table><tr><th>parameter</th><th>value</th><th>standard error</th></tr>", r.joint.terms.describe(), escape(&r.joint.covariance));
    for p in &r.joint.sensor_params {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.6}</td><td>{}</td></tr>",
            escape(&p.name),
            p.value,
            p.std_error.map_or("–".into(), |v| format!("{v:.6}"))
        );
    }
    h.push_str("</table>");
    if !r.placements.is_empty() {
        h.push_str("<p>Where the chip sat on the platter (runs of one placement share one radius; without a stated radius it comes from the runs' two speeds; its standard error includes its trade with the scale in the platter's plane and with the bias):</p><ul>");
        for p in &r.placements {
            let _ = write!(h, "<li>{}</li>", escape(&p.sentence()));
        }
        h.push_str("</ul>");
    }
    if let Some(offset) = &r.chip_offset {
        let _ = write!(
            h,
            "<p>Where the chip sits in the device (from the radii of placements turned about its stated centre; standard errors from the radii's robust covariance, which carries their trade with the in-plane scale, the centre's tolerance and a turn by hand within {:.0}°): {}</p>",
            crate::campaign::joint::TURN_SD_DEG,
            escape(&offset.sentence())
        );
    }
    let splits: Vec<String> = r.split_runs.iter().filter_map(|s| s.sentence()).collect();
    if !splits.is_empty() {
        h.push_str("<p>Runs cut at logging gaps:</p><ul>");
        for sentence in &splits {
            let _ = write!(h, "<li>{}</li>", escape(sentence));
        }
        h.push_str("</ul>");
    }
    if let Some(plot) = sensor_plot(r) {
        h.push_str(&figure(
            &plot,
            "Each sensor parameter's effect on a 1 g reading (bias as fitted; scale and misalignment × g; nonlinearity q × g²) with its 95 % interval (± 1.96 standard errors): 1–3 bias x, y, z; 4–6 scale x, y, z; 7–9 misalignment; 10–12 nonlinearity q. An interval that spans zero is an error this campaign cannot tell from none.",
        )?);
    }
    if let Some(plot) = run_residual_plot(r) {
        h.push_str(&figure(
            &plot,
            "What the joint fit leaves on each turntable run, per axis (numbered as in the list of recordings at the end): a run far above the others holds something the model does not (a loose mount, a wobble, a temperature change).",
        )?);
    }
    Ok(())
}

/// What the campaign leaves undetermined, with what to record.
fn undetermined_section(r: &CampaignResult, h: &mut String) {
    if !r.undetermined.is_empty() {
        h.push_str("<h2>What this campaign does not determine</h2><ul>");
        for a in &r.undetermined {
            let _ = write!(h, "<li>{}: {}</li>", escape(&a.parameter), escape(&a.sentence));
        }
        h.push_str("</ul>");
    }
}

/// The gyroscope's parameters and its cross-check against the accelerometer's rate.
fn gyro_section(g: &crate::campaign::gyro::GyroFit, h: &mut String) -> Result<(), PlotError> {
    let _ = write!(
        h,
        "<h2>Gyroscope</h2><p>m = b + K ω, ω in the accelerometer's body frame. Each turntable run's rotation rate, measured by the accelerometer, is the reference about the spindle; still poses give the bias. Standard errors: {}.</p><table><tr><th>parameter</th><th>value</th><th>standard error</th></tr>",
        escape(&g.covariance)
    );
    for p in g.params.iter().chain(&g.session_drift) {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.6e}</td><td>{}</td></tr>",
            escape(&p.name),
            p.value,
            p.std_error.map_or("–".into(), |v| format!("{v:.2e}"))
        );
    }
    h.push_str("</table><h3>Cross-check: the gyro against the accelerometer's rate</h3><table><tr><th>run</th><th>rate from the accelerometer, rad/s</th><th>raw gyro about the spindle</th><th>calibrated gyro</th><th>residual RMS x y z, rad/s</th></tr>");
    for c in &g.rate_checks {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.6} ± {}</td><td>{:.6}</td><td>{:.6}</td><td>{:.2e} {:.2e} {:.2e}</td></tr>",
            escape(&c.run),
            c.accel_rate_radps,
            c.accel_rate_se_radps.map_or("–".into(), |v| format!("{v:.1e}")),
            c.raw_gyro_rate_radps,
            c.calibrated_gyro_rate_radps,
            c.residual_rms_radps[0],
            c.residual_rms_radps[1],
            c.residual_rms_radps[2]
        );
    }
    h.push_str("</table>");
    for s in &g.saturation {
        let _ = write!(h, "<p class=\"warn\">{}</p>", escape(&s.describe()));
    }
    if let Some(plot) = gyro_rate_plot(g) {
        h.push_str(&figure(
            &plot,
            "The gyroscope about the spindle minus the rate the accelerometer measured, per run: raw and calibrated, with the accelerometer rate's 95 % interval around zero. A calibrated gyro sits on zero within that interval.",
        )?);
    }
    if !g.undetermined.is_empty() {
        let _ = write!(
            h,
            "<h3>Not determined</h3><p>Rule: {}{}.</p><ul>",
            escape(&g.nominal_rule),
            if g.saved_model().is_none() {
                "; no term is determined, so no gyroscope part is saved"
            } else {
                ""
            }
        );
        for (name, advice) in &g.undetermined {
            let free = g.free_params.iter().find(|p| &p.name == name);
            let what = if g.left_at_nominal.contains(name) {
                "left at nominal"
            } else {
                "kept (far from nominal)"
            };
            let _ = write!(
                h,
                "<li>{}, {what}{}: to determine it, {}</li>",
                escape(name),
                free.map_or(String::new(), |p| format!(
                    " (fitted free: {:.4e} ± {})",
                    p.value,
                    p.std_error.map_or("–".into(), |v| format!("{v:.1e}"))
                )),
                escape(advice)
            );
        }
        h.push_str("</ul>");
    }
    Ok(())
}

/// Where the time went, and the recordings.
fn timing_and_recordings_section(r: &CampaignResult, h: &mut String) {
    h.push_str("<h2>Where the time went</h2><table><tr><th>stage</th><th>time (s)</th></tr>");
    for s in &r.stage_seconds {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.2}</td></tr>",
            escape(&s.stage),
            s.seconds
        );
    }
    h.push_str("</table>");
    h.push_str("<h2>Recordings</h2><ol>");
    for run in &r.joint.runs {
        let _ = write!(
            h,
            "<li>{} ({}, residual RMS {:.4} {:.4} {:.4} m/s²)</li>",
            escape(&run.name),
            run.direction.describe(),
            run.residual_rms_mps2[0],
            run.residual_rms_mps2[1],
            run.residual_rms_mps2[2]
        );
    }
    h.push_str("</ol><ul>");
    for pose in &r.joint.poses {
        let _ = write!(h, "<li>{} (still pose)</li>", escape(&pose.name));
    }
    h.push_str("</ul>");
}

/// A corrector whose held-out error exceeds the uncorrected signal's by this factor is left out of
/// the held-out plot, which it would flatten (its numbers stay in the table).
const OFF_SCALE: f64 = 5.0;

/// Held-out error per condition for every corrector with the uncorrected signal: against physics,
/// or against truth with the floor (`None` without truth); and the correctors left out as
/// [`OFF_SCALE`].
fn held_out_plot(r: &CampaignResult, against_truth: bool) -> Option<(LinePlot, Vec<String>)> {
    let mut conditions: Vec<&str> = Vec::new();
    for s in &r.held_out {
        if !conditions.contains(&s.condition.as_str()) {
            conditions.push(&s.condition);
        }
    }
    if conditions.is_empty() || (against_truth && r.held_out.iter().all(|s| s.truth.is_none())) {
        return None;
    }
    let comparison = |s: &crate::campaign::choice::HeldOutScore| {
        if against_truth {
            s.truth.clone()
        } else {
            s.physics.clone()
        }
    };
    let index = |c: &str| conditions.iter().position(|&k| k == c);
    let per_condition = |value: &dyn Fn(&crate::campaign::choice::HeldOutScore) -> Option<f64>| {
        let mut y = vec![f64::NAN; conditions.len()];
        for s in &r.held_out {
            if let (Some(i), Some(v)) = (index(&s.condition), value(s)) {
                y[i] = v;
            }
        }
        y
    };
    let x: Vec<f64> = (1..=conditions.len()).map(|i| i as f64).collect();
    let mut plot = LinePlot::new(
        if against_truth {
            "Held-out error against truth"
        } else {
            "Held-out residual against physics"
        },
        "held-out condition (#)",
        "RMS over x, y, z, m/s²",
    )
    .x_range(0.5, conditions.len() as f64 + 0.5)
    .legend(Legend::UpperRight);
    let uncorrected = per_condition(&|s| comparison(s).map(|p| combined(p.uncorrected_rms_mps2)));
    let largest = |y: &[f64]| y.iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max);
    let scale = OFF_SCALE * largest(&uncorrected);
    let mut off_scale = Vec::new();
    for (k, c) in r.candidates.iter().enumerate() {
        let y = per_condition(&|s| {
            (s.candidate == c.candidate)
                .then(|| comparison(s).map(|p| combined(p.rms_mps2)))
                .flatten()
        });
        if largest(&y) > scale {
            off_scale.push(c.candidate.clone());
            continue;
        }
        plot = plot.series(
            Series::new(c.candidate.clone(), x.clone(), y)
                .color(Rgb::palette(k))
                .style(LineStyle::Markers),
        );
    }
    plot = plot.series(
        Series::new("uncorrected", x.clone(), uncorrected)
            .color(Rgb(0, 0, 0))
            .style(LineStyle::Dashed),
    );
    let floor = per_condition(&|s| s.floor_mps2.map(combined));
    if against_truth && floor.iter().any(|v| v.is_finite()) {
        plot = plot.series(
            Series::new("floor", x, floor)
                .color(Rgb(120, 120, 120))
                .style(LineStyle::Dashed),
        );
    }
    Some((plot, off_scale))
}

/// The thermal model: what was chosen, over which range, and its curves with their bands; or why
/// there is none although the recordings carry a temperature.
fn thermal_section(r: &CampaignResult, h: &mut String) -> Result<(), PlotError> {
    if let Some(note) = &r.thermal_note {
        let _ = write!(h, "<h2>Temperature</h2><p>{}</p>", escape(note));
    }
    if !r.temperature_findings.is_empty() {
        let _ = write!(
            h,
            "<p>{} temperature sample(s) were kept out of the thermal fit (held at the last trusted value):</p><ul>",
            r.temperature_masked_samples
        );
        for finding in &r.temperature_findings {
            let _ = write!(h, "<li>{}</li>", escape(&finding.to_string()));
        }
        h.push_str("</ul>");
    }
    let Some(t) = &r.thermal else {
        return Ok(());
    };
    let m = &t.fit.model;
    let _ = write!(
        h,
        "<h2>Temperature</h2><p>Every recording with a temperature was taken to the reference temperature {:.1} °C before the rest of the calibration, and model.json applies the same change first. Bias orders {:?} and gain orders {:?} (x, y, z), kept by the terms rule: {}. Power-on sessions among the still recordings: {}{}. The reported temperature lags the die by τ = {:.0} s (chosen by residual among the candidates), undone as T + τ·dT/dt over {:.0} s. Validated over die temperatures {:.1}–{:.1} °C: <code>spincal correct</code> marks rows outside it. Residual RMS of the thermal fit {:.4} m/s² over {} windows. In the held-out figures above, <em>uncorrected</em> is the recording after this step.{}{}</p>",
        m.reference_c,
        t.fit.terms.bias_orders,
        t.fit.terms.scale_orders,
        escape(&t.fit.terms.rule),
        t.fit.sessions.count,
        if t.fit.sessions.count > 1 {
            format!(
                ", their bias offsets spread by {:.2e} m/s² (estimated from the windows{})",
                t.fit.sessions.spread_sd_mps2,
                if t.fit.sessions.at_lower_bound { ": none seen" } else { "" }
            )
        } else {
            String::new()
        },
        m.lag_s,
        m.smoothing_s,
        m.fitted_range_c[0],
        m.fitted_range_c[1],
        t.fit.residual_rms_mps2,
        t.fit.windows,
        if t.without_temperature.is_empty() {
            String::new()
        } else {
            format!(" Used as recorded (no temperature): {}.", escape(&t.without_temperature.join(", ")))
        },
        if t.clamped_samples == 0 {
            String::new()
        } else {
            format!(" {} samples lay outside the range and were taken to the reference from its nearest end.", t.clamped_samples)
        }
    );
    if !t.fit.terms.tests.is_empty() {
        h.push_str("<table><tr><th>term</th><th>axis</th><th>order</th><th>c/se</th><th>kept</th></tr>");
        for o in &t.fit.terms.tests {
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td></tr>",
                o.part,
                ["x", "y", "z"][o.axis.min(2)],
                o.order,
                o.z,
                if o.kept { "yes" } else { "no" }
            );
        }
        h.push_str("</table>");
    }
    for (gain, caption) in [
        (false, "The bias's change with die temperature per axis, β(T), m/s², with a 95 % band (± 1.96 standard errors of the coefficients, taken as independent; the die temperature's own estimate is not in them, see ThermalFit)."),
        (true, "The gain's change with die temperature per axis, ρ(T), in parts per million, with the same band."),
    ] {
        h.push_str(&figure(&thermal_plot(&t.fit, gain), caption)?);
    }
    Ok(())
}

/// β_k(T) (or ρ_k(T) in ppm) over the fitted range with ± 1.96 SE bands.
fn thermal_plot(fit: &crate::thermal::ThermalFit, gain: bool) -> LinePlot {
    let m = &fit.model;
    let [lo, hi] = m.fitted_range_c;
    let (coefficients, errors, scale, title, unit) = if gain {
        (
            &m.scale_per_c,
            &fit.scale_per_c_se,
            1e6,
            "Gain against temperature",
            "gain change, ppm",
        )
    } else {
        (
            &m.bias_per_c,
            &fit.bias_per_c_se,
            1.0,
            "Bias against temperature",
            "bias change, m/s²",
        )
    };
    let t: Vec<f64> = (0..=50).map(|i| lo + (hi - lo) * i as f64 / 50.0).collect();
    let mut plot = LinePlot::new(title, "die temperature, °C", unit).legend(Legend::UpperLeft);
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        let value = |d: f64| -> (f64, f64) {
            let v = if gain {
                m.scale_change(d)[k]
            } else {
                m.bias_change(d)[k]
            };
            let dt = d - m.reference_c;
            let var: f64 = (0..coefficients[k].len())
                .map(|j| (errors[k].get(j).copied().unwrap_or(0.0) * dt.powi(j as i32 + 1)).powi(2))
                .sum();
            (v * scale, 1.96 * var.sqrt() * scale)
        };
        let (v, band): (Vec<f64>, Vec<f64>) = t.iter().map(|&d| value(d)).unzip();
        let low: Vec<f64> = v.iter().zip(&band).map(|(a, b)| a - b).collect();
        let high: Vec<f64> = v.iter().zip(&band).map(|(a, b)| a + b).collect();
        plot = plot
            .series(Series::new(axis, t.clone(), v).color(Rgb::palette(k)))
            .series(
                Series::new("", t.clone(), low)
                    .color(Rgb::palette(k))
                    .style(LineStyle::Dashed),
            )
            .series(
                Series::new("", t.clone(), high)
                    .color(Rgb::palette(k))
                    .style(LineStyle::Dashed),
            );
    }
    plot
}

/// Vertical intervals as one series: each (x, low, high) a segment, NaN between them.
fn intervals(name: &str, x: &[f64], low: &[f64], high: &[f64], color: Rgb) -> Series {
    let mut xs = Vec::with_capacity(3 * x.len());
    let mut ys = Vec::with_capacity(3 * x.len());
    for i in 0..x.len() {
        xs.extend([x[i], x[i], f64::NAN]);
        ys.extend([low[i], high[i], f64::NAN]);
    }
    Series::new(name, xs, ys).color(color).style(LineStyle::Solid)
}

/// The twelve sensor parameters as their effect on a 1 g reading, m/s², with 95 % intervals.
fn sensor_plot(r: &CampaignResult) -> Option<LinePlot> {
    let params = &r.joint.sensor_params;
    if params.len() != crate::correctors::physical::SENSOR_PARAMS {
        return None;
    }
    let g = crate::input::recording::STANDARD_GRAVITY;
    let per_g = |k: usize| match k {
        0..=2 => 1.0,
        3..=8 => g,
        _ => g * g,
    };
    let x: Vec<f64> = (1..=params.len()).map(|k| k as f64).collect();
    let value: Vec<f64> = params
        .iter()
        .enumerate()
        .map(|(k, p)| p.value * per_g(k))
        .collect();
    let half: Vec<f64> = params
        .iter()
        .enumerate()
        .map(|(k, p)| p.std_error.map_or(f64::NAN, |se| 1.96 * se * per_g(k)))
        .collect();
    let low: Vec<f64> = value.iter().zip(&half).map(|(v, h)| v - h).collect();
    let high: Vec<f64> = value.iter().zip(&half).map(|(v, h)| v + h).collect();
    Some(
        LinePlot::new(
            "Sensor parameters",
            "parameter (#)",
            "effect on a 1 g reading, m/s²",
        )
        .series(intervals("95 % interval", &x, &low, &high, Rgb::palette(0)))
        .series(
            Series::new("fitted", x.clone(), value)
                .color(Rgb::palette(0))
                .style(LineStyle::Markers),
        )
        .series(
            Series::new("", vec![0.5, params.len() as f64 + 0.5], vec![0.0, 0.0])
                .color(Rgb(120, 120, 120))
                .style(LineStyle::Dashed),
        )
        .x_range(0.5, params.len() as f64 + 0.5)
        .legend(Legend::UpperRight),
    )
}

/// The joint fit's residual RMS per run and axis.
fn run_residual_plot(r: &CampaignResult) -> Option<LinePlot> {
    let runs = &r.joint.runs;
    if runs.is_empty() {
        return None;
    }
    let x: Vec<f64> = (1..=runs.len()).map(|i| i as f64).collect();
    let mut plot = LinePlot::new(
        "Joint fit residual per run",
        "turntable run (#)",
        "residual RMS, m/s²",
    )
    .x_range(0.5, runs.len() as f64 + 0.5)
    .legend(Legend::UpperRight);
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        let y = runs.iter().map(|run| run.residual_rms_mps2[k]).collect();
        plot = plot.series(
            Series::new(axis, x.clone(), y)
                .color(Rgb::palette(k))
                .style(LineStyle::Markers),
        );
    }
    Some(plot)
}

/// Gyro minus accelerometer rate about the spindle per run, raw and calibrated, °/s.
fn gyro_rate_plot(g: &crate::campaign::gyro::GyroFit) -> Option<LinePlot> {
    let checks = &g.rate_checks;
    if checks.is_empty() {
        return None;
    }
    let deg = 180.0 / std::f64::consts::PI;
    let x: Vec<f64> = (1..=checks.len()).map(|i| i as f64).collect();
    let raw = checks
        .iter()
        .map(|c| (c.raw_gyro_rate_radps - c.accel_rate_radps) * deg)
        .collect();
    let calibrated = checks
        .iter()
        .map(|c| (c.calibrated_gyro_rate_radps - c.accel_rate_radps) * deg)
        .collect();
    let half: Vec<f64> = checks
        .iter()
        .map(|c| c.accel_rate_se_radps.map_or(f64::NAN, |se| 1.96 * se * deg))
        .collect();
    let low: Vec<f64> = half.iter().map(|h| -h).collect();
    Some(
        LinePlot::new(
            "Gyro against the accelerometer's rate",
            "turntable run (#)",
            "gyro − accelerometer rate, °/s",
        )
        .series(intervals(
            "accelerometer rate, 95 %",
            &x,
            &low,
            &half,
            Rgb(120, 120, 120),
        ))
        .series(
            Series::new("raw gyro", x.clone(), raw)
                .color(Rgb::palette(1))
                .style(LineStyle::Markers),
        )
        .series(
            Series::new("calibrated gyro", x, calibrated)
                .color(Rgb::palette(0))
                .style(LineStyle::Markers),
        )
        .x_range(0.5, checks.len() as f64 + 0.5)
        .legend(Legend::UpperRight),
    )
}

/// Every file a calibration writes, by name, with its content: model.json (when a corrector was
/// saved), results.json, report.html (with the paper's sections when `paper` holds its signals),
/// and, when saved, the linear part of the calibration in the files other tools read
/// (imucal.json, imu_tk_acc.calib, imu_tk_gyro.calib; see [`crate::export`]). `spincal
/// calibrate` (with or without `--campaign`), `spincal fleet` and the Python package write these
/// files.
pub fn campaign_files(
    result: &CampaignResult,
    saved: Option<&CorrectorFile>,
    paper: Option<&PaperSignals>,
) -> Result<Vec<(&'static str, String)>, PlotError> {
    let mut files = Vec::new();
    if let Some(model) = saved {
        files.push(("model.json", model.to_json() + "\n"));
    }
    files.push(("results.json", pretty(result)));
    files.push(("report.html", campaign_report(result, paper)?));
    // Other tools' files only for a calibration that held on held-out conditions.
    if saved.is_none() {
        return Ok(files);
    }
    let sensor = &result.joint.sensor;
    let gyro = result.gyro.as_ref().and_then(|g| g.saved_model());
    let mut imucal = imucal_json(sensor, gyro);
    if let Some(thermal) = &result.thermal {
        let comment = imucal["comment"].as_str().unwrap_or_default().to_string();
        imucal["comment"] = serde_json::json!(format!(
            "{comment} The campaign was taken to the reference temperature {:.1} °C first: these values hold there only (model.json, and `spincal export --ardupilot/--px4`, carry the change with temperature; imucal and imu_tk cannot).",
            thermal.fit.model.reference_c
        ));
    }
    files.push(("imucal.json", pretty(&imucal)));
    if let Some((acc, gyr)) = imu_tk_calibs(sensor, gyro) {
        files.push(("imu_tk_acc.calib", acc.to_text()));
        if let Some(gyr) = gyr {
            files.push(("imu_tk_gyro.calib", gyr.to_text()));
        }
    }
    Ok(files)
}

/// The names [`campaign_files`] may write, to check before any work that none is an input.
pub const CAMPAIGN_FILE_NAMES: [&str; 6] = [
    "model.json",
    "results.json",
    "report.html",
    "imucal.json",
    "imu_tk_acc.calib",
    "imu_tk_gyro.calib",
];
