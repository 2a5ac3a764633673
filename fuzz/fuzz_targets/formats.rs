//! The top-level reader (`formats::read_bytes`, behind `read_path`) with fuzzed read options, file
//! name and contents: a consistent recording or an error, never a panic. Detection looks at the
//! contents only, so the name is fuzzed for the messages it appears in.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::input::formats::{read_bytes, Format, ReadOptions};
use spincal::input::formats::gx1::Gx1Options;
use spincal::input::recording::{GyroUnit, TimeUnit};
use spincal::input::table::Delimiter;
use spincal::input::recording::{AccelUnit, ColumnMap};

/// Values for scales, offsets and rates: ordinary, extreme and invalid.
const VALUES: [f64; 16] = [
    1.0,
    -1.0,
    0.5,
    0.00981,
    1e-300,
    1e300,
    f64::MAX,
    0.0,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MIN_POSITIVE,
    2048.0,
    -0.0,
    1e-12,
    100.0,
];

fn pick<T: Copy>(choices: &[T], byte: u8) -> Option<T> {
    // 0 is "not given".
    match byte as usize % (choices.len() + 1) {
        0 => None,
        k => Some(choices[k - 1]),
    }
}

fuzz_target!(|data: &[u8]| {
    // Eight option bytes, a file name, an optional columns spec, then the file.
    let Some((head, rest)) = data.split_first_chunk::<8>() else {
        return;
    };
    let [format, flags, units, gyro, scale, offset, rate, name_len] = *head;
    let (name, rest) = rest.split_at((name_len as usize % 32).min(rest.len()));
    let name = String::from_utf8_lossy(name);
    let flag = |bit: u32| flags & (1 << bit) != 0;
    let mut columns = ColumnMap::default();
    let mut bytes = rest;
    if flag(7) {
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        bytes = rest.get(end + 1..).unwrap_or(&[]);
        if let Ok(map) = columns
            .clone()
            .with_columns(&String::from_utf8_lossy(&rest[..end]))
        {
            columns = map;
        }
    }
    columns.table.delimiter = pick(
        &[
            Delimiter::Comma,
            Delimiter::Semicolon,
            Delimiter::Tab,
            Delimiter::Whitespace,
        ],
        units,
    );
    columns.accel_unit = pick(&[AccelUnit::Mps2, AccelUnit::G], units >> 3);
    columns.time_unit = pick(&[TimeUnit::S, TimeUnit::Ms, TimeUnit::Us, TimeUnit::Ns], units >> 5);
    columns.gyro_unit = pick(&[GyroUnit::Radps, GyroUnit::Dps], gyro);
    let value = |byte: u8| VALUES[byte as usize % VALUES.len()];
    let options = ReadOptions {
        format: pick(&Format::ALL, format),
        columns,
        accel_scale: flag(1).then(|| value(scale)),
        accel_offset: flag(2).then(|| [value(offset), value(offset >> 4), value(scale >> 4)]),
        sample_rate_hz: flag(3).then(|| value(rate)),
        gx1: Gx1Options {
            accel_gain_scale: flag(4).then(|| u16::from_le_bytes([scale, offset])),
            gyro_gain_scale: flag(5).then(|| u16::from_le_bytes([offset, rate])),
            command: flag(6).then_some(rate),
        },
        retime: flag(0),
        salvage: flag(7),
        ..ReadOptions::default()
    };

    match read_bytes(bytes, &name, &options) {
        Ok(loaded) => {
            let r = &loaded.recording;
            let n = r.len();
            assert!(r.accel_mps2.iter().all(|a| a.len() == n));
            if let Some(g) = &r.gyro_radps {
                assert!(g.iter().all(|a| a.len() == n));
            }
            assert!(r.source.lines.is_empty() || r.source.lines.len() == n);
            if let Some(labels) = &loaded.labels {
                assert_eq!(labels.len(), n);
            }
            assert_eq!(loaded.detection.is_some(), options.format.is_none());
            if let Some(format) = options.format {
                assert_eq!(loaded.format, format);
            }
            assert_eq!(r.source.format, loaded.format.name());
            if options.accel_scale.is_some() {
                assert!(!loaded.raw_counts);
            }
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
