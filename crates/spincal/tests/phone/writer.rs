//! Writes phone exports exactly as the apps lay them out (header text, separators, number
//! formats, meta files), from a known motion, so the readers are tested on the apps' bytes.
//!
//! The layouts, from the apps' sources and documentation:
//! - phyphox Android (DataExport.java `CsvFormat`): quoted header joined by the separator, one
//!   line per row ending `\n`, numbers as Java's `0.000000000E0` with the chosen decimal mark;
//!   `meta/device.csv` (`"property","value"`) and `meta/time.csv` (`"event","experiment
//!   time","system time","system time text"`, system time as `############0.000`).
//! - phyphox iOS (ExperimentExportSet.swift): the header, then `\n` + row for each row (no final
//!   newline), numbers scientific with 10 significant digits; time.csv's with 16.
//! - Sensor Logger (README, UNITS.md): `time,seconds_elapsed,z,y,x`, `time` in epoch ns,
//!   Metadata.csv a header row and a value row.
//! - Physics Toolbox: a blank first line, `;` with a decimal comma, U+2212 minus signs.

use std::io::Write;

use spincal::input::recording::STANDARD_GRAVITY;

/// A phone on a turntable: the platter turns about z at a rate that wobbles ±5 % at 0.5 Hz, the
/// phone's z tilted 2° so gravity swings through x and y once a turn; the chip sits 80 mm out on
/// x. Android's sign convention (+g on z face up), SI units.
pub struct Motion;

impl Motion {
    pub const OMEGA_RADPS: f64 = 3.490658503988659; // 33⅓ rpm
    const WOW: f64 = 0.05;
    const WOW_HZ: f64 = 0.5;
    const RADIUS_M: f64 = 0.08;
    const TILT_RAD: f64 = 2.0 * std::f64::consts::PI / 180.0;

    fn rate(t: f64) -> f64 {
        Self::OMEGA_RADPS * (1.0 + Self::WOW * (2.0 * std::f64::consts::PI * Self::WOW_HZ * t).sin())
    }

    fn angle(t: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * Self::WOW_HZ;
        Self::OMEGA_RADPS * (t + Self::WOW * (1.0 - (w * t).cos()) / w)
    }

    /// Specific force, m/s² (x, y, z).
    pub fn accel(t: f64) -> [f64; 3] {
        let (w, phi) = (Self::rate(t), Self::angle(t));
        let dw = Self::OMEGA_RADPS
            * Self::WOW
            * 2.0
            * std::f64::consts::PI
            * Self::WOW_HZ
            * (2.0 * std::f64::consts::PI * Self::WOW_HZ * t).cos();
        let g = STANDARD_GRAVITY;
        [
            -w * w * Self::RADIUS_M + g * Self::TILT_RAD.sin() * phi.cos(),
            dw * Self::RADIUS_M - g * Self::TILT_RAD.sin() * phi.sin(),
            g * Self::TILT_RAD.cos(),
        ]
    }

    /// Rotation rate, rad/s (x, y, z): the wobble's tilt shows on x and y.
    pub fn gyro(t: f64) -> [f64; 3] {
        let (w, phi) = (Self::rate(t), Self::angle(t));
        [0.02 * phi.sin(), 0.02 * phi.cos(), w]
    }

    /// The largest change of any axis of `f` within `dt` around any of `times`: the error a
    /// misalignment of `dt` makes.
    pub fn change_within(f: fn(f64) -> [f64; 3], times: &[f64], dt: f64) -> f64 {
        times
            .iter()
            .flat_map(|&t| {
                let (a, b) = (f(t), f(t + dt));
                (0..3).map(move |k| (a[k] - b[k]).abs())
            })
            .fold(0.0, f64::max)
    }
}

/// Sample times: `n` at `rate_hz` from `start_s`, each jittered by up to ±10 % of an interval
/// (a fixed pattern, so the files are the same every run).
pub fn times(start_s: f64, rate_hz: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let jitter = 0.1 * ((i as f64 * 1.618_033_988_75).fract() * 2.0 - 1.0);
            start_s + (i as f64 + jitter) / rate_hz
        })
        .collect()
}

/// phyphox's separator and decimal mark: the five CSV variants of its export dialog
/// (DataExport.java `exportFormats`; ExperimentExportSet.swift `exportTypes`).
#[derive(Clone, Copy, Debug)]
pub struct Variant {
    pub separator: char,
    pub decimal: char,
}

pub const VARIANTS: [Variant; 5] = [
    Variant {
        separator: ',',
        decimal: '.',
    },
    Variant {
        separator: '\t',
        decimal: '.',
    },
    Variant {
        separator: ';',
        decimal: '.',
    },
    Variant {
        separator: '\t',
        decimal: ',',
    },
    Variant {
        separator: ';',
        decimal: ',',
    },
];

/// Java's `DecimalFormat("0.000000000E0")` (phyphox Android) and Apple's scientific
/// NumberFormatter with 10 significant digits (phyphox iOS) print the same text.
pub fn phyphox_number(v: f64, decimal: char) -> String {
    let s = format!("{v:.9e}").replace('e', "E");
    if decimal == ',' {
        s.replace('.', ",")
    } else {
        s
    }
}

/// Which phyphox app wrote the export.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum App {
    Android,
    Ios,
}

/// One export set: its name, its column names and its rows.
pub struct Set {
    pub name: String,
    pub header: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

fn set(name: &str, header: &[&str], times: &[f64], f: fn(f64) -> [f64; 3], absolute: bool) -> Set {
    Set {
        name: name.into(),
        header: header.iter().map(|s| s.to_string()).collect(),
        rows: times
            .iter()
            .map(|&t| {
                let v = f(t);
                let mut row = vec![t, v[0], v[1], v[2]];
                if absolute {
                    row.push((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
                }
                row
            })
            .collect(),
    }
}

/// A simple experiment's accelerometer set (SimpleExperimentCreator.java; SimpleExperimentTemplete.swift).
pub fn accelerometer_set(app: App, times: &[f64]) -> Set {
    match app {
        App::Android => set(
            "Accelerometer",
            &[
                "Time (s)",
                "Acceleration x (m/s^2)",
                "Acceleration y (m/s^2)",
                "Acceleration z (m/s^2)",
            ],
            times,
            Motion::accel,
            false,
        ),
        App::Ios => set(
            "Accelerometer",
            &["Time (s)", "X (m/s^2)", "Y (m/s^2)", "Z (m/s^2)"],
            times,
            Motion::accel,
            false,
        ),
    }
}

/// A simple experiment's gyroscope set.
pub fn gyroscope_set(app: App, times: &[f64]) -> Set {
    match app {
        App::Android => set(
            "Gyroscope",
            &[
                "Time (s)",
                "Gyroscope x (rad/s)",
                "Gyroscope y (rad/s)",
                "Gyroscope z (rad/s)",
            ],
            times,
            Motion::gyro,
            false,
        ),
        App::Ios => set(
            "Gyroscope",
            &["Time (s)", "X (rad/s)", "Y (rad/s)", "Z (rad/s)"],
            times,
            Motion::gyro,
            false,
        ),
    }
}

/// The built-in "Acceleration with g" experiment's set "Raw Data" (accelerometer.phyphox).
pub fn raw_data_set(times: &[f64]) -> Set {
    set(
        "Raw Data",
        &[
            "Time (s)",
            "Acceleration x (m/s^2)",
            "Acceleration y (m/s^2)",
            "Acceleration z (m/s^2)",
            "Absolute acceleration (m/s^2)",
        ],
        times,
        Motion::accel,
        true,
    )
}

/// The simple experiment's "Linear Acceleration" set (Android) or "Linear Accelerometer" (iOS).
pub fn linear_set(app: App, times: &[f64]) -> Set {
    let gravity_removed = |t: f64| {
        let a = Motion::accel(t);
        [a[0], a[1], a[2] - STANDARD_GRAVITY]
    };
    match app {
        App::Android => set(
            "Linear Acceleration",
            &[
                "Time (s)",
                "Linear Acceleration x (m/s^2)",
                "Linear Acceleration y (m/s^2)",
                "Linear Acceleration z (m/s^2)",
            ],
            times,
            gravity_removed,
            false,
        ),
        App::Ios => set(
            "Linear Accelerometer",
            &["Time (s)", "X (m/s^2)", "Y (m/s^2)", "Z (m/s^2)"],
            times,
            gravity_removed,
            false,
        ),
    }
}

/// The built-in "Centripetal acceleration" experiment's set "Data" at 2 Hz (centripetal_acceleration.phyphox).
pub fn centripetal_set(seconds: usize) -> Set {
    Set {
        name: "Data".into(),
        header: vec![
            "Time (s)".into(),
            "Angular velocity (rad/s)".into(),
            "Acceleration (m/s^2)".into(),
        ],
        rows: (0..2 * seconds)
            .map(|i| {
                let t = i as f64 / 2.0;
                vec![t, Motion::rate(t), Motion::rate(t).powi(2) * 0.08]
            })
            .collect(),
    }
}

/// One set as phyphox writes it in `variant`.
pub fn phyphox_csv(app: App, s: &Set, variant: Variant) -> Vec<u8> {
    let sep = variant.separator.to_string();
    let header: Vec<String> = s.header.iter().map(|h| format!("\"{h}\"")).collect();
    let rows = s.rows.iter().map(|r| {
        r.iter()
            .map(|&v| phyphox_number(v, variant.decimal))
            .collect::<Vec<_>>()
            .join(&sep)
    });
    let text = match app {
        App::Android => {
            let mut t = header.join(&sep) + "\n";
            for r in rows {
                t += &r;
                t.push('\n');
            }
            t
        }
        App::Ios => {
            let mut t = header.join(&sep);
            for r in rows {
                t.push('\n');
                t += &r;
            }
            t
        }
    };
    text.into_bytes()
}

/// meta/device.csv.
pub fn device_csv(app: App, variant: Variant) -> Vec<u8> {
    let sep = variant.separator;
    let rows: &[(&str, &str)] = match app {
        App::Android => &[
            ("version", "1.2.0"),
            ("build", "1020009"),
            ("fileFormat", "1.19"),
            ("deviceModel", "Pixel 7"),
            ("deviceBrand", "google"),
            ("deviceBaseOS", ""),
            ("deviceRelease", "14"),
        ],
        App::Ios => &[
            ("version", "1.2.0"),
            ("build", "10200"),
            ("fileFormat", "1.19"),
            ("deviceModel", "iPhone14,5"),
            ("deviceBrand", "Apple"),
            ("deviceRelease", "17.5"),
        ],
    };
    let mut t = format!("\"property\"{sep}\"value\"\n");
    for (k, v) in rows {
        t += &format!("\"{k}\"{sep}\"{v}\"\n");
    }
    t.into_bytes()
}

/// meta/time.csv: one START at experiment time 0 and Unix time `start_unix_s`.
pub fn time_csv(app: App, variant: Variant, start_unix_s: f64) -> Vec<u8> {
    let sep = variant.separator;
    let decimal = |s: String| {
        if variant.decimal == ',' {
            s.replace('.', ",")
        } else {
            s
        }
    };
    let system = match app {
        App::Android => decimal(format!("{start_unix_s:.3}")),
        App::Ios => decimal(format!("{start_unix_s:.15e}").replace('e', "E")),
    };
    format!(
        "\"event\"{sep}\"experiment time\"{sep}\"system time\"{sep}\"system time text\"\n\"START\"{sep}{}{sep}{system}{sep}\"2026-11-28 12:00:00.000 UTC+00:00\"\n",
        phyphox_number(0.0, variant.decimal)
    )
    .into_bytes()
}

/// A zip of `files` (name, bytes), deflated as the apps do.
pub fn zip(files: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in files {
        out.start_file(name.as_str(), options).unwrap();
        out.write_all(bytes).unwrap();
    }
    out.finish().unwrap().into_inner()
}

/// A phyphox zip export of `sets` with its meta files.
pub fn phyphox_zip(app: App, sets: &[Set], variant: Variant, start_unix_s: f64) -> Vec<u8> {
    let mut files: Vec<(String, Vec<u8>)> = sets
        .iter()
        .map(|s| (format!("{}.csv", s.name), phyphox_csv(app, s, variant)))
        .collect();
    files.push(("meta/device.csv".into(), device_csv(app, variant)));
    files.push(("meta/time.csv".into(), time_csv(app, variant, start_unix_s)));
    zip(&files)
}

/// phyphox Android's Excel export (DataExport.java `ExcelFormat`): a sheet per set with a bold
/// header row of strings and number cells, then "Metadata Device" and "Metadata Time".
pub fn phyphox_xlsx(sets: &[Set], start_unix_s: f64) -> Vec<u8> {
    let mut book = rust_xlsxwriter::Workbook::new();
    for s in sets {
        let sheet = book.add_worksheet();
        sheet.set_name(&s.name).unwrap();
        for (c, h) in s.header.iter().enumerate() {
            sheet.write_string(0, c as u16, h).unwrap();
        }
        for (r, row) in s.rows.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                sheet.write_number(r as u32 + 1, c as u16, *v).unwrap();
            }
        }
    }
    let sheet = book.add_worksheet();
    sheet.set_name("Metadata Device").unwrap();
    for (r, (k, v)) in [
        ("property", "value"),
        ("deviceModel", "Pixel 7"),
        ("deviceBrand", "google"),
    ]
    .iter()
    .enumerate()
    {
        sheet.write_string(r as u32, 0, *k).unwrap();
        sheet.write_string(r as u32, 1, *v).unwrap();
    }
    let sheet = book.add_worksheet();
    sheet.set_name("Metadata Time").unwrap();
    for (c, h) in ["event", "experiment time", "system time", "system time text"]
        .iter()
        .enumerate()
    {
        sheet.write_string(0, c as u16, *h).unwrap();
    }
    sheet.write_string(1, 0, "START").unwrap();
    sheet.write_number(1, 1, 0.0).unwrap();
    sheet.write_number(1, 2, start_unix_s).unwrap();
    sheet
        .write_string(1, 3, "2026-11-28 12:00:00.000 UTC+00:00")
        .unwrap();
    book.save_to_buffer().unwrap()
}

/// One Sensor Logger sensor file: `time,seconds_elapsed,z,y,x`, `time` in epoch ns.
pub fn sensor_logger_csv(
    epoch0_ns: i64,
    start_ns: i64,
    times: &[f64],
    values: impl Fn(f64) -> [f64; 3],
) -> Vec<u8> {
    let mut t = String::from("time,seconds_elapsed,z,y,x\n");
    for &s in times {
        let ns = epoch0_ns + (s * 1e9).round() as i64;
        let v = values(s);
        t += &format!(
            "{ns},{},{},{},{}\n",
            (ns - start_ns) as f64 * 1e-9,
            v[2],
            v[1],
            v[0]
        );
    }
    t.into_bytes()
}

/// Sensor Logger's Metadata.csv (the columns README "Accessing Recording Metadata" lists).
pub fn sensor_logger_metadata(platform: &str, standardised: bool) -> Vec<u8> {
    format!(
        "version,device name,recording time,platform,platform version,appVersion,recording timezone,recording epoch time,standardisation\n3,\"Kim's phone, 2\",2026-11-28_12-00-00,{platform},17.5,1.62.0,Europe/London,1796126400000,{standardised}\n"
    )
    .into_bytes()
}

/// Physics Toolbox's multi-sensor CSV in a decimal-comma locale: a blank first line, `;`,
/// decimal commas and U+2212 minus signs, the accelerometer as g-force (g).
pub fn physics_toolbox_csv(times: &[f64], with_gyro: bool) -> Vec<u8> {
    let number = |v: f64| format!("{v:.6}").replace('.', ",").replace('-', "\u{2212}");
    let mut t = String::from("\ntime;gFx;gFy;gFz");
    if with_gyro {
        t += ";wx;wy;wz";
    }
    t += ";TgF\n";
    for &s in times {
        let a = Motion::accel(s).map(|v| v / STANDARD_GRAVITY);
        let mut fields = vec![number(s), number(a[0]), number(a[1]), number(a[2])];
        if with_gyro {
            fields.extend(Motion::gyro(s).map(number));
        }
        fields.push(number((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()));
        t += &fields.join(";");
        t.push('\n');
    }
    t.into_bytes()
}
