//! The feed-forward network: tanh hidden layers, a linear output layer, flat weight storage.
//!
//! Weights are one flat vector, layer after layer; each layer stores its weight matrix row-major
//! (one row per unit, one column per input) followed by its biases. The same layout is used for
//! the columns of the Jacobian.

use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{check_finite, ModelError};

mod block;
mod layout;
mod tanh;

pub use layout::Layout;
// The firmware export checks its own tanh against this one, bit for bit.
#[cfg(test)]
pub(crate) use tanh::{tanh, tanh_in_place};

/// Largest supported number of hidden layers.
pub const MAX_HIDDEN_LAYERS: usize = 3;

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
mod tests;
