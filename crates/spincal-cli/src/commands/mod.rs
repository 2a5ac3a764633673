//! One file per subcommand: its clap arguments and a `run` function.

pub mod allan;
pub mod calibrate;
pub mod compare;
pub mod correct;
pub mod demo;
pub mod fit;
pub mod input;
pub mod inspect;
pub mod sensitivity;
pub mod simulate;
pub mod static_cal;
pub mod strobe;
pub mod sweep;
pub mod sysid;
pub mod tables;
pub mod train;

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use spincal::formats::{self, Format, Loaded, ReadOptions};
use spincal::recording::{AccelUnit, ColumnMap};
use spincal::table::Delimiter;

use crate::ui::{Ui, UsageError};

/// How to read the recording: shared by every command that takes one.
#[derive(Args, Debug)]
pub struct InputArgs {
    /// Recording to read (CSV, whitespace text, imucal, MPU-6050 logger, phyphox, 3DM-GX1 binary).
    pub rec: PathBuf,
    /// File format: csv, whitespace (imu_tk), imucal, mpu6050, phyphox, 3dm-gx1; detected when absent.
    #[arg(long, value_parser = parse_format)]
    pub format: Option<Format>,
    /// Columns `t,ax,ay,az[,gx,gy,gz]` by name or 1-based index (csv).
    #[arg(long)]
    pub columns: Option<String>,
    /// Acceleration unit of a csv file: g or mps2 (default: from column names, else m/s²).
    #[arg(long)]
    pub accel_unit: Option<String>,
    /// Field separator: comma, semicolon, tab, whitespace (default: detected).
    #[arg(long)]
    pub delimiter: Option<String>,
    /// Multiply (value − offset) by this to get m/s² (turns raw counts into SI).
    #[arg(long)]
    pub accel_scale: Option<f64>,
    /// Per-axis offset `x,y,z` subtracted before --accel-scale (file units).
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true)]
    pub accel_offset: Option<[f64; 3]>,
    /// Sample rate, Hz, for files without a time column (MPU-6050 without `Fs`, imucal).
    #[arg(long)]
    pub sample_rate: Option<f64>,
    /// 3DM-GX1 AccelGainScale (EEPROM 230); default: the EEPROM reply captured in the stream.
    #[arg(long)]
    pub gx1_accel_gain: Option<u16>,
    /// 3DM-GX1 GyroGainScale (EEPROM 130); angular rate is decoded only when given.
    #[arg(long)]
    pub gx1_gyro_gain: Option<u16>,
}

fn parse_format(text: &str) -> Result<Format, String> {
    Format::parse(text).ok_or_else(|| {
        let names: Vec<&str> = Format::ALL.iter().map(|f| f.name()).collect();
        format!("unknown format '{text}' (known: {})", names.join(", "))
    })
}

pub fn parse_triple(text: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{s}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    <[f64; 3]>::try_from(v).map_err(|v| format!("expected 3 comma-separated numbers, got {}", v.len()))
}

impl InputArgs {
    /// Validates the options into the library's `ReadOptions`.
    pub fn options(&self) -> anyhow::Result<ReadOptions> {
        let mut columns = ColumnMap::default();
        if let Some(spec) = &self.columns {
            columns = columns
                .with_columns(spec)
                .map_err(|e| UsageError(e.to_string()))?;
        }
        if let Some(u) = &self.accel_unit {
            columns.accel_unit = Some(
                AccelUnit::parse(u).ok_or_else(|| UsageError(format!("--accel-unit: unknown unit '{u}'")))?,
            );
        }
        if let Some(d) = &self.delimiter {
            columns.table.delimiter =
                Some(Delimiter::parse(d).ok_or_else(|| UsageError(format!("--delimiter: unknown '{d}'")))?);
        }
        Ok(ReadOptions {
            format: self.format,
            columns,
            accel_scale: self.accel_scale,
            accel_offset: self.accel_offset,
            sample_rate_hz: self.sample_rate,
            gx1: formats::Gx1Options {
                accel_gain_scale: self.gx1_accel_gain,
                gyro_gain_scale: self.gx1_gyro_gain,
                command: None,
            },
        })
    }

    /// Reads the recording.
    pub fn load(&self, ui: &Ui) -> anyhow::Result<Loaded> {
        let options = self.options()?;
        let spinner = ui.spinner("reading");
        let loaded = formats::read_path(&self.rec, &options)
            .with_context(|| format!("reading {}", self.rec.display()));
        spinner.finish_and_clear();
        loaded
    }
}

/// One line saying which reader was used and why.
pub fn format_line(loaded: &Loaded) -> String {
    match &loaded.detection {
        Some(d) => format!("format: {} (detected: {})", loaded.format, d.reason),
        None => format!("format: {} (given)", loaded.format),
    }
}
