//! How far the single-precision export lands from the library's double-precision correction:
//! the export's own coefficients, rounded to `f32`, run by `spincal-embedded` (the operations the
//! `float` C does, bit for bit: tests/firmware.rs) against the library's stream, over a grid of
//! the model's training range.

use serde::Serialize;

use crate::correctors::corrector::Corrector;
use crate::correctors::model_file::CorrectorModel;
use crate::correctors::physical::predicted_to_help;
use crate::input::recording::STANDARD_GRAVITY;

use super::fusion::grid;
use super::plan::{AccelPlan, CoveragePlan, NetworkPlan, PhysicalPlan, Plan};

/// History long enough for any network a model file may hold (3 axes × (1000 delays + 1)).
const MAX_HISTORY: usize = 3 * (crate::correctors::ann::MAX_DELAYS + 1);

/// The float export's largest difference from the double correction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FloatError {
    /// Largest |float − double| per axis over the grid, m/s².
    pub max_abs_mps2: [f64; 3],
    /// The range it was measured over, in words.
    pub over: String,
    /// Grid points compared (both corrections valid).
    pub points: usize,
    /// Grid points where the float and double flags (valid, outside the training range) differ:
    /// readings within rounding of an envelope's edge.
    pub flags_differ: usize,
    /// For a model with an error bar (`None` without): the largest |float − double| of the
    /// predicted standard deviation over the grid, relative to the double's, on any axis.
    pub sd_max_rel: Option<f64>,
    /// Grid points where the float's `predicted_better` differs from the double's: a correction
    /// within rounding of √2 standard deviations on some axis.
    pub better_differ: usize,
}

/// The training range of a model: per axis [min, max] of the readings, and its description.
fn training_box(model: &CorrectorModel) -> ([[f64; 2]; 3], String) {
    let g = STANDARD_GRAVITY;
    match model {
        CorrectorModel::Physical(p) => (p.input_range_mps2, "the campaign's range of readings".into()),
        CorrectorModel::PhysicalAnn(pa) => (
            pa.physical.input_range_mps2,
            "the campaign's range of readings".into(),
        ),
        CorrectorModel::Ann(a) => (
            std::array::from_fn(|k| match a.axes.iter().position(|x| x.index() == k) {
                Some(c) => [a.input_scaling.min[c], a.input_scaling.max[c]],
                None => [-g, g],
            }),
            "the network's training inputs (constant readings)".into(),
        ),
        CorrectorModel::Static(s) => (
            std::array::from_fn(|k| {
                let (a, b) = (s.bias[k] - g / s.scale[k], s.bias[k] + g / s.scale[k]);
                [a.min(b), a.max(b)]
            }),
            "the readings of ±1 g (the still poses' range)".into(),
        ),
        CorrectorModel::Linear(_) => (
            [[-2.0 * g, 2.0 * g]; 3],
            "±2 g (a linear model stores no range)".into(),
        ),
        CorrectorModel::Uncorrected(_) => ([[-2.0 * g, 2.0 * g]; 3], "±2 g (readings pass as read)".into()),
    }
}

fn f32s(v: &[f64]) -> Vec<f32> {
    v.iter().map(|&x| x as f32).collect()
}

fn three(v: &[f64]) -> [f32; 3] {
    let mut out = [0.0f32; 3];
    for (o, &x) in out.iter_mut().zip(v) {
        *o = x as f32;
    }
    out
}

fn axes3(axes: &[usize]) -> [usize; 3] {
    let mut out = [0; 3];
    out[..axes.len()].copy_from_slice(axes);
    out
}

fn physical(p: &PhysicalPlan) -> spincal_embedded::Physical<f32> {
    spincal_embedded::Physical {
        bias: three(&p.bias),
        one_plus_scale: three(&p.one_plus_scale),
        misalignment: three(&p.misalignment),
        quadratic: three(&p.quadratic),
        lower: three(&p.lower),
        upper: three(&p.upper),
    }
}

/// The owned arrays a network borrows.
struct NetworkData {
    sizes: Vec<usize>,
    weights: Vec<f32>,
}

fn network<'a>(n: &NetworkPlan, data: &'a NetworkData) -> spincal_embedded::Network<'a, f32> {
    spincal_embedded::Network {
        axes: axes3(&n.axes),
        n_axes: n.axes.len(),
        delays: n.delays,
        sizes: &data.sizes,
        weights: &data.weights,
        input_gain: three(&n.input_gain),
        input_offset: three(&n.input_offset),
        output_min: three(&n.output_min),
        output_span: three(&n.output_span),
        output_gain: three(&n.output_gain),
        output_offset: three(&n.output_offset),
        limit: n.limit as f32,
    }
}

fn coverage(c: &CoveragePlan) -> spincal_embedded::Coverage<'_, f32> {
    spincal_embedded::Coverage {
        lower: three(&c.lower),
        width: three(&c.width),
        cells: c.cells,
        covered: &c.bits,
    }
}

/// The float export's difference from the library's double correction of `model` (whose plan
/// is `plan`) over a 9-point-per-axis grid of its training range; constant readings, fed until a
/// network's history is full.
pub(crate) fn float_error(plan: &Plan, model: &CorrectorModel) -> FloatError {
    let network_of = |n: &NetworkPlan| NetworkData {
        sizes: n.sizes.clone(),
        weights: f32s(&n.weights),
    };
    let data = match &plan.accel {
        AccelPlan::Ann(n) => Some(network_of(n)),
        AccelPlan::PhysicalAnn(pa) => Some(network_of(&pa.1)),
        _ => None,
    };
    let accel = match &plan.accel {
        AccelPlan::Physical(p) => spincal_embedded::Accel::Physical(physical(p)),
        AccelPlan::Linear(l) => {
            let k = l.axes.len();
            let mut matrix = [[0.0f32; 3]; 3];
            for i in 0..k {
                matrix[i] = three(&l.matrix[i]);
            }
            spincal_embedded::Accel::Linear(spincal_embedded::Linear {
                axes: axes3(&l.axes),
                n_axes: k,
                offset: three(&l.offset),
                matrix,
            })
        }
        AccelPlan::AsRead => spincal_embedded::Accel::AsRead,
        AccelPlan::Static(s) => spincal_embedded::Accel::Static(spincal_embedded::Static {
            bias: three(&s.bias),
            scale: three(&s.scale),
            nonlinearity: three(&s.nonlinearity),
            matrix: s.matrix.map(|r| three(&r)),
        }),
        AccelPlan::Ann(n) => spincal_embedded::Accel::Ann(network(n, data.as_ref().expect("a network"))),
        AccelPlan::PhysicalAnn(pa) => spincal_embedded::Accel::PhysicalAnn(spincal_embedded::PhysicalAnn {
            physical: physical(&pa.0),
            network: network(&pa.1, data.as_ref().expect("a network")),
            coverage: coverage(&pa.2),
        }),
    };
    let covariance = plan.covariance.map(|c| c.map(|row| row.map(|v| v as f32)));
    let embedded = spincal_embedded::Model {
        accel,
        gyro: None,
        covariance: covariance.as_ref(),
    };
    let error_model = model.error_model();
    let mut sd_max_rel = error_model.map(|_| 0.0f64);
    let mut better_differ = 0;
    let (range, over) = training_box(model);
    let mut state = Box::new(spincal_embedded::State::<f32, MAX_HISTORY>::new());
    let mut max = [0.0f64; 3];
    let (mut points, mut flags_differ) = (0, 0);
    for m in grid(&range) {
        let mut stream = model.stream();
        state.reset();
        let m32 = m.map(|v| v as f32);
        let (mut ours, mut single) = (None, None);
        for _ in 0..=model.warmup_samples() {
            ours = Some(stream.correct_sample(m));
            single = Some(embedded.correct_accel(&mut state, m32));
        }
        let (Some(ours), Some(single)) = (ours, single) else {
            continue;
        };
        if ours.valid != single.valid || ours.outside_training_range != single.outside_training_range {
            flags_differ += 1;
            continue;
        }
        if !ours.valid {
            continue;
        }
        points += 1;
        for k in 0..3 {
            max[k] = max[k].max((f64::from(single.accel[k]) - ours.accel_mps2[k]).abs());
        }
        // The error bar, as `correct` gives it (RowCorrector) and the float export does.
        let Some(error_model) = error_model else {
            continue;
        };
        let double = error_model.predicted_sd(m).map(|sd| {
            let better = (0..3).all(|k| predicted_to_help(ours.accel_mps2[k] - m[k], sd[k]));
            (sd, better)
        });
        match (double, embedded.predicted_error(m32)) {
            (Some((sd, better)), Some(float)) => {
                for k in 0..3 {
                    let diff = (f64::from(float.sd[k]) - sd[k]).abs();
                    let rel = if diff == 0.0 { 0.0 } else { diff / sd[k] };
                    sd_max_rel = sd_max_rel.map(|w| w.max(rel));
                }
                better_differ += usize::from(better != float.better);
            }
            (None, None) => {}
            // One has an inverse (or a slope) the other lacks: within rounding of the edge.
            _ => better_differ += 1,
        }
    }
    FloatError {
        max_abs_mps2: max,
        over: format!(
            "{over}: x {:.4}…{:.4}, y {:.4}…{:.4}, z {:.4}…{:.4}",
            range[0][0], range[0][1], range[1][0], range[1][1], range[2][0], range[2][1]
        ),
        points,
        flags_differ,
        sd_max_rel,
        better_differ,
    }
}
