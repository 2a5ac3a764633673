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
    /// Train a corrector (network or linear) of measured against reference acceleration.
    #[command(after_help = "Examples:
  spincal train --data rec.csv --reference ref.csv --hidden 10,6 -o ann.json
  spincal train --data rec.csv --reference ref.csv --axes x --delays 2 --restarts 20 --seed 7 -o x.json
  spincal train --data rec.csv --reference ref.csv --kind linear -o linear.json --json")]
    Train(commands::train::TrainArgs),
    /// Train a grid of network architectures and tabulate their fit (the paper's Fig. 12).
    #[command(after_help = "Examples:
  spincal sweep --data rec.csv --reference ref.csv -o sweep        # writes sweep.csv, sweep.json
  spincal sweep --data rec.csv --reference ref.csv --grid '1-15' --restarts 5 --threads 2")]
    Sweep(commands::sweep::SweepArgs),
    /// Apply a saved corrector to a recording, streaming, row by row.
    #[command(
        after_help = "Every input row comes out with its original columns, the corrected axes added and a
`valid` column (0 for the first rows without full delay history). A row that cannot be read stops
the command with its line number and reason, and a partial output file is removed.

Examples:
  spincal correct --model ann.json new.csv -o new-corrected.csv
  cat new.csv | spincal correct --model linear.json - > out.csv"
    )]
    Correct(commands::correct::CorrectArgs),
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
        Command::Train(args) => commands::train::run(args, ui),
        Command::Sweep(args) => commands::sweep::run(args, ui),
        Command::Correct(args) => commands::correct::run(args, ui),
        Command::Strobe(args) => commands::strobe::run(args),
    };
    std::process::exit(ui::exit_code(result));
}
