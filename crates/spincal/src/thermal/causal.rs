//! The die temperature from the reported temperatures seen so far, for correcting a stream row by
//! row (`spincal correct`, Python, the vehicle): no look-ahead, memory bounded by one window.
//!
//! The batch estimate ([`super::die_temperature`]) fits a line over a centred window and places a
//! stepped temperature's knots at the midpoints of its steps, which needs the next step. Here both
//! look back only:
//! - a finely resolved temperature: value and slope of a line fitted to the last `smoothing_s`
//!   of samples, evaluated at the newest one;
//! - a stepped one (it changes on fewer than one sample in ten, the batch rule): the line through
//!   the midpoints of the last two steps, continued to now and held within half a step of the
//!   reported level, its slope shrinking when no further step comes.
//!
//! In both, T_die = T + τ·Ṫ. Until a stepped temperature has stepped twice, the trailing line
//! stands in for the steps' line.

use std::collections::VecDeque;

/// Samples seen before the stepped/fine decision is trusted.
const DECIDE_AFTER: usize = 20;

/// What one sample adds to Σ1, Σt, Σt², ΣT, ΣtT.
fn terms(t: f64, v: f64) -> [f64; 5] {
    [1.0, t, t * t, v, t * v]
}

/// The causal die-temperature estimator (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct CausalDieTemperature {
    lag_s: f64,
    smoothing_s: f64,
    /// (time relative to `origin`, reported) within the trailing window.
    window: VecDeque<(f64, f64)>,
    origin: f64,
    /// Σ1, Σt, Σt², ΣT, ΣtT over `window`.
    sums: [f64; 5],
    /// Samples added since the sums were last recomputed from the window (bounds rounding).
    since_rebuild: usize,
    samples: usize,
    changes: usize,
    previous: Option<(f64, f64)>,
    /// The last two step midpoints (time, level) and the smallest step seen.
    knots: [Option<(f64, f64)>; 2],
    step: f64,
}

impl CausalDieTemperature {
    pub fn new(lag_s: f64, smoothing_s: f64) -> CausalDieTemperature {
        CausalDieTemperature {
            lag_s,
            smoothing_s,
            window: VecDeque::new(),
            origin: 0.0,
            sums: [0.0; 5],
            since_rebuild: 0,
            samples: 0,
            changes: 0,
            previous: None,
            knots: [None, None],
            step: f64::INFINITY,
        }
    }

    /// The die temperature at `time_s` given the reported `reported_c`; times must not decrease.
    pub fn update(&mut self, time_s: f64, reported_c: f64) -> f64 {
        if let Some((t0, v0)) = self.previous {
            if reported_c != v0 {
                self.changes += 1;
                self.step = self.step.min((reported_c - v0).abs());
                self.knots = [
                    self.knots[1],
                    Some(((t0 + time_s) / 2.0, (v0 + reported_c) / 2.0)),
                ];
            }
        }
        self.previous = Some((time_s, reported_c));
        self.samples += 1;
        self.push(time_s, reported_c);
        let stepped = self.samples >= DECIDE_AFTER && self.changes * 10 <= self.samples;
        let (value, slope) = match self.steps_line(time_s, reported_c) {
            Some(line) if stepped => line,
            _ => self.window_line(time_s, reported_c),
        };
        value + self.lag_s * slope
    }

    fn push(&mut self, time_s: f64, reported_c: f64) {
        if self.window.is_empty() {
            self.origin = time_s;
        }
        let t = time_s - self.origin;
        self.window.push_back((t, reported_c));
        self.add(t, reported_c, 1.0);
        while self
            .window
            .front()
            .is_some_and(|&(first, _)| first < t - self.smoothing_s)
        {
            if let Some((first, v)) = self.window.pop_front() {
                self.add(first, v, -1.0);
            }
        }
        self.since_rebuild += 1;
        if self.since_rebuild > self.window.len().max(64) {
            self.rebuild();
        }
    }

    fn add(&mut self, t: f64, v: f64, sign: f64) {
        for (s, x) in self.sums.iter_mut().zip(terms(t, v)) {
            *s += sign * x;
        }
    }

    /// Sums recomputed from the window, with the origin moved to its first sample.
    fn rebuild(&mut self) {
        let shift = self.window.front().map_or(0.0, |&(t, _)| t);
        self.origin += shift;
        self.sums = [0.0; 5];
        for i in 0..self.window.len() {
            self.window[i].0 -= shift;
            let (t, v) = self.window[i];
            self.add(t, v, 1.0);
        }
        self.since_rebuild = 0;
    }

    fn window_line(&self, time_s: f64, reported_c: f64) -> (f64, f64) {
        let [count, st, stt, sv, stv] = self.sums;
        if count < 3.0 {
            return (reported_c, 0.0);
        }
        let mean_t = st / count;
        let var_t = stt / count - mean_t * mean_t;
        let mean_v = sv / count;
        if var_t <= 1e-12 {
            return (mean_v, 0.0);
        }
        let slope = (stv / count - mean_t * mean_v) / var_t;
        (mean_v + slope * (time_s - self.origin - mean_t), slope)
    }

    /// The line through the last two steps' midpoints, once there are two. Its slope is at most
    /// one step over the time since the last one: a temperature that has not stepped for long is
    /// not still rising at the rate it once did.
    fn steps_line(&self, time_s: f64, reported_c: f64) -> Option<(f64, f64)> {
        let half = self.step / 2.0;
        match self.knots {
            [Some(a), Some(b)] if b.0 > a.0 => {
                let bound = self.step / (time_s - b.0).max(b.0 - a.0);
                let slope = ((b.1 - a.1) / (b.0 - a.0)).clamp(-bound, bound);
                let value = (b.1 + slope * (time_s - b.0)).clamp(reported_c - half, reported_c + half);
                Some((value, slope))
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::thermal::die_temperature;
    use crate::thermal::tests::{lagging_warm_up as warm_up, WARM_UP_LAG_S};

    fn worst(estimate: &[f64], die: &[f64]) -> f64 {
        estimate[1000..21_000]
            .iter()
            .zip(&die[1000..21_000])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }

    fn causal(time: &[f64], reported: &[f64]) -> Vec<f64> {
        let mut est = CausalDieTemperature::new(WARM_UP_LAG_S, 60.0);
        time.iter()
            .zip(reported)
            .map(|(&t, &v)| est.update(t, v))
            .collect()
    }

    #[test]
    fn undoes_the_lag_looking_back_only() {
        let (time, die, reported) = warm_up();
        let lagging = worst(&reported, &die);
        let fine = causal(&time, &reported);
        assert!(lagging > 0.6, "the lag itself: {lagging}");
        assert!(worst(&fine, &die) < 0.1, "fine: {}", worst(&fine, &die));
        let stepped: Vec<f64> = reported.iter().map(|v| v.round()).collect();
        let from_steps = causal(&time, &stepped);
        let error = worst(&from_steps, &die);
        let batch = worst(&die_temperature(&time, &stepped, WARM_UP_LAG_S, 60.0), &die);
        assert!(
            error < 0.6,
            "stepped: {error} °C (the batch estimate, which looks ahead: {batch})"
        );
        // No 1 °C jumps where the reported value steps (10 Hz).
        // Judged, like the error, after the first 100 s: the first two steps (the fastest part of
        // the warm-up) pass before the steps' line takes over, with jumps of up to 0.4 °C there.
        let jump = from_steps[1000..21_000]
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(jump < 0.1, "largest jump {jump} °C");
    }

    #[test]
    fn a_temperature_that_stops_stepping_stops_rising() {
        // A ramp of 0.02 °C/s for 1000 s that then holds, in whole degrees through a 20 s lag:
        // once the steps stop, the last two steps' slope (and τ times it) must not go on.
        let dt = 0.1;
        let time: Vec<f64> = (0..30_000).map(|i| i as f64 * dt).collect();
        let die: Vec<f64> = time.iter().map(|&t| 20.0 + 0.02 * t.min(1000.0)).collect();
        let keep = (-dt / WARM_UP_LAG_S).exp();
        let mut lagged = die[0];
        let stepped: Vec<f64> = die
            .iter()
            .map(|&d| {
                lagged = keep * lagged + (1.0 - keep) * d;
                lagged.round()
            })
            .collect();
        let estimate = causal(&time, &stepped);
        // Long after the hold began, within half a step of the truth (plus τ × one step over the
        // time since the last: 0.013 °C here). Without the slope's bound it stays 0.9 °C off.
        let late = estimate[25_000..]
            .iter()
            .zip(&die[25_000..])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(late <= 0.52, "after the hold: {late} °C");
    }

    #[test]
    fn a_prefix_gives_the_same_values() {
        // Causal: the estimate at a sample does not depend on what comes after it.
        let (time, _, reported) = warm_up();
        let whole = causal(&time, &reported);
        let part = causal(&time[..12_345], &reported[..12_345]);
        assert_eq!(&whole[..12_345], &part[..]);
    }
}
