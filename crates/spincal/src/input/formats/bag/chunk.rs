//! Compressed chunks: the limits on what a chunk may claim, and its decompression.

/// The most one compressed chunk may say it decompresses to. Real chunks are small (rosbag's
/// default is 768 KiB, MCAP writers' a few MiB); a chunk is decompressed, walked and dropped
/// before the next, so this bounds what decompression holds at once.
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// The most a chunk may say it decompresses to per compressed byte (plus [`CHUNK_SLACK_BYTES`]):
/// a chunk that claims more is refused before anything is allocated, whatever its codec could do.
pub const MAX_CHUNK_RATIO: u64 = 4096;

/// Added to [`MAX_CHUNK_RATIO`] × compressed bytes, so small chunks are never refused for it.
pub const CHUNK_SLACK_BYTES: u64 = 1 << 20;

/// The most a chunk of `compressed` bytes may decompress to: [`MAX_CHUNK_BYTES`], and
/// [`MAX_CHUNK_RATIO`] × `compressed` + [`CHUNK_SLACK_BYTES`].
pub fn chunk_limit(compressed: usize) -> u64 {
    MAX_CHUNK_BYTES.min((compressed as u64).saturating_mul(MAX_CHUNK_RATIO) + CHUNK_SLACK_BYTES)
}

/// A compressed chunk (MCAP's zstd or lz4, ROS 1's bz2 or lz4; lz4 as frames), decompressed to
/// exactly `size` bytes, the size its header states, which is checked against [`chunk_limit`]
/// first; decompression stops one byte past it. The callers have checked the kind.
pub(super) fn decompress_chunk(kind: &str, data: &[u8], size: usize) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let most = chunk_limit(data.len());
    if size as u64 > most {
        return Err(format!(
            "{kind} chunk says it decompresses to {size} bytes from {}: over the limit of {most} bytes (at most {MAX_CHUNK_BYTES}, and {MAX_CHUNK_RATIO} × the compressed bytes + {CHUNK_SLACK_BYTES})",
            data.len()
        ));
    }
    let mut out = Vec::with_capacity(size);
    let limit = size as u64 + 1;
    let result = match kind {
        "zstd" => zstd::stream::read::Decoder::new(data).and_then(|d| d.take(limit).read_to_end(&mut out)),
        "bz2" => bzip2::read::BzDecoder::new(data)
            .take(limit)
            .read_to_end(&mut out),
        _ => lz4_flex::frame::FrameDecoder::new(data)
            .take(limit)
            .read_to_end(&mut out),
    };
    result.map_err(|e| format!("{kind} chunk does not decompress: {e}"))?;
    if out.len() != size {
        return Err(format!(
            "{kind} chunk decompresses to {}{} bytes, its header says {size}",
            out.len().min(size + 1),
            if out.len() > size { "+" } else { "" }
        ));
    }
    Ok(out)
}
