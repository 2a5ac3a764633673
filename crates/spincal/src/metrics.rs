//! Goodness of fit (SPEC §4): MATLAB's normalised RMSE fit and plain RMSE.

/// `100 · (1 − ‖y − ŷ‖ / ‖y − mean(y)‖)`: 100 is perfect, 0 is no better than the mean, can be
/// negative. `reference` is y (the target), `estimate` is ŷ. NaN when the reference is constant.
pub fn fit_percent(reference: &[f64], estimate: &[f64]) -> f64 {
    assert_eq!(reference.len(), estimate.len(), "fit_percent: lengths differ");
    let n = reference.len() as f64;
    let mean = reference.iter().sum::<f64>() / n;
    let mut err = 0.0;
    let mut spread = 0.0;
    for (y, e) in reference.iter().zip(estimate) {
        err += (y - e) * (y - e);
        spread += (y - mean) * (y - mean);
    }
    100.0 * (1.0 - err.sqrt() / spread.sqrt())
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
