//! Writing output files without losing anything.
//!
//! - [`check_outputs`] runs before any work: an output may not be one of the inputs (the same
//!   file, followed through links), and two outputs may not name the same file.
//! - [`write_file`] writes a regular file through a temporary file beside it and renames it into
//!   place only when everything was written, so a failed command leaves the old file (or no
//!   file). A symbolic link is written through to its target, and stays a link. Pipes, devices and
//!   other non-regular targets are streamed to directly and never removed. The only file this
//!   module ever removes is its own temporary file.
//!   Each regular file written is recorded, with the length and CRC-32 of the bytes written, in the
//!   hidden manifest [`MANIFEST`] of its folder.
//! - [`claim_outputs`] runs before any work too: an existing output that spincal did not write is
//!   refused unless the caller forces it, and then each one replaced is returned so the caller can
//!   say so. spincal knows a file as its own only by that recorded fingerprint (or one a spincal
//!   JSON file beside it names), never by a header, comment or mark inside it: a user's file can
//!   carry those too, and a file spincal wrote that was edited since is the user's.
//! - [`write_outputs`] checks a set of outputs and writes them all, or none.
//! - [`create_folder`] makes an output folder, refusing a path that is a file, and remembers the
//!   folders it made: [`remove_empty_created_folders`] removes those a failed command left empty.
//! - [`remove_temporaries`] removes the temporary files being written right now (a signal handler
//!   calls it before the process ends); a temporary that a killed run left (its name carries its
//!   writer's process id) is removed by the next write into its folder once that process is gone.

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
    #[error("{path}: exists and spincal did not write it ({why}); spincal does not replace it: choose another path, move the file away, or set `force` to replace it")]
    NotWrittenBySpincal { path: String, why: String },
    #[error("{path}: spincal keeps its record of the files it wrote in a folder under this name; choose another name")]
    Reserved { path: String },
    #[error("{path}: is a file, not a folder; name a folder for the outputs (it is made if missing)")]
    NotAFolder { path: String },
    #[error("{path}: cannot write: the folder {folder} does not exist; create it first or name a file in an existing folder")]
    MissingFolder { path: String, folder: String },
    #[error("{path}: cannot write: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| {
        let missing_folder = path.parent().filter(|p| !p.as_os_str().is_empty() && !p.exists());
        match missing_folder {
            Some(folder) if source.kind() == std::io::ErrorKind::NotFound => OutputError::MissingFolder {
                path: path.display().to_string(),
                folder: folder.display().to_string(),
            },
            _ => OutputError::Io {
                path: path.display().to_string(),
                source,
            },
        }
    }
}

/// What identifies a file: the device and inode where it exists (so hard and symbolic links
/// agree), else its absolute path with links in the parent resolved.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum Identity {
    Inode(u64, u64),
    Path(PathBuf),
}

pub(crate) fn identity(path: &Path) -> Identity {
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
        if is_manifest(output) {
            return Err(OutputError::Reserved {
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
/// success, then recorded with the fingerprint of what was written in the folder's [`MANIFEST`]
/// (so that a later run knows the file as spincal's); non-regular files (pipes, devices) streamed
/// to, never removed and never recorded.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    let target = write_target(path)?;
    if is_manifest(path) || is_manifest(&target) {
        return Err(OutputError::Reserved {
            path: path.display().to_string(),
        });
    }
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
    let (bytes, crc32) = replace_regular(&target, write).map_err(io_error(path))?;
    let manifest = folder_of(&target).join(MANIFEST);
    record_output(&target, bytes, crc32).map_err(io_error(&manifest))
}

/// Writes the regular file (or new file) `target` through a temporary file beside it, renamed
/// over it when `write` succeeded; returns the length and CRC-32 of what was written. Only the
/// temporary file, which this call created, is ever removed.
fn replace_regular(
    target: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<(u64, String)> {
    let dir = folder_of(target);
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    remove_stale_temporaries(&dir);
    let temporary = dir.join(format!(
        ".{name}.spincal-{}-{}.tmp",
        std::process::id(),
        TEMPORARY_COUNT.fetch_add(1, Ordering::Relaxed)
    ));
    let file = OpenOptions::new().write(true).create_new(true).open(&temporary)?;
    let _live = LiveTemporary::new(&temporary);
    let written = (|| {
        let mut out = Checksumming {
            inner: BufWriter::new(file),
            hasher: crc32fast::Hasher::new(),
            bytes: 0,
        };
        write(&mut out)?;
        let print = (out.bytes, crc_text(out.hasher.finalize()));
        let file = out.inner.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        keep_permissions(target, &file);
        std::fs::rename(&temporary, target)?;
        Ok(print)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    written
}

/// The temporary files being written now, removed by [`remove_temporaries`].
static LIVE_TEMPORARIES: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// A temporary file listed in [`LIVE_TEMPORARIES`] while it exists.
struct LiveTemporary(PathBuf);

impl LiveTemporary {
    fn new(path: &Path) -> LiveTemporary {
        if let Ok(mut live) = LIVE_TEMPORARIES.lock() {
            live.push(path.to_path_buf());
        }
        LiveTemporary(path.to_path_buf())
    }
}

impl Drop for LiveTemporary {
    fn drop(&mut self) {
        if let Ok(mut live) = LIVE_TEMPORARIES.lock() {
            live.retain(|p| *p != self.0);
        }
    }
}

/// Removes every temporary file [`write_file`] is writing now (they are its own, made with
/// `create_new`), and returns them. For a process that is being interrupted: nothing else is
/// removed, and the files being replaced stay as they were.
pub fn remove_temporaries() -> Vec<PathBuf> {
    let live = match LIVE_TEMPORARIES.lock() {
        Ok(mut live) => std::mem::take(&mut *live),
        Err(poisoned) => std::mem::take(&mut *poisoned.into_inner()),
    };
    for path in &live {
        let _ = std::fs::remove_file(path);
    }
    live
}

/// The process id in the name of a temporary file [`replace_regular`] makes
/// (`.<name>.spincal-<pid>-<count>.tmp`), or `None` for any other name.
fn temporary_writer(file_name: &str) -> Option<u32> {
    let stem = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (_, ids) = stem.rsplit_once(".spincal-")?;
    let (pid, count) = ids.split_once('-')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (digits(pid) && digits(count)).then(|| pid.parse().ok()).flatten()
}

/// Whether no process `pid` exists (unix: `kill(pid, 0)` fails with ESRCH). A process that
/// exists but is another user's (EPERM), or any doubt, counts as alive.
#[cfg(unix)]
fn writer_is_gone(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if pid <= 0 {
        return false;
    }
    // SAFETY: signal 0 only checks that the process exists; nothing is sent.
    let result = unsafe { libc::kill(pid, 0) };
    result != 0 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
}

/// Folders already swept for stale temporaries by this process.
static SWEPT_FOLDERS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Removes, once per folder and process, the temporary files an earlier spincal left in `dir`
/// when it was killed without a chance to clean up (SIGKILL, a power cut): only regular files
/// (not links) owned by this user, named as [`replace_regular`] names them, whose writer's
/// process no longer exists. Nobody else's file has that name, owner and a dead writer; a
/// temporary of a live spincal (another run writing there now) is left alone. Elsewhere than
/// unix no process can be asked about, so nothing is removed.
fn remove_stale_temporaries(dir: &Path) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let key = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
        {
            let mut swept = SWEPT_FOLDERS.lock().unwrap_or_else(|p| p.into_inner());
            if swept.contains(&key) {
                return;
            }
            swept.push(key);
        }
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        // SAFETY: geteuid has no preconditions.
        let me = unsafe { libc::geteuid() };
        for entry in entries.flatten() {
            let name = entry.file_name();
            let Some(pid) = name.to_str().and_then(temporary_writer) else {
                continue;
            };
            let Ok(meta) = entry.path().symlink_metadata() else {
                continue;
            };
            if meta.is_file() && meta.uid() == me && pid != std::process::id() && writer_is_gone(pid) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// Makes the output folder `path` (and its parents); a path that exists as a file is refused by
/// name rather than with the system's "File exists".
pub fn create_folder(path: &Path) -> Result<(), OutputError> {
    if let Ok(meta) = std::fs::metadata(path) {
        if !meta.is_dir() {
            return Err(OutputError::NotAFolder {
                path: path.display().to_string(),
            });
        }
        return Ok(());
    }
    make_folders(path).map_err(io_error(path))
}

/// The folders this process created ([`make_folders`]), parents first.
static CREATED_FOLDERS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// `create_dir_all` that remembers each folder it created, so that one left empty by a failure
/// can be removed ([`remove_empty_created_folders`]).
pub(crate) fn make_folders(path: &Path) -> std::io::Result<()> {
    let missing: Vec<&Path> = path
        .ancestors()
        .filter(|p| !p.as_os_str().is_empty())
        .take_while(|p| std::fs::symlink_metadata(p).is_err())
        .collect();
    for folder in missing.into_iter().rev() {
        match std::fs::create_dir(folder) {
            Ok(()) => {
                let absolute = std::path::absolute(folder).unwrap_or_else(|_| folder.to_path_buf());
                CREATED_FOLDERS
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push(absolute);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && folder.is_dir() => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Removes each folder this process created that is still empty, deepest first, and returns
/// them: what a command that failed early leaves behind. `remove_dir` removes only an empty
/// folder, so nothing written into one (by spincal or anyone) is ever lost.
pub fn remove_empty_created_folders() -> Vec<PathBuf> {
    let created = std::mem::take(&mut *CREATED_FOLDERS.lock().unwrap_or_else(|p| p.into_inner()));
    let mut removed = Vec::new();
    for folder in created.into_iter().rev() {
        if std::fs::remove_dir(&folder).is_ok() {
            removed.push(folder);
        }
    }
    removed
}

/// A file's length and FNV-1a 64-bit hash (hex): how a spincal JSON file names a file written
/// beside it (a sweep's `outputs` list; a simulation's truth, its recording).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Fingerprint {
    pub bytes: u64,
    pub fnv1a64: String,
}

/// A file spincal wrote and its fingerprint, as a spincal JSON file's `outputs` list names it.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct NamedFingerprint {
    /// The file's name (no folder).
    pub file: String,
    #[serde(flatten)]
    pub fingerprint: Fingerprint,
}

/// The fingerprints of files just written, for a JSON file's `outputs` list.
pub fn named_fingerprints(paths: &[&Path]) -> std::io::Result<Vec<NamedFingerprint>> {
    paths
        .iter()
        .map(|p| {
            Ok(NamedFingerprint {
                file: p
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                fingerprint: fingerprint(p)?,
            })
        })
        .collect()
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// FNV-1a 64 of `bytes`, continuing from `hash`.
fn fnv1a(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(FNV_PRIME);
    }
    hash
}

impl Fingerprint {
    fn new(bytes: u64, hash: u64) -> Fingerprint {
        Fingerprint {
            bytes,
            fnv1a64: format!("{hash:016x}"),
        }
    }
}

/// The fingerprint of the file at `path`, read in pieces.
pub(crate) fn fingerprint(path: &Path) -> std::io::Result<Fingerprint> {
    let mut hash = FNV_OFFSET;
    let bytes = read_in_pieces(path, |piece| hash = fnv1a(hash, piece))?;
    Ok(Fingerprint::new(bytes, hash))
}

/// Feeds the file at `path` to `take` in pieces of 64 KiB; returns its length.
fn read_in_pieces(path: &Path, mut take: impl FnMut(&[u8])) -> std::io::Result<u64> {
    use std::io::Read;
    let mut file = File::open(path)?;
    let mut bytes = 0u64;
    let mut buffer = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buffer)?;
        if n == 0 {
            return Ok(bytes);
        }
        bytes += n as u64;
        take(&buffer[..n]);
    }
}

/// What a manifest records of a file spincal wrote: its name (no folder), length and CRC-32
/// (IEEE, as zip and PNG use it; hex). CRC-32 rather than FNV-1a because it is computed as every
/// output is written, and SIMD CRC-32 costs `correct` a few per cent where FNV-1a, byte by byte,
/// costs about a quarter of its throughput (measured); against an accidental edit of the same
/// length, 32 bits suffice.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
struct Recorded {
    file: String,
    bytes: u64,
    crc32: String,
}

/// A CRC-32 as the manifest writes it: 8 hex digits.
fn crc_text(crc: u32) -> String {
    format!("{crc:08x}")
}

/// The length and CRC-32 of the file at `path`, read in pieces.
fn crc_of(path: &Path) -> std::io::Result<(u64, String)> {
    let mut hasher = crc32fast::Hasher::new();
    let bytes = read_in_pieces(path, |piece| hasher.update(piece))?;
    Ok((bytes, crc_text(hasher.finalize())))
}

/// A writer that checksums what it passes on, so that a file is not read again to be recorded.
struct Checksumming<W> {
    inner: W,
    hasher: crc32fast::Hasher,
    bytes: u64,
}

impl<W: Write> Write for Checksumming<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// The hidden file in every folder spincal writes a file into, naming each file it wrote there
/// with the length and CRC-32 of what it wrote: `{"spincal_version": …, "outputs": [{"file",
/// "bytes", "crc32"}, …]}`. A later run replaces a file without `force` only while the manifest beside
/// it names it with its current content; no header, comment or mark inside a file counts, since a
/// user's file can carry those too.
pub const MANIFEST: &str = ".spincal-outputs.json";

/// Whether `path` names a manifest, which no command may name as an output.
fn is_manifest(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n == MANIFEST)
}

/// The largest manifest read; a larger one is not spincal's.
const LARGEST_MANIFEST: u64 = 64 << 20;

/// A folder's manifest.
#[derive(serde::Serialize, serde::Deserialize)]
struct Manifest {
    spincal_version: String,
    outputs: Vec<Recorded>,
}

/// What a folder holds under [`MANIFEST`].
enum ManifestState {
    Absent,
    Ours(Manifest),
    /// Not a regular file, unreadable, or not a manifest: neither trusted nor overwritten.
    Foreign,
}

fn read_manifest(folder: &Path) -> ManifestState {
    let path = folder.join(MANIFEST);
    match std::fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => ManifestState::Absent,
        Ok(meta) if meta.is_file() && meta.len() <= LARGEST_MANIFEST => std::fs::read(&path)
            .ok()
            .and_then(|text| serde_json::from_slice::<Manifest>(&text).ok())
            .map_or(ManifestState::Foreign, ManifestState::Ours),
        _ => ManifestState::Foreign,
    }
}

/// The folder a file is in (`.` for a bare name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Serialises changes to manifests within the process (threads writing into one folder).
/// Two processes writing into one folder at once may lose an entry: the file is then refused
/// later, never lost.
static MANIFEST_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Changes the manifest of `folder` with `change`, dropping entries of files that are gone, and
/// writes it through a temporary file. A manifest that is not spincal's is left as it is.
fn update_manifest(folder: &Path, change: impl FnOnce(&mut Vec<Recorded>)) -> std::io::Result<()> {
    let _guard = MANIFEST_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let (mut outputs, existed) = match read_manifest(folder) {
        ManifestState::Absent => (Vec::new(), false),
        ManifestState::Ours(manifest) => (manifest.outputs, true),
        ManifestState::Foreign => return Ok(()),
    };
    change(&mut outputs);
    outputs.retain(|e| std::fs::symlink_metadata(folder.join(&e.file)).is_ok());
    if outputs.is_empty() && !existed {
        return Ok(());
    }
    outputs.sort_by(|a, b| a.file.cmp(&b.file));
    outputs.dedup_by(|a, b| a.file == b.file);
    let manifest = Manifest {
        spincal_version: env!("CARGO_PKG_VERSION").to_string(),
        outputs,
    };
    let text = serde_json::to_string_pretty(&manifest).map_err(std::io::Error::other)? + "\n";
    replace_regular(&folder.join(MANIFEST), |out| out.write_all(text.as_bytes())).map(|_| ())
}

/// Records in its folder's manifest that spincal wrote `bytes` bytes of CRC-32 `crc32` to the
/// regular file `target`.
fn record_output(target: &Path, bytes: u64, crc32: String) -> std::io::Result<()> {
    // A name the manifest cannot hold exactly is not recorded (and so is refused later).
    let Some(name) = target.file_name().and_then(|n| n.to_str()) else {
        return Ok(());
    };
    update_manifest(&folder_of(target), |outputs| {
        outputs.retain(|e| e.file != name);
        outputs.push(Recorded {
            file: name.to_string(),
            bytes,
            crc32,
        });
    })
}

/// The largest JSON file read for the fingerprints it names.
const LARGEST_JSON_CHECKED: u64 = 512 << 20;

/// The top-level JSON object in `path`, if the file is one.
fn json_object(path: &Path) -> Option<serde_json::Map<String, serde_json::Value>> {
    let meta = std::fs::metadata(path).ok()?;
    // A pipe or device named as an output is never read: it could block or never end.
    if !meta.is_file() || meta.len() > LARGEST_JSON_CHECKED {
        return None;
    }
    let text = std::fs::read(path).ok()?;
    match serde_json::from_slice::<serde_json::Value>(&text).ok()? {
        serde_json::Value::Object(map) => Some(map),
        _ => None,
    }
}

/// The fingerprint a spincal JSON file (`claimer`, with a `spincal_version` field) names for the
/// file called `name`, in a `recording` field (a simulation's truth) or an `outputs` list (a
/// sweep's table and heat maps); `Some(None)` when the entry is there but unreadable.
fn claim_of(claimer: &Path, name: &str) -> Option<Option<Fingerprint>> {
    let map = json_object(claimer)?;
    if !map.get("spincal_version").is_some_and(|v| v.is_string()) {
        return None;
    }
    let listed = map.get("outputs").and_then(|o| o.as_array());
    let entry = map
        .get("recording")
        .into_iter()
        .chain(listed.into_iter().flatten())
        .find(|e| e.get("file").and_then(|f| f.as_str()) == Some(name))?;
    Some(serde_json::from_value::<Fingerprint>(entry.clone()).ok())
}

/// Whether the file at `path` has the content `claimed`.
fn has_content(path: &Path, claimed: &Fingerprint) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.len() == claimed.bytes)
        && fingerprint(path).is_ok_and(|f| f == *claimed)
}

/// Whether spincal wrote the regular file `path` (through a link: its target), judged only by a
/// fingerprint of its content that spincal recorded when it wrote it: in the manifest of the
/// file's folder ([`MANIFEST`]), or, for files written before manifests, in a spincal JSON file
/// among `companions` (or `<stem>.truth.json` beside it) that names it in a `recording` field or an
/// `outputs` list. Nothing inside the file counts. `Err` says why it is not known as spincal's.
pub(crate) fn written_by_spincal(path: &Path, companions: &[&Path]) -> Result<(), String> {
    let target = write_target(path).map_err(|e| e.to_string())?;
    let Some(name) = target.file_name().and_then(|n| n.to_str()) else {
        return Err("its name is not UTF-8, so spincal keeps no record of it".into());
    };
    let size = std::fs::metadata(&target).map(|m| m.len()).ok();
    let state = read_manifest(&folder_of(&target));
    let mut named = false;
    if let ManifestState::Ours(manifest) = &state {
        for entry in manifest.outputs.iter().filter(|e| e.file == name) {
            named = true;
            let same = size == Some(entry.bytes) && crc_of(&target).is_ok_and(|(_, crc)| crc == entry.crc32);
            if same {
                return Ok(());
            }
        }
    }
    let beside = path.with_extension("truth.json");
    let claims = companions
        .iter()
        .copied()
        .chain(std::iter::once(beside.as_path()))
        .filter(|c| identity(c) != identity(path))
        .filter_map(|c| claim_of(c, name));
    for claimed in claims {
        named = true;
        if claimed.is_some_and(|c| has_content(&target, &c)) {
            return Ok(());
        }
    }
    Err(if named {
        "it changed since spincal wrote it".to_string()
    } else if matches!(state, ManifestState::Foreign) {
        format!("{MANIFEST} beside it is not spincal's record of its outputs")
    } else {
        format!("spincal's record of what it wrote there ({MANIFEST}) does not name it")
    })
}

/// An existing output that spincal did not write, replaced because the caller forced it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Replaced {
    pub path: PathBuf,
}

/// Checks, before any work, that writing `outputs` loses nothing: each one must be absent, empty,
/// not a regular file (a pipe or device is streamed to), or written by spincal with the content it
/// has now (`written_by_spincal`: its folder's [`MANIFEST`] names it with its fingerprint; the
/// other outputs are companions that may name it too). Any other existing file is refused by
/// name, unless `force`: then it is returned so the caller can say it is replaced.
pub fn claim_outputs(outputs: &[&Path], force: bool) -> Result<Vec<Replaced>, OutputError> {
    let mut replaced = Vec::new();
    for &output in outputs.iter().filter(|p| !is_stdio(p)) {
        let Ok(meta) = std::fs::metadata(output) else {
            continue;
        };
        if !meta.is_file() || meta.len() == 0 {
            continue;
        }
        let Err(why) = written_by_spincal(output, outputs) else {
            continue;
        };
        if !force {
            return Err(OutputError::NotWrittenBySpincal {
                path: output.display().to_string(),
                why,
            });
        }
        replaced.push(Replaced {
            path: output.to_path_buf(),
        });
    }
    Ok(replaced)
}

/// Writes every one of `files` (path, content) after checking them all first, so that a refusal
/// writes nothing: none may be one of `inputs` or collide with another ([`check_outputs`]), and
/// each existing one must be spincal's ([`claim_outputs`], which returns those replaced because
/// of `force`). Missing folders are made; each file goes through [`write_bytes`] and so is
/// recorded in its folder's [`MANIFEST`]. For front ends that hold a set of outputs as text
/// (Python's `Calibration.write`).
pub fn write_outputs(
    inputs: &[&Path],
    files: &[(&Path, &[u8])],
    force: bool,
) -> Result<Vec<Replaced>, OutputError> {
    let paths: Vec<&Path> = files.iter().map(|(p, _)| *p).collect();
    check_outputs(inputs, &paths)?;
    let replaced = claim_outputs(&paths, force)?;
    for (path, bytes) in files {
        create_folder(&folder_of(path))?;
        write_bytes(path, bytes)?;
    }
    Ok(replaced)
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
        // The moved file is still the content spincal wrote: its record follows it.
        let to_name = to
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        update_manifest(folder, |outputs| {
            for e in outputs.iter_mut().filter(|e| e.file == *name) {
                e.file = to_name.clone();
            }
        })?;
        moved.push((from, to));
    }
    Ok(moved)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names in `dir` other than the manifest, sorted.
    fn listing(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != MANIFEST)
            .collect();
        names.sort();
        names
    }

    #[test]
    fn replaces_a_file_atomically_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        std::fs::write(&path, "old").unwrap();
        write_bytes(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(listing(dir.path()), ["out.csv"]);
    }

    #[test]
    fn a_missing_folder_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("absent").join("cal.json");
        let e = write_bytes(&path, b"{}").unwrap_err().to_string();
        assert!(
            e.contains("the folder") && e.contains("absent") && e.contains("does not exist"),
            "{e}"
        );
        assert!(!dir.path().join("absent").exists());
    }

    /// Only a name `.<name>.spincal-<pid>-<n>.tmp` is a temporary's; only a gone writer's is removed.
    #[cfg(unix)]
    #[test]
    fn stale_temporaries_of_gone_writers_are_removed_and_nothing_else() {
        assert_eq!(temporary_writer(".a.csv.spincal-123-4.tmp"), Some(123));
        assert_eq!(temporary_writer(".a.spincal-x.csv.spincal-7-0.tmp"), Some(7));
        for other in [
            "a.csv.spincal-123-4.tmp",
            ".a.csv.spincal-123-4.tmp.bak",
            ".a.csv.spincal-123.tmp",
            ".a.csv.spincal--4.tmp",
            ".a.csv.spincal-12a-4.tmp",
        ] {
            assert_eq!(temporary_writer(other), None, "{other}");
        }
        let dir = tempfile::tempdir().unwrap();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let gone = child.id();
        child.wait().unwrap();
        let stale = dir.path().join(format!(".r.csv.spincal-{gone}-0.tmp"));
        let live = dir
            .path()
            .join(format!(".r.csv.spincal-{}-0.tmp", std::process::id()));
        let parent = dir.path().join(format!(
            ".r.csv.spincal-{}-0.tmp",
            std::os::unix::process::parent_id()
        ));
        let linked = dir.path().join(format!(".l.csv.spincal-{gone}-1.tmp"));
        for path in [&stale, &live, &parent] {
            std::fs::write(path, "x").unwrap();
        }
        std::os::unix::fs::symlink(&live, &linked).unwrap();
        write_bytes(&dir.path().join("r.csv"), b"new").unwrap();
        assert!(!stale.exists());
        assert!(live.exists() && parent.exists() && linked.symlink_metadata().is_ok());
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
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary, no manifest"
        );
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

    /// The bytes of every file in `dir`, the manifest included, by name.
    fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (
                    e.file_name().to_string_lossy().into_owned(),
                    std::fs::read(e.path()).unwrap(),
                )
            })
            .collect();
        files.sort();
        files
    }

    #[test]
    fn only_what_spincal_recorded_writing_is_claimed_and_force_names_the_others() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        // spincal's own files of every kind, written through write_bytes: recorded.
        for (name, text) in [
            ("model.json", r#"{"format_version": 1, "spincal_version": "0.1"}"#),
            (
                "report.html",
                "<html><head><meta name=\"generator\" content=\"spincal\"></head>",
            ),
            ("rec.csv", "t_s,ax_g,ay_g,az_g\n0,0,0,1\n"),
            ("imu.h", "/* spincal */\n#define A 1\n"),
        ] {
            write_bytes(&path(name), text.as_bytes()).unwrap();
        }
        std::fs::write(path("empty.csv"), "").unwrap();
        for ours in [
            "model.json",
            "report.html",
            "rec.csv",
            "imu.h",
            "empty.csv",
            "missing.csv",
        ] {
            assert!(claim_outputs(&[&path(ours)], false).unwrap().is_empty(), "{ours}");
        }
        // A user's files that look like spincal's from the inside: its version field, generator
        // mark, recording header, `correct`'s header, a comment naming it.
        let theirs = [
            (
                "theirs.json",
                r#"{"format_version": 1, "spincal_version": "0.1"}"#,
            ),
            (
                "notes.html",
                "<html><head><meta name=\"generator\" content=\"spincal\"></head>",
            ),
            ("logger.csv", "t_s,ax_g,ay_g,az_g\n0,0,0,1\n"),
            (
                "fixed.csv",
                "t,ax,ay,az,ax_corrected,valid,status\n0,0,0,1,0,1,ok\n",
            ),
            ("mine.h", "/* spincal */\n#define A 2\n"),
            ("cal.txt", "# spincal static calibration\n1 2 3\n"),
        ];
        for (name, text) in theirs {
            std::fs::write(path(name), text).unwrap();
        }
        let before = contents(dir.path());
        for (name, _) in theirs {
            let err = claim_outputs(&[&path(name)], false).unwrap_err();
            assert!(matches!(err, OutputError::NotWrittenBySpincal { .. }), "{err}");
            assert!(
                err.to_string().contains(name) && err.to_string().contains(MANIFEST),
                "{err}"
            );
            let replaced = claim_outputs(&[&path(name)], true).unwrap();
            assert_eq!(replaced, [Replaced { path: path(name) }]);
        }
        assert_eq!(contents(dir.path()), before, "claims change nothing");
        // A recording of spincal's edited by hand is the user's.
        std::fs::write(path("rec.csv"), "t_s,ax_g,ay_g,az_g\n0,0,0,2\n").unwrap();
        let err = claim_outputs(&[&path("rec.csv")], false).unwrap_err();
        assert!(
            err.to_string().contains("changed since spincal wrote it"),
            "{err}"
        );
        // The manifest names each file spincal wrote with what it wrote, and only those.
        let manifest: serde_json::Value =
            serde_json::from_slice(&std::fs::read(path(MANIFEST)).unwrap()).unwrap();
        let named: Vec<&str> = manifest["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["file"].as_str().unwrap())
            .collect();
        assert_eq!(named, ["imu.h", "model.json", "rec.csv", "report.html"]);
        let model = std::fs::read(path("model.json")).unwrap();
        let crc = format!("{:08x}", crc32fast::hash(&model));
        assert_eq!(manifest["outputs"][1]["crc32"], crc.as_str());
        assert_eq!(manifest["outputs"][1]["bytes"], model.len());
        assert!(manifest["spincal_version"].is_string());
    }

    #[test]
    fn a_simulated_recording_named_by_its_truth_is_claimed_while_unchanged() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        std::fs::write(path("rec.csv"), "t_s,ax_g\n0,1\n").unwrap();
        let print = fingerprint(&path("rec.csv")).unwrap();
        let truth = serde_json::json!({
            "spincal_version": "0.1",
            "recording": {"file": "rec.csv", "bytes": print.bytes, "fnv1a64": print.fnv1a64},
        });
        std::fs::write(path("rec.truth.json"), truth.to_string()).unwrap();
        assert!(claim_outputs(&[&path("rec.csv")], false).unwrap().is_empty());
        std::fs::write(path("rec.csv"), "t_s,ax_g\n0,2\n").unwrap();
        assert!(claim_outputs(&[&path("rec.csv")], false).is_err());
        assert_eq!(
            std::fs::read_to_string(path("rec.csv")).unwrap(),
            "t_s,ax_g\n0,2\n"
        );
    }

    #[test]
    fn a_manifest_that_is_not_spincals_is_neither_trusted_nor_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        std::fs::write(path("data.csv"), "1,2,3\n").unwrap();
        let print = crc_of(&path("data.csv")).unwrap();
        // Valid JSON naming the file, but not a manifest spincal writes (no version).
        let foreign = serde_json::json!({"outputs": [
            {"file": "data.csv", "bytes": print.0, "crc32": print.1}
        ]})
        .to_string();
        std::fs::write(path(MANIFEST), &foreign).unwrap();
        let err = claim_outputs(&[&path("data.csv")], false).unwrap_err();
        assert!(err.to_string().contains("not spincal's record"), "{err}");
        write_bytes(&path("out.csv"), b"x\n").unwrap();
        assert_eq!(std::fs::read_to_string(path(MANIFEST)).unwrap(), foreign);
        assert!(
            claim_outputs(&[&path("out.csv")], false).is_err(),
            "not recorded, so not claimed"
        );
        // Not JSON at all.
        std::fs::write(path(MANIFEST), "my notes").unwrap();
        write_bytes(&path("out.csv"), b"y\n").unwrap();
        assert_eq!(std::fs::read_to_string(path(MANIFEST)).unwrap(), "my notes");
        // No command may name the manifest as its output.
        for target in [path(MANIFEST), dir.path().join("sub").join(MANIFEST)] {
            let err = check_outputs(&[], &[&target]).unwrap_err();
            assert!(matches!(err, OutputError::Reserved { .. }), "{err}");
            assert!(matches!(
                write_bytes(&target, b"{}"),
                Err(OutputError::Reserved { .. })
            ));
        }
        assert_eq!(std::fs::read_to_string(path(MANIFEST)).unwrap(), "my notes");
    }

    #[test]
    fn a_file_set_aside_keeps_its_record_and_gone_files_lose_theirs() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        write_bytes(&path("model.json"), b"{}\n").unwrap();
        write_bytes(&path("results.json"), b"[]\n").unwrap();
        write_bytes(&path("gone.csv"), b"1\n").unwrap();
        std::fs::remove_file(path("gone.csv")).unwrap();
        let moved = set_aside_stale(dir.path(), &["model.json", "results.json"], &["results.json"]).unwrap();
        assert_eq!(moved, [(path("model.json"), path("model.json.stale"))]);
        let manifest = std::fs::read_to_string(path(MANIFEST)).unwrap();
        assert!(
            manifest.contains("model.json.stale") && !manifest.contains("gone.csv"),
            "{manifest}"
        );
        assert!(
            claim_outputs(&[&path("model.json.stale"), &path("results.json")], false)
                .unwrap()
                .is_empty()
        );
        // A file of the same name the user puts there later is theirs.
        std::fs::write(path("model.json"), "{}\n").unwrap();
        assert!(claim_outputs(&[&path("model.json")], false).is_err());
    }

    #[test]
    fn write_outputs_writes_all_or_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("cal");
        let a = out.join("a.json");
        let b = out.join("b.csv");
        write_outputs(&[], &[(&a, b"1\n"), (&b, b"2\n")], false).unwrap();
        // Again into its own files: fine.
        write_outputs(&[], &[(&a, b"3\n"), (&b, b"4\n")], false).unwrap();
        std::fs::write(&b, "mine\n").unwrap();
        let err = write_outputs(&[], &[(&a, b"5\n"), (&b, b"6\n")], false).unwrap_err();
        assert!(err.to_string().contains("b.csv"), "{err}");
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "3\n", "nothing written");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "mine\n");
        let replaced = write_outputs(&[], &[(&a, b"5\n"), (&b, b"6\n")], true).unwrap();
        assert_eq!(replaced, [Replaced { path: b.clone() }]);
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "6\n");
    }

    #[test]
    fn an_output_folder_that_is_a_file_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("out");
        std::fs::write(&file, "keep").unwrap();
        let err = create_folder(&file).unwrap_err();
        assert!(matches!(err, OutputError::NotAFolder { .. }), "{err}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep");
        create_folder(&dir.path().join("a/b")).unwrap();
        assert!(dir.path().join("a/b").is_dir());
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
