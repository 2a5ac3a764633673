//! A simulated phone session as files: each recording as its app exports it (a zip), the campaign
//! file and truth.json.
//!
//! The layouts, as `input::formats::phone` reads them and from the apps' sources:
//! - phyphox Android (DataExport.java `CsvFormat`, comma and decimal point): per set a quoted
//!   header joined by `,`, one row per line ending `\n`, numbers as Java's
//!   `DecimalFormat("0.000000000E0")`; a simple experiment's sets `Accelerometer` ("Time (s)",
//!   "Acceleration x (m/s^2)", …) and `Gyroscope` ("Gyroscope x (rad/s)", …)
//!   (SimpleExperimentCreator.java); `meta/device.csv` (`"property","value"`) and `meta/time.csv`
//!   (`"event","experiment time","system time","system time text"`, system time as
//!   `############0.000`).
//! - Sensor Logger (awesome-sensor-logger README, UNITS.md): `time,seconds_elapsed,z,y,x` with
//!   `time` in integer epoch ns; `TotalAcceleration.csv` (with gravity, m/s²), `Gyroscope.csv`
//!   (rad/s), `Accelerometer.csv` (gravity removed), `Metadata.csv` (a header row and a row of
//!   values).

use std::io::Write;
use std::path::{Path, PathBuf};

use super::{PhoneApp, PhoneRecording, PhoneSession, SensorStream};
use crate::simulate::fleet::{create_folder_for, WriteError};

/// Java's `DecimalFormat("0.000000000E0")`: ten significant digits, `E`, no `+` in the exponent.
pub(super) fn java_scientific(v: f64) -> String {
    format!("{v:.9e}").replace('e', "E")
}

/// One phyphox set as Android's CSV export writes it (comma, decimal point).
fn phyphox_set(names: [&str; 3], stream: &SensorStream) -> Vec<u8> {
    let mut text = format!(
        "\"Time (s)\",\"{}\",\"{}\",\"{}\"\n",
        names[0], names[1], names[2]
    );
    for (s, &t) in stream.time_s.iter().enumerate() {
        text.push_str(&java_scientific(t));
        for k in 0..3 {
            text.push(',');
            text.push_str(&java_scientific(stream.values[k][s]));
        }
        text.push('\n');
    }
    text.into_bytes()
}

/// The UTC date and time of Unix time `unix_s` as phyphox's "system time text" writes it.
pub(super) fn utc_text(unix_s: f64) -> String {
    let total_ms = (unix_s * 1e3).round() as i64;
    let (days, ms_of_day) = (total_ms.div_euclid(86_400_000), total_ms.rem_euclid(86_400_000));
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let (h, m, s, ms) = (
        ms_of_day / 3_600_000,
        ms_of_day / 60_000 % 60,
        ms_of_day / 1000 % 60,
        ms_of_day % 1000,
    );
    format!("{year:04}-{month:02}-{day:02} {h:02}:{m:02}:{s:02}.{ms:03} UTC+00:00")
}

fn phyphox_files(r: &PhoneRecording) -> Vec<(String, Vec<u8>)> {
    let device = [
        ("version", "1.2.0"),
        ("build", "1020009"),
        ("fileFormat", "1.19"),
        ("deviceModel", "spincal simulated phone"),
        ("deviceBrand", "spincal"),
        ("deviceBaseOS", ""),
        ("deviceRelease", "14"),
    ]
    .iter()
    .fold(String::from("\"property\",\"value\"\n"), |t, (k, v)| {
        t + &format!("\"{k}\",\"{v}\"\n")
    });
    let time = format!(
        "\"event\",\"experiment time\",\"system time\",\"system time text\"\n\"START\",{},{:.3},\"{}\"\n",
        java_scientific(0.0),
        r.start_unix_s,
        utc_text(r.start_unix_s)
    );
    vec![
        (
            "Accelerometer.csv".into(),
            phyphox_set(
                [
                    "Acceleration x (m/s^2)",
                    "Acceleration y (m/s^2)",
                    "Acceleration z (m/s^2)",
                ],
                &r.accel_mps2,
            ),
        ),
        (
            "Gyroscope.csv".into(),
            phyphox_set(
                [
                    "Gyroscope x (rad/s)",
                    "Gyroscope y (rad/s)",
                    "Gyroscope z (rad/s)",
                ],
                &r.gyro_radps,
            ),
        ),
        ("meta/device.csv".into(), device.into_bytes()),
        ("meta/time.csv".into(), time.into_bytes()),
    ]
}

/// One Sensor Logger file: `time,seconds_elapsed,z,y,x`; `values` maps a sample to what is written.
fn sensor_logger_csv(start_ns: i64, stream: &SensorStream, values: impl Fn(usize) -> [f64; 3]) -> Vec<u8> {
    let mut text = String::from("time,seconds_elapsed,z,y,x\n");
    for (s, &t) in stream.time_s.iter().enumerate() {
        let ns = start_ns + (t * 1e9).round() as i64;
        let v = values(s);
        text.push_str(&format!(
            "{ns},{},{},{},{}\n",
            (ns - start_ns) as f64 * 1e-9,
            v[2],
            v[1],
            v[0]
        ));
    }
    text.into_bytes()
}

fn sensor_logger_files(r: &PhoneRecording, gravity: f64) -> Vec<(String, Vec<u8>)> {
    let start_ns = (r.start_unix_s * 1e3).round() as i64 * 1_000_000;
    let accel = |s: usize| std::array::from_fn(|k| r.accel_mps2.values[k][s]);
    let metadata = format!(
        "version,device name,recording time,platform,platform version,appVersion,recording timezone,recording epoch time,standardisation\n3,spincal simulated phone,{},android,14,1.62.0,UTC,{},false\n",
        utc_text(r.start_unix_s)[..19].replace(' ', "_").replace(':', "-"),
        start_ns / 1_000_000
    );
    vec![
        ("Metadata.csv".into(), metadata.into_bytes()),
        (
            "TotalAcceleration.csv".into(),
            sensor_logger_csv(start_ns, &r.accel_mps2, accel),
        ),
        (
            "Gyroscope.csv".into(),
            sensor_logger_csv(start_ns, &r.gyro_radps, |s| {
                std::array::from_fn(|k| r.gyro_radps.values[k][s])
            }),
        ),
        // The app's gravity-removed stream is in the export too (never read for calibration).
        (
            "Accelerometer.csv".into(),
            sensor_logger_csv(start_ns, &r.accel_mps2, |s| {
                let a: [f64; 3] = accel(s);
                let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(1e-9);
                a.map(|v| v - gravity * v / norm)
            }),
        ),
    ]
}

/// A zip of `files` (name, bytes), deflated as the apps write them.
fn zip(files: &[(String, Vec<u8>)]) -> Result<Vec<u8>, String> {
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in files {
        out.start_file(name.as_str(), options)
            .map_err(|e| e.to_string())?;
        out.write_all(bytes).map_err(|e| e.to_string())?;
    }
    Ok(out.finish().map_err(|e| e.to_string())?.into_inner())
}

impl PhoneSession {
    /// Recording `i`'s export as the session's app writes it: the zip's bytes.
    pub fn export(&self, i: usize) -> Result<Vec<u8>, WriteError> {
        let r = &self.recordings[i];
        let files = match self.truth.setup.app {
            PhoneApp::Phyphox => phyphox_files(r),
            PhoneApp::SensorLogger => sensor_logger_files(r, self.truth.setup.gravity_mps2),
        };
        zip(&files).map_err(|message| WriteError::Archive {
            path: r.file.clone(),
            message,
        })
    }

    /// The campaign file for the exports, named as [`PhoneRecording::file`] beside it: every
    /// recording in one `session` (the phone stays on), the runs of a placement under its label,
    /// no radius unless the setup states the phone's centre.
    pub fn campaign_toml(&self) -> String {
        let setup = &self.truth.setup;
        let app = match setup.app {
            PhoneApp::Phyphox => "phyphox simple-experiment zips (accelerometer and gyroscope)",
            PhoneApp::SensorLogger => "Sensor Logger zips",
        };
        let mut text = format!(
            "# A simulated phone session (spincal simulate --phone, seed {}): {app}.\n# Still poses, then turntable runs; the chip's radius is {}.\nunit = \"{}\"\n# The accelerometer's datasheet: range (± g) and nonlinearity (% of full scale).\nrange_g = {}\nnonlinearity_pct_fs = {}\n",
            self.truth.seed,
            if setup.stated_radius_tol_m.is_some() {
                "the phone's centre within a wide tolerance"
            } else {
                "not stated: the runs of each placement find it"
            },
            setup.unit,
            setup.accel_range_g,
            setup.accel_nonlinearity_pct_fs,
        );
        if setup.gravity_mps2 != crate::input::recording::STANDARD_GRAVITY {
            text.push_str(&format!("gravity_mps2 = {}\n", setup.gravity_mps2));
        }
        for r in &self.recordings {
            text.push_str(&format!("\n[[recording]]\nfile = \"{}\"\n", r.file));
            match &r.run {
                None => text.push_str("kind = \"static\"\n"),
                Some(run) => {
                    text.push_str(&format!(
                        "kind = \"turntable\"\nrpm = {}\nout = \"{}\"\nup = \"+z\"\nplacement = \"{}\"\n",
                        run.rpm,
                        run.out.name(),
                        run.placement
                    ));
                    if let Some((value, tolerance)) = run.stated_radius_m {
                        text.push_str(&format!("radius_m = {value}\nradius_tol_m = {tolerance}\n"));
                    }
                }
            }
            text.push_str("session = \"phone\"\n");
        }
        text
    }

    /// The files [`PhoneSession::write_folder`] writes into `dir`.
    pub fn folder_files(&self, dir: &Path) -> Vec<PathBuf> {
        let mut files = vec![dir.join("campaign.toml"), dir.join("truth.json")];
        files.extend(self.recordings.iter().map(|r| dir.join(&r.file)));
        files
    }

    /// Writes every export, campaign.toml and truth.json into `dir`. Refuses to replace a file
    /// already there unless `replace` (a folder this program made itself, such as the demo's).
    pub fn write_folder(&self, dir: &Path, replace: bool) -> Result<(), WriteError> {
        let files = if replace {
            Vec::new()
        } else {
            self.folder_files(dir)
        };
        create_folder_for(dir, &files)?;
        for (i, r) in self.recordings.iter().enumerate() {
            crate::output::write_bytes(&dir.join(&r.file), &self.export(i)?)?;
        }
        let truth = serde_json::to_string_pretty(&self.truth).expect("the truth serialises") + "\n";
        crate::output::write_bytes(&dir.join("truth.json"), truth.as_bytes())?;
        crate::output::write_bytes(&dir.join("campaign.toml"), self.campaign_toml().as_bytes())?;
        Ok(())
    }
}
