//! A `static` recording that turns is refused by the accelerometer's own spectrum, gyro or not
//! (campaign::checks::STILL_LINE_PEAK_TO_MEDIAN), and no still recording is: simulated still
//! poses with noise and bias drift over many seeds, a thermal warm-up, and the real still
//! recordings of ../shared/data (skipped when absent).

use crate::common;

use spincal::campaign::checks::{still_pose_lines, STILL_LINE_PEAK_TO_MEDIAN};
use spincal::campaign::prepare::UnitRecording;
use spincal::campaign::select::calibrate_campaign;
use spincal::input::formats::{read_path, Format, ReadOptions};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};
use spincal::simulate::thermal::{simulate_thermal_campaign, ThermalProfile};

/// The largest peak-to-median over every pose of `rec`.
fn largest(rec: &spincal::input::recording::Recording, name: &str) -> f64 {
    still_pose_lines(rec, name)
        .unwrap()
        .iter()
        .map(|l| l.peak_to_median)
        .fold(0.0, f64::max)
}

#[test]
fn simulated_still_poses_show_no_line_and_relabelled_runs_do() {
    let mut still_max: f64 = 0.0;
    for (seed, pose_s) in (0..120).map(|s| (s, if s % 2 == 0 { 5.0 } else { 30.0 })) {
        let setup = CampaignSetup {
            runs: Vec::new(),
            pose_duration_s: pose_s,
            ..CampaignSetup::default()
        };
        let sim = simulate_campaign(&setup, seed).unwrap();
        let rec = &sim.recordings[0].recording;
        still_max = still_max.max(largest(rec, "still"));
    }
    let thermal = simulate_thermal_campaign(&ThermalProfile::default(), 3);
    let mut thermal_max: f64 = 0.0;
    for r in std::iter::once(&thermal.warmup).chain(&thermal.poses) {
        thermal_max = thermal_max.max(largest(&r.recording, "warm-up"));
    }
    let mut run_min = f64::INFINITY;
    for seed in 0..4 {
        let sim = simulate_campaign(&CampaignSetup::default(), seed).unwrap();
        for r in sim.recordings.iter().filter(|r| r.turntable.is_some()) {
            run_min = run_min.min(largest(&r.recording, &r.name));
        }
    }
    println!("peak-to-median: simulated still poses at most {still_max:.1}, thermal warm-up {thermal_max:.1}; turntable runs read as still at least {run_min:.0} (threshold {STILL_LINE_PEAK_TO_MEDIAN})");
    assert!(still_max < STILL_LINE_PEAK_TO_MEDIAN / 10.0, "{still_max}");
    assert!(thermal_max < STILL_LINE_PEAK_TO_MEDIAN / 10.0, "{thermal_max}");
    assert!(run_min > STILL_LINE_PEAK_TO_MEDIAN * 10.0, "{run_min}");
}

#[test]
fn a_turntable_run_without_gyro_listed_as_static_is_refused_by_name() {
    let sim = simulate_campaign(&CampaignSetup::default(), 7).unwrap();
    let mut units: Vec<UnitRecording> = sim.unit_recordings(false);
    let run = units.iter().position(|u| u.turntable.is_some()).unwrap();
    units[run].turntable = None;
    units[run].recording.gyro_radps = None;
    let name = units[run].name.clone();
    let err = calibrate_campaign("unit", &units, &Default::default(), &spincal::progress::silent)
        .expect_err("refused")
        .to_string();
    assert!(err.contains(&name) && err.contains("`kind`"), "{err}");
    assert!(err.contains("listed as `static`") && err.contains("33."), "{err}");
    assert!(err.contains("kind = \"turntable\""), "{err}");
}

#[test]
fn real_still_recordings_are_not_taken_for_turning() {
    // (file, format, sample rate where the file has no time column): still poses joined by
    // rotations by hand (Xsens, T265, imucal's session with its 360° turns), and poses alone.
    let files: [(&str, Option<Format>, Option<f64>); 4] = [
        ("imu/imu_tk_xsens/xsens_acc.mat", None, None),
        ("imu/realsense_t265/t265_acc.mat", None, None),
        (
            "imu/mpu6050/example_data_calibration.csv",
            Some(Format::Mpu6050),
            None,
        ),
        ("imu/imucal/annotated_session.csv", None, Some(204.8)),
    ];
    for (relative, format, sample_rate_hz) in files {
        let Some(path) = common::shared_data(relative) else {
            return;
        };
        let options = ReadOptions {
            format,
            sample_rate_hz,
            ..Default::default()
        };
        let loaded = match read_path(&path, &options) {
            Ok(l) => l,
            Err(e) => panic!("{relative}: {e}"),
        };
        let worst = largest(&loaded.recording, relative);
        println!("{relative}: largest peak-to-median over its still poses {worst:.1}");
        assert!(worst < STILL_LINE_PEAK_TO_MEDIAN / 10.0, "{relative}: {worst}");
    }
}
