//! `spincal demo`: the default session simulated, then calibrated, with no input needed.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use spincal::simulate::{simulate, SensorProfile, TurntableSetup};
use spincal::turntable::{fit_turntable, FitOptions, RadiusPrior};
use spincal::AccelUnit;

use crate::ui::{self, Ui};

#[derive(Args, Debug)]
#[command(after_help = "Example:\n  spincal demo --out spincal-demo")]
pub struct DemoArgs {
    /// Folder for the simulated recordings and every result.
    #[arg(long, default_value = "spincal-demo")]
    pub out: PathBuf,
    /// Seed of the simulated session.
    #[arg(long, default_value_t = 2024)]
    pub seed: u64,
}

/// The default session: a 3DM-GX1-like sensor 10 cm out on a record player at 33⅓ and 45 rpm.
pub fn default_session() -> Vec<(String, TurntableSetup)> {
    [("rec33.csv", 100.0 / 3.0), ("rec45.csv", 45.0)]
        .into_iter()
        .map(|(name, rpm)| {
            (
                name.to_string(),
                TurntableSetup {
                    rpm,
                    duration_s: 120.0,
                    ..TurntableSetup::default()
                },
            )
        })
        .collect()
}

pub fn run(args: DemoArgs, ui: Ui) -> anyhow::Result<()> {
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut recordings = Vec::new();
    for (k, (name, table)) in default_session().into_iter().enumerate() {
        let sim = simulate(&SensorProfile::default(), &table, args.seed + k as u64)?;
        let path = args.out.join(&name);
        sim.recording.write_csv_path(&path, AccelUnit::G)?;
        std::fs::write(
            path.with_extension("truth.json"),
            serde_json::to_string_pretty(&sim.truth)? + "\n",
        )?;
        let mut recording = sim.recording;
        recording.source.name = path.display().to_string();
        recordings.push(recording);
    }
    let refs: Vec<_> = recordings.iter().collect();
    let options = FitOptions {
        radius: Some(RadiusPrior {
            value_m: 0.10,
            tolerance_m: 0.002,
        }),
        ..FitOptions::default()
    };
    let spinner = ui.spinner("fitting");
    let fit = fit_turntable(&refs, &options, &mut |stage, p| {
        spinner.set_message(format!("{stage} {}", p.iteration))
    })?;
    spinner.finish_and_clear();
    let fit_path = args.out.join("turntable_fit.json");
    std::fs::write(&fit_path, serde_json::to_string_pretty(&fit)? + "\n")?;
    ui::print(&super::fit::render(&fit))?;
    ui::print(&format!("\nresults in {}\n", args.out.display()))
}
