//! A corrector file, on any bytes: loaded or refused, never a panic. A file that loads is valid,
//! survives a save and reload unchanged, and is applied (streamed and, for a network, in batch)
//! to finite samples without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::correctors::corrector::Corrector;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::input::recording::Recording;

/// Finite readings, m/s²: rest, gravity on each axis, extremes.
const SAMPLES: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 9.80665],
    [9.80665, -0.5, 0.25],
    [-1e300, 1e300, f64::MIN_POSITIVE],
    [f64::MAX, f64::MIN, -0.0],
    [-3.0, 2.0, -9.80665],
];

fuzz_target!(|data: &[u8]| {
    // Lossy, so mutations that break UTF-8 still reach the JSON reader.
    let text = String::from_utf8_lossy(data);
    let Ok(file) = CorrectorFile::from_json(&text, "fuzz.json") else {
        return;
    };
    assert!(file.validate().is_ok());
    let again = CorrectorFile::from_json(&file.to_json(), "again.json").expect("a saved model reloads");
    assert_eq!(again, file);

    let corrector = &file.corrector;
    let warmup = corrector.warmup_samples();
    let axes = corrector.corrected_axes();
    assert!(!axes.is_empty() && axes.len() <= 3);
    // Enough samples to get past the delay history (at most MAX_DELAYS).
    let n = warmup + SAMPLES.len();
    let mut stream = corrector.stream();
    for i in 0..n {
        let sample = stream.correct_sample(SAMPLES[i % SAMPLES.len()]);
        assert_eq!(sample.valid, i >= warmup, "sample {i}, warmup {warmup}");
    }

    let recording = Recording {
        time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
        accel_mps2: std::array::from_fn(|c| (0..n).map(|i| SAMPLES[i % SAMPLES.len()][c]).collect()),
        gyro_radps: None,
        temperature_c: None,
        source: Default::default(),
    };
    let corrected = corrector.correct(&recording);
    assert_eq!(corrected.valid.len(), n);
    if let CorrectorModel::Ann(model) = corrector {
        let batch = model.correct_batch(&recording);
        assert_eq!(batch.len(), axes.len());
        assert!(batch.iter().all(|b| b.len() == n - warmup));
    }
});
