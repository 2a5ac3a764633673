//! The network's layout (layer sizes, parameter offsets), its one-sample passes and its
//! Nguyen–Widrow initial weights.

use rand::Rng;

use super::tanh::tanh;
use super::MAX_HIDDEN_LAYERS;

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
