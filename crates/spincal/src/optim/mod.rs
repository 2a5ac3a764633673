//! Small optimisers shared by the turntable fit, the system-identification fits and the trainers.
//!
//! A problem implements [`LeastSquares`] (residuals and their Jacobian); solvers report progress
//! through an observer callback and never print.

mod golden;
mod lm;
mod nelder_mead;

pub use golden::golden_section_max;
pub use lm::{levenberg_marquardt, levenberg_marquardt_normal, LmOptions, LmReport, LmStop, NormalEquations};
pub use nelder_mead::{nelder_mead_bounded, Bounds, BoundsError, NelderMeadOptions, NelderMeadReport};

use faer::MatMut;

/// A nonlinear least-squares problem: minimise ½‖r(p)‖².
pub trait LeastSquares {
    fn n_params(&self) -> usize;
    fn n_residuals(&self) -> usize;
    /// Writes r(p) into `out` (length `n_residuals`).
    fn residuals(&self, p: &[f64], out: &mut [f64]);
    /// Writes ∂r/∂p (`n_residuals × n_params`) into `out`.
    fn jacobian(&self, p: &[f64], out: MatMut<'_, f64>);
}
