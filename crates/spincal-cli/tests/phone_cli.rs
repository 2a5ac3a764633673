//! Black-box tests of phone exports: a phyphox zip written as the app writes it (one CSV per
//! sensor, meta/), from a `spincal simulate` recording, through `inspect` and `fit`.

use std::io::Write;

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// phyphox Android's number format (Java `0.000000000E0`).
fn number(v: f64) -> String {
    format!("{v:.9e}").replace('e', "E")
}

/// A phyphox simple-experiment zip (Accelerometer.csv, Gyroscope.csv, meta/) of a simulated
/// turntable recording; the gyroscope on its own clock, a quarter sample late.
fn phyphox_zip(csv: &str) -> Vec<u8> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    // simulate's layout: t_s, then ax, ay, az with a unit suffix, then the gyro when simulated.
    let col = |prefix: &str| header.iter().position(|h| h.starts_with(prefix));
    let g_unit = if header[1].ends_with("_g") { 9.80665 } else { 1.0 };
    let t = 0;
    let a = [1, 2, 3];
    let g = match (col("gx"), col("gy"), col("gz")) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let dt = rows[1][t] - rows[0][t];
    let set = |names: [&str; 3], cols: [usize; 3], shift: f64, unit: f64| {
        let mut s = format!(
            "\"Time (s)\",\"{}\",\"{}\",\"{}\"\n",
            names[0], names[1], names[2]
        );
        for r in &rows {
            s += &format!(
                "{},{},{},{}\n",
                number(r[t] + shift),
                number(r[cols[0]] * unit),
                number(r[cols[1]] * unit),
                number(r[cols[2]] * unit)
            );
        }
        s
    };
    let mut files = vec![(
        "Accelerometer.csv",
        set(
            [
                "Acceleration x (m/s^2)",
                "Acceleration y (m/s^2)",
                "Acceleration z (m/s^2)",
            ],
            a,
            0.0,
            g_unit,
        ),
    )];
    if let Some(g) = g {
        files.push((
            "Gyroscope.csv",
            set(
                [
                    "Gyroscope x (rad/s)",
                    "Gyroscope y (rad/s)",
                    "Gyroscope z (rad/s)",
                ],
                g,
                0.25 * dt,
                1.0,
            ),
        ));
    }
    files.push((
        "meta/device.csv",
        "\"property\",\"value\"\n\"deviceModel\",\"Pixel 7\"\n\"deviceBrand\",\"google\"\n".into(),
    ));
    files.push((
        "meta/time.csv",
        "\"event\",\"experiment time\",\"system time\",\"system time text\"\n\"START\",0.000000000E0,1796126400.000,\"2026-11-28 12:00:00.000 UTC+00:00\"\n".into(),
    ));
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, text) in files {
        out.start_file(name, options).unwrap();
        out.write_all(text.as_bytes()).unwrap();
    }
    out.finish().unwrap().into_inner()
}

#[test]
fn inspect_and_fit_take_a_phyphox_zip() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    spincal()
        .args(["simulate", "--duration", "20", "--seed", "3", "-o"])
        .arg(&csv)
        .assert()
        .success();
    let text = std::fs::read_to_string(&csv).unwrap();
    let zip = dir.path().join("Turntable 2026-11-28 12-00-00.zip");
    std::fs::write(&zip, phyphox_zip(&text)).unwrap();

    let out = spincal().arg("inspect").arg(&zip).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("format: phyphox-zip (detected: zip holding phyphox's Accelerometer.csv")
            && stdout.contains("with meta/device.csv, meta/time.csv)"),
        "{stdout}"
    );

    // The same recording fits from the zip as from its CSV.
    let fit = |path: &std::path::Path| {
        let out = spincal().arg("fit").arg(path).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .find_map(|l| {
                l.split_once("fitted ω = ")
                    .and_then(|(_, r)| r.split_once(" rpm"))
                    .map(|(w, _)| w.to_string())
            })
            .unwrap()
    };
    assert_eq!(fit(&zip), fit(&csv));
}
