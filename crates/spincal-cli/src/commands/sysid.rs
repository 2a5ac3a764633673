//! `spincal sysid`: fit one system-identification model to any input/output table.

use std::ops::Range;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use spincal::input::formats::read_table;
use spincal::input::table::{read_file, TableOptions};
use spincal::sysid::{
    fit_and_score_parts, DataPart, FitScore, ModelKind, ModelSpec, NarxFocus, ScoredFit, SysidModel,
};

use super::values::{DelimiterArg, SysidModelArg};
use crate::ui::{self, Ui, UsageError};

#[derive(Args)]
#[command(after_help = "Examples:\n  \
    spincal sysid arx --orders 6,8,1 --data Silverbox_SNLS80mV.csv --input V1 --output V2 \\\n      \
    --train 40650..127400 --test 0..40575 --init-samples 50\n  \
    spincal sysid bj --orders 4,4,4,4,1 --data io.csv --input 1 --output 2 --train ..2000 --json\n  \
    spincal sysid oe --data CascadedTanks_dataBenchmark.mat --input uEst --output yEst \\\n      \
    --test-input uVal --test-output yVal\n\n\
Ranges are 0-based sample indices, end excluded (START..END, ..END or START..). With\n\
--test-input/--test-output the test part is those columns (--test then indexes them).\n\
Columns that are not named may have empty cells.\n\
Fit % is MATLAB's normalised RMSE fit; every number says whether it is a simulation (from the\n\
first --init-samples measured outputs) or a one-step-ahead prediction.")]
pub struct SysidArgs {
    /// Model structure.
    #[arg(value_enum)]
    model: SysidModelArg,
    /// Orders in MATLAB's order: arx/narx [na nb nk], oe/hw [nb nf nk], armax [na nb nc nk],
    /// bj [nb nc nd nf nk]. Default: the paper's.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    orders: Option<Vec<usize>>,
    /// Numeric table: delimited text or a MATLAB v5 MAT-file (variables as columns).
    #[arg(long)]
    data: PathBuf,
    /// Field separator of --data (default: detected).
    #[arg(long, value_enum, value_name = "SEP")]
    delimiter: Option<DelimiterArg>,
    /// Input column (header name or 1-based index).
    #[arg(long)]
    input: String,
    /// Output column (header name or 1-based index).
    #[arg(long)]
    output: String,
    /// Training samples (default: all).
    #[arg(long)]
    train: Option<String>,
    /// Test samples (default: none, or all of --test-input/--test-output).
    #[arg(long)]
    test: Option<String>,
    /// Input column of a separate test part (e.g. uVal); needs --test-output.
    #[arg(long, requires = "test_output")]
    test_input: Option<String>,
    /// Output column of a separate test part (e.g. yVal); needs --test-input.
    #[arg(long, requires = "test_input")]
    test_output: Option<String>,
    /// Measured outputs that start each simulation (excluded from the scores).
    #[arg(long, default_value_t = 5)]
    init_samples: usize,
    /// Sigmoid units (narx) or breakpoints (hw).
    #[arg(long, default_value_t = 10)]
    size: usize,
    /// Iteration limit of the iterative fits.
    #[arg(long, default_value_t = 100)]
    max_iterations: usize,
    /// Seed of NARX's initial weights.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// What a NARX fit minimises: the one-step prediction error or the simulation error.
    #[arg(long, value_parser = ["prediction", "simulation"], default_value = "prediction")]
    focus: String,
    /// Print the result (model included) as JSON.
    #[arg(long)]
    json: bool,
}

fn parse_range(text: &str, n: usize) -> Result<Range<usize>, UsageError> {
    spincal::sysid::parse_range(text, n).map_err(|e| UsageError(e.to_string()))
}

pub fn run(args: SysidArgs, ui: Ui) -> anyhow::Result<()> {
    let kind: ModelKind = args.model.into();
    let orders = args
        .orders
        .clone()
        .unwrap_or_else(|| kind.default_orders().to_vec());
    let spec = ModelSpec {
        size: args.size,
        max_iterations: args.max_iterations,
        seed: args.seed,
        focus: if args.focus == "simulation" {
            NarxFocus::Simulation
        } else {
            NarxFocus::Prediction
        },
        ..ModelSpec::new(kind, &orders).map_err(|e| UsageError(format!("{e}")))?
    };
    let reading = ui.spinner("reading");
    let options = TableOptions {
        delimiter: args.delimiter.map(Into::into),
    };
    let mut keys = vec![args.input.as_str(), args.output.as_str()];
    if let (Some(i), Some(o)) = (&args.test_input, &args.test_output) {
        keys.extend([i.as_str(), o.as_str()]);
    }
    let file = args.data.display().to_string();
    let bytes = read_file(&args.data).with_context(|| format!("reading {file}"))?;
    let table = read_table(&bytes, &file, &options, &keys)?;
    reading.finish_and_clear();
    let (u, y) = (&table.columns[0][..], &table.columns[1][..]);
    let n = y.len();
    let train = match &args.train {
        Some(t) => parse_range(t, n)?,
        None => 0..n,
    };
    let (u_test, y_test) = if table.n_columns() == 4 {
        (&table.columns[2][..], &table.columns[3][..])
    } else {
        (u, y)
    };
    let test = match (&args.test, table.n_columns() == 4) {
        (Some(t), _) => Some(parse_range(t, y_test.len())?),
        (None, true) => Some(0..y_test.len()),
        (None, false) => None,
    };
    let (us, us_test) = ([u], [u_test]);
    let bar = ui.progress(spec.max_iterations as u64, spec.kind.name());
    let row = fit_and_score_parts(
        &spec,
        DataPart {
            u: &us,
            y,
            range: train.clone(),
        },
        test.clone().map(|range| DataPart {
            u: &us_test,
            y: y_test,
            range,
        }),
        args.init_samples,
        &|p| bar.set_position(p.done as u64),
    )
    .with_context(|| format!("fitting {}", spec.structure()))?;
    bar.finish_and_clear();
    if args.json {
        return ui::print_json(&row);
    }
    ui::print(&report(&row, &train, test.as_ref()))
}

fn report(row: &ScoredFit, train: &Range<usize>, test: Option<&Range<usize>>) -> String {
    let mut s = format!("{}\n", row.structure);
    match &row.fitted.model {
        SysidModel::Poly(m) => {
            let fmt = |v: &[f64]| v.iter().map(|x| format!("{x:.6}")).collect::<Vec<_>>().join(" ");
            for (name, p) in [("A", &m.a), ("C", &m.c), ("D", &m.d)] {
                if p.len() > 1 {
                    s += &format!("  {name} = [{}]\n", fmt(p));
                }
            }
            s += &format!("  B = [{}]\n", fmt(&m.b[0]));
            if m.f[0].len() > 1 {
                s += &format!("  F = [{}]\n", fmt(&m.f[0]));
            }
        }
        SysidModel::Narx(m) => {
            s += &format!(
                "  linear term = {:?}, offset {:.6}, {} sigmoid units\n",
                m.linear,
                m.offset,
                m.units.len()
            )
        }
        SysidModel::Hw(m) => {
            s += &format!(
                "  B = {:?}\n  F = {:?}\n  (pwlinear maps: see --json)\n",
                m.b, m.f
            )
        }
    }
    s += &format!(
        "loss {:.6e} after {} iterations, fitted in {:.3} s\n",
        row.fitted.loss, row.fitted.iterations, row.seconds
    );
    let line = |part: &str, r: &Range<usize>, f: &FitScore| {
        format!(
            "{part:<6} {:>7}..{:<7} {:<20} fit {:>8.3} %   RMSE {:.6e}\n",
            r.start,
            r.end,
            f.kind.label(),
            f.fit_percent,
            f.rmse
        )
    };
    s += &line("train", train, &row.train.simulation);
    s += &line("train", train, &row.train.one_step);
    if let (Some(r), Some(t)) = (test, &row.test) {
        s += &line("test", r, &t.simulation);
        s += &line("test", r, &t.one_step);
    }
    s
}
