//! What spincal agrees to read whole: a regular file under a stated size, checked by its
//! metadata before it is opened (opening a FIFO blocks; reading `/dev/zero` never ends).
//! Streams that are read in constant memory (`correct`'s rows, `inspect`'s passes) take any
//! size; `correct` also takes pipes and standard input.

use std::path::Path;

/// The largest recording read whole, bytes. A 4 GiB CSV is about 6·10⁷ rows (a week at 100 Hz),
/// whose chosen columns alone take about 3.4 GB; a larger file is a log of something else (a
/// bag's camera topics) or needs cutting first. `correct` and `inspect` stream text of any size.
pub const LARGEST_RECORDING_BYTES: u64 = 4 << 30;

/// The largest settings file read (a campaign file, a model file, a setup): 10,000 campaign
/// entries or a model with 10⁶ weights are a few tens of MB.
pub const LARGEST_SETTINGS_BYTES: u64 = 256 << 20;

/// Why a path is not read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InputFileError {
    #[error("is {kind}, not a regular file: spincal reads a whole file only from a regular file (only `correct` streams a pipe or standard input)")]
    NotRegular { kind: &'static str },
    #[error("is a folder, not a recording: spincal reads a folder only as a ROS 2 bag (with metadata.yaml) or a Sensor Logger recording (with Metadata.csv); name the recording's file")]
    Folder,
    #[error("is {bytes} bytes, more than the {limit} bytes spincal reads whole ({what}); cut it first (a bag: extract the IMU topic)")]
    TooLarge {
        bytes: u64,
        limit: u64,
        what: &'static str,
    },
}

impl InputFileError {
    /// As an I/O error, so that every reader's `cannot read` error names the file and this.
    pub fn into_io(self) -> std::io::Error {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, self)
    }
}

/// The kind of a non-regular, non-folder file, in words.
fn kind_of(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    let _ = file_type;
    "not a regular file"
}

/// `Ok(true)` for a folder (the caller decides whether it is one it reads), `Ok(false)` for a
/// regular file (links followed) of at most `limit` bytes when a limit is given; anything else
/// refused by name. A missing file gives the system's error.
pub fn check_file(path: &Path, limit: Option<(u64, &'static str)>) -> std::io::Result<bool> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Ok(true);
    }
    if !meta.is_file() {
        return Err(InputFileError::NotRegular {
            kind: kind_of(meta.file_type()),
        }
        .into_io());
    }
    if let Some((limit, what)) = limit {
        if meta.len() > limit {
            return Err(InputFileError::TooLarge {
                bytes: meta.len(),
                limit,
                what,
            }
            .into_io());
        }
    }
    Ok(false)
}

/// A regular file of at most `limit` bytes (`what` names the limit in a refusal); folders are
/// refused too.
pub fn check_regular(path: &Path, limit: u64, what: &'static str) -> std::io::Result<()> {
    if check_file(path, Some((limit, what)))? {
        return Err(InputFileError::Folder.into_io());
    }
    Ok(())
}

/// A path a stream may read row by row: a regular file or a FIFO (any size: the stream holds a
/// row at a time); a device or a socket is refused (`/dev/zero` is one line that never ends).
pub fn check_streamable(path: &Path) -> std::io::Result<()> {
    let meta = std::fs::metadata(path)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if meta.file_type().is_fifo() {
            return Ok(());
        }
    }
    if meta.is_file() {
        return Ok(());
    }
    if meta.is_dir() {
        return Err(InputFileError::Folder.into_io());
    }
    Err(InputFileError::NotRegular {
        kind: kind_of(meta.file_type()),
    }
    .into_io())
}

/// A settings file's text (campaign, model, setup), refused unless a regular file of at most
/// [`LARGEST_SETTINGS_BYTES`].
pub fn read_settings_text(path: &Path) -> std::io::Result<String> {
    check_regular(path, LARGEST_SETTINGS_BYTES, "a settings file's limit")?;
    std::fs::read_to_string(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_devices_and_large_files_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let e = check_regular(dir.path(), 10, "test").unwrap_err();
        assert!(e.to_string().contains("is a folder"), "{e}");
        let file = dir.path().join("a.csv");
        std::fs::write(&file, "0123456789ab").unwrap();
        let e = check_regular(&file, 10, "the test's limit").unwrap_err();
        assert_eq!(
            e.to_string(),
            "is 12 bytes, more than the 10 bytes spincal reads whole (the test's limit); cut it first (a bag: extract the IMU topic)"
        );
        check_regular(&file, 12, "test").unwrap();
        #[cfg(unix)]
        {
            let e = check_regular(Path::new("/dev/zero"), 10, "test").unwrap_err();
            assert!(
                e.to_string()
                    .starts_with("is a character device, not a regular file"),
                "{e}"
            );
        }
        let missing = check_regular(&dir.path().join("none"), 10, "test").unwrap_err();
        assert_eq!(missing.kind(), std::io::ErrorKind::NotFound);
    }
}
