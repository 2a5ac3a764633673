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

use crate::harness::listing;

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
    assert!(
        err.contains("my-recording.csv") && err.contains("spincal did not write it"),
        "{err}"
    );
    assert!(err.contains("set `--force` to replace it"), "{err}");
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
    assert!(
        err.contains("replacing") && err.contains("my-recording.csv"),
        "{err}"
    );
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
    assert!(
        err.contains("model.json") && err.contains("spincal did not write it"),
        "{err}"
    );
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
    // (One recording holds no second condition: nothing is saved, so there is no model.json.)
    let (code, _, err) = calibrate(&rec, &out, false);
    assert_eq!(code, 0, "{err}");
    let verdict = |out: &Path| {
        let results: serde_json::Value = serde_json::from_slice(&read(&out.join("results.json"))).unwrap();
        results["verdict"].as_str().unwrap().to_string()
    };
    let first = verdict(&out);
    let (code, _, err) = calibrate(&rec, &out, false);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("replacing"), "{err}");
    assert_eq!(verdict(&out), first, "the same calibration again");
    assert_eq!(listing(&out), ["report.html", "results.json"]);
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
    assert!(
        err.contains("--out") && err.contains("notes.txt") && err.contains("not a folder"),
        "{err}"
    );
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
    let (rec, model) = crate::harness::linear_model(dir.path());
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
        // A SIGQUIT may dump core: into the test's folder, not the crate's.
        .current_dir(dir.path())
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

/// A closed terminal (SIGHUP) and Ctrl-\ (SIGQUIT) end the process like the others.
#[cfg(unix)]
#[test]
fn sighup_and_sigquit_during_correct_remove_its_temporary_file() {
    interrupted_correct_leaves_nothing("HUP");
    interrupted_correct_leaves_nothing("QUIT");
}

/// `text` with the field `column` (0-based) of line `line` (1-based) replaced.
fn with_field(text: &str, line: usize, column: usize, value: &str) -> String {
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 != line {
                return l.to_string() + "\n";
            }
            let mut fields: Vec<&str> = l.split(',').collect();
            fields[column] = value;
            fields.join(",") + "\n"
        })
        .collect()
}

/// (status, corrected values) of each row of `correct`'s output.
fn statuses(output: &str) -> Vec<(String, Vec<String>)> {
    let mut lines = output.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let corrected: Vec<usize> = (0..header.len())
        .filter(|&c| header[c].contains("_corrected_") && !header[c].contains("_corrected_sd_"))
        .collect();
    lines
        .map(|l| {
            let fields = split_quoted(l);
            (
                fields.last().unwrap().to_string(),
                corrected.iter().map(|&c| fields[c].to_string()).collect(),
            )
        })
        .collect()
}

/// A CSV line's fields, double-quoted ones unquoted.
fn split_quoted(line: &str) -> Vec<String> {
    let mut fields = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                fields.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(String::new()),
            c => fields.last_mut().unwrap().push(c),
        }
    }
    fields
}

#[test]
fn a_value_that_overflows_in_unit_conversion_is_refused_where_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, model) = crate::harness::linear_model(dir.path());
    let text = std::fs::read_to_string(&rec).unwrap();
    assert!(text.starts_with("t_s,ax_g,"), "{}", &text[..40]);
    let huge = dir.path().join("huge.csv");
    std::fs::write(&huge, with_field(&text, 5, 1, "1e308")).unwrap();
    let huge_bytes = read(&huge);
    let model_bytes = read(&model);

    let (code, _, err) = run(&[os("fit"), huge.as_os_str()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("huge.csv:5, column 2 (ax_g)"), "{err}");
    assert!(err.contains("after conversion"), "{err}");

    let out = dir.path().join("corrected.csv");
    let (code, _, err) = run(&[
        os("correct"),
        os("--model"),
        model.as_os_str(),
        huge.as_os_str(),
        os("-o"),
        out.as_os_str(),
    ]);
    assert_eq!(code, 3, "{err}");
    assert!(err.contains("line 5, column 2 (ax_g)"), "{err}");
    let rows = statuses(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), text.lines().count() - 1, "every input row is written");
    assert!(
        rows[3].0.starts_with("refused: line 5, column 2 (ax_g)"),
        "{:?}",
        rows[3]
    );
    assert!(rows[3].1.iter().all(String::is_empty), "{:?}", rows[3]);
    assert_eq!(rows.iter().filter(|r| r.0 != "ok").count(), 1);
    assert_eq!((read(&huge), read(&model)), (huge_bytes, model_bytes));
}

#[test]
fn a_corrected_value_that_is_not_finite_is_never_ok() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, model) = crate::harness::linear_model(dir.path());
    // In m/s², no conversion: the file's largest values, which no correction keeps finite (the
    // values turned into m/s² with the header, or `correct` stops at the unit).
    let original = std::fs::read_to_string(&rec).unwrap();
    let mut lines = original.lines();
    let header = lines
        .next()
        .unwrap()
        .replacen("t_s,ax_g,ay_g,az_g", "t_s,ax_mps2,ay_mps2,az_mps2", 1);
    let mut text = header + "\n";
    for line in lines {
        let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
        for f in &mut fields[1..4] {
            *f = (f.parse::<f64>().unwrap() * 9.80665).to_string();
        }
        text += &(fields.join(",") + "\n");
    }
    let mut text = with_field(&text, 6, 1, "1.7976931348623157e308");
    for column in 1..4 {
        text = with_field(&text, 7, column, "-1.7976931348623157e308");
    }
    let extreme = dir.path().join("extreme.csv");
    std::fs::write(&extreme, &text).unwrap();
    let before = (read(&extreme), read(&model));
    let out = dir.path().join("corrected.csv");
    let (code, _, err) = run(&[
        os("correct"),
        os("--model"),
        model.as_os_str(),
        extreme.as_os_str(),
        os("-o"),
        out.as_os_str(),
    ]);
    let rows = statuses(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), text.lines().count() - 1, "every input row is written");
    for (status, corrected) in &rows {
        if status == "ok" {
            for v in corrected {
                let v: f64 = v.parse().unwrap();
                assert!(v.is_finite(), "status ok with {corrected:?}");
            }
        }
    }
    let not_ok: Vec<&String> = rows.iter().map(|r| &r.0).filter(|s| *s != "ok").collect();
    assert!(!not_ok.is_empty());
    // Not finite, or finite beyond the plausibility bound (MAX_CORRECTED_ACCEL_MPS2).
    assert!(
        not_ok
            .iter()
            .all(|s| s.contains("not finite") || s.contains("beyond ±500 g")),
        "{not_ok:?}"
    );
    assert_eq!(code, 3, "{err}");
    assert_eq!((read(&extreme), read(&model)), before);
}

/// Every file under `dir` with its bytes, sorted by path.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let bytes = read(&path);
                files.push((path, bytes));
            }
        }
    }
    files.sort();
    files
}

#[test]
fn fleet_takes_any_single_toml_and_leaves_no_folder_out_unseen() {
    let dir = tempfile::tempdir().unwrap();
    let setup_path = crate::harness::short_campaign_setup(dir.path());
    let fleet = dir.path().join("fleet");
    let (code, _, err) = run(&[
        os("simulate"),
        os("--fleet"),
        os("2"),
        os("--seed"),
        os("5"),
        os("--out"),
        fleet.as_os_str(),
        os("--setup"),
        setup_path.as_os_str(),
    ]);
    assert_eq!(code, 0, "{err}");
    // The README's name for a unit's campaign file, a folder with no campaign, a hidden folder.
    std::fs::rename(
        fleet.join("unit-02/campaign.toml"),
        fleet.join("unit-02/unit.toml"),
    )
    .unwrap();
    std::fs::create_dir(fleet.join("notes")).unwrap();
    std::fs::write(fleet.join("notes/readme.txt"), "bench log").unwrap();
    std::fs::create_dir(fleet.join(".thumbnails")).unwrap();
    let before = tree(&fleet);

    let out = dir.path().join("cal");
    let (code, stdout, err) = run(&[
        os("fleet"),
        fleet.as_os_str(),
        os("--quiet"),
        os("--out"),
        out.as_os_str(),
    ]);
    assert_eq!(code, 3, "{stdout}\n{err}");
    assert!(
        err.contains(".thumbnails") && err.contains("skipped") && err.contains("hidden"),
        "{err}"
    );
    assert!(err.contains("1 of 3 units failed"), "{err}");
    assert!(err.contains("notes") && err.contains("no campaign file"), "{err}");
    for unit in ["unit-01", "unit-02"] {
        let results: serde_json::Value =
            serde_json::from_slice(&read(&out.join(unit).join("results.json"))).unwrap();
        assert!(results["spincal_version"].is_string(), "{unit}");
    }
    let csv = std::fs::read_to_string(out.join("fleet.csv")).unwrap();
    assert!(csv.contains("notes"), "{csv}");
    assert_eq!(tree(&fleet), before, "no input changed");

    // A unit named but not there fails as its own unit: exit 3, the other one written.
    let missing = fleet.join("unit-09");
    let out2 = dir.path().join("cal2");
    let unit1 = fleet.join("unit-01");
    let (code, stdout, err) = run(&[
        os("fleet"),
        unit1.as_os_str(),
        missing.as_os_str(),
        os("--quiet"),
        os("--out"),
        out2.as_os_str(),
    ]);
    assert_eq!(code, 3, "{stdout}\n{err}");
    assert!(err.contains("unit-09"), "{err}");
    assert!(out2.join("unit-01/results.json").is_file());
    assert_eq!(tree(&fleet), before, "no input changed");
}

/// Every other command's outputs follow the same rule: `correct -o`, `static -o` and `--yaml`,
/// `strobe -o`, `fit -o` and `--reference-csv`: a file spincal did not write is
/// kept (exit 2, named), spincal's own output of the same command is replaced on a second run, and
/// `--force` replaces the foreign file and says so.
#[test]
fn every_command_keeps_a_file_it_did_not_write_and_replaces_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    let (code, _, err) = simulate(&rec, &["--duration", "20", "--rpm", "33.33"]);
    assert_eq!(code, 0, "{err}");
    let p = |name: &str| dir.path().join(name);
    let (code, _, err) = run(&[
        os("train"),
        os("--kind"),
        os("linear"),
        os("--data"),
        rec.as_os_str(),
        os("--reference"),
        rec.as_os_str(),
        os("-o"),
        p("model.json").as_os_str(),
    ]);
    assert_eq!(code, 0, "{err}");
    let model = p("model.json");
    let cases: Vec<(&str, Vec<std::ffi::OsString>)> = vec![
        (
            "corrected.csv",
            vec![
                "correct".into(),
                "--model".into(),
                model.clone().into(),
                rec.clone().into(),
                "-o".into(),
            ],
        ),
        (
            "cal.json",
            vec![
                "static".into(),
                rec.clone().into(),
                "--model".into(),
                "6".into(),
                "--min-interval".into(),
                "0.5".into(),
                "-o".into(),
            ],
        ),
        (
            "disc.svg",
            vec!["strobe".into(), "--rpm".into(), "33.333".into(), "-o".into()],
        ),
        ("fit.json", vec!["fit".into(), rec.clone().into(), "-o".into()]),
        (
            "reference.csv",
            vec!["fit".into(), rec.clone().into(), "--reference-csv".into()],
        ),
        (
            "yaml.yaml",
            vec![
                "static".into(),
                rec.clone().into(),
                "--model".into(),
                "6".into(),
                "--min-interval".into(),
                "0.5".into(),
                "--yaml".into(),
            ],
        ),
    ];
    for (name, mut args) in cases {
        let target = p(name);
        std::fs::write(&target, REAL).unwrap();
        args.push(target.clone().into());
        let argv: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_os_str()).collect();
        let (code, _, err) = run(&argv);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(
            err.contains(name) && err.contains("spincal did not write it"),
            "{name}: {err}"
        );
        assert_eq!(read(&target), REAL.as_bytes(), "{name} was changed");
        let mut forced = vec![os("--force")];
        forced.extend(&argv);
        let (code, _, err) = run(&forced);
        // `static` may find too few poses in a turntable run: what matters is that it got past the
        // output check and said what it replaced, or refused for its own reason.
        if !matches!(name, "cal.json" | "yaml.yaml") {
            assert_eq!(code, 0, "{name}: {err}");
            assert!(err.contains("--force: replacing"), "{name}: {err}");
            let (code, _, err) = run(&argv);
            assert_eq!(
                code, 0,
                "{name}: a second run replaces spincal's own output: {err}"
            );
        } else {
            assert_ne!(code, 2, "{name}: {err}");
        }
    }
}

/// A user's recordings that look like spincal's from the inside (issue 47): its recording header
/// in g (a logger converted to the layout the README documents), in m/s² with gyro and
/// temperature, and `correct`'s header ending in `valid,status`.
const LOOKALIKES: [(&str, &str); 3] = [
    (
        "xsens.csv",
        "t_s,ax_g,ay_g,az_g\n0.000,0.0102,-0.0213,1.0011\n0.010,0.0104,-0.0211,1.0009\n",
    ),
    (
        "bench.csv",
        "t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps,temp_c\n0,0.1,0.2,9.8,0,0,0,24.5\n",
    ),
    (
        "fixed.csv",
        "t,ax,ay,az,ax_corrected,ay_corrected,az_corrected,valid,status\n0,0.1,0.2,9.8,0.1,0.2,9.8,1,ok\n",
    ),
];

/// `simulate -o`, `correct -o` and `fit --reference-csv` never replace a user's file because of
/// its header; the same commands run again into their own outputs just work; their output edited
/// by hand is the user's.
#[test]
fn a_users_file_with_spincals_header_is_kept_and_reruns_replace_only_spincals_own() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, model) = crate::harness::linear_model(dir.path());
    let p = |name: &str| dir.path().join(name);
    for (name, text) in LOOKALIKES {
        std::fs::write(p(name), text).unwrap();
    }
    let before = tree(dir.path());
    for (name, _) in LOOKALIKES {
        let target = p(name);
        let commands: [Vec<&std::ffi::OsStr>; 3] = [
            vec![
                os("simulate"),
                os("--duration"),
                os("2"),
                os("-o"),
                target.as_os_str(),
            ],
            vec![
                os("correct"),
                os("--model"),
                model.as_os_str(),
                rec.as_os_str(),
                os("-o"),
                target.as_os_str(),
            ],
            vec![
                os("fit"),
                rec.as_os_str(),
                os("--reference-csv"),
                target.as_os_str(),
            ],
        ];
        for args in commands {
            let (code, _, err) = run(&args);
            assert_eq!(code, 2, "{args:?}: {err}");
            assert!(
                err.contains(name) && err.contains("spincal did not write it"),
                "{args:?}: {err}"
            );
            assert!(err.contains("--force"), "{err}");
            assert_eq!(tree(dir.path()), before, "{args:?} changed a file");
        }
    }

    // Each command run twice into its own output: no --force, nothing said about replacing.
    let corrected = p("corrected.csv");
    let reference = p("ref.csv");
    let sim = p("sim.csv");
    let reruns: [Vec<&std::ffi::OsStr>; 3] = [
        vec![
            os("simulate"),
            os("--duration"),
            os("2"),
            os("-o"),
            sim.as_os_str(),
        ],
        vec![
            os("correct"),
            os("--model"),
            model.as_os_str(),
            rec.as_os_str(),
            os("-o"),
            corrected.as_os_str(),
        ],
        // linear_model wrote ref.csv with this command already.
        vec![
            os("fit"),
            rec.as_os_str(),
            os("--reference-csv"),
            reference.as_os_str(),
        ],
    ];
    let inputs = (read(&rec), read(&model));
    for args in &reruns {
        for _ in 0..2 {
            let (code, _, err) = run(args);
            assert_eq!(code, 0, "{args:?}: {err}");
            assert!(!err.contains("replacing"), "{args:?}: {err}");
        }
    }
    assert_eq!((read(&rec), read(&model)), inputs);
    for (name, text) in LOOKALIKES {
        assert_eq!(read(&p(name)), text.as_bytes(), "{name}");
    }

    // spincal's output, edited by hand afterwards, is the user's: refused by each command.
    for (target, args) in [&sim, &corrected, &reference].into_iter().zip(&reruns) {
        let mut edited = read(target);
        edited.extend_from_slice(b"# checked by hand\n");
        std::fs::write(target, &edited).unwrap();
        let before = tree(dir.path());
        let (code, _, err) = run(args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            err.contains("spincal did not write it") && err.contains("changed since spincal wrote it"),
            "{args:?}: {err}"
        );
        assert_eq!(tree(dir.path()), before, "{args:?} changed a file");
    }
}

/// The firmware export into one folder twice just works (its `.h` begins with a comment that
/// no longer counts for anything); a user's header beginning `/* spincal */` and an export edited
/// by hand are kept.
#[test]
fn export_reruns_into_its_folder_and_keeps_a_users_header() {
    let dir = tempfile::tempdir().unwrap();
    let (_, model) = crate::harness::linear_model(dir.path());
    let model_bytes = read(&model);
    let export = |out: &Path| {
        run(&[
            os("export"),
            os("--model"),
            model.as_os_str(),
            os("--out"),
            out.as_os_str(),
        ])
    };
    let out = dir.path().join("fw");
    let (code, _, err) = export(&out);
    assert_eq!(code, 0, "{err}");
    let files = listing(&out);
    assert!(files.contains(&"spincal_f32.h".to_string()), "{files:?}");
    let first = tree(&out);
    let (code, _, err) = export(&out);
    assert_eq!(code, 0, "the same export again: {err}");
    assert!(!err.contains("replacing"), "{err}");
    assert_eq!(tree(&out), first, "the same files, to the byte");

    let header = out.join("spincal_f32.h");
    let mut edited = read(&header);
    edited.extend_from_slice(b"#define MY_TRIM 0.01f\n");
    std::fs::write(&header, &edited).unwrap();
    let before = tree(&out);
    let (code, _, err) = export(&out);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("spincal_f32.h") && err.contains("changed since spincal wrote it"),
        "{err}"
    );
    assert_eq!(tree(&out), before);

    let theirs = dir.path().join("fw-mine");
    std::fs::create_dir(&theirs).unwrap();
    let mine = b"/* spincal */\n#define MY_OFFSET 3\n";
    std::fs::write(theirs.join("spincal_f32.h"), mine).unwrap();
    let (code, _, err) = export(&theirs);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("spincal_f32.h") && err.contains("spincal did not write it"),
        "{err}"
    );
    assert_eq!(listing(&theirs), ["spincal_f32.h"], "nothing written");
    assert_eq!(read(&theirs.join("spincal_f32.h")), mine);
    assert_eq!(read(&model), model_bytes);
}
