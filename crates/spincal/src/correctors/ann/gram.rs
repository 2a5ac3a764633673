//! The rank-k update of LM's normal equations, AᵀA over the columns of one Jacobian block, for
//! the small widths of these networks (tens to a few hundred columns).
//!
//! A general matrix-multiply kernel is tuned for large products and reaches only part of its rate
//! here; this one reads the Jacobian's columns where they are (no packing: each is a contiguous
//! run of samples) and computes a 3×4 tile of dot products at a time, 12 running sums of 4 lanes
//! that stay in the 16 AVX registers. [`dispatch`] runs an operation with AVX2+FMA vectors where
//! the CPU has them (checked at run time) and with plain `f64` lanes elsewhere.
//!
//! Summation order is fixed: row r of a column pair goes into lane r mod 4 with a fused
//! multiply-add, and the lanes are added as (l0 + l1) + (l2 + l3). Both paths do exactly this, so
//! the result does not depend on the machine.

use std::array::from_fn;

/// Four f64 lanes with a fused multiply-add.
pub(crate) trait Fma4: Copy {
    type V: Copy;
    fn load(self, x: [f64; 4]) -> Self::V;
    fn mul_add(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V;
    fn lanes(self, v: Self::V) -> [f64; 4];
    /// (l0 + l1) + (l2 + l3) of each of four vectors.
    #[inline(always)]
    fn sums(self, v: [Self::V; 4]) -> [f64; 4] {
        v.map(|v| {
            let l = self.lanes(v);
            (l[0] + l[1]) + (l[2] + l[3])
        })
    }
}

/// Lanes as plain `f64`s (any machine).
#[derive(Clone, Copy)]
pub(crate) struct Portable;

impl Fma4 for Portable {
    type V = [f64; 4];

    #[inline(always)]
    fn load(self, x: [f64; 4]) -> [f64; 4] {
        x
    }

    #[inline(always)]
    fn mul_add(self, a: [f64; 4], b: [f64; 4], c: [f64; 4]) -> [f64; 4] {
        from_fn(|l| a[l].mul_add(b[l], c[l]))
    }

    #[inline(always)]
    fn lanes(self, v: [f64; 4]) -> [f64; 4] {
        v
    }
}

#[cfg(target_arch = "x86_64")]
impl Fma4 for pulp::x86::V3 {
    type V = pulp::f64x4;

    #[inline(always)]
    fn load(self, x: [f64; 4]) -> pulp::f64x4 {
        pulp::cast(x)
    }

    #[inline(always)]
    fn mul_add(self, a: pulp::f64x4, b: pulp::f64x4, c: pulp::f64x4) -> pulp::f64x4 {
        self.mul_add_f64x4(a, b, c)
    }

    #[inline(always)]
    fn lanes(self, v: pulp::f64x4) -> [f64; 4] {
        pulp::cast(v)
    }

    #[inline(always)]
    fn sums(self, v: [pulp::f64x4; 4]) -> [f64; 4] {
        use std::arch::x86_64::__m256d;
        let v: [__m256d; 4] = v.map(pulp::cast);
        // [a0+a1, b0+b1, a2+a3, b2+b3] and the same for c, d; then the halves added.
        let ab = self.avx._mm256_hadd_pd(v[0], v[1]);
        let cd = self.avx._mm256_hadd_pd(v[2], v[3]);
        let low = self.avx._mm256_permute2f128_pd::<0x20>(ab, cd);
        let high = self.avx._mm256_permute2f128_pd::<0x31>(ab, cd);
        pulp::cast(self.avx._mm256_add_pd(low, high))
    }
}

/// An operation generic over the lanes, for [`dispatch`].
pub(crate) trait Fma4Op {
    type Output;
    fn run<F: Fma4>(self, lanes: F) -> Self::Output;
}

/// Runs `op` compiled for AVX2+FMA when the CPU has them (everything `op` inlines is then
/// vectorised 4 wide), else with [`Portable`] lanes.
#[inline]
pub(crate) fn dispatch<Op: Fma4Op>(op: Op) -> Op::Output {
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = pulp::x86::V3::try_new() {
        struct Run<Op>(Op, pulp::x86::V3);
        impl<Op: Fma4Op> pulp::NullaryFnOnce for Run<Op> {
            type Output = Op::Output;

            #[inline(always)]
            fn call(self) -> Op::Output {
                self.0.run(self.1)
            }
        }
        return v3.vectorize(Run(op, v3));
    }
    op.run(Portable)
}

/// Tile of the product: MR columns of A (rows of AᵀA) by NR columns (its columns); each MR
/// columns are read once for two such tiles (JB = 2·NR columns of AᵀA), so that streaming them
/// from L2 takes half the bandwidth.
const MR: usize = 3;
const NR: usize = 4;
const JB: usize = 2 * NR;

/// Adds the lower triangle of AᵀA to `gram` (d×d, row-major, d = `cols.len()`; only entries with
/// j ≤ i are touched), where column q of A is `data[cols[q] * stride + first..][..len]`.
pub(crate) struct AddLower<'a> {
    pub data: &'a [f64],
    pub cols: &'a [usize],
    pub stride: usize,
    pub first: usize,
    pub len: usize,
    pub gram: &'a mut [f64],
}

impl AddLower<'_> {
    /// Runs by [`dispatch`] in a function of its own: the kernel's code generation then does not
    /// depend on what its caller inlines around it (forward and backward passes).
    #[inline(never)]
    pub(crate) fn dispatched(self) {
        dispatch(self)
    }
}

impl Fma4Op for AddLower<'_> {
    type Output = ();

    #[inline(always)]
    fn run<F: Fma4>(self, f: F) {
        let AddLower {
            data,
            cols,
            stride,
            first,
            len,
            gram,
        } = self;
        let d = cols.len();
        assert!(gram.len() >= d * d);
        let col = |q: usize| &data[cols[q] * stride + first..][..len];
        let mut j0 = 0;
        while j0 + NR <= d {
            let panels = if j0 + JB <= d { 2 } else { 1 };
            let b: [[&[f64]; NR]; 2] = from_fn(|p| from_fn(|j| col((j0 + p * NR + j).min(d - 1))));
            // Rows from j0 on (the first tiles straddle the diagonal; their upper entries are dropped).
            let mut i0 = j0;
            while i0 < d {
                if i0 + MR <= d {
                    let a: [&[f64]; MR] = from_fn(|i| col(i0 + i));
                    for (p, b) in b.iter().enumerate().take(panels) {
                        let jp = j0 + p * NR;
                        if i0 + MR > jp {
                            add_tile(gram, d, i0, jp, dot_tile::<F, MR, NR>(f, a, *b, len));
                        }
                    }
                    i0 += MR;
                } else {
                    for (p, b) in b.iter().enumerate().take(panels) {
                        let jp = j0 + p * NR;
                        if i0 + 1 > jp {
                            add_tile(gram, d, i0, jp, dot_tile::<F, 1, NR>(f, [col(i0)], *b, len));
                        }
                    }
                    i0 += 1;
                }
            }
            j0 += panels * NR;
        }
        for j in j0..d {
            let b = [col(j)];
            let mut i0 = j;
            while i0 + MR <= d {
                add_tile(
                    gram,
                    d,
                    i0,
                    j,
                    dot_tile::<F, MR, 1>(f, from_fn(|i| col(i0 + i)), b, len),
                );
                i0 += MR;
            }
            for i in i0..d {
                add_tile(gram, d, i, j, dot_tile::<F, 1, 1>(f, [col(i)], b, len));
            }
        }
    }
}

#[inline(always)]
fn add_tile<const M: usize, const N: usize>(
    gram: &mut [f64],
    d: usize,
    i0: usize,
    j0: usize,
    tile: [[f64; N]; M],
) {
    for (i, row) in tile.iter().enumerate() {
        let at = (i0 + i) * d + j0;
        let lower = (i0 + i + 1).saturating_sub(j0).min(N);
        for (g, v) in gram[at..at + lower].iter_mut().zip(row) {
            *g += v;
        }
    }
}

/// Dot products of every column in `a` with every column in `b`, all of length `len`.
#[inline(always)]
fn dot_tile<F: Fma4, const M: usize, const N: usize>(
    f: F,
    a: [&[f64]; M],
    b: [&[f64]; N],
    len: usize,
) -> [[f64; N]; M] {
    let quads = len / 4;
    let a4: [&[[f64; 4]]; M] = a.map(|s| &s[..len].as_chunks::<4>().0[..quads]);
    let b4: [&[[f64; 4]]; N] = b.map(|s| &s[..len].as_chunks::<4>().0[..quads]);
    let zero = f.load([0.0; 4]);
    let mut acc = [[zero; N]; M];
    let mut step = |av: [F::V; M], bv: [F::V; N]| {
        for j in 0..N {
            for i in 0..M {
                acc[i][j] = f.mul_add(av[i], bv[j], acc[i][j]);
            }
        }
    };
    for q in 0..quads {
        step(from_fn(|i| f.load(a4[i][q])), from_fn(|j| f.load(b4[j][q])));
    }
    // The last rows as one zero-padded step.
    if quads * 4 < len {
        let tail = |s: &[f64]| f.load(from_fn(|l| s.get(quads * 4 + l).copied().unwrap_or(0.0)));
        step(a.map(|s| tail(&s[..len])), b.map(|s| tail(&s[..len])));
    }
    from_fn(|i| {
        if N == 4 {
            let s = f.sums(from_fn(|j| acc[i][j % N]));
            from_fn(|j| s[j])
        } else {
            from_fn(|j| {
                let s = f.lanes(acc[i][j]);
                (s[0] + s[1]) + (s[2] + s[3])
            })
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lower_triangle_of_the_gram_matrix() {
        // Odd sizes: partial tiles in both directions and a row tail.
        for (n_cols, len) in [(1, 1), (2, 3), (7, 9), (11, 37), (13, 64)] {
            let stride = len + 5;
            let data: Vec<f64> = (0..stride * (n_cols + 2))
                .map(|v| ((v * 37 % 101) as f64 - 50.0) / 7.0)
                .collect();
            // Skip column 1 and read from row 2 on, as the trainer does for one output.
            let cols: Vec<usize> = (0..n_cols + 1).filter(|&c| c != 1).collect();
            let d = cols.len();
            let mut gram = vec![0.5; d * d];
            let add = |gram| AddLower {
                data: &data,
                cols: &cols,
                stride,
                first: 2,
                len,
                gram,
            };
            add(&mut gram).run(Portable);
            let mut fast = vec![0.5; d * d];
            add(&mut fast).dispatched();
            assert_eq!(fast, gram, "dispatched and portable lanes differ");
            for i in 0..d {
                for j in 0..d {
                    let got = gram[i * d + j];
                    if j > i {
                        assert_eq!(got, 0.5, "upper entry ({i},{j}) touched");
                        continue;
                    }
                    let at = |c: usize, r: usize| data[cols[c] * stride + 2 + r];
                    let expected = 0.5 + (0..len).map(|r| at(i, r) * at(j, r)).sum::<f64>();
                    assert!(
                        (got - expected).abs() <= 1e-12 * (1.0 + expected.abs()),
                        "({i},{j}) of {d}x{d}, len {len}: {got} vs {expected}"
                    );
                }
            }
        }
    }
}
