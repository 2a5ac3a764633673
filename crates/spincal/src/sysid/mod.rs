//! System identification with MATLAB System Identification Toolbox semantics (SPEC §3):
//! polynomial models (ARX, OE, ARMAX, Box–Jenkins) in the idpoly convention, nonlinear ARX with a
//! sigmoid network, and Hammerstein–Wiener with piecewise-linear nonlinearities.
//!
//! Every model kind follows one shape: a params struct → `fit(u, y, …) -> Result<Fit, SysidError>`
//! → a model with `simulate(u, init)` and `predict(u, y)`. [`fit_and_score`] fits any kind from a
//! [`ModelSpec`] and scores it on training and test ranges, for the comparison table.
//!
//! Signals: `u` is one slice per input, `y` the output, all of one length, sampled uniformly.

mod arx;
mod compare;
mod hw;
mod narx;
mod pem;
mod poly;
mod tsqr;

pub use arx::{ArxFit, ArxParams};
pub use compare::{
    fit_and_score, fit_and_score_parts, score, DataPart, FitScore, FittedModel, ModelKind, ModelSpec,
    PredictionKind, ScoredFit, Scores, SysidModel,
};
pub use compare::{parse_range, RangeError};
pub use hw::{HwFit, HwModel, HwParams, PiecewiseLinear};
pub use narx::{NarxFit, NarxFocus, NarxModel, NarxParams};
pub use pem::{PemFit, PemParams};
pub use poly::{filter, poly_mul, PolyModel, SimInit};

/// Everything that can go wrong while identifying a model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SysidError {
    #[error("{what} has {found} samples, expected {expected}")]
    LengthMismatch {
        what: String,
        expected: usize,
        found: usize,
    },
    #[error("the model has {expected} inputs but {found} were given")]
    InputCount { expected: usize, found: usize },
    #[error("too few samples: {needed} needed, {available} available")]
    TooFewSamples { needed: usize, available: usize },
    #[error("invalid orders: {0}")]
    BadOrders(String),
    #[error("{what} contains a non-finite value at sample {index}")]
    NonFinite { what: String, index: usize },
    #[error("numerical failure: {0}")]
    Numerical(String),
}

/// Checks that every input has y's length and that all values are finite.
/// First sample index at which y(t−1..na) and every input's u(t−nk..t−nk−nb+1) exist.
pub(crate) fn first_complete_row(na: usize, nb: &[usize], nk: &[usize]) -> usize {
    let b = nb
        .iter()
        .zip(nk)
        .map(|(nb, nk)| (nb + nk).saturating_sub(1))
        .max()
        .unwrap_or(0);
    na.max(b)
}

pub(crate) fn check_data(u: &[&[f64]], y: &[f64]) -> Result<(), SysidError> {
    for (i, ui) in u.iter().enumerate() {
        if ui.len() != y.len() {
            return Err(SysidError::LengthMismatch {
                what: format!("input {}", i + 1),
                expected: y.len(),
                found: ui.len(),
            });
        }
        if let Some(index) = ui.iter().position(|v| !v.is_finite()) {
            return Err(SysidError::NonFinite {
                what: format!("input {}", i + 1),
                index,
            });
        }
    }
    if let Some(index) = y.iter().position(|v| !v.is_finite()) {
        return Err(SysidError::NonFinite {
            what: "the output".into(),
            index,
        });
    }
    Ok(())
}
