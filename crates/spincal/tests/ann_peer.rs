//! Peer check: spincal's LM against pyrenn's `train_LM` on the same data from the same initial
//! weights (fixture written by bench/ann/run.sh). Both use trainlm's μ rules (0.001, ×0.1 / ×10)
//! and unnormalised JᵀJ; after the same number of epochs our training MSE must be no worse than
//! pyrenn's by more than 1 %.

use serde::Deserialize;
use spincal::correctors::ann::{Dataset, Layout, LmSettings, LmWorkspace};

#[derive(Deserialize)]
struct Fixture {
    epochs: usize,
    mu_initial: f64,
    sizes: Vec<usize>,
    initial_weights: Vec<f64>,
    inputs: Vec<f64>,
    targets: Vec<f64>,
    pyrenn_initial_mse: f64,
    pyrenn_final_mse: f64,
}

#[test]
fn training_mse_matches_or_beats_pyrenn_from_the_same_start() {
    // SPINCAL_PYRENN_PEER: a fresh peer run to check instead (bench/ann/run.sh sets it, so the
    // bench never rewrites the tracked fixture).
    let tracked = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/ann/pyrenn_peer.json");
    let path = std::env::var("SPINCAL_PYRENN_PEER").unwrap_or_else(|_| tracked.to_string());
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!("{path}: {e} (bench/ann/run.sh makes it; ANN_BENCH_UPDATE_FIXTURE=1 copies it here)")
    });
    let fixture: Fixture = serde_json::from_str(&text).expect("fixture parses");
    let sizes = &fixture.sizes;
    let layout = Layout::new(sizes[0], &sizes[1..sizes.len() - 1], sizes[sizes.len() - 1]);
    let train = Dataset {
        n_inputs: layout.inputs(),
        n_outputs: layout.outputs(),
        inputs: fixture.inputs,
        targets: fixture.targets,
    };
    let mut weights = fixture.initial_weights;
    let mut workspace = LmWorkspace::new(&layout, 256);
    let initial = workspace.mse(&weights, &train);
    assert!(
        (initial - fixture.pyrenn_initial_mse).abs() <= 1e-9 * initial,
        "same network, same start: {initial} vs pyrenn {}",
        fixture.pyrenn_initial_mse
    );
    let settings = LmSettings {
        max_epochs: fixture.epochs,
        mu_initial: fixture.mu_initial,
        min_relative_decrease: 0.0,
        min_gradient: 0.0,
        ..LmSettings::default()
    };
    let report = workspace.train(&mut weights, &train, &Dataset::default(), &settings);
    let ours = workspace.mse(&weights, &train);
    eprintln!(
        "after {} epochs: spincal MSE {ours:.6e}, pyrenn {:.6e} (ratio {:.4})",
        report.epochs,
        fixture.pyrenn_final_mse,
        ours / fixture.pyrenn_final_mse
    );
    assert_eq!(report.epochs, fixture.epochs, "{:?}", report.stop);
    assert!(
        ours <= fixture.pyrenn_final_mse * 1.01,
        "spincal {ours} vs pyrenn {}",
        fixture.pyrenn_final_mse
    );
}
