//! The robust (block-HAC sandwich) covariance and its parts the results expose.

use faer::prelude::Solve;
use faer::{Mat, Side};

use super::layout::run_offset;
use super::result::JointFit;
use crate::correctors::physical::SensorCovariance;
use crate::correctors::physical::SENSOR_PARAMS;

impl JointFit {
    /// The robust covariance of the sensor parameters (`SensorModel::params` order), zero for
    /// those held fixed; `None` when the fit had no covariance.
    pub fn sensor_covariance(&self) -> Option<SensorCovariance> {
        let cov = self.state.covariance.as_ref()?;
        let pos: Vec<Option<usize>> = (0..SENSOR_PARAMS)
            .map(|k| self.state.free_index.iter().position(|&i| i == k))
            .collect();
        Some(std::array::from_fn(|a| {
            std::array::from_fn(|b| match (pos[a], pos[b]) {
                (Some(a), Some(b)) => cov[(a, b)],
                _ => 0.0,
            })
        }))
    }

    /// The robust covariance of run `i`'s parameters `params` (indices into the run's own), zero
    /// for parameters held fixed; `None` when the fit had no covariance.
    pub fn run_covariance(&self, i: usize, params: &[usize]) -> Option<Vec<Vec<f64>>> {
        let cov = self.state.covariance.as_ref()?;
        let o = run_offset(i);
        let pos: Vec<Option<usize>> = params
            .iter()
            .map(|&p| self.state.free_index.iter().position(|&k| k == o + p))
            .collect();
        Some(
            pos.iter()
                .map(|a| {
                    pos.iter()
                        .map(|b| match (a, b) {
                            (Some(a), Some(b)) => cov[(*a, *b)],
                            _ => 0.0,
                        })
                        .collect()
                })
                .collect(),
        )
    }
}

impl JointFit {
    /// The robust covariance of the chip radii (each run's first parameter) of `runs`, across
    /// runs: radii that share a sensor's in-plane scale carry its trade in their covariance.
    /// `None` when the fit had no covariance or a radius was not free.
    pub(crate) fn radii_covariance(&self, runs: &[usize]) -> Option<Vec<Vec<f64>>> {
        let cov = self.state.covariance.as_ref()?;
        let pos: Vec<usize> = runs
            .iter()
            .map(|&i| self.state.free_index.iter().position(|&k| k == run_offset(i)))
            .collect::<Option<_>>()?;
        Some(
            pos.iter()
                .map(|&a| pos.iter().map(|&b| cov[(a, b)]).collect())
                .collect(),
        )
    }
}

/// H⁻¹ S H⁻¹ over the given parameters, with the small-sample factor G/(G − 1) omitted (blocks
/// are many); `None` when H is singular there.
pub(super) fn sandwich(h: &Mat<f64>, s: &Mat<f64>, index: &[usize]) -> Option<Mat<f64>> {
    let n = index.len();
    let ss = Mat::from_fn(n, n, |a, b| s[(index[a], index[b])]);
    let h_inv = inverse_on(h, index)?;
    let left = &h_inv * &ss;
    Some(&left * &h_inv)
}

/// The inverse of the symmetric positive definite `h` restricted to `index` (rows and columns);
/// `None` when it is singular.
pub(super) fn inverse_on(h: &Mat<f64>, index: &[usize]) -> Option<Mat<f64>> {
    let n = index.len();
    let hs = Mat::from_fn(n, n, |a, b| h[(index[a], index[b])]);
    // Scale to unit diagonal for a well-conditioned factorisation.
    let d: Vec<f64> = (0..n).map(|a| hs[(a, a)].max(f64::MIN_POSITIVE).sqrt()).collect();
    let scaled = Mat::from_fn(n, n, |a, b| hs[(a, b)] / (d[a] * d[b]));
    let llt = scaled.llt(Side::Lower).ok()?;
    let inv = llt.solve(Mat::<f64>::identity(n, n));
    Some(Mat::from_fn(n, n, |a, b| inv[(a, b)] / (d[a] * d[b])))
}
