//! Cholesky factorisation and solve for LM's damped normal equations (a hundred or a few hundred
//! parameters).
//!
//! Right-looking, four columns at a time: each entry of the trailing matrix takes its updates
//! column after column, each a fused multiply-subtract (a − l₀c₀, then − l₁c₁, …, each rounded
//! once), so the factor is the same to the bit whatever the vector width, and on every machine.
//! The loops run compiled for the CPU's vector extension ([`pulp::Arch`]); where the products'
//! wide kernels run ([`crate::simd::wide_kernels_chosen`]), the trailing matrix is updated four of its
//! columns at a time in 512-bit registers, each panel value loaded once for the four.

use pulp::{Arch, Simd, WithSimd};

/// Columns factored before each update of the trailing matrix: the trailing matrix is then read
/// and written once per panel rather than once per column.
const PANEL: usize = 4;
/// Trailing columns the AVX-512 update takes at a time.
const GROUP: usize = 4;

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

    /// Factors the symmetric matrix whose columns `column(j)` gives (only their entries on and
    /// below the diagonal are read) plus `shift` on the diagonal; false when it is not positive
    /// definite (a pivot ≤ 0 or not finite).
    pub(crate) fn factor<'a>(&mut self, column: impl Fn(usize) -> &'a [f64], shift: f64) -> bool {
        let n = self.n;
        for j in 0..n {
            self.factor[j * n + j..(j + 1) * n].copy_from_slice(&column(j)[j..n]);
            self.factor[j * n + j] += shift;
        }
        Arch::new().dispatch(Factor {
            n,
            a: &mut self.factor,
            #[cfg(target_arch = "x86_64")]
            wide: crate::simd::wide_kernels_chosen(),
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
    /// Whether to update the trailing matrix with [`trailing_group_avx512`].
    #[cfg(target_arch = "x86_64")]
    wide: bool,
}

impl WithSimd for Factor<'_> {
    type Output = bool;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> bool {
        #[cfg(target_arch = "x86_64")]
        return factor_in_place(self.n, self.a, self.wide);
        #[cfg(not(target_arch = "x86_64"))]
        return factor_in_place(self.n, self.a, false);
    }
}

/// t − l·c rounded once: a fused multiply-add where the CPU has one, else libm's, with the same
/// bits.
#[inline(always)]
fn minus_product(t: f64, l: f64, c: f64) -> f64 {
    (-l).mul_add(c, t)
}

/// Overwrites the lower triangle of the column-major n×n `a` with its Cholesky factor; false at
/// the first pivot that is not positive and finite. `wide`: update the trailing matrix in
/// AVX-512, only where [`crate::simd::has_avx512`] is true.
#[inline(always)]
fn factor_in_place(n: usize, a: &mut [f64], wide: bool) -> bool {
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
                    *t = minus_product(*t, *l, c);
                }
            }
        }
        // The trailing matrix, by the whole panel: entry by entry the same updates in the same
        // order as one column at a time.
        let (done, rest) = a.split_at_mut(k1 * n);
        let panel: [&[f64]; PANEL] = std::array::from_fn(|p| {
            let k = (k0 + p).min(k1 - 1);
            &done[k * n..(k + 1) * n]
        });
        let width = k1 - k0;
        let mut j = k1;
        while j < n {
            #[cfg(target_arch = "x86_64")]
            if wide && width == PANEL && j + GROUP <= n {
                // SAFETY: `wide` only where `simd::has_avx512` says the CPU has the kernel's
                // features (the dispatch's choice implies it; the tests check it); each panel
                // column holds n values.
                unsafe { trailing_group_avx512(&panel, rest, n, k1, j) };
                j += GROUP;
                continue;
            }
            let target = &mut rest[(j - k1) * n + j..(j - k1 + 1) * n];
            let c: [f64; PANEL] = std::array::from_fn(|p| panel[p][j]);
            let rows = j..n;
            match width {
                PANEL => {
                    let [l0, l1, l2, l3] = panel.map(|column| &column[rows.clone()]);
                    for ((((t, a0), a1), a2), a3) in target.iter_mut().zip(l0).zip(l1).zip(l2).zip(l3) {
                        let v = minus_product(minus_product(*t, *a0, c[0]), *a1, c[1]);
                        *t = minus_product(minus_product(v, *a2, c[2]), *a3, c[3]);
                    }
                }
                _ => {
                    for (p, &cp) in c.iter().enumerate().take(width) {
                        for (t, l) in target.iter_mut().zip(&panel[p][rows.clone()]) {
                            *t = minus_product(*t, *l, cp);
                        }
                    }
                }
            }
            j += 1;
        }
        k0 = k1;
    }
    true
}

crate::simd::avx512_kernel! {
    /// Trailing columns `j..j + GROUP` (of `rest`, which starts at column `k1`) minus the whole
    /// panel's updates, each entry's four in panel order: the triangle on and below the diagonal
    /// one entry at a time, the rows below it eight at a time for all four columns, so that each
    /// panel value is loaded once for them.
    ///
    /// # Safety
    /// Each panel column holds at least n values; the CPU has the kernel's features.
    unsafe fn trailing_group_avx512(
        panel: &[&[f64]; PANEL],
        rest: &mut [f64],
        n: usize,
        k1: usize,
        j: usize,
    ) {
        use std::arch::x86_64::*;
        assert!(j + GROUP <= n && rest.len() >= (j + GROUP - k1) * n);
        let mut c = [[0.0; PANEL]; GROUP];
        for g in 0..GROUP {
            for p in 0..PANEL {
                c[g][p] = panel[p][j + g];
            }
        }
        for g in 0..GROUP {
            for i in j + g..j + GROUP {
                let t = &mut rest[(j + g - k1) * n + i];
                for p in 0..PANEL {
                    *t = minus_product(*t, panel[p][i], c[g][p]);
                }
            }
        }
        let start = j + GROUP;
        let mut cv = [[_mm512_setzero_pd(); PANEL]; GROUP];
        for g in 0..GROUP {
            for p in 0..PANEL {
                cv[g][p] = _mm512_set1_pd(c[g][p]);
            }
        }
        let targets = rest.as_mut_ptr();
        let mut r = start;
        while r < n {
            let mask: __mmask8 = if n - r >= 8 {
                0xff
            } else {
                ((1u32 << (n - r)) - 1) as u8
            };
            let mut l = [_mm512_setzero_pd(); PANEL];
            for p in 0..PANEL {
                // SAFETY: r < n ≤ the column's length, and the mask reads rows r..n only.
                l[p] = unsafe { _mm512_maskz_loadu_pd(mask, panel[p].as_ptr().add(r)) };
            }
            for g in 0..GROUP {
                // SAFETY: row r < n of column j + g < n lies in `rest` (asserted above), and the
                // mask touches rows r..n only.
                unsafe {
                    let at = targets.add((j + g - k1) * n + r);
                    let mut t = _mm512_maskz_loadu_pd(mask, at);
                    for p in 0..PANEL {
                        t = _mm512_fnmadd_pd(l[p], cv[g][p], t);
                    }
                    _mm512_mask_storeu_pd(at, mask, t);
                }
            }
            r += 8;
        }
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
            assert!(cholesky.factor(|j| &a[j * n..(j + 1) * n], 0.5));
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
        // Each trailing entry gets its updates in column order either way, with the four-lane
        // loops and (wherever the CPU has it, whatever the dispatch chooses) the AVX-512 group
        // update; 37 and 45 leave short groups, panels and row tails.
        for n in [37, 45] {
            check_against_column_at_a_time(n);
        }
    }

    fn check_against_column_at_a_time(n: usize) {
        let a = spd(n, 9);
        let mut panelled = Cholesky::new(n);
        assert!(panelled.factor(|j| &a[j * n..(j + 1) * n], 0.0));
        let mut l = vec![0.0; n * n];
        for j in 0..n {
            for i in j..n {
                l[j * n + i] = a[i * n + j];
            }
        }
        let mut narrow = l.clone();
        assert!(factor_in_place(n, &mut narrow, false));
        #[cfg(target_arch = "x86_64")]
        let wide = crate::simd::has_avx512().then(|| {
            let mut wide = l.clone();
            assert!(factor_in_place(n, &mut wide, true));
            wide
        });
        for k in 0..n {
            let d = l[k * n + k].sqrt();
            l[k * n + k] = d;
            for i in k + 1..n {
                l[k * n + i] /= d;
            }
            for j in k + 1..n {
                let c = l[k * n + j];
                for i in j..n {
                    l[j * n + i] = (-l[k * n + i]).mul_add(c, l[j * n + i]);
                }
            }
        }
        for j in 0..n {
            for i in j..n {
                assert_eq!(
                    panelled.factor[j * n + i].to_bits(),
                    l[j * n + i].to_bits(),
                    "dispatched ({i},{j})"
                );
                assert_eq!(
                    narrow[j * n + i].to_bits(),
                    l[j * n + i].to_bits(),
                    "four-lane ({i},{j})"
                );
                #[cfg(target_arch = "x86_64")]
                if let Some(wide) = &wide {
                    assert_eq!(
                        wide[j * n + i].to_bits(),
                        l[j * n + i].to_bits(),
                        "AVX-512 ({i},{j})"
                    );
                }
            }
        }
    }

    #[test]
    fn refuses_what_is_not_positive_definite() {
        let n = 6;
        let mut a = spd(n, 3);
        let mut cholesky = Cholesky::new(n);
        a[4 * n + 4] = -50.0;
        assert!(!cholesky.factor(|j| &a[j * n..(j + 1) * n], 0.0));
        a[4 * n + 4] = f64::NAN;
        assert!(!cholesky.factor(|j| &a[j * n..(j + 1) * n], 0.0));
        // A large enough shift makes it definite again.
        a[4 * n + 4] = -50.0;
        assert!(cholesky.factor(|j| &a[j * n..(j + 1) * n], 1e3));
    }
}
