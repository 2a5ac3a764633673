//! ArduPilot DataFlash logs (`.bin`), read by hand: the format describes itself, so a reader is
//! small. Every message is 0xA3 0x95, a type byte and a payload whose length and layout the FMT
//! message (type 128) of that type gives: Length (header included), Name (char[4]), Format (one
//! character per field) and Columns (the labels, comma separated). The format characters and
//! their sizes are ArduPilot's (AP_Logger/LogStructure.h):
//!
//! | char | C type | | char | C type |
//! |---|---|---|---|---|
//! | b, B | int8, uint8 | | n, N, Z | char[4], char[16], char[64] |
//! | h, H | int16, uint16 | | c, C | int16, uint16 × 100 |
//! | i, I | int32, uint32 | | e, E | int32, uint32 × 100 |
//! | q, Q | int64, uint64 | | L | int32 latitude/longitude × 10⁷ |
//! | f, d | float, double | | M | uint8 flight mode |
//! | g | half float | | a | int16[32] |
//!
//! Samples: `IMU` messages (TimeUS µs, I the instance, GyrX/Y/Z rad/s, AccX/Y/Z m/s², T °C); logs
//! before ArduPilot 4.0 name the second and third IMU `IMU2`, `IMU3` and have no `I`. The IMU
//! messages carry no device id: ArduPilot keeps it in the parameters INS_ACC_ID, INS_ACC2_ID,
//! INS_ACC3_ID (INS4_ACC_ID, INS5_ACC_ID), logged as PARM messages (Name, Value).
//!
//! Damage is refused with its byte offset (with `salvage`, the messages before it are read); a
//! last message cut short (power lost while logging) and zero or 0xFF padding after the last
//! message are left out with a note.

use std::collections::BTreeMap;

use super::{
    finite_temperature, parse_topic, recording, FlightError, FlightLog, FlightRead, FlightStack, Series,
};
use crate::input::formats::ReadOptions;

const HEAD: [u8; 2] = [0xA3, 0x95];
const FMT_TYPE: u8 = 128;
/// FMT's own length: header 3, Type 1, Length 1, Name 4, Format 16, Columns 64.
const FMT_LEN: usize = 89;

/// Bytes of a format character; `None` for a character ArduPilot does not define.
fn size_of(c: u8) -> Option<usize> {
    Some(match c {
        b'b' | b'B' | b'M' => 1,
        b'h' | b'H' | b'c' | b'C' | b'g' => 2,
        b'i' | b'I' | b'f' | b'e' | b'E' | b'L' | b'n' => 4,
        b'q' | b'Q' | b'd' => 8,
        b'N' => 16,
        b'Z' | b'a' => 64,
        _ => return None,
    })
}

/// One field's value as a number (pymavlink's arithmetic: the scaled kinds multiplied by 0.01 or
/// 1e-7); `None` for text and arrays.
pub(super) fn number(c: u8, b: &[u8]) -> Option<f64> {
    let a2 = || [b[0], b[1]];
    let a4 = || [b[0], b[1], b[2], b[3]];
    let a8 = || [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
    Some(match c {
        b'b' => f64::from(b[0] as i8),
        b'B' | b'M' => f64::from(b[0]),
        b'h' => f64::from(i16::from_le_bytes(a2())),
        b'H' => f64::from(u16::from_le_bytes(a2())),
        b'i' => f64::from(i32::from_le_bytes(a4())),
        b'I' => f64::from(u32::from_le_bytes(a4())),
        b'f' => f64::from(f32::from_le_bytes(a4())),
        b'd' => f64::from_le_bytes(a8()),
        b'q' => i64::from_le_bytes(a8()) as f64,
        b'Q' => u64::from_le_bytes(a8()) as f64,
        b'c' => f64::from(i16::from_le_bytes(a2())) * 0.01,
        b'C' => f64::from(u16::from_le_bytes(a2())) * 0.01,
        b'e' => f64::from(i32::from_le_bytes(a4())) * 0.01,
        b'E' => f64::from(u32::from_le_bytes(a4())) * 0.01,
        b'L' => f64::from(i32::from_le_bytes(a4())) * 1.0e-7,
        b'g' => half(u16::from_le_bytes(a2())),
        _ => return None,
    })
}

/// IEEE 754 binary16 to f64.
fn half(h: u16) -> f64 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = i32::from((h >> 10) & 0x1f);
    let fraction = f64::from(h & 0x3ff);
    sign * match exponent {
        0 => fraction * 2f64.powi(-24),
        31 if fraction == 0.0 => f64::INFINITY,
        31 => f64::NAN,
        e => (1.0 + fraction / 1024.0) * 2f64.powi(e - 15),
    }
}

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).into_owned()
}

/// A message type as its FMT describes it.
#[derive(Debug, Clone)]
struct Fmt {
    name: String,
    length: usize,
    /// (label, format char, offset in the payload) per field; empty when a character is unknown
    /// (the type is then skipped by its length, and refused only if it is needed).
    fields: Vec<(String, u8, usize)>,
    /// The format text, for messages.
    format: String,
}

impl Fmt {
    fn field(&self, label: &str) -> Option<(u8, usize)> {
        self.fields
            .iter()
            .find(|(l, _, _)| l == label)
            .map(|&(_, c, o)| (c, o))
    }
}

/// FMT's payload decoded and checked.
fn parse_fmt(payload: &[u8]) -> Result<(u8, Fmt), String> {
    let msg_type = payload[0];
    let length = payload[1] as usize;
    let name = text(&payload[2..6]);
    let format = text(&payload[6..22]);
    let labels = text(&payload[22..86]);
    if length < 3 {
        return Err(format!(
            "FMT of {name} (type {msg_type}): length {length} is shorter than the 3-byte header"
        ));
    }
    let sizes: Option<Vec<usize>> = format.bytes().map(size_of).collect();
    let mut fields = Vec::new();
    if let Some(sizes) = sizes {
        let total: usize = 3 + sizes.iter().sum::<usize>();
        if total != length {
            return Err(format!(
                "FMT of {name} (type {msg_type}): format '{format}' makes {total} bytes with the header, its length says {length}"
            ));
        }
        let labels: Vec<&str> = labels.split(',').collect();
        if labels.len() != sizes.len() {
            return Err(format!(
                "FMT of {name} (type {msg_type}): {} labels for {} format characters ('{format}')",
                labels.len(),
                sizes.len()
            ));
        }
        let mut offset = 0;
        for ((label, c), size) in labels.iter().zip(format.bytes()).zip(sizes) {
            fields.push((label.to_string(), c, offset));
            offset += size;
        }
    }
    if msg_type == FMT_TYPE && (length != FMT_LEN || name != "FMT") {
        return Err(format!(
            "FMT redefines type 128 as {name} of {length} bytes; type 128 is FMT, {FMT_LEN} bytes"
        ));
    }
    Ok((
        msg_type,
        Fmt {
            name,
            length,
            fields,
            format,
        },
    ))
}

/// What an IMU message type's fields are, found once per type.
#[derive(Debug, Clone, Copy)]
struct ImuLayout {
    /// (char, offset) of TimeUS, or of TimeMS (then `millis`).
    time: (u8, usize),
    millis: bool,
    instance: Option<(u8, usize)>,
    /// The instance of pre-4.0 `IMU2`/`IMU3` messages, which have no `I`.
    fixed_instance: u8,
    gyro: [(u8, usize); 3],
    accel: [(u8, usize); 3],
    temperature: Option<(u8, usize)>,
}

fn imu_layout(fmt: &Fmt) -> Result<ImuLayout, String> {
    if fmt.fields.is_empty() {
        return Err(format!(
            "{}: format '{}' has a character ArduPilot does not define, so its fields cannot be found",
            fmt.name, fmt.format
        ));
    }
    let need = |label: &str| {
        fmt.field(label).ok_or_else(|| {
            let labels: Vec<&str> = fmt.fields.iter().map(|(l, _, _)| l.as_str()).collect();
            format!("{} has no field {label} (fields: {})", fmt.name, labels.join(","))
        })
    };
    let (time, millis) = match fmt.field("TimeUS") {
        Some(t) => (t, false),
        None => (need("TimeMS")?, true),
    };
    Ok(ImuLayout {
        time,
        millis,
        instance: fmt.field("I"),
        fixed_instance: match fmt.name.as_str() {
            "IMU2" => 1,
            "IMU3" => 2,
            _ => 0,
        },
        gyro: [need("GyrX")?, need("GyrY")?, need("GyrZ")?],
        accel: [need("AccX")?, need("AccY")?, need("AccZ")?],
        temperature: fmt.field("T"),
    })
}

/// The parameter holding the device id of accelerometer `instance` (0-based).
fn device_id_param(instance: u8) -> String {
    match instance {
        0 => "INS_ACC_ID".into(),
        1 | 2 => format!("INS_ACC{}_ID", instance + 1),
        n => format!("INS{}_ACC_ID", n + 1),
    }
}

#[derive(Default)]
struct Imu {
    /// Accelerometer samples (with the temperature).
    series: Series,
    /// The gyro from the same messages.
    gyro: [Vec<f64>; 3],
    has_temperature: bool,
    /// The type names its messages came as (IMU, or IMU2 …).
    name: String,
}

pub(super) fn read(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<FlightRead, FlightError> {
    let corrupt = |offset: usize, what: String| FlightError::Corrupt {
        file: file.into(),
        offset: offset as u64,
        what,
    };
    let mut formats: BTreeMap<u8, (Fmt, Option<ImuLayout>)> = BTreeMap::new();
    let mut imus: BTreeMap<u8, Imu> = BTreeMap::new();
    // Every value each PARM name took, in order.
    let mut params: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut notes = Vec::new();
    let mut metadata = Vec::new();
    let mut pos = 0usize;
    while pos < bytes.len() {
        let step = (|| -> Result<Option<usize>, String> {
            if bytes.len() - pos < 3 {
                return Ok(None);
            }
            if bytes[pos..pos + 2] != HEAD {
                return Err(format!(
                    "expected a message header A3 95, found {:02X} {:02X}",
                    bytes[pos],
                    bytes[pos + 1]
                ));
            }
            let msg_type = bytes[pos + 2];
            let length = match (msg_type, formats.get(&msg_type)) {
                (FMT_TYPE, _) => FMT_LEN,
                (_, Some((fmt, _))) => fmt.length,
                (_, None) => return Err(format!("message type {msg_type} has no FMT before it")),
            };
            if bytes.len() - pos < length {
                return Ok(None);
            }
            let payload = &bytes[pos + 3..pos + length];
            if msg_type == FMT_TYPE {
                let (t, fmt) = parse_fmt(payload)?;
                let layout = match fmt.name.as_str() {
                    "IMU" | "IMU2" | "IMU3" => Some(imu_layout(&fmt)?),
                    _ => None,
                };
                formats.insert(t, (fmt, layout));
                return Ok(Some(length));
            }
            let Some((fmt, layout)) = formats.get(&msg_type) else {
                return Ok(Some(length));
            };
            if let Some(l) = layout {
                let value = |(c, o): (u8, usize)| number(c, &payload[o..]).unwrap_or(f64::NAN);
                let instance = match l.instance {
                    Some((c, o)) => match number(c, &payload[o..]) {
                        Some(i) if (0.0..=255.0).contains(&i) && i.fract() == 0.0 => i as u8,
                        other => return Err(format!("{}: instance I = {other:?} is not 0 to 255", fmt.name)),
                    },
                    None => l.fixed_instance,
                };
                let (c, o) = l.time;
                let raw = match c {
                    b'Q' | b'q' => u64::from_le_bytes(payload[o..o + 8].try_into().unwrap_or([0; 8])),
                    b'I' | b'i' => {
                        u64::from(u32::from_le_bytes(payload[o..o + 4].try_into().unwrap_or([0; 4])))
                    }
                    _ => {
                        return Err(format!(
                            "{}: its time field is format '{}', not an integer",
                            fmt.name,
                            char::from(c)
                        ))
                    }
                };
                let us = if l.millis { raw.saturating_mul(1000) } else { raw };
                let imu = imus.entry(instance).or_default();
                if imu.name.is_empty() {
                    imu.name = fmt.name.clone();
                }
                imu.series.us.push(us);
                imu.series.offset.push(pos as u64);
                for k in 0..3 {
                    imu.series.v[k].push(value(l.accel[k]));
                }
                for k in 0..3 {
                    imu.gyro[k].push(value(l.gyro[k]));
                }
                if let Some(t) = l.temperature {
                    imu.has_temperature = true;
                    imu.series.temperature.push(value(t));
                }
            } else if fmt.name == "PARM" {
                if let (Some((b'N', no)), Some((vc, vo))) = (fmt.field("Name"), fmt.field("Value")) {
                    let name = text(&payload[no..no + 16]);
                    if let Some(v) = number(vc, &payload[vo..]) {
                        params.entry(name).or_default().push(v);
                    }
                }
            } else if fmt.name == "MSG" {
                if let Some((b'Z', o)) = fmt.field("Message") {
                    let m = text(&payload[o..o + 64]);
                    if metadata.len() < 8 {
                        metadata.push(m);
                    }
                }
            }
            Ok(Some(length))
        })();
        match step {
            Ok(Some(length)) => pos += length,
            Ok(None) => {
                notes.push(format!(
                    "the log is cut short: its last message (byte {pos}) ends past the end of the file; the messages before it are read"
                ));
                break;
            }
            // Padding after the last message (a download's last block filled out) is no damage.
            Err(_) if bytes[pos..].iter().all(|&b| b == 0x00 || b == 0xFF) => {
                notes.push(format!(
                    "{} bytes of padding after the last message (byte {pos} on) ignored",
                    bytes.len() - pos
                ));
                break;
            }
            Err(what) if options.salvage && !imus.is_empty() => {
                notes.push(format!(
                    "salvaged: reading stopped at byte {pos} ({what}); the messages before it are read"
                ));
                break;
            }
            Err(what) => return Err(corrupt(pos, what)),
        }
    }
    assemble(imus, params, metadata, file, options, notes)
}

fn assemble(
    mut imus: BTreeMap<u8, Imu>,
    params: BTreeMap<String, Vec<f64>>,
    metadata: Vec<String>,
    file: &str,
    options: &ReadOptions,
    mut notes: Vec<String>,
) -> Result<FlightRead, FlightError> {
    let instances: Vec<u8> = imus.keys().copied().collect();
    let listing = if instances.is_empty() {
        "no IMU messages".to_string()
    } else {
        imus.iter()
            .map(|(i, imu)| format!("IMU[{i}] ({} messages)", imu.series.len()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let available = || listing.clone();
    let asked = options.topic.as_deref().map(parse_topic);
    let instance = match asked {
        None => match instances.first() {
            None => {
                return Err(FlightError::NoImu {
                    file: file.into(),
                    what: "no IMU messages (ArduPilot logs them unless LOG_BITMASK leaves IMU out)".into(),
                })
            }
            Some(&first) if first != 0 => {
                notes.push(format!("the log has no IMU instance 0: instance {first} read"));
                first
            }
            Some(&first) => first,
        },
        // Pre-4.0 names: IMU2 is the second IMU.
        Some((Some("IMU2"), None)) => 1,
        Some((Some("IMU3"), None)) => 2,
        Some((Some("IMU") | None, i)) => i.unwrap_or(0),
        Some(_) => {
            return Err(FlightError::NoInstance {
                file: file.into(),
                asked: options.topic.clone().unwrap_or_default(),
                available: available(),
            })
        }
    };
    let Some(mut imu) = imus.remove(&instance) else {
        return Err(FlightError::NoInstance {
            file: file.into(),
            asked: options.topic.clone().unwrap_or_else(|| instance.to_string()),
            available: available(),
        });
    };
    let sorted = imu.series.sort_with(&mut imu.gyro);
    if sorted {
        notes.push(format!("IMU[{instance}]: messages sorted by time"));
    }
    imu.series.check_finite(file, &format!("{} Acc", imu.name))?;
    let gyro = Series {
        us: Vec::new(),
        v: imu.gyro.clone(),
        temperature: Vec::new(),
        offset: imu.series.offset.clone(),
    };
    gyro.check_finite(file, &format!("{} Gyr", imu.name))?;
    let n = imu.series.len();
    if n < 2 {
        return Err(FlightError::TooFew {
            file: file.into(),
            what: format!("IMU[{instance}]"),
            found: n,
        });
    }
    let mut columns: Vec<String> = ["TimeUS", "AccX", "AccY", "AccZ", "GyrX", "GyrY", "GyrZ"]
        .iter()
        .map(|c| format!("{}.{c}", imu.name))
        .collect();
    let temperature = if imu.has_temperature && imu.series.temperature.len() == n {
        let t = finite_temperature(
            std::mem::take(&mut imu.series.temperature),
            &format!("{}.T", imu.name),
            &mut notes,
        );
        if t.is_some() {
            columns.push(format!("{}.T", imu.name));
        }
        t
    } else {
        notes.push(format!("{} has no T field: no temperature", imu.name));
        None
    };
    let others: Vec<String> = instances
        .iter()
        .filter(|&&i| i != instance)
        .map(|i| i.to_string())
        .collect();
    notes.push(format!(
        "ArduPilot DataFlash: IMU instance {instance} read{}; its values are ArduPilot's corrected readings (its accelerometer calibration, and INS_TCALn's when enabled, applied)",
        if others.is_empty() {
            String::new()
        } else {
            format!(" (also in the log: {}; choose with topic `IMU[N]`)", others.join(", "))
        }
    ));
    let param = device_id_param(instance);
    let (device_id, device_id_from) = match params.get(&param).map(Vec::as_slice) {
        Some([first, rest @ ..]) => {
            if rest.iter().any(|v| v != first) {
                notes.push(format!("{param} changes during the log: the first value is taken"));
            }
            if first.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(first) {
                let id = *first as u32;
                notes.push(format!("accelerometer device id {id} (PARM {param})"));
                (Some(id), format!("PARM {param}"))
            } else {
                notes.push(format!("PARM {param} = {first} is not a device id"));
                (None, format!("PARM {param} (not a whole number: {first})"))
            }
        }
        _ => (
            None,
            format!("not in this log: IMU messages carry none; ArduPilot keeps it in the parameter {param}, logged as a PARM message"),
        ),
    };
    let us = imu.series.us.clone();
    Ok(FlightRead {
        recording: recording(
            file,
            &us,
            imu.series.v,
            Some(imu.gyro),
            temperature,
            columns,
            metadata,
        ),
        log: FlightLog {
            stack: FlightStack::ArduPilot,
            source: "IMU".into(),
            instance,
            instances,
            device_id,
            device_id_from,
        },
        notes,
    })
}
