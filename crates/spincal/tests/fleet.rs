//! Fleets: eight simulated units, each with its own sensor errors (one deliberately faulty), and
//! two broken sources, calibrated together.
//!
//! What must hold:
//! - every calibrated unit's twelve sensor parameters lie within 3 reported standard errors of
//!   that unit's truth for at least 90 % of the 96 (unit, parameter) pairs, and each unit has at
//!   least half of its 12 within;
//! - the faulty unit (bias x +0.1 g, scale y +5 %) is flagged on bias_x and scale_error_y, and no
//!   other unit is flagged on anything;
//! - a unit with a missing recording and a folder without campaign.toml fail with located
//!   messages while every other unit is calibrated;
//! - results are those of calibrating a unit alone (the CLI's path, on all threads), and the
//!   same with 1 and 2 fleet workers: results.json and model.json equal byte for byte, apart from
//!   `seconds_total` and `stage_seconds` (wall time);
//! - the units are the suite's one fleet (`common::suite_fleet`), stored for the CLI's and
//!   Python's fleet tests or found equal to the stored calibration.

use std::path::PathBuf;

use crate::common::suite_fleet::{self, setup, SEED};
use spincal::fleet::{
    calibrate_fleet, fleet_table, silent_fleet, FleetSettings, OutlierSettings, UnitOutcome,
};
use spincal::simulate::fleet::{simulate_fleet, FleetSetup};

/// results.json without the wall time, and model.json.
fn comparable(outcome: &UnitOutcome) -> (String, Option<String>) {
    let cal = outcome.result.as_ref().expect("calibrated");
    let mut value = serde_json::to_value(&cal.result).unwrap();
    value.as_object_mut().unwrap().remove("seconds_total");
    value.as_object_mut().unwrap().remove("stage_seconds");
    (serde_json::to_string_pretty(&value).unwrap(), cal.model_json())
}

#[test]
fn a_fleet_recovers_each_unit_flags_the_faulty_one_and_reports_broken_ones() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = simulate_fleet(&setup(), SEED).unwrap();
    let mut sources: Vec<PathBuf> = fleet.write_folders(dir.path()).unwrap();
    // A ninth unit whose turntable recording is missing, and a folder with no campaign at all.
    let broken = simulate_fleet(
        &FleetSetup {
            units: 1,
            faulty: Vec::new(),
            ..setup()
        },
        7,
    )
    .unwrap();
    let broken_dir = dir.path().join("broken");
    broken.units[0].campaign.write_folder(&broken_dir, false).unwrap();
    let missing = broken.units[0].campaign.recordings[1].name.clone() + ".csv";
    std::fs::remove_file(broken_dir.join(&missing)).unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    sources.insert(3, broken_dir.clone());
    sources.push(empty.clone());

    let started = std::time::Instant::now();
    let settings = FleetSettings {
        threads: Some(2),
        ..FleetSettings::default()
    };
    let outcomes = calibrate_fleet(&sources, &settings, &silent_fleet);
    println!(
        "fleet of {} sources on 2 workers: {:.1} s",
        sources.len(),
        started.elapsed().as_secs_f64()
    );
    assert_eq!(outcomes.len(), sources.len());

    // Broken sources fail alone, each with a located message.
    let broken_outcome = &outcomes[3];
    assert_eq!(broken_outcome.unit, "broken");
    let e = broken_outcome.result.as_ref().unwrap_err();
    assert!(e.contains("campaign.toml:") && e.contains(&missing), "{e}");
    let e = outcomes.last().unwrap().result.as_ref().unwrap_err();
    assert!(
        e.contains(&empty.display().to_string()) && e.contains("campaign.toml"),
        "{e}"
    );

    // Every simulated unit: calibrated, its parameters within 3 SE of its truth.
    let good: Vec<&UnitOutcome> = outcomes.iter().filter(|o| o.unit.starts_with("unit-")).collect();
    assert_eq!(good.len(), 8);
    let (mut inside, mut total) = (0usize, 0usize);
    for (outcome, unit) in good.iter().zip(&fleet.units) {
        assert_eq!(outcome.unit, unit.name);
        let cal = outcome
            .result
            .as_ref()
            .unwrap_or_else(|e| panic!("{}: {e}", unit.name));
        assert_eq!(cal.unit, unit.name);
        let truth = unit.campaign.truth.sensor.params();
        let mut unit_inside = 0;
        let mut worst = 0.0f64;
        for (k, p) in cal.sensor_params().iter().enumerate() {
            let se = p.std_error.expect("every sensor parameter has a standard error");
            let z = (p.value - truth[k]) / se;
            println!(
                "  {:<24} {:+.6e} truth {:+.6e} se {:.2e} z {z:+.1}",
                p.name, p.value, truth[k], se
            );
            worst = worst.max(z.abs());
            unit_inside += usize::from(z.abs() <= 3.0);
        }
        println!(
            "{}{}: {} poses, {unit_inside}/12 within 3 SE (worst {worst:.1} SE), saved {:?}",
            unit.name,
            if unit.faulty { " (faulty)" } else { "" },
            cal.result.joint.poses.len(),
            cal.saved()
        );
        assert!(
            unit_inside >= 6,
            "{}: only {unit_inside}/12 within 3 SE",
            unit.name
        );
        inside += unit_inside;
        total += 12;
    }
    let coverage = inside as f64 / total as f64;
    println!("coverage {inside}/{total} = {coverage:.3}");
    assert!(coverage >= 0.9, "coverage {coverage}");

    // The faulty unit is flagged on what was made faulty; no other unit is flagged.
    let table = fleet_table(&outcomes, &OutlierSettings::default());
    for flag in &table.outliers {
        println!("flag: {}: {}", flag.unit, flag.reason);
    }
    // The margin: every unit's largest |z| / critical value over the parameters.
    let all = fleet_table(
        &outcomes,
        &OutlierSettings {
            false_alarm_probability: 0.99,
            ..OutlierSettings::default()
        },
    );
    for row in all.rows.iter().filter(|r| r.ok) {
        let worst = row.flags.iter().map(|f| f.score.abs()).fold(0.0, f64::max);
        let critical = table
            .rows
            .iter()
            .find(|r| r.unit == row.unit)
            .map(|r| r.flags.len());
        println!(
            "{}: largest |z| {worst:.1} ({critical:?} flags at the default)",
            row.unit
        );
    }
    let faulty = &fleet.units[5].name;
    assert_eq!(table.flagged_units(), [faulty.as_str()]);
    let flagged: Vec<&str> = table.outliers.iter().map(|f| f.parameter.as_str()).collect();
    assert!(flagged.contains(&"bias_x (m/s²)"), "{flagged:?}");
    assert!(flagged.contains(&"scale_error_y (fraction)"), "{flagged:?}");
    assert_eq!((table.units_ok, table.units_failed), (8, 2));
    let csv = table.to_csv();
    assert_eq!(csv.lines().count(), 1 + sources.len());
    assert!(csv.lines().next().unwrap().contains("bias_x SE (m/s²)"), "{csv}");

    // The suite's one fleet: stored for the CLI's and Python's tests, or checked equal to the
    // stored one (another process's calibration of the same units).
    suite_fleet::record(&fleet, dir.path(), &good);

    // A good unit alone, on the CLI's path (all threads, conditions in parallel): the same bytes.
    let started = std::time::Instant::now();
    let outcome = good[0];
    let campaign =
        spincal::campaign::file::Campaign::read_path(&outcome.source.join("campaign.toml")).unwrap();
    let alone = spincal::campaign::run::calibrate_campaign_file(
        &campaign,
        &FleetSettings::default().params,
        &spincal::progress::silent,
    )
    .unwrap();
    // The simulated campaign file states the datasheet's range and nonlinearity: q's prior is
    // that bound, the other terms keep the generic widths.
    let priors = &alone.result.sensor_priors;
    assert_eq!(priors.is_bound, [false, false, false, true], "{priors:?}");
    assert_eq!(
        priors.width[3],
        campaign.datasheet.nonlinearity.unwrap().quadratic_per_mps2(),
        "{priors:?}"
    );
    let mut value = serde_json::to_value(&alone.result).unwrap();
    value.as_object_mut().unwrap().remove("seconds_total");
    value.as_object_mut().unwrap().remove("stage_seconds");
    let expected = (
        serde_json::to_string_pretty(&value).unwrap(),
        alone.saved.as_ref().map(|m| m.to_json() + "\n"),
    );
    assert!(
        comparable(outcome) == expected,
        "{}: differs from the unit alone",
        outcome.unit
    );
    println!("a unit alone: {:.1} s", started.elapsed().as_secs_f64());

    // One worker: the same results (the faulty unit and the broken ones).
    let subset: Vec<PathBuf> = [3, 6, sources.len() - 1].map(|i| sources[i].clone()).to_vec();
    let one = calibrate_fleet(
        &subset,
        &FleetSettings {
            threads: Some(1),
            ..FleetSettings::default()
        },
        &silent_fleet,
    );
    for (a, i) in one.iter().zip([3, 6, sources.len() - 1]) {
        let b = &outcomes[i];
        assert_eq!(a.unit, b.unit);
        match (&a.result, &b.result) {
            (Ok(_), Ok(_)) => assert!(comparable(a) == comparable(b), "{}: 1 vs 2 workers", a.unit),
            (Err(x), Err(y)) => assert_eq!(x, y),
            _ => panic!("{}: one run failed, the other not", a.unit),
        }
    }
}
