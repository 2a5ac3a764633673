//! `spincal init`: a commented campaign file to start from, for a phone, a breakout board or a
//! flight controller (the text is the library's `campaign::template`).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use spincal::campaign::template::{write_campaign_template, Device, TemplateError};
use spincal::output::OutputError;

use crate::ui::{self, UsageError};

/// The devices `--device` names.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DeviceArg {
    /// A smartphone with phyphox or Sensor Logger, on a record player.
    Phone,
    /// An MPU-6050-like breakout board logged by a microcontroller, on a record player.
    Breakout,
    /// A flight controller's own log (PX4 ULog, ArduPilot DataFlash): warm-ups, no turntable.
    FlightController,
}

impl DeviceArg {
    fn device(self) -> Device {
        match self {
            DeviceArg::Phone => Device::Phone,
            DeviceArg::Breakout => Device::Breakout,
            DeviceArg::FlightController => Device::FlightController,
        }
    }
}

#[derive(Args, Debug)]
#[command(after_help = "Examples:
  spincal init --device phone                       # writes campaign.toml here
  spincal init --device breakout -o board7/campaign.toml
  spincal init --device flight-controller -o fc/campaign.toml
The file says what to record and for how long; an existing file is refused unless --force.")]
pub struct InitArgs {
    /// What is calibrated: the template says what to record with it.
    #[arg(long, value_enum)]
    pub device: DeviceArg,
    /// The campaign file to write; the unit is named after its folder.
    #[arg(short, long, default_value = "campaign.toml")]
    pub output: PathBuf,
}

pub fn run(args: &InitArgs) -> anyhow::Result<()> {
    let force = super::force();
    let device = args.device.device();
    // Only a failing write is a failure; every refusal is the command line's to fix.
    let replaced = write_campaign_template(device, &args.output, force).map_err(|e| match e {
        TemplateError::Output(OutputError::Io { .. }) => anyhow::Error::from(e),
        TemplateError::Exists { path } => UsageError(format!(
            "{path} already exists; edit it, name another file, or give --force to replace it"
        ))
        .into(),
        refused => UsageError(refused.to_string()).into(),
    })?;
    for r in replaced {
        eprintln!("spincal: --force: replacing {}", r.path.display());
    }
    let file = args.output.display();
    let folder = match args.output.parent() {
        Some(p) if !p.as_os_str().is_empty() => format!("{}/", p.display()),
        _ => String::new(),
    };
    ui::print(&format!(
        "wrote {file}, a campaign for a {}: it says what to record and for how long.\n\
         Record {}, put them in {}, edit the lines marked EDIT, then:\n  spincal calibrate --campaign {file} --out {folder}cal\n",
        device_words(device),
        files_list(device),
        if folder.is_empty() { "this folder".to_string() } else { folder.clone() },
    ))
}

fn device_words(device: Device) -> &'static str {
    match device {
        Device::Phone => "phone",
        Device::Breakout => "breakout board",
        _ => "flight controller",
    }
}

fn files_list(device: Device) -> String {
    device.recording_files().join(", ")
}
