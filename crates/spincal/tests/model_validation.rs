//! Saved correctors are checked against their own structure on load: a damaged file of every kind
//! is refused with an error that names the file and the field, never a panic, and a file that
//! loads can be applied without panicking.

use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::common::synthetic::turntable_pair;
use serde_json::{json, Value};
use spincal::correctors::ann::{AnnError, AnnProblem, LmSettings, MAX_DELAYS};
use spincal::correctors::corrector::{Axis, Corrector};
use spincal::correctors::division::DivisionMode;
use spincal::correctors::linear::LinearModel;
use spincal::correctors::model_file::CorrectorError;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::correctors::static_cal::{StaticCalibration, StaticModel};
use spincal::input::recording::Recording;

/// Written in place of a string marker: JSON that parses as a number, but no finite f64.
const INFINITE: &str = "1e999";
const INFINITE_MARKER: &str = "\"__infinite__\"";

struct Models {
    /// Axes x, y; 2 delays; hidden 4, 3: the layout 6-4-3-2.
    ann: CorrectorFile,
    /// Axes x, y; no delays, no hidden layer: the layout 2-2.
    ann_plain: CorrectorFile,
    /// Axes x, y, z.
    linear: CorrectorFile,
    /// The 12-parameter model.
    static_nonlinear: CorrectorFile,
    /// The 6-parameter model.
    static_bias_scale: CorrectorFile,
    measured: Recording,
}

fn models() -> Models {
    let (measured, reference) = turntable_pair(400, 3);
    let xy = [Axis::X, Axis::Y];
    let settings = LmSettings {
        max_epochs: 8,
        ..LmSettings::default()
    };
    let train = |delays: usize, hidden: &[usize]| {
        let problem = AnnProblem::new(&measured, &reference, &xy, delays, DivisionMode::Contiguous).unwrap();
        let model = problem.train(hidden, 1, 4, &settings).unwrap();
        CorrectorFile::new(CorrectorModel::Ann(Box::new(model)))
    };
    let linear = LinearModel::fit(&measured, &reference, &Axis::ALL, DivisionMode::Contiguous).unwrap();
    let static_nonlinear = StaticCalibration {
        model: StaticModel::Nonlinear,
        bias: [0.1, -0.05, 0.02],
        scale: [1.01, 0.99, 1.002],
        misalignment: [0.01, -0.02, 0.015],
        nonlinearity: [0.001, -0.0005, 0.0008],
        gravity_mps2: 9.81,
        input_unit: "m/s^2".into(),
    };
    let static_bias_scale = StaticCalibration {
        model: StaticModel::BiasScale,
        misalignment: [0.0; 3],
        nonlinearity: [0.0; 3],
        ..static_nonlinear.clone()
    };
    Models {
        ann: train(2, &[4, 3]),
        ann_plain: train(0, &[]),
        linear: CorrectorFile::new(CorrectorModel::Linear(Box::new(linear))),
        static_nonlinear: CorrectorFile::new(CorrectorModel::Static(Box::new(static_nonlinear))),
        static_bias_scale: CorrectorFile::new(CorrectorModel::Static(Box::new(static_bias_scale))),
        measured,
    }
}

/// The file's JSON after `edit` (on its `corrector` object), with the marker turned into 1e999.
fn damaged(file: &CorrectorFile, edit: &dyn Fn(&mut Value)) -> String {
    let mut value = serde_json::to_value(file).unwrap();
    edit(&mut value["corrector"]);
    serde_json::to_string_pretty(&value)
        .unwrap()
        .replace(INFINITE_MARKER, INFINITE)
}

/// Reads `text` as `bad.json`, catching a panic: the outcome, or the panic's message.
fn load(text: &str) -> Result<Result<CorrectorFile, CorrectorError>, String> {
    catch_unwind(|| CorrectorFile::from_json(text, "bad.json")).map_err(|panic| {
        panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    })
}

fn pop(v: &mut Value) {
    v.as_array_mut().unwrap().pop();
}

type Edit = Box<dyn Fn(&mut Value)>;

fn edit(f: impl Fn(&mut Value) + 'static) -> Edit {
    Box::new(f)
}

/// (what, file, edit, field the error must name, words its reason must hold).
fn cases(m: &Models) -> Vec<(&'static str, &CorrectorFile, Edit, &'static str, &'static str)> {
    vec![
        // The five that used to panic in `spincal correct`, and the one that wrote wrong numbers.
        (
            "weights shorter than the layout needs",
            &m.ann,
            edit(|c| {
                pop(&mut c["network"]["weights"]);
                pop(&mut c["network"]["weights"]);
            }),
            "corrector.network.weights",
            "49 values, but the layout 6-4-3-2 needs 51",
        ),
        (
            "more axes than network inputs",
            &m.ann,
            edit(|c| c["axes"] = json!(["x", "y", "z"])),
            "corrector.network.inputs",
            "6 inputs, but axes × (delays + 1) = 3 × (2 + 1) = 9",
        ),
        (
            "delays changed",
            &m.ann,
            edit(|c| c["delays"] = json!(3)),
            "corrector.network.inputs",
            "6 inputs, but axes × (delays + 1) = 2 × (3 + 1) = 8",
        ),
        (
            "inputs changed",
            &m.ann,
            edit(|c| c["network"]["inputs"] = json!(7)),
            "corrector.network.inputs",
            "7 inputs, but axes × (delays + 1) = 2 × (2 + 1) = 6",
        ),
        (
            "delays 10^12",
            &m.ann,
            edit(|c| c["delays"] = json!(1_000_000_000_000u64)),
            "corrector.delays",
            "above the limit of 1000",
        ),
        (
            "one axis for a two-input network",
            &m.ann_plain,
            edit(|c| c["axes"] = json!(["x"])),
            "corrector.network.inputs",
            "2 inputs, but axes × (delays + 1) = 1 × (0 + 1) = 1",
        ),
        // Delays.
        (
            "negative delays",
            &m.ann,
            edit(|c| c["delays"] = json!(-1)),
            "corrector.delays",
            "-1",
        ),
        (
            "delays beyond 64 bits",
            &m.ann,
            edit(|c| c["delays"] = json!(1e20)),
            "corrector.delays",
            "1e+20",
        ),
        (
            "fractional delays",
            &m.ann,
            edit(|c| c["delays"] = json!(1.5)),
            "corrector.delays",
            "1.5",
        ),
        // Layers.
        (
            "outputs changed",
            &m.ann,
            edit(|c| c["network"]["outputs"] = json!(3)),
            "corrector.network.outputs",
            "one output per axis",
        ),
        (
            "an empty hidden layer",
            &m.ann,
            edit(|c| c["network"]["hidden"][1] = json!(0)),
            "corrector.network.hidden[1]",
            "0 units",
        ),
        (
            "too many hidden layers",
            &m.ann,
            edit(|c| c["network"]["hidden"] = json!([4, 3, 2, 2])),
            "corrector.network.hidden",
            "at most 3",
        ),
        (
            "hidden sizes changed",
            &m.ann,
            edit(|c| c["network"]["hidden"] = json!([4, 4])),
            "corrector.network.weights",
            "the layout 6-4-4-2 needs 58",
        ),
        (
            "a hidden layer beyond counting",
            &m.ann,
            edit(|c| c["network"]["hidden"] = json!([u64::MAX, 3])),
            "corrector.network.hidden",
            "too large",
        ),
        (
            "weights missing",
            &m.ann,
            edit(|c| {
                c["network"].as_object_mut().unwrap().remove("weights");
            }),
            "corrector.network",
            "missing field `weights`",
        ),
        // Numbers.
        (
            "a NaN weight (serde_json writes NaN as null)",
            &m.ann,
            edit(|c| c["network"]["weights"][5] = Value::Null),
            "corrector.network.weights[5]",
            "null",
        ),
        (
            "an infinite weight",
            &m.ann,
            edit(|c| c["network"]["weights"][5] = json!("__infinite__")),
            "corrector.network.weights[5]",
            "number out of range",
        ),
        (
            "a weight that is text",
            &m.ann,
            edit(|c| c["network"]["weights"][50] = json!("0.5")),
            "corrector.network.weights[50]",
            "string",
        ),
        // Scaling.
        (
            "input scaling too short",
            &m.ann,
            edit(|c| pop(&mut c["input_scaling"]["min"])),
            "corrector.input_scaling.min",
            "1 value, but 2 axes need 2",
        ),
        (
            "output scaling too long",
            &m.ann,
            edit(|c| {
                c["output_scaling"]["max"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!(1.0))
            }),
            "corrector.output_scaling.max",
            "3 values, but 2 axes need 2",
        ),
        (
            "scaling min above max",
            &m.ann,
            edit(|c| {
                let hi = c["input_scaling"]["max"][1].as_f64().unwrap();
                c["input_scaling"]["min"][1] = json!(hi + 1.0);
            }),
            "corrector.input_scaling.min[1]",
            "above max[1]",
        ),
        (
            "infinite scaling",
            &m.ann,
            edit(|c| c["output_scaling"]["min"][0] = json!("__infinite__")),
            "corrector.output_scaling.min[0]",
            "number out of range",
        ),
        (
            "scaling wider than a float",
            &m.ann,
            edit(|c| {
                c["input_scaling"]["min"][0] = json!(-1e308);
                c["input_scaling"]["max"][0] = json!(1e308);
            }),
            "corrector.input_scaling.max[0]",
            "wider",
        ),
        // Axes.
        (
            "a duplicated axis",
            &m.ann,
            edit(|c| c["axes"] = json!(["y", "y"])),
            "corrector.axes[1]",
            "twice",
        ),
        (
            "an unknown axis",
            &m.ann,
            edit(|c| c["axes"] = json!(["x", "w"])),
            "corrector.axes[1]",
            "`w`",
        ),
        (
            "no axes",
            &m.ann,
            edit(|c| c["axes"] = json!([])),
            "corrector.axes",
            "no axes",
        ),
        // The training summary.
        (
            "kept epoch beyond the report",
            &m.ann,
            edit(|c| c["training"]["report"]["best_epoch"] = json!(1_000_000)),
            "corrector.training.report.best_epoch",
            "1000000",
        ),
        (
            "kept restart beyond the restarts",
            &m.ann,
            edit(|c| c["training"]["best_restart"] = json!(1)),
            "corrector.training.best_restart",
            "1 restarts",
        ),
        (
            "a fit missing",
            &m.ann,
            edit(|c| pop(&mut c["training"]["fits"]["test"])),
            "corrector.training.fits.test",
            "2 axes",
        ),
        (
            "a division range beyond the samples",
            &m.ann,
            edit(|c| c["training"]["division"]["train"][0]["end"] = json!(100_000)),
            "corrector.training.division.train[0]",
            "n_samples",
        ),
        (
            "a division that ignores the delays",
            &m.ann,
            edit(|c| c["training"]["division"]["first_sample"] = json!(0)),
            "corrector.training.division.first_sample",
            "delays",
        ),
        // Linear.
        (
            "a matrix row missing",
            &m.linear,
            edit(|c| pop(&mut c["matrix"])),
            "corrector.matrix",
            "2 rows, but 3 axes need a 3 × 3 matrix",
        ),
        (
            "a matrix row too short",
            &m.linear,
            edit(|c| pop(&mut c["matrix"][1])),
            "corrector.matrix[1]",
            "2 values, but 3 axes need 3",
        ),
        (
            "a matrix that is not a matrix",
            &m.linear,
            edit(|c| c["matrix"] = json!([1.0, 2.0, 3.0])),
            "corrector.matrix[0]",
            "floating point",
        ),
        (
            "a NaN in the matrix",
            &m.linear,
            edit(|c| c["matrix"][2][0] = Value::Null),
            "corrector.matrix[2][0]",
            "null",
        ),
        (
            "an infinite offset",
            &m.linear,
            edit(|c| c["offset_mps2"][1] = json!("__infinite__")),
            "corrector.offset_mps2[1]",
            "number out of range",
        ),
        (
            "an offset missing",
            &m.linear,
            edit(|c| pop(&mut c["offset_mps2"])),
            "corrector.offset_mps2",
            "2 values, but 3 axes need 3",
        ),
        (
            "fewer axes than the matrix",
            &m.linear,
            edit(|c| c["axes"] = json!(["x", "y"])),
            "corrector.offset_mps2",
            "3 values, but 2 axes need 2",
        ),
        (
            "a duplicated linear axis",
            &m.linear,
            edit(|c| c["axes"] = json!(["x", "y", "x"])),
            "corrector.axes[2]",
            "twice",
        ),
        (
            "a linear fit missing",
            &m.linear,
            edit(|c| pop(&mut c["training"]["uncorrected"]["validation"])),
            "corrector.training.uncorrected.validation",
            "3 axes",
        ),
        // Static.
        (
            "an infinite bias",
            &m.static_nonlinear,
            edit(|c| c["bias"][1] = json!("__infinite__")),
            "corrector.bias[1]",
            "number out of range",
        ),
        (
            "a NaN scale",
            &m.static_nonlinear,
            edit(|c| c["scale"][0] = Value::Null),
            "corrector.scale[0]",
            "null",
        ),
        (
            "a zero scale",
            &m.static_nonlinear,
            edit(|c| c["scale"][2] = json!(0.0)),
            "corrector.scale[2]",
            "0",
        ),
        (
            "negative gravity",
            &m.static_nonlinear,
            edit(|c| c["gravity_mps2"] = json!(-9.81)),
            "corrector.gravity_mps2",
            "positive",
        ),
        (
            "a bias of two axes",
            &m.static_nonlinear,
            edit(|c| pop(&mut c["bias"])),
            "corrector.bias",
            "length 2",
        ),
        (
            "an unknown static model",
            &m.static_nonlinear,
            edit(|c| c["model"] = json!("quartic")),
            "corrector.model",
            "quartic",
        ),
        (
            "misalignment the model does not estimate",
            &m.static_bias_scale,
            edit(|c| c["misalignment"][1] = json!(0.01)),
            "corrector.misalignment[1]",
            "bias_scale estimates no misalignment",
        ),
        (
            "nonlinearity the model does not estimate",
            &m.static_bias_scale,
            edit(|c| c["nonlinearity"][0] = json!(0.001)),
            "corrector.nonlinearity[0]",
            "must be 0",
        ),
        // Every kind.
        (
            "an unknown kind",
            &m.linear,
            edit(|c| c["kind"] = json!("quadratic")),
            "corrector.kind",
            "unknown variant `quadratic`",
        ),
    ]
}

#[test]
fn every_damaged_file_is_refused_by_field_without_a_panic() {
    let m = models();
    let mut failures = Vec::new();
    for (what, file, edit, field, words) in cases(&m) {
        let text = damaged(file, &*edit);
        match load(&text) {
            Err(panic) => failures.push(format!("{what}: panicked: {panic}")),
            Ok(Ok(_)) => failures.push(format!("{what}: loaded")),
            Ok(Err(e)) => {
                let message = e.to_string();
                let named = matches!(&e, CorrectorError::Invalid { file, field: f, reason }
                    if file == "bad.json" && f == field && reason.contains(words));
                if !named || !message.starts_with("bad.json: ") {
                    failures.push(format!("{what}: expected {field} ({words}), got {message}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn undamaged_files_load_and_correct_identically() {
    let m = models();
    for file in [
        &m.ann,
        &m.ann_plain,
        &m.linear,
        &m.static_nonlinear,
        &m.static_bias_scale,
    ] {
        file.validate().unwrap();
        let back = CorrectorFile::from_json(&file.to_json(), "model.json").unwrap();
        assert!(back == *file, "{} round trip is not exact", file.corrector.kind());
        assert!(back.corrector.correct(&m.measured) == file.corrector.correct(&m.measured));
        // The damage edits leave a file alone when they change nothing.
        let same = damaged(file, &|_| {});
        assert!(CorrectorFile::from_json(&same, "model.json").unwrap() == *file);
    }
}

/// Every numeric leaf of a value, as a list of steps (key or index).
fn leaves(value: &Value, path: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match value {
        Value::Number(_) => out.push(path.clone()),
        Value::Array(items) => {
            out.push(path.clone()); // arrays are damaged by length too
            for (i, item) in items.iter().enumerate() {
                path.push(json!(i));
                leaves(item, path, out);
                path.pop();
            }
        }
        Value::Object(map) => {
            for (key, item) in map {
                path.push(json!(key));
                leaves(item, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn at<'a>(value: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(value, |v, step| match step {
        Value::String(key) => &mut v[key.as_str()],
        _ => &mut v[step.as_u64().unwrap() as usize],
    })
}

/// Every number of every kind set to awkward values, every array shortened, lengthened and
/// emptied: each file is refused by field or loads and corrects a recording, never panics.
#[test]
fn no_single_edit_makes_loading_or_correcting_panic() {
    let m = models();
    let numbers = [
        json!(0),
        json!(-1),
        json!(2),
        json!(1_000_000_000_000u64),
        json!(u64::MAX),
        json!(0.5),
        json!(-1e300),
        json!(1e300),
        json!("__infinite__"),
    ];
    let mut short = m.measured.clone();
    for axis in &mut short.accel_mps2 {
        axis.truncate(50);
    }
    short.time_s.truncate(50);
    let (mut loaded, mut refused) = (0, 0);
    let mut failures = Vec::new();
    for file in [
        &m.ann,
        &m.ann_plain,
        &m.linear,
        &m.static_nonlinear,
        &m.static_bias_scale,
    ] {
        let corrector = serde_json::to_value(&file.corrector).unwrap();
        let mut paths = Vec::new();
        leaves(&corrector, &mut Vec::new(), &mut paths);
        for path in &paths {
            let edits: Vec<Edit> = if at(&mut corrector.clone(), path).is_array() {
                let (p1, p2, p3) = (path.clone(), path.clone(), path.clone());
                vec![
                    edit(move |c| pop(at(c, &p1))),
                    edit(move |c| {
                        let items = at(c, &p2).as_array_mut().unwrap();
                        let copy = items.last().cloned().unwrap_or(json!(1.0));
                        items.push(copy);
                    }),
                    edit(move |c| *at(c, &p3) = json!([])),
                ]
            } else {
                numbers
                    .iter()
                    .map(|n| {
                        let (p, n) = (path.clone(), n.clone());
                        edit(move |c| *at(c, &p) = n.clone())
                    })
                    .collect()
            };
            for (k, e) in edits.iter().enumerate() {
                let text = damaged(file, &**e);
                let what = format!("{} {path:?} edit {k}", file.corrector.kind());
                match load(&text) {
                    Err(panic) => failures.push(format!("{what}: loading panicked: {panic}")),
                    Ok(Err(CorrectorError::Invalid { field, .. })) => {
                        refused += 1;
                        if !field.starts_with("corrector") {
                            failures.push(format!("{what}: refused by {field}"));
                        }
                    }
                    Ok(Err(other)) => failures.push(format!("{what}: refused without a field: {other}")),
                    Ok(Ok(back)) => {
                        loaded += 1;
                        let applied = catch_unwind(AssertUnwindSafe(|| {
                            let mut stream = back.corrector.stream();
                            for i in 0..short.len() {
                                let a = &short.accel_mps2;
                                stream.correct_sample([a[0][i], a[1][i], a[2][i]]);
                            }
                            back.corrector.correct(&short)
                        }));
                        if applied.is_err() {
                            failures.push(format!("{what}: loaded, then correcting panicked"));
                        }
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    eprintln!("{loaded} edited files loaded and corrected, {refused} refused by field");
    // Both outcomes happen: harmless edits (a training MSE, a weight's value) still load.
    assert!(
        loaded > 100 && refused > 100,
        "{loaded} loaded, {refused} refused"
    );
}

#[test]
fn training_refuses_more_delays_than_a_file_may_hold() {
    let (measured, reference) = turntable_pair(1200, 3);
    let err = AnnProblem::new(
        &measured,
        &reference,
        &[Axis::X],
        MAX_DELAYS + 1,
        DivisionMode::Contiguous,
    )
    .unwrap_err();
    assert!(
        matches!(err, AnnError::TooManyDelays(d) if d == MAX_DELAYS + 1),
        "{err}"
    );
}
