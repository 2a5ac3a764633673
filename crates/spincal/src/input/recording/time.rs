//! The rules for a time column whose unit nobody stated, stated once for every reader.
//!
//! - A unit given by the caller (`time_unit`) is used as given.
//! - Otherwise the unit comes from the column's name (`t_ms`, ROS's `stamp` in ns) or is assumed
//!   to be seconds, and is held against the values: the sample interval it implies must give a
//!   rate of at least [`MIN_RATE_HZ`] and at most [`MAX_RATE_HZ`], over a span of at most
//!   [`MAX_SPAN_S`]. A name's unit that fails is an error naming the fix. An assumed second that
//!   fails is replaced by the one unit among ms, µs and ns that passes, with a note (saying so
//!   when the values are timestamps since the Unix epoch); none or several is an error. The rate,
//!   not the magnitude, decides: a `micros()` counter reaches the magnitude of epoch seconds
//!   after half an hour, and its steps of 10,000 say it counts microseconds.
//! - A counter that wraps (uint16 or uint32, or int32 passing from its largest to its smallest
//!   value) is unwrapped with a note: a step back by the counter's modulus, to within ten sample
//!   intervals, is the counter wrapping, not time going back.

use super::units::TimeUnit;

/// The lowest sample rate an IMU recording has, Hz.
pub const MIN_RATE_HZ: f64 = 1.0;
/// The highest, Hz (a gyro's 32 kHz output is the fastest in common parts).
pub const MAX_RATE_HZ: f64 = 40_000.0;
/// The longest span of one recording, s (7 days).
pub const MAX_SPAN_S: f64 = 7.0 * 86_400.0;

/// Seconds since the Unix epoch of 2000-01-01 and 2100-01-01: a timestamp between is a date.
const EPOCH_RANGE_S: [f64; 2] = [946_684_800.0, 4_102_444_800.0];

/// Moduli of the counters that wrap: uint16 and uint32 (int32 wraps by 2³² too).
const COUNTER_MODULI: [f64; 2] = [65_536.0, 4_294_967_296.0];

/// Where a time column's unit came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeUnitSource {
    /// Given by the caller: used as given.
    Stated,
    /// Read from the column's name.
    Named,
    /// Nothing said: seconds assumed.
    Assumed,
}

/// The unit a time column is read in, and what the user should be told about it.
#[derive(Debug, Clone, PartialEq)]
pub struct SettledTime {
    pub unit: TimeUnit,
    pub note: Option<String>,
}

/// Why a time column cannot be read as time.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: the time column `{column}` read in {unit} gives {rate_hz:.4} Hz over {span}, which no IMU recording has (at least {MIN_RATE_HZ} Hz, at most 7 days); {fix}")]
pub struct ImplausibleTime {
    pub file: String,
    pub column: String,
    pub unit: &'static str,
    pub rate_hz: f64,
    pub span: String,
    pub fix: String,
}

fn unit_name(unit: TimeUnit) -> &'static str {
    match unit {
        TimeUnit::S => "s",
        TimeUnit::Ms => "ms",
        TimeUnit::Us => "us",
        TimeUnit::Ns => "ns",
    }
}

/// The typical sample interval of raw values in time order: the median over windows of up to 64
/// steps ([`super::sample_interval`]), so that timestamps quantised by their f64 (epoch
/// nanoseconds) still give the rate; NaN when there are not two distinct times.
fn typical_step(raw: &[f64]) -> f64 {
    let step = super::sample_interval(raw);
    if step > 0.0 && step.is_finite() {
        step
    } else {
        f64::NAN
    }
}

fn span_text(span_s: f64) -> String {
    if span_s >= 2.0 * 365.25 * 86_400.0 {
        format!("{:.0} years", span_s / (365.25 * 86_400.0))
    } else if span_s >= 2.0 * 86_400.0 {
        format!("{:.0} days", span_s / 86_400.0)
    } else {
        format!("{span_s:.3} s")
    }
}

/// Whether `unit` makes `step` (raw) a plausible sample interval and `span` (raw) a plausible
/// length.
fn plausible(unit: TimeUnit, step: f64, span: f64) -> bool {
    let rate = 1.0 / (step * unit.to_si());
    (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&rate) && span * unit.to_si() <= MAX_SPAN_S
}

/// Settles the unit of the raw time values `raw` (as in the file, in time order) read in `unit`
/// by `source`; `file` and `column` name them in errors. A column without two distinct times
/// says nothing about its unit and keeps it.
pub fn settle_unit(
    raw: &[f64],
    unit: TimeUnit,
    source: TimeUnitSource,
    file: &str,
    column: &str,
) -> Result<SettledTime, ImplausibleTime> {
    let kept = SettledTime { unit, note: None };
    let step = typical_step(raw);
    if source == TimeUnitSource::Stated || !step.is_finite() {
        return Ok(kept);
    }
    let span = match (raw.first(), raw.last()) {
        (Some(a), Some(b)) => (b - a).abs(),
        _ => 0.0,
    };
    if plausible(unit, step, span) {
        return Ok(kept);
    }
    let others: Vec<TimeUnit> = [TimeUnit::Ms, TimeUnit::Us, TimeUnit::Ns]
        .into_iter()
        .filter(|&u| u != unit && plausible(u, step, span))
        .collect();
    let rate_in = |u: TimeUnit| 1.0 / (step * u.to_si());
    let error = |fix: String| ImplausibleTime {
        file: file.to_string(),
        column: column.to_string(),
        unit: unit_name(unit),
        rate_hz: rate_in(unit),
        span: span_text(span * unit.to_si()),
        fix,
    };
    let candidates = || {
        others
            .iter()
            .map(|&u| format!("{} ({:.4} Hz)", unit_name(u), rate_in(u)))
            .collect::<Vec<_>>()
            .join(" or ")
    };
    match (source, others.as_slice()) {
        (TimeUnitSource::Assumed, [only]) => {
            let first_s = raw.first().copied().unwrap_or(0.0) * only.to_si();
            let epoch = (EPOCH_RANGE_S[0]..=EPOCH_RANGE_S[1]).contains(&first_s);
            let what = if epoch {
                "timestamps since the Unix epoch"
            } else {
                "a clock"
            };
            Ok(SettledTime {
                unit: *only,
                note: Some(format!(
                    "the time column `{column}` holds {what} in {} (read in s it would give {:.4} Hz; in {} it gives {:.4} Hz); give `time_unit` to say otherwise",
                    unit_name(*only),
                    rate_in(TimeUnit::S),
                    unit_name(*only),
                    rate_in(*only)
                )),
            })
        }
        (_, []) => Err(error(
            "give `time_unit` (s, ms, us or ns) if the unit is right and the file is unusual, or `sample_rate_hz` when the column is no clock"
                .to_string(),
        )),
        _ => Err(error(format!("give `time_unit` {}", candidates()))),
    }
}

/// Unwraps a counter that wraps, in place (values in time order, `to_si` seconds per counter
/// unit); returns a note when it wrapped, naming the first line (`lines[i]`, else the sample
/// number).
pub fn unwrap_counter(raw: &mut [f64], to_si: f64, lines: &[usize]) -> Option<String> {
    let step = typical_step(raw);
    if !step.is_finite() {
        return None;
    }
    let mut offset = 0.0;
    let mut wraps = 0usize;
    let mut first = None;
    let mut modulus_used = 0.0;
    let mut previous = raw.first().copied()?;
    for i in 1..raw.len() {
        let here = raw[i];
        if here < previous {
            // Measured against the value as read: a wrapped counter lands near its start.
            let wrapped = COUNTER_MODULI
                .iter()
                .find(|&&m| {
                    let gap = here + m * to_si - previous;
                    gap > 0.0 && gap <= 10.0 * step
                })
                .copied();
            if let Some(m) = wrapped {
                offset += m * to_si;
                wraps += 1;
                modulus_used = m;
                first.get_or_insert(lines.get(i).copied().unwrap_or(i + 1));
            }
        }
        previous = here;
        raw[i] = here + offset;
    }
    let first = first?;
    Some(format!(
        "the time counter wrapped {wraps} time(s) at 2^{} (first at line {first}) and was unwrapped",
        modulus_used.log2().round()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn column(start: f64, step: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| start + i as f64 * step).collect()
    }

    #[test]
    fn epoch_nanoseconds_under_a_bare_name_are_read_as_nanoseconds_with_a_note() {
        let raw = column(1.77e18, 1e7, 500);
        let settled =
            settle_unit(&raw, TimeUnit::S, TimeUnitSource::Assumed, "f.csv", "time").expect("settled");
        assert_eq!(settled.unit, TimeUnit::Ns);
        assert!(settled
            .note
            .expect("a note")
            .contains("since the Unix epoch in ns"));
    }

    #[test]
    fn a_micros_counter_at_epoch_seconds_magnitude_is_microseconds_not_a_date() {
        let raw = column(1.7e9, 10_000.0, 500);
        let settled = settle_unit(&raw, TimeUnit::S, TimeUnitSource::Assumed, "f.csv", "t").expect("settled");
        assert_eq!(settled.unit, TimeUnit::Us);
        assert!(settled.note.expect("a note").contains("a clock in us"));
        // Epoch milliseconds at 50 Hz.
        let raw = column(1.7e12, 20.0, 500);
        let settled = settle_unit(&raw, TimeUnit::S, TimeUnitSource::Assumed, "f.csv", "t").expect("settled");
        assert_eq!(settled.unit, TimeUnit::Ms);
    }

    #[test]
    fn seconds_that_fit_stay_and_a_stated_unit_is_never_second_guessed() {
        let raw = column(3.0, 0.01, 500);
        let settled = settle_unit(&raw, TimeUnit::S, TimeUnitSource::Assumed, "f.csv", "t").expect("settled");
        assert_eq!(
            settled,
            SettledTime {
                unit: TimeUnit::S,
                note: None
            }
        );
        let slow = column(0.0, 10.0, 50);
        let stated = settle_unit(&slow, TimeUnit::S, TimeUnitSource::Stated, "f.csv", "t").expect("stated");
        assert_eq!(stated.unit, TimeUnit::S);
    }

    #[test]
    fn a_named_unit_the_values_contradict_is_an_error_naming_the_fix() {
        // Milliseconds under `t_s`: 0.1 Hz read as seconds.
        let raw = column(0.0, 10.0, 500);
        let e = settle_unit(&raw, TimeUnit::S, TimeUnitSource::Named, "f.csv", "t_s").expect_err("refused");
        let text = e.to_string();
        assert!(
            text.contains("f.csv")
                && text.contains("`t_s`")
                && text.contains("give `time_unit` ms (100.0000 Hz)"),
            "{text}"
        );
        // Nothing fits: a sample every two nanoseconds' worth of seconds.
        let raw = column(0.0, 1e-6, 50);
        let e = settle_unit(&raw, TimeUnit::S, TimeUnitSource::Assumed, "f.csv", "t").expect_err("refused");
        assert!(e.to_string().contains("`sample_rate_hz`"), "{e}");
        // Steps of 100 are 10 Hz in ms or 10 kHz in µs: the unit must be said.
        let raw = column(0.0, 100.0, 50);
        let e = settle_unit(&raw, TimeUnit::S, TimeUnitSource::Assumed, "f.csv", "t").expect_err("refused");
        assert!(
            e.to_string()
                .contains("give `time_unit` ms (10.0000 Hz) or us (10000.0000 Hz)"),
            "{e}"
        );
    }

    #[test]
    fn a_uint32_millisecond_counter_is_unwrapped_and_a_real_step_back_is_not() {
        let modulus = 4_294_967_296.0;
        let mut raw: Vec<f64> = (0..200)
            .map(|i| (modulus - 1000.0 + 10.0 * i as f64) % modulus)
            .collect();
        let lines: Vec<usize> = (2..202).collect();
        let note = unwrap_counter(&mut raw, 1.0, &lines).expect("a note");
        assert!(note.contains("2^32") && note.contains("line 102"), "{note}");
        assert!(raw.windows(2).all(|w| w[1] - w[0] == 10.0));
        let mut back = column(0.0, 0.01, 100);
        back[50] = 0.2;
        let before = back.clone();
        assert_eq!(unwrap_counter(&mut back, 1.0, &[]), None);
        assert_eq!(back, before);
    }
}
