//! The streaming reader's tests: order keys, exact medians over passes, and agreement with the
//! whole-file reader on inspections and on refusals.

use super::median::{key, unkey, Kth};
use super::*;

#[test]
fn order_keys_follow_total_cmp_and_invert() {
    let values = [-f64::INFINITY, -2.5, -0.0, 0.0, 1e-300, 3.0, f64::MAX];
    for w in values.windows(2) {
        assert!(key(w[0]) < key(w[1]), "{w:?}");
    }
    for v in values {
        assert_eq!(unkey(key(v)).to_bits(), v.to_bits());
    }
}

/// The k-th by histogram passes equals the k-th of the sorted values, beyond what is kept.
#[test]
fn kth_over_several_passes_is_exact() {
    let n = KEEP * 3 + 17;
    let value = |i: usize| {
        let x = (i as f64 * 0.618_033_988_749_895).fract();
        // Most values in one narrow band, so the first histogram does not settle it.
        if i.is_multiple_of(5) {
            -x * 1e3
        } else {
            9.81 + x * 1e-9
        }
    };
    let mut sorted: Vec<f64> = (0..n).map(value).collect();
    sorted.sort_by(f64::total_cmp);
    for rank in [0, n / 2, n - 1] {
        let mut kth = Kth::new();
        let mut passes = 0;
        let found = loop {
            passes += 1;
            (0..n).for_each(|i| kth.push(value(i)));
            if let Some(v) = kth.end_pass(rank as u64) {
                break v;
            }
        };
        assert_eq!(found.to_bits(), sorted[rank].to_bits(), "rank {rank}");
        assert!(passes > 1 || rank == 0, "{passes}");
    }
}

/// The streamed inspection and the whole-file one agree on `text` read with `options`.
fn agree(text: &str, options: &ReadOptions) -> Inspection {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.csv");
    std::fs::write(&path, text).unwrap();
    let whole = read_path(&path, options).unwrap();
    let expected = inspect(&whole.recording, None);
    let (loaded, found) = stream(&path, options, None).unwrap().expect("streamed");
    assert_eq!(format!("{found:?}"), format!("{expected:?}"));
    assert_eq!(loaded.format, whole.format);
    assert_eq!(loaded.detection, whole.detection);
    assert_eq!(loaded.raw_counts, whole.raw_counts);
    assert_eq!(loaded.notes, whole.notes);
    assert_eq!(loaded.recording.source.columns, whole.recording.source.columns);
    assert_eq!(loaded.recording.source.metadata, whole.recording.source.metadata);
    assert_eq!(loaded.recording.source.format, whole.recording.source.format);
    found
}

/// A 100 Hz recording with jitter, a gap, repeated stamps, rails (the gyro's z pinned at
/// 250 °/s for samples 1000–1399) and a temperature of `distinct` values.
fn recording(n: usize, distinct: usize) -> String {
    let mut s = String::from("# logger v1\nt_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp_c\n");
    for i in 0..n {
        let jitter = if (4995..5005).contains(&i) {
            0.0
        } else {
            ((i * 7919) % 13) as f64 * 0.01
        };
        let t = if (5000..5003).contains(&i) {
            49_990.0
        } else {
            i as f64 * 10.0 + jitter + if i > 20_000 { 70.0 } else { 0.0 }
        };
        let ax = if (300..310).contains(&i) {
            2.0
        } else {
            ((i as f64) * 0.01).sin()
        };
        let temp = 20.0 + (i % distinct) as f64 * 0.001 + (i as f64) * 1e-9;
        s += &format!(
            "{t},{ax},{},{},0.1,-0.2,{},{temp}\n",
            (i % 17) as f64 * 0.01,
            1.0 - (i % 3) as f64 * 1e-3,
            if (1000..1400).contains(&i) {
                250.0
            } else {
                (i % 5) as f64
            }
        );
    }
    s
}

#[test]
fn streamed_inspection_equals_the_whole_file_one() {
    let text = recording(30_000, 50);
    let found = agree(&text, &ReadOptions::default());
    assert_eq!((found.samples, found.gap_count), (30_000, 2));
    assert!(
        found.repeated_times >= 2 && !found.saturation.is_empty(),
        "{found:?}"
    );
    let pinned: Vec<(char, usize)> = found
        .gyro_saturation
        .iter()
        .map(|s| (s.axis, s.samples))
        .collect();
    assert_eq!(pinned, [('z', 400)]);
    // Distinct temperatures beyond what one pass keeps.
    let found = agree(
        &recording(KEEP_DISTINCT + 5_000, usize::MAX),
        &ReadOptions::default(),
    );
    assert_eq!(found.temperature.unwrap().distinct_values, KEEP_DISTINCT + 5_000);
    // Few samples: the windows are shorter than 64.
    for n in [1, 2, 9, 100, 513, 514, 600] {
        agree(&recording(n, 7), &ReadOptions::default());
    }
    let options = ReadOptions {
        sample_rate_hz: Some(50.0),
        accel_scale: Some(2.0),
        accel_offset: Some([0.5, 0.0, -1.0]),
        ..ReadOptions::default()
    };
    agree(&text, &options);
    agree(
        &text,
        &ReadOptions {
            retime: true,
            ..ReadOptions::default()
        },
    );
    agree(
        &text,
        &ReadOptions {
            retime: true,
            sample_rate_hz: Some(20.0),
            ..ReadOptions::default()
        },
    );
}

#[test]
fn whitespace_files_and_raw_counts_agree() {
    let mut counts = String::new();
    let mut si = String::new();
    for i in 0..40_000 {
        let t = i as f64 * 0.005;
        counts += &format!(
            "{t} {} {} {}\n",
            100 + i % 7,
            -50 + (i % 11) as i64,
            16_000 + (i % 13) as i64
        );
        si += &format!("{t}   {}  {} 9.{}\n", (i % 7) as f64 * 0.01, -0.02, 80 + i % 3);
    }
    let found = agree(&counts, &ReadOptions::default());
    assert_eq!(found.samples, 40_000);
    agree(&si, &ReadOptions::default());
    agree(
        &counts,
        &ReadOptions {
            accel_scale: Some(9.81 / 16384.0),
            ..ReadOptions::default()
        },
    );
}

#[test]
fn a_file_the_stream_refuses_is_read_whole_with_the_same_message() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.csv");
    // Time goes backwards across a block boundary; then an empty cell in an unused column.
    let mut text = String::from("t,ax,ay,az,note\n");
    for i in 0..BLOCK_ROWS + 10 {
        let t = if i == BLOCK_ROWS { 0.0 } else { i as f64 * 0.01 };
        text += &format!("{t},0.1,0.2,9.8,1\n");
    }
    std::fs::write(&path, &text).unwrap();
    let options = ReadOptions::default();
    assert!(stream(&path, &options, None).unwrap().is_none());
    let e = inspect_path(&path, &options, None).unwrap_err().to_string();
    assert_eq!(e, read_path(&path, &options).unwrap_err().to_string());
    assert!(e.contains("time goes backwards"), "{e}");
    std::fs::write(&path, "t,ax,ay,az,note\n0,0,0,9.8,1\n0.01,0,0,9.8,\n").unwrap();
    let (_, found) = inspect_path(&path, &options, None).unwrap();
    assert_eq!(found.samples, 2);
}
