//! Rust side of bench/ann: seconds per LM epoch, the epoch's FLOP count, faer's DGEMM rate, and
//! the data export for the pyrenn peer check.
//!
//! `cargo run --release -p spincal --example ann_epoch -- time [--rounds R] [--epochs K] [N…]` prints one
//! JSON object per N: best and median of R rounds for one epoch, and the marginal epoch
//! ((K epochs − 1 epoch) / (K − 1)).
//! `cargo run --release -p spincal --example ann_epoch -- dgemm` prints faer's single-thread rate.
//! `… -- parts` times the parts of an epoch as the trainer runs them; `… -- csv N PREFIX` writes a synthetic pair.
//! `cargo run --release -p spincal --example ann_epoch -- export N HIDDEN SEED OUT.json` writes the
//! scaled training data and the initial weights of restart 0.

#[path = "../tests/common/synthetic.rs"]
mod synthetic;

use std::time::Instant;

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use spincal::correctors::ann::{AnnProblem, Layout, LmSettings, LmWorkspace};
use spincal::correctors::corrector::Axis;
use spincal::correctors::division::DivisionMode;

const XY: [Axis; 2] = [Axis::X, Axis::Y];

/// The whole data set is the training set: 100 % of N samples, as the benchmark asks for N
/// training samples.
fn problem(n: usize) -> AnnProblem {
    // 60 % goes to training: generate N / 0.6 samples so the training part has N.
    let total = (n as f64 / 0.6).ceil() as usize + 1;
    let (measured, reference) = synthetic::turntable_pair(total, 42);
    let mut p = AnnProblem::new(&measured, &reference, &XY, 0, DivisionMode::Contiguous).expect("valid data");
    p.train.inputs.truncate(n * p.train.n_inputs);
    p.train.targets.truncate(n * p.train.n_outputs);
    p
}

/// FLOPs of one LM epoch with one accepted step, counting multiply and add separately, with JᵀJ
/// and Jᵀe as products over the rows of J (the work numpy and pyrenn do, and the bound's).
fn epoch_flops(layout: &Layout, n: usize) -> (f64, f64) {
    let p = layout.n_params() as f64;
    let rows = (n * layout.outputs()) as f64;
    let forward: f64 = layout
        .sizes
        .windows(2)
        .map(|w| 2.0 * (w[0] * w[1]) as f64)
        .sum::<f64>()
        * n as f64;
    let syrk = rows * p * (p + 1.0); // lower triangle of JᵀJ
    let gemv = 2.0 * rows * p; // Jᵀe
                               // Backprop per output row: one pass down the hidden layers (≈ forward's multiply-adds).
    let backprop = forward * layout.outputs() as f64;
    let cholesky = p * p * p / 3.0 + 2.0 * p * p;
    let trial = forward;
    (syrk, forward + syrk + gemv + backprop + cholesky + trial)
}

/// CPU time of this thread in seconds (from /proc/thread-self/schedstat, ns resolution), so that
/// other processes on a shared machine do not inflate the numbers; wall time when unavailable.
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|v| v.parse::<f64>().ok()))
        .map(|ns| ns * 1e-9)
        .unwrap_or_else(|| {
            static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
            START.get_or_init(Instant::now).elapsed().as_secs_f64()
        })
}

/// Seconds per `train` call of `epochs` epochs from restart 0's weights, one value per round.
/// The thread's CPU time advances in scheduler ticks (4 ms here), so a single call cannot be
/// timed: each round is the mean over ≥ 1 s of back-to-back calls (a tick is < 0.5 % of that).
fn time_epochs(n: usize, block_samples: usize, epochs: usize, rounds: usize) -> Vec<f64> {
    let p = problem(n);
    let layout = p.layout(&[10, 6]).expect("valid layout");
    let weights = p.initial_weights(&layout, 1, 0);
    let mut ws = LmWorkspace::new(&layout, block_samples);
    let settings = LmSettings {
        max_epochs: epochs,
        max_validation_failures: usize::MAX,
        min_relative_decrease: 0.0,
        block_samples,
        ..LmSettings::default()
    };
    let empty = spincal::correctors::ann::Dataset::default();
    // One epoch = normal equations + damped solve + trial evaluation (+ the initial error).
    // Warm-up: one call outside the timed rounds.
    let mut w = weights.clone();
    ws.train(&mut w, &p.train, &empty, &settings);
    (0..rounds)
        .map(|_| {
            let started = cpu_seconds();
            let mut repeats = 0;
            while cpu_seconds() - started < 1.0 {
                let mut w = weights.clone();
                let report = ws.train(&mut w, &p.train, &empty, &settings);
                assert_eq!(
                    report.epochs, epochs,
                    "every epoch accepts a step from Nguyen–Widrow weights"
                );
                repeats += 1;
            }
            (cpu_seconds() - started) / repeats as f64
        })
        .collect()
}

fn best(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The upper median (the middle value for odd counts), as bench.py takes it.
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

fn dgemm_gflops() -> f64 {
    let n = 2000;
    let a = Mat::<f64>::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 17) as f64 / 17.0);
    let b = Mat::<f64>::from_fn(n, n, |i, j| ((i * 5 + j * 3) % 11) as f64 / 11.0);
    let mut c = Mat::<f64>::zeros(n, n);
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let started = cpu_seconds();
        matmul(c.as_mut(), Accum::Replace, a.as_ref(), b.as_ref(), 1.0, Par::Seq);
        best = best.min(cpu_seconds() - started);
    }
    2.0 * (n * n * n) as f64 / best / 1e9
}

/// The epoch's parts as the trainer runs them (dispatched, default block size), N samples:
/// forming the normal equations (forward + backprop + JᵀJ/Jᵀe kernel) and one full trial error
/// (forward only). The rest of an epoch is the damped Cholesky solves and the rejected trials.
fn parts(n: usize) {
    let p = problem(n);
    let layout = p.layout(&[10, 6]).expect("valid layout");
    let weights = p.initial_weights(&layout, 1, 0);
    let mut ws = LmWorkspace::new(&layout, LmSettings::default().block_samples);
    // At least 1 s per round: the thread's CPU time advances in 4 ms ticks.
    let time = |f: &mut dyn FnMut()| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let started = cpu_seconds();
            let mut repeats = 0;
            while cpu_seconds() - started < 1.0 {
                f();
                repeats += 1;
            }
            best = best.min((cpu_seconds() - started) / repeats as f64);
        }
        best
    };
    let normal = time(&mut || {
        std::hint::black_box(ws.normal_equations(&weights, &p.train, None));
    });
    let forward = time(&mut || {
        std::hint::black_box(ws.mse(&weights, &p.train));
    });
    let (syrk, _) = epoch_flops(&layout, n);
    println!(
        "{{\"n\": {n}, \"normal_equations_s\": {normal:.3e}, \"trial_error_s\": {forward:.3e}, \"syrk_flops\": {syrk:.3e}}}"
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("time") => {
            // time [--rounds R] [--epochs K] [N…]: best and median of R rounds of one-epoch
            // training calls, and the marginal epoch (K epochs minus one, over K − 1), the same
            // rule bench.py applies to pyrenn.
            let mut rounds = 5;
            let mut epochs = 3;
            let mut sizes = Vec::new();
            let mut rest = args[1..].iter();
            while let Some(a) = rest.next() {
                match a.as_str() {
                    "--rounds" => rounds = rest.next().and_then(|v| v.parse().ok()).expect("--rounds R"),
                    "--epochs" => epochs = rest.next().and_then(|v| v.parse().ok()).expect("--epochs K"),
                    v => sizes.push(v.parse::<usize>().expect("sample count")),
                }
            }
            assert!(rounds >= 1 && epochs >= 2, "rounds ≥ 1 and epochs ≥ 2");
            if sizes.is_empty() {
                sizes = vec![3000, 30000];
            }
            for n in sizes {
                let layout = Layout::new(2, &[10, 6], 2);
                let (syrk, total) = epoch_flops(&layout, n);
                // What the trainer actually multiplies: JᵀJ and Jᵀe from Kronecker factors.
                let (padded, unpadded) = LmWorkspace::new(&layout, 256).multiply_adds_per_sample();
                let factored = (2 * padded * n) as f64;
                let factored_unpadded = (2 * unpadded * n) as f64;
                let mut blocks = Vec::new();
                for block in [64, 256, 1024, n] {
                    blocks.push(format!("\"{block}\": {:.6e}", best(&time_epochs(n, block, 1, 3))));
                }
                let default_block = LmSettings::default().block_samples;
                let one = time_epochs(n, default_block, 1, rounds);
                let many = time_epochs(n, default_block, epochs, rounds);
                let marginal = |a: f64, b: f64| (a - b) / (epochs - 1) as f64;
                println!(
                    "{{\"n\": {n}, \"params\": {}, \"rounds\": {rounds}, \"seconds_per_epoch\": {:.6e}, \"seconds_per_epoch_median\": {:.6e}, \"marginal_epochs\": {epochs}, \"marginal_seconds_per_epoch\": {:.6e}, \"marginal_seconds_per_epoch_median\": {:.6e}, \"flops\": {total:.6e}, \"syrk_flops\": {syrk:.6e}, \"factored_product_flops\": {factored:.6e}, \"factored_product_flops_unpadded\": {factored_unpadded:.6e}, \"seconds_by_block_samples\": {{{}}}}}",
                    layout.n_params(),
                    best(&one),
                    median(&one),
                    marginal(best(&many), best(&one)),
                    marginal(median(&many), median(&one)),
                    blocks.join(", ")
                );
            }
        }
        Some("parts") => {
            for n in [3000, 30000] {
                parts(n);
            }
        }
        Some("csv") if args.len() == 3 => {
            // Synthetic measured/reference pair for CLI runs (sweep timing).
            let n: usize = args[1].parse().expect("sample count");
            let (measured, reference) = synthetic::turntable_pair(n, 42);
            let unit = spincal::input::recording::AccelUnit::Mps2;
            measured
                .write_csv_path(format!("{}-measured.csv", args[2]).as_ref(), unit)
                .expect("write");
            reference
                .write_csv_path(format!("{}-reference.csv", args[2]).as_ref(), unit)
                .expect("write");
        }
        Some("dgemm") => println!("{{\"faer_dgemm_gflops\": {:.3}}}", dgemm_gflops()),
        Some("export") if args.len() == 5 => {
            let n: usize = args[1].parse().expect("sample count");
            let hidden: Vec<usize> = args[2]
                .split(',')
                .map(|s| s.parse().expect("layer size"))
                .collect();
            let seed: u64 = args[3].parse().expect("seed");
            let p = problem(n);
            let layout = p.layout(&hidden).expect("valid layout");
            let weights = p.initial_weights(&layout, seed, 0);
            let json = serde_json::json!({
                "generator": {"function": "tests/common/synthetic.rs turntable_pair", "seed": 42, "axes": ["x", "y"]},
                "n": n,
                "sizes": layout.sizes,
                "seed": seed,
                "weights_layout": "per layer: weight matrix row-major (unit x input), then biases",
                "initial_weights": weights,
                "inputs": p.train.inputs,
                "targets": p.train.targets,
            });
            std::fs::write(&args[4], serde_json::to_string(&json).expect("json")).expect("write export");
        }
        _ => {
            eprintln!(
                "usage: ann_epoch time [--rounds R] [--epochs K] [N…] | parts | dgemm | csv N PREFIX | export N HIDDEN SEED OUT.json"
            );
            std::process::exit(2);
        }
    }
}
