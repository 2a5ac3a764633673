//! The `spincal` command: parses arguments, calls the library, prints, draws progress bars.
//! Exit codes: 0 success, 1 failure, 2 bad usage. A closed pipe on stdout is not an error.

mod commands;
mod ui;

use clap::{Parser, Subcommand};

/// Turntable-referenced IMU accelerometer calibration.
#[derive(Parser)]
#[command(name = "spincal", version, about, long_about = None)]
struct Cli {
    /// Hide progress bars.
    #[arg(long, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate the default record-player session and calibrate it (the README's main command).
    Demo(commands::demo::DemoArgs),
    /// Simulate a 3DM-GX1-like accelerometer on a turntable (CSV + truth JSON).
    Simulate(commands::simulate::SimulateArgs),
    /// Fit the turntable model to recordings: r, ω, tilt, β, phase, offsets, drift.
    Fit(commands::fit::FitArgs),
    /// The paper's Table 1: signal changes when r, α or ω is off by ± a percentage.
    Sensitivity(commands::sensitivity::SensitivityArgs),
    /// Draw a printable stroboscopic disc (SVG, true size) to check a turntable's speed under mains light.
    #[command(
        after_help = "Example:\n  spincal strobe --rpm 33.333 --rpm 45 --mains 50 --diameter-mm 120 -o disc.svg"
    )]
    Strobe(commands::strobe::Args),
    /// Fit a system-identification model (ARX, OE, ARMAX, BJ, NARX, HW) to an input/output table.
    Sysid(commands::sysid::SysidArgs),
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    let ui = ui::Ui::new(cli.quiet);
    let result = match cli.command {
        Command::Demo(args) => commands::demo::run(args, ui),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Fit(args) => commands::fit::run(args, ui),
        Command::Sensitivity(args) => commands::sensitivity::run(args),
        Command::Strobe(args) => commands::strobe::run(args),
        Command::Sysid(args) => commands::sysid::run(args, ui),
    };
    std::process::exit(ui::exit_code(result));
}
