//! Goodness of fit (SPEC §4): MATLAB's normalised RMSE fit and plain RMSE; Student's t quantiles
//! for the tests the fleet screen and the held-out verdicts make.

/// `100 · (1 − ‖y − ŷ‖ / ‖y − mean(y)‖)`: 100 is perfect, 0 is no better than the mean, can be
/// negative. `reference` is y (the target), `estimate` is ŷ. NaN when the reference is constant.
pub fn fit_percent(reference: &[f64], estimate: &[f64]) -> f64 {
    assert_eq!(reference.len(), estimate.len(), "fit_percent: lengths differ");
    let mut sums = FitSums::new(reference);
    for (y, e) in reference.iter().zip(estimate) {
        sums.add(*y, *e);
    }
    sums.fit_percent()
}

/// The sums behind [`fit_percent`] and [`rmse`], for an estimate made sample by sample and never
/// stored (a day-long model signal would double a fit's memory). Same sums in the same order as
/// those functions, so the same bits.
#[derive(Debug, Clone, Copy)]
pub struct FitSums {
    mean: f64,
    samples: usize,
    err: f64,
    spread: f64,
}

impl FitSums {
    pub fn new(reference: &[f64]) -> FitSums {
        FitSums {
            mean: reference.iter().sum::<f64>() / reference.len() as f64,
            samples: 0,
            err: 0.0,
            spread: 0.0,
        }
    }

    /// The next sample of the reference and of the estimate.
    #[inline]
    pub fn add(&mut self, reference: f64, estimate: f64) {
        self.err += (reference - estimate) * (reference - estimate);
        self.spread += (reference - self.mean) * (reference - self.mean);
        self.samples += 1;
    }

    pub fn fit_percent(&self) -> f64 {
        100.0 * (1.0 - self.err.sqrt() / self.spread.sqrt())
    }

    pub fn rmse(&self) -> f64 {
        (self.err / self.samples as f64).sqrt()
    }
}

/// Root-mean-square of `reference − estimate`.
pub fn rmse(reference: &[f64], estimate: &[f64]) -> f64 {
    assert_eq!(reference.len(), estimate.len(), "rmse: lengths differ");
    let sse: f64 = reference
        .iter()
        .zip(estimate)
        .map(|(y, e)| (y - e) * (y - e))
        .sum();
    (sse / reference.len() as f64).sqrt()
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine terms).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        sum += c / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// The continued fraction of the regularised incomplete beta function (modified Lentz).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut c = 1.0;
    let mut d = 1.0 - (a + b) * x / (a + 1.0);
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=300 {
        let m = m as f64;
        let m2 = 2.0 * m;
        for aa in [
            m * (b - m) * x / ((a + m2 - 1.0) * (a + m2)),
            -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0)),
        ] {
            d = 1.0 + aa * d;
            if d.abs() < TINY {
                d = TINY;
            }
            c = 1.0 + aa / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            h *= d * c;
        }
        if (d * c - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function I_x(a, b).
fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front = (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// Two-sided false-alarm probability of the Wald test that decides which terms a saved model
/// carries (the accelerometer's q, the gyroscope's terms held at nominal, the thermal orders).
/// Here, below both the campaign and the thermal fit, so that both use this one value.
pub const TERM_FALSE_ALARM: f64 = 1e-3;

/// The |estimate/se| a term must reach to be kept by the Wald test at [`TERM_FALSE_ALARM`].
pub(crate) fn term_threshold() -> f64 {
    student_t_quantile(1.0 - 0.5 * TERM_FALSE_ALARM, 1e6)
}

/// The share of a left-out term's squared move that noise alone would not make: (1 − k/W)₊ for
/// the Wald statistic W of k terms left out (E[W] = k where they are zero). A saved model that
/// leaves terms out adds that share of its move to its error bars: the accelerometer's q
/// (`campaign::candidate`) and the thermal orders (`thermal::fit`). 0 where W is NaN.
pub(crate) fn share_beyond_noise(wald: f64, terms: usize) -> f64 {
    (1.0 - terms as f64 / wald).max(0.0)
}

/// P(T > t) for Student's t with `nu` degrees of freedom, t ≥ 0.
fn student_t_upper(t: f64, nu: f64) -> f64 {
    0.5 * incomplete_beta(nu / 2.0, 0.5, nu / (nu + t * t))
}

/// The `p` quantile (p > 0.5) of Student's t with `nu` degrees of freedom, by bisection.
pub(crate) fn student_t_quantile(p: f64, nu: f64) -> f64 {
    let tail = 1.0 - p;
    if !(tail > 0.0 && tail < 0.5 && nu > 0.0) {
        return f64::INFINITY;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    while student_t_upper(hi, nu) > tail {
        hi *= 2.0;
        if hi > 1e12 {
            return f64::INFINITY;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_upper(mid, nu) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_percent_matches_hand_values() {
        let y = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(fit_percent(&y, &y), 100.0);
        assert!(fit_percent(&y, &[2.5; 4]).abs() < 1e-12);
        // ‖e‖ = 1, ‖y − ȳ‖ = √5.
        let f = fit_percent(&y, &[1.0, 2.0, 3.0, 5.0]);
        assert!((f - 100.0 * (1.0 - 1.0 / 5f64.sqrt())).abs() < 1e-12);
        assert!((rmse(&y, &[1.0, 2.0, 3.0, 5.0]) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn student_t_quantiles_match_the_tables() {
        // Published values: t(0.975; 1) = 12.706, t(0.975; 5) = 2.571, t(0.995; 10) = 3.169,
        // t(0.9995; 6) = 5.959, and the normal 0.99995 quantile 3.891 for many degrees of freedom.
        for (p, nu, t) in [
            (0.975, 1.0, 12.706),
            (0.975, 5.0, 2.571),
            (0.995, 10.0, 3.169),
            (0.9995, 6.0, 5.959),
            (0.99995, 1e7, 3.891),
        ] {
            let got = student_t_quantile(p, nu);
            assert!((got - t).abs() < 1.5e-3, "t({p}; {nu}) = {got}, not {t}");
        }
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        // The critical values the module documentation quotes.
        assert!((student_t_quantile(1.0 - 5e-5, 6.0) - 9.08).abs() < 0.01);
        assert!((student_t_quantile(1.0 - 5e-5, 10.0) - 6.21).abs() < 0.01);
    }
}
