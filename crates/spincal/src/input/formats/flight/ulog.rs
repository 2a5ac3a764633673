//! PX4 ULog (<https://docs.px4.io/main/en/dev_log/ulog_file_format.html>) through `px4-ulog`,
//! PX4's own Rust parser: of the ULog crates it is the one PX4 maintains, it depends on byteorder
//! alone and builds on Rust 1.88 (ulog-rs 0.0.4 is a pre-release that pulls clap and dirs into
//! the library; yule_log 0.4 pulls env_logger and lazy_static). The crate decodes the formats
//! ('F', nested types, arrays, trailing padding) and the data ('D').
//!
//! The records are framed here, one at a time, so that an error names the byte offset of its
//! record, appended data sections are followed, and two record kinds px4-ulog 0.6.1 indexes
//! without a length check ('A' shorter than 3 bytes, 'P' whose key runs past its end) are refused
//! before they reach it: spincal never panics on input.
//!
//! Samples: `sensor_accel` (x, y, z in m/s², `temperature` in °C, `device_id`) with the
//! `sensor_gyro` of the same device id (rad/s), both at `timestamp_sample` (µs; `timestamp`
//! where a log has no sample stamp); else `sensor_combined` (accelerometer_m_s2, gyro_rad at
//! timestamp + accelerometer_timestamp_relative; no temperature).

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;

use px4_ulog::stream_parser::model::{DataMessage, FieldLookupError, InfoMessage};
use px4_ulog::stream_parser::{LogParser, ParseableFieldType};

use super::{
    finite_temperature, gyro_on_accel_stamps, parse_topic, recording, FlightError, FlightLog, FlightRead,
    FlightStack, Series, ULOG_MAGIC,
};
use crate::input::formats::ReadOptions;

/// Header: magic (7 bytes), version (1), start timestamp (u64).
const HEADER_LEN: usize = 16;
/// sensor_combined's accelerometer_timestamp_relative when the message carries no accelerometer
/// sample (PX4's RELATIVE_TIMESTAMP_INVALID).
const RELATIVE_TIMESTAMP_INVALID: i32 = 0x7fff_ffff;

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Topic {
    Accel,
    Gyro,
}

impl Topic {
    fn name(self) -> &'static str {
        match self {
            Topic::Accel => "sensor_accel",
            Topic::Gyro => "sensor_gyro",
        }
    }
}

/// One `sensor_accel` or `sensor_gyro` instance.
#[derive(Default)]
struct Sensor {
    series: Series,
    /// Each message's device id, when the topic has the field.
    device_ids: Vec<u32>,
    /// `timestamp_sample`, or `timestamp` in logs without it.
    stamp: &'static str,
    has_temperature: bool,
}

/// `sensor_combined`: accelerometer stamps and values, the gyro beside them.
#[derive(Default)]
struct Combined {
    accel: Series,
    gyro: [Vec<f64>; 3],
    /// accelerometer_timestamp_relative of each kept message, µs.
    relative_us: Vec<i32>,
    /// Messages whose accelerometer part is marked invalid.
    invalid: usize,
}

#[derive(Default)]
struct Collector {
    file: String,
    sensors: BTreeMap<(Topic, u8), Sensor>,
    combined: Combined,
    /// sensor_selection.accel_device_id, each distinct value in order.
    selected_ids: Vec<u32>,
    /// Messages per topic name (for the error when no IMU topic is there).
    counts: BTreeMap<String, usize>,
    metadata: Vec<String>,
    error: Option<FlightError>,
}

/// A field's value, `None` when the topic lacks it; a field of another type is an error.
fn field<T: ParseableFieldType>(m: &DataMessage, name: &str) -> Result<Option<T>, String> {
    match m.flattened_format.get_field_parser::<T>(name) {
        // The crate checked the message's size against its format, which holds this field.
        Ok(p) => Ok(Some(p.parse(m.data))),
        Err(FieldLookupError::MissingField) => Ok(None),
        Err(FieldLookupError::TypeMismatch) => Err(format!(
            "{}.{name} has another type than PX4 logs ({})",
            m.flattened_format.message_name(),
            std::any::type_name::<T>()
        )),
    }
}

fn required<T: ParseableFieldType>(m: &DataMessage, name: &str) -> Result<T, String> {
    field(m, name)?.ok_or_else(|| {
        let fields: Vec<&str> = m
            .flattened_format
            .field_iter()
            .map(|f| f.flattened_field_name.as_str())
            .collect();
        format!(
            "{} has no field {name} (fields: {})",
            m.flattened_format.message_name(),
            fields.join(", ")
        )
    })
}

impl Collector {
    fn data(&mut self, m: &DataMessage, offset: u64) {
        if self.error.is_some() {
            return;
        }
        let name = m.flattened_format.message_name();
        *self.counts.entry(name.to_string()).or_default() += 1;
        let result = match name {
            "sensor_accel" => self.sensor(Topic::Accel, m, offset),
            "sensor_gyro" => self.sensor(Topic::Gyro, m, offset),
            "sensor_combined" => self.combined(m, offset),
            "sensor_selection" => field::<u32>(m, "accel_device_id").map(|id| {
                if let Some(id) = id.filter(|&id| self.selected_ids.last() != Some(&id)) {
                    self.selected_ids.push(id);
                }
            }),
            _ => Ok(()),
        };
        if let Err(what) = result {
            self.error = Some(FlightError::Corrupt {
                file: self.file.clone(),
                offset,
                what,
            });
        }
    }

    fn sensor(&mut self, topic: Topic, m: &DataMessage, offset: u64) -> Result<(), String> {
        let (stamp, t) = match field::<u64>(m, "timestamp_sample")? {
            Some(t) => ("timestamp_sample", t),
            None => ("timestamp", required::<u64>(m, "timestamp")?),
        };
        let v = [
            required::<f32>(m, "x")?,
            required::<f32>(m, "y")?,
            required::<f32>(m, "z")?,
        ];
        let temperature = field::<f32>(m, "temperature")?;
        let device_id = field::<u32>(m, "device_id")?;
        let s = self.sensors.entry((topic, m.multi_id.value())).or_default();
        s.stamp = stamp;
        s.series.us.push(t);
        for k in 0..3 {
            s.series.v[k].push(f64::from(v[k]));
        }
        s.series.offset.push(offset);
        if let Some(temp) = temperature {
            s.has_temperature = true;
            s.series.temperature.push(f64::from(temp));
        }
        if let Some(id) = device_id {
            s.device_ids.push(id);
        }
        Ok(())
    }

    fn combined(&mut self, m: &DataMessage, offset: u64) -> Result<(), String> {
        let t = required::<u64>(m, "timestamp")?;
        let relative = required::<i32>(m, "accelerometer_timestamp_relative")?;
        let c = &mut self.combined;
        if relative == RELATIVE_TIMESTAMP_INVALID {
            c.invalid += 1;
            return Ok(());
        }
        let at = t.checked_add_signed(i64::from(relative)).ok_or_else(|| {
            format!("sensor_combined: timestamp {t} µs + accelerometer_timestamp_relative {relative} µs is before the clock's start")
        })?;
        let mut a = [0.0; 3];
        let mut g = [0.0; 3];
        for k in 0..3 {
            a[k] = f64::from(required::<f32>(m, &format!("accelerometer_m_s2[{k}]"))?);
            g[k] = f64::from(required::<f32>(m, &format!("gyro_rad[{k}]"))?);
        }
        c.accel.us.push(at);
        c.accel.offset.push(offset);
        c.relative_us.push(relative);
        for k in 0..3 {
            c.accel.v[k].push(a[k]);
            c.gyro[k].push(g[k]);
        }
        Ok(())
    }

    fn info(&mut self, m: &InfoMessage) {
        // The system's names (sys_name, ver_hw, ver_sw …) are text; other info is not kept.
        if m.type_str.starts_with("char[") && (m.key == "sys_name" || m.key.starts_with("ver_")) {
            if let Ok(text) = std::str::from_utf8(m.value) {
                self.metadata
                    .push(format!("{}: {}", m.key, text.trim_end_matches('\0')));
            }
        }
    }
}

/// px4-ulog's error without the format dump some of its messages append.
fn one_line(text: &str) -> String {
    let end = [text.find(", format:"), text.find('\n')]
        .into_iter()
        .flatten()
        .min();
    let short = &text[..end.unwrap_or(text.len())];
    short.chars().take(300).collect()
}

/// Refuses the records px4-ulog 0.6.1 would index past their end.
fn unchecked_record(kind: u8, payload: &[u8]) -> Option<String> {
    match kind {
        b'A' if payload.len() < 3 => Some(format!(
            "add_logged message ('A') of {} bytes; it needs at least 3 (multi_id, msg_id)",
            payload.len()
        )),
        b'P' => match payload.first() {
            None => Some("parameter message ('P') with no key".into()),
            Some(&key_len) if 1 + key_len as usize > payload.len() => Some(format!(
                "parameter message ('P'): its key of {key_len} bytes runs past its {} bytes",
                payload.len()
            )),
            Some(_) => None,
        },
        _ => None,
    }
}

/// Where each data section starts and ends: [start, end) pairs, the definitions' section from the
/// header and any appended section from the flag bits message's offsets.
fn sections(bytes: &[u8], file: &str) -> Result<Vec<(usize, usize)>, FlightError> {
    let b = &bytes[HEADER_LEN..];
    // The flag bits message ('B', 40 bytes at least) comes first when the log has one.
    let mut appended = Vec::new();
    if b.len() >= 3 + 40 && b[2] == b'B' {
        let incompat0 = b[3 + 8];
        if incompat0 & 1 == 1 {
            for k in 0..3 {
                let at = 3 + 16 + 8 * k;
                let mut v = [0u8; 8];
                v.copy_from_slice(&b[at..at + 8]);
                let offset = u64::from_le_bytes(v);
                if offset != 0 {
                    appended.push(offset);
                }
            }
        }
    }
    let mut starts = vec![HEADER_LEN];
    for &offset in &appended {
        let previous = *starts.last().unwrap_or(&HEADER_LEN);
        match usize::try_from(offset) {
            Ok(o) if o > previous && o <= bytes.len() => starts.push(o),
            _ => {
                return Err(FlightError::Corrupt {
                    file: file.into(),
                    offset: (HEADER_LEN + 3 + 16) as u64,
                    what: format!(
                        "the flag bits message says data is appended at byte {offset}, which is not after byte {previous} and within the file's {} bytes",
                        bytes.len()
                    ),
                })
            }
        }
    }
    let ends = starts.iter().skip(1).copied().chain([bytes.len()]);
    Ok(starts.iter().copied().zip(ends).collect())
}

pub(super) fn read(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<FlightRead, FlightError> {
    let corrupt = |offset: usize, what: String| FlightError::Corrupt {
        file: file.into(),
        offset: offset as u64,
        what,
    };
    if bytes.len() < HEADER_LEN || !bytes.starts_with(ULOG_MAGIC) {
        return Err(corrupt(
            0,
            format!(
                "not a ULog file: it must start with the 16-byte header 'ULog' 01 12 35, version, timestamp ({} bytes)",
                bytes.len()
            ),
        ));
    }
    let sections = sections(bytes, file)?;
    let offset = Cell::new(0u64);
    let collector = RefCell::new(Collector {
        file: file.into(),
        ..Collector::default()
    });
    let mut notes = Vec::new();
    {
        let mut on_data = |m: &DataMessage| collector.borrow_mut().data(m, offset.get());
        let mut on_info = |m: &InfoMessage| collector.borrow_mut().info(m);
        let mut parser = LogParser::default();
        parser.set_data_message_callback(&mut on_data);
        parser.set_info_message_callback(&mut on_info);
        parser
            .consume_bytes(&bytes[..HEADER_LEN])
            .map_err(|e| corrupt(0, e.description))?;
        'sections: for (k, &(start, end)) in sections.iter().enumerate() {
            let mut pos = start;
            while pos < end {
                let cut = |pos: usize| {
                    format!(
                        "the log is cut short: its last message (byte {pos}) ends past the end of the {}; the messages before it are read",
                        if k == 0 && sections.len() == 1 { "file".to_string() } else { format!("data section at byte {start}") }
                    )
                };
                if end - pos < 3 {
                    notes.push(cut(pos));
                    break;
                }
                let size = u16::from_le_bytes([bytes[pos], bytes[pos + 1]]) as usize;
                let kind = bytes[pos + 2];
                let next = pos + 3 + size;
                if next > end {
                    notes.push(cut(pos));
                    break;
                }
                let refused = unchecked_record(kind, &bytes[pos + 3..next]).map_or_else(
                    || {
                        offset.set(pos as u64);
                        parser.consume_bytes(&bytes[pos..next]).err().map(|e| {
                            format!(
                                "'{}' message: {}",
                                char::from(kind).escape_default(),
                                one_line(&e.to_string())
                            )
                        })
                    },
                    Some,
                );
                if let Some(what) = refused {
                    if options.salvage && parser.in_data() {
                        notes.push(format!(
                            "salvaged: reading stopped at byte {pos} ({what}); the messages before it are read"
                        ));
                        break 'sections;
                    }
                    return Err(corrupt(pos, what));
                }
                if let Some(e) = collector.borrow_mut().error.take() {
                    return Err(e);
                }
                pos = next;
            }
        }
    }
    assemble(collector.into_inner(), file, options, notes)
}

fn listing(c: &Collector) -> String {
    let mut parts: Vec<String> = c
        .sensors
        .keys()
        .map(|(t, i)| format!("{} {i}", t.name()))
        .collect();
    if !c.combined.accel.us.is_empty() || c.combined.invalid > 0 {
        parts.push("sensor_combined 0".into());
    }
    if parts.is_empty() {
        "none".into()
    } else {
        parts.join(", ")
    }
}

fn assemble(
    mut c: Collector,
    file: &str,
    options: &ReadOptions,
    mut notes: Vec<String>,
) -> Result<FlightRead, FlightError> {
    let (asked_name, asked_instance) = options.topic.as_deref().map(parse_topic).unwrap_or((None, None));
    let no_instance = |c: &Collector| FlightError::NoInstance {
        file: file.into(),
        asked: options.topic.clone().unwrap_or_default(),
        available: listing(c),
    };
    let accel_instances: Vec<u8> = c
        .sensors
        .keys()
        .filter(|(t, _)| *t == Topic::Accel)
        .map(|&(_, i)| i)
        .collect();
    let combined = match asked_name {
        None => accel_instances.is_empty(),
        Some("sensor_accel" | "sensor_gyro") => false,
        Some("sensor_combined") => true,
        Some(_) => return Err(no_instance(&c)),
    };
    if combined {
        let none_logged = c.combined.accel.us.is_empty() && c.combined.invalid == 0;
        if asked_instance.is_some_and(|i| i != 0) || (asked_name.is_some() && none_logged) {
            return Err(no_instance(&c));
        }
        return read_combined(c, file, notes);
    }
    let Some(&lowest) = accel_instances.first() else {
        return Err(no_instance(&c));
    };
    let instance = match asked_instance {
        Some(i) if accel_instances.contains(&i) => i,
        Some(_) => return Err(no_instance(&c)),
        None if accel_instances.contains(&0) => 0,
        None => {
            notes.push(format!("sensor_accel has no instance 0: instance {lowest} read"));
            lowest
        }
    };
    let mut accel = c.sensors.remove(&(Topic::Accel, instance)).unwrap_or_default();
    let device_id = accel.device_ids.first().copied();
    if let Some(id) = device_id {
        if accel.device_ids.iter().any(|&d| d != id) {
            notes.push(format!(
                "sensor_accel instance {instance}: the device id changes during the log (first {id})"
            ));
        }
    }
    // The gyro of the same chip: PX4's IMU drivers give both sensors one device id; else the same
    // instance number.
    let gyro_key = c
        .sensors
        .iter()
        .find(|((t, _), s)| {
            *t == Topic::Gyro && device_id.is_some() && s.device_ids.first().copied() == device_id
        })
        .map(|(k, _)| *k)
        .or_else(|| {
            c.sensors
                .contains_key(&(Topic::Gyro, instance))
                .then_some((Topic::Gyro, instance))
        });
    let mut gyro = gyro_key.and_then(|k| c.sensors.remove(&k));
    if accel.series.sort() {
        notes.push(format!(
            "sensor_accel instance {instance}: messages sorted by {}",
            accel.stamp
        ));
    }
    accel.series.check_finite(file, "sensor_accel")?;
    let mut source = "sensor_accel".to_string();
    let mut columns = vec![
        format!("sensor_accel.{}", accel.stamp),
        "sensor_accel.x".into(),
        "sensor_accel.y".into(),
        "sensor_accel.z".into(),
    ];
    let (kept, gyro_values) = match (&mut gyro, gyro_key) {
        (Some(g), Some((_, gi))) => {
            if g.series.sort() {
                notes.push(format!(
                    "sensor_gyro instance {gi}: messages sorted by {}",
                    g.stamp
                ));
            }
            g.series.check_finite(file, "sensor_gyro")?;
            let (kept, values, [equal, interpolated, dropped]) =
                gyro_on_accel_stamps(&accel.series.us, &g.series);
            let by = match (g.device_ids.first(), device_id) {
                (Some(a), Some(b)) if *a == b => format!("device id {a}, the accelerometer's"),
                (Some(a), Some(b)) => format!(
                    "by instance number; its device id {a} is not the accelerometer's {b}: check that they are one chip"
                ),
                _ => "by instance number".into(),
            };
            notes.push(format!(
                "gyro: sensor_gyro instance {gi} ({by}) on the accelerometer's stamps: {equal} equal, {interpolated} interpolated, {dropped} accelerometer samples outside the gyro's span dropped"
            ));
            source.push_str(" + sensor_gyro");
            columns.extend(["sensor_gyro.x", "sensor_gyro.y", "sensor_gyro.z"].map(String::from));
            (kept, Some(values))
        }
        _ => {
            notes.push(format!(
                "no sensor_gyro for sensor_accel instance {instance}: the gyro is not read"
            ));
            ((0..accel.series.len()).collect(), None)
        }
    };
    let pick = |x: &[f64]| kept.iter().map(|&i| x[i]).collect::<Vec<f64>>();
    let us: Vec<u64> = kept.iter().map(|&i| accel.series.us[i]).collect();
    if us.len() < 2 {
        return Err(FlightError::TooFew {
            file: file.into(),
            what: format!("{source} instance {instance}"),
            found: us.len(),
        });
    }
    let temperature = if accel.has_temperature && accel.series.temperature.len() == accel.series.len() {
        let t = finite_temperature(
            pick(&accel.series.temperature),
            "sensor_accel.temperature",
            &mut notes,
        );
        if t.is_some() {
            columns.push("sensor_accel.temperature".into());
        }
        t
    } else {
        notes.push("sensor_accel has no temperature field: no temperature".into());
        None
    };
    let accel_values = [
        pick(&accel.series.v[0]),
        pick(&accel.series.v[1]),
        pick(&accel.series.v[2]),
    ];
    let others: Vec<String> = accel_instances
        .iter()
        .filter(|&&i| i != instance)
        .map(|i| i.to_string())
        .collect();
    notes.push(format!(
        "PX4 ULog: sensor_accel instance {instance} read{}; time from {} (µs)",
        if others.is_empty() {
            String::new()
        } else {
            format!(
                " (also in the log: {}; choose with topic `sensor_accel_N`)",
                others.join(", ")
            )
        },
        accel.stamp
    ));
    let combined_n = c.combined.accel.len();
    if combined_n > 2 * us.len() {
        notes.push(format!(
            "sensor_combined has {combined_n} samples against sensor_accel's {} (PX4 logs the sensor topics slowly unless told to): topic `sensor_combined` reads them, PX4's corrected values without a temperature",
            us.len()
        ));
    }
    let device_id_from = match device_id {
        Some(id) => {
            notes.push(format!(
                "accelerometer device id {id} (sensor_accel.device_id): PX4's CAL_ACCn_ID and TC_An_ID for it"
            ));
            "sensor_accel.device_id".to_string()
        }
        None => "not in this log's sensor_accel; PX4 keeps it in the CAL_ACCn_ID parameters".to_string(),
    };
    let metadata = std::mem::take(&mut c.metadata);
    Ok(FlightRead {
        recording: recording(
            file,
            &us,
            accel_values,
            gyro_values,
            temperature,
            columns,
            metadata,
        ),
        log: FlightLog {
            stack: FlightStack::Px4,
            source,
            instance,
            instances: accel_instances,
            device_id,
            device_id_from,
        },
        notes,
    })
}

fn read_combined(c: Collector, file: &str, mut notes: Vec<String>) -> Result<FlightRead, FlightError> {
    let Collector {
        combined: mut comb,
        selected_ids,
        metadata,
        counts,
        ..
    } = c;
    if comb.accel.us.is_empty() && comb.invalid == 0 {
        let topics: Vec<String> = counts.iter().map(|(n, k)| format!("{n} ({k})")).collect();
        return Err(FlightError::NoImu {
            file: file.into(),
            what: format!(
                "no sensor_accel, sensor_gyro or sensor_combined messages (topics logged: {})",
                if topics.is_empty() {
                    "none".into()
                } else {
                    topics.join(", ")
                }
            ),
        });
    }
    if comb.invalid > 0 {
        notes.push(format!(
            "sensor_combined: {} messages without an accelerometer sample (accelerometer_timestamp_relative invalid) left out",
            comb.invalid
        ));
    }
    // The gyro and the relative stamp ride with their message.
    let n = comb.accel.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&k| comb.accel.us[k]);
    if comb.accel.sort_with(&mut comb.gyro) {
        notes.push("sensor_combined: messages sorted by accelerometer time".into());
        comb.relative_us = order.iter().map(|&k| comb.relative_us[k]).collect();
    }
    comb.accel
        .check_finite(file, "sensor_combined.accelerometer_m_s2")?;
    let gyro = Series {
        us: comb.accel.us.clone(),
        v: comb.gyro,
        temperature: Vec::new(),
        offset: comb.accel.offset.clone(),
    };
    gyro.check_finite(file, "sensor_combined.gyro_rad")?;
    if n < 2 {
        return Err(FlightError::TooFew {
            file: file.into(),
            what: "sensor_combined".into(),
            found: n,
        });
    }
    let mut relative = comb.relative_us.clone();
    relative.sort_unstable();
    notes.push(format!(
        "PX4 ULog: sensor_combined read (no sensor_accel in the log); time = timestamp + accelerometer_timestamp_relative (µs); the gyro in each message was sampled {} µs from its accelerometer (median)",
        -i64::from(relative[relative.len() / 2])
    ));
    notes.push(
        "sensor_combined holds PX4's corrected values (its calibration, rotation and thermal compensation applied), not the sensor's own".into(),
    );
    notes.push(
        "no temperature: sensor_combined carries none (the thermal path needs sensor_accel, whose temperature field PX4 logs with the sensor topics)".into(),
    );
    let (device_id, device_id_from) = match selected_ids.as_slice() {
        [] => (
            None,
            "not in this log: PX4 logs it in sensor_accel.device_id and sensor_selection.accel_device_id, and keeps it in the CAL_ACCn_ID parameters".to_string(),
        ),
        [id, rest @ ..] => {
            if !rest.is_empty() {
                notes.push(format!(
                    "sensor_selection.accel_device_id changes during the log ({id}, then {}): the device id is the first",
                    rest.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
                ));
            }
            notes.push(format!(
                "accelerometer device id {id} (sensor_selection.accel_device_id): PX4's CAL_ACCn_ID and TC_An_ID for it"
            ));
            (Some(*id), "sensor_selection.accel_device_id".to_string())
        }
    };
    let columns = [
        "sensor_combined.timestamp+accelerometer_timestamp_relative",
        "sensor_combined.accelerometer_m_s2[0]",
        "sensor_combined.accelerometer_m_s2[1]",
        "sensor_combined.accelerometer_m_s2[2]",
        "sensor_combined.gyro_rad[0]",
        "sensor_combined.gyro_rad[1]",
        "sensor_combined.gyro_rad[2]",
    ]
    .map(String::from)
    .to_vec();
    Ok(FlightRead {
        recording: recording(
            file,
            &comb.accel.us,
            comb.accel.v,
            Some(gyro.v),
            None,
            columns,
            metadata,
        ),
        log: FlightLog {
            stack: FlightStack::Px4,
            source: "sensor_combined".into(),
            instance: 0,
            instances: vec![0],
            device_id,
            device_id_from,
        },
        notes,
    })
}
