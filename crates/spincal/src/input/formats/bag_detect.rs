//! What a ROS bag looks like from outside: its storage, announced by the first bytes, or a ROS 2
//! bag directory. Built without the `bags` feature too, so that a bag is still recognised and
//! refused by name rather than misread as another format.

use std::path::Path;

/// The MCAP magic at both ends of the file.
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// The first 16 bytes of every SQLite 3 database.
pub const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";
/// Every ROS 1 bag starts with this; format 2.0 continues `2.0\n`.
pub const ROS1_MAGIC_PREFIX: &[u8] = b"#ROSBAG V";

/// How a bag stores its messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// ROS 2, MCAP storage (`.mcap`).
    Mcap,
    /// ROS 2, sqlite3 storage (`.db3`).
    Sqlite3,
    /// ROS 1 bag format 2.0 (`.bag`).
    Ros1,
}

impl Storage {
    pub fn name(self) -> &'static str {
        match self {
            Storage::Mcap => "ROS 2 mcap",
            Storage::Sqlite3 => "ROS 2 sqlite3",
            Storage::Ros1 => "ROS 1 bag 2.0",
        }
    }

    /// The storage a file's first bytes announce, if any.
    pub fn sniff(head: &[u8]) -> Option<Storage> {
        if head.starts_with(MCAP_MAGIC) {
            Some(Storage::Mcap)
        } else if head.starts_with(SQLITE_MAGIC) {
            Some(Storage::Sqlite3)
        } else if head.starts_with(ROS1_MAGIC_PREFIX) {
            Some(Storage::Ros1)
        } else {
            None
        }
    }
}

/// Whether `path` is a ROS 2 bag directory (it holds `metadata.yaml`).
pub fn is_bag_dir(path: &Path) -> bool {
    path.is_dir() && path.join("metadata.yaml").is_file()
}
