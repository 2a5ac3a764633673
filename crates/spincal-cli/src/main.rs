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
    /// Show what a recording holds: detected format, samples, rate, gaps, saturation, metadata.
    #[command(
        after_help = "Examples:\n  spincal inspect session.csv\n  spincal inspect imu.bin --format 3dm-gx1 --gx1-accel-gain 5000\n  spincal inspect data.csv --json"
    )]
    Inspect(commands::inspect::InspectArgs),
    /// Calibrate bias, scale and misalignment from still poses (|a| = g).
    #[command(
        after_help = "Examples:\n  spincal static xsens_acc.mat --format whitespace --gravity 9.81744 -o cal.json\n  spincal static annotated_session.csv --model 6 --yaml kalibr.yaml\n  spincal static example_data_calibration.csv --model 12 --json"
    )]
    Static(commands::static_cal::StaticArgs),
    /// Allan deviation of a still recording: noise density and bias instability per axis.
    #[command(
        after_help = "Examples:\n  spincal allan still.csv --plot allan.svg --curve allan.csv --profile sensor.json\n  spincal allan xsens_acc.mat --calibration cal.json --still --json"
    )]
    Allan(commands::allan::AllanArgs),
    /// Draw a printable stroboscopic disc (SVG, true size) to check a turntable's speed under mains light.
    #[command(
        after_help = "Example:\n  spincal strobe --rpm 33.333 --rpm 45 --mains 50 --diameter-mm 120 -o disc.svg"
    )]
    Strobe(commands::strobe::Args),
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
        Command::Inspect(args) => commands::inspect::run(&args, &ui),
        Command::Static(args) => commands::static_cal::run(&args, &ui),
        Command::Allan(args) => commands::allan::run(&args, &ui),
        Command::Strobe(args) => commands::strobe::run(args),
    };
    std::process::exit(ui::exit_code(result));
}
