//! How every command reads recordings: one set of flags ([`ReadArgs`]), resolved once into the
//! library's [`ReadOptions`].

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use spincal::input::formats::{self, Loaded, ReadOptions};
use spincal::input::recording::ColumnMap;
use spincal::input::recording::Recording;

use super::values::{AccelUnitArg, DelimiterArg, FormatArg, GyroUnitArg, TimeUnitArg};
use crate::ui::{Ui, UsageError};

/// Flags that say how to read a recording file; shared by every command that reads one.
#[derive(Args, Debug, Clone, Default)]
pub struct ReadArgs {
    /// File format; detected when absent.
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub format: Option<FormatArg>,
    /// Columns holding t,ax,ay,az[,gx,gy,gz]: header names or 1-based indices (guessed when absent).
    #[arg(long, value_name = "t,ax,ay,az")]
    pub columns: Option<String>,
    /// Unit of the acceleration columns (default: from the column names, else m/s²).
    #[arg(long, value_enum, value_name = "UNIT")]
    pub accel_unit: Option<AccelUnitArg>,
    /// Unit of the gyro columns (default: from the column names, else rad/s).
    #[arg(long, value_enum, value_name = "UNIT")]
    pub gyro_unit: Option<GyroUnitArg>,
    /// Unit of the time column (default: from the column name, else s).
    #[arg(long, value_enum, value_name = "UNIT")]
    pub time_unit: Option<TimeUnitArg>,
    /// Field separator (default: detected).
    #[arg(long, value_enum, value_name = "SEP")]
    pub delimiter: Option<DelimiterArg>,
    /// Multiply (value − offset) by this to get m/s² (turns raw counts into SI).
    #[arg(long, value_name = "M/S²_PER_UNIT", value_parser = super::values::finite, allow_negative_numbers = true)]
    pub accel_scale: Option<f64>,
    /// A 16-bit accelerometer's configured range, ± g (2, 4, 8, 16: the MPU-6050's AFS_SEL):
    /// sets --accel-scale for its raw counts.
    #[arg(long, value_name = "G", conflicts_with = "accel_scale", value_parser = super::values::finite)]
    pub accel_range_g: Option<f64>,
    /// Multiply the gyro columns by this to get rad/s (turns raw counts into SI).
    #[arg(long, value_name = "RAD/S_PER_UNIT", value_parser = super::values::finite, allow_negative_numbers = true)]
    pub gyro_scale: Option<f64>,
    /// A 16-bit gyro's configured range, ± °/s (125 … 2000: the MPU-6050's FS_SEL; its default is
    /// 250): sets --gyro-scale for its raw counts.
    #[arg(long, value_name = "DEG/S", conflicts_with = "gyro_scale", value_parser = super::values::finite)]
    pub gyro_range_dps: Option<f64>,
    /// Per-axis offset `x,y,z` subtracted before --accel-scale (file units).
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true, value_name = "X,Y,Z")]
    pub accel_offset: Option<[f64; 3]>,
    /// Sample rate, Hz: time = sample number / rate. Needed by files without a time column
    /// (MPU-6050 without `Fs`, imucal); overrides a file's time column (a sample index, a coarse clock).
    #[arg(long, value_name = "HZ", value_parser = super::values::positive, allow_negative_numbers = true)]
    pub sample_rate: Option<f64>,
    /// Replace the timestamps by evenly spaced ones at the rate all of them give (coarse, repeated
    /// or jittered stamps).
    #[arg(long)]
    pub retime: bool,
    /// ROS bags: read the messages before damage at the end of the file (cut short, its footer or
    /// index lost) instead of refusing it; the output says where reading stopped.
    #[arg(long)]
    pub salvage: bool,
    /// ROS bag topic to read: a sensor_msgs/Imu topic, or `ACCEL,GYRO` geometry_msgs/Vector3Stamped
    /// topics (default: the bag's only IMU topic; several are listed with their message counts).
    /// Flight logs: the IMU instance (`1`, `sensor_accel_1`, `sensor_combined`, `IMU[1]`; default 0).
    #[arg(long, value_name = "TOPIC")]
    pub topic: Option<String>,
    /// 3DM-GX1 AccelGainScale (EEPROM 230); default: the EEPROM reply captured in the stream.
    #[arg(long)]
    pub gx1_accel_gain: Option<u16>,
    /// 3DM-GX1 GyroGainScale (EEPROM 130); angular rate is decoded only when given.
    #[arg(long)]
    pub gx1_gyro_gain: Option<u16>,
}

/// Parses `x,y,z` into three numbers.
pub fn parse_triple(text: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("'{s}' is not a finite number"))
        })
        .collect::<Result<_, _>>()?;
    <[f64; 3]>::try_from(v).map_err(|v| format!("expected 3 comma-separated numbers, got {}", v.len()))
}

impl ReadArgs {
    /// Resolves the flags into a checked column map; bad values are usage errors.
    pub fn column_map(&self) -> anyhow::Result<ColumnMap> {
        let mut map = ColumnMap::default();
        if let Some(spec) = &self.columns {
            map = map.with_columns(spec).map_err(|e| UsageError(e.to_string()))?;
        }
        map.accel_unit = self.accel_unit.map(Into::into);
        map.time_unit = self.time_unit.map(Into::into);
        map.gyro_unit = self.gyro_unit.map(Into::into);
        map.table.delimiter = self.delimiter.map(Into::into);
        Ok(map)
    }

    /// The library's read options.
    pub fn options(&self) -> anyhow::Result<ReadOptions> {
        if let Some(rate) = self.sample_rate {
            if !(rate.is_finite() && rate > 0.0) {
                return Err(
                    UsageError(format!("--sample-rate {rate}: expected a positive rate in Hz")).into(),
                );
            }
        }
        if let Some(scale) = self.accel_scale {
            if !(scale.is_finite() && scale != 0.0) {
                return Err(UsageError(format!(
                    "--accel-scale {scale}: expected a finite, non-zero factor"
                ))
                .into());
            }
        }
        // A 16-bit part's range names its scale (`scale_flag` for any other part).
        let range = |value: Option<f64>,
                     flag: &str,
                     scale_flag: &str,
                     of_range: fn(f64) -> Result<f64, formats::UnknownRange>| {
            value
                .map(|r| {
                    of_range(r).map_err(|unknown| {
                        UsageError(format!(
                            "--{flag} {unknown}; for another part give --{scale_flag}"
                        ))
                    })
                })
                .transpose()
        };
        let accel_range = range(
            self.accel_range_g,
            "accel-range-g",
            "accel-scale",
            formats::accel_scale_of_range_g,
        )?;
        let gyro_range = range(
            self.gyro_range_dps,
            "gyro-range-dps",
            "gyro-scale",
            formats::gyro_scale_of_range_dps,
        )?;
        Ok(ReadOptions {
            format: self.format.map(Into::into),
            columns: self.column_map()?,
            accel_scale: self.accel_scale.or(accel_range),
            accel_offset: self.accel_offset,
            gyro_scale: self.gyro_scale.or(gyro_range),
            sample_rate_hz: self.sample_rate,
            gx1: formats::gx1::Gx1Options {
                accel_gain_scale: self.gx1_accel_gain,
                gyro_gain_scale: self.gx1_gyro_gain,
                command: None,
            },
            topic: self.topic.clone(),
            retime: self.retime,
            salvage: self.salvage,
        })
    }

    /// Reads a file in any supported format, raw counts allowed.
    pub fn load(&self, path: &Path, ui: &Ui) -> anyhow::Result<Loaded> {
        let options = self.options()?;
        let spinner = ui.spinner("reading");
        let loaded =
            formats::read_path(path, &options).with_context(|| format!("reading {}", path.display()));
        spinner.finish_and_clear();
        if let Ok(l) = &loaded {
            warn_left_out(path, &l.recording);
        }
        loaded
    }

    /// Reads one recording in SI units; a file of raw counts without a scale is refused.
    pub fn read(&self, path: &Path) -> anyhow::Result<Recording> {
        self.read_with(path, |_, _| Ok(()))
    }

    /// [`ReadArgs::read`], with `attach` given the file as read and the options (a gyro file is
    /// attached to it there) before its units are checked.
    pub fn read_with(
        &self,
        path: &Path,
        attach: impl FnOnce(&mut Loaded, &ReadOptions) -> anyhow::Result<()>,
    ) -> anyhow::Result<Recording> {
        let options = self.options()?;
        let mut loaded =
            formats::read_path(path, &options).with_context(|| format!("reading {}", path.display()))?;
        warn_left_out(path, &loaded.recording);
        attach(&mut loaded, &options)?;
        if loaded.gyro_counts {
            // Raw gyro counts are not rad/s; without a gyro scale they are left out.
            loaded.recording.gyro_radps = None;
        }
        if loaded.raw_counts {
            return Err(UsageError(format!(
                "{}: the {} file holds raw counts; spincal needs m/s² or g here (pass --accel-range-g or --accel-scale, or use `spincal static` to calibrate the counts first)",
                path.display(),
                loaded.format.name()
            ))
            .into());
        }
        Ok(loaded.recording)
    }
}

/// Says on standard error which rows a reader left out, so that no command drops rows silently,
/// and what it decided about the time column (a unit found from the values, a counter unwrapped).
fn warn_left_out(path: &Path, recording: &Recording) {
    if let Some(left_out) = recording.source.incomplete_rows.describe() {
        eprintln!("warning: {}: {left_out}", path.display());
    }
    for note in &recording.source.time_notes {
        eprintln!("note: {}: {}", path.display(), crate::ui::in_flags(note));
    }
}

/// One recording to read, with the reading flags.
#[derive(Args, Debug)]
pub struct InputArgs {
    /// Recording to read (CSV, whitespace text, imucal, MPU-6050 logger, phyphox CSV, zip or
    /// Excel, Sensor Logger zip or folder, Physics Toolbox CSV, 3DM-GX1 binary, MATLAB v5
    /// MAT-file, ROS bag file or ROS 2 bag directory).
    pub rec: PathBuf,
    #[command(flatten)]
    pub read: ReadArgs,
}

impl InputArgs {
    /// Reads the recording (raw counts allowed).
    pub fn load(&self, ui: &Ui) -> anyhow::Result<Loaded> {
        self.read.load(&self.rec, ui)
    }

    /// Reads and inspects the recording: a CSV or whitespace file streamed (the `Loaded` then
    /// holds the recording's source and no samples), any other read whole.
    pub fn inspect(&self, ui: &Ui) -> anyhow::Result<(Loaded, spincal::input::inspect::Inspection)> {
        let options = self.read.options()?;
        let spinner = ui.spinner("reading");
        let found = formats::streamed::inspect_path(&self.rec, &options, None)
            .with_context(|| format!("reading {}", self.rec.display()));
        spinner.finish_and_clear();
        found
    }
}

/// One line saying which reader was used and why.
pub fn format_line(loaded: &Loaded) -> String {
    match &loaded.detection {
        Some(d) => format!("format: {} (detected: {})", loaded.format, d.reason),
        None => format!("format: {} (given)", loaded.format),
    }
}
