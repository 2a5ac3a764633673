//! Power-on sessions: the spread of the bias offsets between them found from the recordings, on
//! poses drawn by the independent forward model (`common::independent`), not spincal's simulator.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use spincal::campaign::joint::{fit_joint, JointFit, JointSettings, PoseInput};

use crate::common::independent::{random_gravity, still_pose, Sensor};

/// `sessions` power-ons of `per_session` poses each, every session's bias offset drawn with
/// standard deviation `spread` m/s²; 800 samples per pose, poses 20 s apart.
fn campaign(seed: u64, sessions: usize, per_session: usize, spread: f64) -> (Sensor, Vec<PoseInput>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sensor = Sensor::draw(&mut rng);
    let offset = Normal::new(0.0, spread.max(1e-300)).unwrap();
    let mut poses = Vec::new();
    for session in 0..sessions {
        let delta: [f64; 3] = std::array::from_fn(|_| {
            if spread > 0.0 {
                offset.sample(&mut rng)
            } else {
                0.0
            }
        });
        for p in 0..per_session {
            let f = random_gravity(&mut rng);
            let t = 20.0 * (session * per_session + p) as f64;
            poses.push(still_pose(&sensor, f, delta, 800, session, t, &mut rng));
        }
    }
    (sensor, poses)
}

fn fit(poses: &[PoseInput], estimate: bool) -> JointFit {
    let settings = JointSettings {
        estimate_bias_spread: estimate,
        ..JointSettings::default()
    };
    fit_joint(&[], poses, &settings, &spincal::progress::silent).unwrap()
}

/// Offsets of 0.05 m/s² between eight power-ons of six poses each are found (within a factor of
/// two, well above the lower end), and a sensor that kept its bias shows none, on every seed.
#[test]
fn the_spread_of_bias_offsets_between_sessions_is_found_and_no_spread_is_found_where_there_is_none() {
    for seed in 1..=5 {
        let (_, poses) = campaign(seed, 8, 6, 0.05);
        let found = fit(&poses, true).bias_spread;
        assert!(found.estimated && !found.at_lower_bound, "seed {seed}: {found:?}");
        assert!((0.025..0.1).contains(&found.sd_mps2), "seed {seed}: {found:?}");
        assert!(found.likelihood_ratio > 10.0, "seed {seed}: {found:?}");
        let (_, steady) = campaign(seed, 8, 6, 0.0);
        let none = fit(&steady, true).bias_spread;
        assert!(none.sd_mps2 < 0.005, "seed {seed}: {none:?}");
    }
}

/// One file per pose, the sensor powered throughout: with the spread estimated, the 24 one-pose
/// sessions tell the bias nearly as well as one session of 24 poses does (standard errors within
/// 60 %; measured 0.9–1.5×: the spread found, 4–9·10⁻⁴ m/s², is about one pose mean's error, so
/// each file's offset keeps a little freedom), and the estimates cover the truth (an RMS of
/// error/SE between 0.5 and 1.5 over seeds and axes). With the fixed prior of 0.03 m/s² per
/// session they told 5–15× less (against standard errors whose pose residuals are scaled up by
/// their leverage, HC2).
#[test]
fn one_file_per_pose_tells_the_bias_as_one_file_does_when_the_sensor_kept_it() {
    let (mut z2, mut n) = (0.0, 0.0);
    for seed in 11..=16 {
        let (sensor, mut poses) = campaign(seed, 1, 24, 0.0);
        let one_file = fit(&poses, true);
        for (i, pose) in poses.iter_mut().enumerate() {
            pose.session = i;
        }
        let per_file = fit(&poses, true);
        let fixed = fit(&poses, false);
        eprintln!("seed {seed}: spread {:?}", per_file.bias_spread);
        for k in 0..3 {
            let se = |f: &JointFit| f.sensor_params[k].std_error.unwrap();
            assert!(
                se(&per_file) < 1.6 * se(&one_file),
                "seed {seed} axis {k}: {} vs {}",
                se(&per_file),
                se(&one_file)
            );
            assert!(
                se(&fixed) > 4.0 * se(&one_file),
                "seed {seed} axis {k}: {} vs {}",
                se(&fixed),
                se(&one_file)
            );
            z2 += ((per_file.sensor_params[k].value - sensor.bias[k]) / se(&per_file)).powi(2);
            n += 1.0;
        }
    }
    let rms_z = (z2 / n).sqrt();
    assert!((0.5..1.5).contains(&rms_z), "RMS of error/SE {rms_z}");
}

/// A fit given the spread (every later fit of a campaign: each fold's, the saved one) still counts
/// the offsets behind it, so that a saved model says whether the campaign could see a spread
/// between sessions at all: eight sessions can, one cannot.
#[test]
fn a_fit_given_the_spread_counts_the_sessions_behind_it() {
    let (_, poses) = campaign(3, 8, 6, 0.05);
    let given = JointSettings {
        estimate_bias_spread: false,
        bias_instability_mps2: 0.05,
        ..JointSettings::default()
    };
    let spread = fit_joint(&[], &poses, &given, &spincal::progress::silent)
        .unwrap()
        .bias_spread;
    assert!(!spread.estimated && spread.offsets == 8, "{spread:?}");
    let (_, one) = campaign(3, 1, 12, 0.05);
    let spread = fit_joint(&[], &one, &given, &spincal::progress::silent)
        .unwrap()
        .bias_spread;
    assert_eq!(spread.offsets, 1, "{spread:?}");
}
