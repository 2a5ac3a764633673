//! `spincal export`: a saved corrector as firmware source (C99 float/double, no_std Rust) and the
//! values x-io Fusion takes. One library call makes the files; this prints what was written.

use std::path::PathBuf;

use clap::ValueEnum;
use spincal::firmware::{export_firmware, write_export, ExportOptions, Precision};
use spincal::CorrectorFile;

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
    /// Folder to write into (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Arithmetic of the C export.
    #[arg(long, value_enum, default_value_t = PrecisionArg::Both)]
    precision: PrecisionArg,
    /// Prefix of the files and C symbols (NAME_f32.h, NAME_f32_correct, NAME_model.rs).
    #[arg(long, default_value = "spincal")]
    name: String,
}

pub fn run(args: ExportArgs) -> anyhow::Result<()> {
    let model = CorrectorFile::read_path(&args.model)?;
    let precisions = match args.precision {
        PrecisionArg::Float => vec![Precision::Float],
        PrecisionArg::Double => vec![Precision::Double],
        PrecisionArg::Both => vec![Precision::Float, Precision::Double],
    };
    let options = ExportOptions {
        name: args.name,
        precisions,
    };
    let export =
        export_firmware(&model, &args.model.display().to_string(), &options).map_err(|e| match e {
            spincal::firmware::FirmwareError::Name { .. } => anyhow::Error::new(UsageError(e.to_string())),
            other => anyhow::Error::new(other),
        })?;
    let paths: Vec<PathBuf> = export.files.iter().map(|(name, _)| args.out.join(name)).collect();
    super::check_outputs(
        &[args.model.as_path()],
        &paths.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
    )?;
    let written = write_export(&export, &args.out)?;
    let mut text = format!("exported the {} corrector:\n", export.kind);
    for path in &written {
        text.push_str(&format!("  {}\n", path.display()));
    }
    text.push_str(&export.float_error_text());
    text.push_str("\n\n");
    text.push_str(&spincal::firmware::fusion_text(&export.fusion));
    ui::print(&text)
}
