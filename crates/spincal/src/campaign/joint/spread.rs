//! The spread of the bias offsets between power-on sessions, estimated from the recordings.
//!
//! Every still session and every run carries a bias offset δ ~ N(0, σ²) about the unit's bias
//! (a run in a named session is tied to its session's). σ is chosen by the marginal likelihood
//! of the recordings (type-II maximum likelihood, the Laplace approximation about the current
//! fit): with Λ(σ) = P/σ² the offsets' prior precision,
//!
//! log L(σ) = −½ min_p S(p; σ) − ½ log det(H + Λ) + ½ log det Λ,
//!
//! where S is the weighted sum of squares with the priors and H the data's normal matrix. One
//! offset per one-pose file says little alone, but the many of a campaign recorded one file per
//! pose say together whether the sensor kept its bias: σ then shrinks, and the poses inform the
//! bias and q instead of being absorbed by their offsets.

use faer::prelude::Solve;
use faer::{Mat, Side};

use super::layout::{run_offset, session_offset, sessions, GEOMETRY};
use super::problem::{JointProblem, Want, SESSION_DRIFT_S, SESSION_TIE};

/// The search's range for σ, as multiples of g: from 10 µg (no spread any campaign could
/// see) to 5 % of g (a sensor that is not one sensor between power-ons).
const SEARCH_G: (f64, f64) = (1e-5, 0.05);
/// Log-spaced trial values before the golden-section refinement.
const GRID: usize = 24;

/// What the estimate found.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BiasSpread {
    /// The standard deviation of a session's or run's bias offset, m/s².
    pub sd_mps2: f64,
    /// True when estimated from the recordings; false when the settings gave it.
    pub estimated: bool,
    /// True when the estimate sits at the search's lower end: no spread is seen.
    pub at_lower_bound: bool,
    /// Offsets behind it: still sessions plus runs not tied to a session.
    pub offsets: usize,
    /// Twice the log-likelihood gained over the lower end of the search (a likelihood-ratio
    /// statistic for a spread above zero; χ²₁-like, about 0 when none is seen).
    pub likelihood_ratio: f64,
}

/// The quadratic form P of the offsets' prior precision (Λ = P/σ²) over the parameter vector:
/// diagonal entries and ties.
struct OffsetPrior {
    diagonal: Vec<(usize, f64)>,
    ties: Vec<(usize, usize, f64)>,
}

impl OffsetPrior {
    fn of(problem: &JointProblem<'_>) -> OffsetPrior {
        let (runs, poses) = (problem.runs, problem.poses);
        let mut diagonal = Vec::new();
        let mut ties = Vec::new();
        for (i, run) in runs.iter().enumerate() {
            for k in 0..3 {
                let own = run_offset(i) + GEOMETRY + k;
                match run.session {
                    Some(s) => ties.push((
                        own,
                        session_offset(runs.len(), poses.len(), s) + k,
                        SESSION_TIE.powi(2),
                    )),
                    None => diagonal.push((own, 1.0)),
                }
            }
        }
        for s in 0..sessions(runs, poses) {
            let so = session_offset(runs.len(), poses.len(), s);
            for k in 0..3 {
                diagonal.push((so + k, 1.0));
                diagonal.push((so + 3 + k, SESSION_DRIFT_S.powi(2)));
            }
        }
        OffsetPrior { diagonal, ties }
    }

    /// Adds `scale`·P to `h` and `scale`·P p to `g`; returns `scale`·pᵀPp.
    fn add(&self, h: &mut Mat<f64>, g: &mut [f64], p: &[f64], scale: f64) -> f64 {
        let mut quadratic = 0.0;
        for &(i, w) in &self.diagonal {
            h[(i, i)] += scale * w;
            g[i] += scale * w * p[i];
            quadratic += scale * w * p[i] * p[i];
        }
        for &(a, b, w) in &self.ties {
            let d = p[a] - p[b];
            h[(a, a)] += scale * w;
            h[(b, b)] += scale * w;
            h[(a, b)] -= scale * w;
            h[(b, a)] -= scale * w;
            g[a] += scale * w * d;
            g[b] -= scale * w * d;
            quadratic += scale * w * d * d;
        }
        quadratic
    }

    /// Offsets with a prior (the dimension of Λ).
    fn dimension(&self) -> usize {
        self.diagonal.len() + self.ties.len()
    }
}

/// The bias offsets of `problem`: still sessions plus runs not tied to a session.
pub(super) fn offset_count(problem: &JointProblem<'_>) -> usize {
    problem.runs.iter().filter(|r| r.session.is_none()).count() + sessions(problem.runs, problem.poses)
}

/// The marginal likelihood's maximum over σ for `problem` about `p`, with `free` the parameters
/// the fit estimates. `None` when the problem has no offsets or its matrix is singular.
pub(super) fn estimate_bias_spread(
    problem: &JointProblem<'_>,
    p: &[f64],
    free: &[bool],
) -> Option<BiasSpread> {
    let prior = OffsetPrior::of(problem);
    if prior.dimension() == 0 {
        return None;
    }
    let offsets = offset_count(problem);
    let (lo, hi) = (
        (SEARCH_G.0 * problem.gravity).ln(),
        (SEARCH_G.1 * problem.gravity).ln(),
    );
    // One offset cannot be told from the unit's bias, so its likelihood is flat and its maximum
    // an accident of the other priors. Where runs are tied to that one power-on, that accident
    // would loosen their tie (a phone's radius then took a 1.2 mm error bar): there is no spread
    // between power-ons, and the runs share the session's offset (their drift within a run stays
    // free). A lone still session keeps the likelihood's value, which also sizes its drift prior.
    if offsets < 2 && problem.runs.iter().any(|r| r.session.is_some()) {
        return Some(BiasSpread {
            sd_mps2: lo.exp(),
            estimated: true,
            at_lower_bound: true,
            offsets,
            likelihood_ratio: 0.0,
        });
    }
    let n = p.len();
    let mut h = Mat::zeros(n, n);
    let mut g = vec![0.0; n];
    let sse = problem.evaluate(p, Want::Normal(&mut h, &mut g));
    // The data's part: the offsets' prior at the fit's σ taken out.
    let sigma_fit = problem.bias_sigma;
    let sse_rest = sse - prior.add(&mut h, &mut g, p, -1.0 / (sigma_fit * sigma_fit));
    let index: Vec<usize> = (0..n).filter(|&k| free[k]).collect();
    let log_likelihood = |log_sigma: f64| -> Option<f64> {
        let sigma = log_sigma.exp();
        let scale = 1.0 / (sigma * sigma);
        let mut a = h.clone();
        let mut rhs = g.clone();
        let quadratic = prior.add(&mut a, &mut rhs, p, scale);
        let m = index.len();
        let d: Vec<f64> = index
            .iter()
            .map(|&k| a[(k, k)].max(f64::MIN_POSITIVE).sqrt())
            .collect();
        let scaled = Mat::from_fn(m, m, |i, j| a[(index[i], index[j])] / (d[i] * d[j]));
        let b = Mat::from_fn(m, 1, |i, _| rhs[index[i]] / d[i]);
        let llt = scaled.llt(Side::Lower).ok()?;
        let x = llt.solve(&b);
        let reduction: f64 = (0..m).map(|i| b[(i, 0)] * x[(i, 0)]).sum();
        let l = llt.L();
        let log_det = (0..m)
            .map(|i| 2.0 * l[(i, i)].ln() + 2.0 * d[i].ln())
            .sum::<f64>();
        let min_sse = sse_rest + quadratic - reduction;
        let value = -0.5 * min_sse - 0.5 * log_det - prior.dimension() as f64 * log_sigma;
        value.is_finite().then_some(value)
    };
    let grid: Vec<(f64, f64)> = (0..GRID)
        .filter_map(|i| {
            let x = lo + (hi - lo) * i as f64 / (GRID - 1) as f64;
            log_likelihood(x).map(|v| (x, v))
        })
        .collect();
    let &(best_x, _) = grid.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let step = (hi - lo) / (GRID - 1) as f64;
    let value_at = |x: f64| log_likelihood(x).unwrap_or(f64::NEG_INFINITY);
    let x = crate::optim::golden_section_max(value_at, (best_x - step).max(lo), (best_x + step).min(hi), 30);
    let value = value_at(x);
    let at_lower = log_likelihood(lo)?;
    Some(BiasSpread {
        sd_mps2: x.exp(),
        estimated: true,
        at_lower_bound: x <= lo + 0.05 * step,
        offsets,
        likelihood_ratio: (2.0 * (value - at_lower)).max(0.0),
    })
}
