//! Readers for the formats IMU users log, chosen by [`Format`] or detected from the first bytes.
//!
//! Every reader returns a [`Loaded`]: the [`Recording`] plus what the reader learned (format and why
//! it was chosen, whether the accelerometer values are still raw counts, section labels, 3DM-GX1
//! stream faults). Raw-count formats keep counts in `accel_mps2` unless a scale is given
//! ([`ReadOptions::accel_scale`]); [`Loaded::raw_counts`] says which.

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

// The ROS bag readers (and the SQLite and compressors they need) with the `bags` feature;
// without it a bag is still detected, and refused.
#[cfg(feature = "bags")]
pub mod bag;
pub mod bag_detect;
pub mod gx1;
pub mod mat;
pub mod streamed;

use std::path::Path;

use serde::Serialize;

use crate::input::recording::{ColumnMap, Recording, RecordingError, Source, TemperatureUnit};
use crate::input::table::{read_labelled, Delimiter, Table, TableError, TableOptions};
use gx1::{Gx1Error, Gx1Options, Gx1Report};

/// The file formats spincal reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Format {
    /// Delimited text with a header naming time and acceleration columns (spincal's own files).
    Csv,
    /// imu_tk's whitespace-separated `t ax ay az` rows, no header.
    Whitespace,
    /// imucal's CSV with a text `part` column labelling sections, raw counts, a `samples` index.
    Imucal,
    /// MPU-6050 logger CSV: metadata lines (`Fs,100`), header `ax,ay,az,gx,gy,gz`, int16 counts.
    Mpu6050,
    /// phyphox's CSV export (`"Time (s)","Acceleration x (m/s^2)"`, …), any separator, decimal comma.
    Phyphox,
    /// Microstrain 3DM-GX1 binary serial stream.
    Gx1,
    /// MATLAB v5 MAT-file: numeric variables become columns (see [`mat`]).
    Mat,
    /// ROS bag: ROS 2 (MCAP or sqlite3 storage, file or bag directory) or ROS 1 (format 2.0);
    /// `sensor_msgs/Imu` or `geometry_msgs/Vector3Stamped` accelerometer (+ gyro) topics.
    RosBag,
}

impl Format {
    pub const ALL: [Format; 8] = [
        Format::Csv,
        Format::Whitespace,
        Format::Imucal,
        Format::Mpu6050,
        Format::Phyphox,
        Format::Gx1,
        Format::Mat,
        Format::RosBag,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Whitespace => "whitespace",
            Format::Imucal => "imucal",
            Format::Mpu6050 => "mpu6050",
            Format::Phyphox => "phyphox",
            Format::Gx1 => "3dm-gx1",
            Format::Mat => "mat",
            Format::RosBag => "rosbag",
        }
    }

    /// Parses a format name (`csv`, `whitespace`/`imu-tk`, `imucal`, `mpu6050`, `phyphox`, `3dm-gx1`/`gx1`,
    /// `rosbag`/`bag`).
    pub fn parse(text: &str) -> Option<Format> {
        match text.to_ascii_lowercase().as_str() {
            "imu-tk" | "imu_tk" | "imutk" => Some(Format::Whitespace),
            "gx1" | "3dmgx1" => Some(Format::Gx1),
            "mpu-6050" => Some(Format::Mpu6050),
            "matlab" => Some(Format::Mat),
            "bag" | "ros" | "ros-bag" | "mcap" | "db3" => Some(Format::RosBag),
            t => Format::ALL.into_iter().find(|f| f.name() == t),
        }
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

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

/// How to read a file.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Format; detected when `None`.
    pub format: Option<Format>,
    /// Column choice and units for `csv` (and separators for every text format).
    pub columns: ColumnMap,
    /// m/s² per count (or per file unit): a = (value − offset) · scale. Turns raw counts into SI.
    pub accel_scale: Option<f64>,
    /// Per-axis offset subtracted before scaling, in file units.
    pub accel_offset: Option<[f64; 3]>,
    /// Sample rate for formats without a time column (overrides `Fs` metadata; imucal: 204.8 Hz).
    pub sample_rate_hz: Option<f64>,
    pub gx1: Gx1Options,
    /// ROS bags: the topic to read (`accel,gyro` for two `Vector3Stamped` topics); without it a
    /// bag with one IMU topic is read and one with several is refused with the list.
    pub topic: Option<String>,
    /// Replace the timestamps by t₀ + i·Δt, Δt from all the timestamps (for coarse, repeated or
    /// jittered stamps). Dropped samples are not restored: use it on recordings without gaps.
    pub retime: bool,
    /// ROS bags: a file whose end is damaged (cut, its footer or index lost) gives the messages
    /// before the damage, with a note, instead of an error naming how many are intact.
    pub salvage: bool,
}

/// A recording and what its reader learned.
#[derive(Debug, Clone, Serialize)]
pub struct Loaded {
    #[serde(skip)]
    pub recording: Recording,
    pub format: Format,
    /// Present when the format was detected rather than given.
    pub detection: Option<Detection>,
    /// `accel_mps2` holds raw counts (no scale was given for a raw-count format).
    pub raw_counts: bool,
    /// `gyro_radps` holds the file's raw counts, not rad/s (MPU-6050, imucal: no gyro scale is
    /// known); a consumer that needs rad/s must not use it as such.
    pub gyro_counts: bool,
    /// Per-sample section labels (imucal's `part`).
    #[serde(skip)]
    pub labels: Option<Vec<String>>,
    /// Decoder statistics for the 3DM-GX1 stream.
    pub gx1: Option<Gx1Report>,
    /// Things the user should know (synthesised time, dropped gyro counts, linear acceleration …).
    pub notes: Vec<String>,
}

/// Everything that can go wrong reading a file in any format.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Recording(#[from] RecordingError),
    #[error(transparent)]
    Gx1(#[from] Gx1Error),
    #[error(transparent)]
    Mat(#[from] mat::MatError),
    #[cfg(feature = "bags")]
    #[error(transparent)]
    Bag(#[from] bag::BagError),
    #[cfg(not(feature = "bags"))]
    #[error("{file}: a ROS bag, and this build of spincal lacks the `bags` feature that reads them")]
    BagsNotBuilt { file: String },
    #[error("{file}: no sample rate: the file has no time column and no `Fs,<Hz>` line; pass --sample-rate")]
    NoSampleRate { file: String },
    #[error("{file}:{line}: sample rate '{text}' is not a positive number")]
    BadSampleRate { file: String, line: usize, text: String },
    #[error("{file}: no column '{name}' (columns: {available})")]
    MissingColumn {
        file: String,
        name: String,
        available: String,
    },
    #[error("{file}:{line}: the `{column}` index {value} repeats or is not a whole number")]
    BadIndex {
        file: String,
        line: usize,
        column: String,
        value: f64,
    },
    #[error("accel scale must be finite and non-zero, got {0}")]
    BadScale(f64),
    #[error("read option {name} = {value}: {why}")]
    BadOption {
        name: &'static str,
        value: String,
        why: &'static str,
    },
}

/// Reads a file in the given or detected format.
pub fn read_path(path: &Path, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let file = path.display().to_string();
    // A ROS 2 bag directory, or a bag file.
    if bag_detect::is_bag_dir(path)
        || options.format == Some(Format::RosBag)
        || (options.format.is_none() && sniff_bag(path))
    {
        check_options(options)?;
        return read_bag_path(path, options);
    }
    let bytes = crate::input::table::read_file(path).map_err(|source| FormatError::Io {
        file: file.clone(),
        source,
    })?;
    read_bytes(&bytes, &file, options)
}

/// Reads an in-memory file; `file` names it in errors.
pub fn read_bytes(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    check_options(options)?;
    let detection = match options.format {
        Some(_) => None,
        None => Some(detect(bytes)),
    };
    let format = options
        .format
        .or(detection.as_ref().map(|d| d.format))
        .unwrap_or(Format::Csv);
    let loaded = match format {
        Format::Csv => {
            let recording =
                Recording::parse_csv_timed(bytes, file, &options.columns, options.sample_rate_hz)?;
            Loaded::new(recording, format, false)
        }
        Format::Whitespace => read_whitespace(bytes, file, options)?,
        Format::Imucal => read_imucal(bytes, file, options)?,
        Format::Mpu6050 => read_mpu6050(bytes, file, options)?,
        Format::Phyphox => read_phyphox(bytes, file, options)?,
        Format::Gx1 => {
            let (recording, report) = gx1::decode(bytes, file, &options.gx1)?;
            let mut l = Loaded::new(recording, format, false);
            if !report.faults.is_empty() {
                l.notes.push(format!(
                    "{} damaged stretches skipped, first at byte {}",
                    report.faults.len(),
                    report.faults[0].offset
                ));
            }
            l.gx1 = Some(report);
            l
        }
        Format::Mat => read_mat(bytes, file, options)?,
        #[cfg(feature = "bags")]
        Format::RosBag => bag_loaded(bag::read_bytes(
            bytes,
            file,
            options.topic.as_deref(),
            options.salvage,
        )?),
        #[cfg(not(feature = "bags"))]
        Format::RosBag => return Err(FormatError::BagsNotBuilt { file: file.into() }),
    };
    finish(loaded, detection, options)
}

/// Whether the file at `path` starts with a bag's magic.
fn sniff_bag(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 16];
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    let mut n = 0;
    while n < head.len() {
        match f.read(&mut head[n..]) {
            Ok(0) | Err(_) => break,
            Ok(k) => n += k,
        }
    }
    bag_detect::Storage::sniff(&head[..n]).is_some()
}

/// Reads a bag file or a ROS 2 bag directory (an sqlite3 bag is opened in place, not copied).
#[cfg(feature = "bags")]
fn read_bag_path(path: &Path, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let read = bag::read_path(path, options.topic.as_deref(), options.salvage)?;
    let detection = options.format.is_none().then(|| Detection {
        format: Format::RosBag,
        reason: if path.is_dir() {
            format!("directory with metadata.yaml ({})", read.storage.name())
        } else {
            format!("{} magic at byte 0", read.storage.name())
        },
    });
    finish(bag_loaded(read), detection, options)
}

#[cfg(not(feature = "bags"))]
fn read_bag_path(path: &Path, _: &ReadOptions) -> Result<Loaded, FormatError> {
    Err(FormatError::BagsNotBuilt {
        file: path.display().to_string(),
    })
}

#[cfg(feature = "bags")]
fn bag_loaded(read: bag::BagRead) -> Loaded {
    let mut l = Loaded::new(read.recording, Format::RosBag, false);
    l.notes = read.notes;
    l
}

fn check_options(options: &ReadOptions) -> Result<(), FormatError> {
    if let Some(rate) = options.sample_rate_hz {
        if !(rate.is_finite() && rate > 0.0) {
            return Err(FormatError::BadOption {
                name: "sample_rate_hz",
                value: rate.to_string(),
                why: "must be a finite positive rate in Hz",
            });
        }
    }
    if let Some(offset) = options.accel_offset {
        if offset.iter().any(|v| !v.is_finite()) {
            return Err(FormatError::BadOption {
                name: "accel_offset",
                value: format!("{offset:?}"),
                why: "every offset must be finite",
            });
        }
    }
    Ok(())
}

/// What every reader's result goes through: detection kept, scale and offset, re-timing.
fn finish(
    mut loaded: Loaded,
    detection: Option<Detection>,
    options: &ReadOptions,
) -> Result<Loaded, FormatError> {
    loaded.detection = detection;
    loaded.recording.source.format = loaded.format.name().into();
    if let Some(left_out) = loaded.recording.source.incomplete_rows.describe() {
        loaded.notes.push(left_out);
    }
    if let (Some(rate), Format::Csv | Format::Whitespace | Format::Phyphox | Format::Mat) =
        (options.sample_rate_hz, loaded.format)
    {
        // The rate given won over the file's time column (a sample index, or a coarse clock).
        let column = loaded
            .recording
            .source
            .columns
            .first()
            .cloned()
            .unwrap_or_default();
        loaded.notes.push(format!(
            "time = sample number / {rate} Hz (--sample-rate given; the `{column}` column is not used)"
        ));
    }
    apply_scale(&mut loaded, options)?;
    if options.retime {
        retime(&mut loaded);
    }
    Ok(loaded)
}

/// Reads the columns `keys` (header names or 1-based indices) of a numeric table in any tabular
/// format: a MAT-file (by its first bytes) or delimited text. Only those columns are kept, in that
/// order, so an empty cell elsewhere in a text file is no error.
pub fn read_table(
    bytes: &[u8],
    file: &str,
    options: &TableOptions,
    keys: &[&str],
) -> Result<Table, FormatError> {
    let table = if mat::is_mat(bytes) {
        mat::table(&mat::parse(bytes, file)?, file)?
    } else {
        return Ok(Table::parse_columns(bytes, file, options, keys)?);
    };
    let picked: Vec<usize> = keys
        .iter()
        .map(|k| {
            table.column_index(k).ok_or_else(|| FormatError::MissingColumn {
                file: file.into(),
                name: k.to_string(),
                available: table.header.join(", "),
            })
        })
        .collect::<Result<_, _>>()?;
    Ok(Table {
        header: picked.iter().map(|&c| table.header[c].clone()).collect(),
        columns: picked.iter().map(|&c| table.columns[c].clone()).collect(),
        ..table
    })
}

/// A MAT-file: its numeric variables as a table, then the columns as for `csv`.
fn read_mat(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let parsed = mat::parse(bytes, file)?;
    let table = mat::table(&parsed, file)?;
    let recording = Recording::from_table_timed(&table, &options.columns, options.sample_rate_hz)?;
    let mut l = Loaded::new(recording, Format::Mat, false);
    for s in &parsed.skipped {
        l.notes.push(format!("variable '{}' skipped: {}", s.name, s.why));
    }
    Ok(l)
}

/// Evenly spaced timestamps at the rate all the stamps give, from the first stamp.
fn retime(loaded: &mut Loaded) {
    let t = &mut loaded.recording.time_s;
    let dt = crate::input::recording::sample_interval(t);
    if let (Some(&t0), true) = (t.first(), dt.is_finite()) {
        for (i, v) in t.iter_mut().enumerate() {
            *v = t0 + i as f64 * dt;
        }
        loaded.notes.push(format!(
            "re-timed: t = {t0} s + i · {dt:.9} s (from all timestamps)"
        ));
    }
}

impl Loaded {
    fn new(recording: Recording, format: Format, raw_counts: bool) -> Loaded {
        Loaded {
            recording,
            format,
            detection: None,
            raw_counts,
            gyro_counts: false,
            labels: None,
            gx1: None,
            notes: Vec::new(),
        }
    }
}

fn apply_scale(loaded: &mut Loaded, options: &ReadOptions) -> Result<(), FormatError> {
    if options.accel_scale.is_none() && options.accel_offset.is_none() {
        return Ok(());
    }
    let scale = options.accel_scale.unwrap_or(1.0);
    if !scale.is_finite() || scale == 0.0 {
        return Err(FormatError::BadScale(scale));
    }
    let offset = options.accel_offset.unwrap_or([0.0; 3]);
    for (axis, b) in loaded.recording.accel_mps2.iter_mut().zip(offset) {
        axis.iter_mut().for_each(|v| *v = (*v - b) * scale);
    }
    if options.accel_scale.is_some() {
        loaded.raw_counts = false;
    }
    loaded
        .notes
        .push(format!("accel = (value − {offset:?}) × {scale} applied"));
    Ok(())
}

fn table_options(options: &ReadOptions, default: Option<Delimiter>) -> TableOptions {
    let mut table = options.columns.table.clone();
    table.delimiter = table.delimiter.or(default);
    table
}

/// A whitespace file's median |a| above this is taken for raw counts: 200 m/s² (20 g) is beyond
/// most MEMS ranges, counts are in the thousands.
const RAW_COUNTS_MPS2: f64 = 200.0;

/// imu_tk's columns: without a header or a column choice, a file of other than 4 columns is read
/// as its first four.
fn whitespace_map(mut map: ColumnMap, no_header: bool, width: usize) -> ColumnMap {
    if map.columns.is_none() && no_header && width != 4 {
        map.columns = Some(vec!["1".into(), "2".into(), "3".into(), "4".into()]);
    }
    map
}

/// imu_tk: `t ax ay az`, no header. Values above 200 in magnitude are taken to be raw counts.
fn read_whitespace(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let table = Table::parse(bytes, file, &table_options(options, Some(Delimiter::Whitespace)))?;
    let map = whitespace_map(
        options.columns.clone(),
        table.header.is_empty(),
        table.n_columns(),
    );
    let recording = Recording::from_table_timed(&table, &map, options.sample_rate_hz)?;
    let raw = median_abs(&recording.accel_mps2) > RAW_COUNTS_MPS2;
    let mut l = Loaded::new(recording, Format::Whitespace, raw);
    if raw {
        l.notes
            .push("values look like raw counts (|a| ≫ 20 g): pass --accel-scale to convert".into());
    }
    Ok(l)
}

fn median_abs(axes: &[Vec<f64>; 3]) -> f64 {
    let mut norms: Vec<f64> = (0..axes[0].len())
        .map(|i| (axes[0][i].powi(2) + axes[1][i].powi(2) + axes[2][i].powi(2)).sqrt())
        .collect();
    if norms.is_empty() {
        return 0.0;
    }
    let mid = norms.len() / 2;
    *norms.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// imucal's sample rate for its example session (not stated in the file).
pub const IMUCAL_SAMPLE_RATE_HZ: f64 = 204.8;

fn column(table: &Table, names: &[&str]) -> Result<usize, FormatError> {
    names
        .iter()
        .find_map(|n| table.column_index(n))
        .ok_or_else(|| FormatError::MissingColumn {
            file: table.file.clone(),
            name: names[0].to_string(),
            available: table.header.join(", "),
        })
}

/// imucal: rows grouped by `part`; the `samples` index restores time order.
fn read_imucal(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let lt = read_labelled(bytes, file, &table_options(options, None), "part")?;
    let table = &lt.table;
    let idx = column(table, &["samples", "sample"])?;
    let acc = [
        column(table, &["acc_x"])?,
        column(table, &["acc_y"])?,
        column(table, &["acc_z"])?,
    ];
    let gyro: Option<Vec<usize>> = ["gyr_x", "gyr_y", "gyr_z"]
        .iter()
        .map(|n| table.column_index(n))
        .collect();
    let fs = options.sample_rate_hz.unwrap_or(IMUCAL_SAMPLE_RATE_HZ);
    let samples = &table.columns[idx];
    let mut order: Vec<usize> = (0..table.n_rows()).collect();
    order.sort_by(|&a, &b| samples[a].total_cmp(&samples[b]));
    for w in order.windows(2) {
        let (a, b) = (samples[w[0]], samples[w[1]]);
        if a == b || a.fract() != 0.0 {
            return Err(FormatError::BadIndex {
                file: file.into(),
                line: table.lines[w[1]],
                column: table.header[idx].clone(),
                value: b,
            });
        }
    }
    let recording = Recording {
        time_s: order.iter().map(|&i| samples[i] / fs).collect(),
        accel_mps2: acc.map(|c| order.iter().map(|&i| table.columns[c][i]).collect()),
        gyro_radps: gyro
            .as_ref()
            .map(|g| std::array::from_fn(|a| order.iter().map(|&i| table.columns[g[a]][i]).collect())),
        temperature_c: None,
        source: Source {
            name: file.into(),
            format: "imucal".into(),
            columns: [idx, acc[0], acc[1], acc[2]]
                .iter()
                .chain(gyro.iter().flatten())
                .map(|&c| table.header[c].clone())
                .collect(),
            metadata: table.metadata.iter().map(|(_, s)| s.clone()).collect(),
            lines: order.iter().map(|&i| table.lines[i]).collect(),
            incomplete_rows: Default::default(),
        },
    };
    let mut l = Loaded::new(recording, Format::Imucal, true);
    l.gyro_counts = gyro.is_some();
    l.labels = Some(order.iter().map(|&i| lt.labels[i].clone()).collect());
    l.notes.push(format!(
        "time = samples / {fs} Hz; rows sorted by `samples`; gyro kept in raw counts (no scale)"
    ));
    Ok(l)
}

/// MPU-6050 logger: `Fs,<Hz>` metadata, no time column: time = i / Fs.
fn read_mpu6050(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let table = Table::parse(bytes, file, &table_options(options, None))?;
    let mut fs = None;
    for (line, text) in &table.metadata {
        let mut parts = text.splitn(2, [',', ';', '\t']);
        if parts.next().is_some_and(|k| k.trim().eq_ignore_ascii_case("fs")) {
            let v = parts.next().unwrap_or("").trim();
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => fs = Some(x),
                _ => {
                    return Err(FormatError::BadSampleRate {
                        file: file.into(),
                        line: *line,
                        text: v.into(),
                    })
                }
            }
        }
    }
    let fs = options
        .sample_rate_hz
        .or(fs)
        .ok_or_else(|| FormatError::NoSampleRate { file: file.into() })?;
    let acc = [
        column(&table, &["ax", "acc_x", "accx"])?,
        column(&table, &["ay", "acc_y", "accy"])?,
        column(&table, &["az", "acc_z", "accz"])?,
    ];
    let gyro: Option<Vec<usize>> = [
        ["gx", "gyr_x", "gyrox"],
        ["gy", "gyr_y", "gyroy"],
        ["gz", "gyr_z", "gyroz"],
    ]
    .iter()
    .map(|names| names.iter().find_map(|n| table.column_index(n)))
    .collect();
    // The logger's TEMP_OUT column, raw counts like every other column.
    let temperature = ["temp", "temperature", "temp_out"]
        .iter()
        .find_map(|n| table.column_index(n));
    let n = table.n_rows();
    let recording = Recording {
        time_s: (0..n).map(|i| i as f64 / fs).collect(),
        accel_mps2: acc.map(|c| table.columns[c].clone()),
        gyro_radps: gyro
            .as_ref()
            .map(|g| std::array::from_fn(|a| table.columns[g[a]].clone())),
        temperature_c: temperature.map(|c| {
            table.columns[c]
                .iter()
                .map(|&v| TemperatureUnit::Mpu6050Counts.to_celsius(v))
                .collect()
        }),
        source: Source {
            name: file.into(),
            format: "mpu6050".into(),
            columns: acc
                .iter()
                .chain(gyro.iter().flatten())
                .chain(temperature.iter())
                .map(|&c| table.header[c].clone())
                .collect(),
            metadata: table.metadata.iter().map(|(_, s)| s.clone()).collect(),
            lines: table.lines.clone(),
            incomplete_rows: Default::default(),
        },
    };
    let mut l = Loaded::new(recording, Format::Mpu6050, true);
    l.gyro_counts = gyro.is_some();
    l.notes.push(format!(
        "time synthesised from Fs = {fs} Hz; gyro kept in raw counts (no scale)"
    ));
    if temperature.is_some() {
        l.notes.push(
            "temperature from TEMP_OUT counts by the MPU-6050 register map's formula: °C = counts / 340 + 36.53"
                .into(),
        );
    }
    Ok(l)
}

/// phyphox export: quoted unit-bearing headers; the semicolon and tab variants may use a decimal comma.
fn read_phyphox(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let text = String::from_utf8_lossy(bytes);
    let data_line = text.lines().nth(1).unwrap_or("");
    // phyphox writes tab or semicolon only together with a decimal comma, so those win over ','.
    let delimiter = options
        .columns
        .table
        .delimiter
        .unwrap_or(if data_line.contains('\t') {
            Delimiter::Tab
        } else if data_line.contains(';') {
            Delimiter::Semicolon
        } else {
            Delimiter::Comma
        });
    let decimal_comma = delimiter != Delimiter::Comma && data_line.contains(',');
    let converted;
    let input: &[u8] = if decimal_comma {
        // Why a blanket replace: in these variants a comma can only be a decimal separator.
        converted = text.replace(',', ".");
        converted.as_bytes()
    } else {
        bytes
    };
    let mut map = options.columns.clone();
    map.table.delimiter = Some(delimiter);
    let recording = Recording::parse_csv_timed(input, file, &map, options.sample_rate_hz)?;
    let mut l = Loaded::new(recording, Format::Phyphox, false);
    if decimal_comma {
        l.notes.push("decimal comma converted".into());
    }
    if l.recording
        .source
        .columns
        .iter()
        .any(|c| c.to_ascii_lowercase().starts_with("linear acceleration"))
    {
        l.notes
            .push("phyphox 'Linear Acceleration' has gravity removed: static calibration needs 'Acceleration with g'".into());
    }
    Ok(l)
}

#[cfg(test)]
mod tests {

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

        let l = read(
            b"\"Time (s)\"\t\"Linear Acceleration x (m/s^2)\"\t\"Linear Acceleration y (m/s^2)\"\t\"Linear Acceleration z (m/s^2)\"\n0,5\t1,25\t0\t-2\n0,75\t1\t0\t-2,5\n",
        );
        assert_eq!(l.format, Format::Phyphox);
        assert_eq!(l.recording.accel_mps2[2], [-2.0, -2.5]);
        assert_eq!(l.recording.time_s, [0.5, 0.75]);
        assert!(
            l.notes.iter().any(|n| n.contains("gravity removed")),
            "{:?}",
            l.notes
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
}
