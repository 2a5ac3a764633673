#!/usr/bin/env bash
# LM epoch benchmark and pyrenn peer check for spincal's network trainer.
# Usage: bench/ann/run.sh            (from the repository root; writes bench/out/ann/)
# The peer check writes bench/out/ann/pyrenn_peer.json and runs the ann_peer test on it; nothing
# tracked is written unless ANN_BENCH_UPDATE_FIXTURE=1, which copies it over
# crates/spincal/tests/fixtures/ann/pyrenn_peer.json (the test's default input).
set -euo pipefail
cd "$(dirname "$0")/../.."
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
out=bench/out/ann
mkdir -p "$out"
# The venv is shared with the turntable bench: install what this bench needs when it is missing.
if ! bench/.venv/bin/python -c "import numpy, pyrenn" 2>/dev/null; then
    [ -x bench/.venv/bin/python ] || python3 -m venv bench/.venv
    bench/.venv/bin/pip install -q numpy pyrenn
fi
py=bench/.venv/bin/python
cargo build --release -p spincal --example ann_epoch
ex=target/release/examples/ann_epoch

echo "== machine"
lscpu | grep -E "Model name|^CPU\(s\)|Thread|MHz" || true

echo "== peer check: pyrenn vs spincal, same data and initial weights"
$ex export 1000 10,6 3 "$out/peer_export.json"
$py bench/ann/bench.py peer "$out/peer_export.json" 40 "$out/pyrenn_peer.json"
SPINCAL_PYRENN_PEER="$(pwd)/$out/pyrenn_peer.json" cargo test --release -p spincal --test ann_peer -- --nocapture
if [ "${ANN_BENCH_UPDATE_FIXTURE:-0}" = 1 ]; then
    cp "$out/pyrenn_peer.json" crates/spincal/tests/fixtures/ann/pyrenn_peer.json
fi

echo "== seconds per LM epoch, 2-input [10,6] 2-output network"
$ex dgemm > "$out/faer_dgemm.json"
$ex parts | tee "$out/parts.json"
$ex time 3000 30000 > "$out/spincal_epoch.json"
$ex export 3000 10,6 1 "$out/export_3000.json"
$ex export 30000 10,6 1 "$out/export_30000.json"
$py bench/ann/bench.py epoch "$out/spincal_epoch.json" "$out/faer_dgemm.json" \
    "$out/export_3000.json" "$out/export_30000.json" | tee "$out/epoch.txt"

if [ "${ANN_BENCH_SWEEP:-0}" = 1 ]; then
    echo "== sweep on a 10-minute 100 Hz recording (60,000 samples), subset of the default grid"
    mkdir -p "$out/sweep"
    $ex csv 60000 "$out/sweep/tt60k"
    cargo build --release -p spincal-cli
    (cd "$out/sweep" && /usr/bin/time -v ../../../../target/release/spincal --quiet sweep \
        --data tt60k-measured.csv --reference tt60k-reference.csv \
        --grid "2;8;15;4,3;10,6;15,10" --restarts 2 --threads 2 -o subset)
fi
