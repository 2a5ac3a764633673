//! The format readers' tests: option checks, detection, every text format, scaling, located
//! errors.

#[test]
fn unusable_read_options_are_refused_by_name() {
    let bytes = b"ax,ay,az\n1,2,3\n4,5,6\n";
    for options in [
        ReadOptions {
            sample_rate_hz: Some(f64::NAN),
            ..Default::default()
        },
        ReadOptions {
            sample_rate_hz: Some(0.0),
            ..Default::default()
        },
        ReadOptions {
            accel_offset: Some([0.0, f64::INFINITY, 0.0]),
            ..Default::default()
        },
    ] {
        let e = read_bytes(bytes, "f.csv", &options).unwrap_err();
        assert!(matches!(e, FormatError::BadOption { .. }), "{e}");
    }
}

use super::*;

#[test]
#[cfg(not(feature = "bags"))]
fn a_bag_is_detected_and_refused_by_name_without_the_bags_feature() {
    let bytes = [bag_detect::MCAP_MAGIC, &[0u8; 32][..]].concat();
    assert_eq!(detect(&bytes).format, Format::RosBag);
    let e = read_bytes(&bytes, "imu.mcap", &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(&e, FormatError::BagsNotBuilt { file } if file == "imu.mcap"),
        "{e}"
    );
    assert!(e.to_string().contains("`bags` feature"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.bag");
    std::fs::write(&path, b"#ROSBAG V2.0\n").unwrap();
    let e = read_path(&path, &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().starts_with(&path.display().to_string()), "{e}");
}

fn read(text: &[u8]) -> Loaded {
    read_bytes(text, "f", &ReadOptions::default()).unwrap()
}

#[test]
fn detects_and_reads_every_text_format() {
    let l = read(b"part,samples,acc_x,acc_y,acc_z,gyr_x\nz_p,1,0,0,2048,1\nx_p,0,2048,0,0,1\n");
    assert_eq!(l.format, Format::Imucal);
    assert!(l.raw_counts);
    assert_eq!(l.labels.unwrap(), ["x_p", "z_p"]);
    assert_eq!(l.recording.accel_mps2[0], [2048.0, 0.0]);
    assert!((l.recording.time_s[1] - 1.0 / 204.8).abs() < 1e-15);

    let l = read(b"Fs,50\nLogging Type,0\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n7,8,9,1,2,3\n");
    assert_eq!(l.format, Format::Mpu6050);
    assert_eq!(l.recording.time_s, [0.0, 0.02]);
    assert_eq!(l.recording.accel_mps2[2], [3.0, 9.0]);

    let l = read(b"  1.0  33000 33100 36000\n  1.01  33001 33101 36001\n");
    assert_eq!(l.format, Format::Whitespace);
    assert!(l.raw_counts);

    let l = read(
        b"\"Time (s)\";\"Acceleration x (m/s^2)\";\"Acceleration y (m/s^2)\";\"Acceleration z (m/s^2)\";\"Absolute acceleration (m/s^2)\"\n0,0E0;1,5E-1;0;9,81;9,8\n1,0E-2;1;0;9,8;9,8\n",
    );
    assert_eq!(l.format, Format::Phyphox);
    assert_eq!(l.recording.accel_mps2[0], [0.15, 1.0]);
    assert_eq!(l.recording.time_s, [0.0, 0.01]);

    // Gravity removed: refused by name (phone::phyphox), no longer read with a note.
    let linear = b"\"Time (s)\"\t\"Linear Acceleration x (m/s^2)\"\t\"Linear Acceleration y (m/s^2)\"\t\"Linear Acceleration z (m/s^2)\"\n0,5\t1,25\t0\t-2\n0,75\t1\t0\t-2,5\n";
    assert_eq!(detect(linear).format, Format::Phyphox);
    let e = read_bytes(linear, "f", &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(e, FormatError::Phone(phone::PhoneError::GravityRemoved { .. })),
        "{e}"
    );

    let l = read(b"t_s,ax_g,ay_g,az_g\n0,0,0,1\n0.1,0,0,1\n");
    assert_eq!(l.format, Format::Csv);
}

#[test]
fn scale_and_offset_convert_counts() {
    let options = ReadOptions {
        accel_scale: Some(0.5),
        accel_offset: Some([10.0, 0.0, 0.0]),
        ..Default::default()
    };
    let l = read_bytes(b"0 30 2 4\n1 10 4 6\n", "w", &options).unwrap();
    assert!(!l.raw_counts);
    assert_eq!(l.recording.accel_mps2[0], [10.0, 0.0]);
}

#[test]
fn errors_are_located() {
    let e = read_bytes(b"Fs,abc\nax,ay,az\n1,2,3\n", "m.csv", &ReadOptions::default()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "m.csv:1: sample rate 'abc' is not a positive number"
    );
    let e = read_bytes(
        b"part,samples,acc_x,acc_y,acc_z\nx,0,1,2,3\ny,0,1,2,3\n",
        "i.csv",
        &ReadOptions::default(),
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .starts_with("i.csv:3: the `samples` index 0 repeats"),
        "{e}"
    );
}
