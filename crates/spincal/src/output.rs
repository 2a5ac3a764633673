//! Writing output files without losing anything.
//!
//! - [`check_outputs`] runs before any work: an output may not be one of the inputs (the same
//!   file, followed through links), and two outputs may not name the same file.
//! - [`write_file`] writes a regular file through a temporary file beside it and renames it into
//!   place only when everything was written, so a failed command leaves the old file (or no
//!   file). A symbolic link is written through to its target, and stays a link. Pipes, devices and
//!   other non-regular targets are streamed to directly and never removed. The only file this
//!   module ever removes is its own temporary file.
//! - [`claim_outputs`] runs before any work too: an existing output that spincal did not write
//!   (recognised by its content, `written_by_spincal`) is refused unless the caller forces it,
//!   and then each one replaced is returned so the caller can say so.
//! - [`create_folder`] makes an output folder, refusing a path that is a file.
//! - [`remove_temporaries`] removes the temporary files being written right now (a signal handler
//!   calls it before the process ends).

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
    #[error("{path}: is a file, not a folder; name a folder for the outputs (it is made if missing)")]
    NotAFolder { path: String },
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
    let _live = LiveTemporary::new(&temporary);
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
    std::fs::create_dir_all(path).map_err(io_error(path))
}

/// The mark spincal's HTML reports carry in their head.
pub(crate) const HTML_GENERATOR: &str = "<meta name=\"generator\" content=\"spincal\">";

/// A file's length and FNV-1a 64-bit hash (hex): how a spincal JSON file names a file it was
/// written with (a simulation's truth names its recording).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Fingerprint {
    pub bytes: u64,
    pub fnv1a64: String,
}

/// A file written beside a spincal JSON file, named in its `outputs` list so that a later run
/// recognises it as spincal's (`written_by_spincal`).
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

/// The fingerprint of the file at `path`, read in pieces.
pub(crate) fn fingerprint(path: &Path) -> std::io::Result<Fingerprint> {
    use std::io::Read;
    let mut file = File::open(path)?;
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut bytes = 0u64;
    let mut buffer = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buffer)?;
        if n == 0 {
            break;
        }
        bytes += n as u64;
        for &b in &buffer[..n] {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    Ok(Fingerprint {
        bytes,
        fnv1a64: format!("{hash:016x}"),
    })
}

/// The largest JSON file read to decide whether spincal wrote it.
const LARGEST_JSON_CHECKED: u64 = 512 << 20;

/// The top-level JSON object in `path`, if the file is one.
fn json_object(path: &Path) -> Option<serde_json::Map<String, serde_json::Value>> {
    let meta = std::fs::metadata(path).ok()?;
    if meta.len() > LARGEST_JSON_CHECKED {
        return None;
    }
    let text = std::fs::read(path).ok()?;
    match serde_json::from_slice::<serde_json::Value>(&text).ok()? {
        serde_json::Value::Object(map) => Some(map),
        _ => None,
    }
}

/// Whether a JSON object is one spincal writes: a `spincal_version` field (models, results,
/// truth), a campaign's results.json from before it carried one (its joint fit, held-out scores,
/// candidates and verdict), or imucal's file with the comment spincal gives it.
fn spincal_json(map: &serde_json::Map<String, serde_json::Value>) -> bool {
    map.get("spincal_version").is_some_and(|v| v.is_string())
        || ["unit", "joint", "held_out", "candidates", "verdict"]
            .iter()
            .all(|k| map.contains_key(*k))
        || map
            .get("comment")
            .and_then(|c| c.as_str())
            .is_some_and(|c| c.starts_with("spincal "))
}

/// What a spincal JSON file (`claimer`) says of `file`: `None` when it does not name it, else
/// whether `file` still has the fingerprint it names, in a `recording` field or an `outputs`
/// list (`{"file": name, "bytes": …, "fnv1a64": …}`).
fn claim_of(claimer: &Path, file: &Path) -> Option<bool> {
    let map = json_object(claimer)?;
    if !spincal_json(&map) {
        return None;
    }
    let name = file.file_name().and_then(|n| n.to_str())?;
    let listed = map.get("outputs").and_then(|o| o.as_array());
    let entry = map
        .get("recording")
        .into_iter()
        .chain(listed.into_iter().flatten())
        .find(|e| e.get("file").and_then(|f| f.as_str()) == Some(name))?;
    let Ok(claimed) = serde_json::from_value::<Fingerprint>(entry.clone()) else {
        return Some(false);
    };
    let same_size = std::fs::metadata(file).is_ok_and(|m| m.len() == claimed.bytes);
    Some(same_size && fingerprint(file).is_ok_and(|f| f == claimed))
}

/// Whether spincal wrote the regular file `path`, judged by its content:
/// - JSON with a `spincal_version` field (model files, results.json, a simulation's truth) or
///   imucal's file with spincal's comment;
/// - HTML with spincal's generator mark ([`HTML_GENERATOR`]) in its first 4 KiB;
/// - text whose first line is a comment naming spincal (`# spincal static calibration`, the C
///   export's `/* … spincal … */`), or an SVG marked `data-generator="spincal"` (the strobe disc);
/// - a CSV laid out as spincal writes it: `correct`'s output (its header ends with `valid` and
///   `status`) or a recording (`t_s,ax_g|ax_mps2,…`, as `fit` writes them) that no truth file
///   beside it names (a simulated recording is judged by its truth's fingerprint alone);
/// - an imu_tk `.calib` file beside a results.json or imucal.json that spincal wrote (a
///   campaign's or `static --exports`' files);
/// - any file that a spincal JSON file among `companions` (or `<stem>.truth.json` beside it) names
///   with its current length and hash, in a `recording` field (a simulated recording) or an
///   `outputs` list (a sweep's table and heat maps); once named, only that content counts.
pub(crate) fn written_by_spincal(path: &Path, companions: &[&Path]) -> bool {
    use std::io::Read;
    let mut head = Vec::with_capacity(4096);
    if File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .is_err()
    {
        return false;
    }
    let start = head
        .iter()
        .position(|b| !b.is_ascii_whitespace() && !matches!(b, 0xEF | 0xBB | 0xBF));
    if start.is_some_and(|i| head[i] == b'{') {
        return json_object(path).is_some_and(|map| spincal_json(&map));
    }
    if head
        .windows(HTML_GENERATOR.len())
        .any(|w| w == HTML_GENERATOR.as_bytes())
    {
        return true;
    }
    let folder = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let beside = path.with_extension("truth.json");
    let mut claimers = companions
        .iter()
        .copied()
        .chain(std::iter::once(beside.as_path()))
        .filter(|c| identity(c) != identity(path))
        .filter_map(|c| claim_of(c, path));
    if let Some(claimed) = claimers.next() {
        // A file a spincal JSON names is spincal's only while it has the content named there.
        return claimed || claimers.any(|c| c);
    }
    let first_line = String::from_utf8_lossy(&head[start.unwrap_or(0)..]);
    let first_line = first_line.lines().next().unwrap_or("").trim();
    let spincal_svg = first_line.starts_with("<svg") && first_line.contains("data-generator=\"spincal\"");
    if spincal_svg || is_spincal_comment(first_line) || is_spincal_csv_header(first_line) {
        return true;
    }
    if path.extension().is_some_and(|e| e == "calib") {
        return ["results.json", "imucal.json"]
            .iter()
            .any(|beside| json_object(&folder.join(beside)).is_some_and(|map| spincal_json(&map)));
    }
    false
}

/// A first line that is a comment naming spincal.
fn is_spincal_comment(line: &str) -> bool {
    let comment = ["#", "//", "/*", "<!--", "%"].iter().any(|m| line.starts_with(m));
    comment && line.to_ascii_lowercase().contains("spincal")
}

/// A header spincal's CSV writers write: `correct`'s (ending in `valid`, `status`) or a
/// recording's ([`crate::input::recording::Recording::write_csv`]).
fn is_spincal_csv_header(line: &str) -> bool {
    let fields: Vec<&str> = line
        .split([',', ' ', '\t', ';'])
        .filter(|f| !f.is_empty())
        .collect();
    if fields.ends_with(&["valid", "status"]) {
        return true;
    }
    let recording = |unit: &str| {
        let axes = [format!("ax_{unit}"), format!("ay_{unit}"), format!("az_{unit}")];
        fields.len() >= 4 && fields[0] == "t_s" && fields[1..4].iter().zip(&axes).all(|(f, a)| f == a) && {
            let rest = &fields[4..];
            let gyro = ["gx_radps", "gy_radps", "gz_radps"];
            let rest = if rest.starts_with(&gyro) { &rest[3..] } else { rest };
            rest.is_empty() || rest == ["temp_c"]
        }
    };
    recording("g") || recording("mps2")
}

/// An existing output that spincal did not write, replaced because the caller forced it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Replaced {
    pub path: PathBuf,
}

/// Checks, before any work, that writing `outputs` loses nothing: each one must be absent, empty,
/// not a regular file (a pipe or device is streamed to), or written by spincal
/// (`written_by_spincal`, with the other outputs as companions). Any other existing file is
/// refused by name, unless `force`: then it is returned so the caller can say it is replaced.
pub fn claim_outputs(outputs: &[&Path], force: bool) -> Result<Vec<Replaced>, OutputError> {
    let mut replaced = Vec::new();
    for &output in outputs.iter().filter(|p| !is_stdio(p)) {
        let Ok(meta) = std::fs::metadata(output) else {
            continue;
        };
        if !meta.is_file() || meta.len() == 0 {
            continue;
        }
        if written_by_spincal(output, outputs) {
            continue;
        }
        if !force {
            let why = match output.extension().and_then(|e| e.to_str()) {
                Some("json") => "no spincal_version field in it",
                Some("html") => "no spincal generator mark in it",
                Some("calib") => "no results.json or imucal.json by spincal beside it",
                _ => "no spincal file names it with its current content",
            };
            return Err(OutputError::NotWrittenBySpincal {
                path: output.display().to_string(),
                why: why.to_string(),
            });
        }
        replaced.push(Replaced {
            path: output.to_path_buf(),
        });
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

    #[test]
    fn only_files_spincal_wrote_are_claimed_and_force_names_the_others() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        std::fs::write(
            path("model.json"),
            r#"{"format_version": 1, "spincal_version": "0.1"}"#,
        )
        .unwrap();
        std::fs::write(path("theirs.json"), r#"{"format_version": 1}"#).unwrap();
        std::fs::write(
            path("report.html"),
            format!("<html><head>{HTML_GENERATOR}</head>"),
        )
        .unwrap();
        std::fs::write(path("notes.html"), "<html>notes</html>").unwrap();
        std::fs::write(path("empty.csv"), "").unwrap();
        std::fs::write(path("rec.csv"), "t_s,ax_g\n0,1\n").unwrap();
        let print = fingerprint(&path("rec.csv")).unwrap();
        let truth = serde_json::json!({
            "spincal_version": "0.1",
            "recording": {"file": "rec.csv", "bytes": print.bytes, "fnv1a64": print.fnv1a64},
        });
        std::fs::write(path("rec.truth.json"), truth.to_string()).unwrap();
        for ours in ["model.json", "report.html", "empty.csv", "rec.csv", "missing.csv"] {
            assert!(claim_outputs(&[&path(ours)], false).unwrap().is_empty(), "{ours}");
        }
        for theirs in ["theirs.json", "notes.html"] {
            let err = claim_outputs(&[&path(theirs)], false).unwrap_err();
            assert!(matches!(err, OutputError::NotWrittenBySpincal { .. }), "{err}");
            assert!(err.to_string().contains(theirs), "{err}");
            let replaced = claim_outputs(&[&path(theirs)], true).unwrap();
            assert_eq!(replaced, [Replaced { path: path(theirs) }]);
        }
        // An edited recording is no longer the one its truth names.
        std::fs::write(path("rec.csv"), "t_s,ax_g\n0,2\n").unwrap();
        assert!(claim_outputs(&[&path("rec.csv")], false).is_err());
        assert_eq!(
            std::fs::read_to_string(path("rec.csv")).unwrap(),
            "t_s,ax_g\n0,2\n"
        );
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
