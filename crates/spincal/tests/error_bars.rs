//! The error bar `correct` writes per row: the physical model's parameter covariance carried
//! through its inverse. On campaigns of one file per pose from the independent forward model
//! (`common::independent`), the systematic error at orientations the campaign never held, divided
//! by the standard deviation predicted there, has an RMS near one: error bars neither too small
//! nor too large.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use spincal::campaign::joint::{fit_joint, JointSettings};
use spincal::correctors::physical::{PhysicalCorrector, SensorUncertainty};

use crate::common::independent::{random_gravity, still_pose, Sensor, G};

/// Held-out orientations per unit.
const HELD_OUT: usize = 8;

/// The RMS over units, held-out orientations and axes of (corrected − true)/predicted sd, for
/// units calibrated from `poses` still poses, each its own file (session), 800 samples each.
fn normalised_error_rms(poses: usize, seeds: std::ops::RangeInclusive<u64>) -> f64 {
    let (mut z2, mut n) = (0.0, 0usize);
    for seed in seeds {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sensor = Sensor::draw(&mut rng);
        let inputs: Vec<_> = (0..poses)
            .map(|p| {
                let f = random_gravity(&mut rng);
                still_pose(&sensor, f, [0.0; 3], 800, p, 20.0 * p as f64, &mut rng)
            })
            .collect();
        let settings = JointSettings {
            gravity_mps2: G,
            ..JointSettings::default()
        };
        let fit = fit_joint(&[], &inputs, &settings, &spincal::progress::silent).unwrap();
        let corrector = PhysicalCorrector {
            sensor: fit.sensor,
            gravity_mps2: G,
            input_range_mps2: [[-G, G]; 3],
            uncertainty: Some(SensorUncertainty {
                covariance: fit.sensor_covariance().expect("a covariance"),
                noise_sd_mps2: [sensor.noise_mps2; 3],
                session_spread_mps2: None,
            }),
        };
        for _ in 0..HELD_OUT {
            let f = random_gravity(&mut rng);
            let reading = sensor.read(f, [0.0; 3]);
            let corrected = corrector.sensor.correct(reading).unwrap();
            let sd = corrector.predicted_sd(reading).unwrap();
            for k in 0..3 {
                z2 += ((corrected[k] - f[k]) / sd[k]).powi(2);
                n += 1;
            }
        }
    }
    (z2 / n as f64).sqrt()
}

/// 24 poses, one file each: the error bars cover the systematic error on 12 units (RMS of
/// error/sd within 0.7–1.4). With 12 poses (as many readings as the sensor's terms and the poses'
/// angles) they are too narrow: 1.52 measured, not yet asserted.
#[test]
fn the_predicted_sd_covers_the_error_at_new_orientations() {
    let rms = normalised_error_rms(24, 1..=12);
    eprintln!("24 poses: RMS of error/predicted sd {rms:.3}");
    assert!((0.7..1.4).contains(&rms), "RMS of error/predicted sd {rms}");
}
