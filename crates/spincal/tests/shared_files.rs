//! Every file in ../shared/data, read as shipped (skipped with a printed reason when the folder is
//! absent). The list of expected files is here: a file added to the folder fails this test until it
//! is listed with how spincal reads it (at most a `--columns`-style choice, a unit or a rate, as a
//! user would pass on the command line) and a sanity value taken from the data's own documentation
//! (README.md beside it, or the file's own section limits); files that are not data are listed as
//! such, with the reason.

// Axis loops index several parallel per-axis arrays at once.
#![allow(clippy::needless_range_loop)]

use crate::common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use spincal::input::formats::{read_bytes, read_path, read_table, Format, Loaded, ReadOptions};
use spincal::input::recording::{ColumnMap, GyroUnit};
use spincal::input::table::{read_file, Table, TableOptions};

/// How a file is read, and what it must give.
enum How {
    /// As a recording (`spincal inspect FILE [options]`), then checked.
    Recording(ReadOptions, fn(&Path, &Loaded)),
    /// As a numeric table with these columns (`spincal sysid --data FILE --input … --output …`).
    Table(&'static [&'static str], fn(&Path, &Table)),
    /// Not a recording or a table spincal reads; why.
    NotData(&'static str),
}

fn options(format: Option<Format>, columns: Option<&str>) -> ReadOptions {
    let mut map = ColumnMap::default();
    if let Some(c) = columns {
        map = map.with_columns(c).unwrap();
    }
    ReadOptions {
        format,
        columns: map,
        ..Default::default()
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Mean of each axis over samples `range`.
fn axis_means(axes: &[Vec<f64>; 3], range: std::ops::Range<usize>) -> [f64; 3] {
    std::array::from_fn(|a| mean(&axes[a][range.clone()]))
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Median of |a| over all samples.
fn median_norm(axes: &[Vec<f64>; 3]) -> f64 {
    let mut n: Vec<f64> = (0..axes[0].len())
        .map(|i| norm([axes[0][i], axes[1][i], axes[2][i]]))
        .collect();
    n.sort_by(f64::total_cmp);
    n[n.len() / 2]
}

fn data_lines(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| {
            l.trim_start()
                .starts_with(|c: char| c == '-' || c == '.' || c.is_ascii_digit())
        })
        .count()
}

/// imu_tk's Xsens files: 51,175 rows, 100 Hz, the first ~50 s still.
fn xsens_acc(path: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), 51_175, "{}", path.display());
    assert!(l.raw_counts);
    assert!((r.sample_rate_hz() - 100.0).abs() < 0.5);
    // README: factory offset and scale (counts per m/s²), local g = 9.81744 m/s².
    let m = axis_means(&r.accel_mps2, 0..4000);
    let offset = [33123.0, 33276.0, 32360.0];
    let scale = [415.0, 413.0, 415.0];
    let g = norm(std::array::from_fn(|a| (m[a] - offset[a]) / scale[a]));
    assert!((g / 9.81744 - 1.0).abs() < 0.02, "still |a| = {g} m/s²");
}

fn xsens_gyro(path: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), 51_175, "{}", path.display());
    // Gyro counts (in the file's four columns: t and three axes) sit near mid-scale at rest.
    let m = axis_means(&r.accel_mps2, 0..4000);
    for v in m {
        assert!((v - 32768.0).abs() < 1000.0, "still gyro counts {m:?}");
    }
}

/// T265: stamps of 2 decimals at ~200 Hz (half repeat); m/s² and rad/s.
fn t265_acc(path: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), data_lines(path));
    assert!(!l.raw_counts);
    let span_rate = (r.len() - 1) as f64 / r.duration_s();
    assert!((r.sample_rate_hz() / span_rate - 1.0).abs() < 0.01);
    assert!((r.sample_rate_hz() - 200.0).abs() < 5.0, "{}", r.sample_rate_hz());
    let g = norm(axis_means(&r.accel_mps2, 0..200));
    assert!((g / 9.81 - 1.0).abs() < 0.05, "first second |a| = {g} m/s²");
}

fn t265_gyr(path: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), data_lines(path));
    let w = norm(axis_means(&r.accel_mps2, 0..200));
    assert!(w < 0.05, "first second |ω| = {w} rad/s");
}

/// imucal's annotated session: ~2048 counts per g (README), gyro counts kept.
fn imucal_session(_: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), 9414);
    assert!(l.raw_counts && l.gyro_counts);
    let g = r.gyro_radps.as_ref().expect("gyro kept");
    assert_eq!(g[0].len(), r.len());
    let labels = l.labels.as_ref().unwrap();
    let still: Vec<usize> = (0..r.len()).filter(|&i| labels[i] == "z_p").collect();
    let z = mean(&still.iter().map(|&i| r.accel_mps2[2][i]).collect::<Vec<_>>());
    assert!((z / 2048.0 - 1.0).abs() < 0.1, "z_p: {z} counts");
}

/// The Ferraris session (m/s², deg/s, 102.4 Hz; README): its section limits are in the JSON beside it.
fn ferraris_session(path: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), 10_376);
    assert!(
        (r.sample_rate_hz() - 102.4).abs() < 1e-9,
        "{}",
        r.sample_rate_hz()
    );
    let list = std::fs::read_to_string(path.with_file_name("example_ferraris_session_list.json")).unwrap();
    let list: serde_json::Value = serde_json::from_str(&list).unwrap();
    let section = |name: &str| {
        let s = &list[name];
        s["start"].as_u64().unwrap() as usize..s["end"].as_u64().unwrap() as usize
    };
    // Not yet calibrated (that is what the session is for): |a| at rest within 10 % of g.
    let g = norm(axis_means(&r.accel_mps2, section("x_p")));
    assert!((g / 9.81 - 1.0).abs() < 0.1, "x_p |a| = {g}");
    // Each rotation section is one full turn about its axis: ∫ω dt ≈ 2π once deg/s became rad/s.
    let gyro = r.gyro_radps.as_ref().expect("gyro kept");
    for (axis, name) in ["x_rot", "y_rot", "z_rot"].iter().enumerate() {
        let turn: f64 = gyro[axis][section(name)].iter().sum::<f64>() / 102.4;
        assert!(
            (turn.abs() / std::f64::consts::TAU - 1.0).abs() < 0.1,
            "{name}: {} degrees",
            turn.to_degrees()
        );
    }
}

fn ferraris_example(_: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), 50);
    let g = norm(axis_means(&r.accel_mps2, 0..50));
    assert!((g / 9.81 - 1.0).abs() < 0.01, "calibrated still |a| = {g}");
}

/// MPU-6050 at ±2 g: 16,384 counts per g; gyro counts kept.
fn mpu6050(path: &Path, l: &Loaded) {
    let r = &l.recording;
    assert_eq!(r.len(), data_lines(path), "{}", path.display());
    assert!(l.raw_counts && l.gyro_counts);
    assert!((r.sample_rate_hz() - 100.0).abs() < 1e-9);
    assert!(r.gyro_radps.is_some());
    // Median over still poses and motion, bias and scale uncalibrated: within 10 % of 1 g.
    let g = median_norm(&r.accel_mps2);
    assert!((g / 16384.0 - 1.0).abs() < 0.1, "median |a| = {g} counts");
}

/// Their fit [m_yz, m_zy, m_zx, s_x, s_y, s_z, b_x, b_y, b_z]: scales near 9.81/16384 m/s² per count.
fn mpu_params_acc(_: &Path, t: &Table) {
    assert_eq!(t.n_rows(), 9);
    for s in &t.columns[0][3..6] {
        // The data sheet's sensitivity tolerance is ±3 %; allow 5 %.
        assert!((s / (9.81 / 16384.0) - 1.0).abs() < 0.05, "scale {s}");
    }
}

/// Their gyro fit: 12 values, the three scales (rows 7–9) near (π/180)/131 rad/s per count (±250 °/s).
fn mpu_params_gyro(_: &Path, t: &Table) {
    assert_eq!(t.n_rows(), 12);
    for s in &t.columns[0][6..9] {
        assert!(
            (s / (1.0f64.to_radians() / 131.0) - 1.0).abs() < 0.05,
            "scale {s}"
        );
    }
}

/// Start and end sample of each still interval: two rows of ten, ends after starts.
fn mpu_static_intervals(_: &Path, t: &Table) {
    assert_eq!((t.n_rows(), t.n_columns()), (2, 10));
    for c in &t.columns {
        assert!(c[1] > c[0], "{c:?}");
    }
}

/// Silverbox: 131,072 samples, V1 the input (README); the excitation is about 80 mV peak.
fn silverbox(_: &Path, t: &Table) {
    assert_eq!(t.n_rows(), 131_072);
    let peak = t.columns[0].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!((0.05..0.3).contains(&peak), "V1 peak {peak} V");
}

fn wiener_hammerstein(_: &Path, t: &Table) {
    assert_eq!(t.n_rows(), 188_000);
    let rms = (mean(&t.columns[1].iter().map(|v| v * v).collect::<Vec<_>>())).sqrt();
    assert!(rms > 0.01 && rms < 1.0, "y rms {rms} V");
}

fn tanks(_: &Path, t: &Table) {
    assert_eq!(t.n_rows(), 1024);
    // Water levels in V, sensor range 0–10 V.
    for c in &t.columns {
        assert!(c.iter().all(|v| (-0.5..=10.5).contains(v)), "{:?}", &c[..5]);
    }
}

fn robot_arm(_: &Path, t: &Table) {
    assert_eq!(t.n_rows(), 1024);
    assert!(t.columns[0].iter().any(|v| *v != 0.0));
}

fn expected() -> Vec<(&'static str, How)> {
    use How::*;
    let rec = |format, columns| options(format, columns);
    let ferraris = || {
        let mut o = options(None, Some("n_samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"));
        o.sample_rate_hz = Some(102.4);
        o.columns.gyro_unit = Some(GyroUnit::Dps);
        o
    };
    vec![
        ("README.md", NotData("the folder's documentation")),
        ("imu/imu_tk_xsens/xsens_acc.mat", Recording(rec(None, None), xsens_acc)),
        // imu_tk keeps the gyro in a file of its own with the same four columns; spincal reads it as
        // such a table (the three axes land where accelerometer axes go).
        ("imu/imu_tk_xsens/xsens_gyro.mat", Recording(rec(None, None), xsens_gyro)),
        ("imu/realsense_t265/t265_acc.mat", Recording(rec(None, None), t265_acc)),
        ("imu/realsense_t265/t265_gyr.mat", Recording(rec(None, None), t265_gyr)),
        ("imu/realsense_t265/t265_imu_tk_run.log", NotData("imu_tk's console output")),
        (
            "imu/realsense_t265/t265_test_imu_acc.calib",
            NotData("imu_tk's accelerometer calibration (misalignment, scale, bias): spincal has no reader"),
        ),
        (
            "imu/realsense_t265/t265_test_imu_gyro.calib",
            NotData("imu_tk's gyroscope calibration: spincal has no reader"),
        ),
        ("imu/imucal/LICENSE", NotData("licence text")),
        ("imu/imucal/annotated_session.csv", Recording(rec(None, None), imucal_session)),
        (
            "imu/imucal/example_cal.json",
            NotData("imucal's Ferraris calibration JSON: spincal has no reader (tests/real_imu.rs compares against it)"),
        ),
        ("imu/imucal/example_ferraris_session.csv", Recording(ferraris(), ferraris_session)),
        (
            "imu/imucal/example_ferraris_session_list.json",
            NotData("section limits of the Ferraris session (used by its check above)"),
        ),
        ("imu/imucal/ferraris_example.csv", Recording(ferraris(), ferraris_example)),
        ("imu/mpu6050/LICENSE", NotData("licence text")),
        ("imu/mpu6050/example_data_calibration.csv", Recording(rec(None, None), mpu6050)),
        ("imu/mpu6050/imu_90_x_rot.csv", Recording(rec(None, None), mpu6050)),
        ("imu/mpu6050/params_acc.csv", Table(&["1"], mpu_params_acc)),
        ("imu/mpu6050/params_gyro.csv", Table(&["1"], mpu_params_gyro)),
        (
            "imu/mpu6050/static_intervals.csv",
            Table(&["1", "2", "3", "4", "5", "6", "7", "8", "9", "10"], mpu_static_intervals),
        ),
        ("sysid/Silverbox_SNLS80mV.csv", Table(&["V1", "V2"], silverbox)),
        ("sysid/Silverbox_SNLS80mV.mat", Table(&["V1", "V2"], silverbox)),
        ("sysid/WienerHammerBenchmark.csv", Table(&["uBenchMark", "yBenchMark"], wiener_hammerstein)),
        ("sysid/CascadedTanks_dataBenchmark.csv", Table(&["uEst", "yEst", "uVal", "yVal"], tanks)),
        ("sysid/CascadedTanks_dataBenchmark.mat", Table(&["uEst", "yEst", "uVal", "yVal"], tanks)),
        ("sysid/DaISy_robot_arm.csv", Table(&["u", "y"], robot_arm)),
    ]
}

fn walk(root: &Path, dir: &Path, out: &mut BTreeSet<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            walk(root, &path, out);
        } else {
            out.insert(
                path.strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/"),
            );
        }
    }
}

fn read_table_file(path: &Path, keys: &[&str]) -> Table {
    let file = path.display().to_string();
    let bytes = read_file(path).unwrap();
    read_table(&bytes, &file, &TableOptions::default(), keys).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_shared_file_is_read_or_listed() {
    let Some(root) = common::shared_data("") else {
        return;
    };
    let mut found = BTreeSet::new();
    walk(&root, &root, &mut found);
    let expected = expected();
    let listed: BTreeSet<String> = expected.iter().map(|(p, _)| p.to_string()).collect();
    let new: Vec<&String> = found.difference(&listed).collect();
    assert!(
        new.is_empty(),
        "files in {} not listed in this test: {new:?}",
        root.display()
    );
    let gone: Vec<&String> = listed.difference(&found).collect();
    assert!(
        gone.is_empty(),
        "listed files missing from {}: {gone:?}",
        root.display()
    );
    let mut not_data = 0;
    for (relative, how) in &expected {
        let path: PathBuf = root.join(relative);
        match how {
            How::Recording(options, check) => {
                let loaded = read_path(&path, options).unwrap_or_else(|e| panic!("{e}"));
                check(&path, &loaded);
            }
            How::Table(keys, check) => check(&path, &read_table_file(&path, keys)),
            How::NotData(why) => {
                assert!(!why.is_empty());
                not_data += 1;
            }
        }
    }
    eprintln!(
        "{} files read, {not_data} listed as not data",
        expected.len() - not_data
    );
}

/// The CSV copies hold 5 significant digits of what the MAT-files hold exactly (README).
#[test]
fn mat_files_and_their_csv_copies_agree() {
    for (stem, keys) in [
        ("sysid/Silverbox_SNLS80mV", &["V1", "V2"][..]),
        (
            "sysid/CascadedTanks_dataBenchmark",
            &["uEst", "yEst", "uVal", "yVal"][..],
        ),
    ] {
        let (Some(mat), Some(csv)) = (
            common::shared_data(&format!("{stem}.mat")),
            common::shared_data(&format!("{stem}.csv")),
        ) else {
            return;
        };
        let (m, c) = (read_table_file(&mat, keys), read_table_file(&csv, keys));
        assert_eq!(m.n_rows(), c.n_rows());
        for (k, (a, b)) in m.columns.iter().zip(&c.columns).enumerate() {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                // 5 significant digits: half a unit in the 5th digit, relative to the value.
                assert!(
                    (x - y).abs() <= 5e-5 * x.abs().max(1e-300) * 1.0001 + 1e-12,
                    "{stem} {}[{i}]: mat {x}, csv {y}",
                    keys[k]
                );
            }
        }
    }
}

/// A generic table's used column with an empty cell stays a located error; unused ones may be
/// empty. A recording leaves out, and counts, the rows that lack a used column (a logger's packets
/// of another kind).
#[test]
fn an_empty_cell_is_an_error_only_in_a_used_column() {
    let Some(path) = common::shared_data("sysid/WienerHammerBenchmark.csv") else {
        return;
    };
    let file = path.display().to_string();
    let bytes = read_file(&path).unwrap();
    let e = read_table(&bytes, &file, &TableOptions::default(), &["uBenchMark", "fs"]).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!("{file}:3, column 3 (fs): the cell is empty")
    );
    let t = read_table(&bytes, &file, &TableOptions::default(), &["yBenchMark"]).unwrap();
    assert_eq!(t.header, ["yBenchMark"]);
    // The same through the recording reader: empty cells in columns not chosen are no error.
    let text = "t,ax,ay,az,note\n0,0,0,9.8,1\n0.01,0,0,9.8,\n0.02,0,0,9.8,\n";
    let r = read_bytes(text.as_bytes(), "e.csv", &ReadOptions::default()).unwrap();
    assert_eq!(r.recording.len(), 3);
    assert!(r.notes.is_empty(), "{:?}", r.notes);
    let gap = "t,ax,ay,az,note\n0,0,0,9.8,1\n0.01,0,,9.8,\n0.02,0,0,9.8,\n";
    let r = read_bytes(gap.as_bytes(), "e.csv", &ReadOptions::default()).unwrap();
    assert_eq!(
        (r.recording.time_s.as_slice(), r.recording.source.lines.as_slice()),
        (&[0.0, 0.02][..], &[2, 4][..])
    );
    assert_eq!(
        r.notes,
        ["1 row lacks a value in a column used and was left out (the first at line 3, column 3)"]
    );
}

/// Loggers write more than a tidy CSV: a text column (a state letter), packets of another kind
/// interleaved with the IMU's (their IMU columns empty), time in integer nanoseconds since the
/// epoch, and `rostopic echo -p`'s dump (`%time` header, ns stamps, a text frame id).
#[test]
fn logger_files_read_as_they_are() {
    let mut text = String::from("time,state,ax,ay,az\n");
    let mut mixed = String::from("time,kind,ax,ay,az,baro\n");
    let mut epoch = String::from("timestamp_ns,ax,ay,az\n");
    let mut ros = String::from(
        "%time,field.header.seq,field.header.stamp,field.header.frame_id,field.linear_acceleration.x,field.linear_acceleration.y,field.linear_acceleration.z,field.angular_velocity.x,field.angular_velocity.y,field.angular_velocity.z\n",
    );
    let t0: u64 = 1_732_000_000_123_456_789;
    for i in 0..500u64 {
        let z = 9.8 + (i % 7) as f64 * 1e-3;
        text += &format!(
            "{},{},0.01,-0.02,{z}\n",
            i as f64 * 0.01,
            ["A", "B", "idle"][i as usize % 3]
        );
        if i % 10 == 3 {
            mixed += &format!("{},baro,,,,101325.5\n", i as f64 * 0.01 - 0.005);
        }
        mixed += &format!("{},imu,0.01,-0.02,{z},\n", i as f64 * 0.01);
        epoch += &format!("{},0.01,-0.02,{z}\n", t0 + i * 5_000_000);
        ros += &format!(
            "{},{i},{},imu_link,0.01,-0.02,{z},0.001,0.002,0.003\n",
            t0 + i * 5_000_000 + 777,
            t0 + i * 5_000_000
        );
    }
    let read = |text: &str, columns: Option<&str>| {
        read_bytes(text.as_bytes(), "logger.csv", &options(None, columns)).unwrap_or_else(|e| panic!("{e}"))
    };
    let l = read(&text, None);
    assert_eq!(
        (l.recording.len(), l.recording.source.columns[1].as_str()),
        (500, "ax")
    );
    assert!((l.recording.sample_rate_hz() - 100.0).abs() < 1e-6);
    let l = read(&mixed, None);
    assert_eq!(l.recording.len(), 500);
    assert_eq!(l.recording.source.incomplete_rows.count, 50);
    assert_eq!(l.recording.source.incomplete_rows.first, Some((5, 3)));
    assert!(
        l.notes.iter().any(|n| n.starts_with("50 rows lack a value")),
        "{:?}",
        l.notes
    );
    for l in [
        read(&epoch, None),
        read(&epoch.replace("timestamp_ns", "stamp"), None),
    ] {
        let t = &l.recording.time_s;
        assert!((t[0] - 1_732_000_000.123_457).abs() < 1e-6, "{}", t[0]);
        assert!(
            (l.recording.sample_rate_hz() - 200.0).abs() < 1e-3,
            "{}",
            l.recording.sample_rate_hz()
        );
    }
    // Under any other name the unit is given by --time-unit (here through the column map).
    let mut o = options(None, Some("clock,ax,ay,az"));
    o.columns.time_unit = Some(spincal::input::recording::TimeUnit::Ns);
    let l = read_bytes(
        epoch.replace("timestamp_ns", "clock").as_bytes(),
        "logger.csv",
        &o,
    )
    .unwrap();
    assert!((l.recording.sample_rate_hz() - 200.0).abs() < 1e-3);
    let l = read(&ros, None);
    assert_eq!(
        l.recording.source.columns,
        [
            "%time",
            "field.linear_acceleration.x",
            "field.linear_acceleration.y",
            "field.linear_acceleration.z",
            "field.angular_velocity.x",
            "field.angular_velocity.y",
            "field.angular_velocity.z"
        ]
    );
    assert!((l.recording.sample_rate_hz() - 200.0).abs() < 1e-3);
    let l = read(&ros, Some("field.header.stamp,5,6,7"));
    assert!((l.recording.time_s[0] - 1_732_000_000.123_457).abs() < 1e-6);
    // Text in a used column is still an error naming its place.
    let bad = text.replacen("0.01,-0.02", "n/a,-0.02", 1);
    let e = read_bytes(bad.as_bytes(), "logger.csv", &options(None, None)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "logger.csv:2, column 3 (ax): 'n/a' is not a number"
    );
}

/// `--sample-rate` replaces a time column (the Ferraris session's is a sample index).
#[test]
fn sample_rate_overrides_a_time_column() {
    let text = "n,ax,ay,az\n0,0,0,9.8\n1,0,0,9.8\n2,0,0,9.8\n";
    let plain = read_bytes(text.as_bytes(), "s.csv", &options(None, Some("n,ax,ay,az"))).unwrap();
    assert_eq!(plain.recording.time_s, [0.0, 1.0, 2.0]);
    let mut o = options(None, Some("n,ax,ay,az"));
    o.sample_rate_hz = Some(4.0);
    let timed = read_bytes(text.as_bytes(), "s.csv", &o).unwrap();
    assert_eq!(timed.recording.time_s, [0.0, 0.25, 0.5]);
    assert!(
        timed.notes.iter().any(|n| n.contains("`n` column is not used")),
        "{:?}",
        timed.notes
    );
}

/// A MAT-file is detected by its header and read as a recording through `--columns`.
#[test]
fn a_mat_file_reads_as_a_recording() {
    let Some(path) = common::shared_data("sysid/CascadedTanks_dataBenchmark.mat") else {
        return;
    };
    let mut o = options(None, Some("uEst,uVal,yEst,yVal"));
    o.sample_rate_hz = Some(0.25);
    let l = read_path(&path, &o).unwrap();
    assert_eq!(l.format, Format::Mat);
    assert_eq!(l.recording.len(), 1024);
    assert!((l.recording.duration_s() - 1023.0 * 4.0).abs() < 1e-9);
    let _ = read_bytes(b"MATLAB 5.0 MAT-file", "x.mat", &ReadOptions::default()).unwrap_err();
}
