//! The 3DM-GX1 decoder on any bytes: never panics; every byte is either in a valid packet or in a
//! reported damaged stretch.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::input::formats::gx1::{decode, scan, Gx1Options, Gx1Packet, EEPROM_REPLY_LEN, VECTORS_LEN};

fuzz_target!(|data: &[u8]| {
    let (packets, faults) = scan(data);
    let packet_bytes: usize = packets
        .iter()
        .map(|p| match p {
            Gx1Packet::Vectors(_) => VECTORS_LEN,
            Gx1Packet::Eeprom { .. } => EEPROM_REPLY_LEN,
        })
        .sum();
    let skipped: usize = faults.iter().map(|f| f.skipped).sum();
    assert_eq!(packet_bytes + skipped, data.len());
    let options = Gx1Options {
        accel_gain_scale: Some(5000),
        gyro_gain_scale: Some(10000),
        command: None,
    };
    let _ = decode(data, "fuzz.bin", &options);
    let _ = decode(data, "fuzz.bin", &Gx1Options::default());
});
