//! Black-box tests of reading flight-controller logs (the library's fixtures, made by
//! crates/spincal/tests/fixtures/flight/make_fixtures.py): detected, the instance chosen with
//! --topic, the temperature and the device id shown.

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../spincal/tests/fixtures/flight")
        .join(name)
}

fn inspect(name: &str, extra: &[&str]) -> String {
    let out = spincal()
        .arg("inspect")
        .arg(fixture(name))
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn has(text: &str, wants: &[&str]) {
    for want in wants {
        assert!(text.contains(want), "no '{want}' in\n{text}");
    }
}

#[test]
fn inspect_shows_the_instance_temperature_and_device_id_of_a_flight_log() {
    has(
        &inspect("px4_sensor_accel.ulg", &[]),
        &[
            "format: ulog (detected: ULog magic",
            "samples: 300",
            "temperature: ",
            "note: PX4 ULog: sensor_accel instance 0 read (also in the log: 1;",
            "note: accelerometer device id 2490378 (sensor_accel.device_id)",
        ],
    );
    has(
        &inspect("px4_sensor_accel.ulg", &["--topic", "sensor_accel_1"]),
        &["note: accelerometer device id 3014666", "43 interpolated"],
    );
    has(
        &inspect("px4_sensor_combined.ulg", &[]),
        &[
            "samples: 399",
            "note: no temperature: sensor_combined carries none",
        ],
    );
    has(
        &inspect("ardupilot_imu.bin", &["--topic", "IMU[1]"]),
        &[
            "format: dataflash (detected: DataFlash FMT message",
            "samples: 300",
            "temperature: ",
            "note: accelerometer device id 2752772 (PARM INS_ACC2_ID)",
        ],
    );
}

#[test]
fn a_log_read_as_the_other_format_or_an_absent_instance_is_refused_with_the_reason() {
    let out = spincal()
        .arg("inspect")
        .arg(fixture("ardupilot_imu.bin"))
        .args(["--format", "ulog"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("byte 0: not a ULog file"), "{err}");
    let out = spincal()
        .arg("inspect")
        .arg(fixture("px4_sensor_accel.ulg"))
        .args(["--topic", "sensor_accel_3"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no IMU instance 'sensor_accel_3' (the log has: sensor_accel 0, sensor_accel 1, sensor_gyro 0, sensor_gyro 1, sensor_combined 0)"),
        "{err}"
    );
}
