//! The error bar `correct` writes per row: the physical model's parameter covariance carried
//! through its inverse. On campaigns of one file per pose from the independent forward model
//! (`common::independent`), the systematic error at orientations the campaign never held, divided
//! by the standard deviation predicted there, has an RMS near one: error bars neither too small
//! nor too large. The same for the campaign's `linear-12` map, whose covariance carries the
//! joint fit's into the map.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use spincal::campaign::candidate::{candidate, CandidateKind, TrainingSet};
use spincal::campaign::file::{Datasheet, DatasheetNonlinearity, SignedAxis, TurntableEntry};
use spincal::campaign::joint::{fit_joint, JointSettings, PoseInput, SensorTerms};
use spincal::campaign::select::TermsRule;
use spincal::correctors::model_file::CorrectorModel;
use spincal::correctors::physical::{predicted_to_help, PhysicalCorrector, SensorUncertainty};

use crate::common::independent::{random_gravity, still_pose, turntable_run, Placement, Sensor, G};

/// Held-out orientations per unit.
const HELD_OUT: usize = 8;

/// The joint fit's settings for the generator's sensor, a ±2 g part whose datasheet gives 0.5 %
/// FS nonlinearity (the generator's q reaches 0.4 % of the reading at 1 g), as its campaign file
/// would state it.
fn datasheet_settings() -> JointSettings {
    let mut settings = JointSettings {
        gravity_mps2: G,
        ..JointSettings::default()
    };
    settings.set_datasheet_priors(&Datasheet {
        nonlinearity: Some(DatasheetNonlinearity {
            range_g: 2.0,
            pct_fs: 0.5,
        }),
        ..Datasheet::default()
    });
    settings
}

/// `poses` still poses at random orientations, 800 samples each, `spacing_s` apart: one power-on
/// session when `one_session`, else a session per file.
fn random_poses(
    sensor: &Sensor,
    poses: usize,
    one_session: bool,
    spacing_s: f64,
    rng: &mut ChaCha8Rng,
) -> Vec<PoseInput> {
    (0..poses)
        .map(|p| {
            let f = random_gravity(rng);
            let session = if one_session { 0 } else { p };
            still_pose(sensor, f, [0.0; 3], 800, session, spacing_s * p as f64, rng)
        })
        .collect()
}

/// Σ over `HELD_OUT` random orientations and the three axes of ((corrected − true)/predicted sd)².
fn held_out_squared_z(corrector: &PhysicalCorrector, sensor: &Sensor, rng: &mut ChaCha8Rng) -> f64 {
    let mut z2 = 0.0;
    for _ in 0..HELD_OUT {
        let f = random_gravity(rng);
        let reading = sensor.read(f, [0.0; 3]);
        let corrected = corrector.sensor.correct(reading).unwrap();
        let sd = corrector.predicted_sd(reading).unwrap();
        z2 += (0..3)
            .map(|k| ((corrected[k] - f[k]) / sd[k]).powi(2))
            .sum::<f64>();
    }
    z2
}

/// The RMS over units, held-out orientations and axes of (corrected − true)/predicted sd, for
/// units calibrated from `poses` still poses, each its own file (session), 800 samples each.
fn normalised_error_rms(poses: usize, seeds: std::ops::RangeInclusive<u64>) -> f64 {
    normalised_error_rms_with(poses, seeds, &datasheet_settings())
}

fn normalised_error_rms_with(
    poses: usize,
    seeds: std::ops::RangeInclusive<u64>,
    settings: &JointSettings,
) -> f64 {
    let (mut z2, mut n) = (0.0, 0usize);
    for seed in seeds {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sensor = Sensor::draw(&mut rng);
        let inputs = random_poses(&sensor, poses, false, 20.0, &mut rng);
        let fit = fit_joint(&[], &inputs, settings, &spincal::progress::silent).unwrap();
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
        z2 += held_out_squared_z(&corrector, &sensor, &mut rng);
        n += 3 * HELD_OUT;
    }
    (z2 / n as f64).sqrt()
}

/// 12, 16 and 24 poses, one file each: the error bars cover the systematic error on 12 units
/// (RMS of error/sd within 0.7–1.4; 1.28, 0.93 and 0.76 measured; 1.19 at 12 poses when q's
/// prior took the datasheet's bound as its standard deviation). At 12 poses the poses give as
/// many readings as the sensor's terms and their own angles take, and the block sandwich alone,
/// estimated from residuals with almost no degrees of freedom left, put the RMS at 2.1; the
/// covariance's floor at the model's own and the poses' CR2 correction bring it into the band.
/// Below 12 the priors decide some terms (next test).
#[test]
fn the_predicted_sd_covers_the_error_at_new_orientations() {
    for poses in [12, 16, 24] {
        let rms = normalised_error_rms(poses, 1..=12);
        eprintln!("{poses} poses: RMS of error/predicted sd {rms:.3}");
        assert!(
            (0.7..1.4).contains(&rms),
            "{poses} poses: RMS of error/predicted sd {rms}"
        );
    }
}

/// Below 12 poses the priors decide some terms, and the bars are the priors': too wide with a
/// generic part's widths, held when the campaign states the datasheet's bounds the sensor lies
/// within (`Sensor::draw`'s: ±0.2 m/s², ±2 %, ±10 mrad, and q's). 12 units of 7 and of 9
/// one-file poses: RMS of error/sd within 0.7–1.4 with the bounds (measured 0.85 and 1.03); at 7
/// poses below 0.7 without them (0.41; 0.89 at 9 poses, where fewer terms rest on the priors).
#[test]
fn the_datasheets_bounds_hold_the_bars_where_the_poses_leave_terms_to_them() {
    let mut bounded = datasheet_settings();
    bounded.set_datasheet_priors(&Datasheet {
        nonlinearity: Some(DatasheetNonlinearity {
            range_g: 2.0,
            pct_fs: 0.5,
        }),
        zero_g_offset_mg: Some(0.2 / G * 1e3),
        sensitivity_tolerance_pct: Some(2.0),
        cross_axis_pct: Some(1.0),
    });
    for poses in [7, 9] {
        let with = normalised_error_rms_with(poses, 1..=12, &bounded);
        let without = normalised_error_rms(poses, 1..=12);
        eprintln!("{poses} poses: RMS of error/predicted sd {with:.3} with the bounds, {without:.3} without");
        assert!((0.7..1.4).contains(&with), "{poses} poses: {with}");
        assert!(poses > 7 || without < 0.7, "{poses} poses: {without}");
    }
}

/// The RMS over units, held-out orientations and axes of (corrected − true)/predicted sd of the
/// campaign's `linear-12` map, trained as a campaign trains it (`campaign::candidate`), for units
/// with `poses` still poses (each its own file, 800 samples) and, with `runs`, two turntable runs
/// (33⅓ and 45 rpm, 20 s at 100 Hz, radius unstated) in the poses' session. Also the share of
/// held-out readings flagged `predicted_better`, the library's rule on the map's sd, and the
/// physical kind's RMS on the same readings.
fn linear_normalised_error_rms(
    poses: usize,
    runs: bool,
    seeds: std::ops::RangeInclusive<u64>,
) -> LinearCoverage {
    let (mut z2, mut physical_z2, mut n, mut better) = (0.0, 0.0, 0usize, 0usize);
    for seed in seeds {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sensor = Sensor::draw(&mut rng);
        // With runs, one power-on throughout (poses 20 s apart); without, a session per file.
        let inputs = random_poses(&sensor, poses, runs, 20.0, &mut rng);
        let mut run_inputs = Vec::new();
        if runs {
            let placement = Placement {
                centre_radius_m: 0.10,
                out: (0, 1.0),
                up: (2, 1.0),
                yaw_rad: 0.03,
                chip_offset_m: [0.0; 3],
            };
            for rpm in [100.0 / 3.0, 45.0] {
                let entry = TurntableEntry {
                    rpm,
                    radius: None,
                    out: SignedAxis { axis: 0, sign: 1 },
                    up: SignedAxis { axis: 2, sign: 1 },
                    direction: None,
                    placement: None,
                    centre: None,
                };
                let rate = 1.01 * rpm * std::f64::consts::PI / 30.0;
                let run = turntable_run(
                    &sensor, &placement, entry, rate, [0.0; 3], 20.0, 100.0, "run", &mut rng,
                );
                run_inputs.push(run.in_session(Some(0)));
            }
        }
        let settings = datasheet_settings();
        let training = TrainingSet::new(run_inputs, inputs, &settings);
        let trained = candidate(CandidateKind::Linear)
            .train(&training, &spincal::progress::silent)
            .unwrap();
        let Some(CorrectorModel::Linear(map)) = trained.saved() else {
            panic!("linear-12 trains a linear map");
        };
        let physical = candidate(CandidateKind::Physical)
            .train(&training, &spincal::progress::silent)
            .unwrap();
        let Some(CorrectorModel::Physical(physical)) = physical.saved() else {
            panic!("physical trains a physical model");
        };
        let error_model = CorrectorModel::Linear(map.clone());
        let error_model = error_model
            .error_model()
            .expect("linear-12 carries its covariance");
        for _ in 0..HELD_OUT {
            let f = random_gravity(&mut rng);
            let reading = sensor.read(f, [0.0; 3]);
            let corrected = map.apply(reading);
            let sd = error_model.predicted_sd(reading).unwrap();
            let (by_physics, physical_sd) = (
                physical.sensor.correct(reading).unwrap(),
                physical.predicted_sd(reading).unwrap(),
            );
            for k in 0..3 {
                z2 += ((corrected[k] - f[k]) / sd[k]).powi(2);
                physical_z2 += ((by_physics[k] - f[k]) / physical_sd[k]).powi(2);
                n += 1;
            }
            better += usize::from((0..3).all(|k| predicted_to_help(corrected[k] - reading[k], sd[k])));
        }
    }
    LinearCoverage {
        rms: (z2 / n as f64).sqrt(),
        physical_rms: (physical_z2 / n as f64).sqrt(),
        better: better as f64 / (n / 3) as f64,
    }
}

struct LinearCoverage {
    /// RMS of (corrected − true)/predicted sd of the map.
    rms: f64,
    /// The same of the physical kind trained on the same campaign, on the same readings.
    physical_rms: f64,
    /// The share of held-out readings flagged `predicted_better`.
    better: f64,
}

/// linear-12's error bars cover its error at orientations the campaign never held, and so do the
/// physical kind's trained the same way: RMS of error/sd within 0.7–1.4 over 12 units, from 24
/// one-file poses (0.95 and 0.76 measured) and from 12 poses of one session with two turntable
/// runs (1.21 and 1.19; 1.47 and 1.91 before the covariance's floor at the model's own). Each part
/// of the map's covariance alone errs narrow (`campaign::candidate`'s `map_covariance` gives the
/// figures).
#[test]
fn the_linear_maps_predicted_sd_covers_its_error_at_new_orientations() {
    for (poses, runs) in [(24, false), (12, true)] {
        let c = linear_normalised_error_rms(poses, runs, 1..=12);
        eprintln!(
            "linear-12, {poses} poses{}: RMS of error/predicted sd {:.3} (physical {:.3}), predicted_better on {:.0} % of held-out readings",
            if runs { " + 2 runs" } else { "" },
            c.rms,
            c.physical_rms,
            100.0 * c.better
        );
        assert!((0.7..1.4).contains(&c.rms), "RMS of error/predicted sd {}", c.rms);
        assert!(
            (0.7..1.4).contains(&c.physical_rms),
            "physical: {}",
            c.physical_rms
        );
        // A sensor with biases to 0.2 m/s² is worth correcting almost everywhere.
        assert!(c.better > 0.5, "predicted_better on {}", c.better);
    }
}

/// The RMS over units, held-out orientations and axes of (corrected − true)/predicted sd of the
/// physical family's candidate where the terms rule holds q at zero on an axis, for units with
/// `poses` still poses of one power-on session (800 samples each), and how many units left a q
/// out. Units whose rule keeps every q are the full model's (the tests above) and are skipped.
fn left_out_terms_normalised_error_rms(poses: usize, seeds: std::ops::RangeInclusive<u64>) -> (f64, usize) {
    let (mut z2, mut n, mut units) = (0.0, 0usize, 0usize);
    for seed in seeds {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sensor = Sensor::draw(&mut rng);
        let inputs = random_poses(&sensor, poses, true, 10.0, &mut rng);
        let full = datasheet_settings();
        let fit = fit_joint(&[], &inputs, &full, &spincal::progress::silent).unwrap();
        let rule = TermsRule::of(&fit).expect("the fit has q");
        if rule.nonlinearity_axes == [true; 3] {
            continue;
        }
        units += 1;
        let settings = JointSettings {
            terms: SensorTerms {
                nonlinearity_axes: rule.nonlinearity_axes,
                ..full.terms
            },
            ..full
        };
        let kind = if rule.keeps_nonlinearity {
            CandidateKind::Physical
        } else {
            CandidateKind::PhysicalLinear
        };
        // The model is fitted with the rule's terms, as the campaign's saved one is (`fit` has q
        // on every axis).
        let training = TrainingSet::new(Vec::new(), inputs, &settings);
        let trained = candidate(kind)
            .train(&training, &spincal::progress::silent)
            .unwrap();
        let Some(CorrectorModel::Physical(physical)) = trained.saved() else {
            panic!("the physical family trains a physical model");
        };
        z2 += held_out_squared_z(physical, &sensor, &mut rng);
        n += 3 * HELD_OUT;
    }
    ((z2 / n.max(1) as f64).sqrt(), units)
}

/// Where the terms rule holds a q at zero, the saved model errs by what its kept terms absorbed of
/// it, and its error bars say so: RMS of error/sd within 0.7–1.4 over the units of 24 whose rule
/// left a q out (12 poses of one session; 1.19 measured over 23 units).
#[test]
fn error_bars_hold_what_a_left_out_q_moved() {
    let (rms, units) = left_out_terms_normalised_error_rms(12, 1..=24);
    eprintln!("{units} of 24 units left a q out: RMS of error/predicted sd {rms:.3}");
    assert!(
        units >= 6,
        "only {units} units left a q out: the test has no power"
    );
    assert!((0.7..1.4).contains(&rms), "RMS of error/predicted sd {rms}");
}
