//! Cholesky factorisation and solve for LM's damped normal equations (a hundred or a few hundred
//! parameters).
//!
//! Right-looking, four columns at a time: each entry of the trailing matrix takes its updates
//! column after column (a − l₀c₀ − l₁c₁ − …, plain multiplies and subtractions), so the factor is
//! the same to the bit whatever the vector width, and on every machine. The loops run compiled
//! for the CPU's vector extension ([`pulp::Arch`]).

use pulp::{Arch, Simd, WithSimd};

/// Columns factored before each update of the trailing matrix: the trailing matrix is then read
/// and written once per panel rather than once per column.
const PANEL: usize = 4;

/// A lower-triangular Cholesky factor of an n×n matrix, column-major (column j from j·n).
pub(crate) struct Cholesky {
    n: usize,
    factor: Vec<f64>,
}

impl Cholesky {
    pub(crate) fn new(n: usize) -> Cholesky {
        Cholesky {
            n,
            factor: vec![0.0; n * n],
        }
    }

    /// Factors the matrix whose lower triangle `lower(i, j)` gives (i ≥ j) plus `shift` on the
    /// diagonal; false when it is not positive definite (a pivot ≤ 0 or not finite).
    pub(crate) fn factor(&mut self, lower: impl Fn(usize, usize) -> f64, shift: f64) -> bool {
        let n = self.n;
        for j in 0..n {
            for i in j..n {
                self.factor[j * n + i] = lower(i, j);
            }
            self.factor[j * n + j] += shift;
        }
        Arch::new().dispatch(Factor {
            n,
            a: &mut self.factor,
        })
    }

    /// Solves L·Lᵀ·x = b in place (`b` becomes x).
    pub(crate) fn solve_in_place(&self, b: &mut [f64]) {
        let (n, l) = (self.n, &self.factor);
        for j in 0..n {
            b[j] /= l[j * n + j];
            let v = b[j];
            for (bi, lij) in b[j + 1..].iter_mut().zip(&l[j * n + j + 1..(j + 1) * n]) {
                *bi -= lij * v;
            }
        }
        for j in (0..n).rev() {
            let column = &l[j * n + j + 1..(j + 1) * n];
            let mut sum = b[j];
            for (lij, bi) in column.iter().zip(&b[j + 1..]) {
                sum -= lij * bi;
            }
            b[j] = sum / l[j * n + j];
        }
    }
}

struct Factor<'a> {
    n: usize,
    a: &'a mut [f64],
}

impl WithSimd for Factor<'_> {
    type Output = bool;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> bool {
        let Factor { n, a } = self;
        let mut k0 = 0;
        while k0 < n {
            let k1 = (k0 + PANEL).min(n);
            // The panel's columns, each updated by the panel's earlier ones, then scaled.
            for k in k0..k1 {
                let pivot = a[k * n + k];
                if !(pivot > 0.0 && pivot.is_finite()) {
                    return false;
                }
                let d = pivot.sqrt();
                a[k * n + k] = d;
                for v in &mut a[k * n + k + 1..(k + 1) * n] {
                    *v /= d;
                }
                let (done, rest) = a.split_at_mut((k + 1) * n);
                let column = &done[k * n..];
                for j in k + 1..k1 {
                    let c = column[j];
                    let target = &mut rest[(j - k - 1) * n + j..(j - k) * n];
                    for (t, l) in target.iter_mut().zip(&column[j..n]) {
                        *t -= l * c;
                    }
                }
            }
            // The trailing matrix, by the whole panel: entry by entry the same updates in the
            // same order as one column at a time.
            let (done, rest) = a.split_at_mut(k1 * n);
            let panel: [&[f64]; PANEL] = std::array::from_fn(|p| {
                let k = (k0 + p).min(k1 - 1);
                &done[k * n..(k + 1) * n]
            });
            let width = k1 - k0;
            for j in k1..n {
                let target = &mut rest[(j - k1) * n + j..(j - k1 + 1) * n];
                let c: [f64; PANEL] = std::array::from_fn(|p| panel[p][j]);
                let rows = j..n;
                match width {
                    PANEL => {
                        let [l0, l1, l2, l3] = panel.map(|column| &column[rows.clone()]);
                        for ((((t, a0), a1), a2), a3) in target.iter_mut().zip(l0).zip(l1).zip(l2).zip(l3) {
                            *t = (((*t - a0 * c[0]) - a1 * c[1]) - a2 * c[2]) - a3 * c[3];
                        }
                    }
                    _ => {
                        for (p, &cp) in c.iter().enumerate().take(width) {
                            for (t, l) in target.iter_mut().zip(&panel[p][rows.clone()]) {
                                *t -= l * cp;
                            }
                        }
                    }
                }
            }
            k0 = k1;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random symmetric positive definite matrix (BᵀB + I), full.
    fn spd(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let b: Vec<f64> = (0..n * n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..n).map(|k| b[k * n + i] * b[k * n + j]).sum::<f64>() + f64::from(i == j);
            }
        }
        a
    }

    #[test]
    fn solves_positive_definite_systems() {
        for (n, seed) in [(1, 1), (3, 2), (4, 3), (5, 4), (9, 5), (110, 6)] {
            let a = spd(n, seed);
            let mut cholesky = Cholesky::new(n);
            assert!(cholesky.factor(|i, j| a[i * n + j], 0.5));
            let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
            let mut b: Vec<f64> = (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| (a[i * n + j] + 0.5 * f64::from(i == j)) * x[j])
                        .sum()
                })
                .collect();
            cholesky.solve_in_place(&mut b);
            for i in 0..n {
                assert!((b[i] - x[i]).abs() <= 1e-10, "n {n}: x[{i}] {} vs {}", b[i], x[i]);
            }
        }
    }

    #[test]
    fn the_panel_update_keeps_the_bits_of_one_column_at_a_time() {
        // Each trailing entry gets its updates in column order either way.
        let n = 37;
        let a = spd(n, 9);
        let mut panelled = Cholesky::new(n);
        assert!(panelled.factor(|i, j| a[i * n + j], 0.0));
        let mut l = vec![0.0; n * n];
        for j in 0..n {
            for i in j..n {
                l[j * n + i] = a[i * n + j];
            }
        }
        for k in 0..n {
            let d = l[k * n + k].sqrt();
            l[k * n + k] = d;
            for i in k + 1..n {
                l[k * n + i] /= d;
            }
            for j in k + 1..n {
                let c = l[k * n + j];
                for i in j..n {
                    l[j * n + i] -= l[k * n + i] * c;
                }
            }
        }
        for j in 0..n {
            for i in j..n {
                assert_eq!(
                    panelled.factor[j * n + i].to_bits(),
                    l[j * n + i].to_bits(),
                    "({i},{j})"
                );
            }
        }
    }

    #[test]
    fn refuses_what_is_not_positive_definite() {
        let n = 6;
        let mut a = spd(n, 3);
        let mut cholesky = Cholesky::new(n);
        a[4 * n + 4] = -50.0;
        assert!(!cholesky.factor(|i, j| a[i * n + j], 0.0));
        a[4 * n + 4] = f64::NAN;
        assert!(!cholesky.factor(|i, j| a[i * n + j], 0.0));
        // A large enough shift makes it definite again.
        a[4 * n + 4] = -50.0;
        assert!(cholesky.factor(|i, j| a[i * n + j], 1e3));
    }
}
