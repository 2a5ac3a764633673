//! Prediction-error method for the general idpoly model, used for OE, ARMAX and Box–Jenkins:
//!
//! ```text
//! A y = Σ Bᵢ/Fᵢ uᵢ + C/D e,   e(t) = D/C · (A y − Σ Bᵢ/Fᵢ uᵢ)
//! ```
//!
//! Initialisation (as MATLAB's `pem` does in spirit): ARX, then instrumental variables for B/F,
//! then Hannan–Rissanen for the noise model C/D, every monic polynomial whose roots must be inside
//! the unit circle reflected there. Refinement: Levenberg–Marquardt (Gauss–Newton with damping) on
//! the one-step prediction errors, with the exact gradient obtained by filtering signals. Trial
//! steps that make F, C or D unstable are rejected (their cost is NaN), which shortens the step
//! until the polynomials stay stable. Zero initial conditions throughout.

use faer::prelude::Solve;
use faer::{Mat, MatMut};
use serde::{Deserialize, Serialize};

use super::arx::{regressors, ArxParams};
use super::poly::{filter, is_stable, poly_mul, stabilize, PolyModel, SimInit};
use super::{check_data, SysidError};
use crate::optim::{levenberg_marquardt, LeastSquares, LmOptions, LmStop};
use crate::progress::Observer;

/// Orders and solver limits of a prediction-error fit. `nb`, `nf`, `nk` have one entry per input.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PemParams {
    pub na: usize,
    pub nb: Vec<usize>,
    pub nc: usize,
    pub nd: usize,
    pub nf: Vec<usize>,
    pub nk: Vec<usize>,
    /// Levenberg–Marquardt iteration limit.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the loss by less than this fraction.
    pub tolerance: f64,
}

/// A fitted prediction-error model and how the fit went.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PemFit {
    pub model: PolyModel,
    /// The initial (ARX / IV / Hannan–Rissanen) model the search started from.
    pub initial: PolyModel,
    /// Mean squared one-step prediction error on the training rows (MATLAB's loss function, SISO).
    pub loss: f64,
    pub initial_loss: f64,
    pub iterations: usize,
    pub stop: LmStop,
}

impl PemParams {
    fn with(na: usize, nb: usize, nc: usize, nd: usize, nf: usize, nk: usize) -> PemParams {
        PemParams {
            na,
            nb: vec![nb],
            nc,
            nd,
            nf: vec![nf],
            nk: vec![nk],
            max_iterations: 100,
            tolerance: 1e-10,
        }
    }

    /// Box–Jenkins y = B/F u + C/D e, single input.
    pub fn bj(nb: usize, nc: usize, nd: usize, nf: usize, nk: usize) -> PemParams {
        PemParams::with(0, nb, nc, nd, nf, nk)
    }

    /// Output error y = B/F u + e, single input.
    pub fn oe(nb: usize, nf: usize, nk: usize) -> PemParams {
        PemParams::with(0, nb, 0, 0, nf, nk)
    }

    /// ARMAX A y = B u + C e, single input.
    pub fn armax(na: usize, nb: usize, nc: usize, nk: usize) -> PemParams {
        PemParams::with(na, nb, nc, 0, 0, nk)
    }

    fn validate(&self, n_inputs: usize) -> Result<(), SysidError> {
        if self.nb.len() != n_inputs || self.nf.len() != n_inputs || self.nk.len() != n_inputs {
            return Err(SysidError::BadOrders(format!(
                "nb, nf and nk need one value per input ({n_inputs}); got {}, {}, {}",
                self.nb.len(),
                self.nf.len(),
                self.nk.len()
            )));
        }
        if self.na > 0 && self.nf.iter().any(|&n| n > 0) {
            return Err(SysidError::BadOrders(
                "models with both A and F polynomials are not supported (use ARMAX or BJ)".into(),
            ));
        }
        if self.nb.iter().all(|&n| n == 0) {
            return Err(SysidError::BadOrders(
                "nb must be at least 1 for some input".into(),
            ));
        }
        if self.max_iterations == 0 && self.tolerance.is_nan() {
            return Err(SysidError::BadOrders("tolerance is NaN".into()));
        }
        Ok(())
    }

    fn layout(&self) -> Layout {
        Layout {
            na: self.na,
            nb: self.nb.clone(),
            nc: self.nc,
            nd: self.nd,
            nf: self.nf.clone(),
            nk: self.nk.clone(),
        }
    }

    /// Fits the model to inputs `u` (one slice per input) and output `y`.
    pub fn fit(&self, u: &[&[f64]], y: &[f64], observer: &Observer) -> Result<PemFit, SysidError> {
        self.validate(u.len())?;
        check_data(u, y)?;
        let layout = self.layout();
        let t0 = layout.first_row();
        if y.len() < t0 + 2 * layout.n_params() {
            return Err(SysidError::TooFewSamples {
                needed: t0 + 2 * layout.n_params(),
                available: y.len(),
            });
        }
        let initial = initial_model(self, u, y)?;
        let problem = PemProblem {
            u: u.to_vec(),
            y,
            layout: layout.clone(),
            t0,
        };
        let p0 = layout.pack(&initial);
        let m = problem.n_residuals() as f64;
        let options = LmOptions {
            max_iterations: self.max_iterations,
            cost_tolerance: self.tolerance,
            ..LmOptions::default()
        };
        let mut r0 = vec![0.0; problem.n_residuals()];
        problem.residuals(&p0, &mut r0);
        let initial_loss = r0.iter().map(|v| v * v).sum::<f64>() / m;
        if !initial_loss.is_finite() {
            return Err(SysidError::Numerical(
                "the initial model's prediction errors are not finite".into(),
            ));
        }
        let report = levenberg_marquardt(&problem, &p0, &options, observer);
        Ok(PemFit {
            model: layout.unpack(&report.params),
            initial,
            loss: report.sse / m,
            initial_loss,
            iterations: report.iterations,
            stop: report.stop,
        })
    }
}

/// Where each polynomial's free coefficients sit in the parameter vector:
/// [a₁..a_na, (bᵢ₀..bᵢ,nbᵢ−1)ᵢ, c₁..c_nc, d₁..d_nd, (fᵢ₁..fᵢ,nfᵢ)ᵢ].
#[derive(Debug, Clone)]
struct Layout {
    na: usize,
    nb: Vec<usize>,
    nc: usize,
    nd: usize,
    nf: Vec<usize>,
    nk: Vec<usize>,
}

impl Layout {
    fn n_params(&self) -> usize {
        self.na + self.nb.iter().sum::<usize>() + self.nc + self.nd + self.nf.iter().sum::<usize>()
    }

    /// First residual used: where A y and the B regressors are fully inside the data.
    fn first_row(&self) -> usize {
        super::first_complete_row(self.na, &self.nb, &self.nk)
    }

    fn unpack(&self, p: &[f64]) -> PolyModel {
        let mut k = 0;
        let mut take = |n: usize| {
            let v = &p[k..k + n];
            k += n;
            v
        };
        let monic = |v: &[f64]| [&[1.0][..], v].concat();
        let a = monic(take(self.na));
        let b = self
            .nb
            .iter()
            .zip(&self.nk)
            .map(|(&nb, &nk)| [vec![0.0; nk], take(nb).to_vec()].concat())
            .collect();
        let c = monic(take(self.nc));
        let d = monic(take(self.nd));
        let f = self.nf.iter().map(|&n| monic(take(n))).collect();
        PolyModel {
            a,
            b,
            c,
            d,
            f,
            nk: self.nk.clone(),
        }
    }

    fn pack(&self, m: &PolyModel) -> Vec<f64> {
        let mut p = Vec::with_capacity(self.n_params());
        let tail = |v: &[f64], n: usize, p: &mut Vec<f64>| {
            for k in 1..=n {
                p.push(v.get(k).copied().unwrap_or(0.0));
            }
        };
        tail(&m.a, self.na, &mut p);
        for ((bi, nb), nk) in m.b.iter().zip(&self.nb).zip(&self.nk) {
            for j in 0..*nb {
                p.push(bi.get(nk + j).copied().unwrap_or(0.0));
            }
        }
        tail(&m.c, self.nc, &mut p);
        tail(&m.d, self.nd, &mut p);
        for (fi, nf) in m.f.iter().zip(&self.nf) {
            tail(fi, *nf, &mut p);
        }
        p
    }
}

struct PemProblem<'a> {
    u: Vec<&'a [f64]>,
    y: &'a [f64],
    layout: Layout,
    t0: usize,
}

impl PemProblem<'_> {
    /// Unstable F, C or D make the predictor (or its gradient) diverge: such points are not admissible.
    fn admissible(m: &PolyModel) -> bool {
        is_stable(&m.c) && is_stable(&m.d) && m.f.iter().all(|f| is_stable(f))
    }
}

impl LeastSquares for PemProblem<'_> {
    fn n_params(&self) -> usize {
        self.layout.n_params()
    }

    fn n_residuals(&self) -> usize {
        self.y.len() - self.t0
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let m = self.layout.unpack(p);
        if !Self::admissible(&m) {
            out.fill(f64::NAN);
            return;
        }
        match m.prediction_errors(&self.u, self.y) {
            Ok(e) => out.copy_from_slice(&e[self.t0..]),
            Err(_) => out.fill(f64::NAN),
        }
    }

    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        let m = self.layout.unpack(p);
        let t0 = self.t0;
        let rows = self.n_residuals();
        // Column j of the Jacobian is `sign · signal(t − shift)` for t = t0.., zero before the data.
        let mut put = |col: usize, signal: &[f64], shift: usize, sign: f64| {
            for r in 0..rows {
                let t = t0 + r;
                out[(r, col)] = if t >= shift { sign * signal[t - shift] } else { 0.0 };
            }
        };
        let w: Vec<Vec<f64>> =
            m.b.iter()
                .zip(&m.f)
                .zip(&self.u)
                .map(|((b, f), u)| filter(b, f, u))
                .collect();
        let mut v = filter(&m.a, &[1.0], self.y);
        for wi in &w {
            v.iter_mut().zip(wi).for_each(|(a, b)| *a -= b);
        }
        let mut col = 0;
        // ∂e/∂aₖ = D/C · y(t−k)
        if self.layout.na > 0 {
            let yf = filter(&m.d, &m.c, self.y);
            for k in 1..=self.layout.na {
                put(col, &yf, k, 1.0);
                col += 1;
            }
        }
        // ∂e/∂bᵢⱼ = −D/(C Fᵢ) · uᵢ(t − nkᵢ − j)
        for i in 0..self.u.len() {
            let cf = poly_mul(&m.c, &m.f[i]);
            let uf = filter(&m.d, &cf, self.u[i]);
            for j in 0..self.layout.nb[i] {
                put(col, &uf, self.layout.nk[i] + j, -1.0);
                col += 1;
            }
        }
        let e = filter(&m.d, &m.c, &v);
        // ∂e/∂cₖ = −1/C · e(t−k)
        if self.layout.nc > 0 {
            let ec = filter(&[1.0], &m.c, &e);
            for k in 1..=self.layout.nc {
                put(col, &ec, k, -1.0);
                col += 1;
            }
        }
        // ∂e/∂dₖ = 1/C · v(t−k), v = A y − Σ Bᵢ/Fᵢ uᵢ
        if self.layout.nd > 0 {
            let vc = filter(&[1.0], &m.c, &v);
            for k in 1..=self.layout.nd {
                put(col, &vc, k, 1.0);
                col += 1;
            }
        }
        // ∂e/∂fᵢₖ = D/(C Fᵢ) · wᵢ(t−k), wᵢ = Bᵢ/Fᵢ uᵢ
        for ((&nf, fi), wi) in self.layout.nf.iter().zip(&m.f).zip(&w) {
            if nf == 0 {
                continue;
            }
            let cf = poly_mul(&m.c, fi);
            let wf = filter(&m.d, &cf, wi);
            for k in 1..=nf {
                put(col, &wf, k, 1.0);
                col += 1;
            }
        }
    }
}

/// Stability margin for initial polynomials: roots are pulled inside this radius.
const MAX_RADIUS: f64 = 0.999;

/// ARX → instrumental variables for B/F → Hannan–Rissanen for C/D.
fn initial_model(params: &PemParams, u: &[&[f64]], y: &[f64]) -> Result<PolyModel, SysidError> {
    let nf_max = params.nf.iter().copied().max().unwrap_or(0);
    let n_den = params.na.max(nf_max);
    let arx = ArxParams {
        na: n_den,
        nb: params.nb.clone(),
        nk: params.nk.clone(),
    };
    let mut det = arx.fit(u, y)?.model;
    if nf_max > 0 {
        // The ARX denominator is biased by coloured noise; IV with noise-free instruments simulated
        // from the current model removes that bias (two passes, as IV4 iterates).
        for _ in 0..2 {
            det.a = stabilize(&det.a, MAX_RADIUS)?;
            let x = det.simulate(u, SimInit::Zero)?;
            match iv_step(&arx, u, y, &x) {
                Ok(m) => det = m,
                Err(_) => break,
            }
        }
    }
    let den = stabilize(&det.a, MAX_RADIUS)?;
    let mut model = PolyModel {
        a: vec![1.0],
        b: det.b.clone(),
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0]; u.len()],
        nk: params.nk.clone(),
    };
    if params.na > 0 {
        model.a = den;
    } else {
        // One common denominator serves every input with its own order (truncated or padded).
        for (fi, &nf) in model.f.iter_mut().zip(&params.nf) {
            let mut f: Vec<f64> = (0..=nf).map(|k| den.get(k).copied().unwrap_or(0.0)).collect();
            if !is_stable(&f) {
                f = stabilize(&f, MAX_RADIUS)?;
            }
            *fi = f;
        }
    }
    if params.nc + params.nd > 0 {
        // Residual of the deterministic part: v = A y − Σ B/F u ≈ C/D e.
        let mut v = filter(&model.a, &[1.0], y);
        for ((b, f), ui) in model.b.iter().zip(&model.f).zip(u) {
            let w = filter(b, f, ui);
            v.iter_mut().zip(&w).for_each(|(a, b)| *a -= b);
        }
        let (c, d) = hannan_rissanen(&v, params.nc, params.nd)?;
        model.c = stabilize(&c, MAX_RADIUS)?;
        model.d = stabilize(&d, MAX_RADIUS)?;
    }
    Ok(model)
}

/// One instrumental-variable solve of the ARX structure with instruments built from `x` in place
/// of y: (ZᵀΦ) θ = Zᵀy.
fn iv_step(arx: &ArxParams, u: &[&[f64]], y: &[f64], x: &[f64]) -> Result<PolyModel, SysidError> {
    let t0 = arx.first_row();
    let (phi, target) = regressors(arx, u, y, t0);
    let (z, _) = regressors(arx, u, x, t0);
    let ztphi = z.transpose() * &phi;
    let rhs = Mat::from_fn(target.len(), 1, |i, _| target[i]);
    let zty = z.transpose() * &rhs;
    let theta = ztphi.partial_piv_lu().solve(&zty);
    if (0..theta.nrows()).any(|i| !theta[(i, 0)].is_finite()) {
        return Err(SysidError::Numerical(
            "instrumental-variable system is singular".into(),
        ));
    }
    let mut a = vec![1.0];
    a.extend((0..arx.na).map(|i| theta[(i, 0)]));
    let mut k = arx.na;
    let b = arx
        .nb
        .iter()
        .zip(&arx.nk)
        .map(|(nb, nk)| {
            let mut bi = vec![0.0; nk + nb];
            for j in 0..*nb {
                bi[nk + j] = theta[(k + j, 0)];
            }
            k += nb;
            bi
        })
        .collect();
    Ok(PolyModel {
        a,
        b,
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0]; u.len()],
        nk: arx.nk.clone(),
    })
}

/// Hannan–Rissanen for D v = C e: a long AR model estimates e, then v(t) is regressed on its own
/// past and the estimated past innovations. Returns (C, D).
fn hannan_rissanen(v: &[f64], nc: usize, nd: usize) -> Result<(Vec<f64>, Vec<f64>), SysidError> {
    let long = (3 * (nc + nd)).max(20).min(v.len() / 10).max(nc + nd);
    let ar = ArxParams {
        na: long,
        nb: vec![],
        nk: vec![],
    }
    .fit(&[], v)?;
    let e = filter(&ar.model.a, &[1.0], v);
    let arma = ArxParams {
        na: nd,
        nb: vec![nc],
        nk: vec![1],
    }
    .fit(&[&e], v)?;
    let mut c = vec![1.0];
    c.extend_from_slice(&arma.model.b[0][1..]);
    Ok((c, arma.model.a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sysid::poly::filter;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// Checks the analytic Jacobian against central differences on a BJ model.
    #[test]
    fn jacobian_matches_finite_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 200;
        let u: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
        let e: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
        let mut y = filter(&[0.0, 1.0, 0.4], &[1.0, -0.6, 0.2], &u);
        let noise = filter(&[1.0, 0.3], &[1.0, -0.5], &e);
        y.iter_mut().zip(&noise).for_each(|(a, b)| *a += 0.3 * b);
        let params = PemParams {
            na: 1,
            nb: vec![2],
            nc: 1,
            nd: 1,
            nf: vec![0],
            nk: vec![1],
            max_iterations: 10,
            tolerance: 1e-8,
        };
        for params in [params, PemParams::bj(2, 1, 1, 2, 1)] {
            let layout = params.layout();
            let problem = PemProblem {
                u: vec![&u],
                y: &y,
                layout: layout.clone(),
                t0: layout.first_row(),
            };
            let p: Vec<f64> = (0..layout.n_params()).map(|k| 0.1 + 0.05 * k as f64).collect();
            let m = problem.n_residuals();
            let mut jac = Mat::<f64>::zeros(m, p.len());
            problem.jacobian(&p, jac.as_mut());
            let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
            for j in 0..p.len() {
                let h = 1e-6;
                let mut q = p.clone();
                q[j] += h;
                problem.residuals(&q, &mut rp);
                q[j] -= 2.0 * h;
                problem.residuals(&q, &mut rm);
                for r in 0..m {
                    let fd = (rp[r] - rm[r]) / (2.0 * h);
                    assert!(
                        (fd - jac[(r, j)]).abs() < 1e-6 * (1.0 + fd.abs()),
                        "param {j} row {r}: {fd} vs {}",
                        jac[(r, j)]
                    );
                }
            }
        }
    }
}
