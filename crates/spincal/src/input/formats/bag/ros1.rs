//! ROS 1 bags, format 2.0.
//!
//! After the line `#ROSBAG V2.0\n` the file is a sequence of records: `u32` header length, header
//! fields (each `u32` length then `name=value`, the value binary), `u32` data length, data. The
//! header's `op` field says what the record is: bag header (0x03), chunk (0x05: `compression`
//! none/bz2/lz4, `size` uncompressed; its data holds connection and message records), connection
//! (0x07: `conn`, `topic`; its data holds the connection header with `type`), message data (0x02:
//! `conn`, `time` as `u32` secs + `u32` nsecs), index (0x04) and chunk info (0x06). Connections
//! come before their messages, inside the chunks, so one linear pass reads the bag.

use std::collections::HashMap;

use super::{BagError, Collector};

const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

const OP_MSG_DATA: u8 = 0x02;
const OP_CHUNK: u8 = 0x05;
const OP_CONNECTION: u8 = 0x07;

fn corrupt(file: &str, at: String, what: impl Into<String>) -> BagError {
    BagError::Corrupt {
        file: file.into(),
        at,
        what: what.into(),
    }
}

/// Where the records being walked live: the file itself, or a decompressed chunk.
#[derive(Clone, Copy)]
enum Place {
    File,
    Chunk { at: usize, compression: &'static str },
}

impl Place {
    fn at(self, offset: usize) -> String {
        match self {
            Place::File => format!("byte {offset}"),
            Place::Chunk { at, compression } => {
                format!("byte {offset} of the {compression}-compressed chunk at byte {at}")
            }
        }
    }
}

/// Header fields of one record.
struct Fields<'a>(Vec<(&'a [u8], &'a [u8])>);

impl<'a> Fields<'a> {
    fn parse(header: &'a [u8]) -> Result<Fields<'a>, String> {
        let mut out = Vec::new();
        let mut p = 0;
        while p < header.len() {
            if header.len() - p < 4 {
                return Err(format!("header field length cut at byte {p} of the header"));
            }
            let len = u32::from_le_bytes(header[p..p + 4].try_into().expect("4 bytes")) as usize;
            p += 4;
            if len > header.len() - p {
                return Err(format!(
                    "header field of {len} bytes at byte {} of the header runs past its end ({} left)",
                    p - 4,
                    header.len() - p
                ));
            }
            let field = &header[p..p + len];
            let Some(eq) = field.iter().position(|&b| b == b'=') else {
                return Err(format!("header field at byte {} of the header has no '='", p - 4));
            };
            out.push((&field[..eq], &field[eq + 1..]));
            p += len;
        }
        Ok(Fields(out))
    }

    fn get(&self, name: &str) -> Option<&'a [u8]> {
        self.0
            .iter()
            .find(|(n, _)| *n == name.as_bytes())
            .map(|(_, v)| *v)
    }

    fn need(&self, name: &str) -> Result<&'a [u8], String> {
        self.get(name).ok_or_else(|| format!("no `{name}` field"))
    }

    fn u32(&self, name: &str) -> Result<u32, String> {
        let v = self.need(name)?;
        <[u8; 4]>::try_from(v)
            .map(u32::from_le_bytes)
            .map_err(|_| format!("`{name}` field has {} bytes, not 4", v.len()))
    }

    fn text(&self, name: &str) -> Result<String, String> {
        let v = self.need(name)?;
        std::str::from_utf8(v)
            .map(str::to_string)
            .map_err(|_| format!("`{name}` field is not UTF-8"))
    }
}

/// One record: (op, header fields, data, offset of the data in the buffer, next record offset).
fn record_at<'a>(buf: &'a [u8], pos: usize) -> Result<(u8, Fields<'a>, &'a [u8], usize), String> {
    let left = buf.len() - pos;
    let len_at = |p: usize, what: &str| -> Result<usize, String> {
        if buf.len() - p < 4 {
            return Err(format!(
                "the {what} length is cut off ({} bytes left; truncated)",
                buf.len() - p
            ));
        }
        Ok(u32::from_le_bytes(buf[p..p + 4].try_into().expect("4 bytes")) as usize)
    };
    let hlen = len_at(pos, "record header")?;
    if hlen > left - 4 {
        return Err(format!(
            "record header of {hlen} bytes runs past the end ({} bytes left; truncated)",
            left - 4
        ));
    }
    let header = &buf[pos + 4..pos + 4 + hlen];
    let dpos = pos + 4 + hlen;
    let dlen = len_at(dpos, "record data")?;
    if dlen > buf.len() - dpos - 4 {
        return Err(format!(
            "record data of {dlen} bytes runs past the end ({} bytes left; truncated)",
            buf.len() - dpos - 4
        ));
    }
    let fields = Fields::parse(header)?;
    let op = match fields.get("op") {
        Some([op]) => *op,
        Some(v) => return Err(format!("`op` field has {} bytes, not 1", v.len())),
        None => return Err("record header has no `op` field".into()),
    };
    Ok((op, fields, &buf[dpos + 4..dpos + 4 + dlen], dpos + 4))
}

/// Reads every message of a ROS 1 bag into `c`.
pub fn scan(bytes: &[u8], file: &str, c: &mut Collector) -> Result<(), BagError> {
    if !bytes.starts_with(MAGIC) {
        let line: String = String::from_utf8_lossy(&bytes[..bytes.len().min(13)])
            .trim()
            .to_string();
        return Err(BagError::Unsupported {
            file: file.into(),
            what: format!("'{line}': only ROS 1 bag format 2.0 (#ROSBAG V2.0) is read"),
        });
    }
    let mut conns: HashMap<u32, usize> = HashMap::new();
    walk(bytes, MAGIC.len(), Place::File, file, &mut conns, c)
}

fn walk(
    buf: &[u8],
    start: usize,
    place: Place,
    file: &str,
    conns: &mut HashMap<u32, usize>,
    c: &mut Collector,
) -> Result<(), BagError> {
    let mut pos = start;
    while pos < buf.len() {
        let (op, fields, data, data_at) = match record_at(buf, pos) {
            Ok(record) => record,
            // A file cut inside a record: every record before it is whole.
            Err(w) if matches!(place, Place::File) => return c.damaged_end(corrupt(file, place.at(pos), w)),
            Err(w) => return Err(corrupt(file, place.at(pos), w)),
        };
        let fail = |w: String| corrupt(file, place.at(pos), w);
        match op {
            OP_CHUNK => {
                if !matches!(place, Place::File) {
                    return Err(fail("a chunk inside a chunk".into()));
                }
                let compression = fields.text("compression").map_err(fail)?;
                let size = fields.u32("size").map_err(fail)? as usize;
                let owned;
                let (inner, inner_place, inner_start) = match compression.as_str() {
                    "none" => {
                        if size != data.len() {
                            return Err(fail(format!(
                                "uncompressed chunk says {size} bytes but holds {}",
                                data.len()
                            )));
                        }
                        (buf, Place::File, data_at)
                    }
                    "bz2" | "lz4" => {
                        let name: &'static str = if compression == "bz2" { "bz2" } else { "lz4" };
                        owned = super::decompress_chunk(name, data, size).map_err(fail)?;
                        (
                            &owned[..],
                            Place::Chunk {
                                at: pos,
                                compression: name,
                            },
                            0,
                        )
                    }
                    other => {
                        return Err(fail(format!(
                            "chunk compression '{other}' is not none, bz2 or lz4"
                        )))
                    }
                };
                let end = inner_start
                    + if matches!(inner_place, Place::File) {
                        data.len()
                    } else {
                        inner.len()
                    };
                walk(&inner[..end], inner_start, inner_place, file, conns, c)?;
            }
            OP_CONNECTION => {
                let id = fields.u32("conn").map_err(fail)?;
                let topic = fields.text("topic").map_err(fail)?;
                let conn_header = Fields::parse(data).map_err(|w| fail(format!("connection header: {w}")))?;
                let msgtype = conn_header
                    .text("type")
                    .map_err(|w| fail(format!("connection header: {w}")))?;
                let t = c.topic(&topic, &msgtype, "ros1");
                conns.insert(id, t);
            }
            OP_MSG_DATA => {
                let id = fields.u32("conn").map_err(fail)?;
                let time = fields.need("time").map_err(fail)?;
                let Ok(time) = <[u8; 8]>::try_from(time) else {
                    return Err(fail(format!("`time` field has {} bytes, not 8", time.len())));
                };
                let secs = u32::from_le_bytes(time[..4].try_into().expect("4 bytes")) as u64;
                let nsecs = u32::from_le_bytes(time[4..].try_into().expect("4 bytes")) as u64;
                let Some(&topic) = conns.get(&id) else {
                    return Err(fail(format!(
                        "message on connection {id}, which no connection record defined before it"
                    )));
                };
                c.message(topic, secs * 1_000_000_000 + nsecs, data, &|| {
                    format!("{}, data at {}", place.at(pos), place.at(data_at))
                });
            }
            _ => {}
        }
        pos = data_at + data.len();
    }
    Ok(())
}
