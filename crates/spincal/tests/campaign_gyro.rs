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
        for (k, p) in fit.params.iter().enumerate() {
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
