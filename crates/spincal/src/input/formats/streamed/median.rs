//! Exact medians and distinct counts over passes: values kept while few, else narrowed by a
//! histogram on their order key and the file read again.

use std::collections::BTreeSet;

use super::reading::{Reading, Sample};
use super::{Declined, KEEP, KEEP_DISTINCT};
use crate::input::inspect::TemperatureSummary;

/// The order key of `f64::total_cmp`.
pub(super) fn key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

pub(super) fn unkey(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// The k-th smallest of values given once per pass, in `total_cmp` order, in bounded memory (see
/// the module documentation).
pub(super) struct Kth {
    /// Values in play have these top `16 · level` bits of their key.
    pub(super) prefix: u64,
    pub(super) level: u32,
    /// The rank within the values in play, once known.
    pub(super) rank: Option<u64>,
    pub(super) kept: Vec<f64>,
    pub(super) count: u64,
    pub(super) histogram: Vec<u64>,
}

impl Kth {
    pub(super) fn new() -> Kth {
        Kth {
            prefix: 0,
            level: 0,
            rank: None,
            kept: Vec::new(),
            count: 0,
            histogram: vec![0; 1 << 16],
        }
    }

    pub(super) fn push(&mut self, x: f64) {
        let k = key(x);
        if self.level > 0 && k >> (64 - 16 * self.level) != self.prefix {
            return;
        }
        if self.kept.len() < KEEP {
            self.kept.push(x);
        }
        self.count += 1;
        self.histogram[((k >> (48 - 16 * self.level)) & 0xffff) as usize] += 1;
    }

    /// After a pass: the value (with `rank` the rank among all values, used on the first call),
    /// or `None` when the values must be given again.
    pub(super) fn end_pass(&mut self, rank: u64) -> Option<f64> {
        let rank = *self.rank.get_or_insert(rank);
        if self.count == 0 {
            return Some(f64::NAN);
        }
        if self.count as usize <= KEEP {
            let kept = &mut self.kept;
            return Some(*kept.select_nth_unstable_by(rank as usize, f64::total_cmp).1);
        }
        let mut below = 0;
        for (bucket, &c) in self.histogram.iter().enumerate() {
            if below + c > rank {
                self.prefix = self.prefix << 16 | bucket as u64;
                self.level += 1;
                self.rank = Some(rank - below);
                if self.level == 4 {
                    return Some(unkey(self.prefix));
                }
                self.kept.clear();
                self.count = 0;
                self.histogram.iter_mut().for_each(|c| *c = 0);
                return None;
            }
            below += c;
        }
        Some(f64::NAN)
    }

    /// The value of `rank`, rereading with `value` of each sample as needed.
    pub(super) fn resolve(
        &mut self,
        rank: u64,
        src: &Reading,
        value: impl Fn(&Sample) -> f64,
    ) -> Result<f64, Declined> {
        loop {
            if let Some(v) = self.end_pass(rank) {
                return Ok(v);
            }
            src.each(&mut None, |_, s| self.push(value(s)))?;
        }
    }
}

/// The distinct temperatures, as [`crate::input::inspect::temperature_summary`] counts them
/// (sorted by `total_cmp`, equal values merged: −0 and +0 are one value, −0 when both occur), at
/// most [`KEEP_DISTINCT`] per pass.
pub(super) struct Distinct {
    /// Keys at or below this were counted on earlier passes.
    pub(super) floor: Option<u64>,
    pub(super) set: BTreeSet<u64>,
    pub(super) full: bool,
    pub(super) count: usize,
    pub(super) min: Option<f64>,
    pub(super) max: f64,
    pub(super) previous: Option<f64>,
    pub(super) resolution: f64,
    pub(super) negative_zero: bool,
}

impl Distinct {
    pub(super) fn new() -> Distinct {
        Distinct {
            floor: None,
            set: BTreeSet::new(),
            full: false,
            count: 0,
            min: None,
            max: f64::NAN,
            previous: None,
            resolution: f64::INFINITY,
            negative_zero: false,
        }
    }

    pub(super) fn push(&mut self, c: f64) {
        let c = if c == 0.0 {
            self.negative_zero |= c.is_sign_negative();
            0.0
        } else {
            c
        };
        let k = key(c);
        if self.floor.is_some_and(|f| k <= f) {
            return;
        }
        if self.set.len() < KEEP_DISTINCT {
            self.set.insert(k);
        } else if self.set.last().is_some_and(|&last| k < last) && self.set.insert(k) {
            self.set.pop_last();
            self.full = true;
        } else if self.set.last().is_some_and(|&last| k > last) {
            self.full = true;
        }
    }

    pub(super) fn resolve(&mut self, src: &Reading) -> Result<Option<TemperatureSummary>, Declined> {
        loop {
            for &k in &self.set {
                let v = unkey(k);
                if let Some(p) = self.previous {
                    self.resolution = self.resolution.min(v - p);
                }
                self.previous = Some(v);
                self.min.get_or_insert(v);
                self.max = v;
                self.count += 1;
            }
            if !self.full {
                break;
            }
            self.floor = self.set.last().copied();
            self.set.clear();
            self.full = false;
            src.each(&mut None, |_, s| {
                if let Some(c) = s.temperature {
                    self.push(c);
                }
            })?;
        }
        let zero = |v: f64| if v == 0.0 && self.negative_zero { -0.0 } else { v };
        Ok(self.min.map(|min| TemperatureSummary {
            min_c: zero(min),
            max_c: zero(self.max),
            resolution_c: if self.resolution.is_finite() {
                self.resolution
            } else {
                0.0
            },
            distinct_values: self.count,
        }))
    }
}
