//! Output paths a careless user gets wrong (issue 31): a file spincal did not write is never
//! replaced without `--force`, spincal's own earlier outputs are, `--out` naming a file is refused
//! by name, and an interrupted `correct` leaves no temporary file. Each case checks the exit code,
//! the message and the bytes of every input and pre-existing output.

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// Runs spincal; returns exit code, stdout and stderr.
fn run(args: &[&std::ffi::OsStr]) -> (i32, String, String) {
    let out = spincal().args(args).output().unwrap();
    (
        out.status.code().expect("spincal ended by a signal"),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn os(s: &str) -> &std::ffi::OsStr {
    std::ffi::OsStr::new(s)
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap()
}

/// Names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A recording as a logger writes it: spincal did not write it.
const REAL: &str = "# logger v2, unit 4711\ntime,ax,ay,az\n0.00,0.01,0.02,1.00\n0.01,0.01,0.02,1.01\n";

fn simulate(output: &Path, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![os("simulate"), os("-o"), output.as_os_str()];
    if !extra.contains(&"--duration") {
        args.extend([os("--duration"), os("2")]);
    }
    args.extend(extra.iter().map(|s| os(s)));
    run(&args)
}

#[test]
fn simulate_never_replaces_a_recording_it_did_not_write_but_replaces_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("my-recording.csv");
    std::fs::write(&real, REAL).unwrap();
    let (code, _, err) = simulate(&real, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("my-recording.csv") && err.contains("spincal did not write it"), "{err}");
    assert!(err.contains("--force"), "{err}");
    assert_eq!(read(&real), REAL.as_bytes());
    assert_eq!(listing(dir.path()), ["my-recording.csv"], "nothing else written");

    // A truth file of the user's beside a fresh output name is refused the same way.
    let fresh = dir.path().join("fresh.csv");
    let their_truth = dir.path().join("fresh.truth.json");
    std::fs::write(&their_truth, "{\"notes\": \"mine\"}\n").unwrap();
    let (code, _, err) = simulate(&fresh, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("fresh.truth.json"), "{err}");
    assert!(!fresh.exists());
    assert_eq!(read(&their_truth), b"{\"notes\": \"mine\"}\n");

    // spincal's own simulation is replaced by a second run, with another seed, without a word.
    let own = dir.path().join("sim.csv");
    let (code, _, err) = simulate(&own, &["--seed", "3"]);
    assert_eq!(code, 0, "{err}");
    let first = read(&own);
    let (code, _, err) = simulate(&own, &["--seed", "4"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.is_empty(), "{err}");
    assert_ne!(read(&own), first, "the second run wrote its own recording");
    // Once its recording is edited by hand, spincal no longer claims it.
    let mut edited = read(&own);
    edited.extend_from_slice(b"99,0,0,1\n");
    std::fs::write(&own, &edited).unwrap();
    let (code, _, err) = simulate(&own, &["--seed", "5"]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(read(&own), edited);

    // --force replaces the real recording and says so.
    let (code, _, err) = run(&[
        os("--force"),
        os("simulate"),
        os("--duration"),
        os("2"),
        os("-o"),
        real.as_os_str(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("replacing") && err.contains("my-recording.csv"), "{err}");
    assert_ne!(read(&real), REAL.as_bytes());
}

/// A short simulated recording in `dir`.
fn recording(dir: &Path) -> PathBuf {
    let rec = dir.join("rec.csv");
    let (code, _, err) = simulate(&rec, &["--duration", "10"]);
    assert_eq!(code, 0, "{err}");
    rec
}

fn calibrate(rec: &Path, out: &Path, force: bool) -> (i32, String, String) {
    let mut args = vec![
        os("calibrate"),
        rec.as_os_str(),
        os("--hidden"),
        os("2"),
        os("--restarts"),
        os("1"),
        os("--quiet"),
        os("--out"),
        out.as_os_str(),
    ];
    if force {
        args.push(os("--force"));
    }
    run(&args)
}

#[test]
fn calibrate_keeps_files_it_did_not_write_and_replaces_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let rec = recording(dir.path());
    let rec_bytes = read(&rec);
    let out = dir.path().join("cal");
    std::fs::create_dir(&out).unwrap();
    let theirs = out.join("model.json");
    let their_model = b"{\"weights\": [1, 2, 3]}\n";
    std::fs::write(&theirs, their_model).unwrap();
    let (code, _, err) = calibrate(&rec, &out, false);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("model.json") && err.contains("spincal did not write it"), "{err}");
    assert_eq!(read(&theirs), their_model);
    assert_eq!(listing(&out), ["model.json"], "refused before any work");

    // A report of the user's is kept too.
    std::fs::remove_file(&theirs).unwrap();
    let report = out.join("report.html");
    std::fs::write(&report, "<html>my notes</html>").unwrap();
    let (code, _, err) = calibrate(&rec, &out, false);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("report.html"), "{err}");
    assert_eq!(read(&report), b"<html>my notes</html>");
    std::fs::remove_file(&report).unwrap();

    // Into an empty folder, then again into the same folder: spincal's own files are replaced.
    let (code, _, err) = calibrate(&rec, &out, false);
    assert_eq!(code, 0, "{err}");
    let model = read(&out.join("model.json"));
    let (code, _, err) = calibrate(&rec, &out, false);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("replacing"), "{err}");
    assert_eq!(read(&out.join("model.json")), model, "the same calibration again");
    assert_eq!(listing(&out), ["model.json", "report.html", "results.json"]);
    assert_eq!(read(&rec), rec_bytes);
}

#[test]
fn out_naming_a_file_is_refused_by_name_and_force_says_what_it_replaces() {
    let dir = tempfile::tempdir().unwrap();
    let rec = recording(dir.path());
    let rec_bytes = read(&rec);
    let file = dir.path().join("notes.txt");
    std::fs::write(&file, "keep me").unwrap();
    let (code, _, err) = calibrate(&rec, &file, false);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--out") && err.contains("notes.txt") && err.contains("not a folder"), "{err}");
    assert!(!err.contains("os error"), "{err}");
    assert_eq!(read(&file), b"keep me");

    let out = dir.path().join("cal");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("results.json"), "[1, 2]").unwrap();
    let (code, _, err) = calibrate(&rec, &out, true);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("replacing") && err.contains("results.json"), "{err}");
    let results: serde_json::Value = serde_json::from_slice(&read(&out.join("results.json"))).unwrap();
    assert!(results["spincal_version"].is_string());
    assert_eq!(read(&rec), rec_bytes);
}

/// `correct` reading a pipe that stays open, ended by `signal` once its temporary output exists:
/// the temporary file is removed, the output never appears, and the inputs are unchanged.
#[cfg(unix)]
fn interrupted_correct_leaves_nothing(signal: &str) {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let rec = recording(dir.path());
    let reference = dir.path().join("ref.csv");
    let model = dir.path().join("linear.json");
    spincal()
        .args(["fit", "--quiet"])
        .arg(&rec)
        .arg("--reference-csv")
        .arg(&reference)
        .assert()
        .success();
    spincal()
        .args(["train", "--kind", "linear", "--quiet", "--data"])
        .arg(&rec)
        .arg("--reference")
        .arg(&reference)
        .arg("-o")
        .arg(&model)
        .assert()
        .success();
    let before = [read(&rec), read(&model)];
    let work = dir.path().join("work");
    std::fs::create_dir(&work).unwrap();
    let output = work.join("corrected.csv");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_spincal"))
        .arg("correct")
        .arg("--model")
        .arg(&model)
        .arg("-")
        .arg("-o")
        .arg(&output)
        .stdin(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let text = String::from_utf8(read(&rec)).unwrap();
    stdin.write_all(text.as_bytes()).unwrap();
    stdin.flush().unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while listing(&work).is_empty() {
        assert!(std::time::Instant::now() < deadline, "no temporary file appeared");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(listing(&work)[0].ends_with(".tmp"), "{:?}", listing(&work));
    let killed = std::process::Command::new("kill")
        .arg(format!("-{signal}"))
        .arg(child.id().to_string())
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    drop(stdin);
    assert!(!status.success(), "{status:?}");
    assert!(listing(&work).is_empty(), "left behind: {:?}", listing(&work));
    assert_eq!([read(&rec), read(&model)], before);
}

#[cfg(unix)]
#[test]
fn sigint_during_correct_removes_its_temporary_file() {
    interrupted_correct_leaves_nothing("INT");
}

#[cfg(unix)]
#[test]
fn sigterm_during_correct_removes_its_temporary_file() {
    interrupted_correct_leaves_nothing("TERM");
}
