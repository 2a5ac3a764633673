//! The campaign file (TOML): which recordings of one unit were made, and how.
//!
//! ```toml
//! unit = "imu-07"
//! gravity_mps2 = 9.80665          # optional, local gravity
//! range_g = 5                     # optional, with the next: the datasheet's range (± g) and
//! nonlinearity_pct_fs = 0.2       # nonlinearity (% of full scale), the bound on q
//! zero_g_offset_mg = 50           # optional: the datasheet's zero-g offset (± mg), the bound on
//!                                 # the bias
//! sensitivity_tolerance_pct = 3   # optional: its sensitivity tolerance (± %), on the scale errors
//! cross_axis_pct = 2              # optional: its cross-axis sensitivity (± %), on the misalignments
//! [[recording]]
//! file = "still-1.csv"            # relative to this file
//! kind = "static"                 # one or more still poses (found in the file)
//! [[recording]]
//! file = "t33-r09.csv"
//! kind = "turntable"
//! rpm = 33.333                    # nominal; the rate is measured from the data
//! radius_m = 0.09                 # optional (with the next): the chip's radius by ruler
//! radius_tol_m = 0.002
//! placement = "A"                 # optional: runs made without moving the device
//! centre_radius_m = 0.10          # optional (with the next): the radius of the device's centre,
//! centre_radius_tol_m = 0.01      # the point it is turned about between placements
//! out = "+x"                      # sensor axis pointing away from the spindle
//! up = "+z"                       # sensor axis along the spindle, upwards
//! direction = "cw"                # optional: cw or ccw seen from above; found from the data
//! truth = "t33-r09.truth.csv"     # optional: true specific force per sample (simulations)
//! ```
//! A run's `radius_m` is the chip's distance from the spindle, within `radius_tol_m` (a ruler's
//! tolerance, or a wide one around a point the user can measure, such as a phone's centre).
//! Runs with the same `placement` were made without moving the device: they share one radius,
//! fitted from the runs. Without a stated radius the placement needs two speeds (or runs in a
//! `session` with still poses, which pins their bias offset), and its radius is the runs' alone.
//! Runs stating `centre_radius_m` say that their placements are the device turned about its
//! centre, kept at that radius; each placement's turn is what its `out` says (all with one `up`).
//! Their chip radii then locate the chip in the device (`campaign::joint::chip_offset`): the
//! component along a turn of 180° from the radii and the centre's radius, both in-plane components
//! and the centre's radius itself once the turns also include one of 90°.
//!
//! Optional per recording: `session` (recordings with the same label were made in one power-on
//! of the sensor and share one bias offset; without it each recording has its own offset, and
//! the spread of those offsets is estimated from the recordings); how to read it, as the CLI's
//! flags: `format`, `columns`, `accel_unit`, `gyro_unit`, `time_unit`, `sample_rate_hz`,
//! `retime`, `topic`, `accel_scale` and `accel_offset`, `gyro_scale`, or for a 16-bit part's raw
//! counts its configured ranges `accel_range_g` (2, 4, 8, 16: the MPU-6050's AFS_SEL) and
//! `gyro_range_dps` (125 … 2000: its FS_SEL); `gyro_file` (the gyro recorded in a second file,
//! imu_tk's `t gx gy gz` or with gyro columns, read with the entry's flags: merged on time when it
//! has its own times, sample for sample when not, `input::gyro_file::attach_gyro_file`); `truth`,
//! `noise_floor_mps2` (the RMS per axis of the error no corrector can remove, when known) and
//! `random_error` (that error per sample, a file shaped like the recording: t and three axes, m/s²;
//! the floor of any part of the recording is then its RMS over exactly those samples).

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::input::formats::{
    accel_scale_of_range_g, gyro_scale_of_range_dps, Format, ReadOptions, UnknownRange,
};
use crate::input::recording::{AccelUnit, ColumnMap, GyroUnit, TimeUnit, STANDARD_GRAVITY};
use crate::turntable::fit::RadiusPrior;
use crate::turntable::model::Direction;

/// A sensor axis with a sign, as `out` and `up` name them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SignedAxis {
    /// 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// +1 or −1.
    pub sign: i8,
}

impl SignedAxis {
    pub fn parse(text: &str) -> Option<SignedAxis> {
        let t = text.trim();
        let (sign, rest) = match t.as_bytes().first()? {
            b'+' => (1, &t[1..]),
            b'-' => (-1, &t[1..]),
            _ => (1, t),
        };
        let axis = match rest {
            "x" | "X" => 0,
            "y" | "Y" => 1,
            "z" | "Z" => 2,
            _ => return None,
        };
        Some(SignedAxis { axis, sign })
    }

    /// The signed axis nearest to `v`'s direction: its largest component, with that component's
    /// sign (z for a zero vector).
    pub fn nearest(v: [f64; 3]) -> SignedAxis {
        let axis = (0..3)
            .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
            .unwrap_or(2);
        SignedAxis {
            axis,
            sign: if v[axis] >= 0.0 { 1 } else { -1 },
        }
    }

    /// The unit vector of this axis in sensor coordinates.
    pub fn vector(self) -> [f64; 3] {
        let mut v = [0.0; 3];
        v[self.axis] = f64::from(self.sign);
        v
    }

    pub fn name(self) -> String {
        format!(
            "{}{}",
            if self.sign > 0 { '+' } else { '-' },
            ["x", "y", "z"][self.axis]
        )
    }
}

/// How the sensor sat on the platter during one run.
#[derive(Debug, Clone, PartialEq)]
pub struct TurntableEntry {
    pub rpm: f64,
    /// The chip's radius as measured (`radius_m` ± `radius_tol_m`); `None`: fitted from the runs.
    pub radius: Option<RadiusPrior>,
    pub out: SignedAxis,
    pub up: SignedAxis,
    pub direction: Option<Direction>,
    /// The placement it shares with runs made without moving the device, when the campaign says.
    pub placement: Option<String>,
    /// The radius of the device's centre, the point it is turned about between placements
    /// (`centre_radius_m` ± `centre_radius_tol_m`), when stated.
    pub centre: Option<RadiusPrior>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum EntryKind {
    /// Still poses (one or more, found in the file).
    Static,
    Turntable(TurntableEntry),
}

/// One recording of the campaign.
#[derive(Debug, Clone)]
pub struct CampaignEntry {
    /// Resolved path (relative entries are taken relative to the campaign file).
    pub file: PathBuf,
    /// Line of the `[[recording]]` table in the campaign file.
    pub line: usize,
    pub kind: EntryKind,
    /// How to read it (the CLI's reading flags, from the entry's keys).
    pub read: ReadOptions,
    /// The gyro recorded beside it in a file of its own, sample for sample.
    pub gyro_file: Option<PathBuf>,
    pub truth: Option<PathBuf>,
    pub noise_floor_mps2: Option<[f64; 3]>,
    pub random_error: Option<PathBuf>,
    /// The power-on session it belongs to, when the campaign says.
    pub session: Option<String>,
}

/// A parsed campaign file.
#[derive(Debug, Clone)]
pub struct Campaign {
    pub unit: String,
    /// The campaign file itself.
    pub path: PathBuf,
    pub gravity_mps2: f64,
    /// What the file gives of the part's datasheet.
    pub datasheet: Datasheet,
    pub recordings: Vec<CampaignEntry>,
}

/// A part's datasheet as a campaign file gives it: each figure given is a bound on its sensor
/// term, which the joint fit takes as that term's prior (`JointSettings::set_datasheet_priors`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Datasheet {
    pub nonlinearity: Option<DatasheetNonlinearity>,
    /// Zero-g offset, ± mg (`zero_g_offset_mg`).
    pub zero_g_offset_mg: Option<f64>,
    /// Sensitivity tolerance, ± % (`sensitivity_tolerance_pct`).
    pub sensitivity_tolerance_pct: Option<f64>,
    /// Cross-axis sensitivity, ± % (`cross_axis_pct`).
    pub cross_axis_pct: Option<f64>,
}

/// A datasheet's nonlinearity: `pct_fs` % of full scale over ±`range_g`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DatasheetNonlinearity {
    pub range_g: f64,
    pub pct_fs: f64,
}

impl DatasheetNonlinearity {
    /// The quadratic coefficient it allows, 1/(m/s²).
    pub fn quadratic_per_mps2(&self) -> f64 {
        crate::correctors::physical::quadratic_from_datasheet(self.pct_fs, self.range_g)
    }
}

/// A campaign file that cannot be used, located.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignError {
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    #[error("{file}:{line}:{column}: {message}")]
    Syntax {
        file: String,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{file}:{line}: `{key}`: {message}")]
    Entry {
        file: String,
        line: usize,
        key: String,
        message: String,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCampaign {
    unit: Option<Spanned<String>>,
    gravity_mps2: Option<Spanned<f64>>,
    range_g: Option<Spanned<f64>>,
    nonlinearity_pct_fs: Option<Spanned<f64>>,
    zero_g_offset_mg: Option<Spanned<f64>>,
    sensitivity_tolerance_pct: Option<Spanned<f64>>,
    cross_axis_pct: Option<Spanned<f64>>,
    #[serde(default)]
    recording: Vec<Spanned<RawEntry>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEntry {
    file: Option<Spanned<String>>,
    kind: Option<Spanned<String>>,
    rpm: Option<Spanned<f64>>,
    radius_m: Option<Spanned<f64>>,
    radius_tol_m: Option<Spanned<f64>>,
    out: Option<Spanned<String>>,
    up: Option<Spanned<String>>,
    direction: Option<Spanned<String>>,
    columns: Option<Spanned<String>>,
    accel_unit: Option<Spanned<String>>,
    format: Option<Spanned<String>>,
    gyro_unit: Option<Spanned<String>>,
    time_unit: Option<Spanned<String>>,
    sample_rate_hz: Option<Spanned<f64>>,
    retime: Option<bool>,
    topic: Option<Spanned<String>>,
    accel_scale: Option<Spanned<f64>>,
    accel_offset: Option<Spanned<Vec<f64>>>,
    gyro_scale: Option<Spanned<f64>>,
    accel_range_g: Option<Spanned<f64>>,
    gyro_range_dps: Option<Spanned<f64>>,
    gyro_file: Option<Spanned<String>>,
    truth: Option<Spanned<String>>,
    noise_floor_mps2: Option<Spanned<Vec<f64>>>,
    random_error: Option<Spanned<String>>,
    session: Option<Spanned<String>>,
    placement: Option<Spanned<String>>,
    centre_radius_m: Option<Spanned<f64>>,
    centre_radius_tol_m: Option<Spanned<f64>>,
}

/// 1-based line and column of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

struct Locator {
    file: String,
    /// Byte offset of each line's start: a line is found by binary search, so that 10,000
    /// entries are located in linear time.
    line_starts: Vec<usize>,
}

impl Locator {
    fn new(file: String, text: &str) -> Locator {
        let line_starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Locator { file, line_starts }
    }

    /// 1-based line of a byte offset.
    fn line(&self, offset: usize) -> usize {
        self.line_starts.partition_point(|&start| start <= offset).max(1)
    }

    fn at(&self, span: Range<usize>, key: &str, message: impl Into<String>) -> CampaignError {
        CampaignError::Entry {
            file: self.file.clone(),
            line: self.line(span.start),
            key: key.into(),
            message: message.into(),
        }
    }

    fn required<T: Clone>(
        &self,
        value: &Option<Spanned<T>>,
        entry: Range<usize>,
        key: &str,
    ) -> Result<(T, Range<usize>), CampaignError> {
        value
            .as_ref()
            .map(|v| (v.get_ref().clone(), v.span()))
            .ok_or_else(|| self.at(entry, key, "missing"))
    }

    fn number(
        &self,
        value: &Option<Spanned<f64>>,
        entry: Range<usize>,
        key: &str,
        ok: fn(f64) -> bool,
        why: &str,
    ) -> Result<f64, CampaignError> {
        let (v, span) = self.required(value, entry, key)?;
        if v.is_finite() && ok(v) {
            Ok(v)
        } else {
            Err(self.at(span, key, format!("{v}: {why}")))
        }
    }
}

impl Campaign {
    /// Reads and checks a campaign file.
    pub fn read_path(path: &Path) -> Result<Campaign, CampaignError> {
        let text = crate::input::limits::read_settings_text(path).map_err(|e| CampaignError::Io {
            file: path.display().to_string(),
            message: e.to_string(),
        })?;
        Campaign::parse(&text, path)
    }

    /// Parses campaign text; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Campaign, CampaignError> {
        let file = path.display().to_string();
        let raw: RawCampaign = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
            CampaignError::Syntax {
                file: file.clone(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        let at = Locator::new(file.clone(), text);
        let base = path.parent().unwrap_or(Path::new(""));
        let unit = at.unit(&raw, path)?;
        let gravity_mps2 = at.gravity(&raw)?;
        let datasheet = at.datasheet(&raw)?;
        if raw.recording.is_empty() {
            return Err(CampaignError::Entry {
                file,
                line: 1,
                key: "recording".into(),
                message: "no [[recording]] tables: a campaign needs at least one recording".into(),
            });
        }
        let mut recordings = Vec::with_capacity(raw.recording.len());
        for spanned in &raw.recording {
            recordings.push(at.entry(spanned, base)?);
        }
        Ok(Campaign {
            unit,
            path: path.to_path_buf(),
            gravity_mps2,
            datasheet,
            recordings,
        })
    }
}

/// `p`, taken relative to `base` unless absolute.
fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// The campaign's top-level keys, then one `[[recording]]` table at a time.
impl Locator {
    /// The unit's name, or the file's stem when not given.
    fn unit(&self, raw: &RawCampaign, path: &Path) -> Result<String, CampaignError> {
        Ok(match &raw.unit {
            Some(u) if u.get_ref().trim().is_empty() => return Err(self.at(u.span(), "unit", "empty")),
            Some(u) => u.get_ref().clone(),
            None => path
                .file_stem()
                .map_or("unit".into(), |s| s.to_string_lossy().into_owned()),
        })
    }

    fn gravity(&self, raw: &RawCampaign) -> Result<f64, CampaignError> {
        Ok(match &raw.gravity_mps2 {
            Some(_) => self.number(
                &raw.gravity_mps2,
                0..0,
                "gravity_mps2",
                |g| (9.7..9.9).contains(&g),
                "local gravity lies between 9.7 and 9.9 m/s²",
            )?,
            None => STANDARD_GRAVITY,
        })
    }

    fn datasheet(&self, raw: &RawCampaign) -> Result<Datasheet, CampaignError> {
        let bound = |value: &Option<Spanned<f64>>, key: &str, ok: fn(f64) -> bool, why: &str| {
            value
                .as_ref()
                .map(|_| self.number(value, 0..0, key, ok, why))
                .transpose()
        };
        Ok(Datasheet {
            nonlinearity: self.nonlinearity(raw)?,
            zero_g_offset_mg: bound(
                &raw.zero_g_offset_mg,
                "zero_g_offset_mg",
                |v| v > 0.0 && v <= 2000.0,
                "a zero-g offset lies above 0 and at most 2000 mg",
            )?,
            sensitivity_tolerance_pct: bound(
                &raw.sensitivity_tolerance_pct,
                "sensitivity_tolerance_pct",
                |v| v > 0.0 && v <= 50.0,
                "a sensitivity tolerance lies above 0 and at most 50 %",
            )?,
            cross_axis_pct: bound(
                &raw.cross_axis_pct,
                "cross_axis_pct",
                |v| v > 0.0 && v <= 20.0,
                "a cross-axis sensitivity lies above 0 and at most 20 %",
            )?,
        })
    }

    fn nonlinearity(&self, raw: &RawCampaign) -> Result<Option<DatasheetNonlinearity>, CampaignError> {
        // Both datasheet numbers or neither: one alone cannot size the prior.
        let alone = |span, given: &str, missing: &str| {
            self.at(
                span,
                given,
                format!("needs `{missing}` too: the two size the nonlinearity's prior together"),
            )
        };
        Ok(match (&raw.range_g, &raw.nonlinearity_pct_fs) {
            (None, None) => None,
            (Some(r), None) => return Err(alone(r.span(), "range_g", "nonlinearity_pct_fs")),
            (None, Some(n)) => return Err(alone(n.span(), "nonlinearity_pct_fs", "range_g")),
            (Some(_), Some(_)) => Some(DatasheetNonlinearity {
                range_g: self.number(
                    &raw.range_g,
                    0..0,
                    "range_g",
                    |r| r > 0.0 && r <= 1000.0,
                    "the datasheet range lies above 0 and at most 1000 g",
                )?,
                pct_fs: self.number(
                    &raw.nonlinearity_pct_fs,
                    0..0,
                    "nonlinearity_pct_fs",
                    |n| n > 0.0 && n < 100.0,
                    "a nonlinearity lies above 0 and below 100 % of full scale",
                )?,
            }),
        })
    }

    /// One `[[recording]]` table, its paths resolved against `base`.
    fn entry(&self, spanned: &Spanned<RawEntry>, base: &Path) -> Result<CampaignEntry, CampaignError> {
        let span = spanned.span();
        let e = spanned.get_ref();
        let (name, name_span) = self.required(&e.file, span.clone(), "file")?;
        if name.trim().is_empty() {
            return Err(self.at(name_span, "file", "empty"));
        }
        let kind = self.kind(e, span.clone())?;
        let read = self.read_options(e)?;
        let noise_floor_mps2 = match &e.noise_floor_mps2 {
            None => None,
            Some(v) => {
                let values = v.get_ref();
                if values.len() != 3 || values.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                    return Err(self.at(
                        v.span(),
                        "noise_floor_mps2",
                        "expected three finite non-negative numbers [x, y, z]",
                    ));
                }
                Some([values[0], values[1], values[2]])
            }
        };
        let session = self.label(&e.session, "session", "the power-on session")?;
        Ok(CampaignEntry {
            file: resolve(base, &name),
            line: self.line(span.start),
            kind,
            read,
            gyro_file: e.gyro_file.as_ref().map(|g| resolve(base, g.get_ref())),
            truth: e.truth.as_ref().map(|t| resolve(base, t.get_ref())),
            noise_floor_mps2,
            random_error: e.random_error.as_ref().map(|t| resolve(base, t.get_ref())),
            session,
        })
    }

    /// The entry's reading keys as the library's read options, each checked as the CLI's flag is.
    fn read_options(&self, e: &RawEntry) -> Result<ReadOptions, CampaignError> {
        let named = |value: &Option<Spanned<String>>, key: &str, expected: &str| {
            value.as_ref().map(|v| {
                let bad = self.at(v.span(), key, format!("'{}': expected {expected}", v.get_ref()));
                (v.get_ref().clone(), bad)
            })
        };
        let mut columns = ColumnMap::default();
        if let Some(spec) = &e.columns {
            columns = columns
                .with_columns(spec.get_ref())
                .map_err(|err| self.at(spec.span(), "columns", err.to_string()))?;
        }
        if let Some((text, bad)) = named(&e.accel_unit, "accel_unit", "g or m/s^2") {
            columns.accel_unit = Some(AccelUnit::parse(&text).ok_or(bad)?);
        }
        if let Some((text, bad)) = named(&e.gyro_unit, "gyro_unit", "rad/s or deg/s") {
            columns.gyro_unit = Some(GyroUnit::parse(&text).ok_or(bad)?);
        }
        if let Some((text, bad)) = named(&e.time_unit, "time_unit", "s, ms, us or ns") {
            columns.time_unit = Some(TimeUnit::parse(&text).ok_or(bad)?);
        }
        let names = Format::ALL.map(Format::name).join(", ");
        let format = match named(&e.format, "format", &format!("one of {names}")) {
            Some((text, bad)) => Some(Format::parse(&text).ok_or(bad)?),
            None => None,
        };
        let optional = |value: &Option<Spanned<f64>>, key: &str, ok: fn(f64) -> bool, why: &str| {
            value
                .as_ref()
                .map(|_| self.number(value, 0..0, key, ok, why))
                .transpose()
        };
        let nonzero = |v: f64| v != 0.0;
        let positive = |v: f64| v > 0.0;
        let mut accel_scale = optional(
            &e.accel_scale,
            "accel_scale",
            nonzero,
            "a finite, non-zero factor",
        )?;
        let mut gyro_scale = optional(&e.gyro_scale, "gyro_scale", nonzero, "a finite, non-zero factor")?;
        // A 16-bit part's range names its scale; the scale itself may not be given as well.
        for (range, key, scale_key, scale, of_range) in [
            (
                &e.accel_range_g,
                "accel_range_g",
                "accel_scale",
                &mut accel_scale,
                accel_scale_of_range_g as fn(f64) -> Result<f64, UnknownRange>,
            ),
            (
                &e.gyro_range_dps,
                "gyro_range_dps",
                "gyro_scale",
                &mut gyro_scale,
                gyro_scale_of_range_dps,
            ),
        ] {
            let Some(r) = range else { continue };
            if scale.is_some() {
                return Err(self.at(r.span(), key, format!("give `{key}` or `{scale_key}`, not both")));
            }
            *scale = Some(of_range(*r.get_ref()).map_err(|unknown| {
                self.at(
                    r.span(),
                    key,
                    format!("{unknown}; for another part give `{scale_key}` (SI units per count)"),
                )
            })?);
        }
        let accel_offset = match &e.accel_offset {
            None => None,
            Some(v) => match v.get_ref()[..] {
                [x, y, z] if [x, y, z].iter().all(|c| c.is_finite()) => Some([x, y, z]),
                _ => {
                    return Err(self.at(
                        v.span(),
                        "accel_offset",
                        "expected three finite numbers [x, y, z] (file units)",
                    ))
                }
            },
        };
        Ok(ReadOptions {
            format,
            columns,
            accel_scale,
            accel_offset,
            gyro_scale,
            sample_rate_hz: optional(
                &e.sample_rate_hz,
                "sample_rate_hz",
                positive,
                "a positive rate in Hz",
            )?,
            topic: e.topic.as_ref().map(|t| t.get_ref().clone()),
            retime: e.retime.unwrap_or(false),
            ..ReadOptions::default()
        })
    }

    /// An optional label (`session`, `placement`): trimmed, and not empty.
    fn label(
        &self,
        value: &Option<Spanned<String>>,
        key: &str,
        what: &str,
    ) -> Result<Option<String>, CampaignError> {
        match value {
            Some(s) if s.get_ref().trim().is_empty() => {
                Err(self.at(s.span(), key, format!("empty: name {what}, or leave the key out")))
            }
            Some(s) => Ok(Some(s.get_ref().trim().to_string())),
            None => Ok(None),
        }
    }

    /// The entry's kind: a static one must not carry turntable keys.
    fn kind(&self, e: &RawEntry, span: Range<usize>) -> Result<EntryKind, CampaignError> {
        let (kind_text, kind_span) = self.required(&e.kind, span.clone(), "kind")?;
        let turntable_only = [
            ("rpm", e.rpm.as_ref().map(Spanned::span)),
            ("radius_m", e.radius_m.as_ref().map(Spanned::span)),
            ("radius_tol_m", e.radius_tol_m.as_ref().map(Spanned::span)),
            ("out", e.out.as_ref().map(Spanned::span)),
            ("up", e.up.as_ref().map(Spanned::span)),
            ("direction", e.direction.as_ref().map(Spanned::span)),
            ("placement", e.placement.as_ref().map(Spanned::span)),
            ("centre_radius_m", e.centre_radius_m.as_ref().map(Spanned::span)),
            (
                "centre_radius_tol_m",
                e.centre_radius_tol_m.as_ref().map(Spanned::span),
            ),
        ];
        match kind_text.as_str() {
            "static" => {
                if let Some((key, Some(s))) = turntable_only.iter().find(|(_, s)| s.is_some()) {
                    return Err(self.at(
                        s.clone(),
                        key,
                        "only a turntable recording has this key (kind = \"static\")",
                    ));
                }
                Ok(EntryKind::Static)
            }
            "turntable" => Ok(EntryKind::Turntable(self.turntable(e, span)?)),
            other => Err(self.at(
                kind_span,
                "kind",
                format!("'{other}': expected static or turntable"),
            )),
        }
    }

    /// A turntable entry's speed, radius, mounting and (optional) sense of rotation.
    fn turntable(&self, e: &RawEntry, span: Range<usize>) -> Result<TurntableEntry, CampaignError> {
        let rpm = self.number(
            &e.rpm,
            span.clone(),
            "rpm",
            |v| v > 0.0 && v <= 1000.0,
            "must be positive and at most 1000",
        )?;
        let radius = self.radius(
            (&e.radius_m, "radius_m"),
            (&e.radius_tol_m, "radius_tol_m"),
            span.clone(),
            "leave both out to fit the radius from the runs",
        )?;
        let centre = self.radius(
            (&e.centre_radius_m, "centre_radius_m"),
            (&e.centre_radius_tol_m, "centre_radius_tol_m"),
            span.clone(),
            "leave both out when the device was not turned about its centre",
        )?;
        let axis = |value: &Option<Spanned<String>>, key: &str| -> Result<SignedAxis, CampaignError> {
            let (text, s) = self.required(value, span.clone(), key)?;
            SignedAxis::parse(&text).ok_or_else(|| {
                self.at(
                    s,
                    key,
                    format!("'{text}': expected one of +x, -x, +y, -y, +z, -z"),
                )
            })
        };
        let out = axis(&e.out, "out")?;
        let up = axis(&e.up, "up")?;
        if out.axis == up.axis {
            let s = e.up.as_ref().map_or(span.clone(), Spanned::span);
            return Err(self.at(
                s,
                "up",
                format!(
                    "{} is along out = {}: the two must be different axes",
                    up.name(),
                    out.name()
                ),
            ));
        }
        let direction = match &e.direction {
            None => None,
            Some(d) => Some(match d.get_ref().as_str() {
                "cw" => Direction::Cw,
                "ccw" => Direction::Ccw,
                other => {
                    return Err(self.at(d.span(), "direction", format!("'{other}': expected cw or ccw")))
                }
            }),
        };
        Ok(TurntableEntry {
            rpm,
            radius,
            out,
            up,
            direction,
            placement: self.label(&e.placement, "placement", "the device's placement on the platter")?,
            centre,
        })
    }

    /// A radius and its tolerance, both or neither (`radius_m`, or the device's centre).
    fn radius(
        &self,
        (value, key): (&Option<Spanned<f64>>, &str),
        (tolerance, tolerance_key): (&Option<Spanned<f64>>, &str),
        span: Range<usize>,
        neither: &str,
    ) -> Result<Option<RadiusPrior>, CampaignError> {
        Ok(match (value, tolerance) {
            (None, None) => None,
            (None, Some(t)) => {
                return Err(self.at(
                    t.span(),
                    tolerance_key,
                    format!("needs `{key}`: the tolerance of which radius? ({neither})"),
                ))
            }
            (Some(_), _) => Some(RadiusPrior {
                value_m: self.number(
                    value,
                    span.clone(),
                    key,
                    |v| (0.0..=2.0).contains(&v),
                    "must be between 0 and 2 m",
                )?,
                tolerance_m: self.number(
                    tolerance,
                    span,
                    tolerance_key,
                    |v| v > 0.0 && v <= 2.0,
                    "must be positive (the ruler's tolerance), at most 2 m",
                )?,
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
unit = "imu-07"
[[recording]]
file = "still-1.csv"
kind = "static"

[[recording]]
file = "t33-r09.csv"
kind = "turntable"
rpm = 33.333
radius_m = 0.09
radius_tol_m = 0.002
out = "+x"
up = "-z"
"#;

    fn parse(text: &str) -> Result<Campaign, CampaignError> {
        Campaign::parse(text, Path::new("runs/c.toml"))
    }

    #[test]
    fn a_good_file_parses_with_paths_relative_to_it() {
        let c = parse(GOOD).unwrap();
        assert_eq!(c.unit, "imu-07");
        assert_eq!(c.recordings.len(), 2);
        assert_eq!(c.recordings[0].file, Path::new("runs/still-1.csv"));
        assert_eq!(c.recordings[1].line, 7);
        match &c.recordings[1].kind {
            EntryKind::Turntable(t) => {
                assert_eq!(t.up, SignedAxis { axis: 2, sign: -1 });
                assert_eq!(t.radius.map(|r| r.value_m), Some(0.09));
                assert_eq!(t.placement, None);
            }
            other => panic!("{other:?}"),
        }
    }

    /// Without `radius_m` and `radius_tol_m` the radius is left to the fit; a placement is kept.
    #[test]
    fn a_run_may_leave_its_radius_to_the_fit_and_name_its_placement() {
        let text = GOOD.replace(
            "radius_m = 0.09\nradius_tol_m = 0.002\n",
            "placement = \" left \"\n",
        );
        match &parse(&text).unwrap().recordings[1].kind {
            EntryKind::Turntable(t) => {
                assert_eq!(t.radius, None);
                assert_eq!(t.placement.as_deref(), Some("left"));
            }
            other => panic!("{other:?}"),
        }
    }

    /// The CLI's reading flags as keys: a 16-bit part's ranges name its scales.
    #[test]
    fn an_entry_takes_the_reading_flags_and_a_parts_ranges() {
        let keys = "format = \"csv\"\ntime_unit = \"ms\"\naccel_range_g = 2\ngyro_range_dps = 250\ngyro_file = \"g.csv\"\nretime = true\n";
        let c = parse(&GOOD.replace("kind = \"static\"\n", &format!("kind = \"static\"\n{keys}"))).unwrap();
        let e = &c.recordings[0];
        assert_eq!(e.read.format, Some(Format::Csv));
        assert_eq!(e.read.columns.time_unit, Some(TimeUnit::Ms));
        assert_eq!(e.read.accel_scale, Some(2.0 * STANDARD_GRAVITY / 32768.0));
        assert_eq!(e.read.gyro_scale, Some(250f64.to_radians() / 32768.0));
        assert!(e.read.retime);
        assert_eq!(e.gyro_file.as_deref(), Some(Path::new("runs/g.csv")));
        let cases = [
            (
                "accel_range_g = 3\n",
                "runs/c.toml:6: `accel_range_g`: 3: a 16-bit part's ranges are 2, 4, 8, 16",
            ),
            (
                "accel_range_g = 2\naccel_scale = 0.001\n",
                "runs/c.toml:6: `accel_range_g`: give `accel_range_g` or `accel_scale`, not both",
            ),
            (
                "format = \"excel\"\n",
                "runs/c.toml:6: `format`: 'excel': expected one of",
            ),
            ("time_unit = \"fortnight\"\n", "runs/c.toml:6: `time_unit`"),
            (
                "accel_offset = [1, 2]\n",
                "runs/c.toml:6: `accel_offset`: expected three",
            ),
        ];
        for (keys, start) in cases {
            let e = parse(&GOOD.replace("kind = \"static\"\n", &format!("kind = \"static\"\n{keys}")))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(start), "{e} (wanted {start})");
        }
    }

    #[test]
    fn bad_entries_name_file_line_and_key() {
        let cases = [
            (GOOD.replace("up = \"-z\"", "up = \"+x\""), "runs/c.toml:14: `up`"),
            (
                GOOD.replace("radius_m = 0.09", "radius_m = -0.09"),
                "runs/c.toml:11: `radius_m`",
            ),
            (
                GOOD.replace("rpm = 33.333\n", ""),
                "runs/c.toml:7: `rpm`: missing",
            ),
            (
                GOOD.replace("kind = \"static\"", "kind = \"still\""),
                "runs/c.toml:5: `kind`",
            ),
            (
                GOOD.replace("kind = \"static\"", "kind = \"static\"\nrpm = 3"),
                "runs/c.toml:6: `rpm`",
            ),
            (
                GOOD.replace("out = \"+x\"", "out = \"+w\""),
                "runs/c.toml:13: `out`",
            ),
            (
                GOOD.replace("radius_m = 0.09\n", ""),
                "runs/c.toml:11: `radius_tol_m`: needs `radius_m`",
            ),
            (
                GOOD.replace("kind = \"static\"", "kind = \"static\"\nplacement = \"A\""),
                "runs/c.toml:6: `placement`: only a turntable",
            ),
            (
                GOOD.replace("up = \"-z\"", "up = \"-z\"\nplacement = \" \""),
                "runs/c.toml:15: `placement`: empty",
            ),
        ];
        for (text, start) in cases {
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.starts_with(start), "{e} (wanted {start})");
        }
    }

    #[test]
    fn the_datasheet_nonlinearity_needs_both_numbers_in_range() {
        let with = |extra: &str| GOOD.replace("unit = \"imu-07\"\n", &format!("unit = \"imu-07\"\n{extra}"));
        let c = parse(&with("range_g = 5\nnonlinearity_pct_fs = 0.2\n")).unwrap();
        let q = c.datasheet.nonlinearity.unwrap().quadratic_per_mps2();
        // 0.2 % of 5 g at the range's end is 1.5 × that over the full scale.
        assert!((q - 1.5 * 0.002 / (5.0 * STANDARD_GRAVITY)).abs() < 1e-15, "{q}");
        assert!(parse(GOOD).unwrap().datasheet.nonlinearity.is_none());
        for (extra, start) in [
            (
                "range_g = 5\n",
                "runs/c.toml:3: `range_g`: needs `nonlinearity_pct_fs`",
            ),
            (
                "nonlinearity_pct_fs = 0.2\n",
                "runs/c.toml:3: `nonlinearity_pct_fs`: needs `range_g`",
            ),
            (
                "range_g = -5\nnonlinearity_pct_fs = 0.2\n",
                "runs/c.toml:3: `range_g`",
            ),
            (
                "range_g = 5\nnonlinearity_pct_fs = 120\n",
                "runs/c.toml:4: `nonlinearity_pct_fs`",
            ),
        ] {
            let e = parse(&with(extra)).unwrap_err().to_string();
            assert!(e.starts_with(start), "{e} (wanted {start})");
        }
    }

    #[test]
    fn the_datasheet_tolerances_are_read_and_checked() {
        let with = |extra: &str| GOOD.replace("unit = \"imu-07\"\n", &format!("unit = \"imu-07\"\n{extra}"));
        let c = parse(&with("zero_g_offset_mg = 50\ncross_axis_pct = 2\n")).unwrap();
        assert_eq!(
            c.datasheet,
            Datasheet {
                zero_g_offset_mg: Some(50.0),
                cross_axis_pct: Some(2.0),
                ..Datasheet::default()
            }
        );
        for (extra, start) in [
            (
                "zero_g_offset_mg = 0\n",
                "runs/c.toml:3: `zero_g_offset_mg`: 0: a zero-g offset",
            ),
            (
                "sensitivity_tolerance_pct = 80\n",
                "runs/c.toml:3: `sensitivity_tolerance_pct`: 80: a sensitivity tolerance",
            ),
            ("cross_axis_pct = nan\n", "runs/c.toml:3: `cross_axis_pct`: NaN"),
        ] {
            let e = parse(&with(extra)).unwrap_err().to_string();
            assert!(e.starts_with(start), "{e} (wanted {start})");
        }
    }

    #[test]
    fn syntax_and_unknown_keys_are_located() {
        let e = parse(&GOOD.replace("radius_tol_m", "radius_tolerance"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("runs/c.toml:12:"), "{e}");
        assert!(e.contains("radius_tolerance"), "{e}");
        let e = parse("unit = \n").unwrap_err().to_string();
        assert!(e.starts_with("runs/c.toml:1:"), "{e}");
        let e = parse("unit = \"a\"\n").unwrap_err().to_string();
        assert!(e.contains("no [[recording]]"), "{e}");
    }
}
