//! `spincal calibrate --campaign FILE` and `spincal simulate --campaign DIR`: a unit's campaign
//! in, results.json, report.html and (when a corrector holds on every held-out condition)
//! model.json out.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use spincal::campaign::{Campaign, CampaignOutput, CampaignSettings};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};
use spincal::simulate::fleet::WriteError;

use crate::ui::{self, Ui, UsageError};

/// Calibrates the unit a campaign file describes; writes into `out` and prints the summary.
pub fn calibrate(file: &Path, out: &Path, json: bool, ui: Ui) -> anyhow::Result<()> {
    let output = calibrate_to(file, out, ui)?;
    if json {
        return ui::print_json(&output.result);
    }
    ui::print(&summary(&output, out))
}

/// Calibrates the unit a campaign file describes; writes results.json, report.html and (when a
/// corrector held on every held-out condition) model.json into `out`.
pub fn calibrate_to(file: &Path, out: &Path, ui: Ui) -> anyhow::Result<CampaignOutput> {
    let campaign = Campaign::read_path(file).map_err(|e| UsageError(e.to_string()))?;
    let outputs = [
        "model.json",
        "results.json",
        "report.html",
        "imucal.json",
        "imu_tk_acc.calib",
        "imu_tk_gyro.calib",
    ]
    .map(|name| out.join(name));
    let mut inputs: Vec<&Path> = vec![file];
    for entry in &campaign.recordings {
        inputs.push(&entry.file);
        if let Some(t) = &entry.truth {
            inputs.push(t);
        }
    }
    super::check_outputs(&inputs, &outputs.iter().map(PathBuf::as_path).collect::<Vec<_>>())?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let bar = ui.progress(1, "calibrating the campaign");
    let output = spincal::fleet::calibrate_campaign_file(&campaign, &CampaignSettings::default(), &|p| {
        crate::ui::show(&bar, p)
    })?;
    bar.finish_and_clear();
    let model_path = out.join("model.json");
    if let Some(model) = &output.saved {
        model.write_path(&model_path)?;
    }
    super::write_text(
        &out.join("results.json"),
        &(serde_json::to_string_pretty(&output.result)? + "\n"),
    )?;
    super::write_text(&out.join("report.html"), &report_html(&output))?;
    // The same calibration in the files imucal and imu_tk read (linear part; see spincal::export).
    let sensor = &output.result.joint.sensor;
    let gyro = output.result.gyro.as_ref().map(|g| &g.model);
    super::write_text(
        &out.join("imucal.json"),
        &(serde_json::to_string_pretty(&spincal::export::imucal_json(sensor, gyro))? + "\n"),
    )?;
    if let Some((acc, gyr)) = spincal::export::imu_tk_calibs(sensor, gyro) {
        super::write_text(&out.join("imu_tk_acc.calib"), &acc.to_text())?;
        if let Some(gyr) = gyr {
            super::write_text(&out.join("imu_tk_gyro.calib"), &gyr.to_text())?;
        }
    }
    Ok(output)
}

fn fmt3(v: &[f64; 3]) -> String {
    format!("{:.4} {:.4} {:.4}", v[0], v[1], v[2])
}

/// The terminal summary: the verdict first, then the held-out table.
pub fn summary(output: &CampaignOutput, out: &Path) -> String {
    let r = &output.result;
    let mut text = format!("unit {}: {}\n\n", r.unit, r.verdict);
    text.push_str("held-out condition            corrector        RMS error x y z (m/s²)   uncorrected              against\n");
    for h in &r.held_out {
        let rms = h
            .rms_mps2
            .map_or_else(|| h.note.clone().unwrap_or_default(), |v| fmt3(&v));
        let _ = writeln!(
            text,
            "{:<29} {:<16} {:<24} {:<24} {}",
            h.condition,
            h.candidate,
            rms,
            fmt3(&h.uncorrected_rms_mps2),
            h.against
        );
    }
    if !r.undetermined.is_empty() {
        text.push_str("\nnot determined by this campaign (one standard error moves a 1 g reading by more than 0.02 m/s²):\n");
        for (name, advice) in &r.undetermined {
            let _ = writeln!(text, "  {name}: {advice}");
        }
    }
    if let Some(g) = &r.gyro {
        text.push_str("\ngyroscope (the record player as a rate table):\n");
        let b = g.model.bias_radps.map(f64::to_degrees);
        let k = &g.model.sensitivity;
        let _ = writeln!(
            text,
            "  bias {:.4} {:.4} {:.4} °/s; scale error {:+.3} {:+.3} {:+.3} %",
            b[0],
            b[1],
            b[2],
            100.0 * (k[0][0] - 1.0),
            100.0 * (k[1][1] - 1.0),
            100.0 * (k[2][2] - 1.0)
        );
        text.push_str("  run                                      rate from accel (rad/s)  raw gyro       calibrated gyro
");
        for c in &g.rate_checks {
            let rel = |v: f64| 100.0 * (v.abs() / c.accel_rate_radps - 1.0);
            let _ = writeln!(
                text,
                "  {:<40} {:<24.6} {:.6} ({:+.3} %)  {:.6} ({:+.4} %)",
                c.run,
                c.accel_rate_radps,
                c.raw_gyro_rate_radps,
                rel(c.raw_gyro_rate_radps),
                c.calibrated_gyro_rate_radps,
                rel(c.calibrated_gyro_rate_radps)
            );
        }
        for (name, advice) in &g.undetermined {
            let _ = writeln!(text, "  not determined: {name}: {advice}");
        }
    }
    if let Some(e) = &r.gyro_error {
        let _ = writeln!(text, "\ngyroscope not calibrated: {e}");
    }
    let dir = out.display();
    let _ = writeln!(
        text,
        "\nwrote {}{dir}/results.json, {dir}/report.html, {dir}/imucal.json, {dir}/imu_tk_*.calib",
        if output.saved.is_some() {
            format!("{dir}/model.json, ")
        } else {
            String::new()
        }
    );
    text
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A self-contained HTML report: the verdict, held-out errors per corrector, the sensor model.
pub fn report_html(output: &CampaignOutput) -> String {
    let r = &output.result;
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>spincal campaign: {unit}</title>\
         <style>body{{font-family:sans-serif;max-width:70em;margin:2em auto}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}th{{background:#eee}}.bad{{color:#b00}}</style></head><body>\
         <h1>Campaign calibration: {unit}</h1><h2>Verdict</h2><p>{verdict}</p>",
        unit = escape(&r.unit),
        verdict = escape(&r.verdict)
    );
    h.push_str("<h2>Correctors on held-out conditions</h2><table><tr><th>corrector</th><th>what it is</th><th>mean RMS error, m/s²</th><th>worst ratio to uncorrected</th><th>eligible</th><th>why not</th></tr>");
    for c in &r.candidates {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            c.candidate,
            escape(&c.description),
            c.mean_rms_mps2.map_or("–".into(), |v| format!("{v:.4}")),
            c.worst_ratio_to_uncorrected
                .map_or("–".into(), |v| format!("{v:.2}")),
            if c.eligible { "yes" } else { "no" },
            escape(c.why_not.as_deref().unwrap_or(""))
        );
    }
    h.push_str("</table><p>Each corrector is trained on every condition but one and scored on the one left out. The error is against the true specific force when the recording carries it (simulations), otherwise against the held-out recording refitted with a perfect sensor.</p>");
    h.push_str("<table><tr><th>held out</th><th>corrector</th><th>RMS x</th><th>RMS y</th><th>RMS z</th><th>uncorrected x</th><th>y</th><th>z</th><th>floor x</th><th>y</th><th>z</th><th>against</th></tr>");
    for s in &r.held_out {
        let cells = |v: Option<[f64; 3]>| {
            v.map_or("<td>–</td><td>–</td><td>–</td>".to_string(), |v| {
                v.iter().map(|x| format!("<td>{x:.4}</td>")).collect()
            })
        };
        let worse = s
            .rms_mps2
            .is_some_and(|v| v.iter().sum::<f64>() > s.uncorrected_rms_mps2.iter().sum::<f64>());
        let _ = write!(
            h,
            "<tr{}><td>{}</td><td>{}</td>{}{}{}<td>{}</td></tr>",
            if worse { " class=\"bad\"" } else { "" },
            escape(&s.condition),
            s.candidate,
            cells(s.rms_mps2),
            cells(Some(s.uncorrected_rms_mps2)),
            cells(s.floor_mps2),
            s.against
        );
    }
    h.push_str("</table><h2>Sensor model (joint fit of every recording)</h2>");
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
    if !r.undetermined.is_empty() {
        h.push_str("<h2>What this campaign does not determine</h2><ul>");
        for (name, advice) in &r.undetermined {
            let _ = write!(h, "<li>{}: record {}</li>", escape(name), escape(advice));
        }
        h.push_str("</ul>");
    }
    if let Some(g) = &r.gyro {
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
        if !g.undetermined.is_empty() {
            h.push_str("<ul>");
            for (name, advice) in &g.undetermined {
                let _ = write!(h, "<li>{}: {}</li>", escape(name), escape(advice));
            }
            h.push_str("</ul>");
        }
    }
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
    h.push_str("<h2>Recordings</h2><ul>");
    for run in &r.joint.runs {
        let _ = write!(
            h,
            "<li>{} ({}, residual RMS {} m/s²)</li>",
            escape(&run.name),
            run.direction.describe(),
            fmt3(&run.residual_rms_mps2)
        );
    }
    for pose in &r.joint.poses {
        let _ = write!(h, "<li>{} (still pose)</li>", escape(&pose.name));
    }
    h.push_str("</ul></body></html>\n");
    h
}

/// Writes a simulated campaign into `dir` and says so.
pub fn simulate(dir: &Path, seed: u64, setup_file: Option<&Path>, json: bool) -> anyhow::Result<()> {
    let setup = match setup_file {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            serde_json::from_str::<CampaignSetup>(&text)
                .with_context(|| format!("{}: not a campaign setup", path.display()))?
        }
        None => CampaignSetup::default(),
    };
    let sim = write_simulated_campaign(dir, &setup, seed, false)?;
    if json {
        return ui::print_json(&serde_json::json!({
            "campaign": dir.join("campaign.toml"),
            "recordings": sim.recordings.iter().map(|r| &r.name).collect::<Vec<_>>(),
        }));
    }
    ui::print(&format!(
        "wrote {} with {} recordings ({} still poses, {} turntable runs), their true specific force and truth.json\n",
        dir.join("campaign.toml").display(),
        sim.recordings.len(),
        setup.poses,
        setup.runs.len()
    ))
}

/// Writes campaign.toml, one CSV per recording, its truth CSV and truth.json into `dir`. Refuses
/// to replace a file already there unless `replace_own` (the demo's own folder).
pub fn write_simulated_campaign(
    dir: &Path,
    setup: &CampaignSetup,
    seed: u64,
    replace_own: bool,
) -> anyhow::Result<spincal::simulate::campaign::SimulatedCampaign> {
    let sim = simulate_campaign(setup, seed).map_err(|e| UsageError(e.to_string()))?;
    match sim.write_folder(dir, replace_own) {
        Err(e @ WriteError::Exists { .. }) => Err(UsageError(e.to_string()).into()),
        Err(e) => Err(e.into()),
        Ok(()) => Ok(sim),
    }
}
