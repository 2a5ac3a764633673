//! A phone on a record player, calibrated from the zips phyphox writes: 16 still poses at random
//! orientations and, in two placements of the phone (the second turned 180°), runs at 33⅓ and
//! 45 rpm with the platter 1 % fast, accelerometer and gyroscope in each simple-experiment zip,
//! the chip off the phone's centre, no radius stated. Motion and sensor from the independent
//! forward model (`common::independent`). The chip's radius within 2 mm and 3 standard errors,
//! the gyro's scale about the spindle within 0.1 % and 3 (bench/accuracy/RESULTS.md).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use spincal::campaign::file::Campaign;
use spincal::campaign::params::Params;
use spincal::campaign::run::calibrate_campaign_file;

use super::writer::{self, App, Set, VARIANTS};
use crate::common::independent::{random_gravity, Placement, Sensor};

const RATE_HZ: f64 = 100.0;
const GYRO_NOISE_RADPS: f64 = 0.002;

/// A phone's gyroscope: m = b + K ω, K within 1 % of one on the diagonal and 5 mrad off it.
struct Gyro {
    bias: [f64; 3],
    gain: [[f64; 3]; 3],
}

impl Gyro {
    fn draw(rng: &mut ChaCha8Rng) -> Gyro {
        Gyro {
            bias: [0; 3].map(|_| rng.gen_range(-0.01..0.01)),
            gain: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    if i == j {
                        1.0 + rng.gen_range(-0.01..0.01)
                    } else {
                        rng.gen_range(-0.005..0.005)
                    }
                })
            }),
        }
    }

    fn read(&self, w: [f64; 3], rng: &mut ChaCha8Rng) -> [f64; 3] {
        std::array::from_fn(|i| {
            let z = normal(rng);
            self.bias[i] + (0..3).map(|j| self.gain[i][j] * w[j]).sum::<f64>() + GYRO_NOISE_RADPS * z
        })
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// One simple-experiment zip (Android's names) of `samples` readings made by `reading(t)`.
fn zip_of(samples: usize, mut reading: impl FnMut(f64) -> ([f64; 3], [f64; 3])) -> Vec<u8> {
    let times = writer::times(0.0, RATE_HZ, samples);
    let (mut accel, mut gyro) = (Vec::new(), Vec::new());
    for &t in &times {
        let (a, g) = reading(t);
        accel.push(vec![t, a[0], a[1], a[2]]);
        gyro.push(vec![t, g[0], g[1], g[2]]);
    }
    let set = |name: &str, quantity: &str, unit: &str, rows| Set {
        name: name.into(),
        header: std::iter::once("Time (s)".to_string())
            .chain(["x", "y", "z"].map(|axis| format!("{quantity} {axis} ({unit})")))
            .collect(),
        rows,
    };
    writer::phyphox_zip(
        App::Android,
        &[
            set("Accelerometer", "Acceleration", "m/s^2", accel),
            set("Gyroscope", "Gyroscope", "rad/s", gyro),
        ],
        VARIANTS[0],
        1.79e9,
    )
}

/// One seed in the suite; `SPINCAL_PHONE_SEEDS=1-5` runs more (bench/accuracy/RESULTS.md).
#[test]
fn a_phone_campaign_of_phyphox_zips_finds_the_chip_radius_and_the_gyro_scale() {
    let seeds = match std::env::var("SPINCAL_PHONE_SEEDS") {
        Ok(range) => {
            let (a, b) = range.split_once('-').expect("SPINCAL_PHONE_SEEDS=FIRST-LAST");
            a.parse().unwrap()..=b.parse().unwrap()
        }
        Err(_) => 11..=11,
    };
    for seed in seeds {
        phone_campaign(seed);
    }
}

fn phone_campaign(seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sensor = Sensor::draw(&mut rng);
    let gyro = Gyro::draw(&mut rng);
    let dir = tempfile::tempdir().unwrap();
    let mut toml = String::from("unit = \"phone\"\n");
    let mut entry = |file: &str, bytes: Vec<u8>, keys: &str| {
        std::fs::write(dir.path().join(file), bytes).unwrap();
        toml += &format!("\n[[recording]]\nfile = \"{file}\"\nsession = \"on\"\n{keys}");
    };
    for p in 0..16 {
        let f = random_gravity(&mut rng);
        let still = sensor.read(f, [0.0; 3]);
        let bytes = zip_of(400, |_| {
            let a = still.map(|v| v + sensor.noise_mps2 * normal(&mut rng));
            (a, gyro.read([0.0; 3], &mut rng))
        });
        entry(&format!("pose-{p:02}.zip"), bytes, "kind = \"static\"\n");
    }
    let chip = [rng.gen_range(-0.03..0.03), rng.gen_range(-0.03..0.03), 0.004];
    let mut truth = Vec::new();
    for (label, out) in [("A", (0, 1.0)), ("B", (0, -1.0))] {
        let placement = Placement {
            centre_radius_m: 0.10,
            out,
            up: (2, 1.0),
            yaw_rad: rng.gen_range(-0.1..0.1),
            chip_offset_m: chip,
        };
        truth.push(placement.chip_radius_m());
        for rpm in [100.0 / 3.0, 45.0] {
            let rate = 1.01 * rpm * std::f64::consts::PI / 30.0;
            let phase = rng.gen_range(0.0..std::f64::consts::TAU);
            let spindle = placement.spindle_in_sensor();
            let bytes = zip_of(3000, |t| {
                let f = placement.specific_force(rate, 2e-3, phase, t);
                let a = sensor
                    .read(f, [0.0; 3])
                    .map(|v| v + sensor.noise_mps2 * normal(&mut rng));
                (a, gyro.read(spindle.map(|s| rate * s), &mut rng))
            });
            let out_name = if out.1 > 0.0 { "+x" } else { "-x" };
            entry(
                &format!("{label}-{rpm:.0}.zip"),
                bytes,
                &format!(
                    "kind = \"turntable\"\nrpm = {rpm}\nout = \"{out_name}\"\nup = \"+z\"\nplacement = \"{label}\"\n"
                ),
            );
        }
    }
    let path = dir.path().join("campaign.toml");
    std::fs::write(&path, &toml).unwrap();
    let campaign = Campaign::read_path(&path).unwrap();
    let output = calibrate_campaign_file(&campaign, &Params::default(), &spincal::progress::silent).unwrap();
    let result = &output.result;
    // The gyro's scale about the spindle: within 0.1 % and 3 of its standard errors.
    let gyro_fit = result.gyro.as_ref().expect("a gyro fit");
    let k_zz = gyro_fit
        .params
        .iter()
        .find(|p| p.name == "gyro_K_zz")
        .expect("K_zz");
    let se = k_zz.std_error.expect("K_zz determined, not left at nominal");
    let error = k_zz.value - gyro.gain[2][2];
    eprintln!(
        "seed {seed}: gyro K_zz {:.6} ± {se:.6} (true {:.6}; {:+.3} %, error/se {:.2})",
        k_zz.value,
        gyro.gain[2][2],
        100.0 * error / gyro.gain[2][2],
        error / se
    );
    assert!(
        error.abs() < 1e-3 * gyro.gain[2][2] && error.abs() < 3.0 * se,
        "seed {seed}: K_zz {} ± {se} against {}",
        k_zz.value,
        gyro.gain[2][2]
    );
    assert_eq!(result.placements.len(), 2);
    for (fit, truth) in result.placements.iter().zip(&truth) {
        let se = fit.radius_se_m.expect("a standard error");
        let error = fit.radius_m - truth;
        eprintln!(
            "seed {seed}: {} (true {:.2} mm; error/se {:.2})",
            fit.sentence(),
            1e3 * truth,
            error / se
        );
        assert!(
            error.abs() < 2e-3 && error.abs() < 3.0 * se,
            "{} (true {truth})",
            fit.sentence()
        );
    }
}
