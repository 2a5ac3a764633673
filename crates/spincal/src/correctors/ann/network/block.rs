//! The block passes: forward and backward over many samples at once, a layer at a time, bit for
//! bit the same values as the one-sample passes.

use super::layout::Layout;
use super::tanh::tanh_in_place;
use super::MAX_HIDDEN_LAYERS;

/// Samples per register-held chunk of the block forward pass.
const FORWARD_CHUNK: usize = 16;

impl Layout {
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
}
