//! The chip's radius from the runs: a device on a record player at two speeds in each of two
//! placements (turned 180° between them), no radius stated, recorded from the independent
//! forward model (`common::independent`): the chip sits off the device's centre, so its radius
//! and its radial direction are not the device's.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spincal::campaign::file::{SignedAxis, TurntableEntry};
use spincal::campaign::joint::{
    check_placements, fit_joint, placement_fits, JointSettings, PlacementError, RunInput,
};
use spincal::turntable::fit::RadiusPrior;

use crate::common::independent::{random_gravity, still_pose, turntable_run, Placement, Sensor, G};

const RPM: f64 = std::f64::consts::PI / 30.0;

fn entry(placement: &Placement, label: &str, rpm: f64, radius: Option<RadiusPrior>) -> TurntableEntry {
    let axis = |(axis, sign): (usize, f64)| SignedAxis {
        axis,
        sign: if sign > 0.0 { 1 } else { -1 },
    };
    TurntableEntry {
        rpm,
        radius,
        out: axis(placement.out),
        up: axis(placement.up),
        direction: None,
        placement: Some(label.to_string()),
    }
}

/// A phone-like campaign of `seed`: 12 still poses and, in two placements of the device (centre
/// at 100 mm, the second turned 180°), runs at 33⅓ and 45 rpm with the platter 1 % fast; one
/// power-on throughout. `stated`: what the user writes as each placement's radius.
fn campaign(
    seed: u64,
    stated: impl Fn(&Placement) -> Option<RadiusPrior>,
) -> (Vec<RunInput>, Vec<f64>, Vec<spincal::campaign::joint::PoseInput>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sensor = Sensor::draw(&mut rng);
    let poses = (0..12)
        .map(|p| {
            still_pose(
                &sensor,
                random_gravity(&mut rng),
                [0.0; 3],
                400,
                0,
                10.0 * p as f64,
                &mut rng,
            )
        })
        .collect();
    let chip = [rng.gen_range(-0.03..0.03), rng.gen_range(-0.03..0.03), 0.004];
    let placements = [(0, 1.0), (0, -1.0)].map(|out| Placement {
        centre_radius_m: 0.10,
        out,
        up: (2, 1.0),
        yaw_rad: rng.gen_range(-0.1..0.1),
        chip_offset_m: chip,
    });
    let (mut runs, mut truth) = (Vec::new(), Vec::new());
    for (p, placement) in placements.iter().enumerate() {
        let label = ["A", "B"][p];
        for rpm in [100.0 / 3.0, 45.0] {
            let e = entry(placement, label, rpm, stated(placement));
            let name = format!("{label} {rpm:.0} rpm");
            let run = turntable_run(
                &sensor,
                placement,
                e,
                1.01 * rpm * RPM,
                [0.0; 3],
                40.0,
                100.0,
                &name,
                &mut rng,
            );
            runs.push(run.in_session(Some(0)));
        }
        truth.push(placement.chip_radius_m());
    }
    (runs, truth, poses)
}

fn settings() -> JointSettings {
    JointSettings {
        gravity_mps2: G,
        ..JointSettings::default()
    }
}

/// No radius stated: each placement's chip radius within 2 mm of the truth and within 3 of its
/// standard errors, on 3 seeds; the two placements' radii differ as the chip's offset makes them.
#[test]
fn the_chip_radius_comes_from_two_speeds_of_one_placement() {
    for seed in 1..=3 {
        let (runs, truth, poses) = campaign(seed, |_| None);
        check_placements(&runs, &[0]).unwrap();
        let joint = fit_joint(&runs, &poses, &settings(), &spincal::progress::silent).unwrap();
        let found = placement_fits(&runs, &joint);
        assert_eq!(found.len(), 2, "seed {seed}");
        for (fit, truth) in found.iter().zip(&truth) {
            let error = fit.radius_m - truth;
            let se = fit.radius_se_m.expect("a standard error");
            eprintln!(
                "seed {seed} placement {}: {:.3} mm (true {:.3}), error {:.4} mm, se {:.4} mm",
                fit.label,
                1e3 * fit.radius_m,
                1e3 * truth,
                1e3 * error,
                1e3 * se
            );
            assert!(error.abs() < 2e-3, "seed {seed}: {}", fit.sentence());
            assert!(
                error.abs() < 3.0 * se,
                "seed {seed}: error {error} against se {se}"
            );
            assert!(!fit.contradicted && fit.stated.is_none(), "seed {seed}");
        }
    }
}

/// The device's centre stated as the radius within a ruler's 2 mm, while the chip sits 20–40 mm
/// away: the runs contradict it, by name. The chip's true radius stated within 2 mm: no
/// contradiction.
#[test]
fn a_stated_radius_the_runs_contradict_is_named() {
    let centre = |_: &Placement| {
        Some(RadiusPrior {
            value_m: 0.10,
            tolerance_m: 0.002,
        })
    };
    for seed in 4..=5 {
        let (runs, truth, poses) = campaign(seed, centre);
        let joint = fit_joint(&runs, &poses, &settings(), &spincal::progress::silent).unwrap();
        let found = placement_fits(&runs, &joint);
        // The chip's offset moves one placement's radius out and the other's in.
        let off = found
            .iter()
            .zip(&truth)
            .filter(|(_, t)| (*t - 0.10f64).abs() > 0.008);
        for (fit, truth) in off {
            assert!(fit.contradicted, "seed {seed} (true {truth}): {}", fit.sentence());
            assert!(fit.sentence().contains("contradicts"), "{}", fit.sentence());
        }
        let (runs, _, poses) = campaign(seed, |p| {
            Some(RadiusPrior {
                value_m: p.chip_radius_m(),
                tolerance_m: 0.002,
            })
        });
        let joint = fit_joint(&runs, &poses, &settings(), &spincal::progress::silent).unwrap();
        for fit in placement_fits(&runs, &joint) {
            assert!(!fit.contradicted, "seed {seed}: {}", fit.sentence());
        }
    }
}

/// A placement without a radius needs two speeds or an offset the poses pin; one mounting.
#[test]
fn a_placement_the_runs_cannot_determine_is_refused_by_name() {
    let (runs, _, _) = campaign(6, |_| None);
    // One speed of placement A, in no session: refused.
    let lone = vec![runs[0].clone().in_session(None)];
    let e = check_placements(&lone, &[0]).unwrap_err();
    assert!(matches!(e, PlacementError::Radius { .. }), "{e}");
    assert!(
        e.to_string().contains("A 33 rpm") && e.to_string().contains("one run"),
        "{e}"
    );
    // The same run in the poses' session: its offset is pinned, so the radius is determined.
    check_placements(&[runs[0].clone()], &[0]).unwrap();
    // Two runs under one label with different mountings.
    let mut moved = runs[2].clone();
    moved.entry.placement = Some("A".into());
    let e = check_placements(&[runs[0].clone(), moved], &[0]).unwrap_err();
    assert!(matches!(e, PlacementError::Mounting { .. }), "{e}");
}
