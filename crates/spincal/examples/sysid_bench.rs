//! Timing of the sysid fits on the benchmark's data (bench/sysid/run.sh writes the CSVs):
//! `sysid_bench ARX_CSV BJ_CSV [RUNS]` prints one JSON line per case with the best and median
//! seconds of RUNS timed fits (default 3) after one warm-up fit, and the fit %.

use std::path::Path;
use std::time::Instant;

use spincal::input::table::{Table, TableOptions};
use spincal::sysid::{fit_and_score, ArxParams, ModelKind, ModelSpec};

/// Best and (upper) median, the rule bench_peers.py applies to the peers.
fn best_and_median(times: &[f64]) -> (f64, f64) {
    let mut s = times.to_vec();
    s.sort_by(f64::total_cmp);
    (s[0], s[s.len() / 2])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let runs: usize = args.get(3).map(|v| v.parse()).transpose()?.unwrap_or(3).max(1);
    let arx = Table::read_path(Path::new(&args[1]), &TableOptions::default())?;
    let (u, y) = (&arx.columns[0], &arx.columns[1]);
    let mut times = Vec::new();
    let mut theta = Vec::new();
    // Run 0 is the warm-up; the fit is deterministic, the timing is not.
    for run in 0..=runs {
        let t = Instant::now();
        let fit = ArxParams::siso(6, 8, 1).fit(&[u], y)?;
        if run > 0 {
            times.push(t.elapsed().as_secs_f64());
        }
        theta = fit.model.a[1..].to_vec();
        theta.extend_from_slice(&fit.model.b[0][1..]);
    }
    let (best, median) = best_and_median(&times);
    println!(
        "{{\"case\": \"arx\", \"samples\": {}, \"runs\": {runs}, \"seconds\": {best}, \"median_seconds\": {median}, \"theta\": {theta:?}}}",
        y.len()
    );
    let bj = Table::read_path(Path::new(&args[2]), &TableOptions::default())?;
    let (u, y) = (&bj.columns[0], &bj.columns[1]);
    let n = y.len();
    let spec = ModelSpec::new(ModelKind::Bj, &[4, 4, 4, 4, 1])?;
    let mut times = Vec::new();
    let mut scores = None;
    for run in 0..=runs {
        let row = fit_and_score(
            &spec,
            &[u],
            y,
            0..n / 2,
            Some(n / 2..n),
            0,
            &spincal::progress::silent,
        )?;
        if run > 0 {
            times.push(row.seconds);
        }
        scores = row.test;
    }
    let (best, median) = best_and_median(&times);
    let s = scores.expect("test range given");
    println!(
        "{{\"case\": \"bj\", \"samples\": {n}, \"runs\": {runs}, \"seconds\": {best}, \"median_seconds\": {median}, \"validation_simulation_fit_percent\": {}, \"validation_one_step_fit_percent\": {}}}",
        s.simulation.fit_percent, s.one_step.fit_percent
    );
    Ok(())
}
