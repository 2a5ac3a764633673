//! The values x-io Fusion's inertial calibration takes, from a saved corrector.
//!
//! Fusion (FusionCalibration.h) corrects a sensor as
//! `calibrated = M · ((uncalibrated − offset) ⊙ sensitivity)`, accelerometer in g, gyroscope in
//! degrees per second. Its model is affine, so it holds spincal's linear part exactly:
//!
//! - physical (and physical-linear): f = (I + M)⁻¹ diag(1/(1 + s)) (m − b), so M = (I + M)⁻¹,
//!   sensitivity = 1/(1 + s), offset = b (in g);
//! - linear: a = o + A m, so M = A (identity rows for axes it leaves), sensitivity = 1,
//!   offset = −A⁻¹ o;
//! - static: a = T (s ⊙ (r − b)) + T q u², so M = T, sensitivity = s, offset = b;
//! - ann: a network is not affine; the affine map nearest it (least squares over a 9-point grid
//!   per axis of its training box) is given;
//! - physical_ann: the physical part's values;
//! - the gyroscope: ω = K⁻¹ (m − b), so M = K⁻¹, sensitivity = 1, offset = b.
//!
//! What Fusion cannot hold (a quadratic term, a network) is named with its largest effect:
//! the largest difference, per axis, between spincal's correction and Fusion's over a grid of the
//! training range (9 points per axis, the box's corners included).

use serde::Serialize;

use crate::correctors::ann::AnnModel;
use crate::correctors::corrector::Corrector;
use crate::correctors::gyro::GyroInputUnit;
use crate::correctors::linear::LinearModel;
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::correctors::physical::SensorModel;
use crate::correctors::static_cal::StaticCalibration;
use crate::geometry::{inverse, IDENTITY, M3};
use crate::input::recording::STANDARD_GRAVITY;

/// Grid points per axis of the training box for the largest effect.
const GRID: usize = 9;

/// One sensor's Fusion calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FusionCalibration {
    /// Row-major 3 × 3.
    pub misalignment: M3,
    pub sensitivity: [f64; 3],
    pub offset: [f64; 3],
    /// The unit Fusion's uncalibrated input must be in (`g`, `deg/s`, or the raw `counts`).
    pub input_unit: String,
    /// The unit of the calibrated output (`g`, `deg/s`).
    pub output_unit: String,
}

impl FusionCalibration {
    /// Fusion's formula: M · ((u − offset) ⊙ sensitivity).
    pub fn apply(&self, u: [f64; 3]) -> [f64; 3] {
        let v: [f64; 3] = std::array::from_fn(|k| (u[k] - self.offset[k]) * self.sensitivity[k]);
        std::array::from_fn(|i| (0..3).map(|j| self.misalignment[i][j] * v[j]).sum())
    }
}

/// Something Fusion's affine model leaves out, and its largest effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NotHeld {
    /// What it is, in words.
    pub what: String,
    /// Largest |spincal − Fusion| per axis over the training range, m/s².
    pub max_effect_mps2: [f64; 3],
    /// The range it was measured over, in words.
    pub over: String,
}

/// The accelerometer's and the gyroscope's Fusion values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FusionValues {
    /// `None` when no affine map can stand for the corrector (`accelerometer_note` says why).
    pub accelerometer: Option<FusionCalibration>,
    pub accelerometer_note: Option<String>,
    pub not_held: Vec<NotHeld>,
    pub gyroscope: Option<FusionCalibration>,
}

/// (I + M)⁻¹ for the strictly lower-triangular misalignment [m_yx, m_zx, m_zy].
fn unskew([m_yx, m_zx, m_zy]: [f64; 3]) -> M3 {
    [
        [1.0, 0.0, 0.0],
        [-m_yx, 1.0, 0.0],
        [m_yx * m_zy - m_zx, -m_zy, 1.0],
    ]
}

/// An accelerometer calibration whose input is m/s² (or counts when `counts`), in Fusion's g.
fn in_g(
    misalignment: M3,
    sensitivity: [f64; 3],
    offset_mps2_or_counts: [f64; 3],
    counts: bool,
) -> FusionCalibration {
    let g = STANDARD_GRAVITY;
    if counts {
        // u counts, s m/s² per count: the output in g needs s / g.
        FusionCalibration {
            misalignment,
            sensitivity: sensitivity.map(|s| s / g),
            offset: offset_mps2_or_counts,
            input_unit: "counts".into(),
            output_unit: "g".into(),
        }
    } else {
        FusionCalibration {
            misalignment,
            sensitivity,
            offset: offset_mps2_or_counts.map(|o| o / g),
            input_unit: "g".into(),
            output_unit: "g".into(),
        }
    }
}

/// The training box (per axis [min, max]) over which something Fusion leaves out is measured,
/// and what it is.
type Domain = ([[f64; 2]; 3], String);

/// The Fusion values of a saved corrector.
pub fn fusion_values(file: &CorrectorFile) -> FusionValues {
    let (accelerometer, note, not_held) = match accelerometer_values(file) {
        Ok((cal, domain)) => {
            let not_held = domain
                .map(|(range, what)| not_held(&file.corrector, &cal, &range, what))
                .into_iter()
                .collect();
            (Some(cal), None, not_held)
        }
        Err(note) => (None, Some(note), Vec::new()),
    };
    FusionValues {
        accelerometer,
        accelerometer_note: note,
        not_held,
        gyroscope: gyroscope_values(file),
    }
}

/// The accelerometer's Fusion values and, when the corrector does more than they hold, the range
/// and words for it; else why no affine map can stand for the corrector.
fn accelerometer_values(file: &CorrectorFile) -> Result<(FusionCalibration, Option<Domain>), String> {
    match &file.corrector {
        CorrectorModel::Physical(p) => {
            let s = &p.sensor;
            let what = (s.quadratic_per_mps2 != [0.0; 3]).then(|| quadratic_term(s.quadratic_per_mps2));
            Ok((sensor_values(s), what.map(|w| (p.input_range_mps2, w))))
        }
        CorrectorModel::PhysicalAnn(pa) => {
            let s = &pa.physical.sensor;
            let mut what = String::from("the network on the physical model's residual");
            if s.quadratic_per_mps2 != [0.0; 3] {
                what = format!("{} and {what}", quadratic_term(s.quadratic_per_mps2));
            }
            Ok((sensor_values(s), Some((pa.physical.input_range_mps2, what))))
        }
        CorrectorModel::Linear(l) => linear_values(l),
        CorrectorModel::Static(s) => Ok(static_values(s)),
        CorrectorModel::Ann(a) => ann_values(file, a),
        CorrectorModel::Uncorrected(u) => Err(format!(
            "the model leaves the accelerometer as read (kind `uncorrected`: {}); keep the flight stack's own accelerometer calibration",
            u.reason
        )),
    }
}

/// The words for a sensor model's quadratic term.
fn quadratic_term(q: [f64; 3]) -> String {
    format!(
        "the quadratic term q = [{:.3e}, {:.3e}, {:.3e}] 1/(m/s²)",
        q[0], q[1], q[2]
    )
}

/// A fitted sensor model's inverse as Fusion's values (its quadratic term aside).
fn sensor_values(s: &SensorModel) -> FusionCalibration {
    in_g(
        unskew(s.misalignment_rad),
        s.scale_error.map(|e| 1.0 / (1.0 + e)),
        s.bias_mps2,
        false,
    )
}

/// A linear corrector (matrix, then offset) as Fusion's offset-then-matrix.
fn linear_values(l: &LinearModel) -> Result<(FusionCalibration, Option<Domain>), String> {
    let mut a = IDENTITY;
    let mut o = [0.0; 3];
    for (i, ai) in l.axes.iter().enumerate() {
        o[ai.index()] = l.offset_mps2[i];
        for (j, aj) in l.axes.iter().enumerate() {
            a[ai.index()][aj.index()] = l.matrix[i][j];
        }
    }
    match inverse(&a) {
        Some(inv) => {
            let offset: [f64; 3] = std::array::from_fn(|i| -(0..3).map(|j| inv[i][j] * o[j]).sum::<f64>());
            Ok((in_g(a, [1.0; 3], offset, false), None))
        }
        None => Err("the linear corrector's matrix is singular: Fusion's offset (subtracted before the matrix) cannot express its offset".into()),
    }
}

/// A still-pose calibration, its nonlinearity over the readings that give ±g.
fn static_values(s: &StaticCalibration) -> (FusionCalibration, Option<Domain>) {
    let g = STANDARD_GRAVITY;
    let counts = s.input_unit != "m/s^2";
    let cal = in_g(s.misalignment_matrix(), s.scale, s.bias, counts);
    let what = (s.nonlinearity != [0.0; 3]).then(|| quadratic_term(s.nonlinearity));
    // Still poses span ±1 g on each axis: the readings that give ±g.
    let range: [[f64; 2]; 3] = std::array::from_fn(|k| {
        let (a, b) = (s.bias[k] - g / s.scale[k], s.bias[k] + g / s.scale[k]);
        [a.min(b), a.max(b)]
    });
    (cal, what.map(|w| (range, w)))
}

/// A network's nearest affine map over its training range.
fn ann_values(file: &CorrectorFile, a: &AnnModel) -> Result<(FusionCalibration, Option<Domain>), String> {
    let g = STANDARD_GRAVITY;
    let range: [[f64; 2]; 3] = std::array::from_fn(|k| {
        match a.axes.iter().position(|x| x.index() == k) {
            Some(c) => [a.input_scaling.min[c], a.input_scaling.max[c]],
            // An axis the network does not read passes through: any range shows that.
            None => [-g, g],
        }
    });
    let Some((m, o)) = affine_fit(&file.corrector, &range) else {
        return Err("the network gives no finite correction over its training range".into());
    };
    let offset =
        inverse(&m).map(|inv| std::array::from_fn(|i| -(0..3).map(|j| inv[i][j] * o[j]).sum::<f64>()));
    match offset {
        Some(offset) => Ok((
            in_g(m, [1.0; 3], offset, false),
            Some((
                range,
                "the network (Fusion's values are its nearest affine map)".to_string(),
            )),
        )),
        None => Err("the network's nearest affine map is singular".into()),
    }
}

/// What Fusion's values do not hold: its largest effect over `range`.
fn not_held(
    corrector: &CorrectorModel,
    cal: &FusionCalibration,
    range: &[[f64; 2]; 3],
    what: String,
) -> NotHeld {
    let counts = cal.input_unit == "counts";
    let max = max_difference(corrector, cal, range, counts);
    let unit = if counts { "counts" } else { "m/s²" };
    NotHeld {
        what,
        max_effect_mps2: max,
        over: format!(
            "readings x {:.4}…{:.4}, y {:.4}…{:.4}, z {:.4}…{:.4} {unit}",
            range[0][0], range[0][1], range[1][0], range[1][1], range[2][0], range[2][1]
        ),
    }
}

/// The gyro model's inverse in deg/s, when it has one.
fn gyroscope_values(file: &CorrectorFile) -> Option<FusionCalibration> {
    file.gyro.as_ref().and_then(|gm| {
        let inv = inverse(&gm.sensitivity)?;
        let deg = 180.0 / std::f64::consts::PI;
        Some(match gm.input_unit {
            GyroInputUnit::RadPerS => FusionCalibration {
                misalignment: inv,
                sensitivity: [1.0; 3],
                offset: gm.bias_radps.map(|b| b * deg),
                input_unit: "deg/s".into(),
                output_unit: "deg/s".into(),
            },
            GyroInputUnit::Counts => FusionCalibration {
                misalignment: inv.map(|row| row.map(|v| v * deg)),
                sensitivity: [1.0; 3],
                offset: gm.bias_radps,
                input_unit: "counts".into(),
                output_unit: "deg/s".into(),
            },
        })
    })
}

/// The grid over `range`: GRID points per axis, ends included.
pub(crate) fn grid(range: &[[f64; 2]; 3]) -> impl Iterator<Item = [f64; 3]> + '_ {
    let at =
        move |k: usize, i: usize| range[k][0] + (range[k][1] - range[k][0]) * i as f64 / (GRID - 1) as f64;
    (0..GRID * GRID * GRID).map(move |n| {
        [
            at(0, n % GRID),
            at(1, (n / GRID) % GRID),
            at(2, n / (GRID * GRID)),
        ]
    })
}

/// spincal's correction of a constant reading (a fresh stream fed it until its history is full);
/// `None` where it is not valid.
fn steady(model: &CorrectorModel, m: [f64; 3]) -> Option<[f64; 3]> {
    let mut stream = model.stream();
    let mut out = None;
    for _ in 0..=model.warmup_samples() {
        let s = stream.correct_sample(m);
        out = s.valid.then_some(s.accel_mps2);
    }
    out
}

fn max_difference(
    model: &CorrectorModel,
    cal: &FusionCalibration,
    range: &[[f64; 2]; 3],
    counts: bool,
) -> [f64; 3] {
    let g = STANDARD_GRAVITY;
    let mut max = [0.0f64; 3];
    for m in grid(range) {
        let Some(ours) = steady(model, m) else { continue };
        let input = if counts { m } else { m.map(|v| v / g) };
        let theirs = cal.apply(input).map(|v| v * g);
        for k in 0..3 {
            max[k] = max[k].max((ours[k] - theirs[k]).abs());
        }
    }
    max
}

/// The affine map a = A m + o nearest the corrector (least squares over the grid of `range`).
fn affine_fit(model: &CorrectorModel, range: &[[f64; 2]; 3]) -> Option<(M3, [f64; 3])> {
    // Normal equations of [m, 1] (4 unknowns per output), solved by Gaussian elimination.
    let mut ata = [[0.0f64; 4]; 4];
    let mut atb = [[0.0f64; 3]; 4];
    for m in grid(range) {
        let Some(a) = steady(model, m) else { continue };
        let x = [m[0], m[1], m[2], 1.0];
        for i in 0..4 {
            for j in 0..4 {
                ata[i][j] += x[i] * x[j];
            }
            for k in 0..3 {
                atb[i][k] += x[i] * a[k];
            }
        }
    }
    for col in 0..4 {
        let pivot = (col..4).max_by(|&a, &b| ata[a][col].abs().total_cmp(&ata[b][col].abs()))?;
        if ata[pivot][col] == 0.0 || ata[pivot][col].is_nan() {
            return None;
        }
        ata.swap(col, pivot);
        atb.swap(col, pivot);
        for row in 0..4 {
            if row != col {
                let f = ata[row][col] / ata[col][col];
                for j in 0..4 {
                    ata[row][j] -= f * ata[col][j];
                }
                for k in 0..3 {
                    atb[row][k] -= f * atb[col][k];
                }
            }
        }
    }
    let solution: [[f64; 3]; 4] = std::array::from_fn(|i| atb[i].map(|v| v / ata[i][i]));
    let a: M3 = std::array::from_fn(|k| std::array::from_fn(|j| solution[j][k]));
    let o = solution[3];
    let finite = a.iter().flatten().chain(&o).all(|v| v.is_finite());
    finite.then_some((a, o))
}

/// The values as text: each sensor's M, sensitivity and offset, what Fusion cannot hold, and C
/// initialisers in Fusion's types.
pub fn fusion_text(values: &FusionValues) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "x-io Fusion calibration: calibrated = M · ((uncalibrated − offset) ⊙ sensitivity)\n\
         (FusionCalibrationInertial; 1 g = {STANDARD_GRAVITY} m/s²)\n"
    );
    let matrix = |m: &M3| {
        m.iter()
            .map(|r| format!("[{:.9}, {:.9}, {:.9}]", r[0], r[1], r[2]))
            .collect::<Vec<_>>()
            .join("\n                ")
    };
    let vector = |v: &[f64; 3]| format!("[{:.9}, {:.9}, {:.9}]", v[0], v[1], v[2]);
    let mut c = String::new();
    let mut sensor = |name: &str, ident: &str, cal: &FusionCalibration, s: &mut String| {
        let _ = writeln!(
            s,
            "{name} (uncalibrated in {}, calibrated in {}):\n  misalignment  {}\n  sensitivity   {}\n  offset        {} {}",
            cal.input_unit,
            cal.output_unit,
            matrix(&cal.misalignment),
            vector(&cal.sensitivity),
            vector(&cal.offset),
            cal.input_unit
        );
        let m: Vec<String> = cal
            .misalignment
            .iter()
            .flatten()
            .map(|v| format!("{:?}f", *v as f32))
            .collect();
        let _ = writeln!(
            c,
            "const FusionMatrix {ident}Misalignment = {{{}}};\nconst FusionVector {ident}Sensitivity = {{{}}};\nconst FusionVector {ident}Offset = {{{}}};",
            m.join(", "),
            cal.sensitivity.iter().map(|v| format!("{:?}f", *v as f32)).collect::<Vec<_>>().join(", "),
            cal.offset.iter().map(|v| format!("{:?}f", *v as f32)).collect::<Vec<_>>().join(", "),
        );
    };
    match &values.accelerometer {
        Some(cal) => sensor("accelerometer", "accelerometer", cal, &mut s),
        None => {
            let _ = writeln!(
                s,
                "accelerometer: no Fusion values: {}",
                values.accelerometer_note.as_deref().unwrap_or("not affine")
            );
        }
    }
    for n in &values.not_held {
        let e = n.max_effect_mps2;
        let _ = writeln!(
            s,
            "  not held by Fusion: {}; leaving it out changes the correction by at most\n    {:.3e}, {:.3e}, {:.3e} m/s² (x, y, z) over {}",
            n.what, e[0], e[1], e[2], n.over
        );
    }
    if values.not_held.is_empty() && values.accelerometer.is_some() {
        let _ = writeln!(s, "  Fusion holds this accelerometer correction exactly.");
    }
    let _ = writeln!(s);
    match &values.gyroscope {
        Some(cal) => {
            sensor("gyroscope", "gyroscope", cal, &mut s);
            let _ = writeln!(s, "  Fusion holds this gyroscope correction exactly.");
        }
        None => {
            let _ = writeln!(s, "gyroscope: not calibrated by this model");
        }
    }
    if !c.is_empty() {
        let _ = writeln!(s, "\nIn C (Fusion's types):\n{c}");
    }
    s
}
