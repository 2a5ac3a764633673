//! The chip's radius from the runs: a device on a record player at two speeds in each of two
//! placements (turned 180° between them), no radius stated, recorded from the independent
//! forward model (`common::independent`): the chip sits off the device's centre, so its radius
//! and its radial direction are not the device's.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use spincal::campaign::file::{SignedAxis, TurntableEntry};
use spincal::campaign::joint::{
    check_placements, chip_offset, fit_joint, placement_fits, JointSettings, PlacementError, RunInput,
    TURN_SD_DEG,
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
        centre: None,
    }
}

/// 12 still poses at random orientations, 400 samples each, 10 s apart, in power-on session 0.
fn still_poses(sensor: &Sensor, rng: &mut ChaCha8Rng) -> Vec<spincal::campaign::joint::PoseInput> {
    (0..12)
        .map(|p| {
            still_pose(
                sensor,
                random_gravity(rng),
                [0.0; 3],
                400,
                0,
                10.0 * p as f64,
                rng,
            )
        })
        .collect()
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
    let poses = still_poses(&sensor, &mut rng);
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

/// A 33⅓ rpm run with a 5-minute logging gap, across which the platter's angle moved by an
/// unknown amount (its speed wandered while nothing was recorded), beside a 45 rpm run of the
/// same placement and 12 still poses; one power-on, no radius stated. `prepare` cuts the run at
/// the gap into two segments with their own phase: each segment's rate and the chip's radius are
/// then found: the radius within 3 of its standard errors and 2 mm, each segment's rate at its
/// stated precision. Fitted whole, one phase across the gap, the same run's rate is off by more
/// than 10 standard errors.
#[test]
fn a_run_is_cut_at_a_logging_gap_into_segments_with_their_own_phase() {
    use spincal::campaign::prepare::{prepare, UnitRecording};
    use spincal::input::recording::Recording;
    let mut segment_z = Vec::new();
    for seed in 7..=12 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sensor = Sensor::draw(&mut rng);
        let poses = still_poses(&sensor, &mut rng);
        let placement = Placement {
            centre_radius_m: 0.09,
            out: (0, 1.0),
            up: (2, 1.0),
            yaw_rad: 0.05,
            chip_offset_m: [0.01, -0.02, 0.004],
        };
        let rate = |rpm: f64| 1.01 * rpm * RPM;
        let slow = 100.0 / 3.0;
        // Each call draws its own phase: the angle after the gap is unrelated to the one before.
        let halves: Vec<RunInput> = (0..2)
            .map(|_| {
                let e = entry(&placement, "A", slow, None);
                turntable_run(
                    &sensor,
                    &placement,
                    e,
                    rate(slow),
                    [0.0; 3],
                    30.0,
                    100.0,
                    "half",
                    &mut rng,
                )
            })
            .collect();
        let gap_s = 300.0;
        let time_s: Vec<f64> = halves[0]
            .time_s
            .iter()
            .copied()
            .chain(halves[1].time_s.iter().map(|t| t + 30.0 + gap_s))
            .collect();
        let accel: [Vec<f64>; 3] = std::array::from_fn(|k| {
            [halves[0].accel_mps2[k].clone(), halves[1].accel_mps2[k].clone()].concat()
        });
        let fast = turntable_run(
            &sensor,
            &placement,
            entry(&placement, "A", 45.0, None),
            rate(45.0),
            [0.0; 3],
            30.0,
            100.0,
            "fast",
            &mut rng,
        );
        let unit = |name: &str, time_s: &[f64], accel: &[Vec<f64>; 3], rpm: f64| UnitRecording {
            name: name.into(),
            recording: Recording {
                time_s: time_s.to_vec(),
                accel_mps2: accel.clone(),
                gyro_radps: None,
                temperature_c: None,
                source: Default::default(),
            },
            turntable: Some(entry(&placement, "A", rpm, None)),
            truth: None,
            floor_mps2: None,
            random_mps2: None,
            session: Some("power-on".into()),
        };
        let prepared = prepare(&[
            unit("gapped.csv", &time_s, &accel, slow),
            unit("fast.csv", &fast.time_s, &fast.accel_mps2, 45.0),
        ])
        .unwrap();
        assert_eq!(
            prepared.runs.len(),
            3,
            "seed {seed}: two segments and the 45 rpm run"
        );
        assert_eq!(prepared.split_runs.len(), 1);
        let split = &prepared.split_runs[0];
        assert_eq!(split.gaps.len(), 1);
        assert!(
            (split.gaps[0].length_s - (gap_s + 0.01)).abs() < 1e-6,
            "{:?}",
            split.gaps
        );
        assert_eq!(
            (prepared.run_origin[1].start, prepared.run_origin[1].end),
            (3000, 6000)
        );
        let joint = fit_joint(&prepared.runs, &poses, &settings(), &spincal::progress::silent).unwrap();
        let omega_error = |run: &spincal::campaign::joint::RunFit| {
            let omega = &run.params[1];
            let se = omega.std_error.expect("a standard error");
            ((omega.value - rate(slow)) / se, se)
        };
        for run in &joint.runs[..2] {
            let (z, se) = omega_error(run);
            eprintln!(
                "seed {seed} {}: rate error {z:.2} se (se {se:.2e} rad/s)",
                run.name
            );
            segment_z.push(z.abs());
        }
        let fits = placement_fits(&prepared.runs, &joint);
        assert_eq!(fits.len(), 1);
        let (radius, se) = (fits[0].radius_m, fits[0].radius_se_m.unwrap());
        let truth = placement.chip_radius_m();
        eprintln!(
            "seed {seed}: radius {:.3} mm (true {:.3}), se {:.3} mm",
            1e3 * radius,
            1e3 * truth,
            1e3 * se
        );
        assert!(
            (radius - truth).abs() < 3.0 * se && (radius - truth).abs() < 2e-3,
            "seed {seed}: {}",
            fits[0].sentence()
        );
        // The same run whole: one phase across the gap.
        let mut whole = vec![RunInput::new(
            "gapped.csv".into(),
            time_s.clone(),
            accel.clone(),
            vec![true; time_s.len()],
            entry(&placement, "A", slow, None),
            None,
        )
        .in_session(Some(0))];
        whole.push(prepared.runs[2].clone());
        let joint = fit_joint(&whole, &poses, &settings(), &spincal::progress::silent).unwrap();
        let (z, _) = omega_error(&joint.runs[0]);
        eprintln!("seed {seed} whole: rate error {z:.1} se");
        assert!(
            z.abs() > 10.0,
            "seed {seed}: the whole run's rate is {z:.1} se off"
        );
    }
    // The segments' rates are unbiased at their stated precision: the median |error|/se is 0.67
    // for a normal error. (Measured on seeds 7–18: median 0.57, one segment of 24 at 7.6 se; the
    // runs without a gap scatter as widely, RMS 1.6 se, so that is the joint fit's rate error
    // bar on 30 s runs, not the cut. Whole, the same runs were 16–67 se off.)
    segment_z.sort_by(f64::total_cmp);
    let median = 0.5 * (segment_z[5] + segment_z[6]);
    assert!(
        median < 1.5,
        "median |rate error| / se {median:.2}: {segment_z:?}"
    );
}

/// A campaign of `seed` whose placements turn the device about its centre (100 mm from the
/// spindle) to `outs` (+x, −x, +y: 0°, 180°, 90°), each turned by hand (off by a normal
/// [`TURN_SD_DEG`]), runs of 30 s at 33⅓ and 45 rpm, the chip up to 30 mm off the centre; each
/// run states the centre within 5 mm (the statement itself drawn within that). The chip's offset
/// along x and y is the truth.
fn turned_campaign(
    seed: u64,
    outs: &[(usize, f64)],
) -> (Vec<RunInput>, [f64; 2], Vec<spincal::campaign::joint::PoseInput>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sensor = Sensor::draw(&mut rng);
    let poses = still_poses(&sensor, &mut rng);
    let chip = [rng.gen_range(-0.03..0.03), rng.gen_range(-0.03..0.03), 0.004];
    let normal = |rng: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(rng) };
    let stated = RadiusPrior {
        value_m: 0.10 + 0.005 * normal(&mut rng),
        tolerance_m: 0.005,
    };
    let mut runs = Vec::new();
    for (p, &out) in outs.iter().enumerate() {
        let placement = Placement {
            centre_radius_m: 0.10,
            out,
            up: (2, 1.0),
            yaw_rad: TURN_SD_DEG.to_radians() * normal(&mut rng),
            chip_offset_m: chip,
        };
        let label = ["A", "B", "C"][p];
        for rpm in [100.0 / 3.0, 45.0] {
            let mut e = entry(&placement, label, rpm, None);
            e.centre = Some(stated);
            let name = format!("{label} {rpm:.0} rpm");
            let run = turntable_run(
                &sensor,
                &placement,
                e,
                1.01 * rpm * RPM,
                [0.0; 3],
                30.0,
                100.0,
                &name,
                &mut rng,
            );
            runs.push(run.in_session(Some(0)));
        }
    }
    (runs, [chip[0], chip[1]], poses)
}

/// Placements turned 0°, 180° and 90° about the device's stated centre: the chip's offset along
/// x and y within 3 standard errors and 2 mm on each of 4 seeds, and the errors over their
/// standard errors scatter as a unit normal's (RMS within 0.4–1.6, the 99 % range of 8 draws'
/// RMS). Turned 180° only: the offset along x alone, y named as needing a turn of 90°.
#[test]
fn the_chip_offset_in_the_device_comes_from_turned_placements() {
    let mut z = Vec::new();
    for seed in 21..=24 {
        let (runs, truth, poses) = turned_campaign(seed, &[(0, 1.0), (0, -1.0), (1, 1.0)]);
        check_placements(&runs, &[0]).unwrap();
        let joint = fit_joint(&runs, &poses, &settings(), &spincal::progress::silent).unwrap();
        let offset = chip_offset(&runs, &joint).expect("the runs state the centre");
        eprintln!(
            "seed {seed}: {} (true {:.2}, {:.2} mm)",
            offset.sentence(),
            1e3 * truth[0],
            1e3 * truth[1]
        );
        assert_eq!(offset.undetermined, None, "seed {seed}");
        assert_eq!(offset.components.len(), 2, "seed {seed}");
        for (c, (axis, truth)) in offset.components.iter().zip([("+x", truth[0]), ("+y", truth[1])]) {
            assert_eq!(c.axis, axis);
            let error = c.offset_m - truth;
            assert!(
                error.abs() < 2e-3 && error.abs() < 3.0 * c.se_m,
                "seed {seed}: {axis} error {error} against se {}",
                c.se_m
            );
            z.push(error / c.se_m);
        }
        let centre = offset.centre_radius_m.unwrap() - 0.10;
        assert!(
            centre.abs() < 3.0 * offset.centre_radius_se_m.unwrap(),
            "seed {seed}: centre off by {centre}"
        );
    }
    let rms = (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt();
    eprintln!("error / se: {z:.2?}, RMS {rms:.2}");
    assert!((0.4..1.6).contains(&rms), "RMS of error / se {rms:.2}: {z:?}");

    let (runs, truth, poses) = turned_campaign(25, &[(0, 1.0), (0, -1.0)]);
    let joint = fit_joint(&runs, &poses, &settings(), &spincal::progress::silent).unwrap();
    let offset = chip_offset(&runs, &joint).unwrap();
    eprintln!("180° only: {}", offset.sentence());
    assert_eq!(offset.components.len(), 1);
    let c = &offset.components[0];
    assert_eq!(c.axis, "+x");
    assert!(
        (c.offset_m - truth[0]).abs() < 3.0 * c.se_m,
        "{}",
        offset.sentence()
    );
    assert!(
        offset.sentence().contains("along y needs a placement turned 90°"),
        "{}",
        offset.sentence()
    );
    // Without a stated centre nothing is claimed.
    let unstated: Vec<RunInput> = runs
        .into_iter()
        .map(|mut r| {
            r.entry.centre = None;
            r
        })
        .collect();
    assert_eq!(chip_offset(&unstated, &joint), None);
}
