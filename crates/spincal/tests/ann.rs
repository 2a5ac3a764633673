//! The network corrector end to end on synthetic turntable data.

use crate::common::synthetic::turntable_pair;
use spincal::correctors::ann::{
    full_jacobian, reduce_sweep, run_sweep_job, sweep, AnnError, AnnProblem, LmSettings, LmWorkspace,
    StopReason, SweepJobs, SweepRow, SweepRun, SweepSettings,
};
use spincal::correctors::corrector::{Axis, Corrector};
use spincal::correctors::division::{DivisionMode, Part};
use spincal::correctors::linear::LinearModel;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};

const XY: [Axis; 2] = [Axis::X, Axis::Y];

#[test]
fn jacobian_with_delays_matches_finite_differences() {
    let (measured, reference) = turntable_pair(400, 1);
    for (delays, hidden) in [(0usize, vec![5]), (3, vec![4, 3]), (2, vec![3, 2, 2])] {
        let problem = AnnProblem::new(&measured, &reference, &XY, delays, DivisionMode::Contiguous).unwrap();
        let layout = problem.layout(&hidden).unwrap();
        let weights = problem.initial_weights(&layout, 11, 0);
        let mut data = problem.train.clone();
        data.inputs.truncate(30 * data.n_inputs);
        data.targets.truncate(30 * data.n_outputs);
        let jacobian = full_jacobian(&layout, &weights, &data);
        let mut activations = vec![0.0; layout.n_activations()];
        let out_at = layout.n_activations() - layout.outputs();
        let outputs = |w: &[f64], row: usize, activations: &mut [f64]| -> Vec<f64> {
            let n_in = layout.inputs();
            layout.forward(w, &data.inputs[row * n_in..(row + 1) * n_in], activations);
            activations[out_at..].to_vec()
        };
        let h = 1e-6;
        for p in 0..layout.n_params() {
            let (mut plus, mut minus) = (weights.clone(), weights.clone());
            plus[p] += h;
            minus[p] -= h;
            for row in 0..data.len() {
                let up = outputs(&plus, row, &mut activations);
                let down = outputs(&minus, row, &mut activations);
                for k in 0..layout.outputs() {
                    let numeric = (up[k] - down[k]) / (2.0 * h);
                    let analytic = jacobian[(row * layout.outputs() + k, p)];
                    let scale = analytic.abs().max(numeric.abs()).max(1e-3);
                    assert!(
                        (numeric - analytic).abs() <= 1e-6 * scale,
                        "delays {delays} hidden {hidden:?} param {p} row {row} output {k}: {analytic} vs {numeric}"
                    );
                }
            }
        }
    }
}

#[test]
fn blocked_normal_equations_equal_the_full_jacobian_products() {
    let (measured, reference) = turntable_pair(500, 2);
    // No hidden layer, one, two and three; one output and two.
    for (axes, hidden) in [
        (&XY[..], vec![6, 4]),
        (&XY[..], vec![10, 6]),
        (&XY[..], vec![]),
        (&XY[..1], vec![5]),
        (&XY[..], vec![3, 2, 2]),
    ] {
        let problem = AnnProblem::new(&measured, &reference, axes, 1, DivisionMode::Contiguous).unwrap();
        let layout = problem.layout(&hidden).unwrap();
        let weights = problem.initial_weights(&layout, 3, 1);
        // 37 does not divide the 299 training samples: the last block is partial.
        let mut workspace = LmWorkspace::new(&layout, 37);
        let sse = workspace.normal_equations(&weights, &problem.train, None);
        let jacobian = full_jacobian(&layout, &weights, &problem.train);
        let jtj = jacobian.transpose() * &jacobian;
        let n_out = problem.train.n_outputs;
        let mut expected_sse = 0.0;
        let mut errors = vec![0.0; jacobian.nrows()];
        let mut activations = vec![0.0; layout.n_activations()];
        let out_at = layout.n_activations() - n_out;
        for row in 0..problem.train.len() {
            let n_in = layout.inputs();
            layout.forward(
                &weights,
                &problem.train.inputs[row * n_in..(row + 1) * n_in],
                &mut activations,
            );
            for k in 0..n_out {
                let e = problem.train.targets[row * n_out + k] - activations[out_at + k];
                errors[row * n_out + k] = e;
                expected_sse += e * e;
            }
        }
        assert!((sse - expected_sse).abs() <= 1e-10 * expected_sse);
        for j in 0..layout.n_params() {
            for i in j..layout.n_params() {
                let got = workspace.jtj()[(i, j)];
                assert!(
                    (got - jtj[(i, j)]).abs() <= 1e-9 * (1.0 + jtj[(i, j)].abs()),
                    "{hidden:?}: JᵀJ[{i},{j}] {got} vs {}",
                    jtj[(i, j)]
                );
            }
            let jte: f64 = (0..jacobian.nrows()).map(|r| jacobian[(r, j)] * errors[r]).sum();
            assert!(
                (workspace.jte()[(j, 0)] - jte).abs() <= 1e-9 * (1.0 + jte.abs()),
                "{hidden:?}: Jᵀe[{j}]"
            );
        }
    }
}

#[test]
fn subsampled_normal_equations_scale_the_chosen_blocks_and_keep_the_full_gradient() {
    let (measured, reference) = turntable_pair(500, 2);
    let problem = AnnProblem::new(&measured, &reference, &XY, 1, DivisionMode::Contiguous).unwrap();
    let layout = problem.layout(&[6, 4]).unwrap();
    let weights = problem.initial_weights(&layout, 3, 1);
    let mut full = LmWorkspace::new(&layout, 37);
    let full_sse = full.normal_equations(&weights, &problem.train, None);
    // 299 samples in 9 blocks of 37; about 80 samples asked for: 3 blocks, every third (0, 3, 6).
    let mut sub = LmWorkspace::new(&layout, 37);
    let sse = sub.normal_equations(&weights, &problem.train, Some(80));
    assert_eq!(sse, full_sse, "the error always uses every sample");
    let n_p = layout.n_params();
    for j in 0..n_p {
        let (got, all) = (sub.jte()[(j, 0)], full.jte()[(j, 0)]);
        // Same terms, summed in another order for the blocks outside JᵀJ.
        assert!(
            (got - all).abs() <= 1e-12 * (1.0 + all.abs()),
            "Jᵀe[{j}] uses every sample: {got} vs {all}"
        );
    }
    let jacobian = full_jacobian(&layout, &weights, &problem.train);
    let n_out = problem.train.n_outputs;
    let chosen: Vec<usize> = [0..37, 111..148, 222..259].into_iter().flatten().collect();
    let scale = 299.0 / chosen.len() as f64;
    for j in 0..n_p {
        for i in j..n_p {
            let expected: f64 = chosen
                .iter()
                .flat_map(|&row| (0..n_out).map(move |k| row * n_out + k))
                .map(|r| jacobian[(r, i)] * jacobian[(r, j)])
                .sum::<f64>()
                * scale;
            let got = sub.jtj()[(i, j)];
            assert!(
                (got - expected).abs() <= 1e-9 * (1.0 + expected.abs()),
                "JᵀJ[{i},{j}]: {got} vs {expected}"
            );
        }
    }
}

#[test]
fn a_subsampled_gauss_newton_matrix_trains_about_as_well() {
    let (measured, reference) = turntable_pair(8000, 4);
    let problem = AnnProblem::new(&measured, &reference, &XY, 0, DivisionMode::Contiguous).unwrap();
    let layout = problem.layout(&[6]).unwrap();
    let exact = LmSettings::default();
    let screened = LmSettings {
        hessian_samples: Some(1024),
        ..LmSettings::default()
    };
    for restart in 0..3 {
        let (_, full) = problem.train_once(&layout, 11, restart, &exact);
        let (_, sub) = problem.train_once(&layout, 11, restart, &screened);
        // Every accepted step lowers the full training error.
        assert!(sub.train_mse.windows(2).all(|w| w[1] < w[0]), "{sub:?}");
        assert!(
            sub.best_validation_mse() <= 2.0 * full.best_validation_mse(),
            "restart {restart}: subsampled {} vs exact {}",
            sub.best_validation_mse(),
            full.best_validation_mse()
        );
    }
}

#[test]
fn keeping_the_accepted_trial_pass_changes_no_bit_of_training() {
    let (measured, reference) = turntable_pair(2500, 6);
    let problem = AnnProblem::new(&measured, &reference, &XY, 1, DivisionMode::Contiguous).unwrap();
    let layout = problem.layout(&[7, 4]).unwrap();
    // A last block shorter than the others, and a subsampled Gauss–Newton matrix too.
    for (block, hessian_samples) in [(96, None), (96, Some(500)), (10_000, None)] {
        let settings = LmSettings {
            max_epochs: 25,
            block_samples: block,
            hessian_samples,
            ..LmSettings::default()
        };
        let run = |budget: usize| {
            let mut workspace = LmWorkspace::new(&layout, block);
            workspace.set_activation_budget(budget);
            let mut weights = problem.initial_weights(&layout, 3, 1);
            let report = workspace.train(&mut weights, &problem.train, &problem.validation, &settings);
            (weights, report)
        };
        let (kept_weights, kept) = run(usize::MAX);
        let (fresh_weights, fresh) = run(0);
        assert!(kept.epochs > 5, "{kept:?}");
        assert_eq!(
            kept.train_mse, fresh.train_mse,
            "block {block}, {hessian_samples:?}"
        );
        assert_eq!(kept.validation_mse, fresh.validation_mse);
        assert_eq!(kept.stop, fresh.stop);
        assert_eq!(kept_weights, fresh_weights);
    }
}

#[test]
fn training_lowers_the_error_every_epoch_and_keeps_the_best_validation_epoch() {
    let (measured, reference) = turntable_pair(3000, 3);
    let problem = AnnProblem::new(&measured, &reference, &XY, 0, DivisionMode::Contiguous).unwrap();
    let layout = problem.layout(&[5]).unwrap();
    let settings = LmSettings::default();
    let (weights, report) = problem.train_once(&layout, 5, 0, &settings);
    assert!(report.epochs > 3, "{report:?}");
    assert_eq!(report.train_mse.len(), report.epochs + 1);
    assert!(
        report.train_mse.windows(2).all(|w| w[1] < w[0]),
        "LM accepts only decreasing steps"
    );
    let best = report.validation_mse[report.best_epoch];
    assert!(report.validation_mse.iter().all(|&v| v >= best));
    let mut workspace = LmWorkspace::new(&layout, 64);
    assert_eq!(
        workspace.mse(&weights, &problem.validation),
        best,
        "kept weights are the best epoch's"
    );
    if report.stop == StopReason::ValidationStop {
        assert_eq!(
            report.epochs - report.best_epoch,
            settings.max_validation_failures
        );
    }
}

#[test]
fn weights_are_bit_identical_across_runs_and_thread_counts() {
    let (measured, reference) = turntable_pair(1500, 4);
    let problem = AnnProblem::new(
        &measured,
        &reference,
        &XY,
        1,
        DivisionMode::Interleaved { block_len: 50 },
    )
    .unwrap();
    let settings = SweepSettings {
        grid: vec![vec![2], vec![4], vec![3, 2]],
        restarts: 3,
        base_seed: 99,
        lm: LmSettings {
            max_epochs: 30,
            ..LmSettings::default()
        },
    };
    let in_pool = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| sweep(&problem, &settings, &|_| {}).unwrap())
    };
    let one = in_pool(1);
    let two = in_pool(2);
    assert_eq!(one.len(), 3);
    for (a, b) in one.iter().zip(&two) {
        assert_eq!(
            a.best_validation_mse.to_bits(),
            b.best_validation_mse.to_bits(),
            "{}",
            a.architecture
        );
        assert_eq!(a.test_fit_percent.to_bits(), b.test_fit_percent.to_bits());
        assert_eq!((a.epochs, a.best_restart), (b.epochs, b.best_restart));
    }
    // train() reproduces the sweep's pick for the same seed, bit for bit, run after run.
    let first = problem.train(&[3, 2], 3, 99, &settings.lm).unwrap();
    let again = problem.train(&[3, 2], 3, 99, &settings.lm).unwrap();
    assert_eq!(first.network.weights, again.network.weights);
    let summary = first.training.as_ref().unwrap();
    assert_eq!(
        summary.report.best_validation_mse().to_bits(),
        one[2].best_validation_mse.to_bits()
    );
}

/// A sweep's rows without their timings (the only field that depends on where a run ran).
fn untimed(rows: &[SweepRow]) -> Vec<SweepRow> {
    rows.iter()
        .map(|r| SweepRow {
            seconds: 0.0,
            ..r.clone()
        })
        .collect()
}

#[test]
fn a_sweep_run_elsewhere_from_its_exchanged_jobs_equals_the_local_sweep_bit_for_bit() {
    let (measured, reference) = turntable_pair(1500, 5);
    let problem = AnnProblem::new(&measured, &reference, &XY, 2, DivisionMode::Contiguous).unwrap();
    let settings = SweepSettings {
        grid: vec![vec![3], vec![2, 2], vec![5]],
        restarts: 2,
        base_seed: 17,
        lm: LmSettings {
            max_epochs: 25,
            ..LmSettings::default()
        },
    };
    let local = sweep(&problem, &settings, &|_| {}).unwrap();

    // A "worker": only the jobs' JSON reaches it; its runs come back as JSON, in any order.
    let jobs_text = SweepJobs::new(&problem, &settings).to_json();
    let jobs = SweepJobs::from_json(&jobs_text).unwrap();
    assert_eq!(jobs.len(), 6);
    let remote_problem = jobs.problem();
    let runs_text: Vec<String> = (0..jobs.len())
        .rev()
        .map(|job| {
            run_sweep_job(&remote_problem, &jobs.settings, job)
                .unwrap()
                .to_json()
        })
        .collect();
    let runs: Vec<SweepRun> = runs_text
        .iter()
        .map(|t| SweepRun::from_json(t).unwrap())
        .collect();
    // A run survives the trip bit for bit, NaN included.
    let mut odd = runs[0].clone();
    odd.report.validation_mse[0] = f64::NAN;
    let back = SweepRun::from_json(&odd.to_json()).unwrap();
    assert!(back.report.validation_mse[0].is_nan());
    assert_eq!(back.weights, odd.weights);

    let distributed = reduce_sweep(&problem, &settings, runs.clone()).unwrap();
    assert_eq!(untimed(&distributed), untimed(&local));
    for (a, b) in distributed.iter().zip(&local) {
        assert_eq!(a.best_validation_mse.to_bits(), b.best_validation_mse.to_bits());
    }

    // Missing, doubled and foreign runs are refused, naming the job.
    let refused = |runs: Vec<SweepRun>| match reduce_sweep(&problem, &settings, runs) {
        Err(AnnError::SweepExchange(why)) => why,
        other => panic!("expected a refusal, got {other:?}"),
    };
    assert!(refused(runs[1..].to_vec()).contains("job 5"));
    let mut doubled = runs.clone();
    doubled[0] = runs[1].clone();
    assert!(refused(doubled).contains("twice"));
    let mut short = runs.clone();
    short[2].weights.pop();
    assert!(refused(short).contains("weights"));
    assert!(run_sweep_job(&problem, &settings, 6).is_err());
    let newer = jobs_text.replace("\"version\":1", "\"version\":2");
    assert!(SweepJobs::from_json(&newer)
        .unwrap_err()
        .to_string()
        .contains("version 2"));
    let greedy = jobs_text.replace("\"restarts\":2", "\"restarts\":99999999");
    assert!(SweepJobs::from_json(&greedy)
        .unwrap_err()
        .to_string()
        .contains("restarts"));
    let cut = &jobs_text[..jobs_text.len() / 2];
    assert!(SweepJobs::from_json(cut).is_err());
}

#[test]
fn network_beats_linear_beats_uncorrected_on_the_test_part() {
    let (measured, reference) = turntable_pair(6000, 5);
    let problem = AnnProblem::new(&measured, &reference, &XY, 0, DivisionMode::Contiguous).unwrap();
    let ann = problem.train(&[8], 3, 1, &LmSettings::default()).unwrap();
    let linear = LinearModel::fit(&measured, &reference, &XY, DivisionMode::Contiguous).unwrap();
    let ann_fit = ann.training.as_ref().unwrap().fits.clone();
    let linear_fit = linear.training.as_ref().unwrap().fits.clone();
    let raw_fit = problem.uncorrected_fits();
    eprintln!(
        "test fit % (x, y): network {:?}, linear {:?}, uncorrected {:?}",
        ann_fit.test, linear_fit.test, raw_fit.test
    );
    for c in 0..2 {
        assert!(
            ann_fit.test[c] > linear_fit.test[c] + 3.0,
            "axis {c}: {ann_fit:?} vs {linear_fit:?}"
        );
        assert!(
            linear_fit.test[c] > raw_fit.test[c] + 5.0,
            "axis {c}: {linear_fit:?} vs {raw_fit:?}"
        );
    }
    assert_eq!(linear.training.as_ref().unwrap().uncorrected, raw_fit);
}

#[test]
fn saved_models_round_trip_and_apply_identically() {
    let (measured, reference) = turntable_pair(1200, 6);
    let problem = AnnProblem::new(&measured, &reference, &XY, 2, DivisionMode::Contiguous).unwrap();
    let ann = problem.train(&[4], 1, 2, &LmSettings::default()).unwrap();
    let linear = LinearModel::fit(&measured, &reference, &Axis::ALL, DivisionMode::Contiguous).unwrap();
    for model in [
        CorrectorModel::Ann(Box::new(ann)),
        CorrectorModel::Linear(Box::new(linear)),
    ] {
        let file = CorrectorFile::new(model);
        let text = file.to_json();
        let back = CorrectorFile::from_json(&text, "model.json").unwrap();
        assert!(back == file, "{} round trip is not exact", file.corrector.kind());
        assert!(back.corrector.correct(&measured) == file.corrector.correct(&measured));
        // The same file with another version is refused, naming the file and both versions.
        let future = text.replacen("\"format_version\": 4", "\"format_version\": 5", 1);
        let message = CorrectorFile::from_json(&future, "future.json")
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("future.json")
                && message.contains("format_version 5")
                && message.contains("format_version 1 to 4"),
            "{message}"
        );
    }
}

#[test]
fn streaming_correction_matches_batch_application() {
    let (measured, reference) = turntable_pair(1500, 7);
    let problem = AnnProblem::new(&measured, &reference, &XY, 3, DivisionMode::Contiguous).unwrap();
    let model = problem
        .train(
            &[5, 3],
            1,
            4,
            &LmSettings {
                max_epochs: 20,
                ..LmSettings::default()
            },
        )
        .unwrap();
    let streamed = model.correct(&measured);
    let batch = model.correct_batch(&measured);
    assert!(streamed.valid[..3].iter().all(|v| !v));
    assert!(streamed.valid[3..].iter().all(|&v| v));
    for (c, axis) in XY.iter().enumerate() {
        // Samples without full history are passed through unchanged.
        assert_eq!(
            &streamed.accel_mps2[axis.index()][..3],
            &measured.accel_mps2[axis.index()][..3]
        );
        for (i, v) in batch[c].iter().enumerate() {
            let s = streamed.accel_mps2[axis.index()][i + 3];
            assert!(
                (s - v).abs() <= 1e-12 * v.abs().max(1.0),
                "axis {axis} sample {}: {s} vs {v}",
                i + 3
            );
        }
    }
    assert_eq!(
        streamed.accel_mps2[2], measured.accel_mps2[2],
        "z is not corrected and passes through"
    );
    let fits = model.training.as_ref().unwrap().fits.clone();
    assert!(fits.mean(Part::Test).is_finite());

    // Inputs within the training range are not flagged; a recording with twice the y swing is,
    // on the samples that leave the range by more than the margin, and those go through
    // uncorrected and invalid (a network extrapolates there).
    assert_eq!(streamed.outside_training_range, 0);
    let mut louder = measured.clone();
    let mean = louder.accel_mps2[1].iter().sum::<f64>() / louder.len() as f64;
    for v in &mut louder.accel_mps2[1] {
        *v = mean + 2.0 * (*v - mean);
    }
    let (low, high) = (model.input_scaling.min[1], model.input_scaling.max[1]);
    let margin = spincal::correctors::ann::EXTRAPOLATION_MARGIN * (high - low);
    let expected = louder.accel_mps2[1]
        .iter()
        .filter(|&&v| v < low - margin || v > high + margin)
        .count();
    let corrected = model.correct(&louder);
    assert!(
        expected > louder.len() / 10,
        "the test signal leaves the range: {expected}"
    );
    assert_eq!(corrected.outside_training_range, expected);
    assert!(corrected.accel_mps2[1].iter().all(|v| v.is_finite()));
    for (s, &v) in louder.accel_mps2[1].iter().enumerate().skip(3) {
        let outside = v < low - margin || v > high + margin;
        if outside {
            assert!(!corrected.valid[s]);
            assert_eq!(corrected.accel_mps2[1][s], v);
        }
    }
    assert!(corrected.valid.iter().skip(3).any(|&v| v));
}

/// The paper's single-speed case: calibrated on one 33⅓ rpm recording, nothing can be held out,
/// so nothing is saved, with the reason, which parameters the recording determines and what to
/// record next. Calibrated on 33⅓ and 45 rpm (each held out in turn) nothing is saved either:
/// two turntable runs at one radius do not determine the sensor's biases and scales (README's
/// quick start), measured on all five seeds (2026-11-29: saved in 0 of 5), so the verdict says
/// so instead of a model that was never checked on a condition it did not train on. Five seeds.
#[test]
fn a_turntable_only_calibration_saves_nothing_and_says_why() {
    use spincal::calibrate::calibrate;
    use spincal::campaign::params::{NetworkChoice, Params};
    use spincal::simulate::{simulate, SensorProfile, TurntableSetup};
    use spincal::turntable::fit::{FitOptions, RadiusPrior};
    let settings = Params {
        fit: FitOptions {
            radius: Some(RadiusPrior {
                value_m: 0.10,
                tolerance_m: 0.002,
            }),
            ..FitOptions::default()
        },
        network: NetworkChoice::Fixed {
            hidden: vec![8, 6],
            restarts: 2,
        },
        sysid: Vec::new(),
        ..Params::default()
    };
    let sensor = SensorProfile::default();
    let at = |rpm: f64, seed: u64| {
        simulate(
            &sensor,
            &TurntableSetup {
                rpm,
                ..TurntableSetup::default()
            },
            seed,
        )
        .unwrap()
    };
    for seed in 0..5 {
        let trained_on = simulate(&sensor, &TurntableSetup::default(), seed).unwrap();
        let alone = calibrate(std::slice::from_ref(&trained_on.recording), &settings, &|_| {}).unwrap();
        let verdict = &alone.result.verdict;
        assert!(alone.saved.is_none() && !alone.result.validated_off_training_condition);
        assert!(
            verdict.starts_with("Nothing saved") && verdict.contains("Record next"),
            "{verdict}"
        );
        // It says which parameters this one recording determines, and what it cannot.
        let fit = &alone.result.paper.as_ref().unwrap().turntable;
        assert!(verdict.contains("This recording determines"), "{verdict}");
        for p in fit.params.iter().filter(|p| p.determined) {
            assert!(verdict.contains(&p.name), "{} missing", p.name);
        }
        if let Some(remedy) = &fit.remedy {
            assert!(verdict.contains(remedy.as_str()));
        }

        let both = [trained_on.recording.clone(), at(45.0, seed + 100).recording];
        let out = calibrate(&both, &settings, &|_| {}).unwrap();
        let verdict = &out.result.verdict;
        assert!(
            out.saved.is_none(),
            "seed {seed}: saved {:?}: {verdict}",
            out.result.saved
        );
        assert!(
            verdict.starts_with("Nothing saved") && verdict.contains("Record next"),
            "seed {seed}: {verdict}"
        );
    }
}
