//! Unit tests of the phone readers' pieces: text normalisation, meta/time.csv, Metadata.csv,
//! the pairing rule, and the refusal of a zip without the `phone` feature.

use super::pair::merge;
use super::phyphox::{classify, SetKind, TimeReference};
use super::sensor_logger::Metadata;
use super::text::{Members, PhoneCsv, Stream};
use super::*;
use crate::input::table::Delimiter;

#[test]
fn phone_csv_finds_separator_decimal_comma_and_unicode_minus() {
    let csv = PhoneCsv::new(b"\n\"Time (s)\";\"X (m/s^2)\"\n0,5;\xE2\x88\x921,25E0\n", "f");
    assert_eq!(csv.delimiter, Delimiter::Semicolon);
    assert!(csv.decimal_comma);
    assert_eq!(csv.header, ["Time (s)", "X (m/s^2)"]);
    assert_eq!(
        String::from_utf8_lossy(&csv.text),
        "\n\"Time (s)\";\"X (m/s^2)\"\n0.5;-1.25E0\n"
    );
    // Semicolon with a decimal point (phyphox's third variant) keeps its points.
    let csv = PhoneCsv::new(b"\"a\";\"b\"\n1.5;2\n", "f");
    assert!(!csv.decimal_comma);
    let csv = PhoneCsv::new(b"\"a\",\"b\"\n1.5,2\n", "f");
    assert_eq!((csv.delimiter, csv.decimal_comma), (Delimiter::Comma, false));
}

#[test]
fn phyphox_sets_are_told_apart_by_their_names() {
    let h = |names: &[&str]| names.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let ios_accel = h(&["Time (s)", "X (m/s^2)", "Y (m/s^2)", "Z (m/s^2)"]);
    assert_eq!(classify("Accelerometer", &ios_accel), SetKind::AccelerometerIos);
    assert_eq!(
        classify("Linear Accelerometer", &ios_accel),
        SetKind::LinearAcceleration
    );
    assert_eq!(
        classify(
            "Raw Data",
            &h(&[
                "Time (s)",
                "Gyroscope x (rad/s)",
                "Gyroscope y (rad/s)",
                "Gyroscope z (rad/s)"
            ])
        ),
        SetKind::Gyroscope
    );
    assert_eq!(
        classify(
            "Data",
            &h(&["Time (s)", "Angular velocity (rad/s)", "Acceleration (m/s^2)"])
        ),
        SetKind::Centripetal
    );
    assert_eq!(
        classify("Location", &h(&["Time (s)", "Latitude (°)"])),
        SetKind::Other
    );
}

fn members(entries: &[(&str, &str)]) -> Members {
    Members {
        source: "x.zip".into(),
        entries: entries
            .iter()
            .map(|(n, b)| (n.to_string(), b.as_bytes().to_vec()))
            .collect(),
        alone: None,
    }
}

#[test]
fn meta_time_maps_experiment_time_across_a_pause() {
    // Started at Unix 1000 s, paused at experiment time 10 s (Unix 1010), resumed at Unix 1100.
    let m = members(&[(
        "meta/time.csv",
        "\"event\";\"experiment time\";\"system time\";\"system time text\"\n\"START\";0,000000000E0;1000,000;\"a\"\n\"PAUSE\";1,000000000E1;1010,000;\"b\"\n\"START\";1,000000000E1;1100,000;\"c\"\n",
    )]);
    let r = TimeReference::read(&m).unwrap().unwrap();
    assert_eq!(r.mappings.len(), 3);
    assert_eq!(r.unix_time_of(4.0), 1004.0);
    assert_eq!(r.unix_time_of(12.0), 1102.0);
    assert_eq!(r.experiment_time_at(1004.0), Some(4.0));
    assert_eq!(r.experiment_time_at(1050.0), None, "paused then");
    assert_eq!(r.experiment_time_at(1102.0), Some(12.0));

    let bad = members(&[(
        "meta/time.csv",
        "\"event\",\"experiment time\",\"system time\"\n\"START\",x,1\n",
    )]);
    let e = TimeReference::read(&bad).unwrap_err().to_string();
    assert_eq!(e, "x.zip/meta/time.csv:2: column 2 ('x') is not a number");
}

#[test]
fn sensor_logger_metadata_by_header_name() {
    let m = Metadata::read(b"version,device name,platform,standardisation\n3,\"A, B\",ios,true\n");
    assert_eq!(m.platform.as_deref(), Some("ios"));
    assert_eq!(m.standardised, Some(true));
    let old = Metadata::read(b"platform,version\nandroid,2\n");
    assert_eq!(old.standardised, None);
}

fn stream(file: &str, times: Vec<f64>, f: impl Fn(f64) -> f64) -> Stream {
    Stream {
        file: file.into(),
        xyz: [
            times.iter().map(|&t| f(t)).collect(),
            vec![0.0; times.len()],
            vec![0.0; times.len()],
        ],
        lines: (2..times.len() + 2).collect(),
        columns: vec!["t".into(), "x".into(), "y".into(), "z".into()],
        time_s: times,
    }
}

#[test]
fn pairing_interpolates_and_drops_what_the_gyroscope_does_not_cover() {
    let accel = stream("a", (0..10).map(|i| i as f64 * 0.1).collect(), |_| 1.0);
    // Gyro from 0.15 s to 0.75 s at 20 Hz with a hole between 0.45 and 0.65 s; its x is 2t.
    let times: Vec<f64> = [0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.65, 0.7, 0.75].to_vec();
    let gyro = stream("g", times, |t| 2.0 * t);
    let l = merge(accel, Some(gyro), "pair", Format::PhyphoxZip, Vec::new()).unwrap();
    // 0.2, 0.3, 0.4, 0.7 kept; 0.5 and 0.6 fall in the 0.2 s hole (> 3 × 0.05 s).
    assert_eq!(
        l.recording.time_s,
        [0.2, 0.30000000000000004, 0.4, 0.7000000000000001]
    );
    let g = &l.recording.gyro_radps.as_ref().unwrap()[0];
    for (t, v) in l.recording.time_s.iter().zip(g) {
        assert!((v - 2.0 * t).abs() < 1e-12, "{v} at {t}");
    }
    assert_eq!(l.recording.source.lines, [4, 5, 6, 9]);
    assert!(l.notes[0].contains("6 accelerometer samples"), "{:?}", l.notes);

    let late = stream("g", vec![5.0, 5.1, 5.2], |t| t);
    let e = merge(
        stream("a", vec![0.0, 0.1], |_| 0.0),
        Some(late),
        "p",
        Format::PhyphoxZip,
        Vec::new(),
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "a and g: the accelerometer (0.000 … 0.100 s) and the gyroscope (5.000 … 5.200 s) do not overlap in time"
    );
}

#[test]
#[cfg(not(feature = "phone"))]
fn a_zip_is_detected_and_refused_by_name_without_the_phone_feature() {
    let bytes = [ZIP_MAGIC, b"\x14\x00\x00\x00\x08\x00meta/time.csv".as_slice()].concat();
    assert_eq!(super::super::detect(&bytes).format, Format::PhyphoxZip);
    let e = super::super::read_bytes(&bytes, "run.zip", &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(&e, FormatError::Phone(PhoneError::NotBuilt { file, .. }) if file == "run.zip"),
        "{e}"
    );
    assert!(e.to_string().contains("`phone` feature"), "{e}");
}

/// One stored zip member: its local file header (APPNOTE 4.3.7) and its bytes.
fn stored_member(name: &str, data: &[u8]) -> Vec<u8> {
    let mut out = ZIP_MAGIC.to_vec();
    out.extend_from_slice(&[20, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(&(name.len() as u16).to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(name.as_bytes());
    out.extend_from_slice(data);
    out
}

#[test]
fn a_zip_is_a_workbook_by_its_member_names_not_by_bytes_inside_its_data() {
    // A phyphox zip whose data holds "xl/" (its deflated CSVs can, by chance) stays a phyphox zip.
    let phyphox = [
        stored_member(
            "Accelerometer.csv",
            b"\"Time (s)\",\"Acceleration x (m/s^2)\"\nxl/\n",
        ),
        stored_member("meta/time.csv", b"\"event\""),
    ]
    .concat();
    assert_eq!(sniff(&phyphox).unwrap().format, Format::PhyphoxZip);
    // A workbook by its members, the first or a later one within the head.
    for names in [
        ["[Content_Types].xml", "_rels/.rels"],
        ["docProps/app.xml", "xl/workbook.xml"],
    ] {
        let book = [stored_member(names[0], b"<x/>"), stored_member(names[1], b"<x/>")].concat();
        assert_eq!(sniff(&book).unwrap().format, Format::PhyphoxExcel, "{names:?}");
    }
    let logger = [
        stored_member("Metadata.csv", b"version"),
        stored_member("Gyroscope.csv", b"t"),
    ]
    .concat();
    assert_eq!(sniff(&logger).unwrap().format, Format::SensorLogger);
}
