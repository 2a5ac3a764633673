//! The `spincal` command: parses arguments, calls the library, prints, draws progress bars.
//! Exit codes: 0 success, 1 failure, 2 bad usage, 3 finished with some rows refused (`correct`) or
//! some units failed (`fleet`). A closed pipe on stdout is not an error.

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
    /// Replace existing output files that spincal did not write (each one replaced is named on
    /// standard error). Without it such a file is refused; spincal's own earlier outputs, known
    /// by the record of what it wrote that it keeps in `.spincal-outputs.json` in their folder
    /// (edited since, a file is the user's), are always replaced.
    #[arg(long, global = true)]
    force: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a campaign and calibrate it, then the default record-player session (the README's main command).
    Demo(commands::demo::DemoArgs),
    /// Write a commented campaign file for a phone, a breakout board or a flight controller: what to record, for how long.
    Init(commands::init::InitArgs),
    /// The whole job: turntable fit, every corrector trained and compared, model + report written.
    Calibrate(commands::calibrate::CalibrateArgs),
    /// Every corrector on turntable recordings, as the paper's Table 2 (text, CSV, JSON).
    Compare(commands::compare::CompareArgs),
    /// Calibrate many units, each from its campaign, in parallel; a fleet table with outliers.
    #[command(after_help = commands::fleet::AFTER_HELP)]
    Fleet(commands::fleet::FleetArgs),
    /// Simulate a 3DM-GX1-like accelerometer on a turntable (CSV + truth JSON).
    Simulate(commands::simulate::SimulateArgs),
    /// Fit the turntable model to recordings: r, ω, tilt, β, phase, offsets, drift.
    Fit(commands::fit::FitArgs),
    /// The paper's Table 1: signal changes when r, α or ω is off by ± a percentage.
    Sensitivity(commands::sensitivity::SensitivityArgs),
    /// Show what a recording holds: detected format, samples, rate, gaps, saturation, metadata.
    #[command(
        after_help = "Examples:\n  spincal inspect session.csv\n  spincal inspect imu.bin --format 3dm-gx1 --gx1-accel-gain 5000\n  spincal inspect data.csv --json"
    )]
    Inspect(commands::inspect::InspectArgs),
    /// Calibrate bias, scale and misalignment from still poses (|a| = g).
    #[command(
        after_help = "Examples:\n  spincal static xsens_acc.mat --format whitespace --gravity 9.81744 -o cal.json\n  spincal static xsens_acc.mat --gyro-file xsens_gyro.mat --gravity 9.81744 -o cal_gyro.json\n  spincal static annotated_session.csv --model 6 --yaml kalibr.yaml\n  spincal static example_data_calibration.csv --model 6 --json"
    )]
    Static(commands::static_cal::StaticArgs),
    /// Allan deviation of a still recording: noise density and bias instability per axis.
    #[command(
        after_help = "Examples:\n  spincal allan still.csv --plot allan.svg --curve allan.csv --profile sensor.json\n  spincal allan xsens_acc.mat --calibration cal.json --still --json\n  spincal allan xsens_acc.mat --gyro-file xsens_gyro.mat --calibration cal_gyro.json --still --kalibr imu.yaml"
    )]
    Allan(commands::allan::AllanArgs),
    /// Draw a printable stroboscopic disc (SVG, true size) to check a turntable's speed under mains light.
    #[command(
        after_help = "Example:\n  spincal strobe --rpm 33.333 --rpm 45 --mains 50 --diameter-mm 120 -o disc.svg"
    )]
    Strobe(commands::strobe::Args),
    /// Fit a system-identification model (ARX, OE, ARMAX, BJ, NARX, HW) to an input/output table.
    Sysid(commands::sysid::SysidArgs),
    /// Train a corrector (network or linear) of measured against reference acceleration.
    #[command(after_help = "Examples:
  spincal train --data rec.csv --reference ref.csv --hidden 10,6 -o ann.json
  spincal train --data rec.csv --reference ref.csv --correct-axes x --delays 2 --restarts 20 --seed 7 -o x.json
  spincal train --data rec.csv --reference ref.csv --kind linear --correct-axes x,y -o linear.json --json")]
    Train(commands::train::TrainArgs),
    /// Train a grid of network architectures and tabulate their fit (the paper's Fig. 12).
    #[command(after_help = "Examples:
  spincal sweep --data rec.csv --reference ref.csv -o sweep        # writes sweep.csv, sweep.json
  spincal sweep --data rec.csv --reference ref.csv --grid '1-15' --restarts 5 --threads 2")]
    Sweep(commands::sweep::SweepArgs),
    /// Apply a saved corrector to a recording, streaming, row by row.
    #[command(
        after_help = "Every input row comes out, in place, with its original columns, the corrected axes added, a
`valid` column (0 for the first rows without full delay history and for rows a network cannot
correct) and a `status` column: ok, physics-only (outside the training range, a physical model
corrects it alone), outside-range (outside a network's training range: the reading unchanged,
valid 0) or `refused: line N: reason` for a row that
cannot be read or whose time goes backwards (its corrected columns are empty). Exit code 3 says
rows were refused. The output is written to a temporary file and renamed when complete.

Examples:
  spincal correct --model ann.json new.csv -o new-corrected.csv
  cat new.csv | spincal correct --model linear.json - > out.csv
  spincal correct --model warm7-cal/model.json warm7/held-out-40.csv -o held-corrected.csv   # reads temp_c"
    )]
    Correct(commands::correct::CorrectArgs),
    /// A saved corrector as firmware source: C99 (float, double), no_std Rust, x-io Fusion's values.
    #[command(
        after_help = "Writes NAME_f32.h/.c and NAME_f64.h/.c (C99, no dynamic memory, only <math.h>),
NAME_model.rs (statics for the no_std crate spincal-embedded) and fusion.txt (x-io Fusion's
misalignment, sensitivity and offset, with what Fusion cannot hold and its largest effect).
A physical model with its covariance also gets the error bar `correct` writes
(NAME_fXX_predicted_sd in C, Model::predicted_error in Rust).
--ardupilot / --px4 write a thermal model (from a campaign that logged its temperature) as the
flight stacks' INS_TCALn_* / TC_An_* parameters, with what each stack cannot hold stated.

Examples:
  spincal export --model ann.json --out firmware
  spincal export --model linear.json --out firmware-float --precision float --name imu
  spincal export --model warm7-cal/model.json --ardupilot imu.param --px4 imu.params --px4-device-id 1310988"
    )]
    Export(commands::export::ExportArgs),
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
    commands::set_force(cli.force);
    ui::remove_temporaries_on_signals();
    let result = match cli.command {
        Command::Demo(args) => commands::demo::run(args, ui),
        Command::Init(args) => commands::init::run(&args),
        Command::Calibrate(args) => commands::calibrate::run(args, ui),
        Command::Compare(args) => commands::compare::run(args, ui),
        Command::Fleet(args) => commands::fleet::run(args, ui),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Fit(args) => commands::fit::run(args, ui),
        Command::Sensitivity(args) => commands::sensitivity::run(args),
        Command::Inspect(args) => commands::inspect::run(&args, &ui),
        Command::Static(args) => commands::static_cal::run(&args, &ui),
        Command::Allan(args) => commands::allan::run(&args, &ui),
        Command::Strobe(args) => commands::strobe::run(args),
        Command::Sysid(args) => commands::sysid::run(args, ui),
        Command::Train(args) => commands::train::run(args, ui),
        Command::Sweep(args) => commands::sweep::run(args, ui),
        Command::Correct(args) => commands::correct::run(args, ui),
        Command::Export(args) => commands::export::run(args),
    };
    let code = ui::exit_code(result);
    // A command that failed before writing leaves no empty folder it made.
    spincal::output::remove_empty_created_folders();
    std::process::exit(code);
}
