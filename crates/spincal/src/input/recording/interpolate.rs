//! A second sensor's samples interpolated onto a recording's times: one rule for a phone's
//! accelerometer/gyro pair, a gyro file merged on time and `correct`'s stream (which holds only
//! the two samples around the current time).
//!
//! A gyro file sampled beside the recording (its k-th sample within half an interval of the
//! k-th target) is taken sample for sample, not interpolated: interpolating between samples
//! smooths their noise (the T265's gyro noise density read 53 % off allantools' that way).
//! [`Bracket::beside`] decides that target by target, in order, so a file read whole and
//! `correct`'s stream take the same values: the k-th sample is given while every pair so far
//! lies within the tolerance, and from the first pair that does not, the rest is interpolated.

/// Why a target time has no interpolated value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Uncovered {
    /// Before the source's first sample (never extrapolated).
    Before { first_s: f64 },
    /// After the source's last sample.
    After { last_s: f64 },
    /// Between two source samples further apart than the widest interval (a dropped stretch).
    Gap { from_s: f64, to_s: f64 },
    /// The source has fewer than two samples.
    Empty,
}

impl std::fmt::Display for Uncovered {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Uncovered::Before { first_s } => write!(f, "before the gyro's first sample ({first_s} s)"),
            Uncovered::After { last_s } => write!(f, "after the gyro's last sample ({last_s} s)"),
            Uncovered::Gap { from_s, to_s } => {
                write!(f, "in a gap of the gyro ({from_s} – {to_s} s)")
            }
            Uncovered::Empty => write!(f, "the gyro has fewer than two samples"),
        }
    }
}

/// The two source samples around the latest target time, fed in time order: a source
/// interpolated linearly at increasing target times in constant memory.
#[derive(Debug, Clone)]
pub struct Bracket {
    widest_s: f64,
    before: Option<(f64, [f64; 3])>,
    after: Option<(f64, [f64; 3])>,
    first_s: Option<f64>,
    /// The source has no more samples.
    ended: bool,
    /// Sample for sample while each pair lies within this, s (`None`: interpolated).
    beside_s: Option<f64>,
    /// Targets given their sample as it is.
    paired: usize,
}

impl Bracket {
    /// Two source samples more than `widest_s` apart leave the targets between them uncovered.
    pub fn new(widest_s: f64) -> Bracket {
        Bracket {
            widest_s,
            before: None,
            after: None,
            first_s: None,
            ended: false,
            beside_s: None,
            paired: 0,
        }
    }

    /// A source that may be sampled beside the targets: the k-th target takes the k-th sample
    /// as it is while every pair so far lies within `tolerance_s` (half an interval); from the
    /// first pair that does not, the targets are interpolated.
    pub fn beside(mut self, tolerance_s: f64) -> Bracket {
        self.beside_s = Some(tolerance_s).filter(|t| t.is_finite() && *t > 0.0);
        self
    }

    /// How many targets so far took a sample as it is ([`Bracket::beside`]).
    pub fn paired(&self) -> usize {
        self.paired
    }

    /// The source at `t` (targets increase from call to call), pulling source samples from
    /// `next` (time order; `None` at its end) until one is at or after `t`.
    pub fn at<E>(
        &mut self,
        t: f64,
        mut next: impl FnMut() -> Result<Option<(f64, [f64; 3])>, E>,
    ) -> Result<Result<[f64; 3], Uncovered>, E> {
        if let Some(tolerance) = self.beside_s {
            // One source sample per target while they pair; the bracket moves with them, so the
            // interpolation that follows a broken pair starts from the samples already taken.
            match next()? {
                Some(sample) => {
                    self.first_s.get_or_insert(sample.0);
                    self.before = self.after.take();
                    self.after = Some(sample);
                    if (sample.0 - t).abs() <= tolerance {
                        self.paired += 1;
                        return Ok(Ok(sample.1));
                    }
                }
                None => self.ended = true,
            }
            self.beside_s = None;
        }
        // The bracket moves forward while it lacks two samples or its later one is before `t`;
        // at the source's end the last pair stays.
        while !self.ended && (self.before.is_none() || self.after.is_none_or(|(t1, _)| t1 < t)) {
            match next()? {
                Some(sample) => {
                    self.first_s.get_or_insert(sample.0);
                    self.before = self.after.take();
                    self.after = Some(sample);
                }
                None => self.ended = true,
            }
        }
        let (Some((t0, v0)), Some((t1, v1))) = (self.before, self.after) else {
            return Ok(Err(Uncovered::Empty));
        };
        let first_s = self.first_s.unwrap_or(t0);
        if t < first_s {
            return Ok(Err(Uncovered::Before { first_s }));
        }
        if t > t1 {
            return Ok(Err(Uncovered::After { last_s: t1 }));
        }
        if t1 - t0 > self.widest_s {
            return Ok(Err(Uncovered::Gap { from_s: t0, to_s: t1 }));
        }
        if t == t1 {
            // A target on a source sample takes it exactly (no rounding through the weight).
            return Ok(Ok(v1));
        }
        let w = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 };
        Ok(Ok(std::array::from_fn(|a| v0[a] + w * (v1[a] - v0[a]))))
    }
}

/// `source` (three axes at `source_time`) at each of `target_time`, linearly interpolated between
/// the two source samples around it, and which targets have a value: none before the first or
/// after the last source sample (never extrapolated), none where the two around it are more than
/// `widest_s` apart (a dropped stretch, not jitter). Both times increase. The rule of [`Bracket`].
pub fn interpolate_onto(
    target_time: &[f64],
    source_time: &[f64],
    source: &[Vec<f64>; 3],
    widest_s: f64,
) -> (Vec<bool>, [Vec<f64>; 3]) {
    let (keep, out, _) = merge_onto(target_time, source_time, source, Bracket::new(widest_s));
    (keep, out)
}

/// [`interpolate_onto`] by a given `bracket` (one made [`Bracket::beside`] takes a source
/// sampled beside the targets sample for sample), and how many targets took a sample as it is.
pub fn merge_onto(
    target_time: &[f64],
    source_time: &[f64],
    source: &[Vec<f64>; 3],
    mut bracket: Bracket,
) -> (Vec<bool>, [Vec<f64>; 3], usize) {
    let n = target_time.len();
    let mut keep = vec![false; n];
    let mut out: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
    let mut j = 0;
    let mut next = || -> Result<_, std::convert::Infallible> {
        let sample = source_time
            .get(j)
            .map(|&t| (t, std::array::from_fn(|a| source[a][j])));
        j += 1;
        Ok(sample)
    };
    for (i, &t) in target_time.iter().enumerate() {
        let Ok(value) = bracket.at(t, &mut next);
        if let Ok(v) = value {
            for a in 0..3 {
                out[a][i] = v[a];
            }
            keep[i] = true;
        }
    }
    (keep, out, bracket.paired())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bracket's values against the direct rule: before, inside, in a gap, after.
    #[test]
    fn targets_are_covered_inside_the_span_and_outside_its_gaps() {
        let source_time = [1.0, 2.0, 3.0, 10.0, 11.0];
        let source = [
            source_time.to_vec(),
            source_time.iter().map(|t| 2.0 * t).collect(),
            vec![0.0; 5],
        ];
        let targets = [0.5, 1.0, 1.5, 3.0, 5.0, 10.5, 11.0, 12.0];
        let (keep, out) = interpolate_onto(&targets, &source_time, &source, 2.0);
        assert_eq!(keep, [false, true, true, true, false, true, true, false]);
        for (i, &t) in targets.iter().enumerate().filter(|(i, _)| keep[*i]) {
            assert_eq!((out[0][i], out[1][i]), (t, 2.0 * t));
        }
        let mut b = Bracket::new(2.0);
        let mut k = 0;
        let mut next = || -> Result<_, ()> {
            k += 1;
            Ok(source_time.get(k - 1).map(|&t| (t, [t, 2.0 * t, 0.0])))
        };
        assert_eq!(b.at(0.5, &mut next), Ok(Err(Uncovered::Before { first_s: 1.0 })));
        assert_eq!(
            b.at(5.0, &mut next),
            Ok(Err(Uncovered::Gap {
                from_s: 3.0,
                to_s: 10.0
            }))
        );
        assert_eq!(b.at(12.0, &mut next), Ok(Err(Uncovered::After { last_s: 11.0 })));
    }
}
