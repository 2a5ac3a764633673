//! ROS 2 bags in MCAP storage.
//!
//! The records (opcode u8, length u64, body) are walked here, at the top level and inside chunks,
//! so that every fault has its byte offset and every length is checked before anything is
//! allocated; schema, channel and chunk bodies are parsed by the `mcap` crate. Chunks are
//! uncompressed (walked in place: offsets stay file offsets), zstd or lz4 (decompressed to their
//! stated size, capped); a non-zero CRC is checked. Messages reach the [`Collector`] uncopied.

use std::collections::HashMap;

use ::mcap::records::{op, Record};

use super::{BagError, Collector};
use crate::input::formats::bag_detect::MCAP_MAGIC;

struct State {
    /// schema id → (name, encoding)
    schemas: HashMap<u16, (String, String)>,
    /// channel id → collector topic
    channels: HashMap<u16, usize>,
}

fn corrupt(file: &str, at: String, what: impl Into<String>) -> BagError {
    BagError::Corrupt {
        file: file.into(),
        at,
        what: what.into(),
    }
}

/// Reads every message of an MCAP file into `c`.
pub fn scan(bytes: &[u8], file: &str, c: &mut Collector) -> Result<(), BagError> {
    if !bytes.starts_with(MCAP_MAGIC) {
        return Err(corrupt(file, "byte 0".into(), "no MCAP magic"));
    }
    let mut state = State {
        schemas: HashMap::new(),
        channels: HashMap::new(),
    };
    let mut pos = MCAP_MAGIC.len();
    loop {
        // Damage at the end (a cut, a lost footer) leaves every record before it whole.
        if pos == bytes.len() {
            return c.damaged_end(corrupt(
                file,
                format!("byte {pos}"),
                "the file ends without a footer record (truncated)",
            ));
        }
        let (opcode, body) = match record_at(bytes, pos, file, "record") {
            Ok(record) => record,
            Err(e) => return c.damaged_end(e),
        };
        let body_at = pos + 9;
        match opcode {
            op::FOOTER => {
                let end = body_at + body.len();
                if bytes.len() - end < MCAP_MAGIC.len() || &bytes[end..end + MCAP_MAGIC.len()] != MCAP_MAGIC {
                    return c.damaged_end(corrupt(
                        file,
                        format!("byte {end}"),
                        "no MCAP magic after the footer (truncated)",
                    ));
                }
                return Ok(());
            }
            op::CHUNK => chunk(bytes, pos, body, file, &mut state, c)?,
            _ => record(opcode, body, body_at, file, &mut state, c, &|| {
                format!("byte {pos}")
            })?,
        }
        pos = body_at + body.len();
    }
}

/// The record at `pos` of `bytes`: opcode and body, its length checked.
fn record_at<'a>(bytes: &'a [u8], pos: usize, file: &str, what: &str) -> Result<(u8, &'a [u8]), BagError> {
    let left = bytes.len() - pos;
    if left < 9 {
        return Err(corrupt(
            file,
            format!("byte {pos}"),
            format!("{left} bytes left: too few for a {what} header (9 bytes; truncated)"),
        ));
    }
    let opcode = bytes[pos];
    let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().expect("8 bytes"));
    if len > (left - 9) as u64 {
        return Err(corrupt(
            file,
            format!("byte {pos}"),
            format!(
                "{what} (opcode {opcode:#04x}) of {len} bytes runs past the end ({} bytes left; truncated)",
                left - 9
            ),
        ));
    }
    Ok((opcode, &bytes[pos + 9..pos + 9 + len as usize]))
}

fn record(
    opcode: u8,
    body: &[u8],
    body_at: usize,
    file: &str,
    state: &mut State,
    c: &mut Collector,
    at: &dyn Fn() -> String,
) -> Result<(), BagError> {
    match opcode {
        op::MESSAGE => {
            if body.len() < 22 {
                return Err(corrupt(
                    file,
                    at(),
                    format!("message record of {} bytes (the header alone is 22)", body.len()),
                ));
            }
            let channel = u16::from_le_bytes([body[0], body[1]]);
            let log_time = u64::from_le_bytes(body[6..14].try_into().expect("8 bytes"));
            let Some(&topic) = state.channels.get(&channel) else {
                return Err(corrupt(
                    file,
                    at(),
                    format!("message on unknown channel {channel}"),
                ));
            };
            let data_at = body_at + 22;
            c.message(topic, log_time, &body[22..], &|| {
                format!("{}, data at byte {data_at}", at())
            });
        }
        op::SCHEMA | op::CHANNEL => {
            check_strings(opcode, body).map_err(|w| corrupt(file, at(), w))?;
            let parsed =
                ::mcap::parse_record(opcode, body).map_err(|e| corrupt(file, at(), e.to_string()))?;
            schema_or_channel(parsed, file, state, c, at)?;
        }
        _ => {}
    }
    Ok(())
}

fn schema_or_channel(
    record: Record<'_>,
    file: &str,
    state: &mut State,
    c: &mut Collector,
    at: &dyn Fn() -> String,
) -> Result<(), BagError> {
    match record {
        Record::Schema { header, .. } => {
            state.schemas.insert(header.id, (header.name, header.encoding));
        }
        Record::Channel(ch) => {
            let msgtype = if ch.schema_id == 0 {
                String::new()
            } else {
                match state.schemas.get(&ch.schema_id) {
                    Some((name, _)) => name.clone(),
                    None => {
                        return Err(corrupt(
                            file,
                            at(),
                            format!(
                                "channel {} ({}) names unknown schema {}",
                                ch.id, ch.topic, ch.schema_id
                            ),
                        ))
                    }
                }
            };
            let topic = c.topic(&ch.topic, &msgtype, &ch.message_encoding);
            state.channels.insert(ch.id, topic);
        }
        _ => {}
    }
    Ok(())
}

fn chunk(
    bytes: &[u8],
    pos: usize,
    body: &[u8],
    file: &str,
    state: &mut State,
    c: &mut Collector,
) -> Result<(), BagError> {
    let here = || format!("chunk at byte {pos}");
    check_strings(op::CHUNK, body).map_err(|w| corrupt(file, here(), w))?;
    let parsed = ::mcap::parse_record(op::CHUNK, body).map_err(|e| corrupt(file, here(), e.to_string()))?;
    let Record::Chunk { header, data } = parsed else {
        return Err(corrupt(file, here(), "chunk record did not parse as a chunk"));
    };
    // The records follow the chunk header: 3 × u64, u32 CRC, the compression string (u32 length
    // + bytes), u64 compressed size.
    let start = pos + 9 + 8 * 3 + 4 + 4 + header.compression.len() + 8;
    let decompressed;
    let (records, base): (&[u8], Option<usize>) = match header.compression.as_str() {
        "" => (&bytes[start..start + data.len()], Some(start)),
        "zstd" | "lz4" => {
            // The size is checked against the chunk limit before anything is allocated.
            if header.uncompressed_size > super::chunk_limit(data.len()) {
                return Err(corrupt(
                    file,
                    here(),
                    format!(
                        "{} chunk says it decompresses to {} bytes from {}: over the limit of {} bytes (at most {}, and {} × the compressed bytes + {})",
                        header.compression,
                        header.uncompressed_size,
                        data.len(),
                        super::chunk_limit(data.len()),
                        super::MAX_CHUNK_BYTES,
                        super::MAX_CHUNK_RATIO,
                        super::CHUNK_SLACK_BYTES
                    ),
                ));
            }
            let size = header.uncompressed_size as usize;
            decompressed = super::decompress_chunk(&header.compression, &data, size)
                .map_err(|w| corrupt(file, here(), w))?;
            (&decompressed[..], None)
        }
        other => {
            return Err(corrupt(
                file,
                here(),
                format!("chunk compression '{other}' is not none, zstd or lz4"),
            ))
        }
    };
    if header.uncompressed_size != records.len() as u64 {
        return Err(corrupt(
            file,
            here(),
            format!(
                "chunk says {} uncompressed bytes but holds {}",
                header.uncompressed_size,
                records.len()
            ),
        ));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(records);
        if crc != header.uncompressed_crc {
            return Err(corrupt(
                file,
                here(),
                format!(
                    "CRC {crc:08x} does not match the stored {:08x}",
                    header.uncompressed_crc
                ),
            ));
        }
    }
    // Offsets: file offsets in an uncompressed chunk, offsets in the decompressed data otherwise.
    let place = |p: usize| match base {
        Some(b) => format!("byte {} (in the chunk at byte {pos})", b + p),
        None => format!(
            "byte {p} of the decompressed {} chunk at byte {pos}",
            header.compression
        ),
    };
    let mut p = 0usize;
    while p < records.len() {
        let (opcode, rbody) = record_at(records, p, file, "record").map_err(|e| match e {
            BagError::Corrupt { what, .. } => corrupt(file, place(p), what),
            e => e,
        })?;
        if opcode == op::CHUNK {
            return Err(corrupt(file, place(p), "a chunk inside a chunk"));
        }
        let body_at = base.map_or(p + 9, |b| b + p + 9);
        let at = place(p);
        record(opcode, rbody, body_at, file, state, c, &|| at.clone())?;
        p += 9 + rbody.len();
    }
    Ok(())
}

/// Checks the length of every string in a schema, channel or chunk body before the `mcap` crate
/// parses it (its parser allocates a string's stated length before reading it).
fn check_strings(opcode: u8, body: &[u8]) -> Result<(), String> {
    fn string(body: &[u8], p: &mut usize, end: usize, what: &str) -> Result<(), String> {
        if end - *p < 4 {
            return Err(format!("the {what} length at byte {p} of the record is cut off"));
        }
        let len = u32::from_le_bytes(body[*p..*p + 4].try_into().expect("4 bytes")) as usize;
        if len > end - *p - 4 {
            return Err(format!(
                "the {what} of {len} bytes at byte {p} of the record runs past its end ({} left)",
                end - *p - 4
            ));
        }
        *p += 4 + len;
        Ok(())
    }
    let end = body.len();
    let skip = |n: usize| {
        if end < n {
            Err(format!("record of {end} bytes is too short"))
        } else {
            Ok(n)
        }
    };
    match opcode {
        op::SCHEMA => {
            let mut p = skip(2)?;
            string(body, &mut p, end, "schema name")?;
            string(body, &mut p, end, "schema encoding")?;
        }
        op::CHANNEL => {
            let mut p = skip(4)?;
            string(body, &mut p, end, "topic")?;
            string(body, &mut p, end, "message encoding")?;
            if end - p < 4 {
                return Err("the channel metadata length is cut off".into());
            }
            let len = u32::from_le_bytes(body[p..p + 4].try_into().expect("4 bytes")) as usize;
            if len > end - p - 4 {
                return Err(format!(
                    "channel metadata of {len} bytes runs past the record's end"
                ));
            }
            let map_end = p + 4 + len;
            p += 4;
            while p < map_end {
                string(body, &mut p, map_end, "metadata key")?;
                string(body, &mut p, map_end, "metadata value")?;
            }
        }
        op::CHUNK => {
            let mut p = skip(28)?;
            string(body, &mut p, end, "chunk compression")?;
        }
        _ => {}
    }
    Ok(())
}
