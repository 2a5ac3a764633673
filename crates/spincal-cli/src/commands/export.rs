//! `spincal export`: a saved corrector as firmware source (C99 float/double, no_std Rust) and the
//! values x-io Fusion takes; its thermal model as ArduPilot's and PX4's parameter files. Library
//! calls make the files; this prints what was written.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use spincal::correctors::model_file::CorrectorFile;
use spincal::firmware::{export_firmware, write_export, ExportOptions, Precision};
use spincal::thermal::flight_stacks::{self, ArduPilotTarget, FlightStackError, Px4Target, StackFile};
use spincal::thermal::ThermalModel;

use crate::ui::{self, UsageError};

/// The arithmetic of the C files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PrecisionArg {
    /// Single precision (`float`): FPUs without double (Cortex-M4F).
    Float,
    /// Double precision: `spincal correct`'s own arithmetic.
    Double,
    /// Both, as separate files with distinct symbols.
    Both,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    /// The saved corrector (model.json from calibrate, train or static).
    #[arg(long)]
    model: PathBuf,
    /// Folder to write the firmware source into (created if missing).
    #[arg(long, required_unless_present_any = ["ardupilot", "px4"])]
    out: Option<PathBuf>,
    /// Arithmetic of the C export.
    #[arg(long, value_enum, default_value_t = PrecisionArg::Both)]
    precision: PrecisionArg,
    /// Prefix of the files and C symbols (NAME_f32.h, NAME_f32_correct, NAME_model.rs).
    #[arg(long, default_value = "spincal")]
    name: String,
    /// Write the model's thermal compensation as ArduPilot parameters (INS_TCALn_*, a .param file).
    #[arg(long, value_name = "FILE")]
    ardupilot: Option<PathBuf>,
    /// n of INS_TCALn_* (the IMU, 1 to 3).
    #[arg(long, value_name = "N", default_value_t = 1)]
    ardupilot_imu: u8,
    /// Write the model's thermal compensation as PX4 parameters (TC_An_*, a QGroundControl .params file).
    #[arg(long, value_name = "FILE", requires = "px4_device_id")]
    px4: Option<PathBuf>,
    /// The accelerometer's device id, CAL_ACCn_ID (PX4 applies TC_An_* only to that sensor).
    #[arg(long, value_name = "ID")]
    px4_device_id: Option<u32>,
    /// n of TC_An_* (0 to 3).
    #[arg(long, value_name = "N", default_value_t = 0)]
    px4_accel: u8,
    /// The vehicle's MAVLink system id (QGroundControl refuses a file saved for another).
    #[arg(long, value_name = "ID", default_value_t = 1)]
    px4_system_id: u8,
}

/// The thermal model a corrector file carries.
fn thermal_of(file: &CorrectorFile) -> Option<&ThermalModel> {
    file.thermal.as_ref()
}

/// A wrong target (IMU number, device id) is a usage error; a model the stacks cannot hold is not.
fn stack_error(e: FlightStackError) -> anyhow::Error {
    match e {
        FlightStackError::Target { .. } => anyhow::Error::new(UsageError(e.to_string())),
        other => anyhow::Error::new(other),
    }
}

/// The flight stacks' files asked for, made before anything is written.
fn stack_files(args: &ExportArgs, model: &CorrectorFile) -> anyhow::Result<Vec<(PathBuf, StackFile)>> {
    if args.ardupilot.is_none() && args.px4.is_none() {
        return Ok(Vec::new());
    }
    let Some(thermal) = thermal_of(model) else {
        return Err(UsageError(format!(
            "{} has no thermal model (no `thermal` field), so there is nothing to write for --ardupilot or --px4",
            args.model.display()
        ))
        .into());
    };
    let mut files = Vec::new();
    if let Some(path) = &args.ardupilot {
        let target = ArduPilotTarget {
            imu: args.ardupilot_imu,
        };
        files.push((
            path.clone(),
            flight_stacks::ardupilot(thermal, target).map_err(stack_error)?,
        ));
    }
    if let Some(path) = &args.px4 {
        let target = Px4Target {
            accel: args.px4_accel,
            device_id: args
                .px4_device_id
                .expect("clap requires --px4-device-id with --px4"),
            system_id: args.px4_system_id,
            component_id: 1,
        };
        files.push((
            path.clone(),
            flight_stacks::px4(thermal, target).map_err(stack_error)?,
        ));
    }
    Ok(files)
}

pub fn run(args: ExportArgs) -> anyhow::Result<()> {
    let model = CorrectorFile::read_path(&args.model)?;
    let stacks = stack_files(&args, &model)?;
    let mut text = String::new();
    if let Some(out) = &args.out {
        let stack_paths: Vec<&Path> = stacks.iter().map(|(p, _)| p.as_path()).collect();
        text.push_str(&firmware(&args, &model, out, &stack_paths)?);
    } else {
        let paths: Vec<&Path> = stacks.iter().map(|(p, _)| p.as_path()).collect();
        super::check_outputs(&[args.model.as_path()], &paths)?;
    }
    for (path, file) in &stacks {
        spincal::output::write_bytes(path, file.text.as_bytes())?;
        if !text.is_empty() {
            text.push_str(if text.ends_with('\n') { "\n" } else { "\n\n" });
        }
        text.push_str(&format!(
            "wrote {} ({} parameters)\n",
            path.display(),
            file.params.len()
        ));
        // The file's own header says what it leaves out and how much; show it here too.
        let header = file.text.lines().map_while(|l| l.strip_prefix("# "));
        for line in header.skip(1) {
            text.push_str(&format!("  {line}\n"));
        }
    }
    ui::print(&text)
}

/// The firmware source into `out`; `also` are the other outputs of this run, checked with them.
fn firmware(args: &ExportArgs, model: &CorrectorFile, out: &Path, also: &[&Path]) -> anyhow::Result<String> {
    let precisions = match args.precision {
        PrecisionArg::Float => vec![Precision::Float],
        PrecisionArg::Double => vec![Precision::Double],
        PrecisionArg::Both => vec![Precision::Float, Precision::Double],
    };
    let options = ExportOptions {
        name: args.name.clone(),
        precisions,
    };
    let export =
        export_firmware(model, &args.model.display().to_string(), &options).map_err(|e| match e {
            spincal::firmware::FirmwareError::Name { .. } => anyhow::Error::new(UsageError(e.to_string())),
            other => anyhow::Error::new(other),
        })?;
    let paths: Vec<PathBuf> = export.files.iter().map(|(name, _)| out.join(name)).collect();
    let mut outputs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    outputs.extend_from_slice(also);
    super::check_outputs(&[args.model.as_path()], &outputs)?;
    let written = write_export(&export, out)?;
    let mut text = format!("exported the {} corrector:\n", export.kind);
    for path in &written {
        text.push_str(&format!("  {}\n", path.display()));
    }
    text.push_str(&export.float_error_text());
    text.push_str("\n\n");
    text.push_str(&spincal::firmware::fusion_text(&export.fusion));
    Ok(text)
}
