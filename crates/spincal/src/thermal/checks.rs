//! The reported temperature checked like every other input, by one rule set that `calibrate`
//! (the thermal stage of a campaign) and `correct` (the row corrector) both run, and the
//! plausibility limits of a thermal model, stated once.
//!
//! **Samples** ([`TemperatureTrack`], one sample at a time, looking back only):
//! - *implausible*: outside [`PLAUSIBLE_C`], the range MEMS parts are specified to survive;
//! - *discontinuous*: a die is a few grams of silicon in a package, and its temperature cannot
//!   move faster than [`MAX_SLEW_C_PER_S`]; a sample further from the last trusted one than that
//!   slew over the time between them, plus [`STEP_ALLOWANCE_C`] for quantisation and noise, opens
//!   a *suspect* stretch (a glitch, or a sensor that reset and steps back). The stretch ends when
//!   the temperature jumps back towards the trusted track (closer to it than to the stretch); a
//!   stretch that lasts [`ADOPT_AFTER_S`] is the sensor's new level and is trusted from then on. A
//!   track that jumps away before [`CONFIRM_SAMPLES`] samples is dropped instead: its first
//!   samples were the glitch.
//!
//! Samples found are kept out of the die-temperature estimate and out of the fit (masked, their
//! rows kept), and named with their file and line.
//!
//! **Recordings**: a temperature column whose median is implausible in its stated unit but
//! within [`OPERATING_C`] in another is a unit error ([`check_unit`]: kelvin under a °C name, and
//! the rest by the same rule), refused with the file, the column and the likely unit. A
//! recording at least [`STUCK_AFTER_S`] long whose temperature never changes is a stuck sensor
//! when its campaign records temperature change elsewhere ([`is_stuck`]).
//!
//! **Models** ([`crate::thermal::ThermalModel::check_plausible`]): what a thermal model may do to a
//! reading over its fitted range, used when model.json is read, when a fit is saved, and by the
//! flight-stack exports.

use serde::{Deserialize, Serialize};

use crate::input::recording::TemperatureUnit;

/// Temperatures a MEMS part is specified to survive, °C (storage range of common IMUs:
/// −40…+150 °C; automotive dies down to −55 °C). A reported value outside it is not the die's.
pub const PLAUSIBLE_C: [f64; 2] = [-55.0, 150.0];

/// Temperatures consumer and industrial IMUs operate at, °C (−40…+85 °C): where a column read in
/// another unit must land for that unit to be suggested.
pub const OPERATING_C: [f64; 2] = [-40.0, 85.0];

/// The fastest a die's temperature can change, °C/s. A packaged MEMS die (a few mm³ of silicon on
/// a board) warms or cools with a time constant of seconds at the very least; power-on
/// self-heating moves it by well under 1 °C/s. 5 °C/s leaves a margin for a heat gun or a soldering
/// iron near the board.
pub const MAX_SLEW_C_PER_S: f64 = 5.0;

/// A change between samples that quantisation and noise explain, °C: two steps of a sensor that
/// reports whole degrees.
pub const STEP_ALLOWANCE_C: f64 = 2.0;

/// A suspect stretch lasting this long is the sensor's new level, s: a reset or a glitch has
/// returned long before, and after five minutes masking more would hide a sensor that really
/// changed (it is still named).
pub const ADOPT_AFTER_S: f64 = 300.0;

/// Samples a track needs before a jump away from it is taken as the jump's fault.
pub const CONFIRM_SAMPLES: usize = 3;

/// A suspect stretch up to this long is named a glitch, longer a step (a reset), s.
pub const GLITCH_MAX_S: f64 = 2.0;

/// A recording at least this long whose temperature never changes is stuck when its campaign
/// records temperature change, s. A powered die drifts by a fraction of a degree over 15 minutes
/// even at a steady ambient, which a sensor resolving 0.1 °C or better shows; one resolving whole
/// degrees can hold one value through a chamber soak, so the finding masks the recording's
/// temperature (kept out of the thermal fit, named) rather than refusing the campaign.
pub const STUCK_AFTER_S: f64 = 900.0;

/// Rows of `correct`'s stream the unit check looks at (the rows read ahead for the time unit).
pub const UNIT_CHECK_ROWS: usize = 256;

/// What the rules decided about one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleCheck {
    /// On the trusted track: used.
    Trusted,
    /// Not finite, or outside [`PLAUSIBLE_C`].
    Implausible,
    /// Faster than a die can change from the trusted track (a glitch or a reset).
    Discontinuous,
}

/// The causal sample rule (see the [module](self) documentation).
#[derive(Debug, Clone, Default)]
pub struct TemperatureTrack {
    /// The last trusted sample (time, value) and how many the track holds.
    trusted: Option<(f64, f64)>,
    trusted_samples: usize,
    /// The previous plausible sample, trusted or not.
    previous: Option<(f64, f64)>,
    /// When the current suspect stretch began.
    suspect_since: Option<f64>,
    /// Set by the last [`TemperatureTrack::check`] when it dropped a young track.
    restarted: bool,
}

impl TemperatureTrack {
    pub fn new() -> TemperatureTrack {
        TemperatureTrack::default()
    }

    /// Whether the last sample checked dropped the track before it (a glitch at its start): a
    /// die estimate fed from it should start again.
    pub fn restarted(&self) -> bool {
        self.restarted
    }

    /// Checks one sample; `time_s` None (no clock) counts as no time elapsed. Times must not
    /// decrease.
    pub fn check(&mut self, time_s: Option<f64>, value_c: f64) -> SampleCheck {
        self.restarted = false;
        if !(value_c.is_finite() && (PLAUSIBLE_C[0]..=PLAUSIBLE_C[1]).contains(&value_c)) {
            return SampleCheck::Implausible;
        }
        let t = time_s.unwrap_or_else(|| self.previous.map_or(0.0, |p| p.0));
        let allowed = |from: (f64, f64)| STEP_ALLOWANCE_C + MAX_SLEW_C_PER_S * (t - from.0).max(0.0);
        let verdict = match (self.trusted, self.suspect_since) {
            (None, _) => self.trust(t, value_c),
            (Some(a), None) if (value_c - a.1).abs() <= allowed(a) => self.trust(t, value_c),
            // A jump before the track is confirmed: the track was the glitch.
            (Some(_), None) if self.trusted_samples < CONFIRM_SAMPLES => {
                self.trusted_samples = 0;
                self.restarted = true;
                self.trust(t, value_c)
            }
            (Some(_), None) => {
                self.suspect_since = Some(t);
                SampleCheck::Discontinuous
            }
            (Some(a), Some(since)) => {
                let p = self.previous.unwrap_or(a);
                let jumped = (value_c - p.1).abs() > allowed(p);
                let back = jumped
                    && (value_c - a.1).abs() <= allowed(a)
                    && (value_c - a.1).abs() < (value_c - p.1).abs();
                if back || t - since >= ADOPT_AFTER_S {
                    self.suspect_since = None;
                    self.trust(t, value_c)
                } else {
                    SampleCheck::Discontinuous
                }
            }
        };
        self.previous = Some((t, value_c));
        verdict
    }

    fn trust(&mut self, t: f64, v: f64) -> SampleCheck {
        self.trusted = Some((t, v));
        self.trusted_samples += 1;
        SampleCheck::Trusted
    }
}

/// What a run of masked samples was taken for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FindingKind {
    /// Outside [`PLAUSIBLE_C`] (or not finite).
    Implausible,
    /// A discontinuous stretch up to [`GLITCH_MAX_S`].
    Glitch,
    /// A longer one: the sensor stepped away (a reset) and came back, or stayed.
    Step,
    /// The whole recording never changes ([`is_stuck`]).
    Stuck,
}

/// Samples of one recording's temperature kept out of the fit, and why (results.json).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TemperatureFinding {
    pub file: String,
    /// 1-based line of the first sample (the sample number when the recording has no lines).
    pub line: usize,
    pub kind: FindingKind,
    /// Samples in the run.
    pub samples: usize,
    /// The value furthest from the trusted track in the run, °C (the stuck value for `stuck`).
    pub value_c: f64,
    /// Duration of the run, s.
    pub duration_s: f64,
}

impl std::fmt::Display for TemperatureFinding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (file, line, n, v) = (&self.file, self.line, self.samples, self.value_c);
        match self.kind {
            FindingKind::Implausible => write!(
                f,
                "{file}:{line}: temperature {v} °C is outside what a MEMS die reaches ({}…{} °C); {n} sample(s) kept out of the fit",
                PLAUSIBLE_C[0], PLAUSIBLE_C[1]
            ),
            FindingKind::Glitch => write!(
                f,
                "{file}:{line}: temperature glitch to {v} °C, faster than a die can change ({MAX_SLEW_C_PER_S} °C/s); {n} sample(s) kept out of the fit"
            ),
            FindingKind::Step => write!(
                f,
                "{file}:{line}: the temperature steps to {v} °C for {:.1} s, faster than a die can change ({MAX_SLEW_C_PER_S} °C/s): a sensor reset?; {n} sample(s) kept out of the fit",
                self.duration_s
            ),
            FindingKind::Stuck => write!(
                f,
                "{file}:{line}: the temperature stays at {v} °C for all {:.0} s while the campaign's other recordings change temperature: a stuck sensor?; the recording is used without its temperature",
                self.duration_s
            ),
        }
    }
}

/// One recording's temperature checked sample by sample.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackCheck {
    /// Per sample: kept out of the fit.
    pub masked: Vec<bool>,
    pub findings: Vec<TemperatureFinding>,
}

impl TrackCheck {
    pub fn masked_samples(&self) -> usize {
        self.masked.iter().filter(|&&m| m).count()
    }

    /// The temperatures with each masked sample replaced by the last trusted one before it (the
    /// first trusted one after it at the start): a held value adds no step to a stepped sensor's
    /// track. `None` when no sample is trusted.
    pub fn held(&self, temperature_c: &[f64]) -> Option<Vec<f64>> {
        let first = (0..temperature_c.len()).find(|&i| !self.masked[i])?;
        let mut last = temperature_c[first];
        Some(
            temperature_c
                .iter()
                .zip(&self.masked)
                .map(|(&v, &masked)| {
                    if !masked {
                        last = v;
                    }
                    last
                })
                .collect(),
        )
    }
}

/// Runs [`TemperatureTrack`] over a recording's temperatures; `lines` names samples (1-based
/// lines, or empty: sample numbers).
pub fn check_track(file: &str, lines: &[usize], time_s: &[f64], temperature_c: &[f64]) -> TrackCheck {
    let n = time_s.len().min(temperature_c.len());
    let mut track = TemperatureTrack::new();
    let mut verdicts = Vec::with_capacity(n);
    for i in 0..n {
        let verdict = track.check(Some(time_s[i]), temperature_c[i]);
        if track.restarted() {
            // The dropped track's samples were the glitch.
            // (Only a young track is dropped: every sample trusted so far is its.)
            for v in verdicts.iter_mut().filter(|v| **v == SampleCheck::Trusted) {
                *v = SampleCheck::Discontinuous;
            }
        }
        verdicts.push(verdict);
    }
    let line_of = |i: usize| lines.get(i).copied().unwrap_or(i + 1);
    let mut findings = Vec::new();
    let mut i = 0;
    while i < n {
        let kind = verdicts[i];
        if kind == SampleCheck::Trusted {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && verdicts[i] == kind {
            i += 1;
        }
        let reference = start
            .checked_sub(1)
            .map(|p| temperature_c[p])
            .or_else(|| temperature_c.get(i).copied())
            .unwrap_or(0.0);
        let value_c = temperature_c[start..i]
            .iter()
            .copied()
            .max_by(|a, b| (a - reference).abs().total_cmp(&(b - reference).abs()))
            .unwrap_or(f64::NAN);
        let duration_s = time_s[i - 1] - time_s[start];
        findings.push(TemperatureFinding {
            file: file.to_string(),
            line: line_of(start),
            kind: match kind {
                SampleCheck::Implausible => FindingKind::Implausible,
                _ if duration_s <= GLITCH_MAX_S => FindingKind::Glitch,
                _ => FindingKind::Step,
            },
            samples: i - start,
            value_c,
            duration_s,
        });
    }
    TrackCheck {
        masked: verdicts.iter().map(|&v| v != SampleCheck::Trusted).collect(),
        findings,
    }
}

/// Whether a recording's temperature is stuck: at least [`STUCK_AFTER_S`] long and one value
/// on every trusted sample. The caller says whether the campaign expects change.
pub fn is_stuck(time_s: &[f64], temperature_c: &[f64], masked: &[bool]) -> Option<f64> {
    let duration = match (time_s.first(), time_s.last()) {
        (Some(a), Some(b)) => b - a,
        _ => return None,
    };
    let mut trusted = temperature_c
        .iter()
        .zip(masked)
        .filter(|(_, &m)| !m)
        .map(|(&v, _)| v);
    let first = trusted.next()?;
    (duration >= STUCK_AFTER_S && trusted.all(|v| v == first)).then_some(first)
}

/// A temperature column that is not a die's temperature in its stated unit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TemperatureError {
    #[error("{file}: column `{column}`: the temperatures (median {median} {declared}) are {median_c:.1} °C, outside what a MEMS die reaches ({lo}…{hi} °C); read as {suggested} they would be {suggested_c:.1} °C: the column is likely in {suggested} (name it `{hint}` or state its unit)", lo = PLAUSIBLE_C[0], hi = PLAUSIBLE_C[1], declared = .declared.describe(), suggested = .suggested.describe(), hint = unit_hint(*.suggested))]
    Unit {
        file: String,
        column: String,
        /// The median in the stated unit, and in °C.
        median: f64,
        median_c: f64,
        declared: TemperatureUnit,
        /// The unit in which the median lies within [`OPERATING_C`], and its value there, °C.
        suggested: TemperatureUnit,
        suggested_c: f64,
    },
    #[error("{file}: column `{column}`: the temperatures (median {median} {declared}) are {median_c:.1} °C, outside what a MEMS die reaches ({lo}…{hi} °C), and no temperature unit spincal knows makes them plausible: is it the temperature column?", lo = PLAUSIBLE_C[0], hi = PLAUSIBLE_C[1], declared = .declared.describe())]
    NotATemperature {
        file: String,
        column: String,
        median: f64,
        median_c: f64,
        declared: TemperatureUnit,
    },
}

/// How a user states `unit` for a column: its name's suffix, or the option.
fn unit_hint(unit: TemperatureUnit) -> String {
    match unit {
        TemperatureUnit::Mpu6050Counts => "temperature_unit mpu6050counts".into(),
        _ => format!("temp_{}", unit.name()),
    }
}

/// Checks a temperature column's unit from its values (in °C, converted from `declared`): a
/// median outside [`PLAUSIBLE_C`] is an error, naming the unit in which it would lie within
/// [`OPERATING_C`] (MPU-6050 counts only when every value is a whole number). Non-finite values
/// are ignored; an empty column passes.
pub fn check_unit(
    file: &str,
    column: &str,
    values_c: &[f64],
    declared: TemperatureUnit,
) -> Result<(), TemperatureError> {
    let mut finite: Vec<f64> = values_c.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return Ok(());
    }
    let middle = finite.len() / 2;
    let median_c = *finite.select_nth_unstable_by(middle, f64::total_cmp).1;
    if (PLAUSIBLE_C[0]..=PLAUSIBLE_C[1]).contains(&median_c) {
        return Ok(());
    }
    let median = declared.from_celsius(median_c);
    let whole = values_c
        .iter()
        .filter(|v| v.is_finite())
        .all(|&v| declared.from_celsius(v).fract().abs() < 1e-9);
    let candidates = [
        TemperatureUnit::C,
        TemperatureUnit::K,
        TemperatureUnit::F,
        TemperatureUnit::Mpu6050Counts,
    ];
    let suggestion = candidates
        .into_iter()
        .filter(|&u| u != declared && (u != TemperatureUnit::Mpu6050Counts || whole))
        .map(|u| (u, u.to_celsius(median)))
        .find(|(_, c)| (OPERATING_C[0]..=OPERATING_C[1]).contains(c));
    let (file, column) = (file.to_string(), column.to_string());
    Err(match suggestion {
        Some((suggested, suggested_c)) => TemperatureError::Unit {
            file,
            column,
            median,
            median_c,
            declared,
            suggested,
            suggested_c,
        },
        None => TemperatureError::NotATemperature {
            file,
            column,
            median,
            median_c,
            declared,
        },
    })
}

/// A recording's temperature unit as its column name states it (`temp_k`, `temperature (°F)`),
/// else °C.
pub fn unit_of_column(name: &str) -> TemperatureUnit {
    crate::input::recording::temperature_unit_of_name(name).unwrap_or(TemperatureUnit::C)
}

/// The name of a recording's temperature column as read (`temperature` when not known).
pub(crate) fn temperature_column(rec: &crate::input::recording::Recording) -> String {
    match rec.source.columns.len() {
        5 | 8 => rec.source.columns[rec.source.columns.len() - 1].clone(),
        _ => "temperature".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(values: &[f64], dt: f64) -> TrackCheck {
        let time: Vec<f64> = (0..values.len()).map(|i| i as f64 * dt).collect();
        check_track("f.csv", &[], &time, values)
    }

    #[test]
    fn a_single_glitch_is_masked_and_named() {
        let mut v: Vec<f64> = (0..1000).map(|i| 20.0 + (i as f64 * 0.001).round()).collect();
        v[500] = 95.0;
        let c = run(&v, 0.02);
        assert_eq!(c.masked_samples(), 1);
        assert!(c.masked[500]);
        assert_eq!(c.findings.len(), 1);
        assert_eq!(
            (c.findings[0].kind, c.findings[0].line),
            (FindingKind::Glitch, 501)
        );
        assert_eq!(c.findings[0].value_c, 95.0);
        let held = c.held(&v).unwrap();
        assert_eq!(held[500], v[499]);
    }

    #[test]
    fn a_glitch_at_the_start_drops_the_young_track() {
        let mut v = vec![25.0; 100];
        v[0] = 95.0;
        let c = run(&v, 0.02);
        assert_eq!(c.masked_samples(), 1, "{:?}", c.findings);
        assert!(c.masked[0]);
    }

    #[test]
    fn a_reset_is_masked_until_it_returns() {
        // 50 Hz, 30 °C, stepping back 10 °C for 60 s from 100 s, warming slowly throughout.
        let v: Vec<f64> = (0..15_000)
            .map(|i| {
                let t = i as f64 / 50.0;
                let base = 30.0 + (t * 0.01).round();
                if (100.0..160.0).contains(&t) {
                    base - 10.0
                } else {
                    base
                }
            })
            .collect();
        let c = run(&v, 1.0 / 50.0);
        assert_eq!(c.masked_samples(), 3000);
        assert_eq!(c.findings.len(), 1);
        assert_eq!(c.findings[0].kind, FindingKind::Step);
        assert_eq!(c.findings[0].line, 5001);
    }

    #[test]
    fn a_lasting_step_is_adopted() {
        let v: Vec<f64> = (0..50_000).map(|i| if i < 1000 { 30.0 } else { 20.0 }).collect();
        let c = run(&v, 0.02);
        // Masked for ADOPT_AFTER_S at 50 Hz, then trusted.
        assert_eq!(c.masked_samples(), 15_000);
        assert!(!c.masked[49_999]);
    }

    #[test]
    fn implausible_values_are_masked_without_moving_the_track() {
        let mut v = vec![25.0; 100];
        v[10] = -273.0;
        v[11] = f64::NAN;
        let c = run(&v, 0.02);
        assert_eq!(c.masked_samples(), 2);
        assert_eq!(c.findings[0].kind, FindingKind::Implausible);
        assert_eq!(c.findings[0].line, 11);
    }

    #[test]
    fn a_warm_up_in_whole_degrees_passes() {
        // 25 °C over 40 minutes at 50 Hz in whole degrees; also a fast (1 °C/s) fine ramp.
        let v: Vec<f64> = (0..120_000)
            .map(|i| (15.0 + 25.0 * (1.0 - (-(i as f64) / 50.0 / 900.0).exp())).round())
            .collect();
        assert_eq!(run(&v, 0.02).masked_samples(), 0);
        let ramp: Vec<f64> = (0..1000).map(|i| 20.0 + i as f64 * 0.02).collect();
        assert_eq!(run(&ramp, 0.02).masked_samples(), 0);
    }

    #[test]
    fn kelvin_under_a_celsius_name_is_named() {
        let e = check_unit("w.csv", "temp_c", &[298.15, 299.15, 300.15], TemperatureUnit::C).unwrap_err();
        let message = e.to_string();
        assert!(
            message.contains("kelvin") && message.contains("temp_k"),
            "{message}"
        );
        assert!(
            message.contains("w.csv") && message.contains("temp_c"),
            "{message}"
        );
        // Celsius under a kelvin name: 25 K is −248 °C.
        let e = check_unit("w.csv", "temp_k", &[25.0 - 273.15], TemperatureUnit::K).unwrap_err();
        assert!(e.to_string().contains("likely in °C"), "{e}");
        // Fahrenheit that only °F explains (a hot die at 170 °F).
        let e = check_unit("w.csv", "temp", &[170.5, 171.2], TemperatureUnit::C).unwrap_err();
        assert!(e.to_string().contains("°F"), "{e}");
        // Plausible values pass; values no unit explains are refused as not a temperature.
        check_unit("w.csv", "temp_c", &[25.0, 400.0, 26.0], TemperatureUnit::C).unwrap();
        let e = check_unit("w.csv", "temp_c", &[5000.5], TemperatureUnit::C).unwrap_err();
        assert!(matches!(e, TemperatureError::NotATemperature { .. }), "{e}");
    }

    #[test]
    fn stuck_needs_length_and_one_value() {
        let time: Vec<f64> = (0..1000).map(|i| i as f64).collect();
        let v = vec![25.0; 1000];
        assert_eq!(is_stuck(&time, &v, &[false; 1000]), Some(25.0));
        assert_eq!(is_stuck(&time[..800], &v[..800], &[false; 800]), None);
        let mut w = v.clone();
        w[999] = 26.0;
        assert_eq!(is_stuck(&time, &w, &[false; 1000]), None);
    }
}
