//! `spincal demo`: a simulated unit calibrated from a campaign (still poses and turntable runs,
//! correctors chosen on held-out conditions), then the paper's single-recording protocol on the
//! default session, then a phone's session calibrated from its phyphox zips, with no input needed.

use std::path::PathBuf;

use clap::Args;
use spincal::campaign::params::Params;
use spincal::input::recording::AccelUnit;
use spincal::simulate::{simulate, SensorProfile, TurntableSetup};
use spincal::turntable::fit::{FitOptions, RadiusPrior};

use super::calibrate::{run_calibration, summary};
use crate::ui::{self, Ui};

#[derive(Args, Debug)]
#[command(
    after_help = "Runs three calibrations, each on simulated data:\n  1. a campaign (still poses and turntable runs, written to OUT/campaign) calibrated as\n     `spincal calibrate --campaign` does, into OUT/campaign-calibration (its verdict first);\n  2. the paper's protocol: two turntable recordings (OUT/rec33.csv, OUT/rec45.csv) calibrated as\n     `spincal calibrate` does, into OUT (results.json, report.html, model.json);\n  3. a phone on the record player: phyphox zips (OUT/phone, no radius stated) calibrated as\n     `spincal calibrate --campaign` does, into OUT/phone-calibration, the chip's radius against the truth.\n\nExample:\n  spincal demo --out spincal-demo && xdg-open spincal-demo/report.html"
)]
pub struct DemoArgs {
    /// Folder for the simulated recordings and every result.
    #[arg(long, default_value = "spincal-demo")]
    pub out: PathBuf,
    /// Seed of the simulated session and of the training.
    #[arg(long, default_value_t = 2024)]
    pub seed: u64,
    /// Still poses in the campaign: 12 (six faces, then six edges) by default. Six (the faces
    /// alone) leave the sensor's nine linear terms nearly to the poses alone, and with a drifting
    /// bias a held-out pose can then defeat every corrector, so that nothing is saved.
    #[arg(long, default_value_t = 12, value_parser = clap::value_parser!(u64).range(3..=60))]
    pub poses: u64,
    /// Print results.json instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// The default session: a 3DM-GX1-like sensor 10 cm out on a record player at 33⅓ and 45 rpm,
/// two minutes each.
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
    super::create_folder("--out", &args.out)?;
    // The campaign first: its verdict is what a user should read first.
    let campaign_dir = args.out.join("campaign");
    super::campaign::write_simulated_campaign(
        &campaign_dir,
        &spincal::simulate::campaign::CampaignSetup {
            poses: args.poses as usize,
            ..Default::default()
        },
        args.seed,
        true,
    )?;
    let campaign_out = args.out.join("campaign-calibration");
    let (campaign, campaign_written) =
        super::campaign::calibrate_to(&campaign_dir.join("campaign.toml"), &campaign_out, ui)?;
    let mut recordings = Vec::new();
    for (k, (name, table)) in default_session().into_iter().enumerate() {
        let sim = simulate(&SensorProfile::default(), &table, args.seed + k as u64)?;
        let path = args.out.join(&name);
        sim.recording.write_csv_path(&path, AccelUnit::G)?;
        super::write_text(
            &path.with_extension("truth.json"),
            &spincal::simulate::truth_json(&sim.truth, &path)?,
        )?;
        let mut recording = sim.recording;
        recording.source.name = name;
        recordings.push(recording);
    }
    let settings = Params {
        fit: FitOptions {
            radius: Some(RadiusPrior {
                value_m: 0.10,
                tolerance_m: 0.002,
            }),
            ..FitOptions::default()
        },
        seed: args.seed,
        ..Params::default()
    };
    let (output, written) = run_calibration(&recordings, &settings, &args.out, None, ui)?;
    let phone_out = args.out.join("phone-calibration");
    let phone = super::phone::demo(&args.out.join("phone"), &phone_out, args.seed, ui)?;
    if args.json {
        return ui::print_json(&output.result);
    }
    ui::print(&format!(
        "== Campaign (one unit: still poses and turntable runs) ==\n{}",
        super::campaign::summary(&campaign, &campaign_out, &campaign_written, false)
    ))?;
    ui::print(&format!(
        "\n== The paper's protocol (two turntable recordings: held out in turn, and 60/20/20 on the first) ==\n{}",
        summary(&output, &args.out, &written, false)
    ))?;
    ui::print(&format!(
        "\n== A phone on the record player (phyphox zips, the chip's radius not stated) ==\n{phone}"
    ))?;
    ui::print(&format!(
        "open {}/report.html (the paper's protocol), {}/report.html (the campaign) and {}/report.html (the phone)\n",
        args.out.display(),
        campaign_out.display(),
        phone_out.display()
    ))
}
