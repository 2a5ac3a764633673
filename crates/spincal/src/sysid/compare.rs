//! One entry point for every model kind: fit from a [`ModelSpec`] on a training range, score
//! simulation and one-step prediction (always labelled) on training and test ranges.

use std::ops::Range;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::hw::{HwModel, HwParams};
use super::narx::{NarxFocus, NarxModel, NarxParams};
use super::poly::{PolyModel, SimInit};
use super::{ArxParams, PemParams, SysidError};
use crate::metrics::{fit_percent, rmse};
use crate::progress::Observer;

/// The model families.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    Arx,
    Oe,
    Armax,
    Bj,
    Narx,
    Hw,
}

impl ModelKind {
    pub const ALL: [ModelKind; 6] = [
        ModelKind::Arx,
        ModelKind::Oe,
        ModelKind::Armax,
        ModelKind::Bj,
        ModelKind::Narx,
        ModelKind::Hw,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Arx => "ARX",
            ModelKind::Oe => "OE",
            ModelKind::Armax => "ARMAX",
            ModelKind::Bj => "BJ",
            ModelKind::Narx => "NARX",
            ModelKind::Hw => "HW",
        }
    }

    /// Order names in MATLAB's order, e.g. `["nb", "nc", "nd", "nf", "nk"]` for BJ.
    pub fn order_names(self) -> &'static [&'static str] {
        match self {
            ModelKind::Arx | ModelKind::Narx => &["na", "nb", "nk"],
            ModelKind::Oe | ModelKind::Hw => &["nb", "nf", "nk"],
            ModelKind::Armax => &["na", "nb", "nc", "nk"],
            ModelKind::Bj => &["nb", "nc", "nd", "nf", "nk"],
        }
    }

    /// The paper's orders (SPEC §3) where it has them.
    pub fn default_orders(self) -> &'static [usize] {
        match self {
            ModelKind::Arx => &[6, 8, 1],
            ModelKind::Oe => &[4, 4, 1],
            ModelKind::Armax => &[4, 4, 4, 1],
            ModelKind::Bj => &[4, 4, 4, 4, 1],
            ModelKind::Narx => &[2, 2, 1],
            ModelKind::Hw => &[2, 3, 1],
        }
    }
}

impl std::str::FromStr for ModelKind {
    type Err = SysidError;
    fn from_str(s: &str) -> Result<Self, SysidError> {
        ModelKind::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                SysidError::BadOrders(format!("unknown model '{s}' (arx, oe, armax, bj, narx, hw)"))
            })
    }
}

/// What to fit: a kind, its orders (single input) and the solver settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelSpec {
    pub kind: ModelKind,
    pub orders: Vec<usize>,
    /// Sigmoid units (NARX) or breakpoints (HW); ignored otherwise.
    pub size: usize,
    pub max_iterations: usize,
    pub seed: u64,
    /// NARX only: the error its fit minimises; ignored otherwise.
    #[serde(default, skip_serializing_if = "is_prediction")]
    pub focus: NarxFocus,
}

fn is_prediction(focus: &NarxFocus) -> bool {
    *focus == NarxFocus::Prediction
}

impl ModelSpec {
    /// Checks the number of orders against the kind.
    pub fn new(kind: ModelKind, orders: &[usize]) -> Result<ModelSpec, SysidError> {
        let names = kind.order_names();
        if orders.len() != names.len() {
            return Err(SysidError::BadOrders(format!(
                "{} takes {} orders [{}], got {}",
                kind.name(),
                names.len(),
                names.join(" "),
                orders.len()
            )));
        }
        Ok(ModelSpec {
            kind,
            orders: orders.to_vec(),
            size: 10,
            max_iterations: 100,
            seed: 1,
            focus: NarxFocus::Prediction,
        })
    }

    /// e.g. "BJ [nb nc nd nf nk] = [4 4 4 4 1]".
    pub fn structure(&self) -> String {
        let list = |v: &[usize]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ");
        let mut s = format!(
            "{} [{}] = [{}]",
            self.kind.name(),
            self.kind.order_names().join(" "),
            list(&self.orders)
        );
        match self.kind {
            ModelKind::Narx => {
                s += &format!(", sigmoidnet {} units", self.size);
                if self.focus == NarxFocus::Simulation {
                    s += ", simulation focus";
                }
            }
            ModelKind::Hw => s += &format!(", pwlinear {} breakpoints", self.size),
            _ => {}
        }
        s
    }

    /// Fits the model on (u, y).
    pub fn fit(&self, u: &[&[f64]], y: &[f64], observer: &Observer) -> Result<FittedModel, SysidError> {
        let o = &self.orders;
        let max_iterations = self.max_iterations;
        let pem = |mut p: PemParams, observer: &Observer| -> Result<FittedModel, SysidError> {
            p.max_iterations = max_iterations;
            let fit = p.fit(u, y, observer)?;
            Ok(FittedModel {
                model: SysidModel::Poly(fit.model),
                loss: fit.loss,
                iterations: fit.iterations,
            })
        };
        match self.kind {
            ModelKind::Arx => {
                let fit = ArxParams::siso(o[0], o[1], o[2]).fit(u, y)?;
                Ok(FittedModel {
                    model: SysidModel::Poly(fit.model),
                    loss: fit.loss,
                    iterations: 0,
                })
            }
            ModelKind::Oe => pem(PemParams::oe(o[0], o[1], o[2]), observer),
            ModelKind::Armax => pem(PemParams::armax(o[0], o[1], o[2], o[3]), observer),
            ModelKind::Bj => pem(PemParams::bj(o[0], o[1], o[2], o[3], o[4]), observer),
            ModelKind::Narx => {
                let fit = NarxParams {
                    units: self.size,
                    max_iterations: self.max_iterations,
                    seed: self.seed,
                    focus: self.focus,
                    ..NarxParams::new(o[0], o[1], o[2])
                }
                .fit(u, y, observer)?;
                Ok(FittedModel {
                    model: SysidModel::Narx(fit.model),
                    loss: fit.loss,
                    iterations: fit.iterations,
                })
            }
            ModelKind::Hw => {
                let fit = HwParams {
                    breakpoints: self.size,
                    max_iterations: self.max_iterations,
                    ..HwParams::new(o[0], o[1], o[2])
                }
                .fit(u, y, observer)?;
                Ok(FittedModel {
                    model: SysidModel::Hw(fit.model),
                    loss: fit.loss,
                    iterations: fit.iterations,
                })
            }
        }
    }
}

/// Any fitted model; serde-tagged so it can join the saved-corrector file family.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum SysidModel {
    Poly(PolyModel),
    Narx(NarxModel),
    Hw(HwModel),
}

impl SysidModel {
    pub fn simulate(&self, u: &[&[f64]], init: SimInit<'_>) -> Result<Vec<f64>, SysidError> {
        match self {
            SysidModel::Poly(m) => m.simulate(u, init),
            SysidModel::Narx(m) => m.simulate(u, init),
            SysidModel::Hw(m) => m.simulate(u, init),
        }
    }

    pub fn predict(&self, u: &[&[f64]], y: &[f64]) -> Result<Vec<f64>, SysidError> {
        match self {
            SysidModel::Poly(m) => m.predict(u, y),
            SysidModel::Narx(m) => m.predict(u, y),
            SysidModel::Hw(m) => m.predict(u, y),
        }
    }
}

/// A model with the loss and iteration count of its fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FittedModel {
    pub model: SysidModel,
    /// Mean squared error of the fit's own criterion: one-step prediction error (ARX, PEM, NARX
    /// with the default focus) or simulation error (HW, NARX with simulation focus).
    pub loss: f64,
    /// Solver iterations (0 for the linear least-squares ARX).
    pub iterations: usize,
}

/// Which kind of output a fit % or RMSE refers to: they differ a lot, so they are never unlabelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PredictionKind {
    /// Infinite-horizon simulation from the input alone (after the initial samples).
    Simulation,
    /// One-step-ahead prediction from measured past outputs.
    OneStepPrediction,
}

impl PredictionKind {
    pub fn label(self) -> &'static str {
        match self {
            PredictionKind::Simulation => "simulation",
            PredictionKind::OneStepPrediction => "one-step prediction",
        }
    }
}

/// Fit % and RMSE of one kind of output over `samples` scored samples.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct FitScore {
    pub kind: PredictionKind,
    pub fit_percent: f64,
    pub rmse: f64,
    pub samples: usize,
}

/// Simulation and one-step scores on one data range.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct Scores {
    pub simulation: FitScore,
    pub one_step: FitScore,
}

/// Scores `model` on (u, y): simulation from the first `init_samples` measured outputs, one-step
/// prediction from zero initial conditions; both scored on samples `init_samples..`.
pub fn score(model: &SysidModel, u: &[&[f64]], y: &[f64], init_samples: usize) -> Result<Scores, SysidError> {
    if init_samples >= y.len() {
        return Err(SysidError::TooFewSamples {
            needed: init_samples + 1,
            available: y.len(),
        });
    }
    let sim = model.simulate(u, SimInit::Measured { y, n: init_samples })?;
    let pred = model.predict(u, y)?;
    let one = |kind, est: &[f64]| FitScore {
        kind,
        fit_percent: fit_percent(&y[init_samples..], &est[init_samples..]),
        rmse: rmse(&y[init_samples..], &est[init_samples..]),
        samples: y.len() - init_samples,
    };
    Ok(Scores {
        simulation: one(PredictionKind::Simulation, &sim),
        one_step: one(PredictionKind::OneStepPrediction, &pred),
    })
}

/// One row of a comparison table.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ScoredFit {
    pub name: String,
    pub structure: String,
    pub fitted: FittedModel,
    pub train: Scores,
    pub test: Option<Scores>,
    /// Wall-clock seconds of the fit alone (not the scoring).
    pub seconds: f64,
}

/// Fits `spec` on `train` and scores it on `train` and, if given, `test` (both index ranges into
/// u and y), simulations starting from `init_samples` measured outputs of each range.
pub fn fit_and_score(
    spec: &ModelSpec,
    u: &[&[f64]],
    y: &[f64],
    train: Range<usize>,
    test: Option<Range<usize>>,
    init_samples: usize,
    observer: &Observer,
) -> Result<ScoredFit, SysidError> {
    let test = test.map(|range| DataPart { u, y, range });
    fit_and_score_parts(
        spec,
        DataPart { u, y, range: train },
        test,
        init_samples,
        observer,
    )
}

/// Inputs, output and the samples of them to use: a training or test part.
#[derive(Debug, Clone)]
pub struct DataPart<'a> {
    pub u: &'a [&'a [f64]],
    pub y: &'a [f64],
    pub range: Range<usize>,
}

/// [`fit_and_score`] with the test part in series of its own (benchmarks that ship estimation and
/// validation records side by side). The test part is only scored, never used to fit.
pub fn fit_and_score_parts(
    spec: &ModelSpec,
    train: DataPart<'_>,
    test: Option<DataPart<'_>>,
    init_samples: usize,
    observer: &Observer,
) -> Result<ScoredFit, SysidError> {
    for part in std::iter::once(&train).chain(test.as_ref()) {
        let r = &part.range;
        let n = part
            .u
            .iter()
            .map(|ui| ui.len())
            .chain([part.y.len()])
            .min()
            .unwrap_or(0);
        if r.start >= r.end || r.end > n {
            return Err(SysidError::BadOrders(format!(
                "range {}..{} is empty or beyond the {} samples",
                r.start, r.end, n
            )));
        }
    }
    fn slice<'a>(p: &DataPart<'a>) -> Vec<&'a [f64]> {
        p.u.iter().map(|ui| &ui[p.range.clone()]).collect()
    }
    let start = Instant::now();
    let fitted = spec.fit(&slice(&train), &train.y[train.range.clone()], observer)?;
    let seconds = start.elapsed().as_secs_f64();
    let train_scores = score(
        &fitted.model,
        &slice(&train),
        &train.y[train.range.clone()],
        init_samples,
    )?;
    let test_scores = match &test {
        Some(p) => Some(score(
            &fitted.model,
            &slice(p),
            &p.y[p.range.clone()],
            init_samples,
        )?),
        None => None,
    };
    Ok(ScoredFit {
        name: spec.kind.name().to_string(),
        structure: spec.structure(),
        fitted,
        train: train_scores,
        test: test_scores,
        seconds,
    })
}

/// A sample range `START..END` that cannot be read or does not fit the data.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RangeError {
    #[error("'{0}' is not a range START..END (0-based, end excluded)")]
    Unreadable(String),
    #[error("range {start}..{end} is empty or beyond the {samples} samples")]
    OutOfData {
        start: usize,
        end: usize,
        samples: usize,
    },
}

/// Parses a 0-based sample range `START..END` (end excluded; either may be left out: `..END`,
/// `START..`) of data with `samples` samples.
pub fn parse_range(text: &str, samples: usize) -> Result<std::ops::Range<usize>, RangeError> {
    let bad = || RangeError::Unreadable(text.to_string());
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    let bound = |s: &str, empty: usize| {
        if s.trim().is_empty() {
            Ok(empty)
        } else {
            s.trim().parse().map_err(|_| bad())
        }
    };
    let (start, end) = (bound(a, 0)?, bound(b, samples)?);
    if start >= end || end > samples {
        return Err(RangeError::OutOfData { start, end, samples });
    }
    Ok(start..end)
}

#[cfg(test)]
mod range_tests {
    use super::*;

    #[test]
    fn ranges_are_read_with_open_ends_and_checked_against_the_data() {
        assert_eq!(parse_range("2..5", 10), Ok(2..5));
        assert_eq!(parse_range("..4", 10), Ok(0..4));
        assert_eq!(parse_range(" 3 .. ", 10), Ok(3..10));
        assert_eq!(parse_range("3-5", 10), Err(RangeError::Unreadable("3-5".into())));
        assert_eq!(
            parse_range("a..5", 10),
            Err(RangeError::Unreadable("a..5".into()))
        );
        assert_eq!(
            parse_range("5..11", 10).unwrap_err().to_string(),
            "range 5..11 is empty or beyond the 10 samples"
        );
        assert!(parse_range("5..5", 10).is_err());
    }
}
