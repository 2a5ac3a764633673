//! Timing of the sysid fits on the benchmark's data (bench/sysid/run.sh writes the CSVs):
//! `sysid_bench ARX_CSV BJ_CSV` prints one JSON line per case with seconds and fit %.

use std::path::Path;
use std::time::Instant;

use spincal::sysid::{fit_and_score, ArxParams, ModelKind, ModelSpec};
use spincal::table::{Table, TableOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let arx = Table::read_path(Path::new(&args[1]), &TableOptions::default())?;
    let (u, y) = (&arx.columns[0], &arx.columns[1]);
    // Best of 3: the fit is deterministic, the timing is not.
    let mut best = f64::INFINITY;
    let mut theta = Vec::new();
    for _ in 0..3 {
        let t = Instant::now();
        let fit = ArxParams::siso(6, 8, 1).fit(&[u], y)?;
        best = best.min(t.elapsed().as_secs_f64());
        theta = fit.model.a[1..].to_vec();
        theta.extend_from_slice(&fit.model.b[0][1..]);
    }
    println!(
        "{{\"case\": \"arx\", \"samples\": {}, \"seconds\": {best}, \"theta\": {theta:?}}}",
        y.len()
    );
    let bj = Table::read_path(Path::new(&args[2]), &TableOptions::default())?;
    let (u, y) = (&bj.columns[0], &bj.columns[1]);
    let n = y.len();
    let spec = ModelSpec::new(ModelKind::Bj, &[4, 4, 4, 4, 1])?;
    let mut best = f64::INFINITY;
    let mut scores = None;
    for _ in 0..3 {
        let row = fit_and_score(
            &spec,
            &[u],
            y,
            0..n / 2,
            Some(n / 2..n),
            0,
            &spincal::progress::silent,
        )?;
        best = best.min(row.seconds);
        scores = row.test;
    }
    let s = scores.expect("test range given");
    println!(
        "{{\"case\": \"bj\", \"samples\": {n}, \"seconds\": {best}, \"validation_simulation_fit_percent\": {}, \"validation_one_step_fit_percent\": {}}}",
        s.simulation.fit_percent, s.one_step.fit_percent
    );
    Ok(())
}
