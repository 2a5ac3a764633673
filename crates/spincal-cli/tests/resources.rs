//! Resources (issue 47, item 5): what spincal agrees to read and what it leaves behind. Campaign
//! entries naming one file are refused before any is read; a device, a FIFO or a folder that is no
//! recording is refused by name without hanging; a killed run's temporary file is removed by the
//! next run into its folder while nobody else's file is touched; a command that fails early leaves
//! no folder it made. Each case checks the exit code, the message and the checksums of the inputs
//! and pre-existing files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::harness::spincal;

/// A file's bytes, for comparing before and after (the files here are small).
fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap()
}

/// Every file under `dir` (recursively) with its bytes, sorted by path.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            let meta = std::fs::symlink_metadata(&path).unwrap();
            if meta.is_dir() {
                stack.push(path);
            } else if meta.is_file() {
                out.push((path.clone(), read(&path)));
            } else {
                out.push((path, Vec::new()));
            }
        }
    }
    out.sort();
    out
}

/// Runs `cmd`, killing it (and failing) if it takes longer than 60 s: a FIFO that blocks must
/// fail the test, not hang it.
fn run_bounded(cmd: &mut Command) -> Output {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{cmd:?} did not finish within 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A small still recording in spincal's CSV layout.
fn still_csv(path: &Path, rows: usize) {
    let mut text = String::from("t,ax,ay,az\n");
    for i in 0..rows {
        let wiggle = 0.001 * ((i * 7919) % 13) as f64;
        text += &format!("{:.3},{wiggle:.4},{:.4},9.8066\n", i as f64 * 0.01, -wiggle);
    }
    std::fs::write(path, text).unwrap();
}

/// `[[recording]]` entries, each a still file.
fn entries(files: &[&str]) -> String {
    files
        .iter()
        .map(|f| format!("[[recording]]\nfile = \"{f}\"\nkind = \"static\"\n"))
        .collect()
}

/// `spincal calibrate --campaign FILE --out OUT`, bounded in time.
fn calibrate_campaign(campaign: &Path, out: &Path) -> Output {
    run_bounded(
        spincal()
            .args(["calibrate", "--quiet", "--campaign"])
            .arg(campaign)
            .arg("--out")
            .arg(out),
    )
}

#[test]
fn campaign_entries_naming_one_file_are_refused_before_any_is_read() {
    let dir = tempfile::tempdir().unwrap();
    still_csv(&dir.path().join("still.csv"), 2000);
    // The same file by another path, and (on unix) by a hard link: one inode.
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    #[cfg(unix)]
    std::fs::hard_link(dir.path().join("still.csv"), dir.path().join("linked.csv")).unwrap();
    #[cfg(not(unix))]
    std::fs::copy(dir.path().join("still.csv"), dir.path().join("linked.csv")).unwrap();
    let campaign = dir.path().join("campaign.toml");
    let mut text = String::from("unit = \"u\"\n");
    text += &entries(&["still.csv", "sub/../still.csv"]);
    std::fs::write(&campaign, &text).unwrap();
    let before = snapshot(dir.path());
    let out = dir.path().join("cal");
    let done = calibrate_campaign(&campaign, &out);
    let err = stderr(&done);
    assert_eq!(done.status.code(), Some(1), "{err}");
    assert!(
        err.contains("campaign.toml:5: `file`") && err.contains("is the same file as the entry at line 2"),
        "{err}"
    );
    #[cfg(unix)]
    {
        text = String::from("unit = \"u\"\n") + &entries(&["still.csv", "linked.csv"]);
        std::fs::write(&campaign, &text).unwrap();
        let done = calibrate_campaign(&campaign, &out);
        let err = stderr(&done);
        assert_eq!(done.status.code(), Some(1), "{err}");
        assert!(
            err.contains("linked.csv is the same file as the entry at line 2"),
            "{err}"
        );
        std::fs::write(&campaign, before_text(&before, &campaign)).unwrap();
    }
    assert!(!out.exists(), "an output folder was left");
    assert_eq!(snapshot(dir.path()), before);

    // 10,000 entries naming one file: refused at once, without reading it 10,000 times.
    let many = String::from("unit = \"u\"\n") + &entries(&vec!["still.csv"; 10_000]);
    std::fs::write(&campaign, many).unwrap();
    let clock = Instant::now();
    let done = calibrate_campaign(&campaign, &out);
    let err = stderr(&done);
    assert_eq!(done.status.code(), Some(1), "{err}");
    assert!(
        err.contains("campaign.toml:5: `file`") && err.contains("line 2"),
        "{err}"
    );
    println!("10,000 entries refused in {:.2} s", clock.elapsed().as_secs_f64());
    assert!(!out.exists());
}

/// The text `campaign` had in a snapshot.
fn before_text(before: &[(PathBuf, Vec<u8>)], campaign: &Path) -> Vec<u8> {
    before.iter().find(|(p, _)| p == campaign).unwrap().1.clone()
}

#[cfg(unix)]
#[test]
fn devices_fifos_and_plain_folders_are_refused_by_name_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("rows.fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let folder = dir.path().join("recordings");
    std::fs::create_dir(&folder).unwrap();
    still_csv(&folder.join("still.csv"), 50);
    let before = snapshot(dir.path());
    let cases: [(&Path, &str); 3] = [
        (
            Path::new("/dev/zero"),
            "is a character device, not a regular file",
        ),
        (&fifo, "is a named pipe (FIFO), not a regular file"),
        (&folder, "is a folder, not a recording"),
    ];
    for (path, why) in cases {
        // A whole-file reader (`fit`) and the streaming inspection.
        for command in ["fit", "inspect"] {
            let done = run_bounded(spincal().arg(command).arg("--quiet").arg(path));
            let err = stderr(&done);
            assert_eq!(done.status.code(), Some(1), "{command} {path:?}: {err}");
            assert!(
                err.contains(&path.display().to_string()) && err.contains(why),
                "{command}: {err}"
            );
        }
        // A campaign entry: refused before any recording is read.
        let campaign = dir.path().join("campaign.toml");
        let text = format!(
            "unit = \"u\"\n{}[[recording]]\nfile = \"{}\"\nkind = \"static\"\n",
            entries(&["recordings/still.csv"]),
            path.display()
        );
        std::fs::write(&campaign, text).unwrap();
        let out = dir.path().join("cal");
        let done = calibrate_campaign(&campaign, &out);
        let err = stderr(&done);
        assert_eq!(done.status.code(), Some(1), "campaign {path:?}: {err}");
        assert!(
            err.contains("campaign.toml:5: `file`") && err.contains(why),
            "{err}"
        );
        assert!(!out.exists(), "an output folder was left");
        std::fs::remove_file(&campaign).unwrap();
    }
    assert_eq!(snapshot(dir.path()), before);

    // `correct` streams a FIFO (tests/real_files.rs) but not a device: /dev/zero is one line
    // that never ends.
    let (_, model) = crate::harness::linear_model(dir.path());
    let before = snapshot(dir.path());
    let out = dir.path().join("corrected.csv");
    let done = run_bounded(
        spincal()
            .args(["correct", "--quiet", "--model"])
            .arg(&model)
            .arg("/dev/zero")
            .arg("-o")
            .arg(&out),
    );
    let err = stderr(&done);
    assert_eq!(done.status.code(), Some(1), "{err}");
    assert!(
        err.contains("/dev/zero") && err.contains("is a character device"),
        "{err}"
    );
    assert_eq!(snapshot(dir.path()), before);
}

/// A process id that is certainly not running: a child that has ended and been reaped.
#[cfg(unix)]
fn dead_pid() -> u32 {
    let mut child = Command::new("true").spawn().unwrap();
    let pid = child.id();
    child.wait().unwrap();
    pid
}

#[cfg(unix)]
#[test]
fn a_killed_runs_temporary_is_removed_by_the_next_run_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim.csv");
    let stale = dir.path().join(format!(".sim.csv.spincal-{}-0.tmp", dead_pid()));
    // A temporary of a live writer (this test's process), and files that only look alike.
    let live = dir
        .path()
        .join(format!(".sim.csv.spincal-{}-3.tmp", std::process::id()));
    let others = [
        live.clone(),
        dir.path().join(".notes.spincal-12.tmp"),
        dir.path().join("sim.csv.spincal-1-0.tmp"),
        dir.path().join(format!(".x.spincal-{}-0.tmp.bak", dead_pid())),
    ];
    std::fs::write(&stale, "half a file").unwrap();
    for other in &others {
        std::fs::write(other, "someone's").unwrap();
    }
    let before = snapshot(dir.path());
    let done = run_bounded(
        spincal()
            .args(["simulate", "--quiet", "--duration", "2", "-o"])
            .arg(&out),
    );
    assert!(done.status.success(), "{}", stderr(&done));
    assert!(!stale.exists(), "the stale temporary is still there");
    let after = snapshot(dir.path());
    for (path, bytes) in before.iter().filter(|(p, _)| *p != stale) {
        let now = after.iter().find(|(p, _)| p == path);
        assert_eq!(now.map(|(_, b)| b), Some(bytes), "{path:?} changed");
    }
    assert!(out.is_file());
}

#[test]
fn an_early_failure_leaves_no_folder_it_made() {
    let dir = tempfile::tempdir().unwrap();
    // The campaign parses, but its recording cannot be read: the failure comes after the
    // output folder was made.
    let campaign = dir.path().join("campaign.toml");
    std::fs::write(dir.path().join("bad.csv"), "t,ax,ay,az\n0,1,2,x\n").unwrap();
    std::fs::write(&campaign, String::from("unit = \"u\"\n") + &entries(&["bad.csv"])).unwrap();
    let before = snapshot(dir.path());
    let out = dir.path().join("new").join("cal");
    let done = calibrate_campaign(&campaign, &out);
    let err = stderr(&done);
    assert_eq!(done.status.code(), Some(1), "{err}");
    assert!(err.contains("bad.csv") && err.contains("not a number"), "{err}");
    assert!(
        !dir.path().join("new").exists(),
        "spincal left the folders it made"
    );
    assert_eq!(snapshot(dir.path()), before);
    // A folder the user made stays, empty as it was.
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    let done = calibrate_campaign(&campaign, &mine);
    assert_eq!(done.status.code(), Some(1), "{}", stderr(&done));
    assert!(mine.is_dir() && std::fs::read_dir(&mine).unwrap().next().is_none());
}
