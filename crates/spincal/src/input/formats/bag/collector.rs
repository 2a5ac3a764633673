//! The collector: every topic counted, the wanted IMU-shaped topics decoded as the storage reader
//! hands their messages over.

use std::collections::HashMap;

use super::msg::{self, Encoding, MsgKind};
use super::BagError;

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
    pub(super) fn kind(&self) -> Option<MsgKind> {
        MsgKind::from_type(&self.msgtype)
    }
    pub(super) fn looks_like(&self, words: &[&str]) -> bool {
        let lower = self.name.to_ascii_lowercase();
        words.iter().any(|w| lower.contains(w))
    }
}

/// The decoded messages of one topic.
#[derive(Debug, Default)]
pub(super) struct Series {
    pub(super) stamps: Vec<i64>,
    pub(super) log: Vec<u64>,
    pub(super) v: [Vec<f64>; 3],
    pub(super) g: [Vec<f64>; 3],
    pub(super) accel_missing: usize,
    pub(super) gyro_missing: usize,
    pub(super) frame_id: Option<String>,
    pub(super) error: Option<BagError>,
}

/// Counts every topic's messages and decodes the wanted IMU-shaped ones, as the storage reader
/// hands them over.
pub struct Collector {
    pub(super) file: String,
    pub(super) wanted: Option<Vec<String>>,
    pub(super) topics: Vec<TopicInfo>,
    pub(super) encodings: Vec<Option<Encoding>>,
    pub(super) kinds: Vec<Option<MsgKind>>,
    pub(super) series: Vec<Option<Series>>,
    pub(super) by_key: HashMap<(String, String), usize>,
    /// Read the messages before damage at the end of the file instead of refusing it.
    pub(super) salvage: bool,
    /// Where reading stopped at such damage, and why (with `salvage`).
    pub(super) salvaged: Option<String>,
}

impl Collector {
    pub(super) fn new(file: &str, topic: Option<&str>, salvage: bool) -> Collector {
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
    pub(super) fn damaged_end(&mut self, error: BagError) -> Result<(), BagError> {
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
