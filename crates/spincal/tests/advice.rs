//! The advice for what to record next (issue 46 item 5), on poses drawn by the independent forward
//! model (`common::independent`): followed in simulation, it brings the named parameter's standard
//! error to what it predicted; it never names a held pose; and for q it does not ask for an axis
//! level, which with free pose directions says nothing about that axis's q.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spincal::campaign::error_map::{error_map, next_pose};
use spincal::campaign::file::{Datasheet, DatasheetNonlinearity};
use spincal::campaign::joint::{fit_joint, Advice, JointFit, JointSettings, PoseInput, HELD_POSE_DEG};
use spincal::correctors::model_file::ErrorModel;
use spincal::correctors::physical::{PhysicalCorrector, SensorUncertainty};

use crate::common::independent::{random_gravity, still_pose, Sensor, G};

const SAMPLES: usize = 800;
/// The campaign's tolerance: one standard error moving a 1 g reading by more than this.
const TOLERANCE: f64 = 0.02;
/// Noise draws of an advised pose over which its parameter's error is measured.
const NOISE_DRAWS: usize = 20;

/// Settings of a ±2 g part with 0.5 % FS nonlinearity stated (its datasheet's q prior).
fn settings() -> JointSettings {
    let mut s = JointSettings::default();
    s.set_datasheet_priors(&Datasheet {
        nonlinearity: Some(DatasheetNonlinearity {
            range_g: 2.0,
            pct_fs: 0.5,
        }),
        ..Datasheet::default()
    });
    s
}

/// `directions` (unit vectors in the sensor frame) each turned by up to `wobble_deg` at random,
/// one pose each, in one power-on session.
fn campaign(seed: u64, directions: &[[f64; 3]], wobble_deg: f64) -> (Sensor, Vec<PoseInput>, ChaCha8Rng) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sensor = Sensor::draw(&mut rng);
    let poses = directions
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let w = wobble_deg.to_radians();
            let tilted = unit([0, 1, 2].map(|k| d[k] + rng.gen_range(-w..w)));
            still_pose(
                &sensor,
                tilted.map(|v| G * v),
                [0.0; 3],
                SAMPLES,
                0,
                20.0 * i as f64,
                &mut rng,
            )
        })
        .collect();
    (sensor, poses, rng)
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

fn six_faces() -> Vec<[f64; 3]> {
    let mut d = Vec::new();
    for k in 0..3 {
        for s in [1.0, -1.0] {
            let mut v = [0.0; 3];
            v[k] = s;
            d.push(v);
        }
    }
    d
}

fn fit(poses: &[PoseInput]) -> JointFit {
    fit_joint(&[], poses, &settings(), &spincal::progress::silent).unwrap()
}

fn se_of(fit: &JointFit, name: &str) -> f64 {
    fit.sensor_params
        .iter()
        .find(|p| p.name == name)
        .unwrap()
        .std_error
        .unwrap()
}

/// The campaign with the advised pose recorded as a file of its own (a new power-on session, the
/// same sensor, no offset), refitted.
fn follow(sensor: &Sensor, poses: &[PoseInput], advice: &Advice, rng: &mut ChaCha8Rng) -> JointFit {
    let u = advice.pose_direction.unwrap();
    let session = poses.iter().map(|p| p.session).max().unwrap() + 1;
    let mut more = poses.to_vec();
    more.push(still_pose(
        sensor,
        u.map(|v| G * v),
        [0.0; 3],
        SAMPLES,
        session,
        1000.0,
        rng,
    ));
    fit(&more)
}

/// The six faces and the three edges between +x, +y and +z (45°), one power-on session.
fn with_edges() -> Vec<[f64; 3]> {
    let s = 0.5f64.sqrt();
    let mut d = six_faces();
    d.extend([[s, s, 0.0], [s, 0.0, s], [0.0, s, s]]);
    d
}

fn one_file_per_pose(poses: &mut [PoseInput]) {
    for (i, p) in poses.iter_mut().enumerate() {
        p.session = i;
    }
}

/// Every advised pose at least `HELD_POSE_DEG` from every held pose's reading.
fn assert_away_from_held(advice: &[Advice], poses: &[PoseInput]) {
    for a in advice {
        if let Some(u) = a.pose_direction {
            assert_direction_away_from_held(u, poses, &format!("{}: {}", a.parameter, a.sentence));
        }
    }
}

/// `u` at least `HELD_POSE_DEG` from every held pose's reading.
fn assert_direction_away_from_held(u: [f64; 3], poses: &[PoseInput], what: &str) {
    for p in poses {
        let m = unit(p.mean_mps2);
        let angle = (u[0] * m[0] + u[1] * m[1] + u[2] * m[2])
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        assert!(angle >= HELD_POSE_DEG, "{angle:.1}° from {}: {what}", p.name);
    }
}

/// Six axis-aligned poses (each placed within 2°), one file per pose: with free pose directions
/// they say nothing about the misalignments, which stay at their prior (0.02 rad). Followed in
/// simulation (the same sensor, the advised pose as a file of its own), the advice for each brings
/// its standard error to within 20 % of the prediction, on 8 seeds × 3 misalignments (measured:
/// 0.996–1.007×), while the prediction is a drop of at least 4×: the check is not vacuous.
#[test]
fn the_advice_followed_in_simulation_brings_the_standard_error_to_its_prediction() {
    let mut worst = 0.0f64;
    for seed in 1..=8 {
        let (sensor, mut poses, mut rng) = campaign(seed, &six_faces(), 2.0);
        one_file_per_pose(&mut poses);
        let fitted = fit(&poses);
        let clock = std::time::Instant::now();
        let advice = fitted.undetermined(G, TOLERANCE, &poses);
        eprintln!(
            "seed {seed}: advice for {} parameters in {:.2} ms",
            advice.len(),
            1e3 * clock.elapsed().as_secs_f64()
        );
        assert_away_from_held(&advice, &poses);
        let misalignments: Vec<&Advice> = advice
            .iter()
            .filter(|a| a.parameter.starts_with("misalignment"))
            .collect();
        assert_eq!(misalignments.len(), 3, "seed {seed}: {advice:?}");
        for a in misalignments {
            let (now, predicted) = (a.std_error.unwrap(), a.predicted_std_error.unwrap());
            assert!(predicted < 0.25 * now, "seed {seed}: {a:?}");
            let after = se_of(&follow(&sensor, &poses, a, &mut rng), &a.parameter);
            let ratio = after / predicted;
            worst = worst.max((ratio - 1.0).abs());
            assert!(
                (0.8..1.2).contains(&ratio),
                "seed {seed} {}: {after:.3e} against {predicted:.3e}",
                a.parameter
            );
        }
    }
    eprintln!("largest |refit/predicted − 1|: {worst:.3}");
}

/// Seven poses at random orientations, one file per pose (the common way, bias spread estimated):
/// every parameter the advice predicts to drop by 5 % or more, followed in simulation on 6 seeds.
/// Measured: 64 of 67 within 20 % of the prediction, median ratio 1.005; the three outside (1.53,
/// 1.61, 2.38) are refitted robust standard errors resting on a few poses' realised residuals
/// (63 of 68 before q's datasheet bound was read as rectangular, bench/accuracy/RESULTS.md). The
/// test holds at least 85 % within 20 % and the median within 10 %, and never a held pose named.
#[test]
fn the_advice_on_random_poses_mostly_holds_its_prediction() {
    let mut ratios = Vec::new();
    for seed in 1..=6 {
        let directions: Vec<[f64; 3]> = {
            let mut r = ChaCha8Rng::seed_from_u64(100 + seed);
            (0..7).map(|_| unit(random_gravity(&mut r))).collect()
        };
        let (sensor, mut poses, mut rng) = campaign(seed, &directions, 2.0);
        one_file_per_pose(&mut poses);
        let advice = fit(&poses).undetermined(G, TOLERANCE, &poses);
        assert_away_from_held(&advice, &poses);
        for a in &advice {
            let (Some(now), Some(predicted)) = (a.std_error, a.predicted_std_error) else {
                panic!("seed {seed}: {a:?}")
            };
            if predicted > 0.95 * now {
                continue;
            }
            let after = se_of(&follow(&sensor, &poses, a, &mut rng), &a.parameter);
            ratios.push(after / predicted);
        }
    }
    ratios.sort_by(f64::total_cmp);
    let within = ratios.iter().filter(|r| (0.8..1.2).contains(*r)).count();
    let median = ratios[ratios.len() / 2];
    eprintln!(
        "{within} of {} within 20 %, median {median:.3}: {ratios:.3?}",
        ratios.len()
    );
    assert!(ratios.len() >= 40, "{ratios:?}");
    assert!(within as f64 >= 0.85 * ratios.len() as f64, "{ratios:?}");
    assert!((0.9..1.1).contains(&median), "{ratios:?}");
}

/// The point: with free pose directions a pose with the x axis level says nothing to
/// first order about q_x (the old fixed text asked for "x axis up, down and level"). On the six
/// faces and three edges, the advice for q_x puts x between 25° and 65° from level. Followed, the
/// error of q̂_x over noise draws of the advised pose falls at least fourfold from the standard
/// error before it, and lies within 0.5–2.5× the advice's prediction (measured: a fall of 5.6–15×,
/// 0.74–1.85× the prediction), while a new pose with x level (y 45° below, z 45° above, not held)
/// leaves the standard error above half its value. Four seeds. The refit's own robust standard
/// error is no measure here: ten poses leave the refit nearly saturated, and it came out 0.35–15×
/// the prediction (6 seeds × 9 terms).
#[test]
fn the_advice_for_q_does_not_ask_for_the_axis_level() {
    let s = 0.5f64.sqrt();
    for seed in 1..=4 {
        let (sensor, poses, mut rng) = campaign(seed, &with_edges(), 2.0);
        let advice = fit(&poses).undetermined(G, TOLERANCE, &poses);
        assert_away_from_held(&advice, &poses);
        let q_x = advice
            .iter()
            .find(|a| a.parameter.starts_with("quadratic_x"))
            .unwrap();
        let u = q_x.pose_direction.unwrap();
        let elevation = u[0].abs().asin().to_degrees();
        assert!((25.0..65.0).contains(&elevation), "seed {seed}: {}", q_x.sentence);
        assert!(!q_x.sentence.contains("x level"), "{}", q_x.sentence);
        let now = q_x.std_error.unwrap();
        let level = Advice {
            pose_direction: Some([0.0, -s, s]),
            ..q_x.clone()
        };
        let x_level = se_of(&follow(&sensor, &poses, &level, &mut rng), &q_x.parameter);
        // The refit's own standard error is no measure here (see above): the error of q̂_x over
        // noise draws of the advised pose is.
        let errors: Vec<f64> = (0..NOISE_DRAWS)
            .map(|_| {
                let refit = follow(&sensor, &poses, q_x, &mut rng);
                let q = refit
                    .sensor_params
                    .iter()
                    .find(|p| p.name == q_x.parameter)
                    .unwrap();
                q.value - sensor.quadratic[0]
            })
            .collect();
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        eprintln!(
            "seed {seed}: q_x se {now:.2e}; advised pose ({elevation:.0}° from level) predicted {:.2e}, error RMS over {NOISE_DRAWS} draws {rms:.2e}; x level: se {x_level:.2e}",
            q_x.predicted_std_error.unwrap_or(f64::NAN)
        );
        assert!(
            rms < 0.25 * now
                && (0.5..2.5).contains(&(rms / q_x.predicted_std_error.unwrap()))
                && x_level > 0.5 * now,
            "seed {seed}: {now:.2e} {rms:.2e} {x_level:.2e}"
        );
    }
}

/// A datasheet's bound B on q, where the poses say nothing of q (the six faces in one session:
/// at ±g, q·g² is one more bias), gives q the standard error of a value anywhere within ±B,
/// B/√3, where the bound taken as the standard deviation gave B. Four seeds.
#[test]
fn a_bound_on_q_gives_its_rectangular_spread_where_the_poses_say_nothing() {
    let bound = DatasheetNonlinearity {
        range_g: 2.0,
        pct_fs: 0.5,
    }
    .quadratic_per_mps2();
    let mut as_sd = settings();
    as_sd.sensor_prior_is_bound[3] = false;
    for seed in 1..=4 {
        let (_, poses, _) = campaign(seed, &six_faces(), 2.0);
        let q_x = "quadratic_x (1/(m/s²))";
        let faces = se_of(&fit(&poses), q_x);
        let faces_as_sd = se_of(
            &fit_joint(&[], &poses, &as_sd, &spincal::progress::silent).unwrap(),
            q_x,
        );
        eprintln!(
            "seed {seed}: q_x se on the faces {faces:.3e} (B/√3 = {:.3e}), {faces_as_sd:.3e} with B as the sd",
            bound / 3f64.sqrt()
        );
        assert!(
            (0.95..1.1).contains(&(faces * 3f64.sqrt() / bound)),
            "seed {seed}: {faces:e}"
        );
        assert!(
            (0.95..1.1).contains(&(faces_as_sd / bound)),
            "seed {seed}: {faces_as_sd:e}"
        );
    }
}

/// The physical corrector a campaign would save from `fit`: its sensor and its covariance, the
/// generator's noise.
fn corrector_of(fit: &JointFit, sensor: &Sensor) -> PhysicalCorrector {
    PhysicalCorrector {
        sensor: fit.sensor,
        gravity_mps2: G,
        input_range_mps2: [[-2.0 * G, 2.0 * G]; 3],
        uncertainty: fit.sensor_covariance().map(|covariance| SensorUncertainty {
            covariance,
            noise_sd_mps2: [sensor.noise_mps2; 3],
            session_spread_mps2: None,
        }),
    }
}

/// The error map's advice (issue 46 items 4 and 5): where the saved model is trusted over part
/// of the sphere only, the still pose that most widens it. Seven, eight and nine poses at random
/// orientations, one file per pose, six seeds each. Followed in simulation (the same sensor, the
/// pose as a file of its own, refitted), the refitted model's map reaches what the advice
/// predicted. Measured: the share trusted within 0.02 of the prediction and the median predicted
/// error within 1 % on 16 of 18; the other two (nine poses) fall short, 0.22 and 0.45 for 0.52
/// and 0.59 predicted, where the refit's robust covariance rests on a few poses' realised
/// residuals (as in the per-parameter advice above). The test holds at least 80 % within 0.1 of
/// the share and 20 % of the median, while every prediction is a fall of the median by a quarter
/// or more: the check is not vacuous. It never names a held pose.
#[test]
fn the_map_advice_followed_in_simulation_widens_the_trusted_region_as_predicted() {
    let (mut cases, mut held) = (0, 0);
    for n_poses in [7, 8, 9] {
        for seed in 1..=6 {
            let directions: Vec<[f64; 3]> = {
                let mut r = ChaCha8Rng::seed_from_u64(300 + seed);
                (0..n_poses).map(|_| unit(random_gravity(&mut r))).collect()
            };
            let (sensor, mut poses, mut rng) = campaign(seed, &directions, 2.0);
            one_file_per_pose(&mut poses);
            let fitted = fit(&poses);
            let corrector = corrector_of(&fitted, &sensor);
            let map = error_map(ErrorModel::Physical(&corrector), G, &poses);
            let next = next_pose(&map, &corrector, &fitted, &poses).unwrap_or_else(|| {
                panic!(
                    "{n_poses} poses, seed {seed}: no advice at share {}",
                    map.share_determined
                )
            });
            let u = next.pose_direction;
            assert_direction_away_from_held(u, &poses, &next.sentence);
            let [median_now, median_predicted] = next.median_sd_over_noise;
            assert!(
                median_predicted < 0.75 * median_now,
                "{n_poses} poses, seed {seed}: {next:?}"
            );
            let session = poses.iter().map(|p| p.session).max().unwrap() + 1;
            let mut more = poses.clone();
            more.push(still_pose(
                &sensor,
                u.map(|v| G * v),
                [0.0; 3],
                SAMPLES,
                session,
                1000.0,
                &mut rng,
            ));
            let refit = fit(&more);
            let after = error_map(ErrorModel::Physical(&corrector_of(&refit, &sensor)), G, &more);
            let median_after = after.median_sd_over_noise.unwrap();
            eprintln!(
                "{n_poses} poses, seed {seed}: share {:.2} → predicted {:.2}, refit {:.2}; median {median_now:.2} → predicted {median_predicted:.2}, refit {median_after:.2}",
                map.share_determined, next.share_determined_after, after.share_determined
            );
            cases += 1;
            held += usize::from(
                (after.share_determined - next.share_determined_after).abs() <= 0.1
                    && (0.8..1.2).contains(&(median_after / median_predicted)),
            );
        }
    }
    eprintln!("{held} of {cases} as predicted");
    assert!(held as f64 >= 0.8 * cases as f64, "{held} of {cases}");
}
