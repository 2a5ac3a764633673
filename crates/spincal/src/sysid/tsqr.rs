//! Streaming (tall-skinny) Householder QR for least squares on very tall matrices.
//!
//! The matrix [Φ | y] is fed in row blocks that stay in L1 cache. Only the (n+1)×(n+1) triangular
//! factor R is kept: each block B is reduced against the current R with Householder reflections,
//!
//! ```text
//! [ R ]       [ R' ]
//! [ B ]  = Q  [ 0  ]
//! ```
//!
//! so after the last block R is the R factor of [Φ | y] (up to row signs), its last column holds
//! Qᵀy and its last diagonal entry is ±‖y − Φθ‖. This is plain Householder QR applied in a
//! different row order, with its backward stability (the normal equations are never formed), and
//! one pass over the data.
//!
//! Rows are split into fixed chunks reduced in parallel, whose R factors are then merged in chunk
//! order, so the result does not depend on the number of threads.

use pulp::{Arch, Simd, WithSimd};
use rayon::prelude::*;

/// Rows per block: a block of up to ~16 columns (32 KiB) stays in L1.
const BLOCK_ROWS: usize = 256;
/// Rows per parallel chunk (a multiple of `BLOCK_ROWS`).
const CHUNK_ROWS: usize = 1 << 16;

/// Upper-triangular factor of a streaming QR, column-major n×n.
#[derive(Debug, Clone)]
pub(crate) struct TriFactor {
    pub n: usize,
    pub r: Vec<f64>,
}

impl TriFactor {
    fn zeros(n: usize) -> TriFactor {
        TriFactor {
            n,
            r: vec![0.0; n * n],
        }
    }

    #[inline]
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.r[i + j * self.n]
    }

    /// Reduces another factor (as an n-row block) into this one.
    fn merge(&mut self, other: &TriFactor) {
        let mut block = other.r.clone();
        let n = self.n;
        absorb_block(&mut self.r, n, &mut block, n, n);
    }

    /// Solves R[..p, ..p] θ = R[..p, p] (p = n − 1) by back substitution: the least-squares
    /// solution when the last column of the factored matrix was the target. `None` when R is
    /// singular (a zero or non-finite solution component).
    ///
    /// A regressor whose pivot is below 1e-10 of the largest lies (numerically) in the span of the
    /// earlier ones: its coefficient is set to zero, which leaves the residual unchanged (a basic
    /// least-squares solution, as MATLAB's backslash gives for rank-deficient ARX problems).
    pub fn solve_last_column(&self) -> Option<Vec<f64>> {
        let p = self.n - 1;
        let largest = (0..p).map(|i| self.at(i, i).abs()).fold(0.0, f64::max);
        if largest == 0.0 {
            return None;
        }
        let mut theta: Vec<f64> = (0..p).map(|i| self.at(i, p)).collect();
        for i in (0..p).rev() {
            if self.at(i, i).abs() <= 1e-10 * largest {
                theta[i] = 0.0;
                continue;
            }
            let mut s = theta[i];
            for (k, th) in theta.iter().enumerate().skip(i + 1) {
                s -= self.at(i, k) * th;
            }
            theta[i] = s / self.at(i, i);
        }
        theta.iter().all(|v| v.is_finite()).then_some(theta)
    }
}

/// Streaming QR of an m×n matrix whose rows are produced on demand: `fill(row0, rows, block, ld)`
/// writes rows `row0..row0 + rows` column-major into `block` (column j at `j * ld`).
pub(crate) fn streaming_qr<F>(m: usize, n: usize, fill: F) -> TriFactor
where
    F: Fn(usize, usize, &mut [f64], usize) + Sync,
{
    let chunks: Vec<usize> = (0..m).step_by(CHUNK_ROWS).collect();
    let factors: Vec<TriFactor> = chunks
        .par_iter()
        .map(|&c0| {
            let c1 = (c0 + CHUNK_ROWS).min(m);
            Arch::new().dispatch(ChunkQr {
                n,
                rows: c0..c1,
                fill: &fill,
            })
        })
        .collect();
    let mut it = factors.into_iter();
    let mut acc = it.next().unwrap_or_else(|| TriFactor::zeros(n));
    for f in it {
        acc.merge(&f);
    }
    acc
}

struct ChunkQr<'a, F> {
    n: usize,
    rows: std::ops::Range<usize>,
    fill: &'a F,
}

impl<F: Fn(usize, usize, &mut [f64], usize)> WithSimd for ChunkQr<'_, F> {
    type Output = TriFactor;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> TriFactor {
        let n = self.n;
        let mut tri = TriFactor::zeros(n);
        let mut block = vec![0.0; BLOCK_ROWS * n];
        let mut r0 = self.rows.start;
        while r0 < self.rows.end {
            let rows = BLOCK_ROWS.min(self.rows.end - r0);
            (self.fill)(r0, rows, &mut block, BLOCK_ROWS);
            absorb_block(&mut tri.r, n, &mut block, rows, BLOCK_ROWS);
            r0 += rows;
        }
        tri
    }
}

/// Householder reduction of [R; B] to [R'; 0] (LAPACK dgeqr2 on the stacked matrix, exploiting
/// that column j of R is zero below row j). `r` is column-major n×n, `block` column-major with
/// `rows` rows and leading dimension `ld`; the block is overwritten.
#[inline(always)]
fn absorb_block(r: &mut [f64], n: usize, block: &mut [f64], rows: usize, ld: usize) {
    for j in 0..n {
        let (left, right) = block.split_at_mut((j + 1) * ld);
        let x = &mut left[j * ld..j * ld + rows];
        let sx = dot(x, x);
        if sx == 0.0 {
            continue; // already reduced: the reflection is the identity
        }
        let alpha = r[j + j * n];
        let norm = (alpha * alpha + sx).sqrt();
        let beta = if alpha >= 0.0 { -norm } else { norm };
        // H = I − τ v vᵀ with v = [1; x / (α − β)], so that H [α; x] = [β; 0].
        let tau = (beta - alpha) / beta;
        let scale = 1.0 / (alpha - beta);
        x.iter_mut().for_each(|v| *v *= scale);
        r[j + j * n] = beta;
        for k in j + 1..n {
            let col = &mut right[(k - j - 1) * ld..(k - j - 1) * ld + rows];
            let s = tau * (r[j + k * n] + dot(x, col));
            r[j + k * n] -= s;
            for (c, v) in col.iter_mut().zip(x.iter()) {
                *c -= s * v;
            }
        }
    }
}

/// Dot product with independent partial sums so that it vectorises.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0; L];
    let (ac, bc) = (a.chunks_exact(L), b.chunks_exact(L));
    let (ar, br) = (ac.remainder(), bc.remainder());
    for (x, y) in ac.zip(bc) {
        for l in 0..L {
            acc[l] += x[l] * y[l];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
    for (x, y) in ar.iter().zip(br) {
        s += x * y;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    #[test]
    fn r_factor_matches_faer_qr_up_to_row_signs() {
        // Rows across several chunks and a ragged last block.
        let (m, n) = (2 * CHUNK_ROWS + 3 * BLOCK_ROWS + 17, 5);
        let val = |i: usize, j: usize| {
            (((i * 7919 + j * 104_729) % 1000) as f64 / 500.0 - 1.0) + f64::from(u8::from(j == 0))
        };
        let tri = streaming_qr(m, n, |r0, rows, block, ld| {
            for j in 0..n {
                for i in 0..rows {
                    block[i + j * ld] = val(r0 + i, j);
                }
            }
        });
        let a = Mat::from_fn(m, n, val);
        let r = a.qr().R().to_owned();
        for i in 0..n {
            let sign = (tri.at(i, i) * r[(i, i)]).signum();
            for j in i..n {
                let (x, y) = (tri.at(i, j), sign * r[(i, j)]);
                assert!((x - y).abs() <= 1e-10 * r[(0, 0)].abs(), "R[{i},{j}]: {x} vs {y}");
            }
        }
    }
}
