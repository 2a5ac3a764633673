//! The ROS bag readers (MCAP, sqlite3, ROS 1) and the message decoders on any bytes: never a
//! panic; a recording has ≥ 2 samples, one time, accel (and gyro) value each, times from 0 and
//! non-decreasing; an error names the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::input::formats::bag::{msg, read_bytes};

const TOPICS: [Option<&str>; 4] = [
    None,
    Some("/imu"),
    Some("/camera/accel/sample,/camera/gyro/sample"),
    Some("/camera/accel/sample"),
];

fuzz_target!(|data: &[u8]| {
    let Some((&choice, file)) = data.split_first() else {
        return;
    };
    // The decoders alone, on the whole input, in both serialisations and both shapes.
    for encoding in [msg::Encoding::Cdr, msg::Encoding::Ros1] {
        for kind in [msg::MsgKind::Imu, msg::MsgKind::Vector3Stamped, msg::MsgKind::Temperature] {
            if let Err(e) = msg::decode(file, encoding, kind) {
                assert!(e.offset <= file.len());
            }
        }
    }
    let topic = TOPICS[usize::from(choice & 0x7f) % TOPICS.len()];
    // The high bit asks for salvage (the messages before damage at the end).
    match read_bytes(file, "fuzz.bag", topic, choice & 0x80 != 0) {
        Ok(read) => {
            let r = &read.recording;
            let n = r.time_s.len();
            assert!(n >= 2);
            assert!(r.accel_mps2.iter().all(|a| a.len() == n));
            if let Some(g) = &r.gyro_radps {
                assert!(g.iter().all(|a| a.len() == n));
            }
            assert_eq!(r.time_s[0], 0.0);
            assert!(r.time_s.windows(2).all(|w| w[0] <= w[1]));
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.bag"), "{e}"),
    }
});
