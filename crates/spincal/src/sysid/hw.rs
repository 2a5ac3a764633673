//! Hammerstein–Wiener [nb nf nk] (MATLAB's `nlhw` with `pwlinear` on both sides):
//!
//! ```text
//! s = f(u),   x = B/F · s,   ŷ = g(x)
//! ```
//!
//! f and g are piecewise-linear with a fixed number of breakpoints (default 10) at fixed positions,
//! evenly spaced over the training range of their input (MATLAB also moves the breakpoints; here
//! only the values are free), extended linearly outside. Fitted by Levenberg–Marquardt on the
//! simulation error, started from an OE fit with identity f and a least-squares g. Unstable F is
//! rejected during the search. Single input. The model has no noise model, so its one-step
//! prediction equals its simulation (from rest).

use faer::MatMut;
use serde::{Deserialize, Serialize};

use super::arx::lstsq;
use super::pem::PemParams;
use super::poly::{filter, is_stable, SimInit};
use super::{check_data, SysidError};
use crate::optim::{levenberg_marquardt, LeastSquares, LmOptions, LmStop};
use crate::progress::Observer;

/// Orders and settings of a Hammerstein–Wiener fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HwParams {
    pub nb: usize,
    pub nf: usize,
    pub nk: usize,
    /// Breakpoints of each piecewise-linear nonlinearity (≥ 2).
    pub breakpoints: usize,
    pub max_iterations: usize,
    pub tolerance: f64,
}

impl HwParams {
    pub fn new(nb: usize, nf: usize, nk: usize) -> HwParams {
        HwParams {
            nb,
            nf,
            nk,
            breakpoints: 10,
            max_iterations: 100,
            tolerance: 1e-9,
        }
    }
}

/// A piecewise-linear function through (xₖ, vₖ), extended linearly past both ends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PiecewiseLinear {
    pub x: Vec<f64>,
    pub v: Vec<f64>,
}

impl PiecewiseLinear {
    /// `k` breakpoints evenly over [lo, hi] with values `map(x)`.
    fn even(lo: f64, hi: f64, k: usize, map: impl Fn(f64) -> f64) -> PiecewiseLinear {
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 1.0, lo + 1.0) };
        let x: Vec<f64> = (0..k)
            .map(|i| lo + (hi - lo) * i as f64 / (k - 1) as f64)
            .collect();
        let v = x.iter().map(|&xi| map(xi)).collect();
        PiecewiseLinear { x, v }
    }

    /// Segment index j (use points j, j+1) and the interpolation weight s of point j+1.
    fn locate(&self, x: f64) -> (usize, f64) {
        let k = self.x.len();
        let j = match self.x.partition_point(|&b| b <= x) {
            0 => 0,
            p if p >= k => k - 2,
            p => p - 1,
        };
        (j, (x - self.x[j]) / (self.x[j + 1] - self.x[j]))
    }

    pub fn eval(&self, x: f64) -> f64 {
        let (j, s) = self.locate(x);
        self.v[j] * (1.0 - s) + self.v[j + 1] * s
    }

    /// An x with eval(x) = y: the solution on the segment (extensions included) closest to the
    /// middle breakpoint; the nearest end when y is out of reach.
    pub fn inverse(&self, y: f64) -> f64 {
        let k = self.x.len();
        let mid = 0.5 * (self.x[0] + self.x[k - 1]);
        let mut best: Option<f64> = None;
        for j in 0..k - 1 {
            let (v0, v1) = (self.v[j], self.v[j + 1]);
            if v1 == v0 {
                continue;
            }
            let s = (y - v0) / (v1 - v0);
            // Inner segments only within [0, 1]; the end segments extend outwards.
            let ok = (s >= 0.0 || j == 0) && (s <= 1.0 || j == k - 2);
            if ok {
                let x = self.x[j] + s * (self.x[j + 1] - self.x[j]);
                let closer = match best {
                    None => true,
                    Some(b) => (x - mid).abs() < (b - mid).abs(),
                };
                if closer {
                    best = Some(x);
                }
            }
        }
        best.unwrap_or(mid)
    }

    fn slope(&self, x: f64) -> f64 {
        let (j, _) = self.locate(x);
        (self.v[j + 1] - self.v[j]) / (self.x[j + 1] - self.x[j])
    }
}

/// A fitted Hammerstein–Wiener model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HwModel {
    pub input: PiecewiseLinear,
    /// [0 × nk, b₀ … b_{nb−1}]
    pub b: Vec<f64>,
    /// [1, f₁ … f_nf]
    pub f: Vec<f64>,
    pub output: PiecewiseLinear,
    pub nk: usize,
}

/// A fitted HW model and how the fit went.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HwFit {
    pub model: HwModel,
    /// Mean squared simulation error on the training data.
    pub loss: f64,
    pub iterations: usize,
    pub stop: LmStop,
}

impl HwModel {
    fn single(u: &[&[f64]]) -> Result<usize, SysidError> {
        match u {
            [u0] => Ok(u0.len()),
            _ => Err(SysidError::InputCount {
                expected: 1,
                found: u.len(),
            }),
        }
    }

    /// The linear block's output x = B/F · f(u), from rest.
    fn linear_output(&self, u: &[f64]) -> Vec<f64> {
        let s: Vec<f64> = u.iter().map(|&v| self.input.eval(v)).collect();
        filter(&self.b, &self.f, &s)
    }

    /// Simulation. With `SimInit::Measured` the first n outputs are the measured ones and the linear
    /// block's past outputs are set to g⁻¹(y) there (the branch of g nearest the breakpoints'
    /// middle when g is not monotone), so the simulation continues from the measured state.
    pub fn simulate(&self, u: &[&[f64]], init: SimInit<'_>) -> Result<Vec<f64>, SysidError> {
        let n = Self::single(u)?;
        let s: Vec<f64> = u[0].iter().map(|&v| self.input.eval(v)).collect();
        let mut x = vec![0.0; n];
        let mut out = vec![0.0; n];
        let n0 = init.samples();
        for (t, &y) in init.measured(n)?.iter().enumerate() {
            x[t] = self.output.inverse(y);
            out[t] = y;
        }
        for t in n0..n {
            let mut acc = 0.0;
            for (j, bj) in self.b.iter().enumerate().take(t + 1) {
                acc += bj * s[t - j];
            }
            for (j, fj) in self.f.iter().enumerate().skip(1).take(t) {
                acc -= fj * x[t - j];
            }
            x[t] = acc;
            out[t] = self.output.eval(acc);
        }
        Ok(out)
    }

    /// Output-error structure: the one-step predictor ignores y and equals the simulation.
    pub fn predict(&self, u: &[&[f64]], y: &[f64]) -> Result<Vec<f64>, SysidError> {
        check_data(u, y)?;
        self.simulate(u, SimInit::Zero)
    }
}

impl HwParams {
    pub fn fit(&self, u: &[&[f64]], y: &[f64], observer: &Observer) -> Result<HwFit, SysidError> {
        HwModel::single(u)?;
        check_data(u, y)?;
        if self.breakpoints < 2 || self.nb == 0 {
            return Err(SysidError::BadOrders(
                "HW needs nb ≥ 1 and at least 2 breakpoints".into(),
            ));
        }
        let k = self.breakpoints;
        let u0 = u[0];
        let (umin, umax) = u0.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
        // Linear block from an output-error fit (f = identity).
        let oe = PemParams {
            max_iterations: 30,
            ..PemParams::oe(self.nb, self.nf, self.nk)
        }
        .fit(u, y, &crate::progress::silent)?;
        let input = PiecewiseLinear::even(umin, umax, k, |x| x);
        let mut model = HwModel {
            input,
            b: oe.model.b[0].clone(),
            f: oe.model.f[0].clone(),
            output: PiecewiseLinear::even(0.0, 1.0, k, |x| x),
            nk: self.nk,
        };
        // g from least squares of y on the hat basis of x (the best static map after the OE block).
        let x = model.linear_output(u0);
        let (xmin, xmax) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
        model.output = PiecewiseLinear::even(xmin, xmax, k, |v| v);
        let basis = faer::Mat::from_fn(x.len(), k, |t, c| hat(&model.output, x[t], c));
        if let Ok(v) = lstsq(&basis, y) {
            model.output.v = v;
        }
        let problem = HwProblem {
            template: model.clone(),
            u: u0,
            y,
            basis_in: (0..k)
                .map(|c| {
                    let phi: Vec<f64> = u0.iter().map(|&v| hat(&model.input, v, c)).collect();
                    phi
                })
                .collect(),
        };
        let options = LmOptions {
            max_iterations: self.max_iterations,
            cost_tolerance: self.tolerance,
            ..LmOptions::default()
        };
        let report = levenberg_marquardt(&problem, &problem.pack(&model), &options, observer);
        let model = problem.unpack(&report.params);
        Ok(HwFit {
            model,
            loss: report.sse / y.len() as f64,
            iterations: report.iterations,
            stop: report.stop,
        })
    }
}

/// Value at `x` of the c-th basis function of a piecewise-linear map with fixed breakpoints.
fn hat(p: &PiecewiseLinear, x: f64, c: usize) -> f64 {
    let (j, s) = p.locate(x);
    if c == j {
        1.0 - s
    } else if c == j + 1 {
        s
    } else {
        0.0
    }
}

struct HwProblem<'a> {
    template: HwModel,
    u: &'a [f64],
    y: &'a [f64],
    /// Input basis functions evaluated on u (fixed: breakpoints do not move).
    basis_in: Vec<Vec<f64>>,
}

impl HwProblem<'_> {
    fn nb(&self) -> usize {
        self.template.b.len() - self.template.nk
    }

    fn nf(&self) -> usize {
        self.template.f.len() - 1
    }

    /// [input values (K), b (nb), f₁.. (nf), output values (K)]
    fn pack(&self, m: &HwModel) -> Vec<f64> {
        let mut p = m.input.v.clone();
        p.extend_from_slice(&m.b[m.nk..]);
        p.extend_from_slice(&m.f[1..]);
        p.extend_from_slice(&m.output.v);
        p
    }

    fn unpack(&self, p: &[f64]) -> HwModel {
        let k = self.template.input.v.len();
        let (nb, nf, nk) = (self.nb(), self.nf(), self.template.nk);
        let mut m = self.template.clone();
        m.input.v.copy_from_slice(&p[..k]);
        m.b[nk..].copy_from_slice(&p[k..k + nb]);
        m.f[1..].copy_from_slice(&p[k + nb..k + nb + nf]);
        m.output.v.copy_from_slice(&p[k + nb + nf..]);
        m
    }
}

impl LeastSquares for HwProblem<'_> {
    fn n_params(&self) -> usize {
        2 * self.template.input.v.len() + self.nb() + self.nf()
    }

    fn n_residuals(&self) -> usize {
        self.y.len()
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let m = self.unpack(p);
        if !is_stable(&m.f) {
            out.fill(f64::NAN);
            return;
        }
        let x = m.linear_output(self.u);
        for t in 0..out.len() {
            out[t] = self.y[t] - m.output.eval(x[t]);
        }
    }

    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        let m = self.unpack(p);
        let k = m.input.v.len();
        let (nb, nf, nk) = (self.nb(), self.nf(), m.nk);
        let n = self.y.len();
        let s: Vec<f64> = self.u.iter().map(|&v| m.input.eval(v)).collect();
        let x = filter(&m.b, &m.f, &s);
        let gp: Vec<f64> = x.iter().map(|&v| m.output.slope(v)).collect();
        // r = y − g(x): every column is −∂ŷ/∂p, and ∂ŷ/∂(linear-side p) = g'(x) ∂x/∂p.
        for (c, phi) in self.basis_in.iter().enumerate() {
            let dx = filter(&m.b, &m.f, phi);
            for t in 0..n {
                out[(t, c)] = -gp[t] * dx[t];
            }
        }
        let sf = filter(&[1.0], &m.f, &s);
        for j in 0..nb {
            let lag = nk + j;
            for t in 0..n {
                out[(t, k + j)] = if t >= lag { -gp[t] * sf[t - lag] } else { 0.0 };
            }
        }
        let xf = filter(&[1.0], &m.f, &x);
        for j in 1..=nf {
            for t in 0..n {
                out[(t, k + nb + j - 1)] = if t >= j { gp[t] * xf[t - j] } else { 0.0 };
            }
        }
        for c in 0..k {
            for t in 0..n {
                out[(t, k + nb + nf + c)] = -hat(&m.output, x[t], c);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn fits_a_saturating_wiener_system_and_has_the_right_jacobian() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let n = 800;
        let u: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
        let x = filter(&[0.0, 0.6, 0.3], &[1.0, -0.5], &u);
        let y: Vec<f64> = x.iter().map(|&v| (0.8 * v).tanh()).collect();
        let fit = HwParams::new(2, 1, 1)
            .fit(&[&u], &y, &crate::progress::silent)
            .unwrap();
        let sim = fit.model.simulate(&[&u], SimInit::Zero).unwrap();
        let fit_pc = crate::metrics::fit_percent(&y, &sim);
        // The OE start alone is limited by the saturation; the PWL output map must lift it.
        assert!(fit_pc > 95.0, "simulation fit {fit_pc}");
        assert_eq!(sim, fit.model.predict(&[&u], &y).unwrap());

        let problem = HwProblem {
            template: fit.model.clone(),
            u: &u,
            y: &y,
            basis_in: (0..10)
                .map(|c| u.iter().map(|&v| hat(&fit.model.input, v, c)).collect())
                .collect(),
        };
        let p = problem.pack(&fit.model);
        let mut jac = Mat::<f64>::zeros(n, p.len());
        problem.jacobian(&p, jac.as_mut());
        let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..p.len() {
            let mut q = p.clone();
            q[j] += 1e-7;
            problem.residuals(&q, &mut rp);
            q[j] -= 2e-7;
            problem.residuals(&q, &mut rm);
            // Kinks of the PWL maps make a few rows non-differentiable: compare the column norms.
            let fd: f64 = (0..n)
                .map(|t| ((rp[t] - rm[t]) / 2e-7 - jac[(t, j)]).powi(2))
                .sum::<f64>()
                .sqrt();
            let norm: f64 = (0..n).map(|t| jac[(t, j)].powi(2)).sum::<f64>().sqrt();
            assert!(
                fd <= 1e-3 * (1.0 + norm),
                "param {j}: difference {fd}, column norm {norm}"
            );
        }
    }
}
