//! A zip export's CSV files, through the `zip` crate (the `phone` feature).

use std::io::Read;

use super::super::FormatError;
use super::text::Members;
use super::PhoneError;

/// At most this many inflated bytes are read from one archive: an hour of phone sensors at
/// 500 Hz is about 0.2 GB of CSV, so this leaves room without letting a zip bomb fill memory.
pub(crate) const MAX_INFLATED_BYTES: u64 = 1 << 30;

/// The CSV members of a zip held in memory. Members are named as inside the archive with `/`
/// separators; a folder that wraps every member (an archive made of the unzipped folder) is
/// removed from the names, so `Run/meta/time.csv` is `meta/time.csv`.
pub(crate) fn members(bytes: &[u8], file: &str) -> Result<Members, FormatError> {
    let zip_error = |why: String| PhoneError::Zip {
        file: file.into(),
        why,
    };
    let mut archive =
        zip::ZipArchive::new(std::io::Cursor::new(bytes)).map_err(|e| zip_error(e.to_string()))?;
    let mut entries = Vec::new();
    let mut left = MAX_INFLATED_BYTES;
    for i in 0..archive.len() {
        let mut member = archive.by_index(i).map_err(|e| zip_error(e.to_string()))?;
        let name = member.name().replace('\\', "/");
        if member.is_dir() || name.starts_with("__MACOSX/") || !name.to_ascii_lowercase().ends_with(".csv") {
            continue;
        }
        let too_large = || PhoneError::TooLarge {
            file: file.into(),
            member: name.clone(),
            limit_bytes: MAX_INFLATED_BYTES,
        };
        // The stated size first, then the inflated bytes themselves (a stated size can lie).
        if member.size() > left {
            return Err(too_large().into());
        }
        let mut data = Vec::with_capacity(member.size() as usize);
        (&mut member)
            .take(left + 1)
            .read_to_end(&mut data)
            .map_err(|e| zip_error(format!("member {name}: {e}")))?;
        if data.len() as u64 > left {
            return Err(too_large().into());
        }
        left -= data.len() as u64;
        entries.push((name, data));
    }
    strip_wrapper(&mut entries);
    Ok(Members {
        source: file.into(),
        entries,
        alone: None,
    })
}

/// Removes a first path component that every member shares.
fn strip_wrapper(entries: &mut [(String, Vec<u8>)]) {
    let first = |n: &str| n.split_once('/').map(|(d, _)| d.to_string());
    let Some(Some(top)) = entries.first().map(|(n, _)| first(n)) else {
        return;
    };
    if top == "meta"
        || !entries
            .iter()
            .all(|(n, _)| first(n).as_deref() == Some(top.as_str()))
    {
        return;
    }
    for (n, _) in entries.iter_mut() {
        *n = n[top.len() + 1..].to_string();
    }
}
