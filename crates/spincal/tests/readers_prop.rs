//! Property tests for every reader: any bytes parse or fail with an error that names the file (and
//! the line, column or byte where it can); never a panic. And the 3DM-GX1 stream survives damage.

use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use spincal::input::formats::gx1::{
    self, Gx1EncodeOptions, Gx1Options, EEPROM_REPLY_LEN, TICK_S, VECTORS_LEN,
};
use spincal::input::formats::{read_bytes, Format, ReadOptions};
use spincal::input::recording::{Recording, Source};

fn check_any_bytes(bytes: &[u8]) {
    let mut formats: Vec<Option<Format>> = Format::ALL.iter().copied().map(Some).collect();
    formats.push(None);
    for format in formats {
        let options = ReadOptions {
            format,
            ..Default::default()
        };
        if let Err(e) = read_bytes(bytes, "prop.dat", &options) {
            let text = e.to_string();
            assert!(
                text.starts_with("prop.dat"),
                "{format:?}: unlocated error: {text}"
            );
        }
    }
}

/// Text that looks like the formats: numbers, separators, labels, metadata, junk.
fn texty() -> impl Strategy<Value = Vec<u8>> {
    let token = prop_oneof![
        Just("part".to_string()),
        Just("Fs".to_string()),
        Just("\"Time (s)\"".to_string()),
        Just("Acceleration x (m/s^2)".to_string()),
        Just("t".to_string()),
        Just("ax".to_string()),
        Just("acc_x".to_string()),
        Just("samples".to_string()),
        Just("NaN".to_string()),
        (-1e5f64..1e5).prop_map(|v| format!("{v}")),
        (0u32..100).prop_map(|v| v.to_string()),
        "[a-z_]{1,5}",
    ];
    let sep = prop_oneof![
        Just(","),
        Just(";"),
        Just("\t"),
        Just(" "),
        Just("\n"),
        Just("\r\n"),
        Just("#")
    ];
    proptest::collection::vec((token, sep), 0..60)
        .prop_map(|v| v.into_iter().flat_map(|(t, s)| (t + s).into_bytes()).collect())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        check_any_bytes(&bytes);
    }

    #[test]
    fn format_like_text_never_panics(bytes in texty()) {
        check_any_bytes(&bytes);
    }

    #[test]
    fn gx1_scan_accounts_for_every_byte(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let (packets, faults) = gx1::scan(&bytes);
        let in_packets: usize = packets.iter().map(|p| match p {
            gx1::Gx1Packet::Vectors(_) => VECTORS_LEN,
            gx1::Gx1Packet::Eeprom { .. } => EEPROM_REPLY_LEN,
        }).sum();
        let skipped: usize = faults.iter().map(|f| f.skipped).sum();
        prop_assert_eq!(in_packets + skipped, bytes.len());
    }
}

fn simulated(n: usize, seed: u64) -> Recording {
    // A sensor on a 33⅓ rpm turntable: gravity on z, centripetal and tangential terms on x/y.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let w = 33.333 / 60.0 * std::f64::consts::TAU;
    let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
    let noise = |rng: &mut rand_chacha::ChaCha8Rng| rng.gen_range(-0.02..0.02);
    let accel = [
        time_s
            .iter()
            .map(|t| 0.1 * w * w * (w * t).cos() + noise(&mut rng))
            .collect(),
        time_s
            .iter()
            .map(|t| 0.1 * w * w * (w * t).sin() + noise(&mut rng))
            .collect(),
        time_s.iter().map(|_| 9.80665 + noise(&mut rng)).collect(),
    ];
    Recording {
        time_s,
        accel_mps2: accel,
        gyro_radps: None,
        temperature_c: None,
        source: Source::default(),
    }
}

#[test]
fn gx1_round_trip_survives_corrupted_and_truncated_packets() {
    let rec = simulated(3000, 1);
    let bytes = gx1::encode(&rec, &Gx1EncodeOptions::default()).unwrap();
    let (clean, report) = gx1::decode(&bytes, "clean.bin", &Gx1Options::default()).unwrap();
    assert!(report.faults.is_empty());
    let lsb = 9.80665 * 5000.0 / 32_768_000.0;
    for a in 0..3 {
        for (x, y) in rec.accel_mps2[a].iter().zip(&clean.accel_mps2[a]) {
            assert!((x - y).abs() <= 0.5 * lsb + 1e-12);
        }
    }
    for (x, y) in rec.time_s.iter().zip(&clean.time_s) {
        assert!((x - y).abs() <= 0.5 * TICK_S + 1e-9);
    }

    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    for round in 0..20 {
        // Damage 5 % of the packets: flip a byte, cut a tail, or insert junk before them.
        let mut damaged = bytes[..EEPROM_REPLY_LEN].to_vec();
        let mut intact = Vec::new();
        for k in 0..rec.len() {
            let start = EEPROM_REPLY_LEN + k * VECTORS_LEN;
            let mut p = bytes[start..start + VECTORS_LEN].to_vec();
            match rng.gen_range(0..60) {
                0 => {
                    let at = rng.gen_range(1..VECTORS_LEN);
                    p[at] ^= 1 << rng.gen_range(0..8);
                }
                1 => p.truncate(rng.gen_range(1..VECTORS_LEN)),
                2 => {
                    let junk: Vec<u8> = (0..rng.gen_range(1..30)).map(|_| rng.gen()).collect();
                    damaged.extend(junk);
                    intact.push(k);
                }
                _ => intact.push(k),
            }
            damaged.extend(p);
        }
        let (back, report) = gx1::decode(&damaged, "damaged.bin", &Gx1Options::default()).unwrap();
        // Every intact packet comes back, with its sample unchanged; damaged ones are reported.
        let expected: Vec<f64> = intact.iter().map(|&k| clean.accel_mps2[0][k]).collect();
        assert_eq!(back.len(), intact.len(), "round {round}: {:?}", report.faults);
        assert_eq!(back.accel_mps2[0], expected, "round {round}");
        let lost = rec.len() - intact.len();
        assert!(report.faults.len() >= lost.min(1), "round {round}");
        for f in &report.faults {
            assert!(f.offset < damaged.len());
        }
    }
}
