//! The name of a unit nobody named: its folder's, because a recording's file name is the app's
//! (phyphox writes `Raw Data.csv` for every session) while the folder is the user's.

use std::path::{Component, Path, PathBuf};

/// The longest name kept, in characters: a name is also a folder's name (a fleet's, an output's),
/// and file systems refuse components over 255 bytes.
pub const LONGEST_UNIT_NAME: usize = 64;

/// The unit a recording at `recording` belongs to: the name of the folder holding it (a file at
/// the working directory's top: the working directory's name), or the recording's own name when
/// it is a folder (a Sensor Logger export, a ROS 2 bag). A path that does not exist (an
/// in-memory source such as `<array>`) keeps its own last component. Always [`safe_name`]d.
pub fn unit_name(recording: &Path) -> String {
    let meta = std::fs::metadata(recording);
    let folder = match meta {
        Ok(m) if m.is_dir() => recording.to_path_buf(),
        Ok(_) => match recording.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        },
        Err(_) => {
            let own = recording
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            return safe_name(&own);
        }
    };
    unit_name_of_folder(&folder)
}

/// The name of `folder` (`.`, `..` and a trailing `/` resolved, through links), made safe.
pub fn unit_name_of_folder(folder: &Path) -> String {
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let resolved = std::fs::canonicalize(folder).unwrap_or_else(|_| folder.to_path_buf());
    let name = resolved
        .components()
        .rev()
        .find_map(|c| match c {
            Component::Normal(n) => Some(n.to_string_lossy().into_owned()),
            _ => None,
        })
        .unwrap_or_default();
    safe_name(&name)
}

/// `text` as a name any file system's folder can hold: characters Windows or Unix forbid in a
/// name (`/ \ : * ? " < > |`, control characters) become `-`, leading and trailing spaces and
/// dots go, Windows' device names (CON, NUL, COM1, …) get a `_` appended, at most
/// [`LONGEST_UNIT_NAME`] characters; `unit` when nothing is left.
pub fn safe_name(text: &str) -> String {
    let replaced: String = text
        .chars()
        .map(|c| {
            if c.is_control() || matches!(c, '/' | '\\' | ':' | '*' | '?' | '"' | '<' | '>' | '|') {
                '-'
            } else {
                c
            }
        })
        .collect();
    let trimmed = replaced.trim_matches(|c: char| c == '.' || c.is_whitespace() || c == '-');
    let mut name: String = trimmed.chars().take(LONGEST_UNIT_NAME).collect();
    name = name
        .trim_end_matches(|c: char| c == '.' || c.is_whitespace())
        .to_string();
    if name.is_empty() {
        return "unit".into();
    }
    let stem = name.split('.').next().unwrap_or("").to_ascii_uppercase();
    let reserved = matches!(stem.as_str(), "CON" | "PRN" | "AUX" | "NUL")
        || ((stem.starts_with("COM") || stem.starts_with("LPT"))
            && stem.len() == 4
            && stem.as_bytes()[3].is_ascii_digit());
    if reserved {
        name.push('_');
    }
    name
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_takes_its_folders_name() {
        let dir = tempfile::tempdir().unwrap();
        let session = dir.path().join("phone-2026-11-28");
        std::fs::create_dir(&session).unwrap();
        let file = session.join("Raw Data.csv");
        std::fs::write(&file, "t,ax,ay,az\n").unwrap();
        assert_eq!(unit_name(&file), "phone-2026-11-28");
        // Through `..` and `.` as typed.
        let typed = session
            .join(".")
            .join("..")
            .join("phone-2026-11-28")
            .join("Raw Data.csv");
        assert_eq!(unit_name(&typed), "phone-2026-11-28");
        // A folder recording (Sensor Logger, a bag) is its own unit.
        assert_eq!(unit_name(&session), "phone-2026-11-28");
        // Not a file: its own name, made safe.
        assert_eq!(unit_name(Path::new("<array>")), "array");
    }

    #[test]
    fn a_file_at_the_working_directorys_top_takes_its_name() {
        let here = std::env::current_dir().unwrap();
        let expected = safe_name(&here.file_name().unwrap().to_string_lossy());
        // Cargo runs unit tests in the crate's folder, which holds Cargo.toml.
        assert_eq!(unit_name(Path::new("Cargo.toml")), expected);
        assert_eq!(unit_name_of_folder(Path::new("")), expected);
    }

    #[test]
    fn names_a_folder_cannot_hold_are_made_safe() {
        assert_eq!(safe_name("a/b\\c:d*e?f\"g<h>i|j"), "a-b-c-d-e-f-g-h-i-j");
        assert_eq!(safe_name("  ..hidden. "), "hidden");
        assert_eq!(safe_name("tab\there"), "tab-here");
        assert_eq!(safe_name("CON"), "CON_");
        assert_eq!(safe_name("com1.log"), "com1.log_");
        assert_eq!(safe_name("COM10"), "COM10");
        assert_eq!(safe_name("..."), "unit");
        assert_eq!(safe_name(""), "unit");
        let long = "é".repeat(300);
        assert_eq!(safe_name(&long).chars().count(), LONGEST_UNIT_NAME);
        assert_eq!(
            safe_name("phone 2026-11-28 (kitchen)"),
            "phone 2026-11-28 (kitchen)"
        );
    }
}
