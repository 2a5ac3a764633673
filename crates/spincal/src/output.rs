//! Writing output files without losing anything.
//!
//! - [`check_outputs`] runs before any work: an output may not be one of the inputs (the same
//!   file, followed through links), and two outputs may not name the same file.
//! - [`write_file`] writes a regular file through a temporary file beside it and renames it into
//!   place only when everything was written, so a failed command leaves the old file (or no
//!   file). A symbolic link is written through to its target, and stays a link. Pipes, devices and
//!   other non-regular targets are streamed to directly and never removed. The only file this
//!   module ever removes is its own temporary file.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// What can stop an output.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    #[error("{output}: this output is also an input ({input}); choose another output path")]
    SameAsInput { output: String, input: String },
    #[error("{first} and {second}: two outputs name the same file; choose distinct paths")]
    Collision { first: String, second: String },
    #[error("{path}: is a directory, not a file")]
    Directory { path: String },
    #[error("{path}: a symbolic link to a missing file ({target}); remove the link or name another output")]
    DanglingLink { path: String, target: String },
    #[error("{path}: cannot write: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// What identifies a file: the device and inode where it exists (so hard and symbolic links
/// agree), else its absolute path with links in the parent resolved.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Identity {
    Inode(u64, u64),
    Path(PathBuf),
}

fn identity(path: &Path) -> Identity {
    #[cfg(unix)]
    if let Ok(meta) = std::fs::metadata(path) {
        use std::os::unix::fs::MetadataExt;
        return Identity::Inode(meta.dev(), meta.ino());
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let resolved = match (absolute.parent(), absolute.file_name()) {
        (Some(parent), Some(name)) => std::fs::canonicalize(parent)
            .map(|p| p.join(name))
            .unwrap_or(absolute.clone()),
        _ => absolute,
    };
    Identity::Path(resolved)
}

/// Whether `path` means standard input or output.
pub fn is_stdio(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Refuses outputs that are inputs or that collide with each other. Call it before any work.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<(), OutputError> {
    let inputs: Vec<(&Path, Identity)> = inputs
        .iter()
        .filter(|p| !is_stdio(p))
        .map(|p| (*p, identity(p)))
        .collect();
    let mut seen: Vec<(&Path, Identity)> = Vec::new();
    for output in outputs.iter().copied().filter(|p| !is_stdio(p)) {
        if output.is_dir() {
            return Err(OutputError::Directory {
                path: output.display().to_string(),
            });
        }
        let id = identity(output);
        if let Some((input, _)) = inputs.iter().find(|(_, other)| *other == id) {
            return Err(OutputError::SameAsInput {
                output: output.display().to_string(),
                input: input.display().to_string(),
            });
        }
        if let Some((first, _)) = seen.iter().find(|(_, other)| *other == id) {
            return Err(OutputError::Collision {
                first: first.display().to_string(),
                second: output.display().to_string(),
            });
        }
        seen.push((output, id));
    }
    Ok(())
}

/// The file a write to `path` lands in: a symbolic link's target, else `path`.
fn write_target(path: &Path) -> Result<PathBuf, OutputError> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_symlink() => {
            std::fs::canonicalize(path).map_err(|_| OutputError::DanglingLink {
                path: path.display().to_string(),
                target: std::fs::read_link(path)
                    .map(|t| t.display().to_string())
                    .unwrap_or_default(),
            })
        }
        _ => Ok(path.to_path_buf()),
    }
}

static TEMPORARY_COUNT: AtomicUsize = AtomicUsize::new(0);

/// Writes `path` with `write`: regular files through a temporary file renamed into place on
/// success; non-regular files (pipes, devices) streamed to and never removed.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    let target = write_target(path)?;
    if let Ok(meta) = std::fs::metadata(&target) {
        if meta.is_dir() {
            return Err(OutputError::Directory {
                path: path.display().to_string(),
            });
        }
        if !meta.is_file() {
            let file = OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(io_error(path))?;
            let mut out = BufWriter::new(file);
            return write(&mut out).and_then(|_| out.flush()).map_err(io_error(path));
        }
    }
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let temporary = dir.join(format!(
        ".{name}.spincal-{}-{}.tmp",
        std::process::id(),
        TEMPORARY_COUNT.fetch_add(1, Ordering::Relaxed)
    ));
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temporary)
        .map_err(io_error(path))?;
    let written = (|| {
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        keep_permissions(&target, &file);
        std::fs::rename(&temporary, &target)
    })();
    if let Err(source) = written {
        // Only the temporary file, which this call created, is ever removed.
        let _ = std::fs::remove_file(&temporary);
        return Err(OutputError::Io {
            path: path.display().to_string(),
            source,
        });
    }
    Ok(())
}

/// A replaced file keeps its permissions.
fn keep_permissions(target: &Path, temporary: &File) {
    if let Ok(meta) = std::fs::metadata(target) {
        let _ = temporary.set_permissions(meta.permissions());
    }
}

/// Writes `bytes` to `path` through [`write_file`].
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_file(path, |out| out.write_all(bytes))
}

/// Moves the files `names` in `folder` that this run does not write (`written`) aside, to
/// `<name>.stale` (or `<name>.stale-2`, … when taken), so that a folder never holds a model or an
/// export beside results that contradict it. Returns each move (from, to).
pub fn set_aside_stale(
    folder: &Path,
    names: &[&str],
    written: &[&str],
) -> std::io::Result<Vec<(std::path::PathBuf, std::path::PathBuf)>> {
    let mut moved = Vec::new();
    for name in names.iter().filter(|n| !written.contains(n)) {
        let from = folder.join(name);
        if !from.is_file() {
            continue;
        }
        let mut to = folder.join(format!("{name}.stale"));
        let mut k = 2;
        while to.exists() {
            to = folder.join(format!("{name}.stale-{k}"));
            k += 1;
        }
        std::fs::rename(&from, &to)?;
        moved.push((from, to));
    }
    Ok(moved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_a_file_atomically_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        std::fs::write(&path, "old").unwrap();
        write_bytes(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_failed_write_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        std::fs::write(&path, "old").unwrap();
        let err = write_file(&path, |out| {
            out.write_all(b"partial")?;
            Err(std::io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("disk on fire"), "{err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn a_link_is_written_through_and_stays_a_link() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("real.csv");
        let link = dir.path().join("link.csv");
        std::fs::write(&target, "old").unwrap();
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_bytes(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        // The link is the input's identity too.
        let err = check_outputs(&[&target], &[&link]).unwrap_err();
        assert!(matches!(err, OutputError::SameAsInput { .. }), "{err}");
    }

    #[test]
    fn outputs_that_are_inputs_or_collide_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        std::fs::write(&input, "data").unwrap();
        let same = dir.path().join(".").join("in.csv");
        assert!(matches!(
            check_outputs(&[&input], &[&same]),
            Err(OutputError::SameAsInput { .. })
        ));
        let a = dir.path().join("a.json");
        let a_again = dir.path().join("sub/../a.json");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        assert!(matches!(
            check_outputs(&[&input], &[&a, &a_again]),
            Err(OutputError::Collision { .. })
        ));
        assert!(check_outputs(&[&input], &[&a, Path::new("-")]).is_ok());
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "data");
    }

    #[cfg(unix)]
    #[test]
    fn a_device_is_streamed_to_and_never_removed() {
        let null = Path::new("/dev/null");
        if !null.exists() {
            return;
        }
        write_bytes(null, b"anything").unwrap();
        assert!(null.exists());
        let full = Path::new("/dev/full");
        if full.exists() {
            assert!(write_bytes(full, b"anything").is_err());
            assert!(full.exists());
        }
    }
}
