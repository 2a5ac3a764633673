//! The gyroscope from a campaign: the record player as a rate table. Over many seeds the fitted
//! gyro bias and sensitivity lie within their reported standard errors of what was simulated, and
//! the calibration, saved with the accelerometer's corrector, turns readings into the true rate.

use spincal::campaign::gyro::{fit_gyro, GyroSettings};
use spincal::campaign::joint::{fit_joint, JointSettings};
use spincal::campaign::prepare::{prepare, UnitRecording};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup, SimulatedCampaign};

use crate::common;

fn units(sim: &SimulatedCampaign) -> Vec<UnitRecording> {
    common::campaign_units(sim, false)
}

#[test]
fn gyro_parameters_are_recovered_within_their_errors_over_12_seeds() {
    let (mut inside, mut total) = (0usize, 0usize);
    let mut worst_bias_sigmas = 0.0f64;
    let mut worst = [0.0f64; 3];
    for seed in 0..12 {
        let sim = simulate_campaign(&CampaignSetup::default(), seed).unwrap();
        let prepared = prepare(&units(&sim)).unwrap();
        let joint = fit_joint(
            &prepared.runs,
            &prepared.poses,
            &JointSettings::default(),
            &spincal::progress::silent,
        )
        .unwrap();
        let fit = fit_gyro(&prepared.runs, &prepared.poses, &joint, &GyroSettings::default())
            .unwrap()
            .expect("the simulated runs carry gyro columns");
        let truth = sim.truth.gyro.clone().unwrap();
        let true_values: Vec<f64> = truth
            .bias_radps
            .iter()
            .copied()
            .chain(truth.sensitivity.iter().flatten().copied())
            .collect();
        // The fit with every term free (the saved one leaves undetermined terms at nominal).
        for (k, p) in fit.free_params.iter().enumerate() {
            let se = p.std_error.expect("every gyro parameter has a standard error");
            let error = (p.value - true_values[k]).abs();
            total += 1;
            inside += usize::from(error <= 3.0 * se);
            if k < 3 {
                worst_bias_sigmas = worst_bias_sigmas.max(error / se);
                worst[0] = worst[0].max(error);
            } else if (k - 3) % 4 == 0 {
                worst[1] = worst[1].max(error);
            } else {
                worst[2] = worst[2].max(error);
            }
            println!(
                "seed {seed} {}: {:.6e} ± {:.2e} (truth {:.6e})",
                p.name, p.value, se, true_values[k]
            );
        }
        // Bias and each axis's own scale are determined; cross-axis terms may be limited by how
        // well the accelerometer fixes each mount's tilt, and the report must say so.
        for (name, advice) in &fit.undetermined {
            assert!(
                !name.contains("bias") && !["gyro_K_xx", "gyro_K_yy", "gyro_K_zz"].contains(&name.as_str()),
                "seed {seed}: {name}"
            );
            assert!(advice.contains("mount"), "seed {seed}: {name}: {advice}");
        }
        // The cross-check: the calibrated gyro reads the accelerometer's rate about the spindle.
        for check in &fit.rate_checks {
            let rel = (check.calibrated_gyro_rate_radps.abs() - check.accel_rate_radps.abs())
                / check.accel_rate_radps;
            assert!(rel.abs() < 1e-3, "seed {seed} {}: {rel}", check.run);
        }
    }
    let coverage = inside as f64 / total as f64;
    println!(
        "gyro coverage within 3 SE: {inside}/{total} = {:.1} %; worst bias error {:.2e} rad/s ({worst_bias_sigmas:.1} SE), scale {:.2e}, cross-axis {:.2e}",
        100.0 * coverage,
        worst[0],
        worst[1],
        worst[2]
    );
    assert!(coverage >= 0.9, "coverage {coverage}");
    // Bias within the simulator's truth: to better than its bias drift bound (0.02 °/s).
    assert!(worst[0] < 0.02f64.to_radians(), "bias error {}", worst[0]);
    // Scale to better than 0.1 %. Cross-axis terms are relative to the accelerometer's frame and
    // no better known than each mount's tilt (about 0.1° from the accelerometer): within 1 %.
    assert!(worst[1] < 1e-3 && worst[2] < 1e-2, "{worst:?}");
}

/// An MPU-6050 at its default ±250 °/s on a record player: 45 rpm (270 °/s) pins the gyro along
/// the spindle for the whole run, 33⅓ rpm (200 °/s) does not. Inspection names the 45 rpm runs'
/// saturation with the range it implies; the gyro fit refuses those runs with the reason and
/// measures the scale from the 33⅓ rpm runs alone, unbiased (before: −7.5 % along z).
#[test]
fn a_gyro_pinned_at_250_dps_is_named_and_kept_out_of_the_scale() {
    let base = CampaignSetup::default();
    let setup = CampaignSetup {
        gyro: spincal::simulate::campaign::GyroProfile {
            range_dps: 250.0,
            ..base.gyro.clone()
        },
        runs: base
            .runs
            .iter()
            .map(|r| spincal::simulate::campaign::RunSetup {
                duration_s: 20.0,
                ..r.clone()
            })
            .collect(),
        ..base
    };
    let sim = simulate_campaign(&setup, 3).unwrap();
    let units = units(&sim);
    let mut pinned_runs = Vec::new();
    for unit in units.iter().filter(|u| u.turntable.is_some()) {
        let found = spincal::input::inspect::inspect(&unit.recording, None);
        let fast = unit.turntable.as_ref().unwrap().rpm > 40.0;
        assert_eq!(
            !found.gyro_saturation.is_empty(),
            fast,
            "{}: {:?}",
            unit.name,
            found.gyro_saturation
        );
        for s in &found.gyro_saturation {
            // The rail of a 16-bit ±250 °/s gyro: 32767 or 32768 codes of 250/32768 °/s.
            assert!((s.limit_dps - 250.0).abs() < 0.01, "{}: {s:?}", unit.name);
            assert!(s.samples * 10 > unit.recording.len() * 9, "{}: {s:?}", unit.name);
            pinned_runs.push(unit.name.clone());
        }
    }
    assert_eq!(pinned_runs.len(), 2, "{pinned_runs:?}");

    let prepared = prepare(&units).unwrap();
    let joint = fit_joint(
        &prepared.runs,
        &prepared.poses,
        &JointSettings::default(),
        &spincal::progress::silent,
    )
    .unwrap();
    let fit = fit_gyro(&prepared.runs, &prepared.poses, &joint, &GyroSettings::default())
        .unwrap()
        .expect("the 33⅓ rpm runs carry an unsaturated gyro");
    let refused: Vec<&str> = fit
        .saturation
        .iter()
        .filter(|s| s.refused)
        .map(|s| s.run.as_str())
        .collect();
    assert_eq!(
        refused,
        pinned_runs.iter().map(String::as_str).collect::<Vec<_>>()
    );
    for s in &fit.saturation {
        let said = s.describe();
        assert!(
            said.contains("pinned at 250.0 °/s") && said.contains("not used"),
            "{said}"
        );
    }
    assert!(fit.rate_checks.iter().all(|c| !pinned_runs.contains(&c.run)));
    // z and x were along the spindle at 33⅓ rpm: their scales as simulated, within 3 standard
    // errors and 0.1 %; y was along it only at 45 rpm: named as not determined.
    let truth = sim.truth.gyro.clone().unwrap();
    for (k, name) in [(0, "gyro_K_xx"), (2, "gyro_K_zz")] {
        let p = fit.params.iter().find(|p| p.name == name).unwrap();
        let error = p.value - truth.sensitivity[k][k];
        let se = p.std_error.unwrap();
        println!(
            "{name}: {:.6} ± {se:.1e} (truth {:.6})",
            p.value, truth.sensitivity[k][k]
        );
        assert!(
            error.abs() < 3.0 * se && error.abs() < 1e-3,
            "{name}: {error:e} ± {se:e}"
        );
    }
    assert!(
        fit.undetermined.iter().any(|(name, _)| name == "gyro_K_yy"),
        "{:?}",
        fit.undetermined
    );

    // Every run pinned: the gyro is refused with the reason, the accelerometer untouched.
    let fast_only: Vec<_> = units
        .iter()
        .filter(|u| u.turntable.as_ref().is_none_or(|t| t.rpm > 40.0))
        .cloned()
        .collect();
    let prepared = prepare(&fast_only).unwrap();
    let joint = fit_joint(
        &prepared.runs,
        &prepared.poses,
        &JointSettings::default(),
        &spincal::progress::silent,
    )
    .unwrap();
    let e = fit_gyro(&prepared.runs, &prepared.poses, &joint, &GyroSettings::default()).unwrap_err();
    let said = e.to_string();
    assert!(
        said.starts_with("every turntable run's gyro is saturated for most of the run")
            && said.contains("pinned at 250.0 °/s"),
        "{said}"
    );
}

/// Where no accelerometer correction is shown to help (here none is offered but the ARX model,
/// which is scored only), the gyroscope's calibration the campaign determines is saved alone
/// (format 3, kind `uncorrected`): the file reads back, corrects no accelerometer axis, and
/// carries the same gyro model a campaign saves beside an accelerometer corrector. A file of that
/// kind with nothing else in it is refused by name.
#[test]
fn the_gyro_is_saved_alone_when_no_accelerometer_correction_is_shown_to_help() {
    use spincal::campaign::candidate::CandidateKind;
    use spincal::campaign::params::Params;
    use spincal::campaign::select::calibrate_campaign;
    use spincal::correctors::corrector::Corrector;
    use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
    let sim = simulate_campaign(&CampaignSetup::default(), 2).unwrap();
    let settings = Params {
        candidates: vec![CandidateKind::Arx],
        ..Params::default()
    };
    let out = calibrate_campaign("u", &units(&sim), &settings, &spincal::progress::silent).unwrap();
    let r = &out.result;
    assert_eq!(r.saved.as_deref(), Some("uncorrected"), "{}", r.verdict);
    assert!(!r.validated_off_training_condition && r.error_map.is_none());
    assert!(
        r.verdict.contains("gyroscope's calibration alone"),
        "{}",
        r.verdict
    );
    // A file is saved, so the verdict does not open with "Nothing saved".
    assert!(
        r.verdict.starts_with("No accelerometer correction saved"),
        "{}",
        r.verdict
    );
    let file = out.saved.expect("the gyro part is saved");
    assert!(matches!(file.corrector, CorrectorModel::Uncorrected(_)));
    assert!(file.corrector.corrected_axes().is_empty());
    let gyro = r
        .gyro
        .as_ref()
        .and_then(|g| g.saved_model())
        .expect("the campaign determines the gyro");
    assert_eq!(file.gyro.as_ref(), Some(gyro));
    let back = CorrectorFile::from_json(&file.to_json(), "model.json").unwrap();
    assert_eq!(back.format_version, 4);
    assert_eq!(back.gyro.as_ref(), Some(gyro));
    let bare = CorrectorFile { gyro: None, ..file };
    let refused = CorrectorFile::from_json(&bare.to_json(), "bare.json")
        .unwrap_err()
        .to_string();
    assert!(
        refused.contains("corrector.kind") && refused.contains("bare.json"),
        "{refused}"
    );
}
