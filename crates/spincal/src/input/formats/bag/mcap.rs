//! ROS 2 bags in MCAP storage.
//!
//! The top-level records (opcode u8, length u64, body) are walked here so that every fault has
//! its byte offset; record bodies are parsed by the `mcap` crate, which also decompresses
//! compressed chunks (zstd, lz4). Uncompressed chunks are walked in place (offsets stay file
//! offsets) and their CRC checked. Messages are handed to the [`Collector`] without copying.

use std::collections::HashMap;

use ::mcap::records::{op, Record};

use super::{BagError, Collector};

/// The MCAP magic at both ends of the file.
pub const MAGIC: &[u8] = b"\x89MCAP0\r\n";

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
    if !bytes.starts_with(MAGIC) {
        return Err(corrupt(file, "byte 0".into(), "no MCAP magic"));
    }
    let mut state = State {
        schemas: HashMap::new(),
        channels: HashMap::new(),
    };
    let mut pos = MAGIC.len();
    loop {
        if pos == bytes.len() {
            return Err(corrupt(
                file,
                format!("byte {pos}"),
                "the file ends without a footer record (truncated)",
            ));
        }
        let (opcode, body) = record_at(bytes, pos, file, "record")?;
        let body_at = pos + 9;
        match opcode {
            op::FOOTER => {
                let end = body_at + body.len();
                if bytes.len() - end < MAGIC.len() || &bytes[end..end + MAGIC.len()] != MAGIC {
                    return Err(corrupt(
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
    let parsed = ::mcap::parse_record(op::CHUNK, body)
        .map_err(|e| corrupt(file, format!("chunk at byte {pos}"), e.to_string()))?;
    let Record::Chunk { header, data } = parsed else {
        return Err(corrupt(
            file,
            format!("byte {pos}"),
            "chunk record did not parse as a chunk",
        ));
    };
    let records_len = data.len();
    if header.compression.is_empty() {
        // The records start where the body's last `compressed_size` bytes do.
        let start = pos + 9 + body.len() - records_len;
        let records = &bytes[start..start + records_len];
        if header.uncompressed_size != records_len as u64 {
            return Err(corrupt(
                file,
                format!("chunk at byte {pos}"),
                format!(
                    "uncompressed chunk says {} bytes but holds {records_len}",
                    header.uncompressed_size
                ),
            ));
        }
        if header.uncompressed_crc != 0 {
            let crc = crc32fast::hash(records);
            if crc != header.uncompressed_crc {
                return Err(corrupt(
                    file,
                    format!("chunk at byte {pos}"),
                    format!(
                        "CRC {crc:08x} does not match the stored {:08x}",
                        header.uncompressed_crc
                    ),
                ));
            }
        }
        let mut p = 0usize;
        while p < records.len() {
            let (opcode, rbody) = record_at(records, p, file, "record").map_err(|e| match e {
                BagError::Corrupt { what, .. } => corrupt(
                    file,
                    format!("byte {} (in the chunk at byte {pos})", start + p),
                    what,
                ),
                e => e,
            })?;
            let at_abs = start + p;
            if opcode == op::CHUNK {
                return Err(corrupt(file, format!("byte {at_abs}"), "a chunk inside a chunk"));
            }
            record(opcode, rbody, at_abs + 9, file, state, c, &|| {
                format!("byte {at_abs} (in the chunk at byte {pos})")
            })?;
            p += 9 + rbody.len();
        }
        return Ok(());
    }
    // Compressed: the mcap crate decompresses (and checks the CRC); records are counted.
    // Why a cap: a damaged size must not allocate gigabytes; real chunks are a few MiB.
    if header.uncompressed_size > (1 << 30).min(records_len as u64 * 4096 + (1 << 20)) {
        return Err(corrupt(
            file,
            format!("chunk at byte {pos}"),
            format!("uncompressed size {} is implausible", header.uncompressed_size),
        ));
    }
    let compression = header.compression.clone();
    let reader = ::mcap::read::ChunkReader::new(header, &data)
        .map_err(|e| corrupt(file, format!("{compression} chunk at byte {pos}"), e.to_string()))?;
    for (k, rec) in reader.enumerate() {
        let at = || format!("record {} of the {compression} chunk at byte {pos}", k + 1);
        let rec = rec.map_err(|e| corrupt(file, at(), e.to_string()))?;
        match rec {
            Record::Message { header, data } => {
                let Some(&topic) = state.channels.get(&header.channel_id) else {
                    return Err(corrupt(
                        file,
                        at(),
                        format!("message on unknown channel {}", header.channel_id),
                    ));
                };
                c.message(topic, header.log_time, &data, &at);
            }
            r @ (Record::Schema { .. } | Record::Channel(_)) => schema_or_channel(r, file, state, c, &at)?,
            _ => {}
        }
    }
    Ok(())
}
