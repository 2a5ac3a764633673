//! Nonlinear ARX [na nb nk] (MATLAB's `nlarx` with a `sigmoidnet`): regressors
//! x(t) = [y(t−1) … y(t−na), u(t−nk) … u(t−nk−nb+1)] and
//!
//! ```text
//! ŷ(t) = lᵀx + l₀ + Σⱼ αⱼ σ(wⱼᵀ z + βⱼ),   σ(s) = 1/(1 + e⁻ˢ),   z = (x − mean)/std
//! ```
//!
//! fitted by Levenberg–Marquardt, started from the ARX solution for the linear term and seeded
//! random weights for the units. Single input. The criterion is MATLAB's `Focus`: the one-step
//! prediction error (the default, [`NarxFocus::Prediction`]) or the simulation error
//! ([`NarxFocus::Simulation`]: the prediction fit refined with the model's own past outputs in the
//! regressor, the Jacobian by forward sensitivities through the fed-back lags, the first rows'
//! lags measured).

use faer::MatMut;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::arx::lstsq;
use super::poly::SimInit;
use super::{check_data, SysidError};
use crate::optim::{levenberg_marquardt, LeastSquares, LmOptions, LmStop};
use crate::progress::Observer;

/// Orders and training settings of a nonlinear ARX model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NarxParams {
    pub na: usize,
    pub nb: usize,
    pub nk: usize,
    /// Sigmoid units (MATLAB's default is 10).
    pub units: usize,
    pub max_iterations: usize,
    pub tolerance: f64,
    /// Seed of the initial unit weights (ChaCha8).
    pub seed: u64,
    /// What the fit minimises.
    #[serde(default)]
    pub focus: NarxFocus,
}

/// The error a NARX fit minimises (MATLAB's `nlarxOptions` `Focus`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NarxFocus {
    /// One-step-ahead prediction error: measured past outputs in the regressor.
    #[default]
    Prediction,
    /// Simulation error: the model's own past outputs in the regressor (started from the first
    /// rows' measured outputs). The prediction fit first, then up to `max_iterations` more on the
    /// simulation error from there; each of those simulates the whole training part.
    Simulation,
}

impl NarxParams {
    pub fn new(na: usize, nb: usize, nk: usize) -> NarxParams {
        NarxParams {
            na,
            nb,
            nk,
            units: 10,
            max_iterations: 100,
            tolerance: 1e-9,
            seed: 1,
            focus: NarxFocus::Prediction,
        }
    }
}

/// A fitted nonlinear ARX model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NarxModel {
    pub na: usize,
    pub nb: usize,
    pub nk: usize,
    /// Linear coefficients on the raw regressors (y lags first, then u lags).
    pub linear: Vec<f64>,
    pub offset: f64,
    /// Regressor standardisation used by the units.
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    /// Per unit: output weight α, bias β, input weights w (on standardised regressors).
    pub units: Vec<SigmoidUnit>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SigmoidUnit {
    pub out: f64,
    pub bias: f64,
    pub weights: Vec<f64>,
}

/// A fitted NARX model and how the fit went.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NarxFit {
    pub model: NarxModel,
    /// Mean squared error on the training rows of the fit's criterion (one-step prediction or
    /// simulation, as [`NarxParams::focus`]).
    pub loss: f64,
    pub iterations: usize,
    pub stop: LmStop,
}

fn sigmoid(s: f64) -> f64 {
    1.0 / (1.0 + (-s).exp())
}

impl NarxModel {
    fn n_regressors(&self) -> usize {
        self.na + self.nb
    }

    /// First sample with a complete regressor.
    pub fn first_row(&self) -> usize {
        self.na.max((self.nk + self.nb).saturating_sub(1))
    }

    fn regressor(&self, y: &[f64], u: &[f64], t: usize, x: &mut [f64]) {
        for k in 0..self.na {
            x[k] = if t > k { y[t - k - 1] } else { 0.0 };
        }
        for j in 0..self.nb {
            let lag = self.nk + j;
            x[self.na + j] = if t >= lag { u[t - lag] } else { 0.0 };
        }
    }

    fn eval(&self, x: &[f64]) -> f64 {
        let mut out = self.offset + self.linear.iter().zip(x).map(|(a, b)| a * b).sum::<f64>();
        for unit in &self.units {
            let s = unit.bias
                + unit
                    .weights
                    .iter()
                    .zip(x.iter().zip(self.mean.iter().zip(&self.scale)))
                    .map(|(w, (xi, (m, sc)))| w * (xi - m) / sc)
                    .sum::<f64>();
            out += unit.out * sigmoid(s);
        }
        out
    }

    fn check<'a>(u: &[&'a [f64]]) -> Result<&'a [f64], SysidError> {
        match u {
            [u0] => Ok(u0),
            _ => Err(SysidError::InputCount {
                expected: 1,
                found: u.len(),
            }),
        }
    }

    /// One-step prediction from measured outputs (regressors outside the data are zero).
    pub fn predict(&self, u: &[&[f64]], y: &[f64]) -> Result<Vec<f64>, SysidError> {
        let u = Self::check(u)?;
        check_data(&[u], y)?;
        let mut x = vec![0.0; self.n_regressors()];
        Ok((0..y.len())
            .map(|t| {
                self.regressor(y, u, t, &mut x);
                self.eval(&x)
            })
            .collect())
    }

    /// Free-run simulation: past outputs in the regressor are the model's own.
    pub fn simulate(&self, u: &[&[f64]], init: SimInit<'_>) -> Result<Vec<f64>, SysidError> {
        let u = Self::check(u)?;
        let n = u.len();
        let mut out = vec![0.0; n];
        let n0 = init.samples();
        let start = init.measured(n)?;
        out[..start.len()].copy_from_slice(start);
        let mut x = vec![0.0; self.n_regressors()];
        for t in n0..n {
            self.regressor(&out, u, t, &mut x);
            out[t] = self.eval(&x);
        }
        Ok(out)
    }

    fn n_params(&self) -> usize {
        let nx = self.n_regressors();
        nx + 1 + self.units.len() * (nx + 2)
    }

    fn pack(&self) -> Vec<f64> {
        let mut p = self.linear.clone();
        p.push(self.offset);
        for unit in &self.units {
            p.push(unit.out);
            p.push(unit.bias);
            p.extend_from_slice(&unit.weights);
        }
        p
    }

    fn unpack(&mut self, p: &[f64]) {
        let nx = self.n_regressors();
        self.linear.copy_from_slice(&p[..nx]);
        self.offset = p[nx];
        for (j, unit) in self.units.iter_mut().enumerate() {
            let base = nx + 1 + j * (nx + 2);
            unit.out = p[base];
            unit.bias = p[base + 1];
            unit.weights.copy_from_slice(&p[base + 2..base + 2 + nx]);
        }
    }
}

impl NarxParams {
    /// Fits on a single input `u[0]` and output `y`.
    pub fn fit(&self, u: &[&[f64]], y: &[f64], observer: &Observer) -> Result<NarxFit, SysidError> {
        let u = NarxModel::check(u)?;
        check_data(&[u], y)?;
        if self.na + self.nb == 0 {
            return Err(SysidError::BadOrders("NARX needs na + nb ≥ 1".into()));
        }
        let mut model = NarxModel {
            na: self.na,
            nb: self.nb,
            nk: self.nk,
            linear: vec![0.0; self.na + self.nb],
            offset: 0.0,
            mean: vec![0.0; self.na + self.nb],
            scale: vec![1.0; self.na + self.nb],
            units: Vec::new(),
        };
        let t0 = model.first_row();
        let nx = model.n_regressors();
        let rows = y.len().saturating_sub(t0);
        let needed = 2 * (nx + 1 + self.units * (nx + 2));
        if rows < needed {
            return Err(SysidError::TooFewSamples {
                needed: t0 + needed,
                available: y.len(),
            });
        }
        // Regressor matrix, row-major (rows × nx).
        let mut xs = vec![0.0; rows * nx];
        for r in 0..rows {
            model.regressor(y, u, t0 + r, &mut xs[r * nx..(r + 1) * nx]);
        }
        for k in 0..nx {
            let col = (0..rows).map(|r| xs[r * nx + k]);
            let mean = col.clone().sum::<f64>() / rows as f64;
            let var = col.map(|v| (v - mean) * (v - mean)).sum::<f64>() / rows as f64;
            model.mean[k] = mean;
            model.scale[k] = if var > 0.0 { var.sqrt() } else { 1.0 };
        }
        // Linear term and offset from least squares (the ARX solution with a constant).
        let phi = faer::Mat::from_fn(rows, nx + 1, |r, k| if k < nx { xs[r * nx + k] } else { 1.0 });
        let theta = lstsq(&phi, &y[t0..])?;
        model.linear.copy_from_slice(&theta[..nx]);
        model.offset = theta[nx];
        let y_std = {
            let m = y[t0..].iter().sum::<f64>() / rows as f64;
            (y[t0..].iter().map(|v| (v - m) * (v - m)).sum::<f64>() / rows as f64).sqrt()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
        model.units = (0..self.units)
            .map(|_| SigmoidUnit {
                out: 0.01 * y_std * normal(),
                bias: normal(),
                weights: (0..nx).map(|_| normal() / (nx as f64).sqrt()).collect(),
            })
            .collect();
        let options = LmOptions {
            max_iterations: self.max_iterations,
            cost_tolerance: self.tolerance,
            ..LmOptions::default()
        };
        let report = {
            let problem = NarxProblem {
                template: model.clone(),
                xs: &xs,
                target: &y[t0..],
            };
            levenberg_marquardt(&problem, &model.pack(), &options, observer)
        };
        let mut iterations = report.iterations;
        let report = match self.focus {
            NarxFocus::Prediction => report,
            NarxFocus::Simulation => {
                // From the prediction fit: random units started anywhere near the ARX solution
                // already move a slow system's simulation far (their small outputs go through the
                // linear part's large low-frequency gain), the prediction fit does not.
                drop(xs);
                let problem = NarxSimulationProblem {
                    template: model.clone(),
                    u,
                    y,
                    t0,
                };
                let refined = levenberg_marquardt(&problem, &report.params, &options, observer);
                iterations += refined.iterations;
                refined
            }
        };
        model.unpack(&report.params);
        Ok(NarxFit {
            model,
            loss: report.sse / rows as f64,
            iterations,
            stop: report.stop,
        })
    }
}

struct NarxProblem<'a> {
    template: NarxModel,
    xs: &'a [f64],
    target: &'a [f64],
}

impl LeastSquares for NarxProblem<'_> {
    fn n_params(&self) -> usize {
        self.template.n_params()
    }

    fn n_residuals(&self) -> usize {
        self.target.len()
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let mut m = self.template.clone();
        m.unpack(p);
        let nx = m.n_regressors();
        for (r, o) in out.iter_mut().enumerate() {
            *o = self.target[r] - m.eval(&self.xs[r * nx..(r + 1) * nx]);
        }
    }

    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        let mut m = self.template.clone();
        m.unpack(p);
        let nx = m.n_regressors();
        let mut z = vec![0.0; nx];
        // r = y − ŷ, so every column is −∂ŷ/∂p.
        for r in 0..self.target.len() {
            let x = &self.xs[r * nx..(r + 1) * nx];
            for k in 0..nx {
                out[(r, k)] = -x[k];
                z[k] = (x[k] - m.mean[k]) / m.scale[k];
            }
            out[(r, nx)] = -1.0;
            for (j, unit) in m.units.iter().enumerate() {
                let base = nx + 1 + j * (nx + 2);
                let s = unit.bias + unit.weights.iter().zip(&z).map(|(w, zk)| w * zk).sum::<f64>();
                let sg = sigmoid(s);
                let ds = unit.out * sg * (1.0 - sg);
                out[(r, base)] = -sg;
                out[(r, base + 1)] = -ds;
                for k in 0..nx {
                    out[(r, base + 2 + k)] = -ds * z[k];
                }
            }
        }
    }
}

/// The simulation-error problem: residuals y(t) − ŷ(t) where ŷ's past outputs in the regressor are
/// the model's own (the first `t0` outputs measured), and the Jacobian by forward sensitivities:
/// dŷ(t)/dθ = ∂f/∂θ + Σₖ ∂f/∂yₖ · dŷ(t−k)/dθ over the na fed-back lags.
struct NarxSimulationProblem<'a> {
    template: NarxModel,
    u: &'a [f64],
    y: &'a [f64],
    t0: usize,
}

impl NarxSimulationProblem<'_> {
    /// The simulated outputs (the first t0 measured).
    fn simulate(&self, m: &NarxModel) -> Vec<f64> {
        let mut out = self.y[..self.t0].to_vec();
        out.resize(self.y.len(), 0.0);
        let mut x = vec![0.0; m.n_regressors()];
        for t in self.t0..self.y.len() {
            m.regressor(&out, self.u, t, &mut x);
            out[t] = m.eval(&x);
        }
        out
    }
}

impl LeastSquares for NarxSimulationProblem<'_> {
    fn n_params(&self) -> usize {
        self.template.n_params()
    }

    fn n_residuals(&self) -> usize {
        self.y.len() - self.t0
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let mut m = self.template.clone();
        m.unpack(p);
        let sim = self.simulate(&m);
        for (r, o) in out.iter_mut().enumerate() {
            let t = self.t0 + r;
            *o = self.y[t] - sim[t];
        }
    }

    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        let mut m = self.template.clone();
        m.unpack(p);
        let (na, nx, np) = (m.na, m.n_regressors(), m.n_params());
        let sim = self.simulate(&m);
        let mut x = vec![0.0; nx];
        let mut z = vec![0.0; nx];
        // dŷ/dθ of the last na + 1 samples, sample t in row t mod (na + 1).
        let mut d = vec![0.0; (na + 1) * np];
        // ∂f/∂y(t−1−k) for the fed-back lags.
        let mut dy = vec![0.0; na];
        for r in 0..self.n_residuals() {
            let t = self.t0 + r;
            m.regressor(&sim, self.u, t, &mut x);
            for k in 0..nx {
                z[k] = (x[k] - m.mean[k]) / m.scale[k];
            }
            let row = (t % (na + 1)) * np;
            let (cur, _) = d[row..].split_at_mut(np);
            cur[..nx].copy_from_slice(&x);
            cur[nx] = 1.0;
            dy.copy_from_slice(&m.linear[..na]);
            for (j, unit) in m.units.iter().enumerate() {
                let base = nx + 1 + j * (nx + 2);
                let s = unit.bias + unit.weights.iter().zip(&z).map(|(w, zk)| w * zk).sum::<f64>();
                let sg = sigmoid(s);
                let ds = unit.out * sg * (1.0 - sg);
                cur[base] = sg;
                cur[base + 1] = ds;
                for k in 0..nx {
                    cur[base + 2 + k] = ds * z[k];
                }
                for k in 0..na {
                    dy[k] += ds * unit.weights[k] / m.scale[k];
                }
            }
            // Sensitivities of the fed-back outputs (zero before t0: those are measured).
            for (k, &g) in dy.iter().enumerate() {
                let lag = k + 1;
                if t < self.t0 + lag || g == 0.0 {
                    continue;
                }
                let prev = ((t - lag) % (na + 1)) * np;
                for q in 0..np {
                    let v = d[prev + q];
                    d[row + q] += g * v;
                }
            }
            for q in 0..np {
                out[(r, q)] = -d[row + q];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    #[test]
    fn jacobian_matches_finite_differences_and_fit_learns_a_static_nonlinearity() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = 600;
        let u: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
        let mut y = vec![0.0; n];
        for t in 1..n {
            // A saturating system: linear ARX cannot represent tanh.
            y[t] = 0.5 * y[t - 1] + (2.0 * u[t - 1]).tanh();
        }
        let params = NarxParams {
            units: 4,
            max_iterations: 200,
            ..NarxParams::new(1, 1, 1)
        };
        let fit = params.fit(&[&u], &y, &crate::progress::silent).unwrap();
        let pred = fit.model.predict(&[&u], &y).unwrap();
        let fit_pc = crate::metrics::fit_percent(&y[1..], &pred[1..]);
        assert!(fit_pc > 99.0, "one-step fit {fit_pc}");
        let sim = fit
            .model
            .simulate(&[&u], SimInit::Measured { y: &y, n: 1 })
            .unwrap();
        assert!(crate::metrics::fit_percent(&y[1..], &sim[1..]) > 97.0);

        // Analytic Jacobian against central differences at the fitted point.
        let t0 = fit.model.first_row();
        let nx = 2;
        let mut xs = vec![0.0; (n - t0) * nx];
        for r in 0..n - t0 {
            fit.model.regressor(&y, &u, t0 + r, &mut xs[r * nx..(r + 1) * nx]);
        }
        let problem = NarxProblem {
            template: fit.model.clone(),
            xs: &xs,
            target: &y[t0..],
        };
        assert_jacobian_matches(&problem, &fit.model.pack(), 37, 1e-6);
    }

    /// `problem`'s analytic Jacobian at `p` against central differences, every `stride`-th row,
    /// within `tolerance` relative to 1 + |difference quotient|.
    fn assert_jacobian_matches(problem: &impl LeastSquares, p: &[f64], stride: usize, tolerance: f64) {
        let m = problem.n_residuals();
        let mut jac = Mat::<f64>::zeros(m, p.len());
        problem.jacobian(p, jac.as_mut());
        let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
        for j in 0..p.len() {
            let mut q = p.to_vec();
            q[j] += 1e-6;
            problem.residuals(&q, &mut rp);
            q[j] -= 2e-6;
            problem.residuals(&q, &mut rm);
            for r in (0..m).step_by(stride) {
                let fd = (rp[r] - rm[r]) / 2e-6;
                assert!(
                    (fd - jac[(r, j)]).abs() < tolerance * (1.0 + fd.abs()),
                    "param {j}, row {r}: {fd} vs {}",
                    jac[(r, j)]
                );
            }
        }
    }

    #[test]
    fn simulation_focus_has_the_right_jacobian_and_removes_the_output_noise_bias() {
        // An output-error system: the noise is on the measurement, not in the recursion, so the
        // one-step fit regresses on noisy past outputs and is biased; the simulation fit is not.
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let n = 3000;
        let u: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
        let mut x = vec![0.0; n];
        for t in 1..n {
            x[t] = 0.9 * x[t - 1] + (1.5 * u[t - 1]).tanh();
        }
        let y: Vec<f64> = x
            .iter()
            .map(|v| {
                let e: f64 = StandardNormal.sample(&mut rng);
                v + 0.5 * e
            })
            .collect();
        let (train, test) = (0..2000, 2000..n);
        let fit = |focus| {
            NarxParams {
                units: 3,
                max_iterations: 100,
                focus,
                ..NarxParams::new(1, 1, 1)
            }
            .fit(&[&u[train.clone()]], &y[train.clone()], &crate::progress::silent)
            .unwrap()
        };
        let noise_free_fit = |m: &NarxModel| {
            let sim = m
                .simulate(
                    &[&u[test.clone()]],
                    SimInit::Measured {
                        y: &x[test.clone()],
                        n: 1,
                    },
                )
                .unwrap();
            crate::metrics::fit_percent(&x[test.clone()][1..], &sim[1..])
        };
        let prediction = noise_free_fit(&fit(NarxFocus::Prediction).model);
        let simulation_fit = fit(NarxFocus::Simulation);
        let simulation = noise_free_fit(&simulation_fit.model);
        assert!(
            simulation > prediction + 5.0 && simulation > 90.0,
            "simulation focus {simulation} %, prediction focus {prediction} %"
        );

        // Forward sensitivities against central differences at the fitted point.
        let model = simulation_fit.model;
        let problem = NarxSimulationProblem {
            template: model.clone(),
            u: &u[..400],
            y: &y[..400],
            t0: model.first_row(),
        };
        assert_jacobian_matches(&problem, &model.pack(), 13, 1e-5);
    }
}
