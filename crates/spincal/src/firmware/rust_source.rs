//! The Rust export: a source file of `static` `spincal_embedded::Model`s, one per precision,
//! for firmware that includes it (`include!("spincal_model.rs")` inside a module, or as a module
//! file). Paths are written out in full, so the file needs no `use` and no inner attributes.

use std::fmt::Write;

use super::plan::{AccelPlan, CoveragePlan, GyroPlan, NetworkPlan, PhysicalPlan, Plan};
use super::Precision;
use crate::correctors::physical::SensorCovariance;
use crate::geometry::M3;

fn lit(x: f64, precision: Precision) -> String {
    match precision {
        Precision::Double => format!("{x:?}"),
        Precision::Float => format!("{:?}", x as f32),
    }
}

fn list(values: &[f64], precision: Precision) -> String {
    let items: Vec<String> = values.iter().map(|&x| lit(x, precision)).collect();
    if items.len() > 8 {
        let lines: Vec<String> = items.chunks(8).map(|c| c.join(", ")).collect();
        format!("[\n            {},\n        ]", lines.join(",\n            "))
    } else {
        format!("[{}]", items.join(", "))
    }
}

/// Up to three values padded with zeros to an array of three.
fn three(values: &[f64], precision: Precision) -> String {
    let mut v = [0.0; 3];
    v[..values.len()].copy_from_slice(values);
    list(&v, precision)
}

fn matrix3(m: &M3, precision: Precision) -> String {
    let rows: Vec<String> = m.iter().map(|r| list(r, precision)).collect();
    format!("[{}]", rows.join(", "))
}

fn axes3(axes: &[usize]) -> String {
    let mut a = [0usize; 3];
    a[..axes.len()].copy_from_slice(axes);
    format!("[{}, {}, {}]", a[0], a[1], a[2])
}

fn physical(p: &PhysicalPlan, x: Precision) -> String {
    format!(
        "spincal_embedded::Physical {{\n        bias: {},\n        one_plus_scale: {},\n        misalignment: {},\n        \
         quadratic: {},\n        lower: {},\n        upper: {},\n    }}",
        list(&p.bias, x),
        list(&p.one_plus_scale, x),
        list(&p.misalignment, x),
        list(&p.quadratic, x),
        list(&p.lower, x),
        list(&p.upper, x),
    )
}

fn network(n: &NetworkPlan, x: Precision) -> String {
    let sizes: Vec<String> = n.sizes.iter().map(|s| s.to_string()).collect();
    format!(
        "spincal_embedded::Network {{\n        axes: {},\n        n_axes: {},\n        delays: {},\n        sizes: &[{}],\n        \
         weights: &{},\n        input_gain: {},\n        input_offset: {},\n        output_min: {},\n        \
         output_span: {},\n        output_gain: {},\n        output_offset: {},\n        limit: {},\n    }}",
        axes3(&n.axes),
        n.axes.len(),
        n.delays,
        sizes.join(", "),
        list(&n.weights, x),
        three(&n.input_gain, x),
        three(&n.input_offset, x),
        three(&n.output_min, x),
        three(&n.output_span, x),
        three(&n.output_gain, x),
        three(&n.output_offset, x),
        lit(n.limit, x),
    )
}

fn coverage(c: &CoveragePlan, x: Precision) -> String {
    let bytes: Vec<String> = c.bits.iter().map(|b| format!("0x{b:02x}")).collect();
    let lines: Vec<String> = bytes.chunks(16).map(|c| c.join(", ")).collect();
    format!(
        "spincal_embedded::Coverage {{\n        lower: {},\n        width: {},\n        cells: {},\n        \
         covered: &[\n            {},\n        ],\n    }}",
        list(&c.lower, x),
        list(&c.width, x),
        c.cells,
        lines.join(",\n            ")
    )
}

fn gyro(g: Option<&GyroPlan>, x: Precision) -> String {
    match g {
        Some(g) => format!(
            "Some(spincal_embedded::Gyro {{\n        bias: {},\n        inverse: {},\n    }})",
            list(&g.bias, x),
            matrix3(&g.inverse, x)
        ),
        None => "None".into(),
    }
}

fn model(plan: &Plan, x: Precision) -> String {
    let accel = match &plan.accel {
        AccelPlan::Physical(p) => format!("spincal_embedded::Accel::Physical({})", physical(p, x)),
        AccelPlan::Linear(l) => {
            let k = l.axes.len();
            let mut m = [[0.0; 3]; 3];
            for i in 0..k {
                m[i][..k].copy_from_slice(&l.matrix[i]);
            }
            format!(
                "spincal_embedded::Accel::Linear(spincal_embedded::Linear {{\n        axes: {},\n        n_axes: {k},\n        \
                 offset: {},\n        matrix: {},\n    }})",
                axes3(&l.axes),
                three(&l.offset, x),
                matrix3(&m, x)
            )
        }
        AccelPlan::Static(s) => format!(
            "spincal_embedded::Accel::Static(spincal_embedded::Static {{\n        bias: {},\n        scale: {},\n        \
             nonlinearity: {},\n        matrix: {},\n    }})",
            list(&s.bias, x),
            list(&s.scale, x),
            list(&s.nonlinearity, x),
            matrix3(&s.matrix, x)
        ),
        AccelPlan::Ann(n) => format!("spincal_embedded::Accel::Ann({})", network(n, x)),
        AccelPlan::AsRead => "spincal_embedded::Accel::AsRead".into(),
        AccelPlan::PhysicalAnn(pa) => {
            let (p, n, c) = (&pa.0, &pa.1, &pa.2);
            format!(
            "spincal_embedded::Accel::PhysicalAnn(spincal_embedded::PhysicalAnn {{\n    physical: {},\n    network: {},\n    \
             coverage: {},\n    }})",
            physical(p, x),
            network(n, x),
            coverage(c, x)
            )
        }
    };
    let covariance = match (&plan.covariance, x) {
        (Some(_), Precision::Float) => "Some(&COVARIANCE_F32)",
        (Some(_), Precision::Double) => "Some(&COVARIANCE_F64)",
        (None, _) => "None",
    };
    format!(
        "spincal_embedded::Model {{\n    accel: {accel},\n    gyro: {},\n    covariance: {covariance},\n}}",
        gyro(plan.gyro.as_ref(), x)
    )
}

/// The 12 × 12 covariance, a row (wrapped six values to a line) per parameter.
fn covariance(c: &SensorCovariance, x: Precision) -> String {
    let rows: Vec<String> = c
        .iter()
        .map(|row| {
            let lines: Vec<String> = row
                .chunks(6)
                .map(|l| l.iter().map(|&v| lit(v, x)).collect::<Vec<_>>().join(", "))
                .collect();
            format!("[\n        {},\n    ]", lines.join(",\n        "))
        })
        .collect();
    format!("[\n    {},\n]", rows.join(",\n    "))
}

fn capitalised(text: &str) -> String {
    let mut chars = text.chars();
    chars
        .next()
        .map(|c| c.to_uppercase().chain(chars).collect())
        .unwrap_or_default()
}

/// The file's text: `HISTORY`, a state type and a `MODEL_F32`/`MODEL_F64` per precision.
pub(crate) fn file(plan: &Plan, precisions: &[Precision], provenance: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// The spincal corrector \"{}\", {provenance}, for the `spincal-embedded` crate\n\
         // (no_std, no allocation). Generated: edit the model, not this file.\n\
         //\n\
         //     let mut state = StateF32::new();\n\
         //     let out = MODEL_F32.correct(&mut state, accel_mps2, gyro);\n",
        plan.kind
    );
    if plan.covariance.is_some() {
        let _ = writeln!(
            s,
            "// The model carries its parameters' covariance: `MODEL_F32.predicted_error(accel_mps2)`\n\
             // gives each sample's error bar and flag as `spincal correct` does (`<column>_corrected_sd`,\n\
             // `predicted_better`).\n"
        );
    } else if let Some(why) = plan.no_error_bar() {
        let _ = writeln!(
            s,
            "// No error bar (`covariance: None`, `predicted_error` gives None): {};\n\
             // `spincal correct` writes none for it either.\n",
            super::wrap_words(why, "\n// ")
        );
    }
    let _ = writeln!(
        s,
        "/// Values of a stream's delay history (the network's inputs; 0 without a network).\npub const HISTORY: usize = {};\n",
        plan.history()
    );
    for &x in precisions {
        let (t, upper) = match x {
            Precision::Float => ("f32", "F32"),
            Precision::Double => ("f64", "F64"),
        };
        let _ = writeln!(
            s,
            "/// One stream's state in {t}.\npub type State{upper} = spincal_embedded::State<{t}, HISTORY>;\n"
        );
        if let Some(c) = &plan.covariance {
            let order = match plan.accel {
                AccelPlan::Linear(_) => "the linear map's parameter covariance in {t} (the offsets, then\n\
                                         /// the matrix row by row: `spincal_embedded::Linear::predicted_error`'s order)",
                _ => "the physical model's parameter covariance in {t} (bias, scale error, misalignment,\n\
                      /// quadratic: `spincal_embedded::PARAMS` order)",
            };
            let _ = writeln!(
                s,
                "/// {}.\n#[rustfmt::skip]\npub static COVARIANCE_{upper}: spincal_embedded::Covariance<{t}> = {};\n",
                capitalised(&order.replace("{t}", t)),
                covariance(c, x)
            );
        }
        let _ = writeln!(
            s,
            "/// The corrector in {t}.\n#[rustfmt::skip]\npub static MODEL_{upper}: spincal_embedded::Model<'static, {t}> = {};\n",
            model(plan, x)
        );
    }
    s
}
