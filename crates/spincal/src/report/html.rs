//! The calibration report: one self-contained HTML file, read top to bottom, plots inline as SVG.
//!
//! Every number shown comes from [`CalibrationResult`] (what `results.json` holds) and is written
//! as `<span data-json="/json/pointer" data-digits="d">`, so a test can check each against the
//! JSON file: one source, no second computation. Plots draw the signals behind those numbers.

use crate::calibrate::{CalibrationOutput, NetworkChoice, PartScore};
use crate::correctors::ann::Part;
use crate::input::recording::{Recording, STANDARD_GRAVITY};
use crate::report::plot::{Figure, HeatMap, LinePlot, PlotError, Rgb, Series};

/// A number tied to its place in results.json.
fn num(pointer: &str, value: f64, digits: usize) -> String {
    let shown = if value.is_finite() {
        format!("{value:.digits$}")
    } else {
        "—".to_string()
    };
    format!(r#"<span data-json="{pointer}" data-digits="{digits}">{shown}</span>"#)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn g_series(name: &str, time: &[f64], values: &[f64], color: usize) -> Series {
    Series::new(
        name,
        time.to_vec(),
        values.iter().map(|v| v / STANDARD_GRAVITY).collect(),
    )
    .color(Rgb::palette(color))
}

/// Samples with time inside [t0, t1].
fn window(time: &[f64], t0: f64, t1: f64) -> std::ops::Range<usize> {
    let a = time.partition_point(|&t| t < t0);
    let b = time.partition_point(|&t| t <= t1);
    a..b
}

fn figure(fig: &impl Figure, caption: &str) -> Result<String, PlotError> {
    Ok(format!(
        "<figure>{}<figcaption>{}</figcaption></figure>\n",
        fig.to_svg()?,
        escape(caption)
    ))
}

fn score_cells(pointer: &str, score: &PartScore) -> String {
    format!(
        "<td>{}</td>",
        num(&format!("{pointer}/fit_percent_mean"), score.fit_percent_mean, 2)
    )
}

/// Renders the report of a calibration of `recordings`.
pub fn render_report(output: &CalibrationOutput, recordings: &[Recording]) -> Result<String, PlotError> {
    let r = &output.result;
    let fit = &r.turntable;
    let mut html = String::new();
    html.push_str(concat!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">",
        "<title>spincal calibration report</title><style>",
        "body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222;line-height:1.45}",
        "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}",
        "th{background:#eee}td:first-child,th:first-child{text-align:left}figure{margin:1em 0}",
        "figcaption{font-size:90%;color:#555}code,pre{background:#f4f4f4;padding:2px 4px}",
        ".chosen{background:#e6f4ea;font-weight:bold}</style></head><body>\n"
    ));
    html.push_str("<h1>spincal calibration report</h1>\n");
    html.push_str(&format!(
        "<p>spincal {} · seed {} · corrected axes {} · total time {} s. Chosen corrector: <b>{}</b> \
         (best validation fit among correctors that can be saved); best on validation among all models without warnings (section 8): <b>{}</b>.</p>\n",
        escape(&r.spincal_version),
        num("/seed", r.seed as f64, 0),
        escape(&r.axes.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")),
        num("/seconds_total", r.seconds_total, 1),
        escape(&r.chosen),
        escape(&r.best_overall)
    ));

    // 1. The recordings.
    html.push_str("<h2>1. The recordings</h2>\n<table><tr><th>recording</th><th>samples</th><th>duration (s)</th><th>sample rate (Hz)</th><th>gaps</th><th>saturated samples</th></tr>\n");
    for (k, s) in r.recordings.iter().enumerate() {
        let p = format!("/recordings/{k}");
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape(&s.name),
            num(&format!("{p}/samples"), s.samples as f64, 0),
            num(&format!("{p}/duration_s"), s.duration_s, 1),
            num(&format!("{p}/sample_rate_hz"), s.sample_rate_hz, 2),
            num(&format!("{p}/gaps"), s.gaps as f64, 0),
            num(&format!("{p}/saturated_samples"), s.saturated_samples as f64, 0)
        ));
    }
    html.push_str("</table>\n");
    for s in &r.recordings {
        for w in &s.warnings {
            html.push_str(&format!("<p>⚠ {}</p>\n", escape(w)));
        }
    }
    for (k, rec) in recordings.iter().enumerate() {
        let mut plot = LinePlot::new(
            format!("Recording {}: {}", k + 1, rec.source.name),
            "time (s)",
            "acceleration (g)",
        );
        for a in 0..3 {
            plot = plot.series(g_series(
                ["ax", "ay", "az"][a],
                &rec.time_s,
                &rec.accel_mps2[a],
                a,
            ));
        }
        html.push_str(&figure(
            &plot,
            "Measured acceleration, all samples (thinned for drawing, extremes kept).",
        )?);
    }

    // 2. The spectrum.
    html.push_str("<h2>2. Rotation rate from the spectrum</h2>\n");
    for (k, rf) in fit.recordings.iter().enumerate() {
        let p = format!("/recordings/{k}");
        html.push_str(&format!(
            "<p>Recording {}: the highest line of the x+y spectrum is at {} rpm = {} rad/s (the paper found 33.5 rpm this way for a nominal 33.3).</p>\n",
            k + 1,
            num(&format!("{p}/rpm_from_spectrum"), r.recordings[k].rpm_from_spectrum, 3),
            num(&format!("{p}/omega_from_spectrum_radps"), r.recordings[k].omega_from_spectrum_radps, 4)
        ));
        if !rf.rate.spectrum_hz.is_empty() {
            let f_max = (rf.rate.frequency_hz * 6.0).min(*rf.rate.spectrum_hz.last().unwrap_or(&1.0));
            let keep = rf.rate.spectrum_hz.partition_point(|&f| f <= f_max);
            let plot = LinePlot::new(
                format!("Spectrum of recording {}", k + 1),
                "frequency (Hz)",
                "power",
            )
            .series(
                Series::new(
                    "x + y",
                    rf.rate.spectrum_hz[1..keep].to_vec(),
                    rf.rate.spectrum_power[1..keep]
                        .iter()
                        .map(|p| p.max(1e-30))
                        .collect(),
                )
                .color(Rgb::palette(0)),
            )
            .log_y()
            .vline(rf.rate.frequency_hz, format!("{:.3} rpm", rf.rate.rpm));
            html.push_str(&figure(
                &plot,
                "Summed power spectrum of x and y with the rotation line marked.",
            )?);
        }
    }

    // 3. Model against measurement.
    html.push_str("<h2>3. Turntable model against measurement</h2>\n");
    html.push_str("<table><tr><th>recording</th><th>fit x (%)</th><th>fit y (%)</th><th>fit z (%)</th><th>direction</th></tr>\n");
    for (k, rf) in fit.recordings.iter().enumerate() {
        let p = format!("/turntable/recordings/{k}/fit_percent");
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:?}</td></tr>\n",
            escape(&rf.name),
            num(&format!("{p}/0"), rf.fit_percent[0], 2),
            num(&format!("{p}/1"), rf.fit_percent[1], 2),
            num(&format!("{p}/2"), rf.fit_percent[2], 2),
            rf.session.direction
        ));
    }
    html.push_str("</table><p>z carries only g cos α plus offset and noise, so its fit % is near zero by construction.</p>\n");
    if let (Some(rec), Some(reference)) = (recordings.first(), output.models.first()) {
        let span = window(&rec.time_s, rec.time_s[0], rec.time_s[0] + 20.0);
        let t = &rec.time_s[span.clone()];
        for a in 0..2 {
            let plot = LinePlot::new(
                format!(
                    "a{} of recording 1: model and measurement (first 20 s)",
                    ["x", "y"][a]
                ),
                "time (s)",
                "acceleration (g)",
            )
            .series(g_series("measured", t, &rec.accel_mps2[a][span.clone()], 0))
            .series(g_series("model", t, &reference.accel_mps2[a][span.clone()], 1));
            html.push_str(&figure(&plot, "The fitted model with the sensor offsets (paper's Fig. 9); without them it is the reference the correctors learn.")?);
        }
        let residual: Vec<Vec<f64>> = (0..3)
            .map(|a| {
                rec.accel_mps2[a]
                    .iter()
                    .zip(&reference.accel_mps2[a])
                    .map(|(m, r)| m - r)
                    .collect()
            })
            .collect();
        let mut plot = LinePlot::new(
            "Residuals, measured − model, recording 1",
            "time (s)",
            "residual (g)",
        );
        for a in 0..3 {
            plot = plot.series(g_series(["x", "y", "z"][a], &rec.time_s, &residual[a], a));
        }
        html.push_str(&figure(
            &plot,
            "What the turntable model does not explain: noise, sensor errors, wow.",
        )?);
    }

    // 4. Parameters.
    html.push_str("<h2>4. Turntable parameters</h2>\n<table><tr><th>parameter</th><th>value</th><th>standard error</th><th>unit</th><th>at bound</th></tr>\n");
    for (i, p) in fit.params.iter().enumerate() {
        let base = format!("/turntable/params/{i}");
        let se = match p.std_error {
            Some(se) => num(&format!("{base}/std_error"), se, 9),
            None => "not determined".into(),
        };
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape(&p.name),
            num(&format!("{base}/value"), p.value, 9),
            se,
            escape(&p.unit),
            if p.at_bound { "yes" } else { "no" }
        ));
    }
    html.push_str("</table>\n");
    if let Some(remedy) = &fit.remedy {
        html.push_str(&format!("<p><b>Not determined:</b> {}</p>\n", escape(remedy)));
    } else {
        html.push_str("<p>Every parameter is determined by the data.</p>\n");
    }
    for (i, d) in fit.drift.iter().enumerate().filter(|(_, d)| d.significant) {
        html.push_str(&format!(
            "<p>Drift detected: recording {} axis {} moves {} m/s² over the recording.</p>\n",
            d.recording + 1,
            d.axis,
            num(&format!("/turntable/drift/{i}/change_mps2"), d.change_mps2, 5)
        ));
    }

    // 5. Sensitivity.
    html.push_str("<h2>5. Sensitivity at the fitted parameters (the paper's Table 1)</h2>\n<table><tr><th>parameter</th><th>change (%)</th><th>value</th><th>mean a_x (g)</th><th>amplitude a_x (g)</th><th>amplitude a_y (g)</th></tr>\n");
    for (i, s) in r.sensitivity.iter().enumerate() {
        let b = format!("/sensitivity/{i}");
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{} {}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape(&s.parameter),
            num(&format!("{b}/change_pct"), s.change_pct, 0),
            num(&format!("{b}/value"), s.value, 4),
            escape(&s.unit),
            num(&format!("{b}/mean_ax_g"), s.mean_ax_g, 4),
            num(&format!("{b}/amplitude_ax_g"), s.amplitude_ax_g, 4),
            num(&format!("{b}/amplitude_ay_g"), s.amplitude_ay_g, 4)
        ));
    }
    html.push_str("</table>\n");

    // 6. Division.
    html.push_str("<h2>6. Training, validation and test division</h2>\n");
    if let Some(rec) = recordings.first() {
        let mut plot = LinePlot::new("Division of recording 1 (paper's Fig. 10)", "time (s)", "ax (g)")
            .series(g_series("ax", &rec.time_s, &rec.accel_mps2[0], 0));
        let colors = [Rgb(0, 158, 115), Rgb(230, 159, 0), Rgb(204, 121, 167)];
        for (part, label, color) in [
            (Part::Train, "training", colors[0]),
            (Part::Validation, "validation", colors[1]),
            (Part::Test, "test", colors[2]),
        ] {
            for range in r.division.ranges(part) {
                if range.end > range.start {
                    plot = plot.span(rec.time_s[range.start], rec.time_s[range.end - 1], label, color);
                }
            }
        }
        html.push_str(&figure(
            &plot,
            "The test part is never used for training or for choosing anything.",
        )?);
    }
    html.push_str(&format!(
        "<p>Samples: training {}, validation {}, test {}.</p>\n",
        r.division.count(Part::Train),
        r.division.count(Part::Validation),
        r.division.count(Part::Test)
    ));

    // 7. Sweep.
    html.push_str("<h2>7. Network architectures</h2>\n");
    if r.sweep.is_empty() {
        html.push_str(&format!(
            "<p>No sweep was run; the architecture [{}] was trained as given.</p>\n",
            escape(&r.network_architecture)
        ));
    } else {
        let mut first: Vec<usize> = r.sweep.iter().map(|s| s.hidden[0]).collect();
        first.sort_unstable();
        first.dedup();
        let mut second: Vec<usize> = r
            .sweep
            .iter()
            .map(|s| s.hidden.get(1).copied().unwrap_or(0))
            .collect();
        second.sort_unstable();
        second.dedup();
        let mut values = vec![f64::NAN; first.len() * second.len()];
        for s in &r.sweep {
            let c = first.binary_search(&s.hidden[0]).unwrap_or(0);
            let row = second
                .binary_search(&s.hidden.get(1).copied().unwrap_or(0))
                .unwrap_or(0);
            values[row * first.len() + c] = s.validation_fit_percent;
        }
        let map = HeatMap::new(
            "Validation fit % by architecture (paper's Fig. 12)",
            "units in hidden layer 1",
            "units in hidden layer 2 (0: one layer)",
            first.iter().map(|v| v.to_string()).collect(),
            second.iter().map(|v| v.to_string()).collect(),
            values,
        )
        .value_label("fit %");
        html.push_str(&figure(
            &map,
            "Each cell: the best of the restarts, chosen on validation.",
        )?);
        html.push_str(&format!(
            "<p>{} architectures were trained; the best on validation is [{}]. The paper's full grid \
             (one layer of 1–15 units, two layers of 1–15 × 1–10) is 165 architectures: \
             <code>spincal calibrate --sweep full</code>; smaller grids (as the demo's) say so here by their count.</p>\n",
            r.sweep.len(),
            escape(&r.network_architecture)
        ));
        let train = r.division.count(Part::Train);
        if let NetworkChoice::Sweep {
            hessian_samples: Some(samples),
            ..
        } = &r.network
        {
            if *samples < train {
                html.push_str(&format!(
                    "<p>To keep the sweep to minutes, each of its epochs formed JᵀJ from about {samples} of \
                     the {train} training samples (whole blocks spread over the training part); errors, \
                     gradients and the accepted steps used all of them, and the chosen architecture was \
                     then trained with every sample.</p>\n"
                ));
            }
        }
    }

    // 8. Comparison.
    html.push_str("<h2>8. Comparison of correctors (the paper's Table 2)</h2>\n");
    html.push_str("<p>Fit % = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖), mean over the corrected axes. Dynamic models: <i>simulation</i> \
        (infinite horizon, started from the first measured outputs) and <i>one-step prediction</i> (uses past reference \
        values, so it is not available when correcting new data). Static maps have one kind.</p>\n");
    html.push_str("<table><tr><th>model</th><th>structure</th><th>train fit (sim.)</th><th>validation fit (sim.)</th><th>test fit (sim.)</th><th>train fit (one-step)</th><th>test fit (one-step)</th><th>test RMSE (m/s²)</th><th>seconds</th></tr>\n");
    for (i, row) in r.comparison.iter().enumerate() {
        let b = format!("/comparison/{i}");
        let one_step = |name: &str, s: &Option<PartScore>| match s {
            Some(s) => score_cells(&format!("{b}/{name}"), s),
            None => "<td>same</td>".into(),
        };
        html.push_str(&format!(
            "<tr{}><td>{}</td><td>{}</td>{}{}{}{}{}<td>{}</td><td>{}</td></tr>\n",
            if row.model == r.chosen {
                " class=\"chosen\""
            } else {
                ""
            },
            escape(&row.model),
            match &row.failed {
                Some(why) => format!("{} — not fitted: {}", escape(&row.structure), escape(why)),
                None =>
                    escape(&row.structure)
                        + &row
                            .warnings
                            .iter()
                            .map(|w| format!("<br><b>warning:</b> {}", escape(w)))
                            .collect::<String>(),
            },
            score_cells(&format!("{b}/train"), &row.train),
            score_cells(&format!("{b}/validation"), &row.validation),
            score_cells(&format!("{b}/test"), &row.test),
            one_step("train_one_step", &row.train_one_step),
            one_step("test_one_step", &row.test_one_step),
            num(&format!("{b}/test/rmse_mps2_mean"), row.test.rmse_mps2_mean, 5),
            num(&format!("{b}/seconds"), row.seconds, 2)
        ));
    }
    html.push_str("</table>\n<p>The paper (MATLAB, its own recording): ARX 51.81 / 48.29, BJ 66.66 / 60.18, NARX 61.09 / 54.70, HW 67.17 / 59.66 (training / test), ANN about 67.</p>\n");
    if !r.cross_condition.is_empty() {
        html.push_str("<h3>Cross-condition: trained on recording 1, tested on another speed or radius</h3>\n<p>A corrector that only learned to emit one sine fails here; a single-recording split cannot show that.</p>\n<table><tr><th>model</th><th>tested on</th><th>fit (%)</th><th>samples outside the network's training range (%)</th></tr>\n");
        for (i, c) in r.cross_condition.iter().enumerate() {
            let outside = match c.outside_training_range_percent {
                Some(p) => num(
                    &format!("/cross_condition/{i}/outside_training_range_percent"),
                    p,
                    1,
                ),
                None => "—".to_string(),
            };
            html.push_str(&format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{outside}</td></tr>\n",
                escape(&c.model),
                escape(&c.tested_on),
                num(
                    &format!("/cross_condition/{i}/score/fit_percent_mean"),
                    c.score.fit_percent_mean,
                    2
                )
            ));
        }
        html.push_str("</table>\n");
    }

    // 9. Corrected signal.
    html.push_str("<h2>9. Corrected signal against the reference (test part)</h2>\n");
    if let (Some(rec), Some(reference)) = (recordings.first(), output.references.first()) {
        let test = r.division.ranges(Part::Test);
        if let (Some(first), Some(last)) = (test.first(), test.last()) {
            let t0 = rec.time_s[first.start];
            let t1 = rec.time_s[last.end - 1].min(t0 + 15.0);
            let span = window(&rec.time_s, t0, t1);
            let t = &rec.time_s[span.clone()];
            let axis = r.axes.first().map(|a| a.index()).unwrap_or(0);
            let plot = LinePlot::new(
                format!(
                    "a{}: measured, corrected ({}) and reference",
                    ["x", "y", "z"][axis],
                    r.chosen
                ),
                "time (s)",
                "acceleration (g)",
            )
            .series(g_series("measured", t, &rec.accel_mps2[axis][span.clone()], 0))
            .series(g_series("corrected", t, &output.corrected[axis][span.clone()], 2))
            .series(g_series(
                "reference",
                t,
                &reference.accel_mps2[axis][span.clone()],
                1,
            ));
            html.push_str(&figure(&plot, "First 15 s of the test part.")?);
        }
    }

    // 10. How to apply.
    html.push_str("<h2>10. Applying the corrector</h2>\n<p>The chosen corrector is saved as <code>model.json</code> (a versioned corrector file). Apply it to new recordings, streaming, row by row:</p>\n<pre>spincal correct --model model.json new.csv -o new-corrected.csv</pre>\n<p>Every input row comes out with its original columns, the corrected axes added and a <code>valid</code> column. In Rust: <code>spincal::corrector::CorrectorFile::read_path</code>, then <code>Corrector::correct</code>.</p>\n");
    html.push_str("</body></html>\n");
    Ok(html)
}
