//! The network on top of physics (the `physical_ann` corrector): the inverse sensor model first,
//! then a small network that adds what the physics left, f = p + n(p) with p the physical
//! model's correction. The network is static (no delays) and learned from a campaign's pooled
//! samples, so it only ever sees the specific force the campaign covered. A tanh network is never
//! trusted elsewhere: the physical correction is used alone, and the sample marked
//! (`outside_training_range`), where the input lies outside the network's per-axis training range
//! (by more than [`crate::correctors::ann::EXTRAPOLATION_MARGIN`] of it), in a cell of the input
//! box that no training sample (nor a neighbouring cell's) reached ([`InputCoverage`]: per-axis
//! ranges alone would trust a held-out mounting's unseen combinations of axes), or where the
//! network's output leaves the range of residuals it was trained on.

use serde::{Deserialize, Serialize};

use crate::correctors::ann::{AnnModel, EXTRAPOLATION_MARGIN};
use crate::correctors::corrector::{Axis, CorrectedSample, Corrector, ModelError, SampleCorrector};
use crate::correctors::physical::PhysicalCorrector;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhysicalAnnCorrector {
    pub physical: PhysicalCorrector,
    /// Maps the physical correction (x, y, z, m/s²) to the residual left on each axis (m/s²).
    pub network: AnnModel,
    /// Where in 3-D the network's training inputs lay.
    pub coverage: InputCoverage,
}

/// The cells of a box (the training inputs' range, `cells` per axis) that training samples
/// reached, grown by one cell in every direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputCoverage {
    /// Box corners, m/s².
    pub lower_mps2: [f64; 3],
    pub upper_mps2: [f64; 3],
    pub cells: usize,
    /// Cell indices (x + cells·(y + cells·z)), ascending.
    pub covered: Vec<u32>,
}

/// Cells per axis of [`InputCoverage`]; 16³ = 4096 cells at most in a file.
pub(crate) const COVERAGE_CELLS: usize = 16;

impl InputCoverage {
    /// The coverage of `inputs` (three columns of equal length).
    pub fn of(inputs: &[Vec<f64>; 3]) -> InputCoverage {
        let n = COVERAGE_CELLS;
        let mut lower = [f64::INFINITY; 3];
        let mut upper = [f64::NEG_INFINITY; 3];
        for k in 0..3 {
            for &v in &inputs[k] {
                lower[k] = lower[k].min(v);
                upper[k] = upper[k].max(v);
            }
            if !(lower[k].is_finite() && upper[k].is_finite()) || upper[k] <= lower[k] {
                // One value (or none): a box of width 2 around it.
                let centre = if lower[k].is_finite() { lower[k] } else { 0.0 };
                (lower[k], upper[k]) = (centre - 1.0, centre + 1.0);
            }
        }
        let mut hit = vec![false; n * n * n];
        let cover = InputCoverage {
            lower_mps2: lower,
            upper_mps2: upper,
            cells: n,
            covered: Vec::new(),
        };
        for i in 0..inputs[0].len() {
            if let Some(c) = cover.cell([inputs[0][i], inputs[1][i], inputs[2][i]]) {
                let (x, y, z) = (c % n, (c / n) % n, c / (n * n));
                for dz in z.saturating_sub(1)..=(z + 1).min(n - 1) {
                    for dy in y.saturating_sub(1)..=(y + 1).min(n - 1) {
                        for dx in x.saturating_sub(1)..=(x + 1).min(n - 1) {
                            hit[dx + n * (dy + n * dz)] = true;
                        }
                    }
                }
            }
        }
        InputCoverage {
            covered: (0..hit.len() as u32).filter(|&c| hit[c as usize]).collect(),
            ..cover
        }
    }

    /// The cell of `v`, `None` outside the box.
    fn cell(&self, v: [f64; 3]) -> Option<usize> {
        let n = self.cells;
        let mut index = [0usize; 3];
        for k in 0..3 {
            let u = (v[k] - self.lower_mps2[k]) / (self.upper_mps2[k] - self.lower_mps2[k]);
            if !(0.0..=1.0).contains(&u) {
                return None;
            }
            index[k] = ((u * n as f64) as usize).min(n - 1);
        }
        Some(index[0] + n * (index[1] + n * index[2]))
    }

    pub fn covers(&self, v: [f64; 3]) -> bool {
        self.cell(v)
            .is_some_and(|c| self.covered.binary_search(&(c as u32)).is_ok())
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        if !(1..=64).contains(&self.cells) {
            return Err(ModelError::new(
                "cells",
                format!("{}: must be 1 to 64", self.cells),
            ));
        }
        for k in 0..3 {
            let (lo, hi) = (self.lower_mps2[k], self.upper_mps2[k]);
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(ModelError::new(
                    format!("lower_mps2[{k}]"),
                    format!("{lo} to {hi}: must be finite with lower < upper"),
                ));
            }
        }
        let total = self.cells.pow(3) as u64;
        for (i, &c) in self.covered.iter().enumerate() {
            if u64::from(c) >= total || (i > 0 && self.covered[i - 1] >= c) {
                return Err(ModelError::new(
                    format!("covered[{i}]"),
                    format!("{c}: cells must ascend, each below {total}"),
                ));
            }
        }
        Ok(())
    }
}

impl PhysicalAnnCorrector {
    /// Both parts valid, and the network static and on all three axes (it reads and corrects
    /// the physical correction's full vector).
    pub fn validate(&self) -> Result<(), ModelError> {
        self.physical.validate().map_err(|e| e.within("physical"))?;
        self.network.validate().map_err(|e| e.within("network"))?;
        self.coverage.validate().map_err(|e| e.within("coverage"))?;
        if self.network.axes != Axis::ALL {
            return Err(ModelError::new(
                "network.axes",
                "must be [x, y, z]: the network reads the physical correction's three axes",
            ));
        }
        if self.network.delays != 0 {
            return Err(ModelError::new(
                "network.delays",
                format!(
                    "{}: the network on top of physics has no delays",
                    self.network.delays
                ),
            ));
        }
        Ok(())
    }
}

struct PhysicalAnnStream<'a> {
    model: &'a PhysicalAnnCorrector,
    physical: Box<dyn SampleCorrector + 'a>,
    network: Box<dyn SampleCorrector + 'a>,
}

impl SampleCorrector for PhysicalAnnStream<'_> {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        let p = self.physical.correct_sample(accel_mps2);
        if !p.valid {
            return p;
        }
        let residual = self.network.correct_sample(p.accel_mps2);
        let scaling = &self.model.network.output_scaling;
        let output_in_range = (0..3)
            .all(|c| scaling.apply(c, residual.accel_mps2[c]).abs() <= 1.0 + 2.0 * EXTRAPOLATION_MARGIN);
        if residual.outside_training_range
            || !residual.valid
            || !output_in_range
            || !self.model.coverage.covers(p.accel_mps2)
        {
            return CorrectedSample {
                outside_training_range: true,
                ..p
            };
        }
        CorrectedSample {
            accel_mps2: std::array::from_fn(|k| p.accel_mps2[k] + residual.accel_mps2[k]),
            valid: true,
            outside_training_range: p.outside_training_range,
        }
    }
}

impl Corrector for PhysicalAnnCorrector {
    fn corrected_axes(&self) -> Vec<Axis> {
        Axis::ALL.to_vec()
    }
    fn warmup_samples(&self) -> usize {
        0
    }
    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        Box::new(PhysicalAnnStream {
            model: self,
            physical: self.physical.stream(),
            network: self.network.stream(),
        })
    }
}
