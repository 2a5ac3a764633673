//! Every example in every `spincal <command> --help` runs, on files made here (or, for the
//! real-data examples, the files in ../shared/data; those skip with a reason where it is absent).

use std::path::Path;

use assert_cmd::Command;
use spincal::input::formats::gx1::{encode, Gx1EncodeOptions};
use spincal::input::recording::{Recording, Source};

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

fn stdout_of(args: &[&str]) -> String {
    let out = spincal().args(args).output().unwrap();
    assert!(out.status.success(), "spincal {args:?} failed");
    String::from_utf8(out.stdout).unwrap()
}

/// The subcommand names listed by `spincal --help`.
fn subcommands() -> Vec<String> {
    let help = stdout_of(&["--help"]);
    let commands = help.split("Commands:").nth(1).expect("a Commands section");
    let list = commands.split("Options:").next().unwrap();
    list.lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

/// The example command lines of one subcommand's help (continuation lines joined, comments and
/// anything after `&&` dropped).
fn examples(command: &str) -> Vec<String> {
    let help = stdout_of(&[command, "--help"]);
    let Some(section) = help.split("Example").nth(1) else {
        return Vec::new();
    };
    let mut found = Vec::new();
    let mut pending: Option<String> = None;
    for line in section.lines() {
        let text = line.trim();
        if let Some(mut joined) = pending.take() {
            joined.push(' ');
            joined.push_str(text.trim_end_matches('\\'));
            if text.ends_with('\\') {
                pending = Some(joined);
            } else {
                found.push(joined);
            }
            continue;
        }
        if !text.starts_with("spincal ") {
            continue;
        }
        let text = text
            .split(" # ")
            .next()
            .unwrap()
            .split(" && ")
            .next()
            .unwrap()
            .trim();
        if let Some(head) = text.strip_suffix('\\') {
            pending = Some(head.trim().to_string());
        } else {
            found.push(text.to_string());
        }
    }
    found
}

/// Splits a command line as a shell would for these examples (single quotes, no escapes).
fn split_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quoted = false;
    let mut any = false;
    for c in line.chars() {
        match c {
            '\'' => {
                quoted = !quoted;
                any = true;
            }
            c if c.is_whitespace() && !quoted => {
                if any {
                    words.push(std::mem::take(&mut word));
                    any = false;
                }
            }
            c => {
                word.push(c);
                any = true;
            }
        }
    }
    if any {
        words.push(word);
    }
    words
}

/// Files the examples name that come from ../shared/data.
const SHARED: [(&str, &str); 6] = [
    ("xsens_acc.mat", "imu/imu_tk_xsens/xsens_acc.mat"),
    ("xsens_gyro.mat", "imu/imu_tk_xsens/xsens_gyro.mat"),
    ("annotated_session.csv", "imu/imucal/annotated_session.csv"),
    (
        "example_data_calibration.csv",
        "imu/mpu6050/example_data_calibration.csv",
    ),
    ("Silverbox_SNLS80mV.csv", "sysid/Silverbox_SNLS80mV.csv"),
    (
        "CascadedTanks_dataBenchmark.mat",
        "sysid/CascadedTanks_dataBenchmark.mat",
    ),
];

fn simulate(dir: &Path, name: &str, rpm: &str, seed: &str) {
    spincal()
        .current_dir(dir)
        .args([
            "simulate",
            "-o",
            name,
            "--rpm",
            rpm,
            "--duration",
            "20",
            "--seed",
            seed,
        ])
        .assert()
        .success();
}

/// A still recording: gravity on z with white noise (a fixed sequence, 60 s at 100 Hz).
fn write_still(path: &Path) {
    let mut state: u64 = 12345;
    let mut noise = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
    };
    let mut text = String::from("t_s,ax_g,ay_g,az_g\n");
    for i in 0..6000 {
        text += &format!(
            "{:.3},{:.6},{:.6},{:.6}\n",
            i as f64 * 0.01,
            noise(),
            noise(),
            1.0 + noise()
        );
    }
    std::fs::write(path, text).unwrap();
}

fn write_gx1(path: &Path) {
    let n = 500;
    let rec = Recording {
        time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
        accel_mps2: [vec![0.5; n], vec![-0.25; n], vec![9.8; n]],
        gyro_radps: None,
        temperature_c: None,
        source: Source::default(),
    };
    std::fs::write(path, encode(&rec, &Gx1EncodeOptions::default()).unwrap()).unwrap();
}

/// Commands whose examples make files that other examples read run first.
fn order(command: &str) -> usize {
    ["simulate", "fit", "static", "train"]
        .iter()
        .position(|c| *c == command)
        .unwrap_or(4)
}

#[test]
fn every_help_example_runs() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path();
    let mut commands = subcommands();
    assert!(commands.len() >= 14, "{commands:?}");
    commands.sort_by_key(|c| order(c));
    let mut ran = 0;
    let mut fixtures_made = false;
    for command in &commands {
        if command != "simulate" && !fixtures_made {
            // Short recordings keep the examples' trainings quick; made after `simulate`'s own
            // example so that they replace its two-minute file.
            simulate(work, "rec.csv", "33.333", "1");
            simulate(work, "rec33.csv", "33.333", "2");
            simulate(work, "rec45.csv", "45", "3");
            for name in ["session.csv", "data.csv", "new.csv", "io.csv"] {
                std::fs::copy(work.join("rec.csv"), work.join(name)).unwrap();
            }
            write_still(&work.join("still.csv"));
            write_gx1(&work.join("imu.bin"));
            for (name, relative) in SHARED {
                if let Some(path) = crate::harness::shared(relative) {
                    std::fs::copy(path, work.join(name)).unwrap();
                }
            }
            fixtures_made = true;
        }
        for example in examples(command) {
            let words = split_words(&example);
            assert_eq!(words[0], "spincal");
            if let Some((name, _)) = SHARED.iter().find(|(name, _)| words.iter().any(|w| w == name)) {
                if !work.join(name).exists() {
                    println!("skipped `{example}`: ../shared/data is absent ({name})");
                    continue;
                }
            }
            if words[1..] == ["demo", "--out", "spincal-demo"] {
                // The suite runs the demo once, this very command (the demo test checks its files).
                crate::support::demo();
                ran += 1;
                continue;
            }
            let out = spincal()
                .current_dir(work)
                .args(&words[1..])
                .arg("--quiet")
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "`{example}` exited with {:?}:\n{}",
                out.status.code(),
                String::from_utf8_lossy(&out.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran >= 25, "only {ran} examples ran");
}

#[test]
fn example_lines_are_split_like_a_shell() {
    assert_eq!(
        split_words("spincal sweep --grid '1-15' -o x"),
        ["spincal", "sweep", "--grid", "1-15", "-o", "x"]
    );
    assert_eq!(split_words("a '' b"), ["a", "", "b"]);
}

/// The README's text.
fn readme() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    std::fs::read_to_string(path).unwrap()
}

/// The subcommands each row of the README's command table names in its first cell
/// (`spincal NAME`, each name once per row).
fn readme_table_rows() -> Vec<Vec<String>> {
    let text = readme();
    let table = text
        .split("| command | what it does |")
        .nth(1)
        .expect("the README's command table");
    table
        .lines()
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|row| {
            let first = row.trim_start_matches('|').split(" | ").next().unwrap();
            let mut names: Vec<String> = first
                .split("`spincal ")
                .skip(1)
                .filter_map(|rest| rest.split([' ', '`']).next())
                .map(str::to_string)
                .collect();
            names.dedup();
            names
        })
        .collect()
}

#[test]
fn the_readme_command_table_names_each_subcommand_exactly_once() {
    let commands = subcommands();
    assert!(commands.len() > 10, "{commands:?}");
    let rows = readme_table_rows();
    for command in &commands {
        let count = rows.iter().filter(|r| r.contains(command)).count();
        assert_eq!(
            count, 1,
            "`spincal {command}` is in {count} rows of the README's table"
        );
    }
    for name in rows.iter().flatten() {
        assert!(
            commands.contains(name),
            "the README's table names `spincal {name}`, which is no subcommand"
        );
    }
}

#[test]
fn the_readme_names_every_model_file_kind() {
    // The kinds the model file reads, from the reader's own refusal of an unknown kind.
    let err = serde_json::from_str::<spincal::correctors::model_file::CorrectorModel>(
        r#"{"kind": "no-such-kind"}"#,
    )
    .unwrap_err()
    .to_string();
    let expected = err.split("expected one of").nth(1).expect(&err);
    let mut kinds: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    kinds.sort();
    assert!(kinds.len() >= 4, "{err}");
    let text = readme();
    let listed = text
        .split("by `kind` (")
        .nth(1)
        .and_then(|rest| rest.split(')').next())
        .expect("the README's list of model kinds");
    let mut readme_kinds: Vec<&str> = listed.split('`').skip(1).step_by(2).collect();
    readme_kinds.sort();
    assert_eq!(readme_kinds, kinds);
}

/// The help of `spincal <command>`.
fn help(command: &str) -> String {
    stdout_of(&[command, "--help"])
}

#[test]
fn help_texts_say_what_the_commands_do() {
    // Every command that writes a model file is named by `correct --model`.
    let correct = help("correct");
    for writer in [
        "spincal calibrate",
        "--campaign",
        "spincal train",
        "spincal static -o",
        "spincal fleet",
    ] {
        assert!(
            correct.contains(writer),
            "correct --help leaves out {writer}:\n{correct}"
        );
    }
    // demo runs a campaign as well as the paper's protocol.
    let demo = help("demo");
    assert!(
        demo.contains("campaign") && demo.contains("calibrate --campaign"),
        "{demo}"
    );
    // static --yaml is not Kalibr's imu.yaml.
    let static_help = help("static");
    assert!(static_help.contains("not Kalibr's imu.yaml"), "{static_help}");
    // strobe --exact: the help's two cases behave as it says.
    let strobe = help("strobe");
    assert!(strobe.contains("33.333") && strobe.contains("45 rpm"), "{strobe}");
    let dir = tempfile::tempdir().unwrap();
    let disc = dir.path().join("disc.svg");
    let passes = spincal()
        .args(["strobe", "--rpm", "33.333", "--exact", "-o"])
        .arg(&disc)
        .output()
        .unwrap();
    assert_eq!(
        passes.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&passes.stderr)
    );
    let before = std::fs::read(&disc).unwrap();
    let fails = spincal()
        .args(["strobe", "--rpm", "45", "--exact", "-o"])
        .arg(&disc)
        .output()
        .unwrap();
    assert_eq!(
        fails.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&fails.stderr)
    );
    assert!(String::from_utf8_lossy(&fails.stderr).contains("133"));
    assert_eq!(
        std::fs::read(&disc).unwrap(),
        before,
        "a failed disc leaves the old one"
    );
}
