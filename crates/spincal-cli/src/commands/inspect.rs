//! `spincal inspect`: what is in a recording.

use clap::Args;
use serde::Serialize;

use super::{format_line, InputArgs};
use crate::ui;

#[derive(Args, Debug)]
pub struct InspectArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Report<'a> {
    file: String,
    loaded: &'a spincal::input::formats::Loaded,
    metadata: &'a [String],
    inspection: spincal::input::inspect::Inspection,
}

pub fn run(args: &InspectArgs, ui: &ui::Ui) -> anyhow::Result<()> {
    // A delimited text file is read row by row, in memory that does not grow with it.
    let (loaded, inspection) = args.input.inspect(ui)?;
    let rec = &loaded.recording;
    if args.json {
        return ui::print_json(&Report {
            file: args.input.rec.display().to_string(),
            loaded: &loaded,
            metadata: &rec.source.metadata,
            inspection,
        });
    }
    let unit = if loaded.raw_counts { "counts" } else { "m/s²" };
    let mut s = String::new();
    s += &format!("{}\n", args.input.rec.display());
    s += &format!("{}\n", format_line(&loaded));
    s += &format!(
        "samples: {}   duration: {:.3} s   sample rate: {:.4} Hz   gyro: {}\n",
        inspection.samples,
        inspection.duration_s,
        inspection.sample_rate_hz,
        if inspection.has_gyro { "yes" } else { "no" }
    );
    s += &format!("columns: {}\n", rec.source.columns.join(", "));
    for a in 0..3 {
        s += &format!(
            "accel {}: {} .. {} {unit}\n",
            ["x", "y", "z"][a],
            inspection.accel_min_mps2[a],
            inspection.accel_max_mps2[a]
        );
    }
    if let Some(t) = &inspection.temperature {
        s += &format!(
            "temperature: {:.2} .. {:.2} °C, resolution {} °C ({} distinct values)\n",
            t.min_c, t.max_c, t.resolution_c, t.distinct_values
        );
    }
    s += &format!("gaps (> 1.5 median intervals): {}\n", inspection.gap_count);
    for g in &inspection.gaps {
        s += &format!(
            "  line {} (sample {}, after t = {:.4} s): {:.4} s\n",
            g.line, g.index, g.start_s, g.length_s
        );
    }
    if inspection.saturation.is_empty() {
        s += "saturation: none (no axis holds its extreme value for 3 or more successive samples)\n";
    }
    for sat in &inspection.saturation {
        s += &format!(
            "possible saturation: a{} at {:.4} g in {} samples, the first at line {}\n",
            sat.axis,
            sat.limit_mps2 / spincal::input::recording::STANDARD_GRAVITY,
            sat.samples,
            sat.first_line
        );
    }
    if inspection.has_gyro && inspection.gyro_saturation.is_empty() {
        s += "gyro saturation: none (no gyro axis holds an extreme of 60 °/s or more for 3 or more successive samples)\n";
    }
    for sat in &inspection.gyro_saturation {
        s += &format!(
            "gyro saturation: {}, the first at line {}\n",
            sat.describe(inspection.samples),
            sat.first_line
        );
    }
    for axis in &inspection.constant_axes {
        s += &format!("constant: a{axis} never changes (a dead or disconnected channel?)\n");
    }
    for m in &rec.source.metadata {
        s += &format!("metadata: {m}\n");
    }
    if let Some(labels) = &loaded.labels {
        let mut sections: Vec<(String, usize)> = Vec::new();
        for l in labels {
            match sections.last_mut() {
                Some((name, n)) if name == l => *n += 1,
                _ => sections.push((l.clone(), 1)),
            }
        }
        let list: Vec<String> = sections.iter().map(|(l, n)| format!("{l} ({n})")).collect();
        s += &format!("sections: {}\n", list.join(", "));
    }
    if let Some(g) = &loaded.gx1 {
        s += &format!(
            "3DM-GX1: {} packets 0x03, {} packets 0x02, kept 0x{:02x}; AccelGainScale {} ({}); {} repeated timer values\n",
            g.inst_packets, g.stab_packets, g.command, g.accel_gain_scale, g.gain_source, g.repeated_ticks
        );
        s += &format!("damaged stretches: {}\n", g.faults.len());
        for f in g.faults.iter().take(20) {
            s += &format!("  {f}\n");
        }
    }
    for n in &loaded.notes {
        s += &format!("note: {n}\n");
    }
    ui::print(&s)
}
