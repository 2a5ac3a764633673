//! `--gyro-file` on every command that reads a recording (issue 48 item 2): a gyro logged on its
//! own jittered clock at another rate is merged on time by the library's one rule (the
//! recording's samples outside its span dropped with a note, or, in `correct`'s stream, written
//! with status `no-gyro`); under half overlap is refused naming both spans. Each test checks the
//! exit code, the message and that the inputs are unchanged
//! (`run_keeping`).

use std::path::{Path, PathBuf};
use std::process::Command;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spincal::correctors::gyro::GyroModel;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::correctors::static_cal::StaticCalibration;
use spincal::simulate::gyro_poses::{simulate_pose_session, PoseSessionSetup};

use crate::harness::spincal;

/// Runs `cmd`; returns its exit code, stdout and stderr.
fn outcome(cmd: &mut Command) -> (i32, String, String) {
    let out = cmd.output().expect("runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn contents(paths: &[&Path]) -> Vec<Vec<u8>> {
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

/// Runs `cmd` as [`outcome`] does and checks that it left `inputs` byte for byte as they were.
fn run_keeping(cmd: &mut Command, inputs: &[&Path]) -> (i32, String, String) {
    let before = contents(inputs);
    let result = outcome(cmd);
    assert_eq!(contents(inputs), before, "{cmd:?} changed its inputs");
    result
}

/// Jittered times at `rate_hz` over `from_s`–`to_s` (±a fifth of an interval).
fn clock(rng: &mut ChaCha8Rng, rate_hz: f64, from_s: f64, to_s: f64) -> Vec<f64> {
    let n = ((to_s - from_s) * rate_hz) as usize;
    let jitter = 0.2 / rate_hz;
    (0..=n)
        .map(|i| from_s + i as f64 / rate_hz + rng.gen_range(-jitter..jitter))
        .collect()
}

/// `t,ax,ay,az` rows from `accel(t)` at 100 Hz over 0–`duration_s`, and imu_tk's `t gx gy gz`
/// rows from `gyro(t)` at 190 Hz over `gyro_span`, each on its own jittered clock.
fn pair(
    dir: &Path,
    duration_s: f64,
    gyro_span: (f64, f64),
    accel: impl Fn(f64, &mut ChaCha8Rng) -> [f64; 3],
    gyro: impl Fn(f64, &mut ChaCha8Rng) -> [f64; 3],
) -> (PathBuf, PathBuf) {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut text = String::from("t,ax,ay,az\n");
    for t in clock(&mut rng, 100.0, 0.0, duration_s) {
        let a = accel(t, &mut rng);
        text += &format!("{t:.6},{:.6},{:.6},{:.6}\n", a[0], a[1], a[2]);
    }
    let accel_path = dir.join("acc.csv");
    std::fs::write(&accel_path, text).unwrap();
    let mut text = String::new();
    for t in clock(&mut rng, 190.0, gyro_span.0, gyro_span.1) {
        let w = gyro(t, &mut rng);
        text += &format!("{t:.6} {:.7} {:.7} {:.7}\n", w[0], w[1], w[2]);
    }
    let gyro_path = dir.join(format!("gyr-{}-{}.txt", gyro_span.0, gyro_span.1));
    std::fs::write(&gyro_path, text).unwrap();
    (accel_path, gyro_path)
}

/// A still accelerometer with noise, and a gyro's noise around a small bias.
fn still(dir: &Path, duration_s: f64, gyro_span: (f64, f64)) -> (PathBuf, PathBuf) {
    pair(
        dir,
        duration_s,
        gyro_span,
        |_, rng| [0.0, 0.0, 9.81].map(|v| v + 0.01 * rng.gen_range(-1.0..1.0)),
        |_, rng| [0.01, -0.02, 0.005].map(|v| v + 0.002 * rng.gen_range(-1.0..1.0)),
    )
}

/// The number in `text` just before `marker` (`… 812 samples outside …`).
fn count_before(text: &str, marker: &str) -> usize {
    let head = &text[..text
        .find(marker)
        .unwrap_or_else(|| panic!("{marker:?} in {text}"))];
    head.split_whitespace().last().unwrap().parse().unwrap()
}

/// Under half overlap: the message names the gyro file and both spans.
fn names_both_spans(stderr: &str, gyro: &Path) {
    let name = gyro.file_name().unwrap().to_string_lossy();
    assert!(stderr.contains(&*name), "{stderr}");
    assert!(stderr.contains("the gyro file's span ("), "{stderr}");
    assert!(stderr.contains("the recording's "), "{stderr}");
    assert!(stderr.contains("overlap for at least half"), "{stderr}");
}

#[test]
fn correct_merges_the_gyro_in_its_stream_and_marks_the_rows_outside_it() {
    let dir = tempfile::tempdir().unwrap();
    let (acc, gyr) = still(dir.path(), 20.0, (3.0, 18.0));
    let mut file = CorrectorFile::new(CorrectorModel::Static(Box::new(StaticCalibration::identity(
        9.81,
    ))));
    let mut gyro = GyroModel::IDEAL;
    gyro.bias_radps = [0.01, -0.02, 0.005];
    file.gyro = Some(gyro);
    let model = dir.path().join("model.json");
    file.write_path(&model).unwrap();
    let inputs = [acc.as_path(), gyr.as_path(), model.as_path()];
    let out = dir.path().join("out.csv");
    let (code, _, stderr) = run_keeping(
        spincal()
            .args(["correct", "--model"])
            .arg(&model)
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&gyr)
            .arg("-o")
            .arg(&out),
        &inputs,
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stderr.contains("interpolated linearly onto the input's 2001 rows"),
        "{stderr}"
    );
    let outside = count_before(&stderr, "rows outside its span");
    // 0–3 s and 18–20 s: about 500 rows.
    assert!((480..=520).contains(&outside), "{stderr}");
    assert!(stderr.contains("lie outside the gyro file's span"), "{stderr}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().count(), 2002, "every row and the header");
    assert_eq!(text.matches("no-gyro: line").count(), outside);
    assert!(text.lines().next().unwrap().contains("gx_corrected_radps"));
    // Inside the overlap the gyro's bias is taken out: about zero.
    let row = text.lines().nth(1000).unwrap();
    let gx: f64 = row.split(',').nth(7).unwrap().parse().unwrap();
    assert!(gx.abs() < 0.003, "{row}");

    // Under half overlap: refused naming both spans, nothing written.
    let (_, far) = still(dir.path(), 20.0, (14.0, 30.0));
    let refused = dir.path().join("refused.csv");
    let (code, _, stderr) = run_keeping(
        spincal()
            .args(["correct", "--model"])
            .arg(&model)
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&far)
            .arg("-o")
            .arg(&refused),
        &inputs,
    );
    assert_eq!(code, 1, "{stderr}");
    names_both_spans(&stderr, &far);
    assert!(!refused.exists());

    // A model without a gyro calibration: the gyro file has nothing to correct.
    let plain = dir.path().join("plain.json");
    CorrectorFile::new(CorrectorModel::Static(Box::new(StaticCalibration::identity(
        9.81,
    ))))
    .write_path(&plain)
    .unwrap();
    let (code, _, stderr) = outcome(
        spincal()
            .args(["correct", "--model"])
            .arg(&plain)
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&gyr),
    );
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("calibrates no gyroscope"), "{stderr}");
}

#[test]
fn allan_merges_the_gyro_on_time_and_analyses_the_covered_samples() {
    let dir = tempfile::tempdir().unwrap();
    let (acc, gyr) = still(dir.path(), 60.0, (5.0, 55.0));
    let (code, stdout, stderr) = run_keeping(
        spincal()
            .arg("allan")
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&gyr)
            .arg("--json"),
        &[&acc, &gyr],
    );
    assert_eq!(code, 0, "{stderr}");
    let dropped = count_before(&stderr, "samples outside its span");
    assert!((980..=1020).contains(&dropped), "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["samples_used"].as_u64().unwrap() as usize, 6001 - dropped);
    // The gyro's white noise: uniform ±0.002 rad/s at 100 Hz, σ = 0.002/√3, density σ/√(100 Hz)…
    // interpolation between 190 Hz samples lowers it; within a factor of two.
    let density = report["gyro_params"]["noise_density"][0].as_f64().unwrap();
    let white = 0.002 / 3f64.sqrt() / 100f64.sqrt();
    assert!(
        density > 0.3 * white && density < 1.5 * white,
        "{density} vs {white}"
    );

    let (_, far) = still(dir.path(), 60.0, (40.0, 100.0));
    let (code, _, stderr) = outcome(spincal().arg("allan").arg(&acc).arg("--gyro-file").arg(&far));
    assert_eq!(code, 1, "{stderr}");
    names_both_spans(&stderr, &far);
}

#[test]
fn static_merges_a_gyro_file_on_its_own_clock() {
    let dir = tempfile::tempdir().unwrap();
    let setup = PoseSessionSetup::random(8);
    let s = simulate_pose_session(&setup, 8).unwrap();
    // The gyro starts 100 samples after the accelerometer and stops 100 before it.
    let n = s.time_s.len();
    let write = |name: &str, v: &[Vec<f64>; 3], rows: std::ops::Range<usize>| {
        let text: String = rows
            .map(|i| {
                format!(
                    "{:.5} {:.3} {:.3} {:.3}\n",
                    s.time_s[i], v[0][i], v[1][i], v[2][i]
                )
            })
            .collect();
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let acc = write("acc.txt", &s.accel, 0..n);
    let gyr = write("gyr.txt", &s.gyro, 100..n - 100);
    let (code, stdout, stderr) = run_keeping(
        spincal().arg("static").arg(&acc).arg("--gyro-file").arg(&gyr),
        &[&acc, &gyr],
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("200 samples outside its span"), "{stderr}");
    assert!(stdout.contains("rotations between still poses"), "{stdout}");
}

/// A turntable run (`spincal simulate`) split into its accelerometer and a gyro on another
/// clock: 190 Hz, the simulated rate interpolated.
fn turntable_pair(dir: &Path, gyro_span: (f64, f64)) -> (PathBuf, PathBuf) {
    let sim = dir.join("sim.csv");
    let (code, _, stderr) = outcome(
        spincal()
            .args(["simulate", "--duration", "30", "--seed", "3", "-o"])
            .arg(&sim),
    );
    assert_eq!(code, 0, "{stderr}");
    let text = std::fs::read_to_string(&sim).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let at = |name: &str| header.iter().position(|h| h.starts_with(name)).unwrap();
    let (t, ax) = (0, at("ax"));
    let accel: String = rows
        .iter()
        .map(|r| format!("{},{},{},{}\n", r[t], r[ax], r[ax + 1], r[ax + 2]))
        .collect();
    let accel_path = dir.join("run.csv");
    let unit = header[ax].trim_start_matches("ax");
    std::fs::write(&accel_path, format!("t_s,ax{unit},ay{unit},az{unit}\n{accel}")).unwrap();
    // The platter's rate: a constant about z, as the gyro would read it.
    let (_, gyr) = pair(
        dir,
        0.0,
        gyro_span,
        |_, _| [0.0; 3],
        |_, rng| [0.0, 0.0, 3.5].map(|v| v + 0.01 * rng.gen_range(-1.0..1.0)),
    );
    (accel_path, gyr)
}

#[test]
fn fit_merges_each_recordings_gyro_file() {
    let dir = tempfile::tempdir().unwrap();
    let (run, gyr) = turntable_pair(dir.path(), (1.0, 29.0));
    let (code, stdout, stderr) = run_keeping(
        spincal().arg("fit").arg(&run).arg("--gyro-file").arg(&gyr),
        &[&run, &gyr],
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stderr.contains("samples outside its span or in its gaps"),
        "{stderr}"
    );
    assert!(!stdout.is_empty());
    // One gyro file for two recordings: which is whose is not known.
    let (code, _, stderr) = outcome(
        spincal()
            .arg("fit")
            .arg(&run)
            .arg(&run)
            .arg("--gyro-file")
            .arg(&gyr),
    );
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("--gyro-file names 1 file(s) for 2 recording(s)"),
        "{stderr}"
    );
}

#[test]
fn calibrate_refuses_a_gyro_file_on_another_span_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let (run, far) = turntable_pair(dir.path(), (20.0, 60.0));
    let out = dir.path().join("cal");
    let (code, _, stderr) = run_keeping(
        spincal()
            .arg("calibrate")
            .arg(&run)
            .arg("--gyro-file")
            .arg(&far)
            .arg("--out")
            .arg(&out),
        &[&run, &far],
    );
    assert_eq!(code, 1, "{stderr}");
    names_both_spans(&stderr, &far);
    assert!(!out.exists(), "no output folder");
}

/// A gyro-only CSV with a header (`t,gx,gy,gz`, `time,gx,gy,gz`, or `t_s,gx_dps,gy_dps,gz_dps`
/// in °/s) is read by the column rules of a recording's header: `correct`'s stream and `allan`
/// (read whole) give the same values from each.
#[test]
fn a_gyro_only_csv_with_a_header_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let (acc, _) = still(dir.path(), 20.0, (0.0, 20.0));
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let samples: Vec<(f64, [f64; 3])> = clock(&mut rng, 190.0, 0.0, 20.0)
        .into_iter()
        .map(|t| {
            (
                t,
                [0.01, -0.02, 0.005].map(|v: f64| v + 0.002 * rng.gen_range(-1.0..1.0)),
            )
        })
        .collect();
    let mut file = CorrectorFile::new(CorrectorModel::Static(Box::new(StaticCalibration::identity(
        9.81,
    ))));
    file.gyro = Some(GyroModel::IDEAL);
    let model = dir.path().join("model.json");
    file.write_path(&model).unwrap();
    let mut corrected = Vec::new();
    let mut densities = Vec::new();
    for (name, header, to_unit) in [
        ("t.csv", "t,gx,gy,gz", 1.0),
        ("time.csv", "time,gx,gy,gz", 1.0),
        (
            "dps.csv",
            "t_s,gx_dps,gy_dps,gz_dps",
            180.0 / std::f64::consts::PI,
        ),
    ] {
        let mut text = format!("{header}\n");
        for (t, w) in &samples {
            let w = w.map(|v| v * to_unit);
            text += &format!("{t:.6},{:.9},{:.9},{:.9}\n", w[0], w[1], w[2]);
        }
        let gyr = dir.path().join(name);
        std::fs::write(&gyr, text).unwrap();
        let out = dir.path().join(format!("out-{name}"));
        let (code, _, stderr) = run_keeping(
            spincal()
                .args(["correct", "--model"])
                .arg(&model)
                .arg(&acc)
                .arg("--gyro-file")
                .arg(&gyr)
                .arg("-o")
                .arg(&out),
            &[&acc, &gyr, &model],
        );
        assert_eq!(code, 0, "{header}: {stderr}");
        let text = std::fs::read_to_string(&out).unwrap();
        let gx: Vec<f64> = text
            .lines()
            .skip(1)
            .filter(|row| !row.contains("no-gyro"))
            .map(|row| row.split(',').nth(7).unwrap().parse().unwrap())
            .collect();
        let mean = gx.iter().sum::<f64>() / gx.len() as f64;
        assert!((mean - 0.01).abs() < 5e-4, "{header}: mean gx {mean}");
        corrected.push(gx);
        let (code, stdout, stderr) = run_keeping(
            spincal()
                .arg("allan")
                .arg(&acc)
                .arg("--gyro-file")
                .arg(&gyr)
                .arg("--json"),
            &[&acc, &gyr],
        );
        assert_eq!(code, 0, "{header}: {stderr}");
        let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        densities.push(report["gyro_params"]["noise_density"][0].as_f64().unwrap());
    }
    for (k, gx) in corrected.iter().enumerate().skip(1) {
        assert_eq!(gx.len(), corrected[0].len());
        let worst = gx
            .iter()
            .zip(&corrected[0])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-7, "variant {k}: {worst}");
    }
    for d in &densities[1..] {
        assert!((d / densities[0] - 1.0).abs() < 1e-6, "{densities:?}");
    }
}

/// A model of kind `uncorrected` (format 3: a campaign that determined the gyroscope but showed no
/// accelerometer correction to help) corrects the gyro columns and writes no corrected
/// accelerometer column; the firmware export passes the accelerometer as read and corrects the
/// gyro (tests/firmware.rs: equal to the library's), with no error bar, and says so.
#[test]
fn a_gyro_saved_alone_corrects_the_gyro_and_leaves_the_accelerometer_as_read() {
    use spincal::correctors::model_file::Uncorrected;
    let dir = tempfile::tempdir().unwrap();
    let mut file = CorrectorFile::new(CorrectorModel::Uncorrected(Box::new(Uncorrected {
        reason: "no accelerometer correction was shown to help".into(),
    })));
    let mut gyro = GyroModel::IDEAL;
    gyro.bias_radps = [0.01, -0.02, 0.005];
    gyro.sensitivity[2][2] = 1.01;
    file.gyro = Some(gyro);
    let model = dir.path().join("model.json");
    file.write_path(&model).unwrap();
    let recording = dir.path().join("rec.csv");
    let mut text = String::from("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n");
    for i in 0..200 {
        text.push_str(&format!(
            "{},0.1,-0.2,9.8,0.01,-0.02,{}\n",
            i as f64 * 0.01,
            0.005 + 1.01 * 2.0
        ));
    }
    std::fs::write(&recording, &text).unwrap();
    let out = dir.path().join("out.csv");
    let (code, _, stderr) = run_keeping(
        spincal()
            .args(["correct", "--model"])
            .arg(&model)
            .arg(&recording)
            .arg("-o")
            .arg(&out),
        &[recording.as_path(), model.as_path()],
    );
    assert_eq!(code, 0, "{stderr}");
    let written = std::fs::read_to_string(&out).unwrap();
    let mut lines = written.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert!(
        !header.iter().any(|c| c.starts_with("ax_corrected")),
        "{header:?}"
    );
    let column = |name: &str| {
        header
            .iter()
            .position(|c| *c == name)
            .unwrap_or_else(|| panic!("{name}: {header:?}"))
    };
    let (gx, gz, status) = (
        column("gx_corrected_radps"),
        column("gz_corrected_radps"),
        column("status"),
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 200);
    for row in &rows {
        assert_eq!(row[status], "ok", "{row:?}");
        assert!(row[gx].parse::<f64>().unwrap().abs() < 1e-12, "{row:?}");
        assert!((row[gz].parse::<f64>().unwrap() - 2.0).abs() < 1e-12, "{row:?}");
    }
    let (code, _, stderr) = run_keeping(
        spincal()
            .args(["export", "--model"])
            .arg(&model)
            .arg("--out")
            .arg(dir.path().join("fw")),
        &[model.as_path()],
    );
    assert_eq!(code, 0, "{stderr}");
    let header = std::fs::read_to_string(dir.path().join("fw").join("spincal_f64.h")).unwrap();
    assert!(header.contains("corrects only the gyroscope"), "{header}");
    let source = std::fs::read_to_string(dir.path().join("fw").join("spincal_f64.c")).unwrap();
    assert!(
        source.contains("gyro_inverse") && source.contains("The accelerometer as read"),
        "{source}"
    );
}
