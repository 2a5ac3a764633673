//! A simulated phone session (`spincal simulate --phone`, the demo's third part): phyphox zips
//! written by the library, calibrated as `spincal calibrate --campaign` does, held against the
//! simulation's truth.

use std::path::Path;

use spincal::simulate::fleet::WriteError;
use spincal::simulate::phone::{simulate_phone, PhoneSession, PhoneSetup};

use crate::ui::{self, Ui, UsageError};

/// Writes the session's zips, campaign.toml and truth.json into `dir`. Refuses to replace a file
/// already there unless `replace_own` (the demo's own folder).
pub fn write_session(
    dir: &Path,
    setup: &PhoneSetup,
    seed: u64,
    replace_own: bool,
) -> anyhow::Result<PhoneSession> {
    let session = simulate_phone(setup, seed).map_err(|e| UsageError(e.to_string()))?;
    match session.write_folder(dir, replace_own) {
        Err(e @ WriteError::Exists { .. }) => Err(UsageError(e.to_string()).into()),
        Err(e) => Err(e.into()),
        Ok(()) => Ok(session),
    }
}

/// `spincal simulate --phone DIR`: writes the session and says so.
pub fn simulate(dir: &Path, seed: u64, setup_file: Option<&Path>, json: bool) -> anyhow::Result<()> {
    let setup: PhoneSetup = super::values::read_json_or_default(setup_file, "a phone setup")?;
    let session = write_session(dir, &setup, seed, false)?;
    let files: Vec<&str> = session.recordings.iter().map(|r| r.file.as_str()).collect();
    if json {
        return ui::print_json(&serde_json::json!({
            "campaign": dir.join("campaign.toml"),
            "truth": dir.join("truth.json"),
            "recordings": files,
        }));
    }
    let runs = session.truth.runs.len();
    ui::print(&format!(
        "wrote {}: {} still poses and {} turntable runs ({} placements, no radius stated) as {} zips, and truth.json (the chip {:.1} mm from the phone's centre); calibrate with `spincal calibrate --campaign {}`\n",
        dir.display(),
        files.len() - runs,
        runs,
        session.truth.placements.len(),
        match setup.app {
            spincal::simulate::phone::PhoneApp::Phyphox => "phyphox",
            spincal::simulate::phone::PhoneApp::SensorLogger => "Sensor Logger",
        },
        1e3 * session.truth.chip_offset_m[0].hypot(session.truth.chip_offset_m[1]),
        dir.join("campaign.toml").display()
    ))
}

/// The demo's third part: a phone session simulated into `dir` as phyphox zips, calibrated from
/// them into `out`; returns the summary with the chip's radius against the truth.
pub fn demo(dir: &Path, out: &Path, seed: u64, ui: Ui) -> anyhow::Result<String> {
    let session = write_session(dir, &PhoneSetup::default(), seed, true)?;
    let (output, written) = super::campaign::calibrate_to(&dir.join("campaign.toml"), out, ui)?;
    let mut text = super::campaign::summary(&output, out, &written, false);
    text.push_str("\nagainst the simulation's truth (truth.json; the calibration never read it):\n");
    for line in session.truth.score(&output.result).lines() {
        text.push_str(&format!("  {line}\n"));
    }
    Ok(text)
}
