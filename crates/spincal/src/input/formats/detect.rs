//! Detection of a file's format from its first bytes (binary magics, then text headers).

use std::path::Path;

use serde::Serialize;

use super::{bag_detect, flight, gx1, mat, phone, Format};

/// A detected format and the evidence for it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Detection {
    pub format: Format,
    pub reason: String,
}

/// How much of a file [`detect`] looks at.
pub const DETECT_BYTES: usize = 8192;

/// The format of a regular file that is delimited text: `Csv` or `Whitespace`, given or detected
/// from its first bytes (with the detection when detected); `None` for any other format (a bag
/// whatever was given) and for anything but a regular file, whose first bytes reading would use up
/// (a pipe) or which has none (a bag directory).
pub fn delimited_text_format(
    path: &Path,
    given: Option<Format>,
) -> std::io::Result<Option<(Format, Option<Detection>)>> {
    use std::io::Read;
    if !path.is_file() {
        return Ok(None);
    }
    let mut head = Vec::with_capacity(DETECT_BYTES);
    std::fs::File::open(path)?
        .take(DETECT_BYTES as u64)
        .read_to_end(&mut head)?;
    if bag_detect::Storage::sniff(&head).is_some() {
        return Ok(None);
    }
    let detection = given.is_none().then(|| detect(&head));
    let format = given
        .or(detection.as_ref().map(|d| d.format))
        .unwrap_or(Format::Csv);
    Ok(matches!(format, Format::Csv | Format::Whitespace).then_some((format, detection)))
}

/// Guesses the format from the first bytes of a file (at most [`DETECT_BYTES`] are used).
pub fn detect(head: &[u8]) -> Detection {
    let head = &head[..head.len().min(DETECT_BYTES)];
    let found = |format, reason: &str| Detection {
        format,
        reason: reason.to_string(),
    };
    if mat::is_mat(head) {
        return found(Format::Mat, "starts with 'MATLAB 5.0 MAT-file'");
    }
    if let Some(storage) = bag_detect::Storage::sniff(head) {
        return found(Format::RosBag, &format!("{} magic at byte 0", storage.name()));
    }
    if let Some(phone) = phone::sniff(head) {
        return phone;
    }
    if let Some((format, reason)) = flight::sniff(head) {
        return found(format, reason);
    }
    // Text files have no NUL and no control bytes other than tab/CR/LF; the GX1 stream is full of them.
    let binary = head
        .iter()
        .filter(|&&b| b == 0 || (b < 0x20 && !matches!(b, b'\t' | b'\r' | b'\n')))
        .count();
    if binary > 0 {
        let (packets, _) = gx1::scan(head);
        return found(
            Format::Gx1,
            &format!(
                "binary data ({binary} control bytes in the first {} bytes, {} valid 3DM-GX1 packets)",
                head.len(),
                packets.len()
            ),
        );
    }
    let text = String::from_utf8_lossy(head);
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#') && !l.starts_with('%'))
        .collect();
    let first = lines.first().copied().unwrap_or("");
    let lower: Vec<String> = lines.iter().take(20).map(|l| l.to_ascii_lowercase()).collect();
    let header: Vec<String> = first
        .split([',', ';', '\t'])
        .map(|f| f.trim().trim_matches('"').to_string())
        .collect();
    if phone::sensor_logger::is_sensor_file(&header) {
        return found(
            Format::SensorLogger,
            "header `time,seconds_elapsed` and x, y, z (Sensor Logger)",
        );
    }
    if phone::physics_toolbox::claims(&header) {
        return found(
            Format::PhysicsToolbox,
            "header with gFx, gFy, gFz or ax, ay, az, aT (Physics Toolbox)",
        );
    }
    if lower
        .iter()
        .any(|l| l.contains("(m/s^2)") || l.contains("\"time (s)\""))
    {
        return found(Format::Phyphox, "header names like \"Time (s)\" and \"(m/s^2)\"");
    }
    let first_fields: Vec<String> = lower
        .first()
        .map(|l| {
            l.split([',', ';', '\t'])
                .map(|f| f.trim().trim_matches('"').to_string())
                .collect()
        })
        .unwrap_or_default();
    if first_fields.iter().any(|f| f == "part") {
        return found(Format::Imucal, "header has a `part` label column");
    }
    if first_fields.first().is_some_and(|f| f == "fs") {
        return found(Format::Mpu6050, "metadata line `Fs,<rate>` before the header");
    }
    let numeric = |l: &str| {
        let f: Vec<&str> = l.split_whitespace().collect();
        !f.is_empty() && f.iter().all(|x| x.parse::<f64>().is_ok())
    };
    if numeric(first) && !first.contains([',', ';']) && first.split_whitespace().count() == 4 {
        return found(
            Format::Whitespace,
            "headerless whitespace-separated rows of 4 numbers (t ax ay az)",
        );
    }
    found(Format::Csv, "delimited text (no more specific format recognised)")
}
