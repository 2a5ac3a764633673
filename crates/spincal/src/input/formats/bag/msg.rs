//! Decoders for the two IMU message shapes and the temperature beside them, in both
//! serialisations ROS uses.
//!
//! * ROS 2 (CDR, XCDR1 "plain"): a 4-byte encapsulation header (`00 01` little endian, `00 00` big
//!   endian, then two option bytes), then the fields, each aligned to its own size counted from the
//!   end of the encapsulation header. Strings are a `u32` length that counts a terminating NUL.
//!   `builtin_interfaces/Time` is `i32 sec, u32 nanosec`.
//! * ROS 1: little endian, packed (no alignment); `std_msgs/Header` starts with `u32 seq`, the
//!   time is `u32 secs, u32 nsecs`, strings are a `u32` length without a NUL.
//!
//! Every length is checked against the bytes left; a message that is short, has a bad string or
//! leaves bytes over is refused with the byte offset inside the message.

/// Which serialisation a message is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 2 CDR (the `cdr` message encoding).
    Cdr,
    /// ROS 1 serialisation (`ros1`).
    Ros1,
}

/// The message types read, by their normalised name (`package/Type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MsgKind {
    /// `sensor_msgs/Imu`.
    Imu,
    /// `geometry_msgs/Vector3Stamped`.
    Vector3Stamped,
    /// `sensor_msgs/Temperature` (°C and its variance).
    Temperature,
}

impl MsgKind {
    /// `sensor_msgs/msg/Imu` (ROS 2) and `sensor_msgs/Imu` (ROS 1) are the same type.
    pub fn from_type(name: &str) -> Option<MsgKind> {
        match name.replace("/msg/", "/").as_str() {
            "sensor_msgs/Imu" => Some(MsgKind::Imu),
            "geometry_msgs/Vector3Stamped" => Some(MsgKind::Vector3Stamped),
            "sensor_msgs/Temperature" => Some(MsgKind::Temperature),
            _ => None,
        }
    }
}

/// A decoded message: header stamp (ns since the epoch of the clock), frame, and the vectors.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    pub stamp_ns: i64,
    pub frame_id: String,
    /// `Imu`: linear acceleration (m/s²); `Vector3Stamped`: the vector; `Temperature`: the
    /// temperature (°C), its variance, 0.
    pub vector: [f64; 3],
    /// `Imu`: angular velocity (rad/s).
    pub angular_velocity: Option<[f64; 3]>,
    /// `Imu`: the first element of the linear-acceleration and angular-velocity covariances
    /// (−1 means "not provided" by REP-145 / the message's documentation).
    pub accel_cov0: f64,
    pub gyro_cov0: f64,
}

/// What is wrong with one message, and where inside it (byte offset from the message start).
#[derive(Debug, Clone, PartialEq)]
pub struct DecodeError {
    pub offset: usize,
    pub what: String,
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "byte {} of the message: {}", self.offset, self.what)
    }
}

struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    /// Where alignment is counted from (CDR: after the encapsulation header); `None`: packed.
    align_origin: Option<usize>,
    little: bool,
}

impl<'a> Cursor<'a> {
    fn fail<T>(&self, what: impl Into<String>) -> Result<T, DecodeError> {
        Err(DecodeError {
            offset: self.pos,
            what: what.into(),
        })
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], DecodeError> {
        if let Some(origin) = self.align_origin {
            let misalign = (self.pos - origin) % n.clamp(1, 8);
            if misalign != 0 && n <= 8 {
                let pad = n - misalign;
                if self.buf.len() - self.pos < pad {
                    return self.fail(format!("ends in the padding before {what}"));
                }
                self.pos += pad;
            }
        }
        if self.buf.len() - self.pos < n {
            return self.fail(format!(
                "ends inside {what} ({} bytes needed, {} left)",
                n,
                self.buf.len() - self.pos
            ));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, DecodeError> {
        let b: [u8; 4] = self.take(4, what)?.try_into().expect("4 bytes");
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64(&mut self, what: &str) -> Result<f64, DecodeError> {
        let b: [u8; 8] = self.take(8, what)?.try_into().expect("8 bytes");
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N], DecodeError> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(what)?;
        }
        Ok(out)
    }

    fn string(&mut self, what: &str) -> Result<String, DecodeError> {
        let start = self.pos;
        let len = self.u32(what)? as usize;
        if len > self.buf.len() - self.pos {
            self.pos = start;
            return self.fail(format!(
                "{what} length {len} exceeds the {} bytes left",
                self.buf.len() - start - 4
            ));
        }
        let bytes = &self.buf[self.pos..self.pos + len];
        let text = if self.align_origin.is_some() && len > 0 {
            // CDR strings carry their NUL.
            if bytes[len - 1] != 0 {
                return self.fail(format!("{what} of {len} bytes does not end in NUL"));
            }
            &bytes[..len - 1]
        } else {
            bytes
        };
        let s = match std::str::from_utf8(text) {
            Ok(s) => s.to_string(),
            Err(_) => return self.fail(format!("{what} is not UTF-8")),
        };
        self.pos += len;
        Ok(s)
    }

    /// `std_msgs/Header` → (stamp ns, frame_id).
    fn header(&mut self, encoding: Encoding) -> Result<(i64, String), DecodeError> {
        if encoding == Encoding::Ros1 {
            self.u32("header.seq")?;
        }
        let sec_at = self.pos;
        let sec_raw = self.u32("header.stamp.sec")?;
        let sec = match encoding {
            Encoding::Cdr => sec_raw as i32 as i64,
            Encoding::Ros1 => sec_raw as i64,
        };
        let nsec = self.u32("header.stamp.nanosec")?;
        if nsec >= 1_000_000_000 {
            return Err(DecodeError {
                offset: sec_at + 4,
                what: format!("header stamp nanoseconds {nsec} ≥ 10⁹"),
            });
        }
        let frame = self.string("header.frame_id")?;
        Ok((sec * 1_000_000_000 + nsec as i64, frame))
    }
}

/// Decodes one message of `kind` in `encoding`.
pub fn decode(data: &[u8], encoding: Encoding, kind: MsgKind) -> Result<Decoded, DecodeError> {
    let mut c = match encoding {
        Encoding::Cdr => {
            if data.len() < 4 {
                return Err(DecodeError {
                    offset: 0,
                    what: format!("{} bytes: shorter than the CDR encapsulation header", data.len()),
                });
            }
            let little = match (data[0], data[1]) {
                (0, 1) => true,
                (0, 0) => false,
                (a, b) => {
                    return Err(DecodeError {
                        offset: 0,
                        what: format!("CDR encapsulation {a:02x} {b:02x} is not plain CDR (00 00 or 00 01)"),
                    })
                }
            };
            Cursor {
                buf: data,
                pos: 4,
                align_origin: Some(4),
                little,
            }
        }
        Encoding::Ros1 => Cursor {
            buf: data,
            pos: 0,
            align_origin: None,
            little: true,
        },
    };
    let (stamp_ns, frame_id) = c.header(encoding)?;
    let decoded = match kind {
        MsgKind::Imu => {
            let _orientation: [f64; 4] = c.f64s("orientation")?;
            let _orientation_cov: [f64; 9] = c.f64s("orientation_covariance")?;
            let gyro: [f64; 3] = c.f64s("angular_velocity")?;
            let gyro_cov: [f64; 9] = c.f64s("angular_velocity_covariance")?;
            let accel: [f64; 3] = c.f64s("linear_acceleration")?;
            let accel_cov: [f64; 9] = c.f64s("linear_acceleration_covariance")?;
            Decoded {
                stamp_ns,
                frame_id,
                vector: accel,
                angular_velocity: Some(gyro),
                accel_cov0: accel_cov[0],
                gyro_cov0: gyro_cov[0],
            }
        }
        MsgKind::Vector3Stamped => Decoded {
            stamp_ns,
            frame_id,
            vector: c.f64s("vector")?,
            angular_velocity: None,
            accel_cov0: 0.0,
            gyro_cov0: 0.0,
        },
        MsgKind::Temperature => {
            let [temperature, variance] = c.f64s("temperature and variance")?;
            Decoded {
                stamp_ns,
                frame_id,
                vector: [temperature, variance, 0.0],
                angular_velocity: None,
                accel_cov0: 0.0,
                gyro_cov0: 0.0,
            }
        }
    };
    let left = data.len() - c.pos;
    // CDR writers may pad the end to a multiple of 4; ROS 1 has no padding.
    let allowed = match encoding {
        Encoding::Cdr => 3,
        Encoding::Ros1 => 0,
    };
    if left > allowed {
        return Err(DecodeError {
            offset: c.pos,
            what: format!("{left} bytes left over after the message"),
        });
    }
    Ok(decoded)
}

/// Encodes a message (the inverse of [`decode`]; used to build test bags and fuzz seeds).
/// `seq` is written only in ROS 1.
pub fn encode(msg: &Decoded, encoding: Encoding, kind: MsgKind, seq: u32) -> Vec<u8> {
    let mut out = Vec::new();
    let origin = match encoding {
        Encoding::Cdr => {
            out.extend_from_slice(&[0, 1, 0, 0]);
            Some(4)
        }
        Encoding::Ros1 => None,
    };
    let align = |out: &mut Vec<u8>, n: usize| {
        if let Some(o) = origin {
            while !(out.len() - o).is_multiple_of(n) {
                out.push(0);
            }
        }
    };
    if encoding == Encoding::Ros1 {
        out.extend_from_slice(&seq.to_le_bytes());
    }
    let sec = msg.stamp_ns.div_euclid(1_000_000_000);
    let nsec = msg.stamp_ns.rem_euclid(1_000_000_000) as u32;
    out.extend_from_slice(&(sec as u32).to_le_bytes());
    out.extend_from_slice(&nsec.to_le_bytes());
    let frame = msg.frame_id.as_bytes();
    match encoding {
        Encoding::Cdr => {
            out.extend_from_slice(&(frame.len() as u32 + 1).to_le_bytes());
            out.extend_from_slice(frame);
            out.push(0);
        }
        Encoding::Ros1 => {
            out.extend_from_slice(&(frame.len() as u32).to_le_bytes());
            out.extend_from_slice(frame);
        }
    }
    let put = |out: &mut Vec<u8>, values: &[f64]| {
        for v in values {
            align(out, 8);
            out.extend_from_slice(&v.to_le_bytes());
        }
    };
    match kind {
        MsgKind::Imu => {
            let mut gyro_cov = [0.0; 9];
            gyro_cov[0] = msg.gyro_cov0;
            let mut accel_cov = [0.0; 9];
            accel_cov[0] = msg.accel_cov0;
            put(&mut out, &[0.0, 0.0, 0.0, 1.0]);
            put(&mut out, &[-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
            put(&mut out, &msg.angular_velocity.unwrap_or([0.0; 3]));
            put(&mut out, &gyro_cov);
            put(&mut out, &msg.vector);
            put(&mut out, &accel_cov);
        }
        MsgKind::Vector3Stamped => put(&mut out, &msg.vector),
        MsgKind::Temperature => put(&mut out, &msg.vector[..2]),
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Decoded {
        Decoded {
            stamp_ns: 1_700_000_000_123_456_789,
            frame_id: "imu_link".into(),
            vector: [0.1, -9.80665, 3.5],
            angular_velocity: Some([0.01, 0.02, 3.49]),
            accel_cov0: 0.0,
            gyro_cov0: 0.0,
        }
    }

    #[test]
    fn round_trips_in_both_encodings_and_refuses_every_truncation() {
        for encoding in [Encoding::Cdr, Encoding::Ros1] {
            for kind in [MsgKind::Imu, MsgKind::Vector3Stamped] {
                let mut msg = sample();
                if kind == MsgKind::Vector3Stamped {
                    msg.angular_velocity = None;
                }
                let bytes = encode(&msg, encoding, kind, 7);
                assert_eq!(decode(&bytes, encoding, kind).unwrap(), msg);
                for cut in 0..bytes.len() {
                    let e = decode(&bytes[..cut], encoding, kind).unwrap_err();
                    assert!(e.offset <= cut, "{e} at cut {cut}");
                }
                let mut long = bytes.clone();
                long.extend_from_slice(&[0; 8]);
                let e = decode(&long, encoding, kind).unwrap_err();
                assert_eq!(e.offset, bytes.len(), "{e}");
                assert!(e.what.contains("left over"), "{e}");
            }
        }
    }

    #[test]
    fn cdr_layout_matches_the_standard() {
        // header: sec, nanosec, "a\0" (len 2) → 4+4+4+2 = 14 bytes of body; f64s aligned to 16.
        let msg = Decoded {
            stamp_ns: 1_000_000_002,
            frame_id: "a".into(),
            vector: [1.0, 2.0, 3.0],
            angular_velocity: None,
            accel_cov0: 0.0,
            gyro_cov0: 0.0,
        };
        let b = encode(&msg, Encoding::Cdr, MsgKind::Vector3Stamped, 0);
        assert_eq!(&b[..4], &[0, 1, 0, 0]);
        assert_eq!(&b[4..8], &1u32.to_le_bytes());
        assert_eq!(&b[8..12], &2u32.to_le_bytes());
        assert_eq!(&b[12..16], &2u32.to_le_bytes());
        assert_eq!(&b[16..18], b"a\0");
        assert_eq!(&b[18..20], &[0, 0]);
        assert_eq!(&b[20..28], &1.0f64.to_le_bytes());
        assert_eq!(b.len(), 4 + 16 + 24);
    }

    #[test]
    fn big_endian_cdr_and_bad_strings() {
        let mut b = vec![0u8, 0, 0, 0];
        b.extend_from_slice(&5u32.to_be_bytes());
        b.extend_from_slice(&6u32.to_be_bytes());
        b.extend_from_slice(&1u32.to_be_bytes());
        b.push(0);
        b.extend_from_slice(&[0; 3]);
        for v in [1.5f64, 2.5, -3.5] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        let d = decode(&b, Encoding::Cdr, MsgKind::Vector3Stamped).unwrap();
        assert_eq!(d.stamp_ns, 5_000_000_006);
        assert_eq!(d.vector, [1.5, 2.5, -3.5]);
        // A frame_id length far beyond the message.
        let mut bad = b.clone();
        bad[12..16].copy_from_slice(&0xffff_fff0u32.to_be_bytes());
        let e = decode(&bad, Encoding::Cdr, MsgKind::Vector3Stamped).unwrap_err();
        assert_eq!(e.offset, 12, "{e}");
        // No NUL.
        let mut bad = b.clone();
        bad[16] = b'x';
        assert!(decode(&bad, Encoding::Cdr, MsgKind::Vector3Stamped)
            .unwrap_err()
            .what
            .contains("NUL"));
        // Another encapsulation.
        let mut bad = b;
        bad[1] = 7;
        assert_eq!(
            decode(&bad, Encoding::Cdr, MsgKind::Vector3Stamped)
                .unwrap_err()
                .offset,
            0
        );
    }
}
