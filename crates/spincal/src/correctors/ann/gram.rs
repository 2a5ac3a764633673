//! The products of LM's normal equations, AᵀB over two sets of columns of one block of samples,
//! for the small widths of these networks (a few to about a hundred columns a side): the
//! Kronecker factors of [`super::factored`].
//!
//! A general matrix-multiply kernel is tuned for large products and reaches only part of its rate
//! here; this one reads the columns where they are (no packing: each is a contiguous run of
//! samples) and computes a 3×4 tile of dot products at a time, 12 running sums of 4 lanes that
//! stay in the 16 AVX registers. [`dispatch`] runs an operation with AVX2+FMA vectors where the
//! CPU has them (checked at run time) and with plain `f64` lanes elsewhere. On Intel CPUs with
//! AVX-512F, 6×8 wide tiles run in 24 of the 32 512-bit registers, two dot products to a
//! register ([`Avx512`]), and so do a product's edges: its last four columns as 6×4, its last
//! three rows as 3×8, the corner as 3×4 ([`Fma4::tile`]). Elsewhere every tile is made of 3×4
//! ones.
//!
//! Summation order is fixed: row r of a column pair goes into lane r mod 4 with a fused
//! multiply-add, and the lanes are added as (l0 + l1) + (l2 + l3). Every path does exactly this,
//! so the result does not depend on the machine.

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

    /// The MR × NR tile every other is made of where the registers do not hold a larger one.
    #[inline(always)]
    fn full_tile(self, a: [&[f64]; MR], b: [&[f64]; NR], len: usize) -> [[f64; NR]; MR] {
        dot_tile(self, a, b, len)
    }

    /// R columns of A (MR or 2·MR) by J of B (NR or 2·NR): [`Fma4::full_tile`]s, or one kernel
    /// where the registers hold the whole tile (fewer loads and lane sums per multiply-add).
    #[inline(always)]
    fn tile<const R: usize, const J: usize>(
        self,
        a: [&[f64]; R],
        b: [&[f64]; J],
        len: usize,
    ) -> [[f64; J]; R] {
        let mut tile = [[0.0; J]; R];
        for (part_rows, rows) in tile.chunks_exact_mut(MR).enumerate() {
            let a: [&[f64]; MR] = from_fn(|i| a[part_rows * MR + i]);
            for p in 0..J / NR {
                let part = self.full_tile(a, from_fn(|j| b[p * NR + j]), len);
                for (row, part) in rows.iter_mut().zip(part) {
                    row[p * NR..(p + 1) * NR].copy_from_slice(&part);
                }
            }
        }
        tile
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

/// AVX2 lanes with the wide tile, made only where the CPU has AVX-512F
/// ([`crate::simd::has_avx512`]; the dispatch takes them where
/// [`crate::simd::wide_kernels_chosen`]): the wide tile runs in 512-bit registers, two dot products to a register (the low four lanes for one column of
/// `b`, the high four for the next), so that each sum takes the same fused multiply-adds in the
/// same order as with four lanes and the result stays the same to the bit on every machine.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx512(pulp::x86::V3);

#[cfg(target_arch = "x86_64")]
impl Avx512 {
    pub(crate) fn try_new(v3: pulp::x86::V3) -> Option<Avx512> {
        crate::simd::has_avx512().then_some(Avx512(v3))
    }
}

#[cfg(target_arch = "x86_64")]
impl Fma4 for Avx512 {
    type V = pulp::f64x4;

    #[inline(always)]
    fn load(self, x: [f64; 4]) -> pulp::f64x4 {
        <pulp::x86::V3 as Fma4>::load(self.0, x)
    }

    #[inline(always)]
    fn mul_add(self, a: pulp::f64x4, b: pulp::f64x4, c: pulp::f64x4) -> pulp::f64x4 {
        <pulp::x86::V3 as Fma4>::mul_add(self.0, a, b, c)
    }

    #[inline(always)]
    fn lanes(self, v: pulp::f64x4) -> [f64; 4] {
        <pulp::x86::V3 as Fma4>::lanes(self.0, v)
    }

    #[inline(always)]
    fn sums(self, v: [pulp::f64x4; 4]) -> [f64; 4] {
        <pulp::x86::V3 as Fma4>::sums(self.0, v)
    }

    #[inline(always)]
    fn tile<const R: usize, const J: usize>(
        self,
        a: [&[f64]; R],
        b: [&[f64]; J],
        len: usize,
    ) -> [[f64; J]; R] {
        // SAFETY: an `Avx512` is made only where `simd::has_avx512` says the CPU has the kernel's
        // features.
        unsafe { tile_avx512(a, b, len) }
    }
}

crate::simd::avx512_kernel! {
    /// [`Fma4::tile`] in 512-bit registers: R × J dot products in R·J / 2 registers, each holding
    /// two of them (the low four lanes for one column of `b`, the high four for the next). Row r
    /// of a column pair goes into lane r mod 4 with a fused multiply-add (the last step
    /// zero-padded), and each sum's lanes are added as (l0 + l1) + (l2 + l3), exactly as with
    /// four lanes. Plain loops and no closures, so that every intrinsic inlines here.
    fn tile_avx512<const R: usize, const J: usize>(
        a: [&[f64]; R],
        b: [&[f64]; J],
        len: usize,
    ) -> [[f64; J]; R] {
        use std::arch::x86_64::*;
        const { assert!(J.is_multiple_of(NR) && J <= JB && R <= WMR) };
        let quads = len / 4;
        // a's columns first, b's from WMR on.
        let mut columns = [&[][..]; WMR + JB];
        columns[..R].copy_from_slice(&a);
        columns[WMR..WMR + J].copy_from_slice(&b);
        let used = |k: usize| k < R || (WMR..WMR + J).contains(&k);
        let mut starts = [std::ptr::null::<f64>(); WMR + JB];
        for k in (0..WMR + JB).filter(|&k| used(k)) {
            assert!(columns[k].len() >= len);
            starts[k] = columns[k].as_ptr();
        }
        // J / 2 pairs of sums a row (the rest of the array stays unused for J < JB).
        let mut acc = [[_mm512_setzero_pd(); JB / 2]; R];
        for q in 0..quads {
            // SAFETY: every used column holds `len` ≥ q·4 + 4 values (asserted above).
            unsafe { tile_step::<R, J>(&mut acc, &starts, q * 4) };
        }
        if quads * 4 < len {
            // The last rows as one zero-padded step.
            let mut padded = [[0.0f64; 4]; WMR + JB];
            for k in (0..WMR + JB).filter(|&k| used(k)) {
                for r in quads * 4..len {
                    padded[k][r - quads * 4] = columns[k][r];
                }
                starts[k] = padded[k].as_ptr();
            }
            // SAFETY: every used column now starts a padded row of four.
            unsafe { tile_step::<R, J>(&mut acc, &starts, 0) };
        }
        // Column j's four lanes of each row, summed by the one definition of that sum.
        let mut sums = [[0.0; J]; R];
        for i in 0..R {
            let mut lanes = [[0.0; 4]; J];
            for p in 0..J / 2 {
                // SAFETY: lanes 2p and 2p + 1 are the eight values stored (2p + 1 < J).
                unsafe { _mm512_storeu_pd(lanes[2 * p..].as_mut_ptr().cast(), acc[i][p]) };
            }
            for half in 0..J / 4 {
                let quad = [
                    lanes[4 * half],
                    lanes[4 * half + 1],
                    lanes[4 * half + 2],
                    lanes[4 * half + 3],
                ];
                sums[i][4 * half..4 * half + 4].copy_from_slice(&Portable.sums(quad));
            }
        }
        sums
    }

    /// One step of [`tile_avx512`]: rows `at..at + 4` of every column (`starts`: a's R from 0,
    /// then b's J from WMR).
    ///
    /// # Safety
    /// Four readable values from `at` in every used column; the CPU has the kernel's features.
    #[inline]
    unsafe fn tile_step<const R: usize, const J: usize>(
        acc: &mut [[std::arch::x86_64::__m512d; JB / 2]; R],
        starts: &[*const f64; WMR + JB],
        at: usize,
    ) {
        use std::arch::x86_64::*;
        let mut pairs = [_mm512_setzero_pd(); JB / 2];
        for (p, pair) in pairs.iter_mut().enumerate().take(J / 2) {
            // SAFETY: columns WMR + 2p and WMR + 2p + 1 are used; the caller vouches for them.
            let (low, high) = unsafe {
                (
                    _mm256_loadu_pd(starts[WMR + 2 * p].add(at)),
                    _mm256_loadu_pd(starts[WMR + 2 * p + 1].add(at)),
                )
            };
            *pair = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(low), high);
        }
        for i in 0..R {
            // SAFETY: column i is used; the caller vouches for it.
            let column = unsafe { _mm256_loadu_pd(starts[i].add(at)) };
            let both = _mm512_broadcast_f64x4(column);
            for p in 0..J / 2 {
                acc[i][p] = _mm512_fmadd_pd(both, pairs[p], acc[i][p]);
            }
        }
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
        return match Avx512::try_new(v3).filter(|_| crate::simd::wide_kernels_chosen()) {
            Some(wide) => vectorized(v3, op, wide),
            None => vectorized(v3, op, v3),
        };
    }
    op.run(Portable)
}

/// Runs `op` with `lanes`, compiled for x86-64-v3 (AVX2, FMA) so that everything it inlines is
/// vectorised.
#[cfg(target_arch = "x86_64")]
fn vectorized<Op: Fma4Op, F: Fma4>(v3: pulp::x86::V3, op: Op, lanes: F) -> Op::Output {
    struct Run<Op, F>(Op, F);
    impl<Op: Fma4Op, F: Fma4> pulp::NullaryFnOnce for Run<Op, F> {
        type Output = Op::Output;

        #[inline(always)]
        fn call(self) -> Op::Output {
            self.0.run(self.1)
        }
    }
    v3.vectorize(Run(op, lanes))
}

/// Tile of the product: MR columns of A (rows of AᵀB) by NR columns of B (its columns).
const MR: usize = 3;
const NR: usize = 4;
/// Columns of B in a wide [`Fma4::tile`]: each MR columns of A are read once for two NR tiles,
/// so that streaming them from L2 takes half the bandwidth.
const JB: usize = 2 * NR;
/// Rows of a wide [`Fma4::tile`].
const WMR: usize = 2 * MR;

/// How many columns of A and of B [`AddProduct`] takes for `rows` and `cols` columns: each side
/// in wide tiles and at most one narrow one, rows a multiple of 3 (6 a wide tile), columns of 4
/// (8 a wide tile). The extra columns must be zero.
pub(crate) fn padded_shape(rows: usize, cols: usize) -> (usize, usize) {
    (rows.next_multiple_of(MR), cols.next_multiple_of(NR))
}

/// Adds AᵀB to `product` (row-major, `rows.len() × cols.len()`), where column q of A is
/// `data[rows[q] * stride..][..len]` and column q of B is `data[cols[q] * stride..][..len]`.
/// The counts must be as [`padded_shape`] gives them.
pub(crate) struct AddProduct<'a> {
    pub data: &'a [f64],
    pub rows: &'a [usize],
    pub cols: &'a [usize],
    pub stride: usize,
    pub len: usize,
    pub product: &'a mut [f64],
}

impl AddProduct<'_> {
    /// Runs by [`dispatch`] in a function of its own: the kernel's code generation then does not
    /// depend on what its caller inlines around it (forward and backward passes).
    #[inline(never)]
    pub(crate) fn dispatched(self) {
        dispatch(self)
    }
}

impl Fma4Op for AddProduct<'_> {
    type Output = ();

    #[inline(always)]
    fn run<F: Fma4>(mut self, f: F) {
        let (m, n) = (self.rows.len(), self.cols.len());
        assert_eq!((m, n), padded_shape(m, n), "unpadded product");
        assert!(self.product.len() >= m * n);
        let wide_rows = m - m % WMR;
        for i0 in (0..wide_rows).step_by(WMR) {
            self.add_rows::<F, WMR>(f, i0);
        }
        if wide_rows < m {
            self.add_rows::<F, MR>(f, wide_rows);
        }
    }
}

impl AddProduct<'_> {
    /// Adds the tiles of rows `i0..i0 + R` (R = MR or WMR): JB columns at a time, then the last
    /// NR where the width leaves them.
    #[inline(always)]
    fn add_rows<F: Fma4, const R: usize>(&mut self, f: F, i0: usize) {
        let (data, stride, len) = (self.data, self.stride, self.len);
        let n = self.cols.len();
        let col = |q: usize| &data[q * stride..][..len];
        let a: [&[f64]; R] = from_fn(|i| col(self.rows[i0 + i]));
        let mut j0 = 0;
        while j0 + JB <= n {
            let b: [&[f64]; JB] = from_fn(|j| col(self.cols[j0 + j]));
            add_tile(self.product, n, i0, j0, f.tile(a, b, len));
            j0 += JB;
        }
        if j0 < n {
            let b: [&[f64]; NR] = from_fn(|j| col(self.cols[j0 + j]));
            add_tile(self.product, n, i0, j0, f.tile(a, b, len));
        }
    }
}

#[inline(always)]
fn add_tile<const M: usize, const N: usize>(
    product: &mut [f64],
    width: usize,
    i0: usize,
    j0: usize,
    tile: [[f64; N]; M],
) {
    for (i, row) in tile.iter().enumerate() {
        let at = (i0 + i) * width + j0;
        for (g, v) in product[at..at + N].iter_mut().zip(row) {
            *g += v;
        }
    }
}

/// Dot products of every column in `a` with every column in `b`, all of length `len`: the
/// MR × NR tile every path shares.
#[inline(always)]
fn dot_tile<F: Fma4>(f: F, a: [&[f64]; MR], b: [&[f64]; NR], len: usize) -> [[f64; NR]; MR] {
    let quads = len / 4;
    let a4: [&[[f64; 4]]; MR] = a.map(|s| &s[..len].as_chunks::<4>().0[..quads]);
    let b4: [&[[f64; 4]]; NR] = b.map(|s| &s[..len].as_chunks::<4>().0[..quads]);
    let zero = f.load([0.0; 4]);
    let mut acc = [[zero; NR]; MR];
    for q in 0..quads {
        dot_step(
            f,
            &mut acc,
            from_fn(|i| f.load(a4[i][q])),
            from_fn(|j| f.load(b4[j][q])),
        );
    }
    // The last rows as one zero-padded step.
    if quads * 4 < len {
        let tail = |s: &[f64]| f.load(from_fn(|l| s.get(quads * 4 + l).copied().unwrap_or(0.0)));
        dot_step(
            f,
            &mut acc,
            a.map(|s| tail(&s[..len])),
            b.map(|s| tail(&s[..len])),
        );
    }
    from_fn(|i| f.sums(acc[i]))
}

/// One step of [`dot_tile`]: four rows of every column pair into their sums' lanes. A function
/// of its own, not a closure, so that it always inlines (a closure that did not took every
/// multiply-add out of the vector context).
#[inline(always)]
fn dot_step<F: Fma4>(f: F, acc: &mut [[F::V; NR]; MR], av: [F::V; MR], bv: [F::V; NR]) {
    for j in 0..NR {
        for i in 0..MR {
            acc[i][j] = f.mul_add(av[i], bv[j], acc[i][j]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padded_shapes_are_whole_tiles() {
        assert_eq!(padded_shape(1, 1), (3, 4));
        assert_eq!(padded_shape(6, 8), (6, 8));
        assert_eq!(padded_shape(7, 12), (9, 12));
        assert_eq!(padded_shape(13, 13), (15, 16));
        assert_eq!(padded_shape(55, 6), (57, 8));
    }

    #[test]
    fn product_of_column_sets() {
        // Odd sizes: padded tiles in both directions and a row tail.
        for (m, n, len) in [
            (1, 1, 1),
            (2, 3, 3),
            (7, 9, 9),
            (11, 4, 37),
            (13, 21, 64),
            (24, 33, 255),
            (41, 20, 130),
        ] {
            let stride = len + 5;
            let data: Vec<f64> = (0..stride * (m + n + 2))
                .map(|v| ((v * 37 % 101) as f64 - 50.0) / 7.0)
                .collect();
            let (pm, pn) = padded_shape(m, n);
            // Columns in any order, some used twice; the padding points at a zero column.
            let zero = m + n + 1;
            let mut data = data;
            data[zero * stride..(zero + 1) * stride].fill(0.0);
            let rows: Vec<usize> = (0..pm)
                .map(|i| if i < m { (i * 5) % (m + n) } else { zero })
                .collect();
            let cols: Vec<usize> = (0..pn)
                .map(|j| if j < n { (j * 3 + 1) % (m + n + 1) } else { zero })
                .collect();
            // Each product starts from 0.5 everywhere, to show the sums are added.
            let added = |run: &dyn Fn(AddProduct<'_>)| {
                let mut product = vec![0.5; pm * pn];
                run(AddProduct {
                    data: &data,
                    rows: &rows,
                    cols: &cols,
                    stride,
                    len,
                    product: &mut product,
                });
                product
            };
            let product = added(&|op| op.run(Portable));
            assert_eq!(
                added(&|op| op.dispatched()),
                product,
                "dispatched and portable lanes differ"
            );
            // Each vector width this CPU has, whichever `dispatched` chose (the wide tile on
            // every CPU with AVX-512F, AMD's included, though the dispatch takes it on Intel's).
            #[cfg(target_arch = "x86_64")]
            {
                if let Some(v3) = pulp::x86::V3::try_new() {
                    let avx2 = added(&|op| vectorized(v3, op, v3));
                    assert_eq!(avx2, product, "AVX2 and portable lanes differ");
                    if let Some(wide) = Avx512::try_new(v3) {
                        let avx512 = added(&|op| vectorized(v3, op, wide));
                        assert_eq!(avx512, product, "AVX-512 and portable lanes differ");
                    }
                }
            }
            let at = |c: usize, r: usize| data[c * stride + r];
            for i in 0..pm {
                for j in 0..pn {
                    let got = product[i * pn + j];
                    let expected = 0.5 + (0..len).map(|r| at(rows[i], r) * at(cols[j], r)).sum::<f64>();
                    assert!(
                        (got - expected).abs() <= 1e-12 * (1.0 + expected.abs()),
                        "({i},{j}) of {m}x{n}, len {len}: {got} vs {expected}"
                    );
                }
            }
        }
    }
}
