//! ROS bags: `sensor_msgs/Imu` (or a `geometry_msgs/Vector3Stamped` accelerometer topic with its
//! gyro topic) read from ROS 2 bags (MCAP or sqlite3 storage) and ROS 1 bags (format 2.0).
//!
//! One pass over the bag: every topic is counted, the IMU-shaped topics (or only the one asked
//! for) are decoded as they come ([`Collector`]); then one topic is chosen (`choose`) and turned
//! into a [`Recording`](crate::input::recording::Recording) (`assemble`). Storage readers (`mcap`, `sqlite`, `ros1`) only walk records
//! and hand each message with a lazily formatted location to the collector, so a message that
//! does not decode is reported with the file, the storage location (byte offset, chunk, row id),
//! the topic and the message's index in it.
//!
//! Time: the header stamps (ns), or the receive (log) times when every stamp of the topic is
//! zero; samples sorted by time (stable); `time_s` counts from the first sample, and the absolute
//! start is kept in the metadata (epoch seconds in an f64 would lose 0.2 µs). Units are REP-103's
//! (m/s², rad/s), as the messages carry them.

mod assemble;
mod choice;
mod chunk;
mod collector;
pub mod mcap;
pub mod msg;
pub mod ros1;
pub mod sqlite;

use std::path::Path;

use crate::input::formats::bag_detect::Storage;

use assemble::assemble;
use chunk::decompress_chunk;

pub use assemble::BagRead;
pub use chunk::{chunk_limit, CHUNK_SLACK_BYTES, MAX_CHUNK_BYTES, MAX_CHUNK_RATIO};
pub use collector::{Collector, TopicInfo};

/// Everything that can go wrong reading a bag. Each names the file, and where inside it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// The storage itself is damaged or cut short.
    #[error("{file}: {at}: {what}")]
    Corrupt { file: String, at: String, what: String },
    /// One message does not decode as its type.
    #[error("{file}: topic {topic}, message {index} ({at}): {what}")]
    Message {
        file: String,
        topic: String,
        /// 1-based index of the message within its topic.
        index: u64,
        at: String,
        what: String,
    },
    #[error("{file}: sqlite3 storage: {what}: {source}")]
    Sqlite {
        file: String,
        what: String,
        #[source]
        source: rusqlite::Error,
    },
    #[error("{file}: {what}")]
    Unsupported { file: String, what: String },
    #[error("{file}: no IMU topic (sensor_msgs/Imu, or geometry_msgs/Vector3Stamped accelerometer [+ gyro]); topics: {topics}")]
    NoImuTopic { file: String, topics: String },
    #[error("{file}: {count} IMU topics; choose one as `topic`: {topics}")]
    SeveralTopics {
        file: String,
        count: usize,
        topics: String,
    },
    #[error("{file}: no IMU topic '{topic}'; IMU topics: {topics}")]
    NoSuchTopic {
        file: String,
        topic: String,
        topics: String,
    },
    #[error("{file}: topic {topic} has {found} messages; at least 2 are needed")]
    TooFew {
        file: String,
        topic: String,
        found: usize,
    },
}

/// Reads a bag held in memory (one `.mcap`, `.db3` or `.bag` file); `file` names it in errors.
/// `salvage`: a file whose end is damaged (cut, its footer or index lost) gives the messages
/// before the damage, with a note, instead of an error.
pub fn read_bytes(bytes: &[u8], file: &str, topic: Option<&str>, salvage: bool) -> Result<BagRead, BagError> {
    let storage = Storage::sniff(bytes).ok_or_else(|| BagError::Corrupt {
        file: file.into(),
        at: "byte 0".into(),
        what: "not a bag: no MCAP, SQLite or ROS 1 bag magic".into(),
    })?;
    let mut c = Collector::new(file, topic, salvage);
    scan(storage, bytes, None, file, &mut c)?;
    assemble(c, storage, topic)
}

fn scan(
    storage: Storage,
    bytes: &[u8],
    path: Option<&Path>,
    file: &str,
    c: &mut Collector,
) -> Result<(), BagError> {
    match storage {
        Storage::Mcap => mcap::scan(bytes, file, c),
        Storage::Sqlite3 => match path {
            Some(p) => sqlite::scan_path(p, file, c),
            None => sqlite::scan_bytes(bytes, file, c),
        },
        Storage::Ros1 => ros1::scan(bytes, file, c),
    }
}

/// Reads a bag file, or a ROS 2 bag directory (its `metadata.yaml` names the storage files, read
/// in order as one bag); `salvage` as in [`read_bytes`].
pub fn read_path(path: &Path, topic: Option<&str>, salvage: bool) -> Result<BagRead, BagError> {
    let file = path.display().to_string();
    let io = |f: &Path, source| BagError::Io {
        file: f.display().to_string(),
        source,
    };
    let files = if path.is_dir() {
        dir_files(path)?
    } else {
        vec![path.to_path_buf()]
    };
    let mut c = Collector::new(&file, topic, salvage);
    let mut storage = None;
    for f in &files {
        let name = f.display().to_string();
        let bytes = crate::input::table::read_file(f).map_err(|e| io(f, e))?;
        let s = Storage::sniff(&bytes).ok_or_else(|| BagError::Corrupt {
            file: name.clone(),
            at: "byte 0".into(),
            what: "not a bag file: no MCAP, SQLite or ROS 1 bag magic".into(),
        })?;
        if storage.is_some_and(|p| p != s) {
            return Err(BagError::Unsupported {
                file: name,
                what: "storage files of different kinds in one bag".into(),
            });
        }
        storage = Some(s);
        c.file = name.clone();
        scan(s, &bytes, Some(f), &name, &mut c)?;
    }
    c.file = file.clone();
    let storage = storage.ok_or_else(|| BagError::Unsupported {
        file: file.clone(),
        what: "no storage file (.mcap or .db3) in the bag directory".into(),
    })?;
    assemble(c, storage, topic)
}

/// The storage files of a ROS 2 bag directory: `relative_file_paths` from `metadata.yaml`, or
/// else every `.mcap` / `.db3` file in it, by name.
fn dir_files(dir: &Path) -> Result<Vec<std::path::PathBuf>, BagError> {
    let meta_path = dir.join("metadata.yaml");
    let file = meta_path.display().to_string();
    let text = crate::input::limits::read_settings_text(&meta_path).map_err(|source| BagError::Io {
        file: file.clone(),
        source,
    })?;
    let mut files = Vec::new();
    let mut in_list = None::<usize>;
    for (n, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        if let Some(value) = trimmed.strip_prefix("compression_format:") {
            let v = value.trim().trim_matches(['\'', '"']);
            if !v.is_empty() {
                return Err(BagError::Unsupported {
                    file: format!("{file}:{}", n + 1),
                    what: format!("compressed ROS 2 bag (compression_format: {v}); decompress it first (ros2 bag convert)"),
                });
            }
        }
        if trimmed.starts_with("relative_file_paths:") {
            in_list = Some(indent);
            continue;
        }
        if let Some(list_indent) = in_list {
            if let Some(item) = trimmed.strip_prefix("- ") {
                if indent >= list_indent {
                    let name = item.trim().trim_matches(['\'', '"']);
                    files.push(dir.join(name));
                    continue;
                }
            }
            in_list = None;
        }
    }
    if files.is_empty() {
        let mut found: Vec<_> = std::fs::read_dir(dir)
            .map_err(|source| BagError::Io {
                file: dir.display().to_string(),
                source,
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "mcap" || x == "db3"))
            .collect();
        found.sort();
        files = found;
    }
    Ok(files)
}

/// Lists a bag's topics with their message counts (reading the whole bag).
pub fn topics(bytes: &[u8], file: &str) -> Result<Vec<TopicInfo>, BagError> {
    let storage = Storage::sniff(bytes).ok_or_else(|| BagError::Corrupt {
        file: file.into(),
        at: "byte 0".into(),
        what: "not a bag: no MCAP, SQLite or ROS 1 bag magic".into(),
    })?;
    // Decode nothing: want a topic name no bag has.
    let mut c = Collector::new(file, Some("\u{0}"), false);
    scan(storage, bytes, None, file, &mut c)?;
    Ok(c.topics)
}
#[cfg(test)]
mod tests;
