//! The first look at each recording: its rotation rate, a sinusoid fit for starting values, and
//! its inspection.

use faer::{Mat, Side};

use super::options::{FitError, FitOptions};
use crate::input::inspect::Inspection;
use crate::input::recording::Recording;
use crate::turntable::model::Direction;
use crate::turntable::spectrum::{estimate_rotation_rate, RateEstimate, RateSearch};

/// Starting values for one recording from a linear fit of mean + sine + cosine (+ slope) at ω.
pub(super) struct SinusoidFit {
    pub(super) mean: [f64; 3],
    pub(super) sin: [f64; 3],
    pub(super) cos: [f64; 3],
    pub(super) noise: [f64; 3],
}

pub(super) fn sinusoid_fit(rec: &Recording, omega: f64) -> SinusoidFit {
    let t0 = rec.time_s[0];
    let t_mid = 0.5 * (t0 + rec.time_s[rec.len() - 1]);
    let mut out = SinusoidFit {
        mean: [0.0; 3],
        sin: [0.0; 3],
        cos: [0.0; 3],
        noise: [0.0; 3],
    };
    // Columns 1, sin, cos, t − t_mid: solve the 4×4 normal equations (well conditioned here).
    for a in 0..3 {
        let y = &rec.accel_mps2[a];
        let mut ata = Mat::<f64>::zeros(4, 4);
        let mut aty = Mat::<f64>::zeros(4, 1);
        crate::turntable::model::for_each_rotation(&rec.time_s, t0, omega, 0.0, |i, s, c| {
            let row = [1.0, s, c, rec.time_s[i] - t_mid];
            for p in 0..4 {
                aty[(p, 0)] += row[p] * y[i];
                for q in 0..4 {
                    ata[(p, q)] += row[p] * row[q];
                }
            }
        });
        let coef = match ata.llt(Side::Lower) {
            Ok(llt) => faer::prelude::Solve::solve(&llt, &aty),
            Err(_) => Mat::zeros(4, 1),
        };
        let mut sse = 0.0;
        crate::turntable::model::for_each_rotation(&rec.time_s, t0, omega, 0.0, |i, s, c| {
            let m =
                coef[(0, 0)] + coef[(1, 0)] * s + coef[(2, 0)] * c + coef[(3, 0)] * (rec.time_s[i] - t_mid);
            sse += (y[i] - m) * (y[i] - m);
        });
        out.mean[a] = coef[(0, 0)];
        out.sin[a] = coef[(1, 0)];
        out.cos[a] = coef[(2, 0)];
        out.noise[a] = (sse / (rec.len() as f64 - 4.0)).sqrt().max(1e-6);
    }
    out
}

pub(super) fn wrap_angle(x: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut y = x.rem_euclid(two_pi);
    if y > std::f64::consts::PI {
        y -= two_pi;
    }
    y
}

/// A turntable's line stands far above the spectrum's median (hundreds of times in real
/// recordings); below this the data hold no rotation.
pub(super) const MIN_PEAK_TO_MEDIAN: f64 = 8.0;

/// What one recording shows before any fit.
pub(super) struct FirstLook {
    pub(super) rate: RateEstimate,
    pub(super) start: SinusoidFit,
    pub(super) inspection: Inspection,
    pub(super) direction: Direction,
}

/// The rotation rate from the spectrum (at least three turns are needed), a sinusoid fit at that
/// rate for the starting values, and the sense of rotation. A constant axis in the objective, or
/// a spectrum without a clear peak, is refused: there is no rotation to fit.
pub(super) fn first_look(
    rec: &Recording,
    inspection: Inspection,
    options: &FitOptions,
) -> Result<FirstLook, FitError> {
    let search = match options.rpm_hint {
        Some(rpm) => RateSearch {
            min_rpm: 0.9 * rpm,
            max_rpm: 1.1 * rpm,
        },
        None => RateSearch::default(),
    };
    if let Some(advice) = crate::input::inspect::time_advice(rec) {
        return Err(FitError::Time {
            file: rec.source.name.clone(),
            advice,
        });
    }
    let rate = estimate_rotation_rate(rec, search)?;
    if let Some(axis) = inspection
        .constant_axes
        .iter()
        .find(|a| options.axes.axes().contains(&(**a as usize - 'x' as usize)))
    {
        return Err(FitError::ConstantAxis {
            file: rec.source.name.clone(),
            axis: *axis,
        });
    }
    let rotations = rec.duration_s() * rate.frequency_hz;
    // A line with fewer than 2 cycles in the window is not resolved: its frequency, and so the
    // rotation count, is not measured. Say so rather than give the count.
    // Three turns at the slowest record speed, 16⅔ rpm, take 10.8 s: a longer recording with no
    // resolved line is not turning (below), not short.
    if rotations < 2.0 && rec.duration_s() < 3.0 * 60.0 / (50.0 / 3.0) && options.rpm_hint.is_none() {
        return Err(FitError::TooShortToMeasure {
            file: rec.source.name.clone(),
            duration_s: rec.duration_s(),
        });
    }
    if (2.0..3.0).contains(&rotations) || (rotations < 3.0 && options.rpm_hint.is_some()) {
        return Err(FitError::TooFewRotations {
            file: rec.source.name.clone(),
            basis: if options.rpm_hint.is_some() {
                "the rate found within 10 % of the rpm given"
            } else {
                "measured"
            },
            rotations,
            rpm: rate.rpm,
            duration_s: rec.duration_s(),
        });
    }
    if rotations < 2.0 || rate.peak_to_median.is_nan() || rate.peak_to_median < MIN_PEAK_TO_MEDIAN {
        return Err(FitError::NoRotation {
            file: rec.source.name.clone(),
            peak_to_median: rate.peak_to_median,
            rpm: rate.rpm,
            advice: crate::input::inspect::repeated_stamps_advice(rec)
                .unwrap_or_else(|| "was the turntable turning?".to_string()),
        });
    }
    let start = sinusoid_fit(rec, rate.omega_radps);
    // Sense of rotation: y leads x by a quarter turn for s = +1 (see the model's equations).
    let direction = Direction::from_sign(start.cos[1] * start.sin[0] - start.sin[1] * start.cos[0]);
    Ok(FirstLook {
        rate,
        start,
        inspection,
        direction,
    })
}
