//! A new user's first commands from the outside: `spincal init` writes a campaign file and never
//! replaces one unasked, a unit nobody named takes its folder's name.

use std::path::Path;

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// Every file under `dir` with its bytes' CRC-32, sorted by path.
fn checksums(dir: &Path) -> Vec<(String, u32)> {
    let mut out = Vec::new();
    for entry in walk(dir) {
        let bytes = std::fs::read(&entry).unwrap();
        out.push((entry.display().to_string(), crc32(&bytes)));
    }
    out.sort();
    out
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else {
            files.push(path);
        }
    }
    files
}

/// CRC-32 (IEEE), bit by bit: enough for a test's few files.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn init_writes_each_devices_campaign_and_never_replaces_a_file_unasked() {
    let dir = tempfile::tempdir().unwrap();
    for (device, folder, says) in [
        ("phone", "pixel-7", "45 rpm"),
        ("breakout", "mpu6050 board", "FS_SEL"),
        ("flight-controller", "fc", "needs no turntable"),
    ] {
        let kit = dir.path().join(folder);
        std::fs::create_dir(&kit).unwrap();
        // The default file name, in the working directory: the unit is the folder's name.
        let run = spincal()
            .current_dir(&kit)
            .args(["init", "--device", device])
            .output()
            .unwrap();
        assert_eq!(
            run.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            stdout.starts_with("wrote campaign.toml")
                && stdout.contains("spincal calibrate --campaign campaign.toml"),
            "{stdout}"
        );
        let file = kit.join("campaign.toml");
        let text = std::fs::read_to_string(&file).unwrap();
        assert!(text.contains(&format!("unit = \"{folder}\"")), "{text}");
        assert!(text.contains(says), "{device}: {text}");

        // Again: refused (a usage error), the file and everything else unchanged.
        let before = checksums(dir.path());
        let again = spincal()
            .current_dir(&kit)
            .args(["init", "--device", "breakout"])
            .output()
            .unwrap();
        assert_eq!(again.status.code(), Some(2));
        let stderr = String::from_utf8_lossy(&again.stderr);
        assert!(
            stderr.contains("campaign.toml already exists") && stderr.contains("--force"),
            "{stderr}"
        );
        assert_eq!(checksums(dir.path()), before);
    }

    // A file the user edited is refused too; --force replaces it and says so.
    let file = dir.path().join("pixel-7/campaign.toml");
    let mut edited = std::fs::read_to_string(&file).unwrap();
    edited.push_str("# my notes\n");
    std::fs::write(&file, &edited).unwrap();
    let before = checksums(dir.path());
    let refused = spincal()
        .args(["init", "--device", "phone", "-o"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(refused.status.code(), Some(2));
    assert_eq!(checksums(dir.path()), before);
    let forced = spincal()
        .args(["--force", "init", "--device", "phone", "-o"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(
        forced.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&forced.stderr)
    );
    assert!(String::from_utf8_lossy(&forced.stderr).contains("replacing"));
    assert!(!std::fs::read_to_string(&file).unwrap().contains("# my notes"));

    // A new folder is made; a folder in the way is refused by name.
    let nested = dir.path().join("new/unit-3/campaign.toml");
    spincal()
        .args(["init", "--device", "breakout", "-o"])
        .arg(&nested)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&nested)
        .unwrap()
        .contains("unit = \"unit-3\""));
    let in_the_way = spincal()
        .args(["init", "--device", "phone", "-o"])
        .arg(dir.path().join("new"))
        .output()
        .unwrap();
    assert_eq!(in_the_way.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&in_the_way.stderr);
    assert!(stderr.contains("new"), "{stderr}");
}

#[test]
fn an_unknown_device_is_a_usage_error_naming_the_choices() {
    let dir = tempfile::tempdir().unwrap();
    let run = spincal()
        .current_dir(dir.path())
        .args(["init", "--device", "toaster"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("phone") && stderr.contains("breakout") && stderr.contains("flight-controller"),
        "{stderr}"
    );
    assert!(
        std::fs::read_dir(dir.path()).unwrap().next().is_none(),
        "wrote something"
    );
}
