//! Campaign calibration: the joint fit recovers what it simulated (with honest standard errors),
//! the fitted sensor model corrects a run it never saw, and nothing is saved that could not be
//! checked on a held-out condition.

use spincal::campaign::candidate::CandidateKind;
use spincal::campaign::joint::{fit_joint, JointSettings, SensorTerms};
use spincal::campaign::params::Params;
use spincal::campaign::prepare::prepare;
use spincal::campaign::select::calibrate_campaign;
use spincal::campaign::verdict::Comparison;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::correctors::physical::{quadratic_from_datasheet, PhysicalCorrector};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup, RunSetup};

use crate::common::campaign_units as units;

/// Simulates the campaign with `seed` and calibrates it (truth attached) with `settings`.
fn calibrated(
    setup: &CampaignSetup,
    seed: u64,
    settings: &Params,
) -> spincal::campaign::select::CampaignOutput {
    let sim = simulate_campaign(setup, seed).unwrap();
    calibrate_campaign("u", &units(&sim, true), settings, &spincal::progress::silent).unwrap()
}

fn wrapped(d: f64) -> f64 {
    (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

/// Over 20 seeds of the default campaign (bias, scale, misalignment, nonlinearity, noise, drift,
/// wow and flutter), the true sensor parameters and each run's geometry (r, ω, α, ϑ₀, β, mount
/// tilts, wow) lie within 3 reported standard errors at least 90 % of the time.
#[test]
fn standard_errors_cover_the_truth_over_20_seeds() {
    let mut inside = 0usize;
    let mut total = 0usize;
    let mut worst_scale = 0.0f64;
    let mut worst_misalignment = 0.0f64;
    let mut worst_bias = 0.0f64;
    for seed in 0..20 {
        let sim = simulate_campaign(&CampaignSetup::default(), seed).unwrap();
        let prepared = prepare(&units(&sim, false)).unwrap();
        let fit = fit_joint(
            &prepared.runs,
            &prepared.poses,
            &JointSettings::default(),
            &spincal::progress::silent,
        )
        .unwrap();
        let truth = sim.truth.sensor.params();
        for (k, p) in fit.sensor_params.iter().enumerate() {
            let se = p.std_error.expect("every sensor parameter has a standard error");
            total += 1;
            inside += usize::from((p.value - truth[k]).abs() <= 3.0 * se);
            let error = (p.value - truth[k]).abs();
            match k {
                0..=2 => worst_bias = worst_bias.max(error),
                3..=5 => worst_scale = worst_scale.max(error),
                6..=8 => worst_misalignment = worst_misalignment.max(error),
                _ => {}
            }
        }
        for (i, run) in fit.runs.iter().enumerate() {
            for j in 0..9 {
                let p = &run.params[j];
                let se = p.std_error.expect("every run parameter has a standard error");
                let mut d = p.value - sim.truth.runs[i][j];
                if j == 3 || j == 4 {
                    d = wrapped(d);
                }
                total += 1;
                inside += usize::from(d.abs() <= 3.0 * se);
            }
        }
    }
    let coverage = inside as f64 / total as f64;
    println!(
        "coverage {inside}/{total} = {coverage:.3}; worst errors: bias {worst_bias:.4} m/s², scale {worst_scale:.5}, misalignment {worst_misalignment:.5} rad"
    );
    assert!(coverage >= 0.9, "coverage {coverage}");
}

/// The sensor model fitted on the default campaign corrects a run at a speed, radius and mounting
/// the campaign never had (78 rpm, sensor on its side) far better than no correction, against the
/// true specific force.
#[test]
fn the_fitted_sensor_model_corrects_an_unseen_run() {
    for seed in [3, 4] {
        let mut setup = CampaignSetup::default();
        setup.runs.push(RunSetup {
            rpm: 78.0,
            radius_m: 0.10,
            out: spincal::campaign::file::SignedAxis::parse("+y").unwrap(),
            up: spincal::campaign::file::SignedAxis::parse("-x").unwrap(),
            ..RunSetup::default()
        });
        let sim = simulate_campaign(&setup, seed).unwrap();
        let mut prepared = prepare(&units(&sim, false)).unwrap();
        prepared.runs.pop();
        let settings = JointSettings {
            terms: SensorTerms::LINEAR,
            ..JointSettings::default()
        };
        let fit = fit_joint(
            &prepared.runs,
            &prepared.poses,
            &settings,
            &spincal::progress::silent,
        )
        .unwrap();
        let unseen = sim.recordings.last().unwrap();
        let (mut corrected, mut raw) = (0.0, 0.0);
        for s in 0..unseen.recording.len() {
            let m: [f64; 3] = std::array::from_fn(|k| unseen.recording.accel_mps2[k][s]);
            let f = fit.sensor.correct(m).unwrap();
            for k in 0..3 {
                corrected += (f[k] - unseen.true_accel_mps2[k][s]).powi(2);
                raw += (m[k] - unseen.true_accel_mps2[k][s]).powi(2);
            }
        }
        let floor = unseen.floor_mps2().iter().map(|f| f * f).sum::<f64>();
        let n = unseen.recording.len() as f64;
        let (corrected, raw, floor) = ((corrected / n).sqrt(), (raw / n).sqrt(), floor.sqrt());
        println!("seed {seed}: corrected {corrected:.4}, uncorrected {raw:.4}, floor {floor:.4} m/s²");
        assert!(corrected < 0.6 * raw, "seed {seed}: {corrected} vs {raw}");
    }
}

/// A campaign of one turntable run has no condition to hold out: nothing is saved, and the
/// verdict says what to record next.
#[test]
fn a_single_recording_saves_nothing_and_says_what_to_record() {
    let setup = CampaignSetup {
        poses: 0,
        runs: vec![RunSetup::default()],
        ..CampaignSetup::default()
    };
    let out = calibrated(&setup, 5, &Params::default());
    assert!(out.saved.is_none());
    assert!(out.result.saved.is_none());
    assert!(
        out.result.verdict.starts_with("Nothing saved"),
        "{}",
        out.result.verdict
    );
    assert!(
        out.result.verdict.contains("second speed or radius"),
        "{}",
        out.result.verdict
    );
    assert!(out.result.conditions.is_empty());
}

/// Whether a held-out comparison is significantly worse than uncorrected, recomputed from its
/// reported RMS values, ratio standard error and block count; `None` within 5 % of the threshold.
fn judged_worse(p: &Comparison) -> Option<bool> {
    let mean_square = |rms: [f64; 3]| rms.iter().map(|v| v * v).sum::<f64>() / 3.0;
    let (ms_c, ms_u) = (mean_square(p.rms_mps2), mean_square(p.uncorrected_rms_mps2));
    let r = (ms_c / ms_u).sqrt();
    assert!(
        (r - p.ratio).abs() <= 1e-9 * r,
        "ratio {} vs RMS values {r}",
        p.ratio
    );
    // The standard error of ms_c − ms_u from the ratio's (delta method: se_r = se / (2 r ms_u)).
    let z = (ms_c - ms_u) / (2.0 * r * ms_u * p.ratio_se);
    if z <= 0.0 {
        return Some(false);
    }
    assert!(p.blocks >= 2, "{p:?}");
    // Student's t quantile at 1 − 1e-3 by the Cornish–Fisher series in 1/ν about the normal's
    // 3.0902 (Abramowitz & Stegun 26.7.5), not the library's bisection.
    let (x, nu) = (3.090_232_306_167_813_f64, (p.blocks - 1) as f64);
    let g = [
        (x.powi(3) + x) / 4.0,
        (5.0 * x.powi(5) + 16.0 * x.powi(3) + 3.0 * x) / 96.0,
        (3.0 * x.powi(7) + 19.0 * x.powi(5) + 17.0 * x.powi(3) - 15.0 * x) / 384.0,
        (79.0 * x.powi(9) + 776.0 * x.powi(7) + 1482.0 * x.powi(5) - 1920.0 * x.powi(3) - 945.0 * x)
            / 92160.0,
    ];
    let t = x + g
        .iter()
        .enumerate()
        .map(|(k, gk)| gk / nu.powi(k as i32 + 1))
        .sum::<f64>();
    ((z / t - 1.0).abs() > 0.05 && nu >= 10.0).then_some(z > t)
}

/// Whatever is saved was never significantly worse than no correction on any held-out condition
/// by physics, the campaign's physical model (which removes most of the error) is saved, truth
/// agrees with the choice, and a saved physical corrector survives the model file.
#[test]
fn a_saved_corrector_held_on_every_condition_and_round_trips() {
    let out = calibrated(&CampaignSetup::default(), 11, &Params::default());
    assert!(!out.result.conditions.is_empty());
    let saved = out
        .result
        .saved
        .clone()
        .unwrap_or_else(|| panic!("nothing saved: {}", out.result.verdict));
    assert!(saved.starts_with("physical"), "{saved}");
    let check = out
        .result
        .truth_check
        .as_ref()
        .expect("a simulation is checked against truth");
    assert!(check.agrees, "{check:?}: {}", out.result.verdict);
    for summary in &out.result.candidates {
        let rows: Vec<_> = out
            .result
            .held_out
            .iter()
            .filter(|h| h.candidate == summary.candidate)
            .collect();
        assert_eq!(rows.len(), out.result.conditions.len());
        let worse = rows.iter().any(|h| h.physics.as_ref().is_none_or(|p| p.worse));
        let savable = summary.candidate != "arx";
        // Eligibility from the reported numbers alone, by the documented rule (verdict.rs:
        // worse when the mean-square difference exceeds t(1 − 1e-3, blocks − 1) standard errors).
        let judged: Vec<Option<bool>> = rows
            .iter()
            .map(|h| h.physics.as_ref().and_then(judged_worse))
            .collect();
        eprintln!("{}: judged worse per condition {judged:?}", summary.candidate);
        if judged.iter().all(Option::is_some) {
            let worse_here = judged.contains(&Some(true));
            assert_eq!(summary.eligible, !worse_here && savable, "{summary:?} {rows:?}");
        } else {
            // Within 5 % of the threshold the approximation below cannot decide; then only a
            // clearly worse condition is checked.
            assert!(
                !(summary.eligible && judged.contains(&Some(true))),
                "{summary:?} {rows:?}"
            );
        }
        assert_eq!(summary.eligible, !worse && savable, "{summary:?}");
        if !savable {
            // The dynamic model is scored on every held-out condition, and its verdict says why
            // it is never saved.
            assert!(rows.iter().all(|h| h.physics.is_some()), "{rows:?}");
            assert!(
                summary.why_not.as_deref().unwrap_or("").contains("scored only"),
                "{summary:?}"
            );
        }
        if saved == summary.candidate {
            assert!(!worse);
            // Held out, the saved corrector removes most of what physics can see, and most of
            // the error against truth.
            for h in &rows {
                let (p, t) = (h.physics.as_ref().unwrap(), h.truth.as_ref().unwrap());
                let figure = h.predicted.as_ref().map_or(p.ratio, |x| x.ratio);
                assert!(p.ratio < 1.0 && figure < 0.9 && t.ratio < 0.9, "{h:?}");
            }
        }
    }
    if let Some(file) = &out.saved {
        let back = CorrectorFile::from_json(&file.to_json(), "model.json").unwrap();
        assert_eq!(&back, file);
    }
    // A physical corrector with a bad field is refused by name.
    let bad = CorrectorFile::new(CorrectorModel::Physical(Box::new(PhysicalCorrector {
        sensor: spincal::correctors::physical::SensorModel {
            scale_error: [0.0, -2.0, 0.0],
            ..Default::default()
        },
        gravity_mps2: 9.8,
        input_range_mps2: [[-10.0, 10.0]; 3],
        uncertainty: None,
    })));
    let e = CorrectorFile::from_json(&bad.to_json(), "m.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("corrector.sensor.scale_error[1]"), "{e}");
}

/// The network on top of physics, trained alone: held out, never far from the physical model it
/// sits on; saved only where the verdict's checks pass (else refused by a named check), and what
/// it corrects is the physical correction plus the network's residual where the network is
/// trusted, and the physical correction alone (marked) where it is not; its file round-trips and a
/// damaged coverage is refused by name.
#[test]
fn the_network_on_top_of_physics_is_trusted_only_where_it_was_trained() {
    use spincal::campaign::candidate::{candidate, TrainingSet};
    use spincal::correctors::corrector::Corrector;
    use spincal::correctors::physical_ann::PhysicalAnnCorrector;
    let sim = simulate_campaign(&CampaignSetup::default(), 5).unwrap();
    let settings = Params {
        candidates: vec![CandidateKind::PhysicalAnn],
        ..Params::default()
    };
    let out = calibrate_campaign("u", &units(&sim, true), &settings, &spincal::progress::silent).unwrap();
    let physical_only = calibrate_campaign(
        "u",
        &units(&sim, true),
        &Params {
            candidates: vec![CandidateKind::Physical],
            ..Params::default()
        },
        &spincal::progress::silent,
    )
    .unwrap();
    let summary = &out.result.candidates[0];
    let physical = &physical_only.result.candidates[0];
    eprintln!(
        "held-out mean RMS: physical-ann {:?}, physical {:?}",
        summary.mean_truth_rms_mps2, physical.mean_truth_rms_mps2
    );
    // Where the network is not trusted it changes nothing: held out, it is never far from
    // the physical model it sits on.
    let (a, b) = (
        summary.mean_truth_rms_mps2.unwrap(),
        physical.mean_truth_rms_mps2.unwrap(),
    );
    assert!(a < 1.25 * b, "{a} vs {b}");
    // A network whose gain departs from one on a held-out fold is refused by that check, by
    // name; one that passes every check is saved and round-trips.
    match &out.saved {
        Some(file) if matches!(file.corrector, CorrectorModel::PhysicalAnn(_)) => {
            assert_eq!(
                &CorrectorFile::from_json(&file.to_json(), "model.json").unwrap(),
                file
            );
        }
        _ => {
            let why = summary.why_not.as_deref().unwrap_or_default();
            assert!(
                why.contains("gain") || why.contains("covariance"),
                "refused without a named check: {why}"
            );
            assert!(out.result.verdict.contains(why), "{}", out.result.verdict);
        }
    }

    // The network trained on the whole campaign, as the verdict would save it.
    let prepared = prepare(&units(&sim, true)).unwrap();
    let training = TrainingSet::new(prepared.runs, prepared.poses, &settings.joint);
    let trained = candidate(CandidateKind::PhysicalAnn)
        .train(&training, &spincal::progress::silent)
        .unwrap();
    let Some(CorrectorModel::PhysicalAnn(model)) = trained.saved() else {
        panic!("physical-ann trains a network on physics")
    };
    let file = CorrectorFile::new(CorrectorModel::PhysicalAnn(model.clone()));
    assert_eq!(
        &CorrectorFile::from_json(&file.to_json(), "model.json").unwrap(),
        &file
    );

    let mut stream = model.stream();
    let mut physical_stream = model.physical.stream();
    let mut network_stream = model.network.stream();
    let (mut trusted, mut untrusted) = (0, 0);
    // Readings across the whole sphere of 1 g and beyond: inside the training data's cells the
    // output is p + n(p); elsewhere p, marked.
    for i in 0..2000 {
        let (u, v) = (i as f64 * 0.618_034 % 1.0, i as f64 * 0.414_214 % 1.0);
        let (theta, phi) = (std::f64::consts::TAU * u, (2.0 * v - 1.0).acos());
        let r = 9.8 * (1.0 + 0.5 * (i % 3) as f64);
        let m = [
            r * phi.sin() * theta.cos(),
            r * phi.sin() * theta.sin(),
            r * phi.cos(),
        ];
        let out = stream.correct_sample(m);
        let p = physical_stream.correct_sample(m);
        let n = network_stream.correct_sample(p.accel_mps2);
        if model.coverage.covers(p.accel_mps2) && !out.outside_training_range {
            trusted += 1;
            for k in 0..3 {
                assert_eq!(out.accel_mps2[k], p.accel_mps2[k] + n.accel_mps2[k]);
            }
        } else {
            untrusted += 1;
            assert!(out.outside_training_range);
            assert_eq!(out.accel_mps2, p.accel_mps2);
        }
    }
    assert!(trusted > 0 && untrusted > 0, "{trusted} trusted, {untrusted} not");

    let mut damaged: PhysicalAnnCorrector = (**model).clone();
    damaged.coverage.covered.reverse();
    let bad = CorrectorFile::new(CorrectorModel::PhysicalAnn(Box::new(damaged)));
    let e = CorrectorFile::from_json(&bad.to_json(), "m.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("corrector.coverage.covered["), "{e}");
}

/// Six still poses (the faces alone) with a drifting bias (seed 2024, the demo's): a held-out pose
/// group pins little down. Whatever is saved is what truth would have chosen. When the evidence
/// cannot show any corrector no worse than none, nothing is saved, and the verdict gives the bound
/// that fell short (or the covariance's prediction) and what to record next. Truth sees errors
/// physics cannot, so it may then know a corrector that would have helped: that is the price of
/// the burden of proof, and it is reported as a disagreement, not hidden.
#[test]
fn six_poses_save_what_truth_would_or_show_why_nothing_can_be_shown() {
    let setup = CampaignSetup {
        poses: 6,
        ..CampaignSetup::default()
    };
    let out = calibrated(&setup, 2024, &Params::default());
    let verdict = &out.result.verdict;
    println!("{verdict}");
    let check = out.result.truth_check.as_ref().unwrap();
    if out.saved.is_some() {
        assert!(check.agrees, "{verdict}");
    } else {
        assert!(
            verdict.contains("pooled over the") || verdict.contains("covariance predicts"),
            "{verdict}"
        );
        assert!(verdict.contains("Record next:"), "{verdict}");
        assert_eq!(check.agrees, check.would_save.is_none(), "{check:?}");
    }
}

/// Without bias drift (the floor is then the white noise, and the fit is told the bias is stable),
/// the saved corrector's RMS error against the true specific force is within 1.25× the floor on
/// every held-out condition and axis. With the default drift (0.01 g bound, 300 s correlation, over
/// a campaign of about 7 minutes) no static corrector can: the bias the campaign can estimate is
/// the drift's own average, whose error is as large as the drift (see the closing measurements in
/// CHANGELOG.md).
#[test]
fn without_drift_the_saved_corrector_reaches_the_floor_on_every_held_out_condition() {
    let mut setup = CampaignSetup::default();
    setup.sensor.bias_drift_g = 0.0;
    let mut settings = Params::default();
    settings.joint.bias_instability_mps2 = 0.001;
    for seed in [0, 7] {
        let out = calibrated(&setup, seed, &settings);
        let saved = out.result.saved.clone().expect("a corrector is saved");
        let mut worst = [0.0f64; 3];
        for h in out.result.held_out.iter().filter(|h| h.candidate == saved) {
            let truth = h.truth.as_ref().unwrap();
            let (rms, floor) = (truth.rms_mps2, h.floor_mps2.unwrap());
            for k in 0..3 {
                worst[k] = worst[k].max(rms[k] / floor[k]);
            }
            assert!(truth.uncorrected_rms_mps2.iter().zip(&floor).all(|(u, f)| u > f));
        }
        println!("seed {seed}: saved {saved}, worst held-out RMS / floor {worst:.3?}");
        assert!(
            worst.iter().all(|&w| w > 0.9 && w <= 1.25),
            "seed {seed}: {worst:?}"
        );
    }
}

/// The verdict never uses truth: without truth keys the held-out figures, the eligibility and the
/// saved corrector are the same to the bit, and only the truth-based columns are gone.
#[test]
fn the_verdict_is_the_same_without_truth_files() {
    let mut setup = CampaignSetup {
        poses: 6,
        ..CampaignSetup::default()
    };
    setup.runs.truncate(3);
    let settings = Params {
        candidates: vec![CandidateKind::Physical, CandidateKind::Linear],
        ..Params::default()
    };
    let sim = simulate_campaign(&setup, 3).unwrap();
    let with = calibrate_campaign("u", &units(&sim, true), &settings, &spincal::progress::silent).unwrap();
    let without =
        calibrate_campaign("u", &units(&sim, false), &settings, &spincal::progress::silent).unwrap();
    assert_eq!(with.result.saved, without.result.saved);
    assert!(without.result.truth_check.is_none() && with.result.truth_check.is_some());
    assert_eq!(with.result.held_out.len(), without.result.held_out.len());
    for (a, b) in with.result.held_out.iter().zip(&without.result.held_out) {
        let (pa, pb) = (a.physics.as_ref().unwrap(), b.physics.as_ref().unwrap());
        assert_eq!(pa.ratio.to_bits(), pb.ratio.to_bits(), "{a:?}");
        assert_eq!(pa.worse, pb.worse);
        assert!(a.truth.is_some() && b.truth.is_none());
        assert_eq!(
            a.predicted.as_ref().map(|p| p.ratio.to_bits()),
            b.predicted.as_ref().map(|p| p.ratio.to_bits())
        );
    }
    for (a, b) in with.result.candidates.iter().zip(&without.result.candidates) {
        assert_eq!(a.eligible, b.eligible, "{a:?} {b:?}");
    }
}

/// Twenty default campaigns (seeds 0–19), each calibrated once with the physical model and the
/// 12-parameter map (the datasheet's nonlinearity as q's prior, as a campaign file states it),
/// shared by the tests below. The physical model without q is left out here (it costs a third of
/// the time): `examples/verdict_validation.rs` runs every candidate.
fn twenty_campaigns() -> &'static [spincal::campaign::select::CampaignOutput] {
    static OUTPUTS: std::sync::OnceLock<Vec<spincal::campaign::select::CampaignOutput>> =
        std::sync::OnceLock::new();
    OUTPUTS.get_or_init(|| {
        let setup = CampaignSetup::default();
        let mut settings = Params {
            candidates: vec![CandidateKind::Physical, CandidateKind::Linear],
            ..Params::default()
        };
        settings.joint.sensor_prior_sd[3] =
            quadratic_from_datasheet(setup.sensor.nonlinearity_pct_fs, setup.sensor.range_g);
        (0..20).map(|seed| calibrated(&setup, seed, &settings)).collect()
    })
}

/// The physical model with its quadratic term beats the linear 12-parameter corrector on held-out
/// conditions (mean RMS against the true specific force) in at least 80 % of 20 simulated
/// campaigns. A per-seed loss happens: the drift between poses, not the model, decides some folds.
#[test]
fn the_physical_model_with_nonlinearity_beats_the_linear_map_on_held_out_conditions() {
    let outputs = twenty_campaigns();
    let mut wins = 0;
    for (seed, out) in outputs.iter().enumerate() {
        let mean = |name: &str| {
            out.result
                .candidates
                .iter()
                .find(|c| c.candidate == name)
                .and_then(|c| c.mean_truth_rms_mps2)
                .unwrap_or(f64::INFINITY)
        };
        let (physical, linear) = (mean("physical"), mean("linear-12"));
        println!("seed {seed}: physical {physical:.4}, linear-12 {linear:.4} m/s²");
        wins += usize::from(physical < linear);
    }
    println!("physical beats linear-12 in {wins}/{}", outputs.len());
    assert!(wins * 10 >= outputs.len() * 8, "{wins}/{}", outputs.len());
}

/// Over the twenty campaigns, the physical model's truth-free figure (its physics residual with
/// the covariance's prediction, over the uncorrected signal against the same reference) lies
/// within a factor 2 of the truth-based figure on at least 90 % of held-out conditions, and the
/// choice made without truth is truth's (or within 10 % of its error against truth) in at least
/// 90 % of campaigns. (`examples/verdict_validation.rs` runs the same with every candidate and
/// over independently drawn units.)
#[test]
fn the_truth_free_figure_tracks_the_truth_it_cannot_see() {
    let (mut within, mut figures, mut agree) = (0, 0, 0);
    let outputs = twenty_campaigns();
    for out in outputs {
        let check = out.result.truth_check.as_ref().unwrap();
        agree += usize::from(check.agrees);
        if !check.agrees {
            eprintln!(
                "disagrees: saved {:?}, truth {:?}: {}",
                out.result.saved, check.would_save, out.result.verdict
            );
            for c in &out.result.candidates {
                eprintln!(
                    "  {} eligible {} mean {:?} truth {:?}: {:?}",
                    c.candidate, c.eligible, c.mean_rms_mps2, c.mean_truth_rms_mps2, c.why_not
                );
            }
        }
        for h in &out.result.held_out {
            if let (Some(p), Some(t)) = (&h.predicted, &h.truth) {
                figures += 1;
                within += usize::from((0.5..=2.0).contains(&(p.ratio / t.ratio)));
            }
        }
    }
    println!(
        "figures within a factor 2: {within}/{figures}; choices agree {agree}/{}",
        outputs.len()
    );
    assert!(figures >= outputs.len() * 10, "{figures}");
    assert!(within * 10 >= figures * 9, "{within}/{figures}");
    assert!(agree * 10 >= outputs.len() * 9, "{agree}/{}", outputs.len());
}

/// Inputs that physics contradicts are refused before any fit, naming the recording and the key.
#[test]
fn inputs_that_physics_contradicts_are_refused_with_the_key() {
    use spincal::campaign::select::CampaignCalError;
    let mut setup = CampaignSetup {
        poses: 6,
        ..CampaignSetup::default()
    };
    setup.runs.truncate(2);
    let sim = simulate_campaign(&setup, 1).unwrap();
    let settings = Params::default();
    let refused = |units: Vec<spincal::campaign::prepare::UnitRecording>| -> (String, String) {
        match calibrate_campaign("u", &units, &settings, &spincal::progress::silent) {
            Err(CampaignCalError::Input(e)) => (e.key.to_string(), e.to_string()),
            Err(e) => panic!("refused for another reason: {e}"),
            Ok(_) => panic!("accepted"),
        }
    };
    let good = units(&sim, false);
    let still = good.iter().position(|u| u.turntable.is_none()).unwrap();
    let run = good.iter().position(|u| u.turntable.is_some()).unwrap();

    // An m/s² file read as g: every value 9.8× too large.
    let mut bad = good.clone();
    for axis in bad[still].recording.accel_mps2.iter_mut() {
        axis.iter_mut()
            .for_each(|v| *v *= spincal::input::recording::STANDARD_GRAVITY);
    }
    let (key, message) = refused(bad);
    assert_eq!(key, "accel_unit", "{message}");
    assert!(message.contains("remove accel_unit"), "{message}");

    // `up` declared wrong on one run.
    let mut bad = good.clone();
    let entry = bad[run].turntable.as_mut().unwrap();
    std::mem::swap(&mut entry.out, &mut entry.up);
    let (key, message) = refused(bad);
    assert_eq!(key, "up", "{message}");

    // A turntable run listed as static: its gyro turns.
    let mut bad = good.clone();
    bad[run].turntable = None;
    let (key, message) = refused(bad);
    assert_eq!(key, "kind", "{message}");

    // The same recording listed twice.
    let mut bad = good.clone();
    bad.push(bad[run].clone());
    bad.last_mut().unwrap().name = "copy.csv".into();
    let (key, message) = refused(bad);
    assert_eq!(key, "file", "{message}");
    assert!(message.contains("copy.csv"), "{message}");

    // A nominal rpm 35 % off.
    let mut bad = good.clone();
    bad[run].turntable.as_mut().unwrap().rpm *= 1.35;
    let (key, message) = refused(bad);
    assert_eq!(key, "rpm", "{message}");

    // And the good campaign passes the checks (it is refused by nothing above).
    assert!(calibrate_campaign(
        "u",
        &good,
        &Params {
            candidates: vec![CandidateKind::Physical],
            ..Params::default()
        },
        &spincal::progress::silent
    )
    .is_ok());
}

/// The advice never names a pose the campaign already holds: with every parameter listed (a
/// tolerance no standard error meets), each advised still pose lies at least `HELD_POSE_DEG` from
/// every held pose, with the campaign's twelve poses and with the z-up ones alone.
#[test]
fn undetermined_advice_knows_the_poses_the_campaign_holds() {
    let setup = CampaignSetup {
        runs: vec![RunSetup::default()],
        ..CampaignSetup::default()
    };
    let sim = simulate_campaign(&setup, 2).unwrap();
    let prepared = prepare(&units(&sim, false)).unwrap();
    let fit = fit_joint(
        &prepared.runs,
        &prepared.poses,
        &JointSettings::default(),
        &spincal::progress::silent,
    )
    .unwrap();
    let g = spincal::input::recording::STANDARD_GRAVITY;
    let z_up: Vec<_> = prepared
        .poses
        .iter()
        .filter(|p| p.mean_mps2[2] > 0.9 * g)
        .cloned()
        .collect();
    assert!(!z_up.is_empty());
    for held in [&prepared.poses, &z_up] {
        let all = fit.undetermined(g, 1e-12, held);
        assert_eq!(all.len(), 12);
        for a in &all {
            let u = a.pose_direction.unwrap_or_else(|| panic!("{a:?}"));
            for p in held.iter() {
                let m = p.mean_mps2;
                let n = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                let cos = (u[0] * m[0] + u[1] * m[1] + u[2] * m[2]) / n;
                assert!(
                    cos.acos().to_degrees() >= spincal::campaign::joint::HELD_POSE_DEG,
                    "{}: {} is {:.1}° from {}",
                    a.parameter,
                    a.sentence,
                    cos.acos().to_degrees(),
                    p.name
                );
            }
        }
    }
}

/// A ±2 g part with 0.8 % FS nonlinearity (q·g² about 0.04 m/s², inside its datasheet) and no
/// datasheet keys in the campaign: the default prior (0.5 % FS over ±8 g) would hold q near zero
/// and let the biases absorb q·g². The campaign's poses determine q, so the data decide it and the
/// true q lies within 3 standard errors (five seeds, three axes: at least 13 of 15).
#[test]
fn the_data_decide_the_nonlinearity_when_the_campaign_determines_it() {
    let mut setup = CampaignSetup::default();
    setup.sensor.range_g = 2.0;
    setup.sensor.nonlinearity_pct_fs = 0.8;
    let settings = Params {
        candidates: vec![CandidateKind::Physical],
        ..Params::default()
    };
    let (mut inside, mut total) = (0, 0);
    for seed in 0..5 {
        let sim = simulate_campaign(&setup, seed).unwrap();
        let out =
            calibrate_campaign("u", &units(&sim, false), &settings, &spincal::progress::silent).unwrap();
        let r = &out.result;
        assert_eq!(r.nonlinearity.decided_by, "data", "{:?}", r.nonlinearity);
        let truth = sim.truth.sensor.params();
        for (k, p) in r.joint.sensor_params.iter().enumerate().skip(9) {
            let se = p.std_error.unwrap();
            println!(
                "seed {seed} {}: {:.2e} ± {:.1e} (true {:.2e})",
                p.name, p.value, se, truth[k]
            );
            total += 1;
            inside += usize::from((p.value - truth[k]).abs() <= 3.0 * se);
        }
    }
    assert!(inside >= 13, "{inside}/{total}");
}
