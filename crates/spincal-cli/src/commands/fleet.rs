//! `spincal fleet UNIT... --out DIR`: many units, each calibrated from its campaign as
//! `calibrate --campaign` does, several at once; per-unit folders, then the fleet table (CSV,
//! JSON) and its HTML summary with outliers flagged. `spincal simulate --fleet N` writes a fleet.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use spincal::fleet::{
    calibrate_fleet, campaign_inputs, expand_sources, failures, fleet_outputs, fleet_table, unit_labels,
    FleetSettings, FleetTable, OutlierSettings, UnitOutcome,
};
use spincal::progress::Progress;
use spincal::simulate::campaign::CampaignSetup;
use spincal::simulate::fleet::{faulty_indices, simulate_fleet, FleetSetup, WriteError};

use crate::ui::{self, Ui, UnitsFailed, UsageError};

pub const AFTER_HELP: &str =
    "Each UNIT is a campaign file, or a folder holding campaign.toml (or exactly one other *.toml
campaign file, such as unit.toml); a folder of such folders (as `spincal simulate --fleet`
writes) stands for all of its folders: one without a campaign file fails as its own unit, so none
is left out unseen (hidden folders and the --out folder are skipped, each named on standard
error). A unit that cannot be found fails as its own unit too. Each unit is calibrated exactly as
`spincal calibrate --campaign` does, on one thread; --threads units run at once.

Writes OUT/<unit>/results.json, report.html and (when saved) model.json per unit, and
OUT/fleet.csv, fleet.json (every sensor parameter with its standard error per unit, fleet median
and robust spread, outliers with the reason) and fleet.html (each parameter across the fleet,
outliers highlighted). A unit is flagged on a parameter when it lies outside the prediction
interval of the other units (those within 5 robust spreads of the median), widened by its own
standard error, at two-sided probability --false-alarm (Student's t; judged with 5 or more
units).

Exit codes: 0 every unit calibrated; 3 some units failed (every other unit's outputs and the
fleet table are written, the failures are in it); 1 no unit could be calibrated; 2 bad usage.

A simulated fleet to try it on: `spincal simulate --fleet 8 --faulty 3 --out fleet8 --seed 7`; then
`spincal fleet fleet8 --out fleet8-cal` calibrates all eight (a minute or two on two cores) and
flags unit-03.

Examples:
  spincal fleet fleet8/unit-01 fleet8/unit-03 --out fleet8-two --threads 2";

#[derive(Args, Debug)]
pub struct FleetArgs {
    /// The units: campaign files, folders holding one (campaign.toml or a single *.toml), or
    /// folders of such folders.
    #[arg(required = true, value_name = "DIR_OR_CAMPAIGN")]
    pub units: Vec<PathBuf>,
    /// Output folder: one folder per unit, fleet.csv, fleet.json and fleet.html.
    #[arg(long)]
    pub out: PathBuf,
    /// Units calibrated at once (default: all cores); each unit uses one thread.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub threads: Option<u64>,
    /// Chance that a unit like the others is flagged on one parameter (two-sided, 0 to 1).
    #[arg(long, default_value_t = 1e-4, value_parser = super::probability, allow_negative_numbers = true)]
    pub false_alarm: f64,
    /// Print the fleet table as JSON instead of the summary.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: FleetArgs, ui: Ui) -> anyhow::Result<()> {
    let expanded = expand_sources(&args.units, &[&args.out]);
    for (folder, why) in &expanded.skipped {
        eprintln!("spincal: skipped {}: {why}", folder.display());
    }
    let sources = expanded.units;
    let labels = unit_labels(&sources);
    // Outputs may not be inputs: every campaign that can be read names its files (one that
    // cannot fails as its own unit later).
    super::check_paths(&campaign_inputs(&sources), &fleet_outputs(&args.out, &labels))?;
    super::create_folder("--out", &args.out)?;

    let multi = ui.multi();
    let bars = ui.labelled_bars(&multi, &labels);
    let settings = FleetSettings {
        threads: args.threads.map(|t| t as usize),
        ..FleetSettings::default()
    };
    let observer = |i: usize, p: Progress<'_>| {
        if let Some(bar) = bars.get(i) {
            ui::show(bar, p);
            if p.stage == "done" || p.stage == "failed" {
                bar.finish();
            }
        }
    };
    let outcomes = calibrate_fleet(&sources, &settings, &observer);
    let _ = multi.clear();

    for outcome in &outcomes {
        if let Ok(cal) = &outcome.result {
            let dir = args.out.join(&outcome.unit);
            let files = spincal::report::campaign::campaign_files(&cal.result, cal.model.as_ref(), None)
                .context("drawing a unit's report")?;
            let names: Vec<PathBuf> = files.iter().map(|(name, _)| dir.join(name)).collect();
            super::check_paths(&cal.inputs, &names)?;
            spincal::output::create_folder(&dir).with_context(|| format!("creating {}", dir.display()))?;
            for ((_, text), path) in files.iter().zip(&names) {
                super::write_text(path, text)?;
            }
        }
    }
    let table = fleet_table(
        &outcomes,
        &OutlierSettings {
            false_alarm_probability: args.false_alarm,
            ..OutlierSettings::default()
        },
    );
    super::write_text(&args.out.join("fleet.csv"), &table.to_csv())?;
    super::write_text(
        &args.out.join("fleet.json"),
        &(serde_json::to_string_pretty(&table)? + "\n"),
    )?;
    let html = spincal::report::fleet::fleet_html(&table).context("drawing fleet.html")?;
    super::write_text(&args.out.join("fleet.html"), &html)?;

    if args.json {
        ui::print_json(&table)?;
    } else {
        ui::print(&summary(&table, &outcomes, &args.out))?;
    }
    let Some(message) = failures(&outcomes) else {
        return Ok(());
    };
    if table.units_ok == 0 {
        anyhow::bail!(message);
    }
    Err(UnitsFailed(message).into())
}

/// The terminal summary: one line per unit, then the flags.
pub fn summary(table: &FleetTable, outcomes: &[UnitOutcome], out: &Path) -> String {
    let width = table.rows.iter().map(|r| r.unit.len()).max().unwrap_or(4).max(4);
    let mut text = format!(
        "{} units: {} calibrated, {} failed, {} flagged\n\n{:<width$}  status  saved             held-out RMS (m/s²)  flagged on\n",
        table.rows.len(),
        table.units_ok,
        table.units_failed,
        table.flagged_units().len(),
        "unit"
    );
    for row in &table.rows {
        let flags: Vec<&str> = row.flags.iter().map(|f| f.parameter.as_str()).collect();
        let _ = writeln!(
            text,
            "{:<width$}  {:<6}  {:<16}  {:<19}  {}",
            row.unit,
            if row.ok { "ok" } else { "failed" },
            row.saved.as_deref().unwrap_or("–"),
            row.held_out_rms_mps2.map_or("–".into(), |v| format!("{v:.4}")),
            flags.join(", ")
        );
    }
    if !table.outliers.is_empty() {
        text.push_str("\nflagged:\n");
        for f in &table.outliers {
            let _ = writeln!(text, "  {}: {}", f.unit, f.reason);
        }
    }
    let ok = outcomes.iter().filter(|o| o.result.is_ok()).count();
    let dir = out.display();
    let _ = writeln!(
        text,
        "\nwrote {dir}/fleet.csv, {dir}/fleet.json, {dir}/fleet.html and {ok} unit folder{} ({dir}/<unit>/results.json, report.html, model.json when saved)",
        if ok == 1 { "" } else { "s" }
    );
    text
}

/// `spincal simulate --fleet N --out DIR`: writes the fleet and says so.
pub fn simulate(
    units: usize,
    dir: &Path,
    seed: u64,
    faulty: &[usize],
    setup_file: Option<&Path>,
    json: bool,
) -> anyhow::Result<()> {
    let campaign: CampaignSetup = super::values::read_json_or_default(setup_file, "a campaign setup")?;
    let faulty = faulty_indices(units, faulty).map_err(|bad| {
        UsageError(format!(
            "--faulty {bad}: units are numbered 1 to {units} (unit-01 is 1)"
        ))
    })?;
    let setup = FleetSetup {
        units,
        campaign,
        faulty,
        ..FleetSetup::default()
    };
    let fleet = simulate_fleet(&setup, seed).map_err(|e| UsageError(e.to_string()))?;
    let folders = match fleet.write_folders(dir) {
        Err(e @ WriteError::Exists { .. }) => return Err(UsageError(e.to_string()).into()),
        other => other?,
    };
    if json {
        return ui::print_json(&serde_json::json!({
            "units": folders,
            "faulty": fleet.faulty_names(),
            "truth": dir.join("fleet-truth.json"),
        }));
    }
    let faulty_names = fleet.faulty_names();
    ui::print(&format!(
        "wrote {} unit campaigns into {} ({}), each with its own sensor errors, and {}\n",
        folders.len(),
        dir.display(),
        if faulty_names.is_empty() {
            "none faulty".to_string()
        } else {
            format!("faulty: {}", faulty_names.join(", "))
        },
        dir.join("fleet-truth.json").display()
    ))
}
