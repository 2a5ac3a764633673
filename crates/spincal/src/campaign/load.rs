//! Reading a campaign's recordings (and their truth and random-error files) from disk.

use crate::campaign::file::{Campaign, EntryKind};
use crate::campaign::prepare::UnitRecording;
use crate::input::formats::{check_input, read_path, FormatError, ReadOptions};
use crate::input::gyro_file::attach_gyro_file;
use crate::output::identity;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    #[error("{campaign}:{line}: `file`: {source}")]
    Recording {
        campaign: String,
        line: usize,
        #[source]
        source: Box<FormatError>,
    },
    /// A companion file (`truth` or `random_error`) that cannot be read.
    #[error("{campaign}:{line}: `{key}`: {source}")]
    Companion {
        campaign: String,
        line: usize,
        key: &'static str,
        #[source]
        source: Box<FormatError>,
    },
    #[error("{campaign}:{line}: `{key}`: {file} has {found} samples but the recording has {expected}")]
    CompanionLength {
        campaign: String,
        line: usize,
        key: &'static str,
        file: String,
        found: usize,
        expected: usize,
    },
    #[error("{campaign}:{line}: `gyro_file`: {message}")]
    GyroFile {
        campaign: String,
        line: usize,
        message: String,
    },
    /// Two entries naming one file (the same device and inode, through any link or path).
    #[error("{campaign}:{line}: `file`: {file} is the same file as the entry at line {first_line} ({first_file}); each recording may be listed once")]
    SameFile {
        campaign: String,
        line: usize,
        file: String,
        first_line: usize,
        first_file: String,
    },
    #[error("{campaign}:{line}: `gyro_range_dps`: {file}'s gyro holds raw counts; give the range the part was set to (`gyro_range_dps`, the MPU-6050's default is 250) or `gyro_scale` (rad/s per count)")]
    RawGyroCounts {
        campaign: String,
        line: usize,
        file: String,
    },
    #[error("{campaign}:{line}: `accel_range_g`: {file} holds raw counts; give the range the part was set to (`accel_range_g`, the MPU-6050's default is 2) or `accel_scale` (m/s² per count)")]
    RawCounts {
        campaign: String,
        line: usize,
        file: String,
    },
}

/// Checks every entry's files before any is read: each a regular file within the size limit
/// (or a bag or Sensor Logger folder), and no file named by two entries (a file read twice
/// counts its samples twice; 10,000 entries naming one file must not be read 10,000 times).
pub fn check_entries(campaign: &Campaign) -> Result<(), LoadError> {
    let name = campaign.path.display().to_string();
    let mut seen = std::collections::HashMap::with_capacity(campaign.recordings.len());
    for entry in &campaign.recordings {
        check_input(&entry.file).map_err(|source| LoadError::Recording {
            campaign: name.clone(),
            line: entry.line,
            source: Box::new(source),
        })?;
        for (key, path) in [
            ("gyro_file", &entry.gyro_file),
            ("truth", &entry.truth),
            ("random_error", &entry.random_error),
        ] {
            if let Some(path) = path {
                check_input(path).map_err(|source| LoadError::Companion {
                    campaign: name.clone(),
                    line: entry.line,
                    key,
                    source: Box::new(source),
                })?;
            }
        }
        if let Some(&(first_line, first)) = seen.get(&identity(&entry.file)) {
            let first: &std::path::Path = first;
            return Err(LoadError::SameFile {
                campaign: name,
                line: entry.line,
                file: entry.file.display().to_string(),
                first_line,
                first_file: first.display().to_string(),
            });
        }
        seen.insert(identity(&entry.file), (entry.line, entry.file.as_path()));
    }
    Ok(())
}

/// Reads every recording of the campaign (formats detected as the CLI does), after
/// [`check_entries`].
pub fn load_campaign(campaign: &Campaign) -> Result<Vec<UnitRecording>, LoadError> {
    check_entries(campaign)?;
    let name = campaign.path.display().to_string();
    let mut out = Vec::with_capacity(campaign.recordings.len());
    for entry in &campaign.recordings {
        let mut loaded = read_path(&entry.file, &entry.read).map_err(|source| LoadError::Recording {
            campaign: name.clone(),
            line: entry.line,
            source: Box::new(source),
        })?;
        if let Some(path) = &entry.gyro_file {
            // The note of a merge on time goes into the recording's time notes.
            attach_gyro_file(&mut loaded, path, &entry.read).map_err(|e| LoadError::GyroFile {
                campaign: name.clone(),
                line: entry.line,
                message: e.to_string(),
            })?;
        }
        if loaded.gyro_counts {
            return Err(LoadError::RawGyroCounts {
                campaign: name.clone(),
                line: entry.line,
                file: entry
                    .gyro_file
                    .as_ref()
                    .unwrap_or(&entry.file)
                    .display()
                    .to_string(),
            });
        }
        if loaded.raw_counts {
            return Err(LoadError::RawCounts {
                campaign: name.clone(),
                line: entry.line,
                file: entry.file.display().to_string(),
            });
        }
        let recording = loaded.recording;
        // A per-sample companion of the recording: its three acceleration columns.
        let companion = |key: &'static str, path: &Option<std::path::PathBuf>| {
            let Some(path) = path else {
                return Ok(None);
            };
            let t = read_path(path, &ReadOptions::default()).map_err(|source| LoadError::Companion {
                campaign: name.clone(),
                line: entry.line,
                key,
                source: Box::new(source),
            })?;
            if t.recording.len() != recording.len() {
                return Err(LoadError::CompanionLength {
                    campaign: name.clone(),
                    line: entry.line,
                    key,
                    file: path.display().to_string(),
                    found: t.recording.len(),
                    expected: recording.len(),
                });
            }
            Ok(Some(t.recording.accel_mps2))
        };
        let truth = companion("truth", &entry.truth)?;
        let random_mps2 = companion("random_error", &entry.random_error)?;
        out.push(UnitRecording {
            name: entry.file.display().to_string(),
            recording,
            turntable: match &entry.kind {
                EntryKind::Static => None,
                EntryKind::Turntable(t) => Some(t.clone()),
            },
            truth,
            floor_mps2: entry.noise_floor_mps2,
            random_mps2,
            session: entry.session.clone(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::recording::STANDARD_GRAVITY;

    /// An MPU-6050 logger's raw counts read through the campaign's keys: its ranges name the
    /// scales; without them the counts are refused with the key to give.
    #[test]
    fn a_breakout_boards_raw_counts_read_by_its_ranges() {
        let dir = tempfile::tempdir().unwrap();
        let rows: String = (0..200)
            .map(|i| format!("{},{},{},131,-262,{}\n", i % 3, -(i % 2), 16384 + i % 5, 655))
            .collect();
        std::fs::write(
            dir.path().join("still.csv"),
            format!("Fs,100\nax,ay,az,gx,gy,gz\n{rows}"),
        )
        .unwrap();
        let path = dir.path().join("c.toml");
        let campaign = |keys: &str| {
            let text = format!("[[recording]]\nfile = \"still.csv\"\nkind = \"static\"\n{keys}");
            Campaign::parse(&text, &path).unwrap()
        };
        let loaded = load_campaign(&campaign("accel_range_g = 2\ngyro_range_dps = 250\n")).unwrap();
        let rec = &loaded[0].recording;
        let z = rec.accel_mps2[2].iter().sum::<f64>() / rec.len() as f64;
        assert!((z - STANDARD_GRAVITY).abs() < 2e-3 * STANDARD_GRAVITY, "az {z}");
        let gyro = rec.gyro_radps.as_ref().expect("the gyro, in rad/s");
        // 131 counts per °/s at ±250 °/s (32768 / 250 = 131.07).
        assert!(
            (gyro[0][0] - 1f64.to_radians()).abs() < 2e-3 * 1f64.to_radians(),
            "gx {}",
            gyro[0][0]
        );
        assert!(
            (gyro[1][0] + 2f64.to_radians()).abs() < 4e-3 * 1f64.to_radians(),
            "gy {}",
            gyro[1][0]
        );
        let e = load_campaign(&campaign("accel_range_g = 2\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(":1: `gyro_range_dps`") && e.contains("raw counts"),
            "{e}"
        );
        let e = load_campaign(&campaign("gyro_range_dps = 250\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(":1: `accel_range_g`") && e.contains("raw counts"),
            "{e}"
        );
    }
}
