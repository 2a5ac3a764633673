//! The standard system-identification protocol on the shipped benchmark files, read as shipped
//! (../shared/data/sysid, skipped when absent): the estimation/test division of
//! ../shared/data/README.md, the model simulated on the test input from the first n measured
//! outputs, RMSE on the rest. One quick model per benchmark, and on WH2009 the NARX and HW of
//! BENCHMARKS.md against ARX [6 8 1] (about 10 s and 3 s of fitting in release); the full table is
//! in BENCHMARKS.md.
//!
//! The bound each test asserts is stated against the data, not a number copied from a run: the
//! simulation's RMSE must stay below a share of the test output's standard deviation (a share of
//! 0.5 is MATLAB's fit above 50 %) and below the same share of the RMSE of the best constant (the
//! training output's mean). The share is 0.5 where a linear model is known to explain most of the
//! output (Silverbox, WH2009) and 0.6 for the tanks, whose overflow a low-order model misses.

use crate::common;

use spincal::input::formats::read_table;
use spincal::input::table::{read_file, Table, TableOptions};
use spincal::metrics::rmse;
use spincal::sysid::{fit_and_score_parts, DataPart, ModelKind, ModelSpec, NarxFocus, ScoredFit};

fn table(relative: &str, keys: &[&str]) -> Option<Table> {
    let path = common::shared_data(relative)?;
    let file = path.display().to_string();
    let bytes = read_file(&path).unwrap();
    Some(read_table(&bytes, &file, &TableOptions::default(), keys).unwrap_or_else(|e| panic!("{e}")))
}

fn std_dev(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Fits on the training part, scores the simulation on the test part, and checks the bound.
fn protocol(
    name: &str,
    spec: &ModelSpec,
    train: DataPart,
    test: DataPart,
    init: usize,
    share: f64,
) -> ScoredFit {
    let y_test = &test.y[test.range.clone()][init..];
    let y_train = &train.y[train.range.clone()];
    let scored = fit_and_score_parts(spec, train.clone(), Some(test.clone()), init, &|_| {}).unwrap();
    let sim = scored.test.as_ref().unwrap().simulation.rmse;
    let spread = std_dev(y_test);
    let mean = y_train.iter().sum::<f64>() / y_train.len() as f64;
    let constant = rmse(y_test, &vec![mean; y_test.len()]);
    eprintln!(
        "{name}: {} test simulation RMSE {sim:.4e} (test output std {spread:.4e}, training-mean constant {constant:.4e})",
        scored.structure
    );
    assert!(sim.is_finite());
    assert!(
        sim < share * spread,
        "{name}: RMSE {sim} not below {share} × the test output's std {spread}"
    );
    assert!(
        sim < share * constant,
        "{name}: RMSE {sim} not below {share} × {constant}, a constant's"
    );
    scored
}

#[test]
fn silverbox_arx_on_the_arrow() {
    let Some(t) = table("sysid/Silverbox_SNLS80mV.mat", &["V1", "V2"]) else {
        return;
    };
    let u = [&t.columns[0][..]];
    let y = &t.columns[1];
    let spec = ModelSpec::new(ModelKind::Arx, &[6, 8, 1]).unwrap();
    protocol(
        "Silverbox",
        &spec,
        DataPart {
            u: &u,
            y,
            range: 40_650..127_400,
        },
        DataPart {
            u: &u,
            y,
            range: 0..40_575,
        },
        50,
        0.5,
    );
}

#[test]
fn wiener_hammerstein_2009_oe() {
    let Some(t) = table("sysid/WienerHammerBenchmark.csv", &["uBenchMark", "yBenchMark"]) else {
        return;
    };
    let u = [&t.columns[0][..]];
    let y = &t.columns[1];
    let spec = ModelSpec {
        max_iterations: 30,
        ..ModelSpec::new(ModelKind::Oe, &[4, 4, 1]).unwrap()
    };
    protocol(
        "WH2009",
        &spec,
        DataPart {
            u: &u,
            y,
            range: 5_200..105_200,
        },
        DataPart {
            u: &u,
            y,
            range: 105_200..184_000,
        },
        50,
        0.5,
    );
}

#[test]
fn cascaded_tanks_separate_test_record() {
    let Some(t) = table(
        "sysid/CascadedTanks_dataBenchmark.mat",
        &["uEst", "yEst", "uVal", "yVal"],
    ) else {
        return;
    };
    let (u, u_val) = ([&t.columns[0][..]], [&t.columns[2][..]]);
    let spec = ModelSpec {
        max_iterations: 300,
        ..ModelSpec::new(ModelKind::Hw, &[3, 3, 1]).unwrap()
    };
    protocol(
        "Cascaded tanks",
        &spec,
        DataPart {
            u: &u,
            y: &t.columns[1],
            range: 0..1024,
        },
        DataPart {
            u: &u_val,
            y: &t.columns[3],
            range: 0..1024,
        },
        5,
        0.6,
    );
}

/// Issue 31, item 8: on WH2009, a nonlinear model with the orders stated in BENCHMARKS.md beats
/// the linear ARX [6 8 1] (fitted here, same protocol) in simulation on the test part, and stays
/// within `bound` where given (its test simulation RMSE as measured here, with a stated margin).
fn wiener_hammerstein_2009_beats_arx(spec: &ModelSpec, bound: Option<f64>) {
    let Some(t) = table("sysid/WienerHammerBenchmark.csv", &["uBenchMark", "yBenchMark"]) else {
        return;
    };
    let u = [&t.columns[0][..]];
    let y = &t.columns[1];
    let train = DataPart {
        u: &u,
        y,
        range: 5_200..105_200,
    };
    let test = DataPart {
        u: &u,
        y,
        range: 105_200..184_000,
    };
    let arx = ModelSpec::new(ModelKind::Arx, &[6, 8, 1]).unwrap();
    let arx = fit_and_score_parts(&arx, train.clone(), Some(test.clone()), 50, &|_| {}).unwrap();
    let arx = arx.test.unwrap().simulation.rmse;
    let scored = protocol("WH2009", spec, train, test, 50, 0.5);
    let sim = scored.test.unwrap().simulation.rmse;
    eprintln!("WH2009: ARX [6 8 1] test simulation RMSE {arx:.4e}");
    assert!(
        sim < 0.5 * arx,
        "{}: RMSE {sim} not below half of ARX [6 8 1]'s {arx}",
        scored.structure
    );
    if let Some(bound) = bound {
        assert!(
            sim < bound,
            "{}: RMSE {sim} above {bound}, the measured value with its margin",
            scored.structure
        );
    }
}

#[test]
fn wiener_hammerstein_2009_narx_beats_arx() {
    wiener_hammerstein_2009_beats_arx(
        &ModelSpec {
            max_iterations: 30,
            focus: NarxFocus::Prediction,
            ..ModelSpec::new(ModelKind::Narx, &[6, 8, 1]).unwrap()
        },
        Some(1.3 * NARX_RMSE_MEASURED),
    );
}

/// WH2009's NARX [6 8 1] (30 iterations, prediction focus) test simulation RMSE as this test
/// measured it (2026-11-29, release, Xeon): 8.7976e-3. Half of ARX [6 8 1]'s 5.8041e-2 (the
/// claim above) would let it grow 3.3-fold unnoticed; the bound is 1.3 × this.
const NARX_RMSE_MEASURED: f64 = 8.7976e-3;

#[test]
fn wiener_hammerstein_2009_hw_beats_arx() {
    // Half of ARX's RMSE is already within 1.3× of HW's (22.08 mV measured, BENCHMARKS.md).
    wiener_hammerstein_2009_beats_arx(&ModelSpec::new(ModelKind::Hw, &[4, 4, 1]).unwrap(), None);
}
