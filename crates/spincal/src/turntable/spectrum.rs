//! Rotation rate from the spectrum: the turntable shows up as a line at f = ω / 2π on x and y.
//!
//! Each horizontal axis is detrended and Hann-windowed; their power spectra (real FFT, zero-padded
//! to a power of two at least twice the length) are summed; the highest line in the allowed band
//! is refined below one bin by maximising the windowed DTFT power directly (Newton on its
//! derivatives). Long recordings are searched in segments, so memory stays bounded.

use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};

use crate::input::recording::{sample_interval, Recording};
use crate::optim::golden_section_max;

/// Most golden-section steps of the fallback refinement (its 1e-12 tolerance ends it first).
const GOLDEN_STEPS: usize = 80;

/// Where to look for the rotation line.
#[derive(Debug, Clone, Copy)]
pub struct RateSearch {
    pub min_rpm: f64,
    pub max_rpm: f64,
}

impl Default for RateSearch {
    /// 5–600 rpm: record players (16⅔–78 rpm) and ordinary rate tables.
    fn default() -> Self {
        RateSearch {
            min_rpm: 5.0,
            max_rpm: 600.0,
        }
    }
}

/// A rotation-rate estimate and the spectrum it came from (for plots).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RateEstimate {
    pub frequency_hz: f64,
    pub rpm: f64,
    pub omega_radps: f64,
    /// Peak power over the median power in the search band (a detection margin).
    pub peak_to_median: f64,
    /// One-sided summed x+y power spectrum from 0 to `SPECTRUM_KEPT_HARMONICS` × the rotation
    /// frequency: frequencies, Hz… (kept in memory for plots, not written to JSON)
    #[serde(skip)]
    pub spectrum_hz: Vec<f64>,
    /// …and power (arbitrary units, window-normalised).
    #[serde(skip)]
    pub spectrum_power: Vec<f64>,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SpectrumError {
    #[error("{file}: {samples} samples are too few for a spectrum (need at least 64)")]
    TooShort { file: String, samples: usize },
    #[error("{file}: the band {min_rpm}–{max_rpm} rpm holds no spectral bin (duration {duration_s:.1} s, sample rate {rate_hz:.1} Hz)")]
    EmptyBand {
        file: String,
        min_rpm: f64,
        max_rpm: f64,
        duration_s: f64,
        rate_hz: f64,
    },
}

/// How far up the spectrum a [`RateEstimate`] keeps, in multiples of the rotation frequency.
pub(crate) const SPECTRUM_KEPT_HARMONICS: f64 = 8.0;

/// Recordings up to this many samples get one FFT of the whole (about 90 bytes per sample beside
/// the recording); longer ones are searched in segments of this length (see
/// [`estimate_rotation_rate`]). 2²⁰ samples are 2.9 h at 100 Hz.
pub(crate) const WHOLE_SPECTRUM_SAMPLES: usize = 1 << 20;

/// Estimates the rotation rate of a recording from its x and y axes.
///
/// Up to `WHOLE_SPECTRUM_SAMPLES` samples, the x and y power spectra of the whole recording are
/// summed and the highest line in the band is refined on the recording's DTFT. A longer recording
/// would need several times its own memory for that FFT, so its spectrum is the sum over
/// segments of that length (Bartlett's average: the same line, finer detection statistics, coarser
/// bins), the line is refined on the first segment's DTFT, then on prefixes four times longer in
/// turn up to the whole recording, each searched ±4 of its own bins around the last estimate. Both
/// end on the same maximum of the whole recording's DTFT; the long route holds one Hann window of
/// the recording's length (8 bytes per sample) at most.
pub fn estimate_rotation_rate(
    recording: &Recording,
    search: RateSearch,
) -> Result<RateEstimate, SpectrumError> {
    estimate_rotation_rate_in_segments(recording, search, WHOLE_SPECTRUM_SAMPLES)
}

/// [`estimate_rotation_rate`] with the segment length given (tests use short ones).
#[doc(hidden)]
pub(crate) fn estimate_rotation_rate_in_segments(
    recording: &Recording,
    search: RateSearch,
    segment: usize,
) -> Result<RateEstimate, SpectrumError> {
    let n = recording.len();
    if n < 64 {
        return Err(SpectrumError::TooShort {
            file: recording.source.name.clone(),
            samples: n,
        });
    }
    let dt = sample_interval(&recording.time_s);
    let rate_hz = 1.0 / dt;
    let segment = if n <= segment.max(64) { n } else { segment.max(64) };
    let segments = n / segment;
    let padded = (2 * segment).next_power_of_two();
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(padded);
    let mut input = fft.make_input_vec();
    let mut output = fft.make_output_vec();
    let mut power = vec![0.0; output.len()];
    let mut first_prepared = Vec::new();
    // One window for every segment (and both axes), and its power.
    let window: Vec<f64> = (0..segment).map(|i| hann(i, segment)).collect();
    let norm = window.iter().map(|w| w * w).sum::<f64>();
    for k in 0..segments {
        let range = k * segment..(k + 1) * segment;
        let prepared = prepare(&recording.accel_mps2[..2], range, &window);
        for axis in &prepared {
            input[..segment].copy_from_slice(axis);
            input[segment..].iter_mut().for_each(|v| *v = 0.0);
            fft.process(&mut input, &mut output)
                .expect("buffer sizes come from the planner");
            for (p, c) in power.iter_mut().zip(&output) {
                *p += c.norm_sqr() / norm;
            }
        }
        if k == 0 {
            first_prepared = prepared;
        }
    }
    drop(input);
    drop(output);
    let bin_hz = rate_hz / padded as f64;
    let lo = (search.min_rpm / 60.0 / bin_hz).ceil() as usize;
    let hi = ((search.max_rpm / 60.0 / bin_hz).floor() as usize).min(power.len().saturating_sub(2));
    if lo < 1 || lo > hi {
        return Err(SpectrumError::EmptyBand {
            file: recording.source.name.clone(),
            min_rpm: search.min_rpm,
            max_rpm: search.max_rpm,
            duration_s: recording.duration_s(),
            rate_hz,
        });
    }
    let peak = (lo..=hi)
        .max_by(|&a, &b| power[a].total_cmp(&power[b]))
        .expect("non-empty band");
    let mut band: Vec<f64> = power[lo..=hi].to_vec();
    let mid = band.len() / 2;
    let median = *band.select_nth_unstable_by(mid, f64::total_cmp).1;
    drop(band);

    // The padded bins are a fine grid of the same DTFT; refine between the neighbours exactly.
    let time_s = &recording.time_s[..segment];
    let t0 = time_s[0];
    let axes = [&first_prepared[0][..], &first_prepared[1][..]];
    let sample = |i: usize| [axes[0][i], axes[1][i]];
    let mut frequency_hz = refine_peak(time_s, t0, &sample, peak as f64 * bin_hz, bin_hz);
    drop(first_prepared);
    let mut length = segment;
    while length < n {
        length = (4 * length).min(n);
        frequency_hz = refine_on_prefix(recording, length, frequency_hz, rate_hz / (2 * length) as f64);
    }
    let peak_to_median = power[peak] / median.max(f64::MIN_POSITIVE);
    // Kept for plots up to a few harmonics only: the whole padded spectrum of a day-long
    // recording would outweigh the recording itself.
    let kept = ((SPECTRUM_KEPT_HARMONICS * frequency_hz / bin_hz).ceil() as usize + 1).clamp(2, power.len());
    power.truncate(kept);
    power.shrink_to_fit();
    Ok(RateEstimate {
        frequency_hz,
        rpm: frequency_hz * 60.0,
        omega_radps: 2.0 * std::f64::consts::PI * frequency_hz,
        peak_to_median,
        spectrum_hz: (0..kept).map(|k| k as f64 * bin_hz).collect(),
        spectrum_power: power,
    })
}

/// The Hann window of length `n` at sample `i`.
fn hann(i: usize, n: usize) -> f64 {
    0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos()
}

/// The axes over `range`, each detrended and multiplied by `window` (as long as the range).
fn prepare(axes: &[Vec<f64>], range: std::ops::Range<usize>, window: &[f64]) -> Vec<Vec<f64>> {
    axes.iter()
        .map(|axis| {
            let mut x = detrend(&axis[range.clone()]);
            x.iter_mut().zip(window).for_each(|(v, w)| *v *= w);
            x
        })
        .collect()
}

/// The maximum of the x+y DTFT power of `sample` (both axes' prepared values at a sample index)
/// over `time_s`, from `start` within ± `bin_hz`: Newton on the power's derivatives (one pass
/// each, a few passes), or golden section over the same bracket when Newton leaves it or meets a
/// convex stretch.
fn refine_peak(time_s: &[f64], t0: f64, sample: &impl Fn(usize) -> [f64; 2], start: f64, bin_hz: f64) -> f64 {
    let derivatives = |f: f64| dtft_power_derivatives(sample, time_s, t0, f);
    newton_max(derivatives, start, start - bin_hz, start + bin_hz).unwrap_or_else(|| {
        golden_section_max(|f| derivatives(f).0, start - bin_hz, start + bin_hz, GOLDEN_STEPS)
    })
}

/// One step of the long route: the DTFT peak of the first `length` samples (detrended and
/// Hann-windowed over that length, computed as they are read) near `previous`: the best of a grid
/// of ±4 bins, then refined within a bin of it.
fn refine_on_prefix(recording: &Recording, length: usize, previous: f64, bin_hz: f64) -> f64 {
    let time_s = &recording.time_s[..length];
    let window: Vec<f64> = (0..length).map(|i| hann(i, length)).collect();
    let [line_x, line_y] = [0, 1].map(|a| Line::fit(&recording.accel_mps2[a][..length]));
    let (x, y) = (&recording.accel_mps2[0], &recording.accel_mps2[1]);
    let sample = |i: usize| {
        [
            line_x.residual(x[i], i) * window[i],
            line_y.residual(y[i], i) * window[i],
        ]
    };
    let t0 = time_s[0];
    let power = |f: f64| dtft_power_derivatives(&sample, time_s, t0, f).0;
    let best = (-4..=4)
        .map(|k| previous + k as f64 * bin_hz)
        .map(|f| (f, power(f)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .expect("nine candidates")
        .0;
    refine_peak(time_s, t0, &sample, best, bin_hz)
}

/// The least-squares straight line through samples against their index.
struct Line {
    mean_i: f64,
    mean_x: f64,
    slope: f64,
}

impl Line {
    fn fit(x: &[f64]) -> Line {
        let n = x.len() as f64;
        let mean_i = (n - 1.0) / 2.0;
        let mean_x = x.iter().sum::<f64>() / n;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (i, v) in x.iter().enumerate() {
            let di = i as f64 - mean_i;
            sxy += di * (v - mean_x);
            sxx += di * di;
        }
        Line {
            mean_i,
            mean_x,
            slope: sxy / sxx,
        }
    }

    /// `v` at index `i` less the line.
    #[inline(always)]
    fn residual(&self, v: f64, i: usize) -> f64 {
        v - self.mean_x - self.slope * (i as f64 - self.mean_i)
    }
}

/// Removes the least-squares straight line (drift would otherwise leak into low bins).
fn detrend(x: &[f64]) -> Vec<f64> {
    let line = Line::fit(x);
    x.iter().enumerate().map(|(i, v)| line.residual(*v, i)).collect()
}

/// The summed x+y DTFT power of `sample` at `f` (Hz) and its first two derivatives in f.
fn dtft_power_derivatives(
    sample: &impl Fn(usize) -> [f64; 2],
    time_s: &[f64],
    t0: f64,
    f: f64,
) -> (f64, f64, f64) {
    let tau = 2.0 * std::f64::consts::PI;
    // Per axis, S_k = Σ x tᵏ e^{−jωt}: X = S₀, dX/dω = −j S₁, d²X/dω² = −S₂.
    let mut sums = [[[0.0f64; 2]; 3]; 2];
    crate::turntable::model::for_each_rotation(time_s, t0, tau * f, 0.0, |i, sin, cos| {
        let t = time_s[i] - t0;
        for (s, x) in sums.iter_mut().zip(sample(i)) {
            let xt = x * t;
            let xtt = xt * t;
            s[0][0] += x * cos;
            s[0][1] -= x * sin;
            s[1][0] += xt * cos;
            s[1][1] -= xt * sin;
            s[2][0] += xtt * cos;
            s[2][1] -= xtt * sin;
        }
    });
    let (mut p, mut dp, mut ddp) = (0.0, 0.0, 0.0);
    for [[re0, im0], [re1, im1], [re2, im2]] in sums {
        p += re0 * re0 + im0 * im0;
        // In ω: P′ = 2 Re(X̄ · (−j S₁)), P″ = 2 (|S₁|² − Re(X̄ S₂)); in f, times 2π and (2π)².
        dp += tau * 2.0 * (re0 * im1 - im0 * re1);
        ddp += tau * tau * 2.0 * (re1 * re1 + im1 * im1 - (re0 * re2 + im0 * im2));
    }
    (p, dp, ddp)
}

/// Newton's method for the maximum of a smooth function from `start` inside [lo, hi], given its
/// value and first two derivatives; `None` when a step meets a convex point or leaves the bracket.
fn newton_max(derivatives: impl Fn(f64) -> (f64, f64, f64), start: f64, lo: f64, hi: f64) -> Option<f64> {
    let mut f = start;
    for _ in 0..30 {
        let (_, d1, d2) = derivatives(f);
        if !(d2 < 0.0 && d1.is_finite()) {
            return None;
        }
        let step = -d1 / d2;
        f += step;
        if !(lo..=hi).contains(&f) {
            return None;
        }
        if step.abs() <= 1e-13 * f.abs() {
            return Some(f);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::recording::Source;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// Newton on the DTFT's derivatives lands where golden section does (on its flat top, to
    /// its tolerance), and both on the frequency of a clean windowed sinusoid.
    #[test]
    fn newton_and_golden_section_find_the_same_dtft_peak() {
        let (rate, n, f_true) = (100.0, 6000, 0.555_555);
        let time_s: Vec<f64> = (0..n).map(|i| 3.0 + i as f64 / rate).collect();
        let axes: Vec<Vec<f64>> = [0.3, 1.4]
            .iter()
            .map(|phase| {
                (0..n)
                    .map(|i| (std::f64::consts::TAU * f_true * time_s[i] + phase).sin() * hann(i, n))
                    .collect()
            })
            .collect();
        let sample = |i: usize| [axes[0][i], axes[1][i]];
        let t0 = time_s[0];
        let bin = rate / (2 * n).next_power_of_two() as f64;
        let start = (f_true / bin).round() * bin;
        let newton = newton_max(
            |f| dtft_power_derivatives(&sample, &time_s, t0, f),
            start,
            start - bin,
            start + bin,
        )
        .expect("Newton converges from the nearest bin");
        let golden = golden_section_max(
            |f| dtft_power_derivatives(&sample, &time_s, t0, f).0,
            start - bin,
            start + bin,
            GOLDEN_STEPS,
        );
        assert!((newton / f_true - 1.0).abs() < 1e-6, "{newton} vs {f_true}");
        assert!((newton / golden - 1.0).abs() < 1e-9, "{newton} vs {golden}");
    }

    /// A noisy, drifting turntable-like recording: x and y a quarter turn apart.
    fn rotating(n: usize, f_hz: f64, noise: f64, seed: u64) -> Recording {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, noise).unwrap();
        let time_s: Vec<f64> = (0..n).map(|i| 12.5 + i as f64 / 100.0).collect();
        let axis = |phase: f64, rng: &mut rand_chacha::ChaCha8Rng| -> Vec<f64> {
            time_s
                .iter()
                .map(|t| {
                    0.4 * (std::f64::consts::TAU * f_hz * t + phase).sin()
                        + 0.3
                        + 1e-4 * t
                        + normal.sample(rng)
                })
                .collect()
        };
        let x = axis(0.0, &mut rng);
        let y = axis(std::f64::consts::FRAC_PI_2, &mut rng);
        let z = vec![9.8; n];
        Recording {
            time_s,
            accel_mps2: [x, y, z],
            gyro_radps: None,
            temperature_c: None,
            source: Source {
                name: "rotating".into(),
                format: "test".into(),
                columns: vec![],
                metadata: vec![],
                lines: vec![],
                incomplete_rows: Default::default(),
                time_notes: Vec::new(),
            },
        }
    }

    /// The segmented route (Bartlett spectrum, then prefixes four times longer) ends on the same
    /// DTFT maximum as one FFT of the whole recording, over several seeds and segment lengths
    /// (one of which leaves a tail shorter than a segment).
    #[test]
    fn segments_find_the_whole_recordings_peak() {
        for seed in 0..4 {
            let f_true = 0.5 + 0.07 * seed as f64;
            let rec = rotating(40_000, f_true, 0.05, seed);
            let whole = estimate_rotation_rate(&rec, RateSearch::default()).unwrap();
            assert!((whole.frequency_hz / f_true - 1.0).abs() < 1e-5);
            for segment in [2048, 3000, 9999] {
                let parts = estimate_rotation_rate_in_segments(&rec, RateSearch::default(), segment).unwrap();
                let gap = (parts.frequency_hz / whole.frequency_hz - 1.0).abs();
                assert!(
                    gap < 1e-10,
                    "seed {seed}, segment {segment}: {} vs {}",
                    parts.frequency_hz,
                    whole.frequency_hz
                );
                assert!(parts.peak_to_median > 100.0, "{}", parts.peak_to_median);
                assert!(parts.spectrum_hz.len() < whole.spectrum_hz.len());
            }
        }
    }
}
