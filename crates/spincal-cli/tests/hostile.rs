//! Hostile input and hostile output paths: each case checks the exit code, the message, that no
//! input file changed, and for `correct` that every input row comes out.

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use proptest::prelude::*;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// A short simulated recording, its reference and a linear model trained on them.
struct Setup {
    _dir: tempfile::TempDir,
    dir: PathBuf,
    rec: PathBuf,
    model: PathBuf,
}

fn setup() -> Setup {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().to_path_buf();
    let (rec, model) = crate::harness::linear_model(&path);
    Setup {
        _dir: dir,
        dir: path,
        rec,
        model,
    }
}

fn contents(paths: &[&Path]) -> Vec<Vec<u8>> {
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

/// Runs spincal; returns exit code and stderr.
fn run(args: &[&std::ffi::OsStr]) -> (i32, String) {
    let out = spincal().args(args).output().unwrap();
    (
        out.status.code().expect("spincal ended by a signal"),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn os(s: &str) -> &std::ffi::OsStr {
    std::ffi::OsStr::new(s)
}

/// `spincal correct --model MODEL INPUT -o OUTPUT`: exit code and stderr.
fn correct(model: &Path, input: &Path, output: &Path) -> (i32, String) {
    run(&[
        os("correct"),
        os("--model"),
        model.as_os_str(),
        input.as_os_str(),
        os("-o"),
        output.as_os_str(),
    ])
}

#[test]
fn an_output_that_is_an_input_or_the_model_is_refused_and_nothing_changes() {
    let s = setup();
    let before = contents(&[&s.rec, &s.model]);
    let (code, err) = correct(&s.model, &s.rec, &s.rec);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("also an input"), "{err}");
    // The same file reached by another spelling.
    let other_spelling = s.dir.join(".").join("rec.csv");
    let (code, err) = correct(&s.model, &s.rec, &other_spelling);
    assert_eq!(code, 2, "{err}");
    // -o naming the model, with a bad input.
    let bad = s.dir.join("bad.csv");
    std::fs::write(&bad, "t,ax,ay,az\nnot numbers at all\n").unwrap();
    let (code, err) = correct(&s.model, &bad, &s.model);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("linear.json"), "{err}");
    assert_eq!(contents(&[&s.rec, &s.model]), before);
}

#[cfg(unix)]
#[test]
fn a_link_output_stays_a_link_and_a_device_is_never_removed() {
    let s = setup();
    let target = s.dir.join("target.csv");
    let link = s.dir.join("link.csv");
    // Empty: a file with content that spincal did not write would be kept (tests/outputs.rs).
    std::fs::write(&target, "").unwrap();
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let (code, err) = correct(&s.model, &s.rec, &link);
    assert_eq!(code, 0, "{err}");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    let rows = std::fs::read_to_string(&target).unwrap().lines().count();
    assert_eq!(rows, std::fs::read_to_string(&s.rec).unwrap().lines().count());
    // A bad input through the link: the target keeps its previous complete contents.
    let written = std::fs::read(&target).unwrap();
    let empty = s.dir.join("empty.csv");
    std::fs::write(&empty, "").unwrap();
    let (code, err) = correct(&s.model, &empty, &link);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("empty.csv"), "{err}");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), written);
    let leftovers: Vec<_> = std::fs::read_dir(&s.dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    let full = Path::new("/dev/full");
    if full.exists() {
        let (code, err) = correct(&s.model, &s.rec, full);
        assert_eq!(code, 1, "{err}");
        assert!(full.exists(), "the device node is still there");
    }
}

#[test]
fn outputs_that_collide_with_inputs_or_each_other_are_refused_before_work() {
    let s = setup();
    let before = contents(&[&s.rec]);
    // sweep -o rec writes rec.csv and rec.json: rec.csv is the input.
    let stem = s.dir.join("rec");
    let reference = s.dir.join("ref.csv");
    let (code, err) = run(&[
        os("sweep"),
        os("--data"),
        s.rec.as_os_str(),
        os("--reference"),
        reference.as_os_str(),
        os("-o"),
        stem.as_os_str(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("also an input"), "{err}");
    // simulate -o s.csv --truth s.csv
    let same = s.dir.join("s.csv");
    let (code, err) = run(&[
        os("simulate"),
        os("-o"),
        same.as_os_str(),
        os("--truth"),
        same.as_os_str(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("same file"), "{err}");
    assert!(!same.exists());
    // fit -o naming its own recording.
    let (code, err) = run(&[os("fit"), s.rec.as_os_str(), os("-o"), s.rec.as_os_str()]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(contents(&[&s.rec]), before);
}

#[test]
fn a_byte_order_mark_is_not_part_of_the_header() {
    let s = setup();
    let text = std::fs::read_to_string(&s.rec).unwrap();
    let bom = s.dir.join("bom.csv");
    std::fs::write(&bom, format!("\u{feff}{text}")).unwrap();
    spincal()
        .args(["inspect", "--quiet"])
        .arg(&bom)
        .assert()
        .success();
    let out = s.dir.join("out.csv");
    let (code, err) = correct(&s.model, &bom, &out);
    assert_eq!(code, 0, "{err}");
    assert!(std::fs::read_to_string(&out).unwrap().starts_with("t_s,"));
}

/// Input rows as `correct` counts them: lines after the header that are not blank or comments
/// (invalid text counts: it comes out refused).
fn data_rows(bytes: &[u8]) -> usize {
    bytes
        .split(|&b| b == b'\n')
        .skip(1)
        .filter(|line| match std::str::from_utf8(line) {
            Ok(text) => {
                let t = text.trim_end_matches('\r').trim_start();
                !(t.is_empty() || t.starts_with('#') || t.starts_with('%'))
            }
            Err(_) => true,
        })
        .count()
}

#[derive(Debug, Clone)]
enum Damage {
    Byte { at: usize, value: u8 },
    DropRow(usize),
    DuplicateRow(usize),
    Truncate(usize),
}

fn damage_strategy() -> impl Strategy<Value = Vec<Damage>> {
    let one = prop_oneof![
        (0usize..20_000, any::<u8>()).prop_map(|(at, value)| Damage::Byte { at, value }),
        (1usize..1000).prop_map(Damage::DropRow),
        (1usize..1000).prop_map(Damage::DuplicateRow),
        (100usize..40_000).prop_map(Damage::Truncate),
    ];
    prop::collection::vec(one, 1..6)
}

fn apply(mut bytes: Vec<u8>, damage: &[Damage]) -> Vec<u8> {
    for d in damage {
        match *d {
            Damage::Byte { at, value } => {
                // Bytes after the header only: a damaged header is a different (fatal) case.
                let header = bytes.iter().position(|&b| b == b'\n').unwrap_or(0) + 1;
                if bytes.len() > header {
                    let i = header + at % (bytes.len() - header);
                    bytes[i] = value;
                }
            }
            Damage::DropRow(k) | Damage::DuplicateRow(k) => {
                let mut lines: Vec<Vec<u8>> = bytes.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
                if lines.len() > 3 {
                    let i = 2 + k % (lines.len() - 3);
                    if matches!(d, Damage::DropRow(_)) {
                        lines.remove(i);
                    } else {
                        let copy = lines[i].clone();
                        lines.insert(i, copy);
                    }
                }
                bytes = lines.join(&b'\n');
            }
            Damage::Truncate(n) => bytes.truncate(n.max(200).min(bytes.len())),
        }
    }
    bytes
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    /// Damaged at random (bytes, dropped or repeated rows, truncation), a recording still comes
    /// out whole: as many output rows as input rows, never a panic, inputs untouched.
    #[test]
    fn correct_writes_every_row_of_a_damaged_recording(damage in damage_strategy()) {
        let s = setup_once();
        let original = std::fs::read(&s.rec).unwrap();
        let damaged = apply(original, &damage);
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("damaged.csv");
        std::fs::write(&input, &damaged).unwrap();
        let out = dir.path().join("out.csv");
        let (code, err) = correct(&s.model, &input, &out);
        prop_assert!(matches!(code, 0 | 1 | 3), "exit {code}: {err}");
        prop_assert_eq!(std::fs::read(&input).unwrap(), damaged.clone());
        if code == 1 {
            // Only a file whose first data row is damaged cannot be streamed; nothing is written.
            prop_assert!(!out.exists(), "{}", err);
            prop_assert!(err.contains("damaged.csv"), "{}", err);
        } else {
            let written = std::fs::read(&out).unwrap();
            // Every output line after the header is a row (refused rows are never blank).
            let out_rows = written.split(|&b| b == b'\n').filter(|l| !l.is_empty()).count() - 1;
            prop_assert_eq!(out_rows, data_rows(&damaged), "{}", err);
            prop_assert_eq!(code == 3, err.contains("refused"), "{}", err);
        }
    }
}

/// One setup shared by the property cases (training a model per case would dominate the test).
fn setup_once() -> &'static Setup {
    static SETUP: std::sync::OnceLock<Setup> = std::sync::OnceLock::new();
    SETUP.get_or_init(setup)
}

#[test]
fn number_flags_out_of_range_are_usage_errors_naming_the_flag() {
    let s = setup_once();
    let rec = s.rec.to_str().unwrap();
    for (args, flag) in [
        (vec!["fit", rec, "--radius", "-0.1"], "--radius"),
        (vec!["fit", rec, "--rpm", "0"], "--rpm"),
        (vec!["fit", rec, "--gravity", "nan"], "--gravity"),
        (vec!["sensitivity", "--rpm", "0"], "--rpm"),
        (
            vec!["simulate", "-o", "never.csv", "--duration", "-5"],
            "--duration",
        ),
        (vec!["inspect", rec, "--sample-rate", "inf"], "--sample-rate"),
    ] {
        let out = spincal().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(flag) && !err.contains("unexpected argument"),
            "{args:?}: {err}"
        );
    }
    assert!(!Path::new("never.csv").exists());
}

#[test]
fn a_headerless_file_needs_its_unit_named_and_a_moving_file_has_no_allan_deviation() {
    let s = setup_once();
    let text = std::fs::read_to_string(&s.rec).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let bare = dir.path().join("bare.csv");
    std::fs::write(&bare, text.split_once('\n').unwrap().1).unwrap();
    let out = dir.path().join("out.csv");
    let (code, err) = correct(&s.model, &bare, &out);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("`--accel-unit`") && err.contains("bare.csv"),
        "{err}"
    );
    assert!(!out.exists());
    let (code, err) = run(&[
        os("correct"),
        os("--model"),
        s.model.as_os_str(),
        bare.as_os_str(),
        os("--accel-unit"),
        os("g"),
        os("-o"),
        out.as_os_str(),
    ]);
    assert_eq!(code, 0, "{err}");
    // A sensor swung through ±1 g: no noise profile of it.
    let mut swinging = String::from("t_s,ax_g,ay_g,az_g\n");
    for i in 0..6000 {
        let t = i as f64 * 0.01;
        let a = (std::f64::consts::PI * t).sin();
        let wobble = 0.001 * ((i * 7919) % 13) as f64;
        swinging += &format!("{t:.2},{a:.5},{wobble:.5},{:.5}\n", (1.0 - a * a).sqrt());
    }
    let moving = dir.path().join("moving.csv");
    std::fs::write(&moving, swinging).unwrap();
    let profile = dir.path().join("profile.json");
    let (code, err) = run(&[
        os("allan"),
        moving.as_os_str(),
        os("--profile"),
        profile.as_os_str(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("the sensor moves"), "{err}");
    assert!(!profile.exists());
}

/// `text` (a simulated CSV) with its time column replaced by `time(i, t)`.
fn retimed(text: &str, time: impl Fn(usize, f64) -> String) -> String {
    let mut lines = text.lines();
    let mut out = lines.next().unwrap().to_string() + "\n";
    for (i, line) in lines.enumerate() {
        let (t, rest) = line.split_once(',').unwrap();
        out += &format!("{},{rest}\n", time(i, t.parse().unwrap()));
    }
    out
}

#[test]
fn a_time_column_that_is_not_seconds_is_refused_with_the_flag_that_fixes_it() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    spincal()
        .args(["simulate", "--duration", "20", "--quiet", "-o"])
        .arg(&rec)
        .assert()
        .success();
    let text = std::fs::read_to_string(&rec).unwrap();
    let cases: [(&str, String, &str, &[&str]); 3] = [
        (
            "index.csv",
            retimed(&text, |i, _| i.to_string()),
            "--sample-rate",
            &["--sample-rate", "100"],
        ),
        (
            "millis.csv",
            retimed(&text, |_, t| format!("{}", (t * 1000.0).round())),
            "`--time-unit` ms",
            &["--time-unit", "ms"],
        ),
        (
            "zeros.csv",
            retimed(&text, |_, _| "0".into()),
            "--sample-rate",
            &["--sample-rate", "100"],
        ),
    ];
    for (name, content, flag, fix) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, &content).unwrap();
        let (code, err) = run(&[os("fit"), path.as_os_str()]);
        assert_eq!(code, 1, "{name}: {err}");
        assert!(err.contains(name) && err.contains(flag), "{name}: {err}");
        assert!(!err.contains("turning"), "{name}: {err}");
        // The flag named fixes it.
        let mut args = vec![os("fit"), path.as_os_str()];
        args.extend(fix.iter().map(|s| os(s)));
        let (code, err) = run(&args);
        assert_eq!(code, 0, "{name} with {fix:?}: {err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), content);
    }
    assert_eq!(std::fs::read_to_string(&rec).unwrap(), text);
}

#[test]
fn a_rotation_count_in_a_refusal_is_measured_or_not_given() {
    let dir = tempfile::tempdir().unwrap();
    // 1 s at 33.5 rpm: about half a turn, too little to measure the rate at all.
    let one = dir.path().join("one.csv");
    spincal()
        .args(["simulate", "--duration", "1", "--rpm", "33.5", "--quiet", "-o"])
        .arg(&one)
        .assert()
        .success();
    let before = std::fs::read(&one).unwrap();
    let (code, err) = run(&[os("fit"), one.as_os_str()]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("one.csv") && err.contains("too short to measure"),
        "{err}"
    );
    assert!(!err.contains("rotations at") && !err.contains("rpm for"), "{err}");
    assert_eq!(std::fs::read(&one).unwrap(), before);
    // 4.5 s at 33.333 rpm: 2.5 turns, resolved: the count and rate given are the measured ones.
    let short = dir.path().join("short.csv");
    spincal()
        .args([
            "simulate",
            "--duration",
            "4.5",
            "--speed-error-pct",
            "0",
            "--quiet",
            "-o",
        ])
        .arg(&short)
        .assert()
        .success();
    let (code, err) = run(&[os("fit"), short.as_os_str()]);
    assert_eq!(code, 1, "{err}");
    let measured: f64 = err
        .split("measured: ")
        .nth(1)
        .and_then(|r| r.split(" rpm").next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no measured rate in: {err}"));
    assert!((measured - 100.0 / 3.0).abs() < 0.5, "{err}");
    let rotations: f64 = err
        .split("only ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no rotation count in: {err}"));
    assert!((rotations - 4.5 * 100.0 / 3.0 / 60.0).abs() < 0.1, "{err}");
}

/// `text` (a simulated CSV) with its header's time column renamed.
fn renamed_time(text: &str, name: &str) -> String {
    let (header, rest) = text.split_once('\n').unwrap();
    let (_, others) = header.split_once(',').unwrap();
    format!("{name},{others}\n{rest}")
}

#[test]
fn epoch_nanoseconds_and_a_wrapping_millisecond_counter_are_read_as_time_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    spincal()
        .args(["simulate", "--duration", "20", "--quiet", "-o"])
        .arg(&rec)
        .assert()
        .success();
    let text = std::fs::read_to_string(&rec).unwrap();
    // A phone logger's epoch nanoseconds under `timestamp`, and a uint32 millis() counter that
    // wraps 5 s into the recording under `time`.
    let epoch = renamed_time(
        &retimed(&text, |_, t| {
            format!("{}", 1_767_225_600_000_000_000u64 + (t * 1e9).round() as u64)
        }),
        "timestamp",
    );
    let wrapping = renamed_time(
        &retimed(&text, |_, t| {
            format!(
                "{}",
                (4_294_967_296u64 - 5_000 + (t * 1000.0).round() as u64) % 4_294_967_296
            )
        }),
        "time",
    );
    for (name, content, note) in [
        ("epoch.csv", epoch, "timestamps since the Unix epoch in ns"),
        ("wrap.csv", wrapping, "wrapped 1 time(s) at 2^32"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, &content).unwrap();
        let out = spincal().args(["inspect", "--json"]).arg(&path).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(0), "{name}: {stdout}");
        let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let rate = json["inspection"]["sample_rate_hz"].as_f64().unwrap();
        assert!((rate - 100.0).abs() < 0.5, "{name}: {rate} Hz");
        let notes = json["loaded"]["notes"].to_string();
        assert!(notes.contains(note), "{name}: the note is missing: {notes}");
        let (code, err) = run(&[os("fit"), path.as_os_str()]);
        assert_eq!(code, 0, "{name}: {err}");
        assert!(err.contains(note), "{name}: {err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), content);
    }
    // Steps of 100 under a bare name are 10 Hz in ms or 10 kHz in µs: refused, naming the fix.
    let hourly = dir.path().join("hourly.csv");
    let content = renamed_time(&retimed(&text, |i, _| format!("{}", i * 100)), "time");
    std::fs::write(&hourly, &content).unwrap();
    let (code, err) = run(&[os("inspect"), hourly.as_os_str()]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("hourly.csv") && err.contains("`--time-unit` ms (10.0000 Hz) or us"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&hourly).unwrap(), content);
}
