//! Readers of text formats with layouts of their own: bare whitespace columns, imucal and MPU-6050
//! logs (phone apps' CSVs are in `phone/`).

use super::shared::table_options;
use super::{Format, FormatError, Loaded, ReadOptions};
use crate::input::recording::{ColumnMap, Recording, Source, TemperatureUnit};
use crate::input::table::{read_labelled, Delimiter, Table};

/// A whitespace file's median |a| above this is taken for raw counts: 200 m/s² (20 g) is beyond
/// most MEMS ranges, counts are in the thousands.
pub(super) const RAW_COUNTS_MPS2: f64 = 200.0;

/// imu_tk's columns: without a header or a column choice, a file of other than 4 columns is read
/// as its first four.
pub(crate) fn whitespace_map(mut map: ColumnMap, no_header: bool, width: usize) -> ColumnMap {
    if map.columns.is_none() && no_header && width != 4 {
        map.columns = Some(vec!["1".into(), "2".into(), "3".into(), "4".into()]);
    }
    map
}

/// imu_tk: `t ax ay az`, no header. Values above 200 in magnitude are taken to be raw counts.
pub(super) fn read_whitespace(
    bytes: &[u8],
    file: &str,
    options: &ReadOptions,
) -> Result<Loaded, FormatError> {
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

pub(super) fn median_abs(axes: &[Vec<f64>; 3]) -> f64 {
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

pub(super) fn column(table: &Table, names: &[&str]) -> Result<usize, FormatError> {
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
pub(super) fn read_imucal(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
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
            time_notes: Vec::new(),
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
pub(super) fn read_mpu6050(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
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
            time_notes: Vec::new(),
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
