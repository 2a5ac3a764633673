//! `spincal calibrate --campaign FILE` and `spincal simulate --campaign DIR`: a unit's campaign
//! in, results.json, report.html and (when a corrector holds on every held-out condition)
//! model.json out.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;
use spincal::campaign::file::Campaign;
use spincal::campaign::params::Params;
use spincal::campaign::run::calibrate_campaign_file;
use spincal::campaign::select::CampaignOutput;
use spincal::report::campaign::{campaign_files, CAMPAIGN_FILE_NAMES};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};
use spincal::simulate::fleet::WriteError;

use crate::ui::{self, Ui, UsageError};

/// Calibrates the unit a campaign file describes; writes into `out` and prints the summary (the
/// per-condition tables too with `tables`).
pub fn calibrate(file: &Path, out: &Path, json: bool, tables: bool, ui: Ui) -> anyhow::Result<()> {
    let (output, written) = calibrate_to(file, out, ui)?;
    if json {
        return ui::print_json(&output.result);
    }
    ui::print(&summary(&output, out, &written, tables))
}

/// Calibrates the unit a campaign file describes; writes results.json, report.html and (when a
/// corrector held on every held-out condition) model.json into `out`. Returns the result and
/// the names of the files written.
pub fn calibrate_to(file: &Path, out: &Path, ui: Ui) -> anyhow::Result<(CampaignOutput, Vec<&'static str>)> {
    let campaign = Campaign::read_path(file).map_err(|e| UsageError(e.to_string()))?;
    super::check_paths(
        &campaign.inputs(),
        &CAMPAIGN_FILE_NAMES.map(|name| out.join(name)),
    )?;
    super::create_folder("--out", out)?;
    let bar = ui.progress(1, "calibrating the campaign");
    let output = calibrate_campaign_file(&campaign, &Params::default(), &|p| crate::ui::show(&bar, p))?;
    bar.finish_and_clear();
    let written = write_calibration(&output, out)?;
    Ok((output, written))
}

/// Writes every file of a calibration into `out` (`campaign_files`: with the paper's sections
/// where its protocol ran) and sets aside its own earlier outputs that this one does not write.
/// Returns the names written.
pub fn write_calibration(output: &CampaignOutput, out: &Path) -> anyhow::Result<Vec<&'static str>> {
    let files = campaign_files(
        &output.result,
        output.saved.as_ref(),
        output.paper_signals.as_deref(),
    )
    .context("drawing the campaign report")?;
    let written: Vec<&'static str> = files.iter().map(|(name, _)| *name).collect();
    super::set_aside_stale(out, &CAMPAIGN_FILE_NAMES, &written)?;
    for (name, text) in files {
        super::write_text(&out.join(name), &text)?;
    }
    Ok(written)
}

/// The first line: whether a model was saved, where, and where it can be trusted.
pub fn lead_line(output: &CampaignOutput, out: &Path) -> String {
    let r = &output.result;
    let model = out.join("model.json");
    match (&r.saved, &r.error_map) {
        (Some(kind), Some(map)) => format!("Saved {} ({kind}). {}", model.display(), map.sentence()),
        (Some(kind), None) if kind == "uncorrected" => format!(
            "Saved {} (the gyroscope's calibration alone; the accelerometer left as read: no correction of it was shown to help).",
            model.display()
        ),
        (Some(kind), None) => format!(
            "Saved {} ({kind}). Trusted as far as the {} held-out conditions it never trained on show (a {kind} model has no covariance to map its error by).",
            model.display(),
            r.conditions.len()
        ),
        (None, _) => format!("No model saved (no model.json in {}).", out.display()),
    }
}

/// The terminal summary: the line on what was saved and where it can be trusted, the verdict,
/// then only what needs the user (parameters not determined, the gyro's summary and saturation,
/// temperature findings) and the files written. The fit's details and the per-condition
/// tables, which report.html always holds, follow only with `tables`.
pub fn summary(output: &CampaignOutput, out: &Path, written: &[&str], tables: bool) -> String {
    let r = &output.result;
    // The verdict leads with the error map's sentence, which the first line already gives.
    let verdict = r
        .error_map
        .as_ref()
        .and_then(|map| r.verdict.strip_prefix(&map.sentence()))
        .map_or(r.verdict.as_str(), str::trim_start);
    let mut text = format!("{}\nunit {}: {verdict}\n", lead_line(output, out), r.unit);
    for placement in &r.placements {
        let _ = writeln!(text, "{}", placement.sentence());
    }
    if let Some(offset) = &r.chip_offset {
        let _ = writeln!(text, "{}", offset.sentence());
    }
    for split in r.split_runs.iter().filter_map(|s| s.sentence()) {
        let _ = writeln!(text, "{split}");
    }
    if !r.undetermined.is_empty() {
        text.push_str("\nnot determined by this campaign (one standard error moves a 1 g reading by more than 0.02 m/s²):\n");
        for a in &r.undetermined {
            let _ = writeln!(text, "  {}: {}", a.parameter, a.sentence);
        }
    }
    if let Some(g) = &r.gyro {
        let b = g.model.bias_radps.map(f64::to_degrees);
        let k = &g.model.sensitivity;
        let at_nominal = |i: usize| g.params.get(i).is_some_and(|p| !p.free);
        let bias: Vec<String> = (0..3)
            .map(|i| match at_nominal(i) {
                true => "nominal".to_string(),
                false => format!("{:.4}", b[i]),
            })
            .collect();
        let scale: Vec<String> = (0..3)
            .map(|i| match at_nominal(3 + 4 * i) {
                true => "nominal".to_string(),
                false => format!("{:+.3}", 100.0 * (k[i][i] - 1.0)),
            })
            .collect();
        let _ = writeln!(
            text,
            "\ngyroscope (the record player as a rate table): bias {} °/s; scale error {} %{}",
            bias.join(" "),
            scale.join(" "),
            if g.saved_model().is_none() {
                " (no term determined: no gyroscope part saved)"
            } else {
                ""
            }
        );
        if !g.undetermined.is_empty() {
            let _ = writeln!(text, "  not determined ({}):", g.nominal_rule);
        }
        for (name, advice) in &g.undetermined {
            let what = if g.left_at_nominal.contains(name) {
                "left at nominal"
            } else {
                "kept"
            };
            let _ = writeln!(text, "    {name} ({what}): to determine it, {advice}");
        }
        for s in &g.saturation {
            let _ = writeln!(text, "  {}", s.describe());
        }
    }
    if let Some(e) = &r.gyro_error {
        let _ = writeln!(text, "\ngyroscope not calibrated: {e}");
    }
    if !r.temperature_findings.is_empty() {
        let _ = writeln!(
            text,
            "\ntemperature: {} sample(s) kept out of the thermal fit:",
            r.temperature_masked_samples
        );
        for finding in &r.temperature_findings {
            let _ = writeln!(text, "  {finding}");
        }
    }
    if let Some(note) = &r.thermal_note {
        let _ = writeln!(text, "\n{note}");
    }
    if tables {
        text.push_str(&super::tables::campaign_tables_text(output));
    }
    let names: Vec<String> = written
        .iter()
        .map(|name| out.join(name).display().to_string())
        .collect();
    let _ = writeln!(text, "\nwrote {}", names.join(", "));
    if !tables {
        text.push_str("(the held-out tables and the fit's details: --tables, or report.html)\n");
    }
    text
}

/// Writes a simulated campaign into `dir` and says so.
pub fn simulate(dir: &Path, seed: u64, setup_file: Option<&Path>, json: bool) -> anyhow::Result<()> {
    let setup: CampaignSetup = super::values::read_json_or_default(setup_file, "a campaign setup")?;
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
