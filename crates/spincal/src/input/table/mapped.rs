//! A file's bytes for parsing: large regular files mapped (and paged in window by window),
//! others read whole.

use std::io::Read;
use std::path::Path;

use crate::input::limits::{check_regular, LARGEST_RECORDING_BYTES};

/// The bytes of a file: mapped when it is a large regular file, read whole otherwise.
pub enum FileBytes {
    Mapped(MappedFile),
    Read(Vec<u8>),
}

impl std::ops::Deref for FileBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            FileBytes::Mapped(file) => &file.map,
            FileBytes::Read(bytes) => bytes,
        }
    }
}

/// Files from this size up are mapped rather than copied into memory.
pub(super) const MAP_BYTES: u64 = 1 << 20;

/// Opens a file for parsing in memory: a regular file of at least 1 MiB is mapped (no copy), a
/// smaller one is read whole.
/// Only a regular file under [`LARGEST_RECORDING_BYTES`] is read (refused by name before it is
/// opened otherwise: a FIFO would block, `/dev/zero` would never end).
pub fn read_file(path: &Path) -> std::io::Result<FileBytes> {
    check_regular(path, LARGEST_RECORDING_BYTES, "a recording's limit")?;
    let mut file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_file() && meta.len() >= MAP_BYTES {
        // SAFETY: the map is read-only. Another process truncating the file while it is parsed
        // would fault the read (SIGBUS), as in any reader that maps files; spincal's inputs are
        // finished recordings, and the speed of a mapped read is why this is worth it.
        if let Ok(map) = unsafe { memmap2::MmapOptions::new().map(&file) } {
            return Ok(FileBytes::Mapped(MappedFile::new(map)));
        }
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    file.read_to_end(&mut bytes)?;
    Ok(FileBytes::Read(bytes))
}

/// A mapped file whose pages the parser hands back as it finishes with them, so a file larger
/// than memory allows can be read and only a window of it is resident at a time. The address
/// ranges of live maps are kept in `LIVE_MAPS`: parsers see plain byte slices.
pub struct MappedFile {
    map: memmap2::Mmap,
}

/// (start, end) addresses of every live [`MappedFile`].
static LIVE_MAPS: std::sync::Mutex<Vec<(usize, usize)>> = std::sync::Mutex::new(Vec::new());

impl MappedFile {
    fn new(map: memmap2::Mmap) -> MappedFile {
        let start = map.as_ptr() as usize;
        if let Ok(mut live) = LIVE_MAPS.lock() {
            live.push((start, start + map.len()));
        }
        MappedFile { map }
    }
}

impl Drop for MappedFile {
    fn drop(&mut self) {
        // Forgotten before the map goes, so no released range can outlive it.
        let start = self.map.as_ptr() as usize;
        if let Ok(mut live) = LIVE_MAPS.lock() {
            live.retain(|&(s, _)| s != start);
        }
    }
}

/// What to tell the kernel about a stretch of a mapped file.
#[derive(Clone, Copy)]
pub(super) enum Paging {
    /// About to be read: fault it in at once.
    Ahead,
    /// Read: drop it from this process (the page cache keeps it; touching it again reads it back).
    Done,
}

/// Gives `part`'s whole pages the advice when `part` lies in a live [`MappedFile`]; any other
/// slice (a `Vec`, a test's string) is left alone. Advice only changes residency, never contents.
pub(super) fn advise_mapped(part: &[u8], paging: Paging) {
    #[cfg(unix)]
    {
        const PAGE: usize = 4096;
        let (start, end) = (part.as_ptr() as usize, part.as_ptr() as usize + part.len());
        let Ok(live) = LIVE_MAPS.lock() else { return };
        if !live.iter().any(|&(s, e)| s <= start && end <= e) {
            return;
        }
        let (first, last) = match paging {
            Paging::Ahead => (start & !(PAGE - 1), end),
            // Only pages wholly inside `part`: its neighbours may still be read.
            Paging::Done => (start.next_multiple_of(PAGE), end & !(PAGE - 1)),
        };
        if first >= last {
            return;
        }
        let advise = |advice: libc::c_int| {
            // SAFETY: the range lies in a live read-only file map (checked under the lock, which
            // `MappedFile::drop` takes before unmapping); these advices leave its contents as
            // they are.
            unsafe { libc::madvise(first as *mut libc::c_void, last - first, advice) == 0 }
        };
        match paging {
            // Linux 5.14+ maps the pages at once; elsewhere, read-ahead at least.
            #[cfg(target_os = "linux")]
            Paging::Ahead => {
                if !advise(libc::MADV_POPULATE_READ) {
                    advise(libc::MADV_WILLNEED);
                }
            }
            #[cfg(not(target_os = "linux"))]
            Paging::Ahead => {
                advise(libc::MADV_WILLNEED);
            }
            Paging::Done => {
                advise(libc::MADV_DONTNEED);
            }
        }
        drop(live);
    }
    #[cfg(not(unix))]
    let _ = (part, paging);
}

/// Asks for transparent huge pages under `v`'s unused capacity (Linux): a column of a large
/// file is then faulted in 2 MiB at a time instead of 4 KiB (about a sixth as many faults per read).
pub(super) fn advise_huge_pages<T>(v: &mut Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let spare = v.spare_capacity_mut();
        let start = spare.as_ptr() as usize;
        let end = start + std::mem::size_of_val(spare);
        let (first, last) = (start.next_multiple_of(HUGE), end & !(HUGE - 1));
        if first < last {
            // SAFETY: the range lies inside the vector's own allocation, none of it initialised
            // yet; MADV_HUGEPAGE changes how pages are backed, never what they hold.
            unsafe {
                libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}
