//! `spincal correct` with damaged model files: each is refused before anything is written, with
//! exit code 1 and an error naming the field; no output file appears, and neither the model nor
//! the input is touched.

use crate::common::write_pair;
use std::path::Path;

use assert_cmd::Command;
use serde_json::{json, Value};
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::correctors::static_cal::{StaticCalibration, StaticModel};

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// The saved model at `path` as JSON.
fn model_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn pop(v: &mut Value) {
    v.as_array_mut().unwrap().pop();
}

type Edit = Box<dyn Fn(&mut Value)>;

fn edit(f: impl Fn(&mut Value) + 'static) -> Edit {
    Box::new(f)
}

#[test]
fn damaged_models_are_refused_by_field_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (m, r) = write_pair(dir.path(), 300);
    let train = |extra: &[&str], name: &str| -> Value {
        let path = dir.path().join(name);
        let out = spincal()
            .args(["train", "--data", &m, "--reference", &r])
            .args(extra)
            .arg("-o")
            .arg(&path)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        model_json(&path)
    };
    // Layout 4-3-2 (axes x, y with one delay), and 2-2 (no delays, no hidden layer).
    let ann = train(
        &[
            "--hidden",
            "3",
            "--delays",
            "1",
            "--restarts",
            "1",
            "--max-epochs",
            "10",
        ],
        "ann.json",
    );
    let ann_plain = train(
        &["--hidden", "none", "--restarts", "1", "--max-epochs", "10"],
        "plain.json",
    );
    let linear = train(&["--kind", "linear"], "linear.json");
    let calibration = StaticCalibration {
        model: StaticModel::Misalignment,
        misalignment: [0.01, -0.02, 0.015],
        ..StaticCalibration::identity(9.81)
    };
    let static_cal =
        serde_json::to_value(CorrectorFile::new(CorrectorModel::Static(Box::new(calibration)))).unwrap();

    let input = Path::new(&m);
    let out_path = dir.path().join("out.csv");
    // The undamaged models correct the input.
    for (name, model) in [
        ("ann", &ann),
        ("plain", &ann_plain),
        ("linear", &linear),
        ("static", &static_cal),
    ] {
        let path = dir.path().join(format!("good-{name}.json"));
        std::fs::write(&path, serde_json::to_string_pretty(model).unwrap()).unwrap();
        let out = spincal()
            .args(["correct", "--model"])
            .arg(&path)
            .arg(input)
            .arg("-o")
            .arg(&out_path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(std::fs::read_to_string(&out_path).unwrap().lines().count(), 301);
        std::fs::remove_file(&out_path).unwrap();
    }

    let cases: Vec<(&str, &Value, Edit, &str)> = vec![
        // The five that used to panic, and the one that wrote wrong numbers.
        (
            "weights short",
            &ann,
            edit(|c| pop(&mut c["network"]["weights"])),
            "corrector.network.weights: 22 values, but the layout 4-3-2 needs 23",
        ),
        (
            "more axes than inputs",
            &ann,
            edit(|c| c["axes"] = json!(["x", "y", "z"])),
            "corrector.network.inputs: 4 inputs, but axes × (delays + 1) = 3 × (1 + 1) = 6",
        ),
        (
            "delays changed",
            &ann,
            edit(|c| c["delays"] = json!(2)),
            "corrector.network.inputs",
        ),
        (
            "inputs changed",
            &ann,
            edit(|c| c["network"]["inputs"] = json!(5)),
            "corrector.network.inputs",
        ),
        (
            "delays 10^12",
            &ann,
            edit(|c| c["delays"] = json!(1_000_000_000_000u64)),
            "corrector.delays: 1000000000000 is above the limit of 1000",
        ),
        (
            "one axis, two inputs",
            &ann_plain,
            edit(|c| c["axes"] = json!(["x"])),
            "corrector.network.inputs",
        ),
        // More damage.
        (
            "NaN weight",
            &ann,
            edit(|c| c["network"]["weights"][3] = Value::Null),
            "corrector.network.weights[3]: invalid type: null",
        ),
        (
            "infinite weight",
            &ann,
            edit(|c| c["network"]["weights"][3] = json!("__infinite__")),
            "corrector.network.weights[3]: number out of range",
        ),
        (
            "negative delays",
            &ann,
            edit(|c| c["delays"] = json!(-1)),
            "corrector.delays",
        ),
        (
            "empty hidden layer",
            &ann,
            edit(|c| c["network"]["hidden"][0] = json!(0)),
            "corrector.network.hidden[0]",
        ),
        (
            "scaling too short",
            &ann,
            edit(|c| pop(&mut c["output_scaling"]["min"])),
            "corrector.output_scaling.min",
        ),
        (
            "duplicated axes",
            &ann,
            edit(|c| c["axes"] = json!(["x", "x"])),
            "corrector.axes[1]",
        ),
        (
            "matrix row missing",
            &linear,
            edit(|c| pop(&mut c["matrix"])),
            "corrector.matrix",
        ),
        (
            "matrix row short",
            &linear,
            edit(|c| pop(&mut c["matrix"][0])),
            "corrector.matrix[0]",
        ),
        (
            "linear axes duplicated",
            &linear,
            edit(|c| c["axes"] = json!(["y", "y"])),
            "corrector.axes[1]",
        ),
        (
            "infinite bias",
            &static_cal,
            edit(|c| c["bias"][2] = json!("__infinite__")),
            "corrector.bias[2]",
        ),
        (
            "zero gravity",
            &static_cal,
            edit(|c| c["gravity_mps2"] = json!(0.0)),
            "corrector.gravity_mps2",
        ),
        (
            "nonlinearity not estimated",
            &static_cal,
            edit(|c| c["nonlinearity"][1] = json!(0.5)),
            "corrector.nonlinearity[1]",
        ),
    ];
    let bad = dir.path().join("bad.json");
    let input_before = std::fs::read(input).unwrap();
    let mut failures = Vec::new();
    for (what, model, edit, expected) in cases {
        let mut value = model.clone();
        edit(&mut value["corrector"]);
        let text = serde_json::to_string_pretty(&value)
            .unwrap()
            .replace("\"__infinite__\"", "1e999");
        std::fs::write(&bad, &text).unwrap();
        let out = spincal()
            .args(["correct", "--model"])
            .arg(&bad)
            .arg(input)
            .arg("-o")
            .arg(&out_path)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        if out.status.code() != Some(1) {
            failures.push(format!("{what}: exit {:?}: {stderr}", out.status.code()));
        }
        if !(stderr.contains("bad.json: invalid corrector file: ") && stderr.contains(expected)) {
            failures.push(format!("{what}: expected {expected}, got {stderr}"));
        }
        if out_path.exists() {
            failures.push(format!("{what}: out.csv was created"));
            std::fs::remove_file(&out_path).unwrap();
        }
        if std::fs::read(&bad).unwrap() != text.as_bytes() {
            failures.push(format!("{what}: the model file changed"));
        }
        if std::fs::read(input).unwrap() != input_before {
            failures.push(format!("{what}: the input changed"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
