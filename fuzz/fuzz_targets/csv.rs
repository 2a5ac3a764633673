//! Every text reader, on any bytes: a recording or a located error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::input::formats::{read_bytes, Format, ReadOptions};

fuzz_target!(|data: &[u8]| {
    // Detection, then each text format forced.
    let _ = read_bytes(data, "fuzz.csv", &ReadOptions::default());
    for format in [
        Format::Csv,
        Format::Whitespace,
        Format::Imucal,
        Format::Mpu6050,
        Format::Phyphox,
    ] {
        let options = ReadOptions {
            format: Some(format),
            ..Default::default()
        };
        let _ = read_bytes(data, "fuzz.csv", &options);
    }
});
