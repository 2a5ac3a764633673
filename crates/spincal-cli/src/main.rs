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
        Command::Sysid(args) => commands::sysid::run(args, ui),
    };
    std::process::exit(ui::exit_code(result));
}
