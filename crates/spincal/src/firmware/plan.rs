//! The coefficients a firmware corrector needs, computed once from a saved model with the
//! library's own arithmetic: every value a stream derives from the model at run time (1 + s,
//! the range's margins, a scaling's gain and offset, K⁻¹, the misalignment matrix) is derived
//! here by the same operations, so the exported code in double precision repeats the library's
//! arithmetic on the same bits.

use crate::correctors::ann::{AnnModel, Scaling, EXTRAPOLATION_MARGIN};
use crate::correctors::gyro::GyroModel;
use crate::correctors::linear::LinearModel;
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::correctors::physical::{PhysicalCorrector, SensorCovariance};
use crate::correctors::physical_ann::InputCoverage;
use crate::correctors::static_cal::StaticCalibration;
use crate::geometry::{inverse, M3};

use super::FirmwareError;

/// Widest hidden or output layer the export takes (the no_std crate's `MAX_UNITS`).
pub const MAX_UNITS: usize = 32;

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PhysicalPlan {
    pub bias: [f64; 3],
    pub one_plus_scale: [f64; 3],
    pub misalignment: [f64; 3],
    pub quadratic: [f64; 3],
    pub lower: [f64; 3],
    pub upper: [f64; 3],
}

impl PhysicalPlan {
    fn of(p: &PhysicalCorrector) -> PhysicalPlan {
        let s = &p.sensor;
        let mut lower = [0.0; 3];
        let mut upper = [0.0; 3];
        for k in 0..3 {
            // As PhysicalCorrector::outside_range computes them.
            let [lo, hi] = p.input_range_mps2[k];
            let margin = 0.1 * (hi - lo);
            lower[k] = lo - margin;
            upper[k] = hi + margin;
        }
        PhysicalPlan {
            bias: s.bias_mps2,
            one_plus_scale: s.scale_error.map(|e| 1.0 + e),
            misalignment: s.misalignment_rad,
            quadratic: s.quadratic_per_mps2,
            lower,
            upper,
        }
    }

    /// Physical-linear: no quadratic term, so u = m exactly and the square root can go.
    pub fn is_linear(&self) -> bool {
        self.quadratic == [0.0; 3]
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NetworkPlan {
    pub axes: Vec<usize>,
    pub delays: usize,
    /// Inputs, hidden layers, outputs.
    pub sizes: Vec<usize>,
    pub weights: Vec<f64>,
    pub input_gain: Vec<f64>,
    pub input_offset: Vec<f64>,
    pub output_min: Vec<f64>,
    pub output_span: Vec<f64>,
    pub output_gain: Vec<f64>,
    pub output_offset: Vec<f64>,
    pub limit: f64,
}

/// Gain and offset of `scaled = gain · x + offset`, as `Scaling::apply` computes them.
fn gain_offset(s: &Scaling, c: usize) -> (f64, f64) {
    let span = s.max[c] - s.min[c];
    if span > 0.0 {
        let gain = 2.0 / span;
        (gain, -1.0 - gain * s.min[c])
    } else {
        (0.0, 0.0)
    }
}

impl NetworkPlan {
    fn of(m: &AnnModel, field: &str) -> Result<NetworkPlan, FirmwareError> {
        let n = m.axes.len();
        for (l, &units) in m.network.hidden.iter().enumerate() {
            if units > MAX_UNITS {
                return Err(FirmwareError::TooLarge {
                    file: String::new(),
                    field: format!("{field}.network.hidden[{l}]"),
                    reason: format!("{units} units; firmware layers hold at most {MAX_UNITS}"),
                });
            }
        }
        let mut sizes = vec![m.network.inputs];
        sizes.extend_from_slice(&m.network.hidden);
        sizes.push(m.network.outputs);
        let input: Vec<(f64, f64)> = (0..n).map(|c| gain_offset(&m.input_scaling, c)).collect();
        let output: Vec<(f64, f64)> = (0..n).map(|c| gain_offset(&m.output_scaling, c)).collect();
        Ok(NetworkPlan {
            axes: m.axes.iter().map(|a| a.index()).collect(),
            delays: m.delays,
            sizes,
            weights: m.network.weights.clone(),
            input_gain: input.iter().map(|g| g.0).collect(),
            input_offset: input.iter().map(|g| g.1).collect(),
            output_min: m.output_scaling.min.clone(),
            output_span: (0..n)
                .map(|c| m.output_scaling.max[c] - m.output_scaling.min[c])
                .collect(),
            output_gain: output.iter().map(|g| g.0).collect(),
            output_offset: output.iter().map(|g| g.1).collect(),
            limit: 1.0 + 2.0 * EXTRAPOLATION_MARGIN,
        })
    }

    /// Values of the delay history: axes × (delays + 1).
    pub fn history(&self) -> usize {
        self.sizes[0]
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CoveragePlan {
    pub lower: [f64; 3],
    pub width: [f64; 3],
    pub cells: usize,
    /// Bit c of byte c / 8 set for covered cell c.
    pub bits: Vec<u8>,
}

impl CoveragePlan {
    fn of(c: &InputCoverage) -> CoveragePlan {
        let total = c.cells.pow(3);
        let mut bits = vec![0u8; total.div_ceil(8)];
        for &cell in &c.covered {
            bits[cell as usize / 8] |= 1 << (cell % 8);
        }
        CoveragePlan {
            lower: c.lower_mps2,
            width: std::array::from_fn(|k| c.upper_mps2[k] - c.lower_mps2[k]),
            cells: c.cells,
            bits,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinearPlan {
    pub axes: Vec<usize>,
    pub offset: Vec<f64>,
    pub matrix: Vec<Vec<f64>>,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct StaticPlan {
    pub bias: [f64; 3],
    pub scale: [f64; 3],
    pub nonlinearity: [f64; 3],
    pub matrix: M3,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct GyroPlan {
    pub bias: [f64; 3],
    pub inverse: M3,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AccelPlan {
    Physical(PhysicalPlan),
    Linear(LinearPlan),
    Static(StaticPlan),
    Ann(NetworkPlan),
    PhysicalAnn(Box<(PhysicalPlan, NetworkPlan, CoveragePlan)>),
    /// The accelerometer as read (kind `uncorrected`: the file corrects the gyroscope alone).
    AsRead,
}

/// Everything the generated sources hold.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plan {
    /// The model file's `kind`, `physical` with no quadratic term named `physical-linear`.
    pub kind: String,
    pub accel: AccelPlan,
    pub gyro: Option<GyroPlan>,
    /// The 12 parameters' covariance, exactly when `spincal correct` writes an error bar for the
    /// model (`CorrectorModel::error_model`: a `physical` or `linear` kind with an uncertainty).
    pub covariance: Option<SensorCovariance>,
}

impl Plan {
    pub fn of(file: &CorrectorFile) -> Result<Plan, FirmwareError> {
        file.validate().map_err(|e| FirmwareError::Invalid {
            file: String::new(),
            field: e.field,
            reason: e.reason,
        })?;
        let mut kind = file.corrector.kind().to_string();
        let accel = match &file.corrector {
            CorrectorModel::Physical(p) => {
                let plan = PhysicalPlan::of(p);
                if plan.is_linear() {
                    kind = "physical-linear".into();
                }
                AccelPlan::Physical(plan)
            }
            CorrectorModel::Linear(l) => AccelPlan::Linear(linear_plan(l)),
            CorrectorModel::Static(s) => AccelPlan::Static(static_plan(s)),
            CorrectorModel::Ann(a) => AccelPlan::Ann(NetworkPlan::of(a, "corrector")?),
            CorrectorModel::PhysicalAnn(pa) => AccelPlan::PhysicalAnn(Box::new((
                PhysicalPlan::of(&pa.physical),
                NetworkPlan::of(&pa.network, "corrector.network")?,
                CoveragePlan::of(&pa.coverage),
            ))),
            // A gyro part saved alone: the accelerometer passes through as `correct` leaves it.
            CorrectorModel::Uncorrected(_) if file.gyro.is_some() => AccelPlan::AsRead,
            CorrectorModel::Uncorrected(u) => {
                return Err(FirmwareError::TooLarge {
                    file: String::new(),
                    field: "corrector.kind".into(),
                    reason: format!(
                        "uncorrected ({}) with no gyro part: nothing the firmware export can correct",
                        u.reason
                    ),
                })
            }
        };
        let gyro = match &file.gyro {
            Some(g) => Some(gyro_plan(g)?),
            None => None,
        };
        // One rule with `correct`: a physical_ann's physical part may carry an uncertainty, but
        // its rows get no error bar, so neither do the exports.
        let covariance = file.corrector.error_model().map(|e| e.uncertainty().covariance);
        Ok(Plan {
            kind,
            accel,
            gyro,
            covariance,
        })
    }

    /// Why the export has no error bar (`None` when it has one), for the generated files.
    pub fn no_error_bar(&self) -> Option<&'static str> {
        match (&self.covariance, &self.accel) {
            (Some(_), _) => None,
            (None, AccelPlan::Physical(_)) => Some(
                "this physical model carries no parameter covariance (a model.json of format 1, or one not saved by a campaign)",
            ),
            (None, AccelPlan::AsRead) => Some(
                "this file corrects only the gyroscope (kind uncorrected): the accelerometer passes as read",
            ),
            (None, AccelPlan::Linear(_)) => Some(
                "this linear map carries no parameter covariance (one not saved by a campaign as linear-12, or saved before it did)",
            ),
            (None, _) => Some(
                "spincal gives an error bar for a physical model or a linear map with a covariance only",
            ),
        }
    }

    /// Length of the stream state's history (0 without a network).
    pub fn history(&self) -> usize {
        match &self.accel {
            AccelPlan::Ann(n) => n.history(),
            AccelPlan::PhysicalAnn(pa) => pa.1.history(),
            _ => 0,
        }
    }
}

fn linear_plan(l: &LinearModel) -> LinearPlan {
    LinearPlan {
        axes: l.axes.iter().map(|a| a.index()).collect(),
        offset: l.offset_mps2.clone(),
        matrix: l.matrix.clone(),
    }
}

fn static_plan(s: &StaticCalibration) -> StaticPlan {
    StaticPlan {
        bias: s.bias,
        scale: s.scale,
        nonlinearity: s.nonlinearity,
        matrix: s.misalignment_matrix(),
    }
}

fn gyro_plan(g: &GyroModel) -> Result<GyroPlan, FirmwareError> {
    // The inverse `correct` applies (GyroModel::corrector).
    let inverse = inverse(&g.sensitivity).ok_or_else(|| FirmwareError::Invalid {
        file: String::new(),
        field: "gyro.sensitivity".into(),
        reason: "singular: the gyroscope's calibration has no inverse".into(),
    })?;
    Ok(GyroPlan {
        bias: g.bias_radps,
        inverse,
    })
}
