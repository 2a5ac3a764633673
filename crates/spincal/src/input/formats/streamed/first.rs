//! The first pass's figures: time steps, extremes, windowed rates and the norms that tell raw
//! counts.

use super::median::{Distinct, Kth};
use super::reading::{Reading, Sample, Shape};
use super::{Declined, WINDOW};
use crate::input::recording::sample_interval;

/// The norm the whole-file reader takes the median of to tell raw counts.
pub(super) fn norm(a: &[f64; 3]) -> f64 {
    (a[0].powi(2) + a[1].powi(2) + a[2].powi(2)).sqrt()
}

/// The first pass's figures.
pub(super) struct First {
    pub(super) first: f64,
    pub(super) last: f64,
    pub(super) quantum: f64,
    pub(super) repeated: (usize, Option<usize>),
    pub(super) backward: (usize, Option<usize>),
    pub(super) min: [f64; 3],
    pub(super) max: [f64; 3],
    /// The gyro's extremes per axis, rad/s.
    pub(super) gyro_min: [f64; 3],
    pub(super) gyro_max: [f64; 3],
    pub(super) rates: Rates,
    pub(super) norms: Kth,
    pub(super) has_temperature: bool,
    pub(super) temperature: Distinct,
}

impl First {
    pub(super) fn new() -> First {
        First {
            first: f64::NAN,
            last: f64::NAN,
            quantum: f64::INFINITY,
            repeated: (0, None),
            backward: (0, None),
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
            gyro_min: [f64::INFINITY; 3],
            gyro_max: [f64::NEG_INFINITY; 3],
            rates: Rates::new(),
            norms: Kth::new(),
            has_temperature: false,
            temperature: Distinct::new(),
        }
    }

    pub(super) fn push(&mut self, i: usize, s: &Sample) {
        if i == 0 {
            self.first = s.t;
        } else {
            let step = s.t - self.last;
            if step > 0.0 {
                self.quantum = self.quantum.min(step);
            } else if step == 0.0 {
                self.repeated.0 += 1;
                self.repeated.1.get_or_insert(s.line);
            } else if step < 0.0 {
                self.backward.0 += 1;
                self.backward.1.get_or_insert(s.line);
            }
        }
        self.last = s.t;
        for a in 0..3 {
            self.min[a] = self.min[a].min(s.accel[a]);
            self.max[a] = self.max[a].max(s.accel[a]);
        }
        if let Some(g) = s.gyro {
            for a in 0..3 {
                self.gyro_min[a] = self.gyro_min[a].min(g[a]);
                self.gyro_max[a] = self.gyro_max[a].max(g[a]);
            }
        }
        self.rates.push(s.t);
        self.norms.push(norm(&s.raw));
        if let Some(c) = s.temperature {
            self.has_temperature = true;
            self.temperature.push(c);
        }
    }
}

/// [`sample_interval`] from the stamps as they pass: the first 513 kept (below that the windows
/// are shorter than 64 and the stamps are few), then one windowed rate per 64 samples.
pub(super) struct Rates {
    pub(super) head: Vec<f64>,
    pub(super) n: usize,
    /// The stamp at the last multiple of [`WINDOW`].
    pub(super) anchor: f64,
    pub(super) kth: Kth,
}

impl Rates {
    pub(super) fn new() -> Rates {
        Rates {
            head: Vec::new(),
            n: 0,
            anchor: f64::NAN,
            kth: Kth::new(),
        }
    }

    pub(super) fn push(&mut self, t: f64) {
        if self.head.len() <= 8 * WINDOW {
            self.head.push(t);
        }
        if self.n.is_multiple_of(WINDOW) {
            if self.n > 0 {
                self.kth.push((t - self.anchor) / WINDOW as f64);
            }
            self.anchor = t;
        }
        self.n += 1;
    }

    /// The sampling interval, rereading the stamps as the median search needs.
    pub(super) fn resolve(&mut self, src: &Reading, shape: &mut Option<Shape>) -> Result<f64, Declined> {
        if self.n <= 8 * WINDOW {
            return Ok(sample_interval(&self.head));
        }
        let rank = ((self.n - 1) / WINDOW / 2) as u64;
        let (mut anchor, kth) = (f64::NAN, &mut self.kth);
        loop {
            if let Some(v) = kth.end_pass(rank) {
                return Ok(v);
            }
            src.each(shape, |i, s| {
                if i.is_multiple_of(WINDOW) {
                    if i > 0 {
                        kth.push((s.t - anchor) / WINDOW as f64);
                    }
                    anchor = s.t;
                }
            })?;
        }
    }
}
