//! The paper protocol's sections of the calibration report (`report::campaign` draws the page and
//! its verdict): plots inline as SVG.
//!
//! Every number shown comes from [`PaperProtocol`] (what `results.json` holds under `paper`) and
//! is written as `<span data-json="/paper/json/pointer" data-digits="d">`, so a test can check
//! each against the JSON file: one source, no second computation. A number shown in other units than the SI value
//! it comes from (degrees, g) also carries `data-scale="factor"`: the page shows value × factor.
//! Plots draw the signals behind those numbers.

use super::escape;
use crate::campaign::paper::{ComparisonRow, PaperProtocol, PaperSignals, PartScore};
use crate::campaign::params::NetworkChoice;
use crate::correctors::division::Part;
use crate::input::recording::{Recording, STANDARD_GRAVITY};
use crate::report::plot::{Figure, HeatMap, LinePlot, PlotError, Rgb, Series};
use crate::turntable::fit::FittedParam;
use crate::turntable::fit::TurntableFit;
use crate::turntable::model::Direction;

const AXES: [&str; 3] = ["x", "y", "z"];

fn shown(value: f64, digits: usize) -> String {
    if value.is_finite() {
        format!("{value:.digits$}")
    } else {
        "—".to_string()
    }
}

/// Where the paper's figures sit in results.json (the campaign envelope's `paper`).
const PAPER_ROOT: &str = "/paper";

/// A number tied to its place in results.json (`pointer` from the paper's figures' root).
fn num(pointer: &str, value: f64, digits: usize) -> String {
    format!(
        r#"<span data-json="{PAPER_ROOT}{pointer}" data-digits="{digits}">{}</span>"#,
        shown(value, digits)
    )
}

/// A number tied to its place in results.json, shown as `value × scale` (a change of unit).
fn num_scaled(pointer: &str, value: f64, scale: f64, digits: usize) -> String {
    format!(
        r#"<span data-json="{PAPER_ROOT}{pointer}" data-digits="{digits}" data-scale="{scale}">{}</span>"#,
        shown(value * scale, digits)
    )
}

/// [`num`] or, with a scale, [`num_scaled`].
fn num_in(pointer: &str, value: f64, scale: Option<f64>, digits: usize) -> String {
    match scale {
        Some(scale) => num_scaled(pointer, value, scale, digits),
        None => num(pointer, value, digits),
    }
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

pub(crate) fn figure(fig: &impl Figure, caption: &str) -> Result<String, PlotError> {
    panels(&[fig], caption)
}

/// Several plots stacked in one figure under one caption.
fn panels<F: Figure>(figs: &[&F], caption: &str) -> Result<String, PlotError> {
    let mut svgs = String::new();
    for fig in figs {
        svgs.push_str(&fig.to_svg()?);
    }
    Ok(format!(
        "<figure>{svgs}<figcaption>{}</figcaption></figure>\n",
        escape(caption)
    ))
}

fn score_cells(pointer: &str, score: &PartScore) -> String {
    format!(
        "<td>{}</td>",
        num(&format!("{pointer}/fit_percent_mean"), score.fit_percent_mean, 2)
    )
}

fn direction_words(direction: Direction) -> &'static str {
    match direction {
        Direction::Cw => "clockwise",
        Direction::Ccw => "counter-clockwise",
    }
}

/// The paper protocol's sections, for the campaign report of a calibration that ran it: one
/// heading at the campaign's sections' level, its numbered sections under it.
/// `saved`: the saved corrector's name.
pub(crate) fn paper_sections(
    paper: &PaperProtocol,
    signals: &PaperSignals,
    saved: Option<&str>,
) -> Result<String, PlotError> {
    let recordings = &signals.recordings;
    let html = [
        summary_section(paper),
        recordings_section(paper, recordings)?,
        spectrum_section(paper)?,
        model_fit_section(paper, signals)?,
        parameters_section(&paper.turntable),
        sensitivity_section(paper),
        division_section(paper, recordings)?,
        sweep_section(paper)?,
        comparison_section(paper),
        corrected_section(paper, signals, saved)?,
        how_to_apply_section(saved.is_some()),
    ]
    .concat();
    Ok(html)
}

/// The paper protocol's heading, what it chose and where its time went.
fn summary_section(r: &PaperProtocol) -> String {
    let mut html = format!(
        "<h2>The paper's protocol: 60/20/20 on the first recording</h2>\n<p>Reported for its figures (the paper's Tables 1–3): what is saved is decided on held-out conditions above. Seed {} · corrected axes {}. Best on validation among correctors a file can hold and no worse than uncorrected on another recording: <b>{}</b>; best on validation among all models without warnings (section 8): <b>{}</b>.</p>\n",
        num("/seed", r.seed as f64, 0),
        escape(&r.axes.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")),
        escape(&r.best_on_validation),
        escape(&r.best_overall)
    );
    if !r.stage_seconds.is_empty() {
        html.push_str("<table><tr><th>stage</th><th>time (s)</th></tr>\n");
        for (k, s) in r.stage_seconds.iter().enumerate() {
            html.push_str(&format!(
                "<tr><td>{}</td><td>{}</td></tr>\n",
                escape(&s.stage),
                num(&format!("/stage_seconds/{k}/seconds"), s.seconds, 2)
            ));
        }
        html.push_str("</table>\n");
    }
    html
}

/// 1. The recordings: a summary table and each axis of each recording in its own panel.
fn recordings_section(r: &PaperProtocol, recordings: &[Recording]) -> Result<String, PlotError> {
    let mut html = String::from("<h3>1. The recordings</h3>\n<table><tr><th>recording</th><th>samples</th><th>duration (s)</th><th>sample rate (Hz)</th><th>gaps</th><th>saturated samples</th></tr>\n");
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
    for w in r.recordings.iter().flat_map(|s| &s.warnings) {
        html.push_str(&format!("<p>⚠ {}</p>\n", escape(w)));
    }
    for (k, rec) in recordings.iter().enumerate() {
        let plots: Vec<LinePlot> = (0..3)
            .map(|a| {
                let name = format!("a{}", AXES[a]);
                LinePlot::new(
                    format!("Recording {}: {}, {name}", k + 1, rec.source.name),
                    "time (s)",
                    format!("{name} (g)"),
                )
                .series(g_series(&name, &rec.time_s, &rec.accel_mps2[a], a))
                .size(900, 240)
            })
            .collect();
        html.push_str(&panels(
            &plots.iter().collect::<Vec<_>>(),
            "Measured acceleration in g, all samples (thinned for drawing, extremes kept): one panel \
             per axis, each scaled to its own range, so the turntable's small oscillation shows on top \
             of the centripetal level (x, y) and of gravity (z).",
        )?);
    }
    Ok(html)
}

/// 2. The rotation rate found in the spectrum of each recording.
fn spectrum_section(r: &PaperProtocol) -> Result<String, PlotError> {
    let mut html = String::from("<h3>2. Rotation rate from the spectrum</h3>\n");
    for (k, rf) in r.turntable.recordings.iter().enumerate() {
        let p = format!("/recordings/{k}");
        html.push_str(&format!(
            "<p>Recording {}: the highest line of the x+y spectrum is at {} rpm = {} rad/s (the paper found 33.5 rpm this way for a nominal 33.3).</p>\n",
            k + 1,
            num(&format!("{p}/rpm_from_spectrum"), r.recordings[k].rpm_from_spectrum, 3),
            num(&format!("{p}/omega_from_spectrum_radps"), r.recordings[k].omega_from_spectrum_radps, 4)
        ));
        let rate = &rf.rate;
        if rate.spectrum_hz.is_empty() {
            continue;
        }
        let f_max = (rate.frequency_hz * 6.0).min(*rate.spectrum_hz.last().unwrap_or(&1.0));
        let keep = rate.spectrum_hz.partition_point(|&f| f <= f_max);
        let power = rate.spectrum_power[1..keep]
            .iter()
            .map(|p| p.max(1e-30))
            .collect();
        let plot = LinePlot::new(
            format!("Spectrum of recording {}", k + 1),
            "frequency (Hz)",
            "power",
        )
        .series(Series::new("x + y", rate.spectrum_hz[1..keep].to_vec(), power).color(Rgb::palette(0)))
        .log_y()
        .vline(rate.frequency_hz, format!("{:.3} rpm", rate.rpm));
        html.push_str(&figure(
            &plot,
            "Summed power spectrum of x and y with the rotation line marked.",
        )?);
    }
    Ok(html)
}

/// 3. The fitted turntable model against the measurement: fit % per axis and plots.
fn model_fit_section(paper: &PaperProtocol, signals: &PaperSignals) -> Result<String, PlotError> {
    let mut html = String::from("<h3>3. Turntable model against measurement</h3>\n");
    html.push_str("<table><tr><th>recording</th><th>fit x (%)</th><th>fit y (%)</th><th>fit z (%)</th><th>sense of rotation</th></tr>\n");
    for (k, rf) in paper.turntable.recordings.iter().enumerate() {
        let p = format!("/turntable/recordings/{k}/fit_percent");
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape(&rf.name),
            num(&format!("{p}/0"), rf.fit_percent[0], 2),
            num(&format!("{p}/1"), rf.fit_percent[1], 2),
            num(&format!("{p}/2"), rf.fit_percent[2], 2),
            direction_words(rf.session.direction)
        ));
    }
    html.push_str("</table><p>z carries only g cos α plus offset and noise, so its fit % is near zero by construction.</p>\n");
    let (Some(rec), Some(model)) = (signals.recordings.first(), signals.models.first()) else {
        return Ok(html);
    };
    let span = window(&rec.time_s, rec.time_s[0], rec.time_s[0] + 20.0);
    let t = &rec.time_s[span.clone()];
    for a in 0..2 {
        let plot = LinePlot::new(
            format!("a{} of recording 1: model and measurement (first 20 s)", AXES[a]),
            "time (s)",
            "acceleration (g)",
        )
        .series(g_series("measured", t, &rec.accel_mps2[a][span.clone()], 0))
        .series(g_series("model", t, &model.accel_mps2[a][span.clone()], 1));
        html.push_str(&figure(&plot, "The fitted model with the sensor offsets (paper's Fig. 9); without them it is the reference the correctors learn.")?);
    }
    let mut plot = LinePlot::new(
        "Residuals, measured − model, recording 1",
        "time (s)",
        "residual (g)",
    );
    for a in 0..3 {
        let residual: Vec<f64> = rec.accel_mps2[a]
            .iter()
            .zip(&model.accel_mps2[a])
            .map(|(m, r)| m - r)
            .collect();
        plot = plot.series(g_series(AXES[a], &rec.time_s, &residual, a));
    }
    html.push_str(&figure(
        &plot,
        "What the turntable model does not explain: noise, sensor errors, wow.",
    )?);
    Ok(html)
}

/// The recording a per-recording parameter belongs to (`tilt[2]` → 1; one recording: no suffix).
fn recording_of(name: &str) -> usize {
    name.rsplit_once('[')
        .and_then(|(_, k)| k.strip_suffix(']')?.parse::<usize>().ok())
        .map_or(0, |k| k.saturating_sub(1))
}

/// How a fitted parameter is shown, as `spincal fit` prints it: angles in degrees, drift as its
/// change in g over the recording, everything else in its SI unit. (scale from SI, unit, digits)
fn display_unit(p: &FittedParam, fit: &TurntableFit) -> (Option<f64>, String, usize) {
    match p.unit.as_str() {
        "rad" => (Some(1f64.to_degrees()), "deg".into(), 7),
        "m/s³" => {
            let k = recording_of(&p.name);
            let duration = fit
                .recordings
                .get(k)
                .map_or(f64::NAN, |r| r.inspection.duration_s);
            (
                Some(duration / STANDARD_GRAVITY),
                "g over the recording".into(),
                7,
            )
        }
        _ => (None, p.unit.clone(), 9),
    }
}

/// What a parameter means, in words.
fn parameter_meaning(name: &str) -> String {
    let base = name.split('[').next().unwrap_or(name);
    let what = match base {
        "beta" => "angle β of the sensor's x axis from the radial direction".to_string(),
        "radius" => "distance r of the sensor from the axis".to_string(),
        "omega" => "rotation rate ω".to_string(),
        "tilt" => "platter tilt α from horizontal".to_string(),
        "phase" => "platter angle φ at the first sample".to_string(),
        _ => match base.split_once('_') {
            Some(("offset", axis)) => format!("sensor offset on {axis}"),
            Some(("drift", axis)) => format!("drift on {axis}"),
            _ => String::new(),
        },
    };
    if name.contains('[') {
        format!("{what}, recording {}", recording_of(name) + 1)
    } else {
        what
    }
}

fn parameter_row(i: usize, p: &FittedParam, fit: &TurntableFit) -> String {
    let base = format!("/turntable/params/{i}");
    let (scale, unit, digits) = display_unit(p, fit);
    let se = match p.std_error {
        Some(se) => num_in(&format!("{base}/std_error"), se, scale, digits),
        None => "not determined".into(),
    };
    format!(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
        escape(&p.name),
        escape(&parameter_meaning(&p.name)),
        num_in(&format!("{base}/value"), p.value, scale, digits),
        se,
        escape(&unit),
        if p.at_bound { "yes" } else { "no" }
    )
}

/// 4. The fitted turntable parameters, in the units `spincal fit` prints, and the drift found.
fn parameters_section(fit: &TurntableFit) -> String {
    let mut html = String::from("<h3>4. Turntable parameters</h3>\n<table><tr><th>parameter</th><th>meaning</th><th>value</th><th>standard error</th><th>unit</th><th>at bound</th></tr>\n");
    for (i, p) in fit.params.iter().enumerate() {
        html.push_str(&parameter_row(i, p, fit));
    }
    html.push_str("</table>\n<p>Angles are shown in degrees and drift as the change in g over the whole recording, as <code>spincal fit</code> prints them; results.json holds the SI values (rad, m/s³).</p>\n");
    if let Some(remedy) = &fit.remedy {
        html.push_str(&format!("<p><b>Not determined:</b> {}</p>\n", escape(remedy)));
    } else {
        html.push_str("<p>Every parameter is determined by the data.</p>\n");
    }
    let to_g = 1.0 / STANDARD_GRAVITY;
    for (i, d) in fit.drift.iter().enumerate().filter(|(_, d)| d.significant) {
        let p = format!("/turntable/drift/{i}");
        html.push_str(&format!(
            "<p>Drift detected: recording {} axis {} moves {} g (± {} g) over the recording.</p>\n",
            d.recording + 1,
            d.axis,
            num_scaled(&format!("{p}/change_mps2"), d.change_mps2, to_g, 4),
            num_scaled(&format!("{p}/std_error_mps2"), d.std_error_mps2, to_g, 4)
        ));
    }
    html
}

/// 5. How the signal moves with each parameter (the paper's Table 1).
fn sensitivity_section(r: &PaperProtocol) -> String {
    let mut html = String::from("<h3>5. Sensitivity at the fitted parameters (the paper's Table 1)</h3>\n<table><tr><th>parameter</th><th>change (%)</th><th>value</th><th>unit</th><th>mean a_x (g)</th><th>amplitude a_x (g)</th><th>amplitude a_y (g)</th></tr>\n");
    for (i, s) in r.sensitivity.iter().enumerate() {
        let b = format!("/sensitivity/{i}");
        let name = match s.parameter.as_str() {
            "r" => "radius r",
            "alpha" => "tilt α",
            "omega" => "rotation rate ω",
            other => other,
        };
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape(name),
            num(&format!("{b}/change_pct"), s.change_pct, 0),
            num(&format!("{b}/value"), s.value, 4),
            escape(&s.unit),
            num(&format!("{b}/mean_ax_g"), s.mean_ax_g, 4),
            num(&format!("{b}/amplitude_ax_g"), s.amplitude_ax_g, 4),
            num(&format!("{b}/amplitude_ay_g"), s.amplitude_ay_g, 4)
        ));
    }
    html.push_str("</table>\n");
    html
}

/// 6. Which samples train, validate and test.
fn division_section(r: &PaperProtocol, recordings: &[Recording]) -> Result<String, PlotError> {
    let mut html = String::from("<h3>6. Training, validation and test division</h3>\n");
    if let Some(rec) = recordings.first() {
        let mut plot = LinePlot::new("Division of recording 1 (paper's Fig. 10)", "time (s)", "ax (g)")
            .series(g_series("ax", &rec.time_s, &rec.accel_mps2[0], 0));
        for (part, label, color) in [
            (Part::Train, "training", Rgb(0, 158, 115)),
            (Part::Validation, "validation", Rgb(230, 159, 0)),
            (Part::Test, "test", Rgb(204, 121, 167)),
        ] {
            for range in r.division.ranges(part).iter().filter(|s| s.end > s.start) {
                plot = plot.span(rec.time_s[range.start], rec.time_s[range.end - 1], label, color);
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
    Ok(html)
}

/// 7. The network architectures tried and how the best was found.
fn sweep_section(r: &PaperProtocol) -> Result<String, PlotError> {
    let mut html = String::from("<h3>7. Network architectures</h3>\n");
    if r.sweep.is_empty() {
        html.push_str(&format!(
            "<p>No sweep was run; the architecture [{}] was trained as given.</p>\n",
            escape(&r.network_architecture)
        ));
        return Ok(html);
    }
    html.push_str(&figure(
        &sweep_heatmap(r),
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
    Ok(html)
}

/// Validation fit % over units in the first (columns) and second (rows, 0: none) hidden layer.
fn sweep_heatmap(r: &PaperProtocol) -> HeatMap {
    let layer = |l: usize| {
        let mut units: Vec<usize> = r
            .sweep
            .iter()
            .map(|s| s.hidden.get(l).copied().unwrap_or(0))
            .collect();
        units.sort_unstable();
        units.dedup();
        units
    };
    let (first, second) = (layer(0), layer(1));
    let mut values = vec![f64::NAN; first.len() * second.len()];
    for s in &r.sweep {
        let c = first.binary_search(&s.hidden[0]).unwrap_or(0);
        let row = second
            .binary_search(&s.hidden.get(1).copied().unwrap_or(0))
            .unwrap_or(0);
        values[row * first.len() + c] = s.validation_fit_percent;
    }
    HeatMap::new(
        "Validation fit % by architecture (paper's Fig. 12)",
        "units in hidden layer 1",
        "units in hidden layer 2 (0: one layer)",
        first.iter().map(|v| v.to_string()).collect(),
        second.iter().map(|v| v.to_string()).collect(),
        values,
    )
    .value_label("fit %")
}

fn comparison_row(i: usize, row: &ComparisonRow, chosen: &str) -> String {
    let b = format!("/comparison/{i}");
    let one_step = |name: &str, s: &Option<PartScore>| match s {
        Some(s) => score_cells(&format!("{b}/{name}"), s),
        None => "<td>same</td>".into(),
    };
    let warnings = match (&row.failed, row.warnings.is_empty()) {
        (None, true) => "none".to_string(),
        (Some(_), _) => format!("<a href=\"#warnings-{i}\">not fitted, see below</a>"),
        (None, false) => format!("<a href=\"#warnings-{i}\">see below</a>"),
    };
    format!(
        "<tr{}><td>{}</td><td>{}</td>{}{}{}{}{}<td>{}</td><td>{}</td><td>{warnings}</td></tr>\n",
        if row.model == chosen {
            " class=\"chosen\""
        } else {
            ""
        },
        escape(&row.model),
        escape(&row.structure),
        score_cells(&format!("{b}/train"), &row.train),
        score_cells(&format!("{b}/validation"), &row.validation),
        score_cells(&format!("{b}/test"), &row.test),
        one_step("train_one_step", &row.train_one_step),
        one_step("test_one_step", &row.test_one_step),
        num(&format!("{b}/test/rmse_mps2_mean"), row.test.rmse_mps2_mean, 5),
        num(&format!("{b}/seconds"), row.seconds, 2)
    )
}

/// The warnings of the comparison table, one list item per model that has any.
fn comparison_warnings(rows: &[ComparisonRow]) -> String {
    let mut items = String::new();
    for (i, row) in rows.iter().enumerate() {
        let texts: Vec<String> = row
            .failed
            .iter()
            .map(|why| format!("not fitted: {}", escape(why)))
            .chain(row.warnings.iter().map(|w| escape(w)))
            .collect();
        if !texts.is_empty() {
            items.push_str(&format!(
                "<li id=\"warnings-{i}\"><b>{}</b>: {}</li>\n",
                escape(&row.model),
                texts.join("; ")
            ));
        }
    }
    if items.is_empty() {
        return items;
    }
    format!("<p><b>Warnings</b> (such a model is not \"best overall\"):</p>\n<ul>\n{items}</ul>\n")
}

/// 8. The correctors compared on the same division (the paper's Table 2) and across conditions.
fn comparison_section(r: &PaperProtocol) -> String {
    let mut html = String::from("<h3>8. Comparison of correctors (the paper's Table 2)</h3>\n");
    html.push_str("<p>Fit % = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖), mean over the corrected axes. Dynamic models: <i>simulation</i> \
        (infinite horizon, started from the first measured outputs) and <i>one-step prediction</i> (uses past reference \
        values, so it is not available when correcting new data). Static maps have one kind.</p>\n");
    html.push_str("<table><tr><th>model</th><th>structure</th><th>train fit, sim. (%)</th><th>validation fit, sim. (%)</th><th>test fit, sim. (%)</th><th>train fit, one-step (%)</th><th>test fit, one-step (%)</th><th>test RMSE (m/s²)</th><th>time (s)</th><th>warnings</th></tr>\n");
    for (i, row) in r.comparison.iter().enumerate() {
        html.push_str(&comparison_row(i, row, &r.best_on_validation));
    }
    html.push_str("</table>\n");
    html.push_str(&comparison_warnings(&r.comparison));
    html.push_str("<p>The paper (MATLAB, its own recording): ARX 51.81 / 48.29, BJ 66.66 / 60.18, NARX 61.09 / 54.70, HW 67.17 / 59.66 (training / test), ANN about 67.</p>\n");
    html.push_str(&cross_condition_table(r));
    html
}

/// Correctors trained on recording 1 applied to the other recordings.
fn cross_condition_table(r: &PaperProtocol) -> String {
    if r.cross_condition.is_empty() {
        return String::new();
    }
    let mut html = String::from("<h4>Cross-condition: trained on recording 1, tested on another speed or radius</h4>\n<p>A corrector that only learned to emit one sine fails here; a single-recording split cannot show that.</p>\n<p>“× uncorrected” is the corrector's RMS error over the uncorrected one's on the same samples, ± its standard error (batch means over blocks); “worse” only where the difference is significant (one-sided, false-alarm probability 0.001).</p>\n<table><tr><th>model</th><th>tested on</th><th>fit (%)</th><th>× uncorrected</th><th>samples outside the network's training range (%)</th></tr>\n");
    for (i, c) in r.cross_condition.iter().enumerate() {
        let p = format!("/cross_condition/{i}");
        let outside = match c.outside_training_range_percent {
            Some(v) => num(&format!("{p}/outside_training_range_percent"), v, 1),
            None => "—".to_string(),
        };
        let against = match &c.against_uncorrected {
            Some(a) => format!(
                "{} ± {}{}",
                num(&format!("{p}/against_uncorrected/ratio"), a.ratio, 2),
                num(&format!("{p}/against_uncorrected/ratio_se"), a.ratio_se, 2),
                if a.worse { " <b>worse</b>" } else { "" }
            ),
            None => "—".to_string(),
        };
        html.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{against}</td><td>{outside}</td></tr>\n",
            escape(&c.model),
            escape(&c.tested_on),
            num(
                &format!("{p}/score/fit_percent_mean"),
                c.score.fit_percent_mean,
                2
            )
        ));
    }
    html.push_str("</table>\n");
    html
}

/// 9. The saved corrector's output against the reference on the test part.
fn corrected_section(
    r: &PaperProtocol,
    signals: &PaperSignals,
    saved: Option<&str>,
) -> Result<String, PlotError> {
    let mut html = String::from("<h3>9. Corrected signal against the reference (test part)</h3>\n");
    let (Some(rec), Some(reference)) = (signals.recordings.first(), signals.references.first()) else {
        return Ok(html);
    };
    let test = r.division.ranges(Part::Test);
    let (Some(first), Some(last)) = (test.first(), test.last()) else {
        return Ok(html);
    };
    let t0 = rec.time_s[first.start];
    let t1 = rec.time_s[last.end - 1].min(t0 + 15.0);
    let span = window(&rec.time_s, t0, t1);
    let t = &rec.time_s[span.clone()];
    let axis = r.axes.first().map(|a| a.index()).unwrap_or(0);
    let plot = LinePlot::new(
        format!(
            "a{}: measured, corrected ({}) and reference",
            AXES[axis],
            saved.unwrap_or("nothing saved")
        ),
        "time (s)",
        "acceleration (g)",
    )
    .series(g_series("measured", t, &rec.accel_mps2[axis][span.clone()], 0))
    .series(g_series(
        "corrected",
        t,
        &signals.corrected[axis][span.clone()],
        2,
    ))
    .series(g_series(
        "reference",
        t,
        &reference.accel_mps2[axis][span.clone()],
        1,
    ));
    html.push_str(&figure(&plot, "First 15 s of the test part.")?);
    Ok(html)
}

/// 10. How to apply the saved corrector to new data.
fn how_to_apply_section(saved: bool) -> String {
    if !saved {
        return "<h3>10. Applying the corrector</h3>\n<p>Nothing was saved (see the verdict): no corrector \
                held on the recordings it did not train on.</p>\n"
            .to_string();
    }
    concat!(
        "<h3>10. Applying the corrector</h3>\n<p>The saved corrector is in <code>model.json</code> ",
        "(a versioned corrector file). Apply it to new recordings, streaming, row by row:</p>\n",
        "<pre>spincal correct --model model.json new.csv -o new-corrected.csv</pre>\n",
        "<p>Every input row comes out with its original columns, the corrected axes added and a ",
        "<code>valid</code> column. In Rust: <code>spincal::correctors::model_file::CorrectorFile::read_path</code>, then ",
        "<code>spincal::correctors::corrector::Corrector::correct</code>.</p>\n"
    )
    .to_string()
}
