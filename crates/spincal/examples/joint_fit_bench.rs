//! Speed benchmark of the joint campaign fit (tracker issue 13) against a scipy peer
//! (`bench/campaign/scipy_joint.py`).
//!
//! Usage: `joint_fit_bench SEED OUT_DIR [REPETITIONS]`
//!
//! Simulates a campaign of 6 still poses and the default 4 turntable runs at 2 minutes each
//! (100 Hz), cuts it into the fit's inputs with `campaign::prepare`, and writes for the peer
//! `OUT_DIR/problem.json`: every run's samples, keep mask and nominal entry, every pose, the
//! settings, the mounting matrices, the rotation senses and the fit's starting vector. It then
//! times `fit_joint` (one warm-up call, then REPETITIONS calls: best and median) and writes
//! `OUT_DIR/spincal_fit.json` with every fitted parameter the public API exposes.
//!
//! The starting vector comes from `campaign::joint::run_start`, the first pass's weights from
//! `difference_noise`. What is not reachable from outside the crate: the weights of the second pass (`JointProblem::run_sigma`/`pose_sigma`, pub(crate)) and the still
//! session's bias offset and drift (only in the pub(crate) `FitState`). The peer then does what
//! `fit_joint` does: solve with those weights, reweight from the residuals (per run and axis; a
//! variance component per still session), estimate the bias offsets' spread (`bias_spread`,
//! written here for comparison), solve again. The campaign is `tests/common/joint_bench.rs`,
//! shared with the suite's scipy fixture test (`tests/joint_scipy.rs`).
//!
//! Run single-threaded (RAYON_NUM_THREADS=1, `taskset -c 1`); `fit_joint` itself does not use
//! rayon, faer is built without it.

use std::time::Instant;

use serde_json::{json, Value};
use spincal::campaign::joint::{
    difference_noise, fit_joint, mounting_matrix, run_start, JointSettings, RUN_PARAMS,
};

// The campaign's setup, shared with the scipy fixture test (tests/joint_scipy.rs).
#[path = "../tests/common/joint_bench.rs"]
mod joint_bench;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let usage = "usage: joint_fit_bench SEED OUT_DIR [REPETITIONS]";
    let seed: u64 = args.next().expect(usage).parse().expect(usage);
    let out_dir = std::path::PathBuf::from(args.next().expect(usage));
    let reps: usize = args.next().map_or(5, |s| s.parse().expect(usage)).max(1);
    std::fs::create_dir_all(&out_dir).expect("cannot create the output directory");

    let (sim, prep) = joint_bench::bench_campaign(seed).expect("the bench's campaign");
    let settings = JointSettings::default();
    let g = settings.gravity_mps2;

    // The starting vector (sensor 12, then 15 per run, 2 per pose, 6 per still session: all zero
    // but the runs' geometry) and what the peer needs besides the data.
    let n_sessions = prep.poses.iter().map(|p| p.session + 1).max().unwrap_or(0);
    let n_params = 12 + RUN_PARAMS * prep.runs.len() + 2 * prep.poses.len() + 6 * n_sessions;
    let mut start = vec![0.0; n_params];
    let mut directions = Vec::new();
    let mut mountings = Vec::new();
    for (i, run) in prep.runs.iter().enumerate() {
        let q = mounting_matrix(run.entry.out, run.entry.up);
        let (s, sigma) = run_start(run, g);
        start[12 + RUN_PARAMS * i..12 + RUN_PARAMS * (i + 1)].copy_from_slice(&s);
        directions.push(sigma);
        mountings.push(q);
    }
    // The starting values' share of fit_joint's time (the same computation, timed alone).
    let mut start_times = Vec::with_capacity(reps);
    for _ in 0..reps {
        // Fresh copies: a run keeps its demodulation once found, and the first fit finds it.
        let fresh: Vec<_> = prep
            .runs
            .iter()
            .map(|r| r.with_readings(r.accel_mps2.clone(), r.keep.clone()))
            .collect();
        let t = Instant::now();
        for run in &fresh {
            std::hint::black_box(run_start(run, g));
        }
        start_times.push(t.elapsed().as_secs_f64());
    }
    let start_best = start_times.iter().copied().fold(f64::INFINITY, f64::min);
    let start_s = median(&mut start_times.clone());
    // Check the recomputed start against spincal's own: with no iterations allowed, both passes
    // return their starting point, so the fit's parameters are its starting vector.
    let frozen = fit_joint(
        &prep.runs,
        &prep.poses,
        &JointSettings {
            max_iterations: 0,
            ..settings.clone()
        },
        &spincal::progress::silent,
    )
    .expect("fit with no iterations");
    let spincal_start: Vec<f64> = frozen
        .sensor_params
        .iter()
        .chain(frozen.runs.iter().flat_map(|r| r.params.iter()))
        .chain(frozen.poses.iter().flat_map(|p| p.params.iter()))
        .map(|p| p.value)
        .collect();
    let start_mismatch = spincal_start
        .iter()
        .zip(&start)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f64, f64::max);
    assert!(
        start_mismatch == 0.0,
        "the recomputed starting vector differs from fit_joint's by up to {start_mismatch:e}"
    );

    let runs_json: Vec<Value> = prep
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            json!({
                "name": r.name,
                "time_s": r.time_s,
                "accel_mps2": r.accel_mps2,
                "keep": r.keep,
                "rpm": r.entry.rpm,
                "radius_m": r.entry.radius.map(|s| s.value_m),
                "radius_tol_m": r.entry.radius.map(|s| s.tolerance_m),
                // The peer implements neither ties (runs sharing a session or a placement).
                "session": r.session,
                "placement": r.entry.placement,
                "out": r.entry.out.name(),
                "up": r.entry.up.name(),
                "mounting": mountings[i],
                "direction": directions[i],
                "first_pass_sigma_mps2": difference_noise(&r.accel_mps2, &r.keep),
            })
        })
        .collect();
    let problem = json!({
        "seed": seed,
        "gravity_mps2": g,
        "settings": settings,
        "lm": { "cost_tolerance": 1e-12, "step_tolerance": 1e-10 },
        "layout": "12 sensor, 15 per run, 2 per pose, 6 per still session",
        "n_params": n_params,
        "start": start,
        "runs": runs_json,
        "poses": prep.poses,
        "truth": sim.truth,
    });
    std::fs::write(
        out_dir.join("problem.json"),
        serde_json::to_vec(&problem).unwrap(),
    )
    .expect("cannot write problem.json");

    // Timing: one warm-up call, then `reps` calls.
    let fit_once = || fit_joint(&prep.runs, &prep.poses, &settings, &spincal::progress::silent).expect("fit");
    let warm = Instant::now();
    let mut fit = fit_once();
    let warm_s = warm.elapsed().as_secs_f64();
    let mut times = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t = Instant::now();
        fit = std::hint::black_box(fit_once());
        times.push(t.elapsed().as_secs_f64());
    }
    let best = times.iter().copied().fold(f64::INFINITY, f64::min);
    let med = median(&mut times.clone());

    // One more (untimed) call that records the cost after each accepted LM step (both passes).
    let trace = std::sync::Mutex::new(Vec::<(usize, f64)>::new());
    let observer = |p: spincal::progress::Progress<'_>| {
        if let Some(c) = p.cost {
            trace.lock().unwrap().push((p.done, c));
        }
    };
    fit_joint(&prep.runs, &prep.poses, &settings, &observer).expect("fit");
    let trace = trace.into_inner().unwrap();

    // Every exposed parameter in the fit's layout order (the still session's 6 are not exposed).
    let mut values = Vec::new();
    let mut errors = Vec::new();
    let mut names = Vec::new();
    let mut push = |prefix: &str, p: &spincal::campaign::joint::JointParam| {
        names.push(format!("{prefix}{}", p.name));
        values.push(p.value);
        errors.push(p.std_error);
    };
    for p in &fit.sensor_params {
        push("sensor: ", p);
    }
    for (i, r) in fit.runs.iter().enumerate() {
        for p in &r.params {
            push(&format!("run {i}: "), p);
        }
    }
    for (i, pose) in fit.poses.iter().enumerate() {
        for p in &pose.params {
            push(&format!("pose {i}: "), p);
        }
    }
    let result = json!({
        "seed": seed,
        "names": names,
        "values": values,
        "std_errors": errors,
        "chi2": fit.chi2,
        "dof": fit.dof,
        "iterations_both_passes": fit.iterations,
        "stop": fit.stop,
        "bias_spread": fit.bias_spread,
        "directions": fit.runs.iter().map(|r| r.direction).collect::<Vec<_>>(),
        "residual_rms_mps2": fit.runs.iter().map(|r| r.residual_rms_mps2).collect::<Vec<_>>(),
        "samples_used": fit.runs.iter().map(|r| r.samples_used).sum::<usize>(),
        "pose_specific_force_mps2": fit.poses.iter().map(|p| p.specific_force_mps2).collect::<Vec<_>>(),
        "accepted_steps_cost": trace,
        "timing": {
            "repetitions": reps,
            "warmup_s": warm_s,
            "times_s": times,
            "best_s": best,
            "median_s": med,
            "start_values_s_example_reimplementation": start_s,
            "start_values_times_s": start_times,
            "start_values_best_s": start_best,
            "start_vector_matches_fit_joint": start_mismatch == 0.0,
        },
    });
    std::fs::write(
        out_dir.join("spincal_fit.json"),
        serde_json::to_string_pretty(&result).unwrap(),
    )
    .expect("cannot write spincal_fit.json");
    println!("{}", serde_json::to_string_pretty(&result).unwrap());
    eprintln!(
        "spincal fit_joint: {} params, {} samples, {} iterations (both passes), stop {:?}, chi2 {:.6e}; best {:.4} s, median {:.4} s of {}",
        n_params,
        fit.runs.iter().map(|r| r.samples_used).sum::<usize>(),
        fit.iterations,
        fit.stop,
        fit.chi2,
        best,
        med,
        reps
    );
}
