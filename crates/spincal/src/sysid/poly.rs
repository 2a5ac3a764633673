//! Polynomial input–output models in MATLAB's idpoly convention:
//!
//! ```text
//! A(q) y(t) = Σᵢ Bᵢ(q)/Fᵢ(q) uᵢ(t − 0) + C(q)/D(q) e(t)
//! ```
//!
//! with q⁻¹ the backward shift. A, C, D, Fᵢ are monic (leading 1). Bᵢ carries the input delay as
//! nkᵢ leading zeros, so `b[i][k]` multiplies uᵢ(t − k).

use serde::{Deserialize, Serialize};

use super::SysidError;

/// MATLAB's `filter(b, a, x)` from zero initial conditions; `a[0]` must be non-zero (it is
/// normalised away).
pub fn filter(b: &[f64], a: &[f64], x: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; x.len()];
    filter_into(b, a, x, &mut out);
    out
}

/// [`filter`] into a preallocated buffer of the same length as `x`.
pub(crate) fn filter_into(b: &[f64], a: &[f64], x: &[f64], out: &mut [f64]) {
    assert_eq!(x.len(), out.len(), "filter_into: lengths differ");
    let a0 = a[0];
    let b: Vec<f64> = b.iter().map(|v| v / a0).collect();
    let a: Vec<f64> = a.iter().map(|v| v / a0).collect();
    for t in 0..x.len() {
        let mut acc = 0.0;
        for (k, bk) in b.iter().enumerate().take(t + 1) {
            acc += bk * x[t - k];
        }
        for (k, ak) in a.iter().enumerate().skip(1).take(t) {
            acc -= ak * out[t - k];
        }
        out[t] = acc;
    }
}

/// Product of two polynomials in q⁻¹.
pub fn poly_mul(p: &[f64], q: &[f64]) -> Vec<f64> {
    if p.is_empty() || q.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0.0; p.len() + q.len() - 1];
    for (i, pi) in p.iter().enumerate() {
        for (j, qj) in q.iter().enumerate() {
            out[i + j] += pi * qj;
        }
    }
    out
}

/// True when every root of the monic `a` (in z, i.e. of zⁿ + a₁zⁿ⁻¹ + …) lies strictly inside the
/// unit circle. Schur–Cohn step-down: all reflection coefficients must have |k| < 1.
pub(crate) fn is_stable(a: &[f64]) -> bool {
    let mut p: Vec<f64> = a.iter().map(|v| v / a[0]).collect();
    while p.len() > 1 {
        let n = p.len() - 1;
        let k = p[n];
        if !k.is_finite() || k.abs() >= 1.0 {
            return false;
        }
        let denom = 1.0 - k * k;
        p = (0..n).map(|i| (p[i] - k * p[n - i]) / denom).collect();
    }
    true
}

/// Roots (in z) of the monic polynomial `a` as (re, im) pairs, from the companion matrix.
pub fn roots(a: &[f64]) -> Result<Vec<(f64, f64)>, SysidError> {
    let n = a.len().saturating_sub(1);
    if n == 0 {
        return Ok(Vec::new());
    }
    let companion = faer::Mat::from_fn(n, n, |i, j| {
        if i == 0 {
            -a[j + 1] / a[0]
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    let eig = companion
        .eigenvalues()
        .map_err(|_| SysidError::Numerical("eigenvalues of a companion matrix did not converge".into()))?;
    Ok(eig.iter().map(|z| (z.re, z.im)).collect())
}

/// Monic polynomial with the given roots (complex roots must come in conjugate pairs).
pub(crate) fn from_roots(roots: &[(f64, f64)]) -> Vec<f64> {
    let mut re = vec![1.0];
    let mut im = vec![0.0];
    for &(rr, ri) in roots {
        let mut nre = vec![0.0; re.len() + 1];
        let mut nim = vec![0.0; im.len() + 1];
        for k in 0..re.len() {
            nre[k] += re[k];
            nim[k] += im[k];
            // (re + i·im)·(−r) shifted by one
            nre[k + 1] -= re[k] * rr - im[k] * ri;
            nim[k + 1] -= re[k] * ri + im[k] * rr;
        }
        re = nre;
        im = nim;
    }
    re
}

/// Reflects roots outside the unit circle to 1/z̄ (same magnitude response up to a gain, as MATLAB's
/// `fstab`), and pulls roots on or near the circle to radius `max_radius`.
pub(crate) fn stabilize(a: &[f64], max_radius: f64) -> Result<Vec<f64>, SysidError> {
    if is_stable(a) && roots_radius(a)? <= max_radius {
        return Ok(a.iter().map(|v| v / a[0]).collect());
    }
    let r: Vec<(f64, f64)> = roots(a)?
        .into_iter()
        .map(|(re, im)| {
            let m2 = re * re + im * im;
            let (re, im) = if m2 > 1.0 { (re / m2, im / m2) } else { (re, im) };
            let m = (re * re + im * im).sqrt();
            if m > max_radius {
                (re * max_radius / m, im * max_radius / m)
            } else {
                (re, im)
            }
        })
        .collect();
    Ok(from_roots(&r))
}

fn roots_radius(a: &[f64]) -> Result<f64, SysidError> {
    Ok(roots(a)?
        .iter()
        .fold(0.0f64, |m, (re, im)| m.max((re * re + im * im).sqrt())))
}

/// How a simulation starts.
#[derive(Debug, Clone, Copy)]
pub enum SimInit<'a> {
    /// All past inputs and outputs zero.
    Zero,
    /// The first `n` outputs are the measured `y[..n]` (the benchmarks' protocol); the simulation
    /// proper starts at sample `n`, with the measured inputs as past inputs.
    Measured { y: &'a [f64], n: usize },
}

impl<'a> SimInit<'a> {
    /// How many leading samples are copied from the measurement (excluded from scoring).
    pub fn samples(&self) -> usize {
        match self {
            SimInit::Zero => 0,
            SimInit::Measured { n, .. } => *n,
        }
    }

    /// The measured outputs that start a simulation of `len` samples, checked to cover `n` of them
    /// (empty for [`SimInit::Zero`]).
    pub fn measured(&self, len: usize) -> Result<&'a [f64], SysidError> {
        match *self {
            SimInit::Zero => Ok(&[]),
            SimInit::Measured { y, n } if y.len() < n || n > len => Err(SysidError::TooFewSamples {
                needed: n,
                available: y.len().min(len),
            }),
            SimInit::Measured { y, n } => Ok(&y[..n]),
        }
    }
}

/// A fitted polynomial model (ARX, ARMAX, OE, BJ or any general idpoly).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolyModel {
    /// [1, a₁, …, a_na]
    pub a: Vec<f64>,
    /// One per input: [0 × nk, b₀, …, b_{nb−1}] (idpoly convention).
    pub b: Vec<Vec<f64>>,
    /// [1, c₁, …, c_nc]
    pub c: Vec<f64>,
    /// [1, d₁, …, d_nd]
    pub d: Vec<f64>,
    /// One per input: [1, f₁, …, f_nf]
    pub f: Vec<Vec<f64>>,
    /// Input delays, one per input (also visible as the leading zeros of `b`).
    pub nk: Vec<usize>,
}

impl PolyModel {
    pub fn n_inputs(&self) -> usize {
        self.b.len()
    }

    /// Orders as MATLAB writes them, e.g. "BJ [nb nc nd nf nk] = [4 4 4 4 1]".
    pub fn structure(&self) -> String {
        let na = self.a.len() - 1;
        let nc = self.c.len() - 1;
        let nd = self.d.len() - 1;
        let nb: Vec<usize> = self.b.iter().zip(&self.nk).map(|(b, nk)| b.len() - nk).collect();
        let nf: Vec<usize> = self.f.iter().map(|f| f.len() - 1).collect();
        let list = |v: &[usize]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ");
        let any_f = nf.iter().any(|&n| n > 0);
        match (na > 0, nc > 0, nd > 0, any_f) {
            (_, false, false, false) => format!("ARX [na nb nk] = [{na} {} {}]", list(&nb), list(&self.nk)),
            (true, true, false, false) => {
                format!(
                    "ARMAX [na nb nc nk] = [{na} {} {nc} {}]",
                    list(&nb),
                    list(&self.nk)
                )
            }
            (false, false, false, true) => {
                format!("OE [nb nf nk] = [{} {} {}]", list(&nb), list(&nf), list(&self.nk))
            }
            (false, _, _, _) => format!(
                "BJ [nb nc nd nf nk] = [{} {nc} {nd} {} {}]",
                list(&nb),
                list(&nf),
                list(&self.nk)
            ),
            _ => format!(
                "idpoly [na nb nc nd nf nk] = [{na} {} {nc} {nd} {} {}]",
                list(&nb),
                list(&nf),
                list(&self.nk)
            ),
        }
    }

    fn check_inputs(&self, u: &[&[f64]], n: usize) -> Result<(), SysidError> {
        if u.len() != self.n_inputs() {
            return Err(SysidError::InputCount {
                expected: self.n_inputs(),
                found: u.len(),
            });
        }
        for (i, ui) in u.iter().enumerate() {
            if ui.len() != n {
                return Err(SysidError::LengthMismatch {
                    what: format!("input {}", i + 1),
                    expected: n,
                    found: ui.len(),
                });
            }
        }
        Ok(())
    }

    /// The deterministic part as one difference equation: y = Σᵢ numᵢ/den · uᵢ with
    /// den = A·ΠFⱼ and numᵢ = Bᵢ·Πⱼ≠ᵢ Fⱼ.
    pub fn transfer(&self) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut den = self.a.clone();
        for f in &self.f {
            den = poly_mul(&den, f);
        }
        let nums = (0..self.n_inputs())
            .map(|i| {
                let mut num = self.b[i].clone();
                for (j, f) in self.f.iter().enumerate() {
                    if j != i {
                        num = poly_mul(&num, f);
                    }
                }
                num
            })
            .collect();
        (nums, den)
    }

    /// Infinite-horizon simulation y = Σ Bᵢ/(A Fᵢ) uᵢ (noise model ignored).
    pub fn simulate(&self, u: &[&[f64]], init: SimInit<'_>) -> Result<Vec<f64>, SysidError> {
        let n = u.first().map_or(0, |u0| u0.len());
        self.check_inputs(u, n)?;
        let (nums, den) = self.transfer();
        let n0 = init.samples();
        let start = init.measured(n)?;
        let mut out = vec![0.0; n];
        out[..start.len()].copy_from_slice(start);
        for t in n0..n {
            let mut acc = 0.0;
            for (num, ui) in nums.iter().zip(u) {
                for (k, c) in num.iter().enumerate().take(t + 1) {
                    acc += c * ui[t - k];
                }
            }
            for (k, c) in den.iter().enumerate().skip(1).take(t) {
                acc -= c * out[t - k];
            }
            out[t] = acc;
        }
        Ok(out)
    }

    /// One-step prediction errors e = D/C · (A y − Σ Bᵢ/Fᵢ uᵢ), zero initial conditions.
    pub fn prediction_errors(&self, u: &[&[f64]], y: &[f64]) -> Result<Vec<f64>, SysidError> {
        self.check_inputs(u, y.len())?;
        let mut v = filter(&self.a, &[1.0], y);
        for ((b, f), ui) in self.b.iter().zip(&self.f).zip(u) {
            let w = filter(b, f, ui);
            v.iter_mut().zip(&w).for_each(|(vi, wi)| *vi -= wi);
        }
        Ok(filter(&self.d, &self.c, &v))
    }

    /// One-step-ahead prediction ŷ(t | t−1) = y(t) − e(t), zero initial conditions.
    pub fn predict(&self, u: &[&[f64]], y: &[f64]) -> Result<Vec<f64>, SysidError> {
        let e = self.prediction_errors(u, y)?;
        Ok(y.iter().zip(&e).map(|(yi, ei)| yi - ei).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_matches_hand_recursion() {
        // y(t) = x(t) + 0.5 x(t−1) + 0.9 y(t−1)
        let x = [1.0, 0.0, 0.0, 2.0];
        let y = filter(&[1.0, 0.5], &[1.0, -0.9], &x);
        let expected = [1.0, 1.4, 1.26, 1.26 * 0.9 + 2.0];
        for (a, b) in y.iter().zip(expected) {
            assert!((a - b).abs() < 1e-12, "{y:?}");
        }
    }

    #[test]
    fn stability_test_agrees_with_roots() {
        assert!(is_stable(&[1.0, -1.5, 0.7]));
        assert!(!is_stable(&[1.0, -2.5, 1.0])); // roots 2 and 0.5
        assert!(!is_stable(&[1.0, 0.0, 1.0])); // on the circle
        let s = stabilize(&[1.0, -2.5, 1.0], 0.999).unwrap();
        assert!(is_stable(&s));
        // 2 is reflected to 0.5: (z − 0.5)² = z² − z + 0.25
        assert!((s[1] + 1.0).abs() < 1e-12 && (s[2] - 0.25).abs() < 1e-12, "{s:?}");
        let p = from_roots(&[(0.5, 0.3), (0.5, -0.3), (-0.2, 0.0)]);
        let mut r = roots(&p).unwrap();
        r.sort_by(|a, b| {
            a.0.partial_cmp(&b.0)
                .unwrap()
                .then(a.1.partial_cmp(&b.1).unwrap())
        });
        assert!((r[0].0 + 0.2).abs() < 1e-12 && (r[1].1 + 0.3).abs() < 1e-12 && (r[2].1 - 0.3).abs() < 1e-12);
    }

    #[test]
    fn simulation_and_prediction_of_an_oe_model() {
        let m = PolyModel {
            a: vec![1.0],
            b: vec![vec![0.0, 1.0, 0.5]],
            c: vec![1.0],
            d: vec![1.0],
            f: vec![vec![1.0, -0.8]],
            nk: vec![1],
        };
        let u: Vec<f64> = (0..50).map(|t| ((t * 7) % 5) as f64 - 2.0).collect();
        let y = m.simulate(&[&u], SimInit::Zero).unwrap();
        assert_eq!(y, filter(&[0.0, 1.0, 0.5], &[1.0, -0.8], &u));
        // An OE model's one-step prediction is its simulation.
        let p = m.predict(&[&u], &y).unwrap();
        assert!(p.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-12));
        // Starting from measured outputs reproduces the exact noise-free output.
        let ym = m.simulate(&[&u], SimInit::Measured { y: &y, n: 5 }).unwrap();
        assert!(ym.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-12));
        assert_eq!(m.structure(), "OE [nb nf nk] = [2 1 1]");
    }
}
