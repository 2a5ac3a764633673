//! The chosen topic (or accelerometer and gyro pair) turned into a recording: stamps or receive
//! times, pairs merged on one clock, a temperature topic beside.

use super::choice::{choose, describe, Choice};
use super::collector::Collector;
use super::msg::MsgKind;
use super::BagError;
use crate::input::formats::bag_detect::Storage;
use crate::input::recording::{Recording, Source};

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
pub(super) struct Timed {
    pub(super) ns: Vec<i64>,
    pub(super) v: [Vec<f64>; 3],
    pub(super) g: Option<[Vec<f64>; 3]>,
    pub(super) clock: &'static str,
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
pub(super) fn merge(accel: Timed, gyro: Timed, notes: &mut Vec<String>, names: (&str, &str)) -> Timed {
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

pub(super) fn assemble(mut c: Collector, storage: Storage, topic: Option<&str>) -> Result<BagRead, BagError> {
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
            time_notes: Vec::new(),
        },
    };
    Ok(BagRead {
        recording,
        storage,
        topic: topic_name,
        notes,
    })
}
