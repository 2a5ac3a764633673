//! The feed-forward network: tanh hidden layers, a linear output layer, flat weight storage.
//!
//! Weights are one flat vector, layer after layer; each layer stores its weight matrix row-major
//! (one row per unit, one column per input) followed by its biases. The same layout is used for
//! the columns of the Jacobian.

use std::array::from_fn;

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{check_finite, ModelError};

/// Samples per register-held chunk of the block forward pass.
const FORWARD_CHUNK: usize = 16;

/// Largest supported number of hidden layers.
pub const MAX_HIDDEN_LAYERS: usize = 3;

/// Hyperbolic tangent, written so that LLVM vectorises it (no libm call, no branches):
/// tanh(|x|) = −u/(2 + u) with u = expm1(−2|x|), the expm1 by range reduction to |r| ≤ ln2/2
/// and a degree-13 Taylor polynomial, so it is accurate near 0 as well. Within a few ulps of
/// `f64::tanh` (see the tests); ±1 for |x| ≥ 20, NaN for NaN.
#[inline(always)]
pub fn tanh(x: f64) -> f64 {
    tanh_lanes([x])[0]
}

/// [`tanh`] of every element, in place (vectorised).
#[inline(always)]
pub fn tanh_in_place(values: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::has_avx512() {
        // SAFETY: the CPU has the kernel's features (checked just above).
        unsafe { tanh_in_place_avx512(values) };
        return;
    }
    tanh_chunks(values);
}

crate::simd::avx512_kernel! {
    /// [`tanh_in_place`] in 512-bit registers: the same operations, so the same bits.
    fn tanh_in_place_avx512(values: &mut [f64]) {
        use std::arch::x86_64::*;
        // Written out: left to itself, LLVM vectorises across chunks with gathers and scatters.
        let (pairs, rest) = values.as_chunks_mut::<16>();
        for pair in pairs {
            let at = pair.as_mut_ptr();
            // SAFETY: `at` starts 16 values.
            let (low, high) = unsafe { (_mm512_loadu_pd(at), _mm512_loadu_pd(at.add(8))) };
            let [low, high] = tanh_avx512([low, high]);
            // SAFETY: as for the loads.
            unsafe {
                _mm512_storeu_pd(at, low);
                _mm512_storeu_pd(at.add(8), high);
            }
        }
        let (chunks, rest) = rest.as_chunks_mut::<8>();
        for chunk in chunks {
            // SAFETY: a chunk is eight values.
            let [t] = tanh_avx512([unsafe { _mm512_loadu_pd(chunk.as_ptr()) }]);
            // SAFETY: as for the load.
            unsafe { _mm512_storeu_pd(chunk.as_mut_ptr(), t) };
        }
        for v in rest {
            *v = tanh(*v);
        }
    }

    /// [`tanh_lanes`] of N vectors of eight, operation for operation (no fused multiply-adds),
    /// so that each lane has the bits of the scalar call.
    #[inline]
    fn tanh_avx512<const N: usize>(
        x: [std::arch::x86_64::__m512d; N],
    ) -> [std::arch::x86_64::__m512d; N] {
        use std::arch::x86_64::*;
        let splat = _mm512_set1_pd;
        let sign = _mm512_set1_epi64(i64::MIN);
        let (add, sub, mul) = (_mm512_add_pd, _mm512_sub_pd, _mm512_mul_pd);
        let mut out = x;
        for (out, &x) in out.iter_mut().zip(&x) {
            let magnitude = _mm512_castsi512_pd(_mm512_andnot_si512(sign, _mm512_castpd_si512(x)));
            // min(20, |x|) returns |x| when it is NaN, as the scalar comparison does.
            let y = mul(splat(-2.0), _mm512_min_pd(splat(20.0), magnitude));
            let shifted = add(mul(y, splat(std::f64::consts::LOG2_E)), splat(ROUNDER));
            let k = sub(shifted, splat(ROUNDER));
            let r = sub(sub(y, mul(k, splat(LN2_HI))), mul(k, splat(LN2_LO)));
            let r2 = mul(r, r);
            let r4 = mul(r2, r2);
            let pair = |j: usize| add(splat(TANH_C[j]), mul(splat(TANH_C[j + 1]), r));
            let (p0, p2, p4, p6, p8, p10) = (pair(0), pair(2), pair(4), pair(6), pair(8), pair(10));
            let low = add(add(p0, mul(p2, r2)), mul(add(p4, mul(p6, r2)), r4));
            let high = add(p8, mul(p10, r2));
            let p = add(low, mul(high, mul(r4, r4)));
            let expm1_r = add(r, mul(r2, p));
            let k_int = _mm512_sub_epi64(
                _mm512_castpd_si512(shifted),
                _mm512_set1_epi64(ROUNDER.to_bits() as i64),
            );
            let scale = _mm512_castsi512_pd(_mm512_slli_epi64::<52>(_mm512_add_epi64(
                k_int,
                _mm512_set1_epi64(1023),
            )));
            let u = add(mul(scale, expm1_r), sub(scale, splat(1.0)));
            let negative_u = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(u), sign));
            let t = _mm512_div_pd(negative_u, add(splat(2.0), u));
            *out = _mm512_castsi512_pd(_mm512_or_si512(
                _mm512_andnot_si512(sign, _mm512_castpd_si512(t)),
                _mm512_and_si512(sign, _mm512_castpd_si512(x)),
            ));
        }
        out
    }
}

#[inline(always)]
fn tanh_chunks(values: &mut [f64]) {
    let (chunks, rest) = values.as_chunks_mut::<8>();
    for chunk in chunks {
        *chunk = tanh_lanes(*chunk);
    }
    for v in rest {
        *v = tanh(*v);
    }
}

// ln 2 split as in fdlibm: the high part has trailing zero bits, so k·LN2_HI is exact.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
// 1.5·2^52: adding it rounds to an integer, whose value sits in the low mantissa bits.
const ROUNDER: f64 = 6_755_399_441_055_744.0;
/// Taylor coefficients of (expm1(r) − r)/r², 1/2! to 1/13!.
const TANH_C: [f64; 12] = [
    0.5,
    1.666_666_666_666_666_6e-1,
    4.166_666_666_666_666_4e-2,
    8.333_333_333_333_333e-3,
    1.388_888_888_888_889e-3,
    1.984_126_984_126_984e-4,
    2.480_158_730_158_73e-5,
    2.755_731_922_398_589_3e-6,
    2.755_731_922_398_589e-7,
    2.505_210_838_544_172e-8,
    2.087_675_698_786_81e-9,
    1.605_904_383_682_161_3e-10,
];

/// [`tanh`] of N values, one step of the computation for all of them before the next: two
/// vectors' dependency chains then run interleaved (~30 % faster than a loop over single
/// values, which waits on each chain). Every lane does the same operations as the scalar call.
#[inline(always)]
fn tanh_lanes<const N: usize>(x: [f64; N]) -> [f64; N] {
    // Clamped so that a NaN passes through (`f64::min` would turn it into 20): every step
    // below then yields NaN without a select, which LLVM would make a slow masked store.
    let y: [f64; N] = from_fn(|i| {
        let magnitude = x[i].abs();
        -2.0 * if magnitude > 20.0 { 20.0 } else { magnitude }
    });
    let shifted: [f64; N] = from_fn(|i| y[i] * std::f64::consts::LOG2_E + ROUNDER);
    let k: [f64; N] = from_fn(|i| shifted[i] - ROUNDER);
    let r: [f64; N] = from_fn(|i| (y[i] - k[i] * LN2_HI) - k[i] * LN2_LO);
    // Estrin's scheme: a dependency chain of 7 operations instead of Horner's 22. Plain
    // multiply-add, not `mul_add`: outside an AVX2 context `mul_add` is a libm call (4× slower
    // per-sample prediction).
    let r2: [f64; N] = from_fn(|i| r[i] * r[i]);
    let r4: [f64; N] = from_fn(|i| r2[i] * r2[i]);
    let pair = |j: usize| -> [f64; N] { from_fn(|i| TANH_C[j] + TANH_C[j + 1] * r[i]) };
    let (p0, p2, p4, p6, p8, p10) = (pair(0), pair(2), pair(4), pair(6), pair(8), pair(10));
    let low: [f64; N] = from_fn(|i| (p0[i] + p2[i] * r2[i]) + (p4[i] + p6[i] * r2[i]) * r4[i]);
    let high: [f64; N] = from_fn(|i| p8[i] + p10[i] * r2[i]);
    let p: [f64; N] = from_fn(|i| low[i] + high[i] * (r4[i] * r4[i]));
    let expm1_r: [f64; N] = from_fn(|i| r[i] + r2[i] * p[i]);
    let scale: [f64; N] = from_fn(|i| {
        let k_int = (shifted[i].to_bits() as i64).wrapping_sub(ROUNDER.to_bits() as i64);
        f64::from_bits((k_int.wrapping_add(1023) as u64) << 52)
    });
    let u: [f64; N] = from_fn(|i| scale[i] * expm1_r[i] + (scale[i] - 1.0));
    from_fn(|i| (-u[i] / (2.0 + u[i])).copysign(x[i]))
}

/// Layer sizes from inputs to outputs, and where each layer's parameters start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// `sizes[0]` inputs, then the hidden layers, then the outputs.
    pub sizes: Vec<usize>,
    /// `offsets[l - 1]` is where layer `l`'s weight matrix starts; its biases follow it.
    offsets: Vec<usize>,
    n_params: usize,
}

impl Layout {
    pub fn new(inputs: usize, hidden: &[usize], outputs: usize) -> Layout {
        let mut sizes = vec![inputs];
        sizes.extend_from_slice(hidden);
        sizes.push(outputs);
        let mut offsets = Vec::with_capacity(sizes.len() - 1);
        let mut n_params = 0;
        for l in 1..sizes.len() {
            offsets.push(n_params);
            n_params += sizes[l] * (sizes[l - 1] + 1);
        }
        Layout {
            sizes,
            offsets,
            n_params,
        }
    }

    pub fn inputs(&self) -> usize {
        self.sizes[0]
    }

    pub fn outputs(&self) -> usize {
        *self.sizes.last().expect("a layout has an output layer")
    }

    pub fn hidden(&self) -> &[usize] {
        &self.sizes[1..self.sizes.len() - 1]
    }

    /// Number of weights and biases.
    pub fn n_params(&self) -> usize {
        self.n_params
    }

    /// Number of weight layers (hidden layers + 1).
    pub fn n_layers(&self) -> usize {
        self.sizes.len() - 1
    }

    /// Length of the activation buffer used by [`Layout::forward`]: every layer's values.
    pub fn n_activations(&self) -> usize {
        self.sizes.iter().sum()
    }

    /// Start of layer `l`'s weight matrix (`l` from 1) and of its biases.
    pub(crate) fn layer_offsets(&self, l: usize) -> (usize, usize) {
        let w = self.offsets[l - 1];
        (w, w + self.sizes[l] * self.sizes[l - 1])
    }

    /// Propagates one input vector. `activations` (length [`Layout::n_activations`]) receives the
    /// input, every hidden layer's output and the network output, in that order; the output is
    /// its last `outputs()` values.
    #[inline]
    pub fn forward(&self, weights: &[f64], input: &[f64], activations: &mut [f64]) {
        let n0 = self.sizes[0];
        activations[..n0].copy_from_slice(input);
        let mut start = 0;
        let last = self.n_layers();
        for l in 1..=last {
            let (n_in, n_out) = (self.sizes[l - 1], self.sizes[l]);
            let (w_at, b_at) = self.layer_offsets(l);
            let (done, rest) = activations.split_at_mut(start + n_in);
            let a_in = &done[start..];
            let a_out = &mut rest[..n_out];
            for i in 0..n_out {
                let row = &weights[w_at + i * n_in..w_at + (i + 1) * n_in];
                let mut z = weights[b_at + i];
                for (w, a) in row.iter().zip(a_in) {
                    z += w * a;
                }
                a_out[i] = if l == last { z } else { tanh(z) };
            }
            start += n_in;
        }
    }

    /// Writes the derivatives of every network output with respect to every parameter, given the
    /// activations of one sample from [`Layout::forward`]: `columns` holds `outputs()` contiguous
    /// vectors of `n_params()` values (one row of the Jacobian per output, stored as a column of
    /// Jᵀ). `delta` is scratch of at least twice the widest layer.
    #[inline]
    pub fn output_gradients(
        &self,
        weights: &[f64],
        activations: &[f64],
        columns: &mut [f64],
        delta: &mut [f64],
    ) {
        let n_p = self.n_params;
        let last = self.n_layers();
        let widest = *self.sizes.iter().max().expect("non-empty");
        let (delta_here, delta_below) = delta.split_at_mut(widest);
        // Activation start of every layer.
        let mut act_start = [0usize; MAX_HIDDEN_LAYERS + 2];
        for l in 1..=last {
            act_start[l] = act_start[l - 1] + self.sizes[l - 1];
        }
        for k in 0..self.outputs() {
            let column = &mut columns[k * n_p..(k + 1) * n_p];
            column.fill(0.0);
            // Output layer: only unit k depends on its own row and bias.
            let n_in = self.sizes[last - 1];
            let (w_at, b_at) = self.layer_offsets(last);
            let a_in = &activations[act_start[last - 1]..act_start[last - 1] + n_in];
            column[w_at + k * n_in..w_at + (k + 1) * n_in].copy_from_slice(a_in);
            column[b_at + k] = 1.0;
            if last == 1 {
                continue;
            }
            // Sensitivity of output k to the last hidden layer's pre-activations.
            let row_k = &weights[w_at + k * n_in..w_at + (k + 1) * n_in];
            for i in 0..n_in {
                let a = a_in[i];
                delta_here[i] = row_k[i] * (1.0 - a * a);
            }
            for l in (1..last).rev() {
                let (n_in, n_out) = (self.sizes[l - 1], self.sizes[l]);
                let (w_at, b_at) = self.layer_offsets(l);
                let a_in = &activations[act_start[l - 1]..act_start[l - 1] + n_in];
                for i in 0..n_out {
                    let d = delta_here[i];
                    let grad = &mut column[w_at + i * n_in..w_at + (i + 1) * n_in];
                    for (g, a) in grad.iter_mut().zip(a_in) {
                        *g = d * a;
                    }
                    column[b_at + i] = d;
                }
                if l > 1 {
                    delta_below[..n_in].fill(0.0);
                    for i in 0..n_out {
                        let d = delta_here[i];
                        let row = &weights[w_at + i * n_in..w_at + (i + 1) * n_in];
                        for (s, w) in delta_below[..n_in].iter_mut().zip(row) {
                            *s += d * w;
                        }
                    }
                    for j in 0..n_in {
                        let a = a_in[j];
                        delta_here[j] = delta_below[j] * (1.0 - a * a);
                    }
                }
            }
        }
    }

    /// Start of every layer's values in the activation buffer (layer 0 = the inputs).
    fn activation_starts(&self) -> [usize; MAX_HIDDEN_LAYERS + 3] {
        let mut starts = [0usize; MAX_HIDDEN_LAYERS + 3];
        for l in 1..self.sizes.len() {
            starts[l] = starts[l - 1] + self.sizes[l - 1];
        }
        starts
    }

    /// [`Layout::forward`] for `count` samples at once, a layer at a time. `inputs` holds the
    /// samples one after another (`count × inputs()`); `activations` (length
    /// `n_activations() × count`) receives every unit's values over the block, unit after unit:
    /// unit `a`'s value for sample `s` is at `a·count + s`, so the outputs are the last
    /// `outputs() × count` values. Bit for bit the same values as [`Layout::forward`].
    /// Inlined so that callers can compile it for the machine's vector extension.
    #[inline(always)]
    pub fn forward_block(&self, weights: &[f64], inputs: &[f64], count: usize, activations: &mut [f64]) {
        let n0 = self.sizes[0];
        for (s, input) in inputs[..count * n0].chunks_exact(n0).enumerate() {
            for (j, v) in input.iter().enumerate() {
                activations[j * count + s] = *v;
            }
        }
        let starts = self.activation_starts();
        let last = self.n_layers();
        for l in 1..=last {
            let (n_in, n_out) = (self.sizes[l - 1], self.sizes[l]);
            let (w_at, b_at) = self.layer_offsets(l);
            let (done, rest) = activations.split_at_mut(starts[l] * count);
            let a_in = &done[starts[l - 1] * count..];
            let a_out = &mut rest[..n_out * count];
            let hidden = l != last;
            for (i, z) in a_out.chunks_exact_mut(count).enumerate() {
                let bias = weights[b_at + i];
                let row = &weights[w_at + i * n_in..w_at + (i + 1) * n_in];
                // FORWARD_CHUNK samples at a time in registers through every input, then one store
                // (a pass per input would load and store z every time). The tanh is a separate
                // pass: fused here it spilled registers and was slower.
                let whole = count - count % FORWARD_CHUNK;
                for (c, z) in z[..whole]
                    .as_chunks_mut::<FORWARD_CHUNK>()
                    .0
                    .iter_mut()
                    .enumerate()
                {
                    let at = c * FORWARD_CHUNK;
                    let mut sum = [bias; FORWARD_CHUNK];
                    for (w, a) in row.iter().zip(a_in.chunks_exact(count)) {
                        let a = &a[at..at + FORWARD_CHUNK];
                        for (sum, a) in sum.iter_mut().zip(a) {
                            *sum += w * a;
                        }
                    }
                    *z = sum;
                }
                for (s, z) in z.iter_mut().enumerate().skip(whole) {
                    let mut sum = bias;
                    for (w, a) in row.iter().zip(a_in.chunks_exact(count)) {
                        sum += w * a[s];
                    }
                    *z = sum;
                }
            }
            if hidden {
                tanh_in_place(a_out);
            }
        }
    }

    /// [`Layout::output_gradients`] for a block of `count` samples from
    /// [`Layout::forward_block`], written as J (not Jᵀ), column-major: `outputs() × count` rows,
    /// output-major (row `k·count + s` is output `k` of sample `s`), one column of that length per
    /// parameter. `delta` is scratch of [`Layout::n_delta_block`]`(count)`. The same values, bit
    /// for bit, as the per-sample routine. Inlined like [`Layout::forward_block`].
    #[inline(always)]
    pub fn jacobian_block(
        &self,
        weights: &[f64],
        activations: &[f64],
        count: usize,
        jacobian: &mut [f64],
        delta: &mut [f64],
    ) {
        let rows = self.outputs() * count;
        let n_in = self.sizes[self.n_layers() - 1];
        let (w_at, b_at) = self.layer_offsets(self.n_layers());
        for k in 0..self.outputs() {
            // Output k does not depend on the other outputs' rows and biases.
            for unit in (0..self.outputs()).filter(|&unit| unit != k) {
                let params = (w_at + unit * n_in..w_at + (unit + 1) * n_in).chain([b_at + unit]);
                for p in params {
                    jacobian[p * rows + k * count..][..count].fill(0.0);
                }
            }
            self.jacobian_block_output(weights, activations, count, k, rows, k * count, jacobian, delta);
        }
    }

    /// Output `k`'s rows of [`Layout::jacobian_block`]: column `p` of them at
    /// `p·stride + first_row ..` (`count` values), except the columns of the other outputs'
    /// weights and biases, which are zero and left untouched. Each column is a sensitivity from
    /// [`Layout::sensitivities_block`] times a layer input (or 1 for a bias).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn jacobian_block_output(
        &self,
        weights: &[f64],
        activations: &[f64],
        count: usize,
        k: usize,
        stride: usize,
        first_row: usize,
        jacobian: &mut [f64],
        delta: &mut [f64],
    ) {
        debug_assert!(stride >= first_row + count);
        let last = self.n_layers();
        let starts = self.activation_starts();
        let layer_values = |l: usize, n: usize| &activations[starts[l] * count..(starts[l] + n) * count];
        let column = |p: usize| p * stride + first_row..p * stride + first_row + count;
        let n_in = self.sizes[last - 1];
        let (w_at, b_at) = self.layer_offsets(last);
        for (j, a) in layer_values(last - 1, n_in).chunks_exact(count).enumerate() {
            jacobian[column(w_at + k * n_in + j)].copy_from_slice(a);
        }
        jacobian[column(b_at + k)].fill(1.0);
        let sensitivities = &mut delta[..self.hidden_units() * count];
        self.sensitivities_block(weights, activations, count, k, sensitivities);
        let mut first_unit = 0;
        for l in 1..last {
            let (n_in, n_out) = (self.sizes[l - 1], self.sizes[l]);
            let (w_at, b_at) = self.layer_offsets(l);
            let a_in = layer_values(l - 1, n_in);
            let layer = &sensitivities[first_unit * count..(first_unit + n_out) * count];
            for (i, d) in layer.chunks_exact(count).enumerate() {
                for (j, a) in a_in.chunks_exact(count).enumerate() {
                    let col = &mut jacobian[column(w_at + i * n_in + j)];
                    for ((g, d), a) in col.iter_mut().zip(d).zip(a) {
                        *g = d * a;
                    }
                }
                jacobian[column(b_at + i)].copy_from_slice(d);
            }
            first_unit += n_out;
        }
    }

    /// The derivatives of output `k` with respect to every hidden unit's pre-activation over a
    /// block of `count` samples from [`Layout::forward_block`] (backpropagation): hidden unit `u`
    /// (counted from the first hidden layer's first unit) at `u·count ..` of `sensitivities`
    /// ([`Layout::hidden_units`]` × count` values).
    #[inline(always)]
    pub(crate) fn sensitivities_block(
        &self,
        weights: &[f64],
        activations: &[f64],
        count: usize,
        k: usize,
        sensitivities: &mut [f64],
    ) {
        let last = self.n_layers();
        if last == 1 {
            return;
        }
        let starts = self.activation_starts();
        let layer_values = |l: usize, n: usize| &activations[starts[l] * count..(starts[l] + n) * count];
        // Hidden layer l's units start at unit starts[l] − inputs.
        let unit_range =
            |l: usize| (starts[l] - self.sizes[0]) * count..(starts[l + 1] - self.sizes[0]) * count;
        let n_in = self.sizes[last - 1];
        let (w_at, _) = self.layer_offsets(last);
        let row_k = &weights[w_at + k * n_in..w_at + (k + 1) * n_in];
        for ((d, a), w) in sensitivities[unit_range(last - 1)]
            .chunks_exact_mut(count)
            .zip(layer_values(last - 1, n_in).chunks_exact(count))
            .zip(row_k)
        {
            for (d, a) in d.iter_mut().zip(a) {
                *d = w * (1.0 - a * a);
            }
        }
        for l in (2..last).rev() {
            let (n_in, n_out) = (self.sizes[l - 1], self.sizes[l]);
            let (w_at, _) = self.layer_offsets(l);
            let (lower, upper) = sensitivities.split_at_mut(unit_range(l).start);
            let here = &upper[..n_out * count];
            let below = &mut lower[unit_range(l - 1)];
            // Unit j's sensitivity: Σ_i d_i·w_ij in i order, times 1 − a_j², FORWARD_CHUNK
            // samples at a time in registers (a pass per i would load and store it every time).
            let whole = count - count % FORWARD_CHUNK;
            for (j, (s, a)) in below
                .chunks_exact_mut(count)
                .zip(layer_values(l - 1, n_in).chunks_exact(count))
                .enumerate()
            {
                let column = |i: usize| weights[w_at + i * n_in + j];
                for (c, s) in s[..whole]
                    .as_chunks_mut::<FORWARD_CHUNK>()
                    .0
                    .iter_mut()
                    .enumerate()
                {
                    let at = c * FORWARD_CHUNK;
                    let mut sum = [0.0; FORWARD_CHUNK];
                    for (i, d) in here.chunks_exact(count).enumerate() {
                        let w = column(i);
                        for (sum, d) in sum.iter_mut().zip(&d[at..at + FORWARD_CHUNK]) {
                            *sum += d * w;
                        }
                    }
                    for ((s, sum), a) in s.iter_mut().zip(sum).zip(&a[at..at + FORWARD_CHUNK]) {
                        *s = sum * (1.0 - a * a);
                    }
                }
                for (r, s) in s.iter_mut().enumerate().skip(whole) {
                    let mut sum = 0.0;
                    for (i, d) in here.chunks_exact(count).enumerate() {
                        sum += d[r] * column(i);
                    }
                    *s = sum * (1.0 - a[r] * a[r]);
                }
            }
        }
    }

    /// Number of hidden units over all hidden layers.
    pub fn hidden_units(&self) -> usize {
        self.hidden().iter().sum()
    }

    /// Scratch length for [`Layout::jacobian_block`]'s `delta` with `count` samples.
    pub fn n_delta_block(&self, count: usize) -> usize {
        self.hidden_units() * count
    }

    /// Scratch length for [`Layout::output_gradients`]'s `delta`.
    pub fn n_delta(&self) -> usize {
        2 * self.sizes.iter().max().expect("non-empty")
    }

    /// Nguyen–Widrow initial weights with MATLAB's `initnw` semantics for inputs scaled to
    /// [−1, 1]: each tanh layer of S units and R inputs gets row-normalised uniform directions of
    /// magnitude 0.7·S^(1/R), biases spread evenly over [−magnitude, magnitude] with the sign of
    /// the row's first weight (0 for a single unit), all widened to tanh's active input range
    /// [−2, 2]. The linear output layer has no finite active range, where `initnw` falls back to
    /// random values (our reading of it): its weights and biases are uniform in [−1, 1].
    pub fn nguyen_widrow<R: Rng>(&self, rng: &mut R) -> Vec<f64> {
        const ACTIVE_HALF_RANGE: f64 = 2.0;
        let mut weights = vec![0.0; self.n_params];
        let last = self.n_layers();
        for l in 1..=last {
            let (r, s) = (self.sizes[l - 1], self.sizes[l]);
            let (w_at, b_at) = self.layer_offsets(l);
            if l == last {
                for v in &mut weights[w_at..b_at + s] {
                    *v = rng.gen_range(-1.0..=1.0);
                }
                continue;
            }
            let magnitude = 0.7 * (s as f64).powf(1.0 / r as f64);
            for i in 0..s {
                let row = &mut weights[w_at + i * r..w_at + (i + 1) * r];
                for v in row.iter_mut() {
                    *v = rng.gen_range(-1.0..=1.0);
                }
                let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
                // A zero row has no direction; MATLAB's normr leaves it, so do we.
                let scale = if norm > 0.0 { magnitude / norm } else { 0.0 };
                for v in row.iter_mut() {
                    *v *= scale;
                }
            }
            for i in 0..s {
                let spread = if s == 1 {
                    0.0
                } else {
                    -1.0 + 2.0 * i as f64 / (s - 1) as f64
                };
                let first = weights[w_at + i * r];
                let sign = if first > 0.0 {
                    1.0
                } else if first < 0.0 {
                    -1.0
                } else {
                    0.0
                };
                weights[b_at + i] = magnitude * spread * sign;
            }
            for v in &mut weights[w_at..b_at + s] {
                *v *= ACTIVE_HALF_RANGE;
            }
        }
        weights
    }
}

/// A network's shape and weights, as saved in a corrector file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Network {
    pub inputs: usize,
    pub hidden: Vec<usize>,
    pub outputs: usize,
    /// Flat weights, layer by layer: weight matrix row-major (unit × input), then biases.
    pub weights: Vec<f64>,
}

impl Network {
    pub fn layout(&self) -> Layout {
        Layout::new(self.inputs, &self.hidden, self.outputs)
    }

    /// Layer sizes as `inputs-hidden…-outputs`, e.g. `2-10-6-2`.
    pub fn label(&self) -> String {
        std::iter::once(self.inputs)
            .chain(self.hidden.iter().copied())
            .chain([self.outputs])
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join("-")
    }

    /// A saved network that its own layout can run: at least one input and output, at most
    /// [`MAX_HIDDEN_LAYERS`] hidden layers of at least one unit, exactly as many weights as the
    /// layout needs (counted without overflow), every weight finite. Fields relative to the
    /// network. After this, [`Network::layout`] and [`Layout::forward`] cannot fail.
    pub fn check(&self) -> Result<(), ModelError> {
        if self.inputs == 0 {
            return Err(ModelError::new("inputs", "0: a network needs at least one input"));
        }
        if self.outputs == 0 {
            return Err(ModelError::new(
                "outputs",
                "0: a network needs at least one output",
            ));
        }
        if self.hidden.len() > MAX_HIDDEN_LAYERS {
            return Err(ModelError::new(
                "hidden",
                format!(
                    "{} hidden layers; at most {MAX_HIDDEN_LAYERS} are supported",
                    self.hidden.len()
                ),
            ));
        }
        if let Some(l) = self.hidden.iter().position(|&h| h == 0) {
            return Err(ModelError::new(
                format!("hidden[{l}]"),
                "0 units: every hidden layer needs at least one",
            ));
        }
        let sizes: Vec<usize> = std::iter::once(self.inputs)
            .chain(self.hidden.iter().copied())
            .chain([self.outputs])
            .collect();
        let n_params = sizes.windows(2).try_fold(0usize, |n, pair| {
            pair[1]
                .checked_mul(pair[0].checked_add(1)?)
                .and_then(|layer| n.checked_add(layer))
        });
        let activations = sizes.iter().try_fold(0usize, |n, &s| n.checked_add(s));
        let (Some(n_params), Some(_)) = (n_params, activations) else {
            return Err(ModelError::new(
                "hidden",
                format!("the layout {} is too large to count", self.label()),
            ));
        };
        if self.weights.len() != n_params {
            return Err(ModelError::new(
                "weights",
                format!(
                    "{} values, but the layout {} needs {n_params}",
                    self.weights.len(),
                    self.label()
                ),
            ));
        }
        check_finite("weights", &self.weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Central differences of the outputs against the backpropagated gradients.
    fn check_gradients(inputs: usize, hidden: &[usize], outputs: usize, seed: u64) {
        let layout = Layout::new(inputs, hidden, outputs);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let weights: Vec<f64> = (0..layout.n_params()).map(|_| rng.gen_range(-1.5..1.5)).collect();
        let x: Vec<f64> = (0..inputs).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let mut act = vec![0.0; layout.n_activations()];
        let mut delta = vec![0.0; layout.n_delta()];
        let mut columns = vec![0.0; outputs * layout.n_params()];
        layout.forward(&weights, &x, &mut act);
        layout.output_gradients(&weights, &act, &mut columns, &mut delta);
        let out_at = layout.n_activations() - outputs;
        let h = 1e-6;
        let mut w = weights.clone();
        for p in 0..layout.n_params() {
            w[p] = weights[p] + h;
            layout.forward(&w, &x, &mut act);
            let plus: Vec<f64> = act[out_at..].to_vec();
            w[p] = weights[p] - h;
            layout.forward(&w, &x, &mut act);
            w[p] = weights[p];
            for k in 0..outputs {
                let numeric = (plus[k] - act[out_at + k]) / (2.0 * h);
                let analytic = columns[k * layout.n_params() + p];
                let tolerance = 1e-6 * analytic.abs().max(numeric.abs()).max(1e-3);
                assert!(
                    (numeric - analytic).abs() <= tolerance,
                    "{inputs}-{hidden:?}-{outputs} param {p} output {k}: backprop {analytic} vs finite difference {numeric}"
                );
            }
        }
    }

    #[test]
    fn vectorised_tanh_is_within_a_few_ulps_of_std() {
        let mut worst = 0u64;
        let mut checked = Vec::new();
        let mut check = |x: f64| {
            checked.push(x);
            let (ours, std) = (tanh(x), x.tanh());
            let ulps = (ours.to_bits() as i64 - std.to_bits() as i64).unsigned_abs();
            assert!(ulps <= 4, "tanh({x:e}): {ours:e} vs std {std:e} ({ulps} ulps)");
            worst = worst.max(ulps);
        };
        for i in -250_000..=250_000 {
            check(i as f64 * 1e-4); // [-25, 25]
        }
        for e in -320..=1 {
            let x = 1.7 * 10f64.powi(e);
            check(x);
            check(-x);
        }
        for x in [
            0.0,
            -0.0,
            19.0,
            19.5,
            20.0,
            709.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            check(x);
        }
        assert!(tanh(f64::NAN).is_nan());
        assert_eq!(tanh(-0.0).to_bits(), (-0.0f64).to_bits());
        // The slice version (whichever vector width this CPU runs) equals the scalar one bit for
        // bit, on every value above, NaN among them, with and without a tail of whole vectors.
        checked.insert(12_345, f64::NAN);
        checked.push(-f64::NAN);
        for trim in [0, 9] {
            let mut v = checked[..checked.len() - trim].to_vec();
            tanh_in_place(&mut v);
            for (x, t) in checked.iter().zip(&v) {
                let expected = tanh(*x);
                assert!(
                    t.to_bits() == expected.to_bits() || (t.is_nan() && expected.is_nan()),
                    "tanh_in_place({x:e}) = {t:e}, tanh = {expected:e}"
                );
            }
        }
    }

    #[test]
    fn block_passes_equal_the_per_sample_ones_bit_for_bit() {
        for (inputs, hidden, outputs) in [(1, vec![], 1), (2, vec![10, 6], 2), (9, vec![4, 3, 2], 3)] {
            let layout = Layout::new(inputs, &hidden, outputs);
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let weights: Vec<f64> = (0..layout.n_params()).map(|_| rng.gen_range(-1.5..1.5)).collect();
            let count = 37;
            let x: Vec<f64> = (0..count * inputs).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let (n_a, n_p) = (layout.n_activations(), layout.n_params());
            let mut block_act = vec![0.0; n_a * count];
            let mut block_delta = vec![0.0; layout.n_delta_block(count)];
            let mut jacobian = vec![f64::NAN; n_p * outputs * count];
            layout.forward_block(&weights, &x, count, &mut block_act);
            layout.jacobian_block(&weights, &block_act, count, &mut jacobian, &mut block_delta);
            let mut act = vec![0.0; n_a];
            let mut delta = vec![0.0; layout.n_delta()];
            let mut columns = vec![0.0; outputs * n_p];
            for s in 0..count {
                layout.forward(&weights, &x[s * inputs..(s + 1) * inputs], &mut act);
                layout.output_gradients(&weights, &act, &mut columns, &mut delta);
                for a in 0..n_a {
                    assert_eq!(act[a].to_bits(), block_act[a * count + s].to_bits());
                }
                for k in 0..outputs {
                    for p in 0..n_p {
                        let block = jacobian[p * outputs * count + k * count + s];
                        assert_eq!(columns[k * n_p + p].to_bits(), block.to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn backprop_matches_finite_differences() {
        check_gradients(1, &[], 1, 1);
        check_gradients(3, &[5], 1, 2);
        check_gradients(2, &[10, 6], 2, 3);
        check_gradients(9, &[4, 3, 2], 3, 4);
    }

    #[test]
    fn nguyen_widrow_rows_have_the_stated_magnitude() {
        let layout = Layout::new(3, &[8], 1);
        let w = layout.nguyen_widrow(&mut ChaCha8Rng::seed_from_u64(7));
        let expected = 2.0 * 0.7 * 8f64.powf(1.0 / 3.0);
        for i in 0..8 {
            let norm = w[i * 3..i * 3 + 3].iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((norm - expected).abs() < 1e-12);
        }
        // Biases run from −magnitude to +magnitude (times the row's sign).
        let biases = &w[24..32];
        assert!((biases[0].abs() - expected).abs() < 1e-12);
        assert!((biases[7].abs() - expected).abs() < 1e-12);
        assert!(w[32..].iter().all(|v| v.abs() <= 1.0));
    }
}
