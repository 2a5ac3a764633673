//! Microstrain 3DM-GX1 binary serial stream: decoder and encoder.
//!
//! Protocol facts (3DM-GX1 data-communications protocol, as used by public drivers):
//! every reply starts with the command byte it answers; fields are big-endian 16-bit; the last two
//! bytes are a checksum = first byte + the sum of the big-endian 16-bit words between it and the
//! checksum, modulo 2¹⁶.
//! - 0x02 (gyro-stabilised vectors) and 0x03 (instantaneous vectors), 23 bytes:
//!   cmd, mag x y z (i16), accel x y z (i16), rate x y z (i16), timer (u16), checksum.
//! - 0x28 (read EEPROM with checksum), 7 bytes: cmd, value (u16), timer (u16), checksum; the value
//!   at address 230 is AccelGainScale, at 130 GyroGainScale.
//!
//! accel \[g\] = raw / (32768000 / AccelGainScale); rate [rad/s] = raw / (32768000 / GyroGainScale);
//! the timer counts 6.5536 ms ticks and wraps at 2¹⁶ (every 429.5 s); it is unwrapped into time.
//!
//! Corrupt or truncated packets are skipped byte by byte until a packet with a known header and a
//! valid checksum starts: each skipped stretch is one [`Gx1Fault`] with its byte offset.

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::input::recording::{Recording, Source, STANDARD_GRAVITY};

/// One timer tick, s.
pub const TICK_S: f64 = 0.0065536;
pub(crate) const CMD_STAB_VECTORS: u8 = 0x02;
pub(crate) const CMD_INST_VECTORS: u8 = 0x03;
pub(crate) const CMD_READ_EEPROM: u8 = 0x28;
/// EEPROM address of AccelGainScale.
pub const EEPROM_ACCEL_GAIN: u16 = 230;
/// EEPROM address of GyroGainScale.
pub const EEPROM_GYRO_GAIN: u16 = 130;
pub const VECTORS_LEN: usize = 23;
pub const EEPROM_REPLY_LEN: usize = 7;
/// Full-scale constant of the gain formula.
const GAIN_NUMERATOR: f64 = 32_768_000.0;

/// How to turn counts into SI units.
#[derive(Debug, Clone, Default)]
pub struct Gx1Options {
    /// AccelGainScale (EEPROM 230). When `None`, the first EEPROM reply found in the stream is taken
    /// as the answer to the address-230 read (a logger captures it before streaming).
    pub accel_gain_scale: Option<u16>,
    /// GyroGainScale (EEPROM 130); angular rate is decoded only when given.
    pub gyro_gain_scale: Option<u16>,
    /// Which vectors command to keep (0x02 or 0x03); the most frequent one when `None`.
    pub command: Option<u8>,
}

/// Why a stretch of bytes was skipped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Gx1Problem {
    /// A known header whose checksum does not match.
    BadChecksum { expected: u16, found: u16 },
    /// A byte that starts no known reply.
    UnknownHeader { byte: u8 },
    /// A known header too close to the end of the stream.
    Truncated { needed: usize, available: usize },
}

/// A skipped stretch of the stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Gx1Fault {
    /// Byte offset of the first skipped byte.
    pub offset: usize,
    /// Number of bytes skipped before the next valid packet (or the end).
    pub skipped: usize,
    /// What was wrong at `offset`.
    pub problem: Gx1Problem,
}

impl std::fmt::Display for Gx1Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "byte {}: ", self.offset)?;
        match &self.problem {
            Gx1Problem::BadChecksum { expected, found } => write!(
                f,
                "bad checksum (computed {expected:#06x}, packet says {found:#06x})"
            )?,
            Gx1Problem::UnknownHeader { byte } => write!(f, "unknown header byte {byte:#04x}")?,
            Gx1Problem::Truncated { needed, available } => {
                write!(f, "truncated packet ({available} of {needed} bytes)")?
            }
        }
        write!(f, "; {} bytes skipped", self.skipped)
    }
}

/// What the decoder saw.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Gx1Report {
    /// Valid 0x02 packets.
    pub stab_packets: usize,
    /// Valid 0x03 packets.
    pub inst_packets: usize,
    /// Values of valid EEPROM replies, in stream order.
    pub eeprom_values: Vec<u16>,
    pub faults: Vec<Gx1Fault>,
    pub accel_gain_scale: u16,
    /// `given` or `eeprom reply at byte N`.
    pub gain_source: String,
    /// Command whose samples were kept.
    pub command: u8,
    /// Consecutive kept packets with the same timer value (time does not advance there).
    pub repeated_ticks: usize,
}

/// Errors that stop decoding altogether.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Gx1Error {
    #[error(
        "{file}: no valid 3DM-GX1 vectors packet (0x02/0x03) in {bytes} bytes ({faults} damaged stretches)"
    )]
    NoPackets {
        file: String,
        bytes: usize,
        faults: usize,
    },
    #[error(
        "{file}: AccelGainScale unknown: the stream holds no EEPROM reply (0x28); pass the gain (EEPROM 230)"
    )]
    NoGain { file: String },
    #[error("{file}: AccelGainScale {value} from {source_desc} is not usable (must be > 0)")]
    BadGain {
        file: String,
        value: u16,
        source_desc: String,
    },
    #[error("{file}: the stream holds EEPROM replies with different values ({values}); a reply does not say which address it answers, so AccelGainScale is ambiguous: pass it (EEPROM 230)")]
    AmbiguousGain { file: String, values: String },
    #[error("{file}: byte {offset}: the timer goes back {ticks} ticks ({seconds:.4} s) from the previous packet (a reset or a spliced capture); split the file there")]
    TimerBackwards {
        file: String,
        offset: usize,
        ticks: u16,
        seconds: f64,
    },
    #[error("3DM-GX1 command {0:#04x} is not a vectors command (0x02 or 0x03)")]
    BadCommand(u8),
    #[error("3DM-GX1 encoder: gain scale must be > 0")]
    ZeroGain,
    #[error("3DM-GX1 encoder: time at sample {index} ({time_s} s) is before the first sample")]
    TimeBeforeStart { index: usize, time_s: f64 },
}

/// 16-bit additive checksum of a whole reply (the last two bytes are excluded from the sum).
pub fn checksum(packet: &[u8]) -> u16 {
    let body = &packet[..packet.len() - 2];
    let mut sum = body[0] as u16;
    for w in body[1..].chunks_exact(2) {
        sum = sum.wrapping_add(u16::from_be_bytes([w[0], w[1]]));
    }
    sum
}

fn be_u16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([b[at], b[at + 1]])
}

fn packet_len(header: u8) -> Option<usize> {
    match header {
        CMD_STAB_VECTORS | CMD_INST_VECTORS => Some(VECTORS_LEN),
        CMD_READ_EEPROM => Some(EEPROM_REPLY_LEN),
        _ => None,
    }
}

/// One decoded vectors packet, raw counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VectorsPacket {
    pub offset: usize,
    pub command: u8,
    pub mag: [i16; 3],
    pub accel: [i16; 3],
    pub rate: [i16; 3],
    pub ticks: u16,
}

/// A valid reply found in the stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gx1Packet {
    Vectors(VectorsPacket),
    Eeprom { offset: usize, value: u16, ticks: u16 },
}

/// Splits a byte stream into valid packets and damaged stretches; never panics, loses no valid
/// packet that is not overlapped by a damaged one.
pub fn scan(bytes: &[u8]) -> (Vec<Gx1Packet>, Vec<Gx1Fault>) {
    let mut packets = Vec::with_capacity(bytes.len() / VECTORS_LEN + 1);
    let mut faults: Vec<Gx1Fault> = Vec::new();
    let mut open: Option<Gx1Fault> = None;
    let mut i = 0;
    while i < bytes.len() {
        let header = bytes[i];
        let problem = match packet_len(header) {
            None => Gx1Problem::UnknownHeader { byte: header },
            Some(len) if i + len > bytes.len() => Gx1Problem::Truncated {
                needed: len,
                available: bytes.len() - i,
            },
            Some(len) => {
                let p = &bytes[i..i + len];
                let (expected, found) = (checksum(p), be_u16(p, len - 2));
                if expected == found {
                    if let Some(f) = open.take() {
                        faults.push(f);
                    }
                    packets.push(parse_valid(p, i));
                    i += len;
                    continue;
                }
                Gx1Problem::BadChecksum { expected, found }
            }
        };
        match &mut open {
            Some(f) => f.skipped += 1,
            None => {
                open = Some(Gx1Fault {
                    offset: i,
                    skipped: 1,
                    problem,
                })
            }
        }
        i += 1;
    }
    faults.extend(open);
    (packets, faults)
}

fn parse_valid(p: &[u8], offset: usize) -> Gx1Packet {
    let i16_at = |k: usize| be_u16(p, k) as i16;
    if p[0] == CMD_READ_EEPROM {
        return Gx1Packet::Eeprom {
            offset,
            value: be_u16(p, 1),
            ticks: be_u16(p, 3),
        };
    }
    Gx1Packet::Vectors(VectorsPacket {
        offset,
        command: p[0],
        mag: [i16_at(1), i16_at(3), i16_at(5)],
        accel: [i16_at(7), i16_at(9), i16_at(11)],
        rate: [i16_at(13), i16_at(15), i16_at(17)],
        ticks: be_u16(p, 19),
    })
}

/// Decodes a captured stream into a recording (accel in m/s², time from the unwrapped timer,
/// starting at 0). `file` names the source in errors and in `Source`.
pub fn decode(bytes: &[u8], file: &str, options: &Gx1Options) -> Result<(Recording, Gx1Report), Gx1Error> {
    let (packets, faults) = scan(bytes);
    let (mut report, first_eeprom) = count_packets(&packets, faults);
    if report.stab_packets + report.inst_packets == 0 {
        return Err(Gx1Error::NoPackets {
            file: file.into(),
            bytes: bytes.len(),
            faults: report.faults.len(),
        });
    }
    let command = match options.command {
        Some(c @ (CMD_STAB_VECTORS | CMD_INST_VECTORS)) => c,
        Some(c) => return Err(Gx1Error::BadCommand(c)),
        None if report.inst_packets >= report.stab_packets => CMD_INST_VECTORS,
        None => CMD_STAB_VECTORS,
    };
    let (gain, gain_source) = accel_gain(&packets, first_eeprom, options, file)?;
    report.accel_gain_scale = gain;
    report.gain_source = gain_source;
    report.command = command;

    let accel_k = STANDARD_GRAVITY * gain as f64 / GAIN_NUMERATOR;
    let gyro_k = options
        .gyro_gain_scale
        .filter(|g| *g > 0)
        .map(|g| g as f64 / GAIN_NUMERATOR);
    let samples = samples(&packets, command, (accel_k, gyro_k), file, &mut report)?;
    let recording = Recording {
        time_s: samples.time_s,
        accel_mps2: samples.accel,
        gyro_radps: gyro_k.map(|_| samples.gyro),
        temperature_c: None,
        source: Source {
            name: file.into(),
            format: "3dm-gx1".into(),
            columns: vec![
                "timer".into(),
                "accel x".into(),
                "accel y".into(),
                "accel z".into(),
            ],
            metadata: vec![format!("AccelGainScale {gain} ({})", report.gain_source)],
            lines: Vec::new(),
            incomplete_rows: Default::default(),
            time_notes: Vec::new(),
        },
    };
    Ok((recording, report))
}

/// The report's packet counts and EEPROM values, and the first EEPROM reply (offset, value).
fn count_packets(packets: &[Gx1Packet], faults: Vec<Gx1Fault>) -> (Gx1Report, Option<(usize, u16)>) {
    let mut report = Gx1Report {
        faults,
        ..Default::default()
    };
    let mut first_eeprom = None;
    for p in packets {
        match p {
            Gx1Packet::Vectors(v) if v.command == CMD_STAB_VECTORS => report.stab_packets += 1,
            Gx1Packet::Vectors(_) => report.inst_packets += 1,
            Gx1Packet::Eeprom { offset, value, .. } => {
                report.eeprom_values.push(*value);
                first_eeprom.get_or_insert((*offset, *value));
            }
        }
    }
    (report, first_eeprom)
}

/// The accelerometer's gain scale and where it came from: given, or the stream's EEPROM replies
/// (which must agree).
fn accel_gain(
    packets: &[Gx1Packet],
    first_eeprom: Option<(usize, u16)>,
    options: &Gx1Options,
    file: &str,
) -> Result<(u16, String), Gx1Error> {
    let eeprom_replies: Vec<(usize, u16)> = packets
        .iter()
        .filter_map(|p| match p {
            Gx1Packet::Eeprom { offset, value, .. } => Some((*offset, *value)),
            Gx1Packet::Vectors(_) => None,
        })
        .collect();
    if options.accel_gain_scale.is_none() && eeprom_replies.iter().any(|(_, v)| *v != eeprom_replies[0].1) {
        let values: Vec<String> = eeprom_replies
            .iter()
            .take(6)
            .map(|(offset, value)| format!("{value} at byte {offset}"))
            .collect();
        return Err(Gx1Error::AmbiguousGain {
            file: file.into(),
            values: values.join(", "),
        });
    }
    let (gain, gain_source) = match (options.accel_gain_scale, first_eeprom) {
        (Some(g), _) => (g, "given".to_string()),
        (None, Some((offset, value))) => (value, format!("EEPROM reply at byte {offset}")),
        (None, None) => return Err(Gx1Error::NoGain { file: file.into() }),
    };
    if gain == 0 {
        return Err(Gx1Error::BadGain {
            file: file.into(),
            value: gain,
            source_desc: gain_source,
        });
    }
    Ok((gain, gain_source))
}

/// The chosen command's samples in SI units.
struct Samples {
    time_s: Vec<f64>,
    accel: [Vec<f64>; 3],
    /// Empty without a gyro gain.
    gyro: [Vec<f64>; 3],
}

/// The samples of the `command` packets, time from the unwrapped timer; `factors` are the
/// accelerometer's (counts to m/s²) and the gyro's, if read. Repeated ticks are counted in
/// `report`.
fn samples(
    packets: &[Gx1Packet],
    command: u8,
    factors: (f64, Option<f64>),
    file: &str,
    report: &mut Gx1Report,
) -> Result<Samples, Gx1Error> {
    let (accel_k, gyro_k) = factors;
    let n = packets.len();
    let mut time_s = Vec::with_capacity(n);
    let mut accel: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
    let mut gyro: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::new());
    let mut ticks_total: u64 = 0;
    let mut last: Option<u16> = None;
    for p in packets {
        let Gx1Packet::Vectors(v) = p else { continue };
        if v.command != command {
            continue;
        }
        if let Some(prev) = last {
            // Wrapping difference: the timer rolls over every 2¹⁶ ticks.
            let d = v.ticks.wrapping_sub(prev);
            // A step of more than half the wrap is the timer going back, not 7 minutes passing.
            if d > u16::MAX / 2 {
                let back = prev.wrapping_sub(v.ticks);
                return Err(Gx1Error::TimerBackwards {
                    file: file.into(),
                    offset: v.offset,
                    ticks: back,
                    seconds: back as f64 * TICK_S,
                });
            }
            if d == 0 {
                report.repeated_ticks += 1;
            }
            ticks_total += d as u64;
        }
        last = Some(v.ticks);
        time_s.push(ticks_total as f64 * TICK_S);
        for a in 0..3 {
            accel[a].push(v.accel[a] as f64 * accel_k);
        }
        if let Some(k) = gyro_k {
            for a in 0..3 {
                gyro[a].push(v.rate[a] as f64 * k);
            }
        }
    }
    Ok(Samples { time_s, accel, gyro })
}

/// Encoder settings.
#[derive(Debug, Clone)]
pub struct Gx1EncodeOptions {
    pub accel_gain_scale: u16,
    pub gyro_gain_scale: u16,
    /// 0x02 or 0x03.
    pub command: u8,
    /// Start the stream with the EEPROM reply carrying AccelGainScale, as a logger would capture it.
    pub eeprom_reply: bool,
}

impl Default for Gx1EncodeOptions {
    fn default() -> Self {
        // 5000 gives ±5 g full scale and 1.5·10⁻⁴ g per count, the GX1's range and resolution.
        Gx1EncodeOptions {
            accel_gain_scale: 5000,
            gyro_gain_scale: 10000,
            command: CMD_INST_VECTORS,
            eeprom_reply: true,
        }
    }
}

/// Counts outside the int16 range are clipped, as the sensor's A/D would.
fn quantise(value: f64) -> i16 {
    value.round().clamp(i16::MIN as f64, i16::MAX as f64) as i16
}

fn finish(packet: &mut Vec<u8>) {
    packet.extend_from_slice(&[0, 0]);
    let sum = checksum(packet);
    let n = packet.len();
    packet[n - 2..].copy_from_slice(&sum.to_be_bytes());
}

/// Builds one EEPROM reply packet.
pub(crate) fn encode_eeprom_reply(value: u16, ticks: u16) -> Vec<u8> {
    let mut p = vec![CMD_READ_EEPROM];
    p.extend_from_slice(&value.to_be_bytes());
    p.extend_from_slice(&ticks.to_be_bytes());
    finish(&mut p);
    p
}

/// Builds one vectors packet from raw counts.
pub(crate) fn encode_vectors(
    command: u8,
    mag: [i16; 3],
    accel: [i16; 3],
    rate: [i16; 3],
    ticks: u16,
) -> Vec<u8> {
    let mut p = Vec::with_capacity(VECTORS_LEN);
    p.push(command);
    for v in mag.iter().chain(&accel).chain(&rate) {
        p.extend_from_slice(&v.to_be_bytes());
    }
    p.extend_from_slice(&ticks.to_be_bytes());
    finish(&mut p);
    p
}

/// Encodes a recording as the byte stream a 3DM-GX1 would send (for tests and the simulator):
/// accel quantised to counts and clipped to int16, gyro likewise (zero when absent), magnetometer
/// zero, time rounded to timer ticks since the first sample (wrapping at 2¹⁶).
pub fn encode(recording: &Recording, options: &Gx1EncodeOptions) -> Result<Vec<u8>, Gx1Error> {
    if options.accel_gain_scale == 0 || options.gyro_gain_scale == 0 {
        return Err(Gx1Error::ZeroGain);
    }
    if !matches!(options.command, CMD_STAB_VECTORS | CMD_INST_VECTORS) {
        return Err(Gx1Error::BadCommand(options.command));
    }
    let accel_k = GAIN_NUMERATOR / options.accel_gain_scale as f64 / STANDARD_GRAVITY;
    let gyro_k = GAIN_NUMERATOR / options.gyro_gain_scale as f64;
    let mut out = Vec::with_capacity(recording.len() * VECTORS_LEN + EEPROM_REPLY_LEN);
    if options.eeprom_reply {
        out.extend(encode_eeprom_reply(options.accel_gain_scale, 0));
    }
    let t0 = recording.time_s.first().copied().unwrap_or(0.0);
    for i in 0..recording.len() {
        let dt = recording.time_s[i] - t0;
        if dt < 0.0 {
            return Err(Gx1Error::TimeBeforeStart {
                index: i,
                time_s: recording.time_s[i],
            });
        }
        let ticks = ((dt / TICK_S).round() as u64 % 65536) as u16;
        let accel = std::array::from_fn(|a| quantise(recording.accel_mps2[a][i] * accel_k));
        let rate = match &recording.gyro_radps {
            Some(g) => std::array::from_fn(|a| quantise(g[a][i] * gyro_k)),
            None => [0; 3],
        };
        out.extend(encode_vectors(options.command, [0; 3], accel, rate, ticks));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recording(n: usize) -> Recording {
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let accel = [0.0, 1.0, 2.0].map(|p: f64| time_s.iter().map(|t| 3.0 * (t + p).sin()).collect());
        let gyro = [0.5, 1.5, 2.5].map(|p: f64| time_s.iter().map(|t| 0.4 * (2.0 * t + p).cos()).collect());
        Recording {
            time_s,
            accel_mps2: accel,
            gyro_radps: Some(gyro),
            temperature_c: None,
            source: Source::default(),
        }
    }

    #[test]
    fn a_second_eeprom_reply_with_another_value_makes_the_gain_ambiguous() {
        let mut bytes = encode(&recording(50), &Gx1EncodeOptions::default()).unwrap();
        bytes.extend(encode_eeprom_reply(10000, 900));
        let err = decode(&bytes, "two.bin", &Gx1Options::default()).unwrap_err();
        let message = err.to_string();
        assert!(
            message.contains("two.bin") && message.contains("5000 at byte 0"),
            "{message}"
        );
        assert!(message.contains("10000 at byte"), "{message}");
        // Given, the gain is used, whatever the replies say.
        let given = Gx1Options {
            accel_gain_scale: Some(5000),
            ..Gx1Options::default()
        };
        assert_eq!(decode(&bytes, "two.bin", &given).unwrap().0.len(), 50);
        // The same value twice is no ambiguity.
        let mut same = encode(&recording(50), &Gx1EncodeOptions::default()).unwrap();
        same.extend(encode_eeprom_reply(5000, 900));
        assert_eq!(
            decode(&same, "same.bin", &Gx1Options::default())
                .unwrap()
                .1
                .accel_gain_scale,
            5000
        );
    }

    #[test]
    fn a_timer_step_backwards_is_an_error_at_its_byte() {
        let mut bytes = encode_eeprom_reply(5000, 0);
        for (k, ticks) in [100u16, 101, 102, 90, 91].into_iter().enumerate() {
            bytes.extend(encode_vectors(
                CMD_INST_VECTORS,
                [0; 3],
                [k as i16; 3],
                [0; 3],
                ticks,
            ));
        }
        let err = decode(&bytes, "back.bin", &Gx1Options::default()).unwrap_err();
        let offset = EEPROM_REPLY_LEN + 3 * VECTORS_LEN;
        assert!(
            err.to_string()
                .contains(&format!("back.bin: byte {offset}: the timer goes back 12 ticks")),
            "{err}"
        );
        // A wrap of the 16-bit timer is still time going on.
        let mut wrapped = encode_eeprom_reply(5000, 0);
        for ticks in [65534u16, 65535, 0, 1] {
            wrapped.extend(encode_vectors(CMD_INST_VECTORS, [0; 3], [0; 3], [0; 3], ticks));
        }
        let (rec, _) = decode(&wrapped, "wrap.bin", &Gx1Options::default()).unwrap();
        assert!((rec.time_s[3] - 3.0 * TICK_S).abs() < 1e-12);
    }

    #[test]
    fn checksum_is_first_byte_plus_big_endian_words() {
        let p = encode_eeprom_reply(0x1388, 0x0102);
        // 0x28 + 0x1388 + 0x0102 = 0x14b2
        assert_eq!(p, [0x28, 0x13, 0x88, 0x01, 0x02, 0x14, 0xb2]);
    }

    #[test]
    fn round_trip_within_quantisation_and_timer_wrap() {
        // 50 000 samples at 100 Hz = 500 s: the 429.5 s timer wraps once.
        let rec = recording(50_000);
        let options = Gx1EncodeOptions::default();
        let bytes = encode(&rec, &options).unwrap();
        let gyro_gain = Gx1Options {
            gyro_gain_scale: Some(options.gyro_gain_scale),
            ..Default::default()
        };
        let (back, report) = decode(&bytes, "s.bin", &gyro_gain).unwrap();
        assert_eq!(back.len(), rec.len());
        assert!(report.faults.is_empty());
        assert_eq!(report.gain_source, "EEPROM reply at byte 0");
        let accel_lsb = STANDARD_GRAVITY * 5000.0 / GAIN_NUMERATOR;
        for a in 0..3 {
            for (x, y) in rec.accel_mps2[a].iter().zip(&back.accel_mps2[a]) {
                assert!((x - y).abs() <= 0.5 * accel_lsb + 1e-12);
            }
            let g = back.gyro_radps.as_ref().unwrap();
            for (x, y) in rec.gyro_radps.as_ref().unwrap()[a].iter().zip(&g[a]) {
                assert!((x - y).abs() <= 0.5 * 10000.0 / GAIN_NUMERATOR + 1e-12);
            }
        }
        for (x, y) in rec.time_s.iter().zip(&back.time_s) {
            assert!((x - y).abs() <= 0.5 * TICK_S + 1e-9, "{x} vs {y}");
        }
    }

    #[test]
    fn damaged_packets_are_reported_and_skipped() {
        let rec = recording(100);
        let bytes = encode(&rec, &Gx1EncodeOptions::default()).unwrap();
        let (clean, _) = decode(&bytes, "c.bin", &Gx1Options::default()).unwrap();
        let mut bad = bytes.clone();
        // Corrupt sample 10's accel x; cut sample 20 short by 5 bytes; add junk before sample 30.
        let at = |k: usize| EEPROM_REPLY_LEN + k * VECTORS_LEN;
        bad[at(10) + 8] ^= 0x40;
        bad.splice(at(30)..at(30), [0xff, 0x00, 0x13]);
        bad.drain(at(20) + 18..at(20) + 23);
        let (back, report) = decode(&bad, "b.bin", &Gx1Options::default()).unwrap();
        assert_eq!(
            back.len(),
            98,
            "two damaged packets dropped, junk skipped: {:?}",
            report.faults
        );
        assert_eq!(report.faults.len(), 3);
        assert_eq!(report.faults[0].offset, at(10));
        assert!(matches!(report.faults[0].problem, Gx1Problem::BadChecksum { .. }));
        assert_eq!(report.faults[1].offset, at(20));
        // Every surviving sample equals the clean decode's sample at the same time.
        for (i, t) in back.time_s.iter().enumerate() {
            let j = clean.time_s.iter().position(|u| u == t).unwrap();
            assert_eq!(back.accel_mps2[0][i], clean.accel_mps2[0][j]);
        }
    }

    #[test]
    fn no_gain_and_no_packets_are_errors() {
        let rec = recording(3);
        let bytes = encode(
            &rec,
            &Gx1EncodeOptions {
                eeprom_reply: false,
                ..Default::default()
            },
        )
        .unwrap();
        let e = decode(&bytes, "n.bin", &Gx1Options::default()).unwrap_err();
        assert!(e.to_string().contains("AccelGainScale unknown"), "{e}");
        let e = decode(&[1, 2, 3], "j.bin", &Gx1Options::default()).unwrap_err();
        assert!(matches!(e, Gx1Error::NoPackets { faults: 1, .. }), "{e}");
    }
}
