//! Commented campaign files to start from (`spincal init`): one per kind of device, each saying
//! what to record and for how long, with only the keys [`crate::campaign::file`] reads today
//! uncommented, so that a template parses as soon as the files it names exist (tested).
//!
//! Keys still being designed appear as comments marked "(coming)".

use std::path::{Path, PathBuf};

use crate::output::{self, OutputError};

/// The kind of device a template is written for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Device {
    /// A smartphone recording with phyphox or Sensor Logger.
    Phone,
    /// An accelerometer/gyro breakout board (MPU-6050-like) logged by a microcontroller.
    Breakout,
    /// A flight controller's IMU from its own log (PX4 ULog, ArduPilot DataFlash): the thermal
    /// path, which needs no turntable.
    FlightController,
}

impl Device {
    /// Every device, in the order `spincal init --help` lists them.
    pub const ALL: [Device; 3] = [Device::Phone, Device::Breakout, Device::FlightController];

    /// The name `--device` takes.
    pub fn name(self) -> &'static str {
        match self {
            Device::Phone => "phone",
            Device::Breakout => "breakout",
            Device::FlightController => "flight-controller",
        }
    }

    /// The device of a `--device` name.
    pub fn parse(text: &str) -> Option<Device> {
        Device::ALL.into_iter().find(|d| d.name() == text.trim())
    }

    /// The recording files its template lists, relative to the campaign file.
    pub fn recording_files(self) -> &'static [&'static str] {
        match self {
            Device::Phone => &[
                "poses.zip",
                "run-33-a.zip",
                "run-45-a.zip",
                "run-33-b.zip",
                "run-45-b.zip",
            ],
            Device::Breakout => &["poses.csv", "run-33-r08.csv", "run-33-r12.csv", "run-45-r08.csv"],
            Device::FlightController => &["warmup.ulg", "poses.ulg"],
        }
    }
}

/// A template that could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TemplateError {
    /// The file exists: a campaign file is the user's to edit, so it is never replaced unasked.
    #[error("{path} already exists; edit it, name another file, or set `force` to replace it")]
    Exists { path: String },
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// The campaign file for `device`, its unit named `unit`.
pub fn campaign_template(device: Device, unit: &str) -> String {
    let unit_line = format!("unit = {}\n", toml::Value::String(unit.to_string()));
    let body = match device {
        Device::Phone => PHONE,
        Device::Breakout => BREAKOUT,
        Device::FlightController => FLIGHT_CONTROLLER,
    };
    let (head, recordings) = body.split_once("@UNIT@\n").unwrap_or((body, ""));
    format!("{head}{unit_line}{recordings}")
}

/// Writes the template for `device` to `path` (its folder made when missing), the unit named
/// after that folder ([`super::unit_name::unit_name_of_folder`]). An existing file is refused
/// unless `force`; the files replaced are returned so the caller can say so.
pub fn write_campaign_template(
    device: Device,
    path: &Path,
    force: bool,
) -> Result<Vec<output::Replaced>, TemplateError> {
    output::check_outputs(&[], &[path])?;
    let exists = std::fs::symlink_metadata(path).is_ok();
    if exists && !force {
        return Err(TemplateError::Exists {
            path: path.display().to_string(),
        });
    }
    let replaced = output::claim_outputs(&[path], force)?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    output::create_folder(&folder)?;
    let unit = super::unit_name::unit_name_of_folder(&folder);
    output::write_bytes(path, campaign_template(device, &unit).as_bytes())?;
    Ok(replaced)
}

const PHONE: &str = r#"# spincal campaign: a smartphone on a record player (from `spincal init --device phone`).
# Record the files below, put them beside this file (or edit the names), measure the radii,
# then run:  spincal calibrate --campaign campaign.toml --out cal
#
# The app. phyphox: "+" > "Add simple experiment", tick "Accelerometer" (with g) and
# "Gyroscope", the highest rate; after each recording export "CSV (Comma, decimal point)",
# which gives a zip holding both sensors. Sensor Logger: Accelerometer and Gyroscope on,
# export each recording as a zip. Never a "linear acceleration" (gravity removed) channel.
#
# Still poses (one recording, about 4 minutes): prop the phone so that nothing touches it
# but its support, then hold each pose 10 s or more, moving it between poses:
#   - the six faces: screen up, screen down, and each of the four edges down;
#   - six more tilted about 45 degrees between two of those faces (leaned on a book or a wedge):
#     they tell the biases and the scale's curvature apart, which level faces cannot.
#   At least 7 poses; 12 as above is better. Several shorter files work too (one entry each).
#
# Turntable runs (four recordings, 2 minutes each; 1 minute at least): the phone flat on the
# platter, screen up, its top pointing straight away from the spindle (placement A), taped or
# on a non-slip mat. Let the platter reach its speed before the recording starts (phyphox's
# timed run has a delay) and end the recording before you touch the phone.
#   - placement A at 33 1/3 rpm, then at 45 rpm, without moving the phone in between;
#   - then turn the phone end for end (placement B: its top toward the spindle), the same two
#     speeds. Two speeds of one placement locate the chip; two placements check it.
#   The radius: not needed. The chip sits somewhere inside the phone; the two speeds of each
#   placement give its radius (results.json's `placements`). A radius you state instead
#   (radius_m with radius_tol_m) is checked against the runs and named when they contradict it.
#   Where the chip sits in the phone: turn the phone about its centre between placements,
#   measure that centre's distance from the spindle and add it to every run
#   (centre_radius_m = 0.09 with centre_radius_tol_m = 0.005); A and B then give the offset along
#   the phone's length (results.json's `chip_offset`), and a third placement turned 90°
#   (out = "+x", the same two speeds) the offset across it as well.
#   Phones' gyros usually reach ±2000 °/s, well above 45 rpm (270 °/s).
#
# Optional: the datasheet of the phone's accelerometer, if you know the part. Each figure bounds
# its term where the recordings say little (range and nonlinearity together); state a figure
# only as a limit, not a typical value:
# range_g = 8
# nonlinearity_pct_fs = 0.5
# zero_g_offset_mg = 40
# sensitivity_tolerance_pct = 2
# cross_axis_pct = 1
@UNIT@

[[recording]]
file = "poses.zip"
kind = "static"
session = "phone"         # the phone stays on: every recording shares one bias

[[recording]]
file = "run-33-a.zip"
kind = "turntable"
rpm = 33.333              # nominal; the rate is measured from the data
out = "+y"                # the phone's top points away from the spindle
up = "+z"                 # screen up
placement = "A"           # runs made without moving the phone share the chip's radius
session = "phone"

[[recording]]
file = "run-45-a.zip"
kind = "turntable"
rpm = 45
out = "+y"
up = "+z"
placement = "A"
session = "phone"

[[recording]]
file = "run-33-b.zip"
kind = "turntable"
rpm = 33.333
out = "-y"                # turned end for end: the top points at the spindle
up = "+z"
placement = "B"
session = "phone"

[[recording]]
file = "run-45-b.zip"
kind = "turntable"
rpm = 45
out = "-y"
up = "+z"
placement = "B"
session = "phone"
"#;

const BREAKOUT: &str = r#"# spincal campaign: a breakout board (MPU-6050-like) on a record player (from
# `spincal init --device breakout`). Record the files below, put them beside this file (or edit
# the names), measure the radii, then run:  spincal calibrate --campaign campaign.toml --out cal
#
# The log. A campaign reads acceleration in g or m/s², not raw counts: have the sketch print
# this header and each sample converted by the range's sensitivity (MPU-6050 register map:
# 16384 counts per g at ±2 g, 8192 at ±4 g; 131 counts per °/s at ±250 °/s, 65.5 at ±500 °/s;
# temperature °C = counts / 340 + 36.53):
#   t_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp_c
# at 100-200 Hz, t_ms from millis() (a counter that wraps is unwrapped). Without gyro columns
# only the accelerometer is calibrated.
#   Or print the raw counts (ax,ay,az,gx,gy,gz with an `Fs,<Hz>` line first, as the MPU-6050
#   logger does) and give each entry the ranges the registers were set to:
#   accel_range_g = 2 and gyro_range_dps = 250 (AFS_SEL and FS_SEL 0).
#
# The gyro's range: at the MPU-6050's default ±250 °/s, 45 rpm (270 °/s) pins the gyro for the
# whole run. Set GYRO_CONFIG's FS_SEL to 1 (±500 °/s) before recording at 45 rpm, or record
# 33 1/3 rpm only (200 °/s).
#
# Still poses (one recording, about 4 minutes): the board in a small box or on a block so that
# its faces can be set down; nothing touching it but its support, each pose 10 s or more,
# moving it between poses:
#   - the six faces (each axis up, then down);
#   - six more tilted about 45 degrees between two of those faces (on a wedge): they tell the
#     biases and the scale's curvature apart, which level faces cannot.
#   At least 7 poses; 12 as above is better. If the board stays powered from the poses to the
#   last run, say so with one `session` label on every recording (below, commented).
#
# Turntable runs (2 minutes each; 1 minute at least): the board flat on the platter, chip up,
# its x axis pointing straight away from the spindle, taped down with its cable slack.
#   - 33 1/3 rpm at two radii (e.g. 8 and 12 cm), and 45 rpm at one of them (see the range);
#   - the radius: from the spindle's centre to the chip's centre (the package's middle) with a
#     ruler, ± 2 mm.
#
# The MPU-6050's datasheet (product specification rev. 3.4, accelerometer table): ±2 g range and
# 0.5 % nonlinearity, which bound the scale's curvature; change them for another part or range.
range_g = 2
nonlinearity_pct_fs = 0.5
# The same table gives a zero-g tolerance of ±50 mg (x, y) and ±80 mg (z), a sensitivity
# tolerance of ±3 % and a cross-axis sensitivity of ±2 %, but as typical values, not limits, and
# soldering a breakout board shifts its offsets further. Each key below bounds its term where the
# poses say little; state one only as a limit you trust for your board:
# zero_g_offset_mg = 150
# sensitivity_tolerance_pct = 3
# cross_axis_pct = 2
@UNIT@

[[recording]]
file = "poses.csv"
kind = "static"
accel_unit = "g"          # as the header's ax_g says; needed when the names carry no unit
# columns = "t_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp_c"   # when your header's names differ
# session = "bench"       # recordings made in one power-on of the board share one bias offset

[[recording]]
file = "run-33-r08.csv"
kind = "turntable"
rpm = 33.333              # nominal; the rate is measured from the data
radius_m = 0.08           # EDIT: spindle to the chip, m
radius_tol_m = 0.002      # the ruler's tolerance
out = "+x"                # the board's x axis points away from the spindle
up = "+z"                 # chip up
accel_unit = "g"
# session = "bench"

[[recording]]
file = "run-33-r12.csv"
kind = "turntable"
rpm = 33.333
radius_m = 0.12           # EDIT
radius_tol_m = 0.002
out = "+x"
up = "+z"
accel_unit = "g"
# session = "bench"

[[recording]]
file = "run-45-r08.csv"
kind = "turntable"
rpm = 45                  # with the gyro at ±500 °/s (FS_SEL = 1), see above
radius_m = 0.08           # EDIT
radius_tol_m = 0.002
out = "+x"
up = "+z"
accel_unit = "g"
# session = "bench"
"#;

const FLIGHT_CONTROLLER: &str = r#"# spincal campaign: a flight controller's IMU corrected for temperature (from
# `spincal init --device flight-controller`). This path needs no turntable: still recordings
# through warm-ups give the accelerometer's bias and gain against its die temperature and the
# six-face calibration. Record the files below, put them beside this file (or edit the names),
# then run:  spincal calibrate --campaign campaign.toml --out cal
# and write the flight stack's parameters from cal/model.json:
#   spincal export --model cal/model.json --px4 imu.params --px4-device-id ID
#   spincal export --model cal/model.json --ardupilot imu.param
# (PX4 applies them to one accelerometer: ID is its CAL_ACC0_ID parameter, shown in QGroundControl.)
#
# The logs, read as the stacks write them: PX4's ULog (.ulg) with sensor_accel and sensor_gyro
# logged (they carry the IMU's temperature; sensor_combined alone has none), or ArduPilot's
# DataFlash log (.bin), whose IMU messages carry it (T). Use .bin names below for ArduPilot.
# The first IMU (instance 0) is read.
#   (coming) a key choosing another IMU instance.
#
# 1. The warm-up (30 minutes): start cold (powered off for an hour, or from a cool room), set
#    the board level on a table, power it on and log without touching it until its temperature
#    stops rising.
# 2. The poses (30 minutes): let it cool again, power it on and, while it warms up, turn it
#    through the six faces and six poses tilted about 45 degrees between two faces, again and
#    again, each pose held still 15 s or more. The poses must span the temperatures the
#    aircraft will see (at least 3 °C between the coldest and the warmest).
# A held-out third session recorded the same way can later be checked with `spincal correct`.
@UNIT@

[[recording]]
file = "warmup.ulg"
kind = "static"

[[recording]]
file = "poses.ulg"
kind = "static"
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::file::{Campaign, EntryKind};

    #[test]
    fn each_template_parses_and_lists_its_files() {
        for device in Device::ALL {
            let text = campaign_template(device, "my \"unit\"");
            let c = Campaign::parse(&text, Path::new("dir/campaign.toml"))
                .unwrap_or_else(|e| panic!("{}: {e}\n{text}", device.name()));
            assert_eq!(c.unit, "my \"unit\"");
            let files: Vec<PathBuf> = c.recordings.iter().map(|r| r.file.clone()).collect();
            let expected: Vec<PathBuf> = device
                .recording_files()
                .iter()
                .map(|f| Path::new("dir").join(f))
                .collect();
            assert_eq!(files, expected, "{}", device.name());
            let runs = c
                .recordings
                .iter()
                .filter(|r| matches!(r.kind, EntryKind::Turntable(_)))
                .count();
            // The thermal path needs no turntable; the others need two speeds.
            assert_eq!(runs == 0, device == Device::FlightController, "{}", device.name());
        }
    }

    #[test]
    fn keys_still_coming_are_only_comments() {
        for device in Device::ALL {
            let text = campaign_template(device, "u");
            for line in text.lines().filter(|l| l.contains("(coming)")) {
                assert!(line.trim_start().starts_with('#'), "{}: {line}", device.name());
            }
        }
    }

    #[test]
    fn devices_are_named_as_the_flag_takes_them() {
        for device in Device::ALL {
            assert_eq!(Device::parse(device.name()), Some(device));
        }
        assert_eq!(Device::parse("toaster"), None);
    }
}
