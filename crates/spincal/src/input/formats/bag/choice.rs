//! Choosing the topic to read: the IMU-shaped candidates, described and picked.

use super::collector::Collector;
use super::msg::MsgKind;
use super::BagError;

/// What [`choose`] picked: an `Imu` topic, or accelerometer (+ gyro) `Vector3Stamped` topics.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Choice {
    Imu(usize),
    Vectors { accel: usize, gyro: Option<usize> },
}

pub(super) fn describe(c: &Collector, choice: &Choice) -> String {
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

pub(super) fn choose(c: &Collector, topic: Option<&str>) -> Result<Choice, BagError> {
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
