//! ARX [na nb nk]: A(q) y = Σ Bᵢ(q) uᵢ + e, fitted by linear least squares through a QR
//! factorisation of the regressor matrix (never the normal equations, which square its condition).
//! The QR is streamed over row blocks of [Φ | y] (tsqr.rs), so Φ is never materialised.

use faer::prelude::SolveLstsq;
use faer::Mat;
use serde::{Deserialize, Serialize};

use super::poly::PolyModel;
use super::tsqr::streaming_qr;
use super::{check_data, SysidError};

/// Orders of an ARX model; `nb` and `nk` have one entry per input.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ArxParams {
    pub na: usize,
    pub nb: Vec<usize>,
    pub nk: Vec<usize>,
}

/// A fitted ARX model with its least-squares loss.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ArxFit {
    pub model: PolyModel,
    /// Mean squared equation error over the rows used.
    pub loss: f64,
    /// First sample whose full regressor is available (rows `first_row..N` were used).
    pub first_row: usize,
}

impl ArxParams {
    pub fn siso(na: usize, nb: usize, nk: usize) -> ArxParams {
        ArxParams {
            na,
            nb: vec![nb],
            nk: vec![nk],
        }
    }

    /// First sample index at which every lagged regressor exists.
    pub fn first_row(&self) -> usize {
        super::first_complete_row(self.na, &self.nb, &self.nk)
    }

    /// Least-squares fit on rows `first_row()..N`. Regressor order: −y(t−1..na), then per input
    /// uᵢ(t−nkᵢ .. t−nkᵢ−nbᵢ+1).
    pub fn fit(&self, u: &[&[f64]], y: &[f64]) -> Result<ArxFit, SysidError> {
        if self.nb.len() != u.len() || self.nk.len() != u.len() {
            return Err(SysidError::BadOrders(format!(
                "ARX orders give {} nb and {} nk values for {} inputs",
                self.nb.len(),
                self.nk.len(),
                u.len()
            )));
        }
        check_data(u, y)?;
        let t0 = self.first_row();
        let n_par = self.na + self.nb.iter().sum::<usize>();
        if n_par == 0 {
            return Err(SysidError::BadOrders("ARX model with no parameters".into()));
        }
        if y.len() < t0 + n_par {
            return Err(SysidError::TooFewSamples {
                needed: t0 + n_par,
                available: y.len(),
            });
        }
        // Streaming Householder QR of [Φ | y]: R's last column is Qᵀy, its last diagonal entry
        // ±‖y − Φθ‖ (see tsqr.rs).
        let m = y.len() - t0;
        let tri = streaming_qr(m, n_par + 1, |r0, rows, block, ld| {
            fill_regressor_block(self, u, y, t0 + r0, rows, block, ld)
        });
        let theta = tri.solve_last_column().ok_or_else(rank_deficient)?;
        let loss = tri.at(n_par, n_par).powi(2) / m as f64;
        let mut b = Vec::new();
        let mut k = self.na;
        for (nb, nk) in self.nb.iter().zip(&self.nk) {
            let mut bi = vec![0.0; nk + nb];
            bi[*nk..].copy_from_slice(&theta[k..k + nb]);
            b.push(bi);
            k += nb;
        }
        let mut a = vec![1.0];
        a.extend_from_slice(&theta[..self.na]);
        Ok(ArxFit {
            model: PolyModel {
                a,
                b,
                c: vec![1.0],
                d: vec![1.0],
                f: vec![vec![1.0]; u.len()],
                nk: self.nk.clone(),
            },
            loss,
            first_row: t0,
        })
    }
}

/// Writes rows `s..s + rows` of [Φ | y] column-major into `block` (column j at `j * ld`).
/// Each column is a shifted copy of y or an input, so this is a few slice copies.
fn fill_regressor_block(
    p: &ArxParams,
    u: &[&[f64]],
    y: &[f64],
    s: usize,
    rows: usize,
    block: &mut [f64],
    ld: usize,
) {
    let mut cols = block.chunks_mut(ld);
    for k in 0..p.na {
        let dst = &mut cols.next().expect("block has a column per regressor")[..rows];
        let src = &y[s - k - 1..s - k - 1 + rows];
        dst.iter_mut().zip(src).for_each(|(d, v)| *d = -v);
    }
    for ((nb, nk), ui) in p.nb.iter().zip(&p.nk).zip(u) {
        for j in 0..*nb {
            let dst = &mut cols.next().expect("block has a column per regressor")[..rows];
            dst.copy_from_slice(&ui[s - nk - j..s - nk - j + rows]);
        }
    }
    cols.next().expect("block has a target column")[..rows].copy_from_slice(&y[s..s + rows]);
}

/// Regressor matrix and target for rows t0..N.
pub(crate) fn regressors(p: &ArxParams, u: &[&[f64]], y: &[f64], t0: usize) -> (Mat<f64>, Vec<f64>) {
    let m = y.len() - t0;
    let n_par = p.na + p.nb.iter().sum::<usize>();
    let mut phi = Mat::<f64>::zeros(m, n_par);
    let mut col = 0;
    for k in 0..p.na {
        let src = &y[t0 - k - 1..t0 - k - 1 + m];
        phi.col_as_slice_mut(col)
            .iter_mut()
            .zip(src)
            .for_each(|(d, v)| *d = -v);
        col += 1;
    }
    for ((nb, nk), ui) in p.nb.iter().zip(&p.nk).zip(u) {
        for j in 0..*nb {
            phi.col_as_slice_mut(col)
                .copy_from_slice(&ui[t0 - nk - j..t0 - nk - j + m]);
            col += 1;
        }
    }
    (phi, y[t0..].to_vec())
}

fn rank_deficient() -> SysidError {
    SysidError::Numerical(
        "the least-squares problem is rank deficient (constant or collinear regressors?)".into(),
    )
}

/// Least-squares solution of Φθ ≈ target via Householder QR.
pub(crate) fn lstsq(phi: &Mat<f64>, target: &[f64]) -> Result<Vec<f64>, SysidError> {
    let rhs = Mat::from_fn(target.len(), 1, |i, _| target[i]);
    let x = phi.qr().solve_lstsq(&rhs);
    let theta: Vec<f64> = (0..phi.ncols()).map(|i| x[(i, 0)]).collect();
    if theta.iter().all(|v| v.is_finite()) {
        Ok(theta)
    } else {
        Err(rank_deficient())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_noise_free_multi_input_arx_exactly() {
        // y = 1.2 y(t−1) − 0.5 y(t−2) + 0.7 u1(t−1) + 0.3 u1(t−2) − 0.4 u2(t−2)
        let n = 300;
        let u1: Vec<f64> = (0..n).map(|t| ((t * 37 % 11) as f64 - 5.0) / 3.0).collect();
        let u2: Vec<f64> = (0..n).map(|t| ((t * 13 % 7) as f64 - 3.0) / 2.0).collect();
        let mut y = vec![0.0; n];
        for t in 2..n {
            y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.7 * u1[t - 1] + 0.3 * u1[t - 2] - 0.4 * u2[t - 2];
        }
        let fit = ArxParams {
            na: 2,
            nb: vec![2, 1],
            nk: vec![1, 2],
        }
        .fit(&[&u1, &u2], &y)
        .unwrap();
        let m = &fit.model;
        let close =
            |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-10);
        assert!(close(&m.a, &[1.0, -1.2, 0.5]), "{:?}", m.a);
        assert!(close(&m.b[0], &[0.0, 0.7, 0.3]), "{:?}", m.b);
        assert!(close(&m.b[1], &[0.0, 0.0, -0.4]), "{:?}", m.b);
        assert!(fit.loss < 1e-20);
        assert!(m.structure().starts_with("ARX"));
    }
}
