//! A small deterministic stand-in for the simulator: a sensor on a turntable whose
//! accelerometer has bias, scale, misalignment, a static nonlinearity with cross-axis coupling,
//! and noise. Shared by the tests and the `ann_epoch` example.
#![allow(dead_code)]

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use spincal::input::recording::Recording;
use spincal::input::recording::Source;

/// (measured, reference) for `n` samples at 100 Hz of a 0.55 Hz turntable (SPEC §2 model:
/// r = 0.1 m, α = 5°, β = 20°) with slow wow so that no two turns are identical.
pub fn turntable_pair(n: usize, seed: u64) -> (Recording, Recording) {
    let g = 9.80665;
    let omega = 2.0 * std::f64::consts::PI * 0.55;
    let (r, alpha, beta) = (0.1, 5f64.to_radians(), 20f64.to_radians());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.004).expect("valid sigma");
    let time_s: Vec<f64> = (0..n).map(|i| i as f64 / 100.0).collect();
    let mut reference = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut measured = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut phase = 0.0;
    for i in 0..n {
        let t = time_s[i];
        // Wow: ±3 % speed at 0.05 Hz, so ω² r and the phase both wander.
        let w = omega * (1.0 + 0.03 * (2.0 * std::f64::consts::PI * 0.05 * t).sin());
        let tilt = 1.0 + 0.2 * (2.0 * std::f64::consts::PI * 0.013 * t).sin();
        let am = w * w * r;
        let ax = am * beta.cos() + g * (alpha * tilt).sin() * (phase - beta).sin();
        let ay = am * beta.sin() + g * (alpha * tilt).sin() * (phase - beta).cos();
        let az = g * (alpha * tilt).cos();
        phase += w / 100.0;
        reference[0][i] = ax;
        reference[1][i] = ay;
        reference[2][i] = az;
        // Scale, misalignment and bias …
        let lx = 1.03 * ax + 0.04 * ay + 0.02 * az + 0.15;
        let ly = -0.03 * ax + 0.97 * ay + 0.01 * az - 0.1;
        let lz = 0.01 * ax + 0.02 * ay + 1.01 * az + 0.05;
        // … then a nonlinearity with cross-axis coupling, and noise.
        measured[0][i] = lx + 0.12 * lx * lx - 0.05 * lx * lx * lx + 0.08 * lx * ly + noise.sample(&mut rng);
        measured[1][i] = ly - 0.10 * ly * ly + 0.04 * ly * ly * ly + 0.06 * lx * lx + noise.sample(&mut rng);
        measured[2][i] = lz + 0.002 * lz * lz + noise.sample(&mut rng);
    }
    let recording = |accel_mps2: [Vec<f64>; 3], name: &str| Recording {
        time_s: time_s.clone(),
        accel_mps2,
        gyro_radps: None,
        temperature_c: None,
        source: Source {
            name: name.into(),
            format: "synthetic".into(),
            ..Source::default()
        },
    };
    (recording(measured, "measured"), recording(reference, "reference"))
}
