//! Levenberg–Marquardt for small dense problems (n ≲ 100 parameters, any number of residuals).
//!
//! Damping is Marquardt's: (JᵀJ + μ·diag(JᵀJ)) δ = −Jᵀr, μ adapted by Nielsen's gain-ratio rule.
//! Box bounds are honoured by clipping each trial step into the box.

use faer::linalg::matmul::matmul;
use faer::prelude::Solve;
use faer::{Accum, Mat, Par, Side};

use super::LeastSquares;
use crate::progress::{Observer, Progress};

/// Stopping and damping settings.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct LmOptions {
    pub max_iterations: usize,
    /// Stop when the relative decrease of the cost in an accepted step is below this.
    pub cost_tolerance: f64,
    /// Stop when every |δᵢ| ≤ step_tolerance · (|pᵢ| + step_tolerance).
    pub step_tolerance: f64,
    /// Stop when ‖Jᵀr‖∞ is below this.
    pub gradient_tolerance: f64,
    pub initial_damping: f64,
    /// After the damped iterations stop, undamped Gauss–Newton steps while one would still move
    /// some parameter by more than this many standard errors (of unit-weight residuals, from
    /// (JᵀJ)⁻¹), at most `POLISH_STEPS` and within `max_iterations`; 0 turns this off. A cost
    /// rule cannot see how far the minimum still is (a step of d standard errors changes the cost
    /// by about d²), this can.
    pub polish_se_tolerance: f64,
    /// Optional box: parameters are clipped into [lower, upper].
    pub lower: Option<Vec<f64>>,
    pub upper: Option<Vec<f64>>,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iterations: 200,
            cost_tolerance: 1e-15,
            step_tolerance: 1e-12,
            gradient_tolerance: 1e-14,
            initial_damping: 1e-3,
            polish_se_tolerance: 0.0,
            lower: None,
            upper: None,
        }
    }
}

/// Why the solver stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LmStop {
    CostTolerance,
    StepTolerance,
    GradientTolerance,
    MaxIterations,
    /// Damping grew without finding a better point: a (local) minimum to machine precision.
    NoProgress,
}

impl LmStop {
    /// Why the solver stopped, for people.
    pub fn describe(self) -> &'static str {
        match self {
            LmStop::CostTolerance => "converged: the cost stopped falling",
            LmStop::StepTolerance => "converged: the steps became negligible",
            LmStop::GradientTolerance => "converged: the gradient vanished",
            LmStop::MaxIterations => "stopped at the iteration limit",
            LmStop::NoProgress => "converged: no step lowers the cost (a minimum to machine precision)",
        }
    }
}

/// Result of a Levenberg–Marquardt run.
#[derive(Debug, Clone)]
pub struct LmReport {
    pub params: Vec<f64>,
    /// Sum of squared residuals at `params`.
    pub sse: f64,
    pub iterations: usize,
    pub stop: LmStop,
    /// JᵀJ at `params` (n × n), for covariance and identifiability.
    pub jtj: Mat<f64>,
}

/// Minimises ½‖r(p)‖² from `p0`, forming the normal equations from the whole Jacobian.
pub fn levenberg_marquardt(
    problem: &dyn LeastSquares,
    p0: &[f64],
    options: &LmOptions,
    observer: &Observer,
) -> LmReport {
    levenberg_marquardt_normal(&Dense::new(problem), p0, None, options, observer)
}

/// A least-squares problem that supplies its normal equations (JᵀJ, Jᵀr) directly, so that the
/// Jacobian never has to be stored whole (memory bounded by the parameter count, not the data).
pub trait NormalEquations {
    fn n_params(&self) -> usize;
    /// ‖r(p)‖².
    fn sse(&self, p: &[f64]) -> f64;
    /// Overwrites `jtj` (n × n) and `jtr` (n) at `p`; returns ‖r(p)‖².
    fn normal_equations(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64;
}

/// The normal equations of a [`LeastSquares`] problem from its whole Jacobian.
struct Dense<'a> {
    problem: &'a dyn LeastSquares,
    jac: std::cell::RefCell<Mat<f64>>,
}

impl<'a> Dense<'a> {
    fn new(problem: &'a dyn LeastSquares) -> Dense<'a> {
        let jac = Mat::zeros(problem.n_residuals(), problem.n_params());
        Dense {
            problem,
            jac: std::cell::RefCell::new(jac),
        }
    }
}

impl NormalEquations for Dense<'_> {
    fn n_params(&self) -> usize {
        self.problem.n_params()
    }
    fn sse(&self, p: &[f64]) -> f64 {
        let mut r = vec![0.0; self.problem.n_residuals()];
        self.problem.residuals(p, &mut r);
        sum_sq(&r)
    }
    fn normal_equations(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64 {
        let m = self.problem.n_residuals();
        let mut r = vec![0.0; m];
        self.problem.residuals(p, &mut r);
        let mut jac = self.jac.borrow_mut();
        self.problem.jacobian(p, jac.as_mut());
        gram(&jac, jtj);
        for (k, gk) in jtr.iter_mut().enumerate() {
            *gk = (0..m).map(|i| jac[(i, k)] * r[i]).sum();
        }
        sum_sq(&r)
    }
}

/// Minimises ½‖r(p)‖² from `p0` given the problem's normal equations. Parameters with
/// `free[k] == false` stay at their start.
pub fn levenberg_marquardt_normal(
    problem: &dyn NormalEquations,
    p0: &[f64],
    free: Option<&[bool]>,
    options: &LmOptions,
    observer: &Observer,
) -> LmReport {
    let n = problem.n_params();
    let limits = Limits { free, options };
    let mut p = p0.to_vec();
    limits.clip(&mut p);
    let mut state = LmState {
        p,
        jtj: Mat::<f64>::zeros(n, n),
        g: vec![0.0; n],
        trial: vec![0.0; n],
        sse: f64::NAN,
        iterations: 0,
    };
    let stop = damped_iterations(problem, &limits, &mut state, observer);
    state.sse = problem.normal_equations(&state.p, &mut state.jtj, &mut state.g);
    if options.polish_se_tolerance > 0.0 && state.sse.is_finite() {
        polish(problem, &limits, &mut state);
    }
    LmReport {
        params: state.p,
        sse: state.sse,
        iterations: state.iterations,
        stop,
        jtj: state.jtj,
    }
}

/// The box and the fixed parameters, as every step sees them.
struct Limits<'a> {
    free: Option<&'a [bool]>,
    options: &'a LmOptions,
}

impl Limits<'_> {
    fn clip(&self, p: &mut [f64]) {
        if let (Some(lo), Some(hi)) = (&self.options.lower, &self.options.upper) {
            for i in 0..p.len() {
                p[i] = p[i].clamp(lo[i], hi[i]);
            }
        }
    }

    fn fixed(&self, k: usize) -> bool {
        self.free.is_some_and(|f| !f[k])
    }

    /// Fixed parameters, and those on a bound whose descent direction points out of the box,
    /// stay put.
    fn pinned_at(&self, p: &[f64], g: &[f64]) -> Vec<bool> {
        (0..g.len())
            .map(|k| {
                self.fixed(k)
                    || match (&self.options.lower, &self.options.upper) {
                        (Some(lo), Some(hi)) => {
                            (p[k] <= lo[k] && g[k] > 0.0) || (p[k] >= hi[k] && g[k] < 0.0)
                        }
                        _ => false,
                    }
            })
            .collect()
    }
}

/// The iterate and its normal equations, carried from the damped iterations to the polish.
struct LmState {
    p: Vec<f64>,
    jtj: Mat<f64>,
    /// The gradient Jᵀr at `p`.
    g: Vec<f64>,
    /// Scratch for a trial point.
    trial: Vec<f64>,
    sse: f64,
    iterations: usize,
}

/// The damped iterations (Nielsen's rule) until a tolerance or the iteration limit stops them.
fn damped_iterations(
    problem: &dyn NormalEquations,
    limits: &Limits,
    state: &mut LmState,
    observer: &Observer,
) -> LmStop {
    let options = limits.options;
    let LmState {
        p,
        jtj,
        g,
        trial,
        sse,
        iterations,
    } = state;
    let n = g.len();
    let mut mu = options.initial_damping;
    let mut nu = 2.0;
    let mut stop = LmStop::MaxIterations;
    let mut need_jacobian = true;

    while *iterations < options.max_iterations {
        if need_jacobian {
            *sse = problem.normal_equations(p, jtj, g);
            need_jacobian = false;
            let largest = (0..n)
                .filter(|&k| !limits.fixed(k))
                .fold(0.0f64, |a, k| a.max(g[k].abs()));
            if largest < options.gradient_tolerance {
                stop = LmStop::GradientTolerance;
                break;
            }
        }
        *iterations += 1;
        let pinned = limits.pinned_at(p, g);
        let Some(delta) = damped_step(jtj, g, mu, &pinned) else {
            mu *= nu;
            nu *= 2.0;
            if mu > 1e30 {
                stop = LmStop::NoProgress;
                break;
            }
            continue;
        };
        for k in 0..n {
            trial[k] = p[k] + delta[k];
        }
        limits.clip(trial);
        let step: Vec<f64> = (0..n).map(|k| trial[k] - p[k]).collect();
        let sse_trial = problem.sse(trial);
        let predicted = predicted_decrease(jtj, g, &step);
        let rho = (*sse - sse_trial) / predicted.max(f64::MIN_POSITIVE);
        if sse_trial.is_finite() && sse_trial < *sse {
            let relative = (*sse - sse_trial) / (*sse).max(f64::MIN_POSITIVE);
            let small_step = step
                .iter()
                .zip(p.iter())
                .all(|(d, x)| d.abs() <= options.step_tolerance * (x.abs() + options.step_tolerance));
            p.copy_from_slice(trial);
            *sse = sse_trial;
            mu *= (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3));
            nu = 2.0;
            need_jacobian = true;
            observer(Progress {
                stage: "Levenberg–Marquardt",
                done: *iterations,
                total: Some(options.max_iterations),
                cost: Some(*sse),
            });
            if relative < options.cost_tolerance {
                stop = LmStop::CostTolerance;
                break;
            }
            if small_step {
                stop = LmStop::StepTolerance;
                break;
            }
        } else {
            mu *= nu;
            nu *= 2.0;
            if mu > 1e30 {
                stop = LmStop::NoProgress;
                break;
            }
        }
    }
    stop
}

/// Predicted decrease of the quadratic model for the (clipped) step.
fn predicted_decrease(jtj: &Mat<f64>, g: &[f64], step: &[f64]) -> f64 {
    let n = step.len();
    let mut predicted = 0.0;
    for a in 0..n {
        let mut jtj_step = 0.0;
        for b in 0..n {
            jtj_step += jtj[(a, b)] * step[b];
        }
        predicted -= step[a] * (2.0 * g[a] + jtj_step);
    }
    predicted
}

/// Undamped Gauss–Newton steps from the damped iterations' end while a step still moves some
/// parameter by more than [`LmOptions::polish_se_tolerance`] standard errors.
fn polish(problem: &dyn NormalEquations, limits: &Limits, state: &mut LmState) {
    let options = limits.options;
    let LmState {
        p,
        jtj,
        g,
        trial,
        sse,
        iterations,
    } = state;
    let n = g.len();
    // Polish steps count as iterations, so `max_iterations: 0` still means none at all.
    for _ in 0..POLISH_STEPS.min(options.max_iterations.saturating_sub(*iterations)) {
        let pinned = limits.pinned_at(p, g);
        let Some((delta, variance)) = gauss_newton_step(jtj, g, &pinned) else {
            break;
        };
        let largest = (0..n)
            .filter(|&k| !pinned[k] && variance[k] > 0.0)
            .fold(0.0f64, |a, k| a.max(delta[k].abs() / variance[k].sqrt()));
        if largest <= options.polish_se_tolerance {
            break;
        }
        for k in 0..n {
            trial[k] = p[k] + delta[k];
        }
        limits.clip(trial);
        // This close to the minimum a step lowers the cost by (d SE)² ≈ 1e-9 for d = 3e-5,
        // below the rounding of a sum over many residuals; only a real rise stops the polish.
        let sse_trial = problem.sse(trial);
        if sse_trial.is_nan() || sse_trial > *sse * (1.0 + POLISH_COST_SLACK) {
            break;
        }
        p.copy_from_slice(trial);
        *iterations += 1;
        *sse = problem.normal_equations(p, jtj, g);
    }
}

/// Most undamped Gauss–Newton steps of [`LmOptions::polish_se_tolerance`].
pub(crate) const POLISH_STEPS: usize = 5;

/// Relative rise of the cost a polish step may show (rounding of the cost's sum) and still be
/// taken.
const POLISH_COST_SLACK: f64 = 1e-10;

/// The Gauss–Newton step −(JᵀJ)⁻¹g over the parameters not pinned, and the diagonal of (JᵀJ)⁻¹
/// (their unit-weight variances); `None` when JᵀJ is not positive definite there.
fn gauss_newton_step(jtj: &Mat<f64>, g: &[f64], pinned: &[bool]) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = g.len();
    let (llt, delta) = solve_pinned(jtj, g, 0.0, pinned)?;
    let inverse = llt.solve(Mat::<f64>::identity(n, n));
    let variance: Vec<f64> = (0..n)
        .map(|i| if pinned[i] { 0.0 } else { inverse[(i, i)] })
        .collect();
    variance
        .iter()
        .all(|v| v.is_finite())
        .then_some((delta, variance))
}

/// Solves (JᵀJ + μ·diag(JᵀJ)) δ = −g with δ = 0 for pinned parameters; `None` when the damped
/// matrix is not positive definite.
fn damped_step(jtj: &Mat<f64>, g: &[f64], mu: f64, pinned: &[bool]) -> Option<Vec<f64>> {
    solve_pinned(jtj, g, mu, pinned).map(|(_, delta)| delta)
}

/// [`damped_step`]'s system, with its Cholesky factor.
fn solve_pinned(
    jtj: &Mat<f64>,
    g: &[f64],
    mu: f64,
    pinned: &[bool],
) -> Option<(faer::linalg::solvers::Llt<f64>, Vec<f64>)> {
    let n = g.len();
    let max_diag = (0..n).fold(0.0f64, |a, k| a.max(jtj[(k, k)]));
    let floor = max_diag * 1e-15 + f64::MIN_POSITIVE;
    let a = Mat::from_fn(n, n, |i, j| {
        if pinned[i] || pinned[j] {
            if i == j {
                1.0
            } else {
                0.0
            }
        } else if i == j {
            jtj[(i, i)] + mu * jtj[(i, i)].max(floor)
        } else {
            jtj[(i, j)]
        }
    });
    let llt = a.llt(Side::Lower).ok()?;
    let rhs = Mat::from_fn(n, 1, |i, _| if pinned[i] { 0.0 } else { -g[i] });
    let x = llt.solve(&rhs);
    let delta: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
    delta.iter().all(|d| d.is_finite()).then_some((llt, delta))
}

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// JᵀJ, sequentially (so the result does not depend on the thread count).
fn gram(jac: &Mat<f64>, jtj: &mut Mat<f64>) {
    matmul(
        jtj.as_mut(),
        Accum::Replace,
        jac.transpose(),
        jac.as_ref(),
        1.0,
        Par::Seq,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::MatMut;

    /// Rosenbrock as least squares: r = (10 (y − x²), 1 − x).
    struct Rosenbrock;
    impl LeastSquares for Rosenbrock {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            2
        }
        fn residuals(&self, p: &[f64], out: &mut [f64]) {
            out[0] = 10.0 * (p[1] - p[0] * p[0]);
            out[1] = 1.0 - p[0];
        }
        fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
            out[(0, 0)] = -20.0 * p[0];
            out[(0, 1)] = 10.0;
            out[(1, 0)] = -1.0;
            out[(1, 1)] = 0.0;
        }
    }

    #[test]
    fn solves_rosenbrock_from_the_classic_start() {
        let report = levenberg_marquardt(
            &Rosenbrock,
            &[-1.2, 1.0],
            &LmOptions::default(),
            &crate::progress::silent,
        );
        assert!((report.params[0] - 1.0).abs() < 1e-10, "{:?}", report);
        assert!((report.params[1] - 1.0).abs() < 1e-10);
        assert!(report.sse < 1e-20);
    }

    #[test]
    fn respects_bounds() {
        let options = LmOptions {
            lower: Some(vec![-2.0, -2.0]),
            upper: Some(vec![0.5, 2.0]),
            ..LmOptions::default()
        };
        let report = levenberg_marquardt(&Rosenbrock, &[-1.2, 1.0], &options, &crate::progress::silent);
        assert!(report.params[0] <= 0.5);
        // Constrained minimum sits on the bound x = 0.5, y = 0.25.
        assert!((report.params[0] - 0.5).abs() < 1e-8, "{:?}", report.params);
        assert!((report.params[1] - 0.25).abs() < 1e-6, "{:?}", report.params);
    }

    /// y = a e^(−b t) + c with a fixed, noise-like wiggle, so the minimum has residuals.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
    }

    impl Decay {
        fn new() -> Decay {
            let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
            let y = t
                .iter()
                .enumerate()
                .map(|(i, t)| 2.0 * (-0.7 * t).exp() + 0.3 + 0.01 * ((i * 7919 % 113) as f64 / 56.0 - 1.0))
                .collect();
            Decay { t, y }
        }
    }

    impl LeastSquares for Decay {
        fn n_params(&self) -> usize {
            3
        }
        fn n_residuals(&self) -> usize {
            self.t.len()
        }
        fn residuals(&self, p: &[f64], out: &mut [f64]) {
            for ((o, t), y) in out.iter_mut().zip(&self.t).zip(&self.y) {
                *o = p[0] * (-p[1] * t).exp() + p[2] - y;
            }
        }
        fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
            for (i, t) in self.t.iter().enumerate() {
                let e = (-p[1] * t).exp();
                out[(i, 0)] = e;
                out[(i, 1)] = -p[0] * t * e;
                out[(i, 2)] = 1.0;
            }
        }
    }

    /// A loose cost rule stops short of the minimum; the Gauss–Newton polish then lands on it
    /// (to 1e-9 of a standard error), where running the damped iterations to exhaustion ends.
    #[test]
    fn the_polish_reaches_the_minimum_a_cost_rule_stops_short_of() {
        let loose = LmOptions {
            cost_tolerance: 1e-4,
            ..LmOptions::default()
        };
        let exhausted = LmOptions {
            cost_tolerance: 0.0,
            step_tolerance: 0.0,
            gradient_tolerance: 0.0,
            max_iterations: 1000,
            ..LmOptions::default()
        };
        let polished = LmOptions {
            polish_se_tolerance: 1e-10,
            ..loose.clone()
        };
        let start = [1.0, 0.2, 0.0];
        let silent = &crate::progress::silent;
        let minimum = levenberg_marquardt(&Decay::new(), &start, &exhausted, silent);
        let short = levenberg_marquardt(&Decay::new(), &start, &loose, silent);
        let report = levenberg_marquardt(&Decay::new(), &start, &polished, silent);
        let se: Vec<f64> = {
            let inverse = minimum
                .jtj
                .llt(Side::Lower)
                .unwrap()
                .solve(Mat::<f64>::identity(3, 3));
            let sigma2 = minimum.sse / (200.0 - 3.0);
            (0..3).map(|k| (sigma2 * inverse[(k, k)]).sqrt()).collect()
        };
        let off = |p: &[f64]| (0..3).fold(0.0f64, |a, k| a.max((p[k] - minimum.params[k]).abs() / se[k]));
        assert!(
            off(&short.params) > 1e-6,
            "the loose rule already stopped at the minimum: {}",
            off(&short.params)
        );
        assert!(
            off(&report.params) < 1e-9,
            "{} standard errors off",
            off(&report.params)
        );
        assert!(report.iterations > short.iterations);
    }
}
