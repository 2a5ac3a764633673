//! `spincal compare`: every corrector on a turntable recording, as the paper's Table 2.

use std::path::PathBuf;

use clap::Args;

use super::calibrate::CalibrateArgs;
use super::tables::{table_csv, table_text};
use crate::ui::{self, Ui};

#[derive(Args, Debug)]
#[command(
    after_help = "Examples:\n  spincal compare rec33.csv rec45.csv --radius 0.10 --sweep none --hidden 10,6\n  \
                        spincal compare rec.csv --arx 4,4,1 --bj 2,2,2,2,1 --csv table.csv"
)]
pub struct CompareArgs {
    #[command(flatten)]
    pub calibrate: CalibrateArgs,
    /// Also write the table as CSV here.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

pub fn run(args: CompareArgs, ui: Ui) -> anyhow::Result<()> {
    if args.calibrate.campaign.is_some() {
        return Err(crate::ui::UsageError(
            "compare takes recordings, not --campaign (spincal calibrate --campaign compares the correctors of a campaign)".into(),
        )
        .into());
    }
    super::require_recordings(&args.calibrate.fit.recordings)?;
    let inputs = args.calibrate.fit.inputs();
    let inputs: Vec<&std::path::Path> = inputs.iter().map(|p| p.as_path()).collect();
    let outputs: Vec<&std::path::Path> = args.csv.iter().map(|p| p.as_path()).collect();
    super::check_outputs(&inputs, &outputs)?;
    let settings = args.calibrate.params()?;
    let fit = &args.calibrate.fit;
    let recordings = fit.read_recordings()?;
    let bar = ui.progress(1, "comparing");
    let paper = spincal::calibrate::paper_protocol(&recordings, &settings, &|p| crate::ui::show(&bar, p))?;
    bar.finish_and_clear();
    if let Some(path) = &args.csv {
        super::write_text(path, &table_csv(&paper.comparison))?;
    }
    if fit.json {
        return ui::print_json(&serde_json::json!({
            "comparison": paper.comparison,
            "cross_condition": paper.cross_condition,
        }));
    }
    ui::print(&table_text(&paper))
}
