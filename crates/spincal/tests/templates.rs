//! The campaign templates of `spincal init` against the campaign reader: each one written with
//! its unit named after its folder, its files simulated in the layout it asks for (a phyphox
//! zip with both sensors, a breakout board's g/°/s log, a PX4 ULog), then read and every
//! recording loaded, so a template can never drift from the keys or the readers.

use std::path::Path;

use rand::Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;
use spincal::campaign::file::{Campaign, EntryKind};
use spincal::campaign::load::load_campaign;
use spincal::campaign::template::{write_campaign_template, Device, TemplateError};
use spincal::input::recording::STANDARD_GRAVITY;

/// Writes `device`'s template into `dir/<folder>/campaign.toml` and returns its path.
fn written(dir: &Path, device: Device, folder: &str) -> std::path::PathBuf {
    let path = dir.join(folder).join("campaign.toml");
    let replaced = write_campaign_template(device, &path, false).unwrap();
    assert!(replaced.is_empty());
    // Never replaced unasked, even its own unedited output.
    let again = write_campaign_template(device, &path, false).unwrap_err();
    assert!(matches!(again, TemplateError::Exists { .. }), "{again}");
    path
}

/// A breakout board's log as the template asks the sketch to print it: counts converted to g
/// and °/s, milliseconds, the die temperature; still, z up, with white noise.
fn breakout_log(seed: u64) -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut text = String::from("t_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp_c\n");
    for i in 0..400 {
        let mut noise = |sd: f64| sd * (rng.gen::<f64>() - 0.5) * 3.46;
        text += &format!(
            "{},{:.5},{:.5},{:.5},{:.3},{:.3},{:.3},{:.2}\n",
            i * 10,
            noise(0.004),
            noise(0.004),
            1.0 + noise(0.004),
            noise(0.05),
            noise(0.05),
            noise(0.05),
            30.0 + 0.001 * i as f64
        );
    }
    text
}

#[test]
fn the_breakout_template_reads_a_log_in_the_layout_it_asks_for() {
    let dir = tempfile::tempdir().unwrap();
    let path = written(dir.path(), Device::Breakout, "mpu-6050 #2");
    let folder = path.parent().unwrap();
    for (k, file) in Device::Breakout.recording_files().iter().enumerate() {
        std::fs::write(folder.join(file), breakout_log(k as u64)).unwrap();
    }
    let campaign = Campaign::read_path(&path).unwrap();
    assert_eq!(campaign.unit, "mpu-6050 #2");
    let datasheet = campaign.datasheet;
    // The datasheet's range and nonlinearity are stated; its offset, sensitivity and cross-axis
    // figures are typical values, so the template leaves them as comments.
    assert!(
        datasheet.nonlinearity.is_some()
            && datasheet.zero_g_offset_mg.is_none()
            && datasheet.sensitivity_tolerance_pct.is_none()
            && datasheet.cross_axis_pct.is_none(),
        "{datasheet:?}"
    );
    let loaded = load_campaign(&campaign).unwrap();
    assert_eq!(loaded.len(), 4);
    for unit in &loaded {
        let r = &unit.recording;
        // g converted to m/s², ms to s, °/s to rad/s: the units the header names.
        let z = r.accel_mps2[2].iter().sum::<f64>() / r.len() as f64;
        assert!((z - STANDARD_GRAVITY).abs() < 0.01, "{}: {z}", unit.name);
        assert!((r.time_s[1] - r.time_s[0] - 0.01).abs() < 1e-12, "{}", unit.name);
        let gyro = r.gyro_radps.as_ref().expect("gyro columns");
        assert!(
            gyro[0].iter().all(|w| w.abs() < 0.1_f64.to_radians()),
            "{}",
            unit.name
        );
        assert!(r.temperature_c.is_some(), "{}", unit.name);
    }
}

#[cfg(feature = "phone")]
#[test]
fn the_phone_template_reads_phyphox_zips_with_both_sensors() {
    use crate::phone::writer::{self, App, VARIANTS};
    let dir = tempfile::tempdir().unwrap();
    let path = written(dir.path(), Device::Phone, "phone-2026-11-28");
    let folder = path.parent().unwrap();
    let accel = writer::times(0.0, 200.0, 400);
    let gyro = writer::times(-0.01, 190.0, 420);
    let zip = writer::phyphox_zip(
        App::Android,
        &[
            writer::accelerometer_set(App::Android, &accel),
            writer::gyroscope_set(App::Android, &gyro),
        ],
        VARIANTS[0],
        1_796_126_400.0,
    );
    for file in Device::Phone.recording_files() {
        std::fs::write(folder.join(file), &zip).unwrap();
    }
    let campaign = Campaign::read_path(&path).unwrap();
    assert_eq!(campaign.unit, "phone-2026-11-28");
    let runs = campaign
        .recordings
        .iter()
        .filter(|e| matches!(e.kind, EntryKind::Turntable(_)))
        .count();
    assert_eq!(runs, 4, "two speeds in two placements");
    let loaded = load_campaign(&campaign).unwrap();
    assert_eq!(loaded.len(), 5);
    assert!(loaded.iter().all(|u| u.recording.gyro_radps.is_some()));
}

#[cfg(feature = "ulog")]
#[test]
fn the_flight_controller_template_reads_ulogs_with_their_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let path = written(dir.path(), Device::FlightController, "fc");
    let folder = path.parent().unwrap();
    let log = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/flight/px4_sensor_accel.ulg");
    for file in Device::FlightController.recording_files() {
        std::fs::copy(&log, folder.join(file)).unwrap();
    }
    let campaign = Campaign::read_path(&path).unwrap();
    assert_eq!(campaign.unit, "fc");
    assert!(campaign
        .recordings
        .iter()
        .all(|e| matches!(e.kind, EntryKind::Static)));
    let loaded = load_campaign(&campaign).unwrap();
    assert_eq!(loaded.len(), 2);
    assert!(loaded.iter().all(|u| u.recording.temperature_c.is_some()));
}
