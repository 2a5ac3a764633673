//! ROS bags: `sensor_msgs/Imu` (or a `geometry_msgs/Vector3Stamped` accelerometer topic with its
//! gyro topic) read from ROS 2 bags (MCAP or sqlite3 storage) and ROS 1 bags (format 2.0).
//!
//! One pass over the bag: every topic is counted, the IMU-shaped topics (or only the one asked
//! for) are decoded as they come ([`Collector`]); then one topic is chosen (`choose`) and turned
//! into a [`Recording`] (`assemble`). Storage readers (`mcap`, `sqlite`, `ros1`) only walk records
//! and hand each message with a lazily formatted location to the collector, so a message that
//! does not decode is reported with the file, the storage location (byte offset, chunk, row id),
//! the topic and the message's index in it.
//!
//! Time: the header stamps (ns), or the receive (log) times when every stamp of the topic is
//! zero; samples sorted by time (stable); `time_s` counts from the first sample, and the absolute
//! start is kept in the metadata (epoch seconds in an f64 would lose 0.2 µs). Units are REP-103's
//! (m/s², rad/s), as the messages carry them.

pub mod mcap;
pub mod msg;
pub mod ros1;
pub mod sqlite;

use std::collections::HashMap;
use std::path::Path;

use crate::input::formats::bag_detect::Storage;
use crate::input::recording::{Recording, Source};
use msg::{Encoding, MsgKind};

/// Everything that can go wrong reading a bag. Each names the file, and where inside it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// The storage itself is damaged or cut short.
    #[error("{file}: {at}: {what}")]
    Corrupt { file: String, at: String, what: String },
    /// One message does not decode as its type.
    #[error("{file}: topic {topic}, message {index} ({at}): {what}")]
    Message {
        file: String,
        topic: String,
        /// 1-based index of the message within its topic.
        index: u64,
        at: String,
        what: String,
    },
    #[error("{file}: sqlite3 storage: {what}: {source}")]
    Sqlite {
        file: String,
        what: String,
        #[source]
        source: rusqlite::Error,
    },
    #[error("{file}: {what}")]
    Unsupported { file: String, what: String },
    #[error("{file}: no IMU topic (sensor_msgs/Imu, or geometry_msgs/Vector3Stamped accelerometer [+ gyro]); topics: {topics}")]
    NoImuTopic { file: String, topics: String },
    #[error("{file}: {count} IMU topics; choose one with --topic: {topics}")]
    SeveralTopics {
        file: String,
        count: usize,
        topics: String,
    },
    #[error("{file}: no IMU topic '{topic}'; IMU topics: {topics}")]
    NoSuchTopic {
        file: String,
        topic: String,
        topics: String,
    },
    #[error("{file}: topic {topic} has {found} messages; at least 2 are needed")]
    TooFew {
        file: String,
        topic: String,
        found: usize,
    },
}

/// A topic as the bag lists it, with its message count.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicInfo {
    pub name: String,
    /// Message type as stored (`sensor_msgs/msg/Imu`, `sensor_msgs/Imu`, …).
    pub msgtype: String,
    /// Serialisation name as stored (`cdr`, `ros1`, …).
    pub encoding: String,
    pub count: u64,
}

impl TopicInfo {
    fn kind(&self) -> Option<MsgKind> {
        MsgKind::from_type(&self.msgtype)
    }
    fn looks_like(&self, words: &[&str]) -> bool {
        let lower = self.name.to_ascii_lowercase();
        words.iter().any(|w| lower.contains(w))
    }
}

/// The decoded messages of one topic.
#[derive(Debug, Default)]
struct Series {
    stamps: Vec<i64>,
    log: Vec<u64>,
    v: [Vec<f64>; 3],
    g: [Vec<f64>; 3],
    accel_missing: usize,
    gyro_missing: usize,
    frame_id: Option<String>,
    error: Option<BagError>,
}

/// Counts every topic's messages and decodes the wanted IMU-shaped ones, as the storage reader
/// hands them over.
pub struct Collector {
    file: String,
    wanted: Option<Vec<String>>,
    topics: Vec<TopicInfo>,
    encodings: Vec<Option<Encoding>>,
    kinds: Vec<Option<MsgKind>>,
    series: Vec<Option<Series>>,
    by_key: HashMap<(String, String), usize>,
    /// Read the messages before damage at the end of the file instead of refusing it.
    salvage: bool,
    /// Where reading stopped at such damage, and why (with `salvage`).
    salvaged: Option<String>,
}

impl Collector {
    fn new(file: &str, topic: Option<&str>, salvage: bool) -> Collector {
        Collector {
            file: file.to_string(),
            wanted: topic.map(|t| t.split(',').map(|s| s.trim().to_string()).collect()),
            topics: Vec::new(),
            encodings: Vec::new(),
            kinds: Vec::new(),
            series: Vec::new(),
            by_key: HashMap::new(),
            salvage,
            salvaged: None,
        }
    }

    /// The end of the file is damaged (cut inside a record, or its footer or index lost) at a
    /// place where every message before it is whole: with `salvage`, reading stops there and says
    /// so; otherwise the refusal says how many messages are intact and how to read them.
    fn damaged_end(&mut self, error: BagError) -> Result<(), BagError> {
        let intact: u64 = self.topics.iter().map(|t| t.count).sum();
        if self.salvage {
            self.salvaged = Some(format!("{error}; the {intact} messages before it were read"));
            return Ok(());
        }
        Err(match error {
            BagError::Corrupt { file, at, what } if intact > 0 => BagError::Corrupt {
                file,
                at,
                what: format!(
                    "{what}; the {intact} messages before it are intact: read them with salvage (--salvage)"
                ),
            },
            other => other,
        })
    }

    /// Registers a topic (or finds it again: ROS 1 bags and split ROS 2 bags repeat connections)
    /// and returns its handle for [`Collector::message`].
    pub fn topic(&mut self, name: &str, msgtype: &str, encoding: &str) -> usize {
        let key = (name.to_string(), msgtype.to_string());
        if let Some(&i) = self.by_key.get(&key) {
            return i;
        }
        let info = TopicInfo {
            name: name.into(),
            msgtype: msgtype.into(),
            encoding: encoding.into(),
            count: 0,
        };
        let enc = match encoding {
            "cdr" => Some(Encoding::Cdr),
            "ros1" => Some(Encoding::Ros1),
            _ => None,
        };
        let info_kind = info.kind();
        // A temperature topic is read whatever IMU topic is chosen: it goes beside it.
        let wanted = self.wanted.as_ref().is_none_or(|w| w.iter().any(|t| t == name))
            || info_kind == Some(MsgKind::Temperature);
        let series = (wanted && info_kind.is_some() && enc.is_some()).then(Series::default);
        self.topics.push(info);
        self.encodings.push(enc);
        self.kinds.push(info_kind);
        self.series.push(series);
        self.by_key.insert(key, self.topics.len() - 1);
        self.topics.len() - 1
    }

    /// One message of topic `topic` received at `log_ns`; `at` says where it is in the file.
    pub fn message(&mut self, topic: usize, log_ns: u64, data: &[u8], at: &dyn Fn() -> String) {
        let info = &mut self.topics[topic];
        info.count += 1;
        let Some(series) = self.series[topic].as_mut() else {
            return;
        };
        if series.error.is_some() {
            return;
        }
        let (Some(kind), Some(encoding)) = (self.kinds[topic], self.encodings[topic]) else {
            return;
        };
        match msg::decode(data, encoding, kind) {
            Ok(d) => {
                series.stamps.push(d.stamp_ns);
                series.log.push(log_ns);
                for k in 0..3 {
                    series.v[k].push(d.vector[k]);
                }
                if let Some(w) = d.angular_velocity {
                    for k in 0..3 {
                        series.g[k].push(w[k]);
                    }
                }
                series.accel_missing += usize::from(d.accel_cov0 == -1.0);
                series.gyro_missing += usize::from(d.gyro_cov0 == -1.0);
                if series.frame_id.is_none() {
                    series.frame_id = Some(d.frame_id);
                }
            }
            Err(e) => {
                series.error = Some(BagError::Message {
                    file: self.file.clone(),
                    topic: info.name.clone(),
                    index: info.count,
                    at: at(),
                    what: e.to_string(),
                })
            }
        }
    }

    /// Every topic seen, in the order the bag first named them.
    pub fn topics(&self) -> &[TopicInfo] {
        &self.topics
    }
}

/// What [`choose`] picked: an `Imu` topic, or accelerometer (+ gyro) `Vector3Stamped` topics.
#[derive(Debug, Clone, PartialEq)]
enum Choice {
    Imu(usize),
    Vectors { accel: usize, gyro: Option<usize> },
}

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
fn decompress_chunk(kind: &str, data: &[u8], size: usize) -> Result<Vec<u8>, String> {
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

fn describe(c: &Collector, choice: &Choice) -> String {
    let t = |i: usize| {
        let info = &c.topics[i];
        format!("{} ({}, {} messages)", info.name, info.msgtype, info.count)
    };
    match choice {
        Choice::Imu(i) => t(*i),
        Choice::Vectors { accel, gyro: None } => t(*accel),
        Choice::Vectors { accel, gyro: Some(g) } => format!(
            "{},{} = {} + {}",
            c.topics[*accel].name,
            c.topics[*g].name,
            t(*accel),
            t(*g)
        ),
    }
}

/// The IMU candidates: every `Imu` topic, and the `Vector3Stamped` accelerometer topic paired with
/// the gyro topic when the names say which is which (one of each).
fn candidates(c: &Collector) -> Vec<Choice> {
    let mut out = Vec::new();
    let mut accels = Vec::new();
    let mut gyros = Vec::new();
    for (i, t) in c.topics.iter().enumerate() {
        match t.kind() {
            Some(MsgKind::Imu) => out.push(Choice::Imu(i)),
            Some(MsgKind::Vector3Stamped) => {
                if t.looks_like(&["gyr", "angular", "ang_vel"]) {
                    gyros.push(i)
                } else if t.looks_like(&["acc"]) {
                    accels.push(i)
                }
            }
            Some(MsgKind::Temperature) | None => {}
        }
    }
    match (accels.as_slice(), gyros.as_slice()) {
        ([a], [g]) => out.push(Choice::Vectors {
            accel: *a,
            gyro: Some(*g),
        }),
        _ => out.extend(accels.iter().map(|&a| Choice::Vectors { accel: a, gyro: None })),
    }
    out
}

fn choose(c: &Collector, topic: Option<&str>) -> Result<Choice, BagError> {
    let file = c.file.clone();
    let all = candidates(c);
    let list = |v: &[Choice]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.iter().map(|ch| describe(c, ch)).collect::<Vec<_>>().join("; ")
        }
    };
    let find = |name: &str, kind: MsgKind| {
        c.topics
            .iter()
            .position(|t| t.name == name && t.kind() == Some(kind))
    };
    match topic {
        Some(spec) => {
            let names: Vec<&str> = spec.split(',').map(str::trim).collect();
            let missing = || BagError::NoSuchTopic {
                file: file.clone(),
                topic: spec.to_string(),
                topics: list(&all),
            };
            match names.as_slice() {
                [one] => find(one, MsgKind::Imu)
                    .map(Choice::Imu)
                    .or_else(|| {
                        find(one, MsgKind::Vector3Stamped).map(|a| Choice::Vectors { accel: a, gyro: None })
                    })
                    .ok_or_else(missing),
                [a, g] => match (find(a, MsgKind::Vector3Stamped), find(g, MsgKind::Vector3Stamped)) {
                    (Some(a), Some(g)) => Ok(Choice::Vectors {
                        accel: a,
                        gyro: Some(g),
                    }),
                    _ => Err(missing()),
                },
                _ => Err(missing()),
            }
        }
        None => match all.as_slice() {
            [one] => Ok(one.clone()),
            [] => Err(BagError::NoImuTopic {
                file,
                topics: if c.topics.is_empty() {
                    "none".into()
                } else {
                    c.topics
                        .iter()
                        .map(|t| format!("{} ({}, {} messages)", t.name, t.msgtype, t.count))
                        .collect::<Vec<_>>()
                        .join("; ")
                },
            }),
            several => Err(BagError::SeveralTopics {
                file,
                count: several.len(),
                topics: list(several),
            }),
        },
    }
}

/// A recording read from a bag, with what the reader learned.
#[derive(Debug)]
pub struct BagRead {
    pub recording: Recording,
    pub storage: Storage,
    /// The topic read (`accel,gyro` for a pair).
    pub topic: String,
    pub notes: Vec<String>,
}

/// One topic's samples on one clock: (ns, accel, gyro), time-sorted.
struct Timed {
    ns: Vec<i64>,
    v: [Vec<f64>; 3],
    g: Option<[Vec<f64>; 3]>,
    clock: &'static str,
}

fn timed(c: &mut Collector, i: usize, notes: &mut Vec<String>) -> Result<Timed, BagError> {
    let name = c.topics[i].name.clone();
    // A topic is taken once; a pair naming the same topic twice finds it gone the second time.
    let s = c.series[i].take().ok_or_else(|| BagError::Unsupported {
        file: c.file.clone(),
        what: format!("topic {name} is chosen twice; an accelerometer and gyro pair needs two topics"),
    })?;
    if let Some(e) = s.error {
        return Err(e);
    }
    let n = s.stamps.len();
    if n < 2 {
        return Err(BagError::TooFew {
            file: c.file.clone(),
            topic: name,
            found: n,
        });
    }
    let zero = s.stamps.iter().filter(|&&t| t == 0).count();
    let (mut ns, clock) = if zero == n {
        notes.push(format!(
            "{name}: every header stamp is zero: receive (log) times used"
        ));
        (
            s.log
                .iter()
                .map(|&t| t.min(i64::MAX as u64) as i64)
                .collect::<Vec<_>>(),
            "receive time",
        )
    } else if zero > 0 {
        let first = s.stamps.iter().position(|&t| t == 0).unwrap_or(0);
        return Err(BagError::Message {
            file: c.file.clone(),
            topic: name,
            index: first as u64 + 1,
            at: "header.stamp".into(),
            what: format!(
                "stamp is zero in {zero} of {n} messages (stamps and receive times would be mixed)"
            ),
        });
    } else {
        (s.stamps, "header stamp")
    };
    let mut v = s.v;
    let gyro_present = !s.g[0].is_empty() && s.gyro_missing < n;
    if !s.g[0].is_empty() && s.gyro_missing == n {
        notes.push(format!(
            "{name}: angular_velocity_covariance[0] = −1 in every message (no gyro): gyro not read"
        ));
    }
    let mut g = gyro_present.then_some(s.g);
    if s.accel_missing == n {
        return Err(BagError::Unsupported {
            file: c.file.clone(),
            what: format!(
                "topic {name}: linear_acceleration_covariance[0] = −1 in every message (no accelerometer data)"
            ),
        });
    }
    if ns.windows(2).any(|w| w[1] < w[0]) {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&k| ns[k]);
        let pick = |x: &Vec<f64>| order.iter().map(|&k| x[k]).collect::<Vec<f64>>();
        v = [pick(&v[0]), pick(&v[1]), pick(&v[2])];
        if let Some(gg) = g.as_mut() {
            *gg = [pick(&gg[0]), pick(&gg[1]), pick(&gg[2])];
        }
        ns = order.iter().map(|&k| ns[k]).collect();
        notes.push(format!(
            "{name}: messages sorted by {clock} (the bag stores them out of order)"
        ));
    }
    Ok(Timed { ns, v, g, clock })
}

/// Gyro samples onto the accelerometer's times: equal stamps taken as they are, others linearly
/// interpolated between the neighbouring gyro samples; accelerometer samples outside the gyro's
/// time span are dropped.
fn merge(accel: Timed, gyro: Timed, notes: &mut Vec<String>, names: (&str, &str)) -> Timed {
    let gv = gyro.v;
    let mut out = Timed {
        ns: Vec::new(),
        v: Default::default(),
        g: Some(Default::default()),
        clock: accel.clock,
    };
    let (mut exact, mut interpolated, mut dropped) = (0usize, 0usize, 0usize);
    let mut j = 0usize;
    for (i, &t) in accel.ns.iter().enumerate() {
        while j + 1 < gyro.ns.len() && gyro.ns[j + 1] <= t {
            j += 1;
        }
        let w = if gyro.ns[j] == t {
            exact += 1;
            [gv[0][j], gv[1][j], gv[2][j]]
        } else if gyro.ns[j] < t && j + 1 < gyro.ns.len() {
            interpolated += 1;
            let f = (t - gyro.ns[j]) as f64 / (gyro.ns[j + 1] - gyro.ns[j]) as f64;
            [0, 1, 2].map(|k| gv[k][j] + f * (gv[k][j + 1] - gv[k][j]))
        } else {
            dropped += 1;
            continue;
        };
        out.ns.push(t);
        for k in 0..3 {
            out.v[k].push(accel.v[k][i]);
            out.g.as_mut().expect("set above")[k].push(w[k]);
        }
    }
    notes.push(format!(
        "{} + {}: gyro on the accelerometer's stamps: {exact} equal, {interpolated} interpolated, {dropped} accelerometer samples outside the gyro's span dropped",
        names.0, names.1
    ));
    out
}

/// The bag's `sensor_msgs/Temperature` on the IMU's times, when there is one to take: the only
/// temperature topic, or among several the one with the IMU's frame_id. Linear between its
/// messages, held at its first and last value beyond them (a temperature changes slowly); each
/// choice is in `notes`. A temperature topic that cannot be read is noted and left out: it never
/// stops the IMU data being read.
fn temperature_beside(
    c: &mut Collector,
    data: &Timed,
    frame: Option<&str>,
    notes: &mut Vec<String>,
) -> Option<Vec<f64>> {
    let topics: Vec<usize> = (0..c.topics.len())
        .filter(|&i| c.kinds[i] == Some(MsgKind::Temperature) && c.series[i].is_some())
        .collect();
    let chosen = match topics.as_slice() {
        [] => return None,
        [one] => *one,
        several => {
            let same_frame: Vec<usize> = several
                .iter()
                .copied()
                .filter(|&i| c.series[i].as_ref().and_then(|s| s.frame_id.as_deref()) == frame)
                .collect();
            let names = several
                .iter()
                .map(|&i| c.topics[i].name.clone())
                .collect::<Vec<_>>()
                .join(", ");
            match same_frame.as_slice() {
                [one] => *one,
                _ => {
                    notes.push(format!(
                        "temperature topics {names}: none has the IMU's frame_id alone, so none is read"
                    ));
                    return None;
                }
            }
        }
    };
    let name = c.topics[chosen].name.clone();
    let mut quiet = Vec::new();
    let series = match timed(c, chosen, &mut quiet) {
        Ok(t) => t,
        Err(e) => {
            notes.push(format!("temperature topic {name} left out: {e}"));
            return None;
        }
    };
    notes.extend(quiet);
    let (ns, value) = (&series.ns, &series.v[0]);
    if let Some(k) = value.iter().position(|v| !v.is_finite()) {
        notes.push(format!(
            "temperature topic {name} left out: message {} holds {}",
            k + 1,
            value[k]
        ));
        return None;
    }
    let (mut inside, mut held) = (0usize, 0usize);
    let mut j = 0usize;
    let merged = data
        .ns
        .iter()
        .map(|&t| {
            while j + 1 < ns.len() && ns[j + 1] <= t {
                j += 1;
            }
            if t < ns[0] || (t > ns[j] && j + 1 == ns.len()) {
                held += 1;
                if t < ns[0] {
                    value[0]
                } else {
                    value[j]
                }
            } else if ns[j] == t || j + 1 == ns.len() {
                inside += 1;
                value[j]
            } else {
                inside += 1;
                let f = (t - ns[j]) as f64 / (ns[j + 1] - ns[j]) as f64;
                value[j] + f * (value[j + 1] - value[j])
            }
        })
        .collect();
    notes.push(format!(
        "temperature from {name} ({} messages) on the IMU's stamps: {inside} within its span (linear between messages), {held} beyond it (its first or last value held)",
        ns.len()
    ));
    Some(merged)
}

fn assemble(mut c: Collector, storage: Storage, topic: Option<&str>) -> Result<BagRead, BagError> {
    let choice = choose(&c, topic)?;
    let mut notes: Vec<String> = c.salvaged.iter().map(|s| format!("salvaged: {s}")).collect();
    let described = describe(&c, &choice);
    let (data, msgtype, frame, topic_name) = match choice {
        Choice::Imu(i) => {
            let frame = c.series[i].as_ref().and_then(|s| s.frame_id.clone());
            let t = timed(&mut c, i, &mut notes)?;
            (t, c.topics[i].msgtype.clone(), frame, c.topics[i].name.clone())
        }
        Choice::Vectors { accel, gyro } => {
            let frame = c.series[accel].as_ref().and_then(|s| s.frame_id.clone());
            let a = timed(&mut c, accel, &mut notes)?;
            let (an, at) = (c.topics[accel].name.clone(), c.topics[accel].msgtype.clone());
            match gyro {
                Some(g) => {
                    let gt = timed(&mut c, g, &mut notes)?;
                    let gn = c.topics[g].name.clone();
                    let merged = merge(a, gt, &mut notes, (&an, &gn));
                    if merged.ns.len() < 2 {
                        return Err(BagError::TooFew {
                            file: c.file.clone(),
                            topic: format!("{an},{gn} (accelerometer samples within the gyro's span)"),
                            found: merged.ns.len(),
                        });
                    }
                    (merged, at, frame, format!("{an},{gn}"))
                }
                None => (a, at, frame, an),
            }
        }
    };
    let temperature = temperature_beside(&mut c, &data, frame.as_deref(), &mut notes);
    let t0 = data.ns[0];
    let time_s: Vec<f64> = data.ns.iter().map(|&t| (t - t0) as f64 * 1e-9).collect();
    let gyro = data.g.is_some();
    let mut columns = vec![
        data.clock.to_string(),
        "linear_acceleration.x".into(),
        "linear_acceleration.y".into(),
        "linear_acceleration.z".into(),
    ];
    if msgtype.contains("Vector3Stamped") {
        columns[1..4].clone_from_slice(&["vector.x".into(), "vector.y".into(), "vector.z".into()]);
    }
    if gyro {
        columns.extend(["angular_velocity.x", "angular_velocity.y", "angular_velocity.z"].map(String::from));
    }
    if temperature.is_some() {
        columns.push("temperature".into());
    }
    let metadata = vec![
        format!("storage: {}", storage.name()),
        format!("topic: {described}"),
        format!("frame_id: {}", frame.unwrap_or_default()),
        format!(
            "time: {} from {}.{:09} s, counted from the first sample",
            data.clock,
            t0.div_euclid(1_000_000_000),
            t0.rem_euclid(1_000_000_000)
        ),
    ];
    let recording = Recording {
        time_s,
        accel_mps2: data.v,
        gyro_radps: data.g,
        temperature_c: temperature,
        source: Source {
            name: c.file.clone(),
            format: "rosbag".into(),
            columns,
            metadata,
            lines: Vec::new(),
            incomplete_rows: Default::default(),
        },
    };
    Ok(BagRead {
        recording,
        storage,
        topic: topic_name,
        notes,
    })
}

/// Reads a bag held in memory (one `.mcap`, `.db3` or `.bag` file); `file` names it in errors.
/// `salvage`: a file whose end is damaged (cut, its footer or index lost) gives the messages
/// before the damage, with a note, instead of an error.
pub fn read_bytes(bytes: &[u8], file: &str, topic: Option<&str>, salvage: bool) -> Result<BagRead, BagError> {
    let storage = Storage::sniff(bytes).ok_or_else(|| BagError::Corrupt {
        file: file.into(),
        at: "byte 0".into(),
        what: "not a bag: no MCAP, SQLite or ROS 1 bag magic".into(),
    })?;
    let mut c = Collector::new(file, topic, salvage);
    scan(storage, bytes, None, file, &mut c)?;
    assemble(c, storage, topic)
}

fn scan(
    storage: Storage,
    bytes: &[u8],
    path: Option<&Path>,
    file: &str,
    c: &mut Collector,
) -> Result<(), BagError> {
    match storage {
        Storage::Mcap => mcap::scan(bytes, file, c),
        Storage::Sqlite3 => match path {
            Some(p) => sqlite::scan_path(p, file, c),
            None => sqlite::scan_bytes(bytes, file, c),
        },
        Storage::Ros1 => ros1::scan(bytes, file, c),
    }
}

/// Reads a bag file, or a ROS 2 bag directory (its `metadata.yaml` names the storage files, read
/// in order as one bag); `salvage` as in [`read_bytes`].
pub fn read_path(path: &Path, topic: Option<&str>, salvage: bool) -> Result<BagRead, BagError> {
    let file = path.display().to_string();
    let io = |f: &Path, source| BagError::Io {
        file: f.display().to_string(),
        source,
    };
    let files = if path.is_dir() {
        dir_files(path)?
    } else {
        vec![path.to_path_buf()]
    };
    let mut c = Collector::new(&file, topic, salvage);
    let mut storage = None;
    for f in &files {
        let name = f.display().to_string();
        let bytes = crate::input::table::read_file(f).map_err(|e| io(f, e))?;
        let s = Storage::sniff(&bytes).ok_or_else(|| BagError::Corrupt {
            file: name.clone(),
            at: "byte 0".into(),
            what: "not a bag file: no MCAP, SQLite or ROS 1 bag magic".into(),
        })?;
        if storage.is_some_and(|p| p != s) {
            return Err(BagError::Unsupported {
                file: name,
                what: "storage files of different kinds in one bag".into(),
            });
        }
        storage = Some(s);
        c.file = name.clone();
        scan(s, &bytes, Some(f), &name, &mut c)?;
    }
    c.file = file.clone();
    let storage = storage.ok_or_else(|| BagError::Unsupported {
        file: file.clone(),
        what: "no storage file (.mcap or .db3) in the bag directory".into(),
    })?;
    assemble(c, storage, topic)
}

/// The storage files of a ROS 2 bag directory: `relative_file_paths` from `metadata.yaml`, or
/// else every `.mcap` / `.db3` file in it, by name.
fn dir_files(dir: &Path) -> Result<Vec<std::path::PathBuf>, BagError> {
    let meta_path = dir.join("metadata.yaml");
    let file = meta_path.display().to_string();
    let text = std::fs::read_to_string(&meta_path).map_err(|source| BagError::Io {
        file: file.clone(),
        source,
    })?;
    let mut files = Vec::new();
    let mut in_list = None::<usize>;
    for (n, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        if let Some(value) = trimmed.strip_prefix("compression_format:") {
            let v = value.trim().trim_matches(['\'', '"']);
            if !v.is_empty() {
                return Err(BagError::Unsupported {
                    file: format!("{file}:{}", n + 1),
                    what: format!("compressed ROS 2 bag (compression_format: {v}); decompress it first (ros2 bag convert)"),
                });
            }
        }
        if trimmed.starts_with("relative_file_paths:") {
            in_list = Some(indent);
            continue;
        }
        if let Some(list_indent) = in_list {
            if let Some(item) = trimmed.strip_prefix("- ") {
                if indent >= list_indent {
                    let name = item.trim().trim_matches(['\'', '"']);
                    files.push(dir.join(name));
                    continue;
                }
            }
            in_list = None;
        }
    }
    if files.is_empty() {
        let mut found: Vec<_> = std::fs::read_dir(dir)
            .map_err(|source| BagError::Io {
                file: dir.display().to_string(),
                source,
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "mcap" || x == "db3"))
            .collect();
        found.sort();
        files = found;
    }
    Ok(files)
}

/// Lists a bag's topics with their message counts (reading the whole bag).
pub fn topics(bytes: &[u8], file: &str) -> Result<Vec<TopicInfo>, BagError> {
    let storage = Storage::sniff(bytes).ok_or_else(|| BagError::Corrupt {
        file: file.into(),
        at: "byte 0".into(),
        what: "not a bag: no MCAP, SQLite or ROS 1 bag magic".into(),
    })?;
    // Decode nothing: want a topic name no bag has.
    let mut c = Collector::new(file, Some("\u{0}"), false);
    scan(storage, bytes, None, file, &mut c)?;
    Ok(c.topics)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chunk_is_held_to_its_stated_size_and_the_chunk_limit() {
        use std::io::Write;
        let zeros = vec![0u8; 4 << 20];
        let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
        bz.write_all(&zeros).unwrap();
        let bz = bz.finish().unwrap();
        assert!(bz.len() < 1024, "{}", bz.len());
        // 4 MiB of zeros in under 1 KiB: over 4096 × its size + 1 MiB, refused unopened.
        let e = decompress_chunk("bz2", &bz, zeros.len()).unwrap_err();
        assert!(e.contains("over the limit of"), "{e}");
        assert!(chunk_limit(bz.len()) < zeros.len() as u64);
        // A 3 GiB claim from a large chunk is over MAX_CHUNK_BYTES.
        let big = vec![0u8; 1 << 20];
        let e = decompress_chunk("zstd", &big, 3 << 30).unwrap_err();
        assert!(e.contains(&format!("at most {MAX_CHUNK_BYTES}")), "{e}");
        // Within the limits: exactly the stated size, and no more.
        let small = zstd::encode_all(&zeros[..100_000], 3).unwrap();
        assert_eq!(decompress_chunk("zstd", &small, 100_000).unwrap().len(), 100_000);
        let e = decompress_chunk("zstd", &small, 99_999).unwrap_err();
        assert_eq!(
            e,
            "zstd chunk decompresses to 100000+ bytes, its header says 99999"
        );
    }

    /// A bag's `sensor_msgs/Temperature` topic goes beside the IMU's samples, on their stamps:
    /// interpolated within its span, held beyond it, in ROS 1 and ROS 2 encodings alike; a
    /// damaged temperature topic is left out with a note and never stops the IMU data.
    #[test]
    fn a_temperature_topic_is_merged_on_the_imu_stamps() {
        for (encoding, name) in [(Encoding::Cdr, "cdr"), (Encoding::Ros1, "ros1")] {
            let (imu_type, temp_type) = match encoding {
                Encoding::Cdr => ("sensor_msgs/msg/Imu", "sensor_msgs/msg/Temperature"),
                Encoding::Ros1 => ("sensor_msgs/Imu", "sensor_msgs/Temperature"),
            };
            for damaged in [false, true] {
                // --topic names the IMU only: the temperature is read all the same.
                let mut c = Collector::new("b", Some("/imu"), false);
                let imu = c.topic("/imu", imu_type, name);
                let temp = c.topic("/imu/temperature", temp_type, name);
                let t0 = 1_700_000_000_000_000_000i64;
                let message = |stamp_ns: i64, vector: [f64; 3]| msg::Decoded {
                    stamp_ns,
                    frame_id: "imu_link".into(),
                    vector,
                    angular_velocity: Some([0.0; 3]),
                    accel_cov0: 0.0,
                    gyro_cov0: 0.0,
                };
                // IMU at 100 Hz for 3 s; temperature at 1 Hz from 0.5 s to 2.5 s, 20 °C rising 1 °C/s.
                for k in 0..300 {
                    let m = message(t0 + k * 10_000_000, [0.0, 0.0, 9.8]);
                    c.message(
                        imu,
                        0,
                        &msg::encode(&m, encoding, MsgKind::Imu, k as u32),
                        &|| String::new(),
                    );
                }
                for k in 0..3 {
                    let m = message(t0 + 500_000_000 + k * 1_000_000_000, [20.0 + k as f64, 0.01, 0.0]);
                    let mut bytes = msg::encode(&m, encoding, MsgKind::Temperature, k as u32);
                    if damaged && k == 1 {
                        bytes.truncate(bytes.len() - 3);
                    }
                    c.message(temp, 0, &bytes, &|| String::new());
                }
                let read = assemble(c, Storage::Mcap, Some("/imu")).unwrap();
                let r = &read.recording;
                assert_eq!(r.len(), 300);
                if damaged {
                    assert!(r.temperature_c.is_none());
                    assert!(
                        read.notes
                            .iter()
                            .any(|n| n.starts_with("temperature topic /imu/temperature left out")),
                        "{:?}",
                        read.notes
                    );
                    continue;
                }
                let temp = r.temperature_c.as_ref().expect("the temperature was merged");
                assert_eq!(r.source.columns.last().map(String::as_str), Some("temperature"));
                assert_eq!(temp[0], 20.0, "held before its first message");
                assert!((temp[150] - 21.0).abs() < 1e-12, "{}", temp[150]);
                assert!((temp[100] - 20.5).abs() < 1e-12, "{}", temp[100]);
                assert_eq!(temp[299], 22.0, "held after its last message");
                assert!(
                    read.notes
                        .iter()
                        .any(|n| n.contains("201 within its span") && n.contains("99 beyond it")),
                    "{:?}",
                    read.notes
                );
            }
        }
    }

    fn collector_with(topics: &[(&str, &str)]) -> Collector {
        let mut c = Collector::new("b", None, false);
        for (name, ty) in topics {
            let i = c.topic(name, ty, "cdr");
            c.topics[i].count = 3;
        }
        c
    }

    #[test]
    fn choice_lists_or_picks() {
        let c = collector_with(&[("/imu", "sensor_msgs/msg/Imu"), ("/cam", "sensor_msgs/msg/Image")]);
        assert_eq!(choose(&c, None).unwrap(), Choice::Imu(0));
        let c = collector_with(&[("/imu", "sensor_msgs/msg/Imu"), ("/imu2", "sensor_msgs/Imu")]);
        let e = choose(&c, None).unwrap_err().to_string();
        assert!(
            e.contains("2 IMU topics") && e.contains("/imu2 (sensor_msgs/Imu, 3 messages)"),
            "{e}"
        );
        assert_eq!(choose(&c, Some("/imu2")).unwrap(), Choice::Imu(1));
        assert!(matches!(
            choose(&c, Some("/nope")),
            Err(BagError::NoSuchTopic { .. })
        ));
        let c = collector_with(&[
            ("/camera/accel/sample", "geometry_msgs/msg/Vector3Stamped"),
            ("/camera/gyro/sample", "geometry_msgs/msg/Vector3Stamped"),
        ]);
        assert_eq!(
            choose(&c, None).unwrap(),
            Choice::Vectors {
                accel: 0,
                gyro: Some(1)
            }
        );
        let c = collector_with(&[("/cam", "sensor_msgs/msg/Image")]);
        let e = choose(&c, None).unwrap_err().to_string();
        assert!(
            e.contains("no IMU topic") && e.contains("/cam (sensor_msgs/msg/Image, 3 messages)"),
            "{e}"
        );
    }

    #[test]
    fn detected_by_magic_and_other_versions_refused() {
        use crate::input::formats::{detect, Format};
        for head in [
            &b"\x89MCAP0\r\n\x01"[..],
            b"SQLite format 3\0xyz",
            b"#ROSBAG V2.0\n",
        ] {
            assert_eq!(detect(head).format, Format::RosBag, "{head:?}");
        }
        let e = read_bytes(b"#ROSBAG V1.2\n\0\0", "old.bag", None, false)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("old.bag: '#ROSBAG V1.2': only ROS 1 bag format 2.0"),
            "{e}"
        );
        let e = read_bytes(b"\x89MCAP0\r\n", "cut.mcap", None, false)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "cut.mcap: byte 8: the file ends without a footer record (truncated)"
        );
        let e = read_bytes(b"#ROSBAG V2.0\n\x05\0\0\0", "cut.bag", None, false)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("cut.bag: byte 13: record header of 5 bytes runs past the end"),
            "{e}"
        );
        let e = read_bytes(b"SQLite format 3\0", "x.db3", None, false)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.db3: sqlite3 storage"), "{e}");
    }

    #[test]
    fn merge_takes_equal_stamps_and_interpolates_others() {
        let accel = Timed {
            ns: vec![0, 10, 20, 40],
            v: [vec![1.0; 4], vec![2.0; 4], vec![3.0; 4]],
            g: None,
            clock: "header stamp",
        };
        let gyro = Timed {
            ns: vec![5, 10, 30],
            v: [vec![0.0, 1.0, 3.0], vec![0.0; 3], vec![0.0; 3]],
            g: None,
            clock: "header stamp",
        };
        let mut notes = Vec::new();
        let m = merge(accel, gyro, &mut notes, ("a", "g"));
        assert_eq!(m.ns, [10, 20]);
        assert_eq!(m.g.unwrap()[0], [1.0, 2.0]);
        assert!(
            notes[0].contains("1 equal, 1 interpolated, 2 accelerometer samples"),
            "{notes:?}"
        );
    }
}
