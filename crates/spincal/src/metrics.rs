//! Goodness of fit (SPEC §4): MATLAB's normalised RMSE fit and plain RMSE.

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
}
